"""``minparam check``'s options."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class CheckOptions:
    """The options of ``minparam check``: ``recursive`` also searches the sub-folders of a folder."""

    recursive: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "recursive", bool(self.recursive))
