"""What ``minparam check`` reports for one valid robot file."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

SCHEMA = "minparam.check/1"


@dataclass(frozen=True)
class TransmissionSummary:
    """A declared transmission: motors, the motors coupled to several joints (from 1), the condition
    number of N, and whether drive gains are given."""

    motors: int
    coupled_motors: tuple[int, ...]
    condition_number: float
    drive_gains: bool

    def to_dict(self) -> dict[str, Any]:
        return {"motors": self.motors, "coupled_motors": list(self.coupled_motors),
                "condition_number": self.condition_number, "drive_gains": self.drive_gains}


@dataclass(frozen=True)
class CheckResult:
    """What ``minparam check --json`` reports for one valid robot file: its name, joint types ("RRP"),
    whether it is branched, exact (rational DH values), gives inertial values, has finite frames, the
    links with inertial values (each a real body) and the declared transmission."""

    robot: str
    source: str
    dof: int
    convention: str
    joint_types: str
    branched: bool
    exact: bool
    inertial: bool
    finite: bool
    bodies: tuple[str, ...] = ()
    transmission: TransmissionSummary | None = None

    def to_dict(self) -> dict[str, Any]:
        """One line of ``minparam check --json``."""
        return {"schema": SCHEMA, "robot": self.robot, "source": self.source, "dof": self.dof,
                "convention": self.convention, "types": self.joint_types, "branched": self.branched,
                "exact": self.exact, "inertial": self.inertial, "finite": self.finite,
                "bodies": {link: "ok" for link in self.bodies},
                "transmission": None if self.transmission is None else self.transmission.to_dict(),
                "status": "ok"}
