"""``minparam platform ik|fk|workspace``'s options (one record per subcommand).

Numbers are in the platform file's units (lengths, and angles in its angle unit); lists take the
command line's "x,y,z" text or a sequence.  Checks that need the file (how many legs, a truss or a
platform) are made where it is read (``api.platform``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from minparam_cli.api.common import OptionError, choice_option, float_option
from minparam_cli.kinematics.defaults import PLATFORM_FK_METHODS

SIDES = ("both", "above", "below")


def _maybe(value: Any, option: str, count: int) -> tuple[float, ...] | None:
    return None if value is None else float_option(value, count, option)


@dataclass(frozen=True)
class IKOptions:
    """``platform ik``: a pose x,y,z,roll,pitch,yaw, or a position and the platform normal (with a
    fixed ``yaw``); a 12-leg truss takes node coordinates (18 numbers; default: the file's)."""

    pose: tuple[float, ...] | None = None
    position: tuple[float, ...] | None = None
    normal: tuple[float, ...] | None = None
    yaw: float = 0.0
    coords: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        put = object.__setattr__  # normalising a field of this record while it is being built
        if self.coords is not None:  # 18 of them for a truss: checked where the file says it is one
            put(self, "coords", float_option(self.coords, None, "--coords"))
        put(self, "pose", _maybe(self.pose, "--pose", 6))
        put(self, "normal", _maybe(self.normal, "--normal", 3))
        if self.normal is not None and not any(self.normal):
            raise OptionError("--normal", "the normal vector must not be zero")
        put(self, "position", _maybe(self.position, "--position", 3))
        put(self, "yaw", float(self.yaw))


@dataclass(frozen=True)
class FKOptions:
    """``platform fk``: the leg lengths (in the file's leg order) and the solver: ``method`` auto,
    exact (degree-16 elimination), pso (the paper's swarm: ``particles`` x ``iterations`` x ``starts``)
    or multistart; modes on ``side`` of the base plane, accepted to ``rtol`` x max length.  A truss
    takes ``frame``: three node names of a face that fix the frame."""

    lengths: tuple[float, ...]
    method: str = "auto"
    starts: int | None = None
    particles: int = 50
    iterations: int = 50
    seed: int = 0
    side: str = "both"
    rtol: float = 1e-12
    frame: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        put = object.__setattr__  # normalising a field of this record while it is being built
        put(self, "lengths", float_option(self.lengths, None, "--lengths"))
        put(self, "method", choice_option(self.method, PLATFORM_FK_METHODS, "--method"))
        put(self, "side", choice_option(self.side, SIDES, "--side"))
        if self.starts is not None and self.starts < 1:
            raise OptionError("--starts", f"must be >= 1, got {self.starts}")
        if self.particles < 2:
            raise OptionError("--particles", f"must be >= 2, got {self.particles}")
        if self.iterations < 1:
            raise OptionError("--iterations", f"must be >= 1, got {self.iterations}")
        if self.seed < 0:
            raise OptionError("--seed", f"must be >= 0, got {self.seed}")
        if not self.rtol >= 0:
            raise OptionError("--rtol", f"must be >= 0, got {self.rtol}")
        if self.frame is not None:
            names = self.frame.split(",") if isinstance(self.frame, str) else [str(n) for n in self.frame]
            put(self, "frame", tuple(names))


@dataclass(frozen=True)
class WorkspaceOptions:
    """``platform workspace``: ``samples`` poses from ``seed`` in the file's box (``orientation``
    roll,pitch,yaw held fixed when given); ``plot``: a PNG of the reachable positions."""

    samples: int = 20000
    orientation: tuple[float, ...] | None = None
    seed: int = 0
    plot: Path | None = None

    def __post_init__(self) -> None:
        if self.samples < 1:
            raise OptionError("--samples", f"must be >= 1, got {self.samples}")
        if self.seed < 0:
            raise OptionError("--seed", f"must be >= 0, got {self.seed}")
        if self.plot is not None:
            object.__setattr__(self, "plot", Path(self.plot))
            if self.plot.suffix.lower() != ".png":
                raise OptionError("--plot", "the plot is written as PNG; use a .png file name")
        object.__setattr__(self, "orientation", _maybe(self.orientation, "--orientation", 3))
