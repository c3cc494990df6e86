"""Plain records produced by the loaders: units resolved to SI, symbols kept.

A loader turns a file into a :class:`RobotDescription`; ``chain.build_chain``
turns any description into the one kinematic chain every stage uses.  The
records carry no behaviour beyond small conveniences.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from minparam_cli.describe.loops import ClosedLoops

# what a loader does with URDF <mimic> joints: move them with their master, or freeze them at their offset
MIMIC_MODES = ("coupled", "fixed")


@dataclass(frozen=True)
class GeomValue:
    """One geometric value of a description.

    ``value`` is in SI (m or rad).  ``exact`` is the same value as a Fraction
    when the file gives it exactly: metres for lengths, *degrees* for angles
    (so that 90 deg is exact).  ``symbol`` is the name the symbolic stage
    prints; ``named`` says whether the file chose it.
    """

    value: float
    symbol: str
    is_angle: bool = False
    exact: Fraction | None = None
    named: bool = False


@dataclass(frozen=True)
class Inertial:
    """Nominal inertial data of one link, in its link frame, SI units.

    ``inertia`` is the tensor about the centre of mass as
    (ixx, ixy, ixz, iyy, iyz, izz), tensor entries (ixy = -sum m x y).
    """

    mass: float
    com: tuple[float, float, float]
    inertia: tuple[float, float, float, float, float, float]


@dataclass(frozen=True)
class JointRecord:
    """One moving joint and the link it moves.

    DH/MDH joints keep their four parameters in ``dh`` (keys alpha, a, d,
    theta).  URDF joints keep their origin in ``origin`` (keys x, y, z, roll,
    pitch, yaw) plus the lumped fixed transforms before it in ``pre_fixed``
    (a 4x4 nested tuple) and the axis.
    """

    name: str
    type: str  # "revolute" | "prismatic"
    parent: int  # index of the parent joint, -1 for the base
    link_name: str = ""
    dh: dict[str, GeomValue] | None = None
    origin: dict[str, GeomValue] | None = None
    pre_fixed: tuple[tuple[float, ...], ...] | None = None
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    extras: tuple[str, ...] = ()
    inertial: Inertial | None = None
    limits: tuple[float, float] | None = None
    # largest |q̇| (rad/s or m/s), |q̈| (rad/s² or m/s²) and |τ| (N·m or N) allowed; None: not given
    max_velocity: float | None = None
    max_acceleration: float | None = None
    max_effort: float | None = None
    # URDF <mimic>: (index of the independent joint that drives this one, multiplier, offset),
    # q_this = multiplier * q_master + offset; None for an independent joint
    mimic: tuple[int, float, float] | None = None
    # one of the six virtual joints of a floating base (3 prismatic, then 3 revolute): no extras;
    # ``massless``: its link has no mass and no parameters (all but the sixth, which carries the free link;
    # also MJCF's frames between the joints of one body, which keep their joint's number)
    virtual: bool = False
    massless: bool = False
    # nominal values of extras the file gives (MJCF armature, frictionloss, damping: "rotor_inertia",
    # "coulomb", "viscous"), SI; extras not listed have none
    nominal_extras: tuple[tuple[str, float], ...] = ()
    # URDF: (source, lo, hi), the box in the link frame that its collision (else visual) shapes fill,
    # fixed links lumped in (describe/urdf_geometry.py); None: no shapes (every YAML row)
    geometry: tuple[str, tuple[float, ...], tuple[float, ...]] | None = None


@dataclass(frozen=True)
class Transmission:
    """Motors and gears between the motor coordinates and the joints (docs/methods/transmission.md).

    theta_m = N (q - zero), tau_joint = Nᵀ tau_m; ``matrix`` is N row by row (motor k = row k),
    ``zero`` the joint coordinates at which every motor reads zero (SI), ``motor_extras`` per motor
    the motor-side columns (kinds of ``params.MOTOR_KINDS``), ``drive_gains`` the motor torque per
    unit of current signal (tau_m = g_k i_k; None: not declared).
    """

    matrix: tuple[tuple[float, ...], ...]
    zero: tuple[float, ...]
    motor_extras: tuple[tuple[str, ...], ...]
    drive_gains: tuple[float, ...] | None = None

    @property
    def n(self) -> int:
        return len(self.matrix)


@dataclass(frozen=True)
class RobotDescription:
    """A whole robot file: its joints in chain order, gravity (and where it came from), units, tool."""

    name: str
    source: str
    convention: str  # "dh" | "mdh" | "urdf" | "mjcf" (the last two: joint records with origins)
    joints: tuple[JointRecord, ...]
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)
    gravity_source: str = "default"  # "file" | "default" | "cli"
    units: dict[str, str] = field(default_factory=lambda: {"length": "m", "angle": "rad"})
    tool: tuple[float, float, float] | None = None
    # URDF: the link whose origin is ``tool`` (None: YAML, or no fixed link on the last moving link)
    tool_link: str | None = None
    # URDF: every link rigidly attached to a moving link, as (link, index of that joint/body,
    # its origin in that body's frame, m), in document walk order; what ``--tool LINK`` may name
    tool_links: tuple[tuple[str, int, tuple[float, float, float]], ...] = ()
    # values the loader changed on request (``--snap-angles``): dicts with where, from, to, degrees
    adjustments: tuple[dict, ...] = ()
    # motors, gears and their coupling (YAML ``transmission:``, or a URDF's side file); None: none declared
    transmission: Transmission | None = None
    # joint-side drive gains (YAML top-level ``drive_gains:``): tau_j = k_j i_j for currents read with joint
    # angles (``identify --current`` without --side motor); None: not declared
    drive_gains: tuple[float, ...] | None = None
    # a closed chain: the joints above are its spanning tree, these its cuts and actuated joints (describe/loops.py)
    loops: ClosedLoops | None = None

    @property
    def dof(self) -> int:
        return len(self.joints)

    def geometry(self) -> dict[str, GeomValue]:
        """Every geometric value by symbol name, in joint order."""
        out: dict[str, GeomValue] = {}
        for j in self.joints:
            for table in (j.dh, j.origin):
                if table:
                    for gv in table.values():
                        out[gv.symbol] = gv
        return out
