"""``minparam platform ik|fk|workspace``'s result."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

SCHEMA = "minparam.platform/1"


@dataclass(frozen=True)
class PlatformResult:
    """``minparam platform ik|fk|workspace`` (``kind``) on one platform file: the model, what the
    stage computed, and its main numbers: ``lengths`` (ik: leg lengths; fk: the given ones),
    ``poses`` (fk: one x,y,z,roll,pitch,yaw per assembly mode, file units), ``reachable``
    (workspace: the share of sampled poses inside the leg limits).  ``to_dict()`` is the command's
    JSON."""

    kind: str  # "ik", "fk" or "workspace"
    model: Any = field(repr=False)  # PlatformModel, or TrussModel for a 12-leg truss
    truss: bool = False
    pose: Any = field(default=None, repr=False)  # ik: the pose (SI angles), or the truss's node coordinates
    leg_lengths: Any = field(default=None, repr=False)  # ik
    within: Any = field(default=None, repr=False)  # ik: every leg within its limits
    solved: Any = field(default=None, repr=False)  # fk: FKResult / TrussFKResult; workspace: WorkspaceResult
    seed: int = 0
    elapsed_s: float = 0.0
    plot: Path | None = None  # workspace: the PNG written beside the output

    @property
    def lengths(self) -> tuple[float, ...]:
        if self.kind == "ik":
            return tuple(float(v) for v in self.leg_lengths)
        if self.kind == "fk":
            return tuple(float(v) for v in self.solved.target)
        return ()

    @property
    def poses(self) -> tuple[tuple[float, ...], ...]:
        if self.kind != "fk" or self.truss:
            return ()
        from minparam_cli.kinematics.parallel.platform_report import pose_dict

        return tuple(tuple(float(v) for v in pose_dict(s.pose, self.model.angle_unit).values()) for s in self.solved.solutions)

    @property
    def reachable(self) -> float | None:
        return float(self.solved.fraction) if self.kind == "workspace" else None

    def to_dict(self) -> dict[str, Any]:
        """``minparam platform <kind> --format json``."""
        from minparam_cli.kinematics.parallel import platform_report as rep

        if self.kind == "ik":
            d = (rep.truss_ik_dict(self.model, self.pose, self.leg_lengths) if self.truss
                 else rep.ik_dict(self.model, self.pose, self.leg_lengths, self.within))
        elif self.kind == "fk":
            d = (rep.truss_fk_dict if self.truss else rep.fk_dict)(self.model, self.solved, self.seed, self.elapsed_s)
        else:
            d = rep.workspace_dict(self.model, self.solved, self.elapsed_s)
            if self.plot is not None:
                d["plot"] = {"file": str(self.plot)}
        return {"schema": SCHEMA, **d}
