"""``minparam singular``'s result: the local test, the scan, the --plot map and the symbolic conditions."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np

    from minparam_cli.chain import Chain

SCHEMA = "minparam.singular/1"


@dataclass(frozen=True)
class ToolPoint:
    """The tool point O_c the analysis uses: its link (URDF --tool), its coordinates (m) in ``frame``,
    and where it comes from."""

    link: str | None
    point: tuple[float, float, float]
    frame: str
    source: str
    line: str  # the table's line

    def to_dict(self) -> dict[str, Any]:
        return {"link": self.link, "point": list(self.point), "frame": self.frame, "source": self.source}


@dataclass(frozen=True)
class SigmaMap:
    """The --plot map: σ_min/σ_max over two joints (numbered from 0 in ``pair``), written to ``file``."""

    file: Path
    pair: tuple[int, int]
    data: Any = field(repr=False)  # kinematics.serial.singular_grid's map

    def to_dict(self) -> dict[str, Any]:
        return {"file": str(self.file), "joints": [self.pair[0] + 1, self.pair[1] + 1],
                "points_per_axis": int(self.data.x.size), "sigma_min_on_map": float(self.data.sigma.min())}


@dataclass(frozen=True)
class Singularity:
    """``minparam singular``: the screw-theory test at q (``singular``: whether it is singular,
    ``sigma_ratio``: σ_min/σ_max of the normalised screw matrix, ``dependent``: the dependent joint
    groups, numbered from 1), with ``scan``, ``map`` and ``symbolic`` sections when asked."""

    robot: str
    source: str
    tool: ToolPoint
    chain: Chain = field(repr=False)
    degrees: bool = False  # the angle unit of the tables
    seed: int = 0
    q: np.ndarray | None = field(default=None, repr=False)  # rad (m)
    local: Any = field(default=None, repr=False)  # kinematics.serial.screws' report
    check: Any = field(default=None, repr=False)  # the nearest-twist check
    scan: Any = field(default=None, repr=False)
    map: SigmaMap | None = field(default=None, repr=False)
    symbolic: Any = field(default=None, repr=False)

    @property
    def singular(self) -> bool | None:
        return None if self.local is None else bool(self.local.test.singular)

    @property
    def sigma_ratio(self) -> float | None:
        from minparam_cli.render.singular_text import json_safe

        return None if self.local is None else json_safe(self.local.test.sigma_min)

    @property
    def dependent(self) -> tuple[tuple[int, ...], ...]:
        return () if self.local is None else tuple(tuple(j + 1 for j in g) for g in self.local.groups)

    def to_dict(self) -> dict[str, Any]:
        """``minparam singular --format json``."""
        from minparam_cli.render.singular_text import json_safe, local_json, scan_json, symbolic_json

        doc: dict[str, Any] = {"schema": SCHEMA, "robot": self.robot, "source": self.source, "tool": self.tool.to_dict()}
        if self.local is not None:
            doc.update(local_json(self.local, self.check, self.seed))
        if self.scan is not None:
            doc["scan"] = scan_json(self.scan)
        if self.map is not None:
            doc["plot"] = self.map.to_dict()
        if self.symbolic is not None:
            doc["symbolic"] = symbolic_json(self.symbolic)
        return json_safe(doc)
