"""The errors record: how far a model's torques are from measured ones (no numpy: ``import minparam``
re-exports it as ``minparam.Errors`` and stays light)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Errors:
    """Torque errors of a model on some data: RMS over all joints, RMS per joint (N·m or N) and ‖r‖/‖τ‖;
    ``relative_per_joint`` (‖r_j‖/‖τ_j‖) where the data's accumulators give it.  The one errors record of
    the package: the identify and evaluate results and the Python API (``minparam.Errors``) use it."""

    rms_total: float
    rms_per_joint: tuple[float, ...]
    relative_error: float
    relative_per_joint: tuple[float, ...] | None = None

    def to_dict(self) -> dict:
        """The reports' errors record: rms_total, rms_per_joint, relative_error."""
        return {"rms_total": float(self.rms_total), "rms_per_joint": [float(x) for x in self.rms_per_joint],
                "relative_error": float(self.relative_error)}
