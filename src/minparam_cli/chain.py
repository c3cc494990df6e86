"""The one kinematic chain model every stage uses.

Every joint j moves link j, and link j's frame is

    F_j = F_parent(j) · Pre_j · Motion_j(q_j) · Post_j

where Motion is a rotation about (revolute) or a translation along
(prismatic) the unit ``axis_j``, expressed in the frame F_parent · Pre_j.

* URDF joint: Pre = (lumped fixed transforms) · origin, Post = identity.
* MDH row (Craig/Khalil, Rx(α)·Tx(a)·Rz(θ)·Tz(d)): Pre = Rx(α)Tx(a)Rz(θ0)Tz(d0), Post = I.
* DH row (Rz(θ)·Tz(d)·Tx(a)·Rx(α)): revolute Pre = I, Post = Rz(θ0)Tz(d)Tx(a)Rx(α);
  prismatic Pre = Rz(θ0), Post = Tz(d0)Tx(a)Rx(α).

So a DH row is a special case of a URDF joint with a constant transform after
the motion.  The chain is frozen; ``build_chain`` is the only builder.  The
constant transforms Pre, axis, Post come from ``joint_matrices.py`` (float or
exact arithmetic).

Joints driven by others (URDF ``<mimic>``) keep their link and their place in
the chain; ``Chain.coupling`` maps the independent coordinates q (``dof`` of
them, what data files and the regressor's rows are about) to every joint:
q_joint = G·q + offset.
"""

from __future__ import annotations

import threading
import weakref
from dataclasses import dataclass, field
from typing import Callable, TypeVar

import numpy as np

from minparam_cli.describe.records import RobotDescription, Transmission
from minparam_cli.joint_matrices import Numbers, exact_matrices, joint_matrices
from minparam_cli.params import EXTRA_ORDER, ParamLayout

REVOLUTE, PRISMATIC = "revolute", "prismatic"
T = TypeVar("T")


_DERIVED: "weakref.WeakKeyDictionary[Chain, dict[str, object]]" = weakref.WeakKeyDictionary()
_DERIVED_LOCK = threading.Lock()


def derived(chain: "Chain", name: str, build: Callable[["Chain"], T]) -> T:
    """``build(chain)``, computed once per chain and kept beside it, never written into it (the chain
    stays frozen, as pinocchio keeps its Data beside the Model); dropped when the chain is.  Two
    threads may both build a value the first time: the first one stored is the one every caller gets.
    A value must not refer to the chain (the chain would never be dropped)."""
    with _DERIVED_LOCK:
        values = _DERIVED.setdefault(chain, {})
        if name in values:
            return values[name]  # type: ignore[return-value]
    value = build(chain)  # outside the lock: the exact matrices take a while
    with _DERIVED_LOCK:
        return values.setdefault(name, value)  # type: ignore[return-value]


@dataclass(frozen=True, eq=False)
class Coupling:
    """Joints moved by other joints (URDF <mimic>): q_joint = G · q + offset for every joint of the
    chain, q the independent coordinates.  By virtual work the generalized force on coordinate i
    is Σ_j G[j, i] τ_j, so the regressor's rows are Gᵀ times the rows of every joint."""

    coordinates: tuple[int, ...]  # the joints that are independent coordinates, in chain order
    G: np.ndarray  # (n joints, dof): the coupling Jacobian
    offset: np.ndarray  # (n joints,)

    def joint_states(self, q, qd, qdd):
        """(q, qd, qdd) of every joint, (N, n), from the coordinates' (N, dof)."""
        Gt = self.G.T
        return q @ Gt + self.offset, qd @ Gt, qdd @ Gt

    def coordinate_rows(self, q, qd, qdd, joint_rows: Callable):
        """The regressor's rows of the coordinates: Gᵀ times ``joint_rows(q, qd, qdd)`` (N, n, P) of
        every joint's state (a closed chain's coupling, ``loops/coupling.py``, has a G per state)."""
        states = (np.ascontiguousarray(x) for x in self.joint_states(q, qd, qdd))
        return np.matmul(self.G.T, joint_rows(*states))


@dataclass(frozen=True, eq=False)
class Chain:
    """The kinematic chain of one robot (frozen): joint transforms, axes, gravity, parameter layout.

    Arrays are per joint in chain order; see the module docstring for the frame convention.
    """

    name: str
    source: str
    convention: str
    joint_names: tuple[str, ...]
    link_names: tuple[str, ...]
    types: tuple[str, ...]
    parents: tuple[int, ...]
    pre: np.ndarray  # (n, 4, 4)
    axes: np.ndarray  # (n, 3) unit, in the frame F_parent·Pre
    post: np.ndarray  # (n, 4, 4)
    gravity: np.ndarray  # (3,) in the base frame, m/s^2
    gravity_source: str
    layout: ParamLayout
    phi_nominal: np.ndarray | None = None  # standard inertial params (10 n) if every link has them
    limits: tuple[tuple[float, float] | None, ...] = ()
    # per joint: largest |q̇|, |q̈|, |τ| allowed (SI; None where the file gives none)
    velocity_limits: tuple[float | None, ...] = ()
    acceleration_limits: tuple[float | None, ...] = ()
    effort_limits: tuple[float | None, ...] = ()
    tool: np.ndarray | None = None
    length_scale: float = 1.0
    # Coulomb friction columns: sign(qd) when 0, else the smooth tanh(qd / coulomb_smoothing) (rad/s or m/s)
    coulomb_smoothing: float = 0.0
    # the description the exact geometry comes from (None: none, e.g. a chain rebuilt at other values)
    exact_source: RobotDescription | None = field(default=None, repr=False)
    # mimic joints (None: every joint is an independent coordinate)
    coupling: Coupling | None = None
    # the first six joints are the virtual joints of a floating base (base wrench equations)
    floating_base: bool = False
    # motors and gears (theta_m = N (q - zero)): the motor-side columns of dynamics/transmission.py
    transmission: Transmission | None = None
    # joint-side drive gains (tau_j = k_j i_j, YAML ``drive_gains:``): identify/simulate --current without --side motor
    drive_gains: tuple[float, ...] | None = None
    # per joint, the nominal values of extras the file gives (MJCF armature, frictionloss, damping)
    nominal_extras: tuple[tuple[tuple[str, float], ...], ...] = ()

    def nominal_extra_values(self) -> np.ndarray:
        """The file's nominal value of every extra column of the layout, in column order (0 where none)."""
        given = [dict(v) for v in self.nominal_extras] or [{} for _ in range(self.n)]
        return np.array([given[k].get(kind, 0.0) for k, kind in self.layout.extra_columns])
    # per link: (source, lo, hi), the box its URDF shapes fill in the link frame, or None (JointRecord.geometry)
    link_geometry: tuple = ()

    @property
    def n(self) -> int:
        """Joints (and links) of the chain, mimic joints included."""
        return len(self.types)

    @property
    def dof(self) -> int:
        """Independent coordinates: the joints that are not driven by another (n without mimic joints)."""
        return self.n if self.coupling is None else len(self.coupling.coordinates)

    @property
    def coordinates(self) -> tuple[int, ...]:
        """The joints that are independent coordinates, in chain order."""
        return tuple(range(self.n)) if self.coupling is None else self.coupling.coordinates

    @property
    def coordinate_types(self) -> tuple[str, ...]:
        return tuple(self.types[j] for j in self.coordinates)

    @property
    def exact(self) -> tuple | None:
        """Exact rational versions of pre, axes, post (per joint, nested tuples of Fraction), or None
        when the geometry is not exact (irrational lengths, angles off multiples of 90 deg, ...).

        Computed on first use (only the exact stages, projection and symbolic, need it), kept by ``derived``."""
        return derived(self, "exact", lambda c: None if c.exact_source is None else exact_matrices(c.exact_source))

    @property
    def revolute(self) -> np.ndarray:
        return np.array([t == REVOLUTE for t in self.types])

    def children(self, j: int) -> tuple[int, ...]:
        return tuple(k for k, p in enumerate(self.parents) if p == j)

    def subtree(self, j: int) -> tuple[int, ...]:
        """Joints whose link is carried by joint j (j included), in chain order."""
        out = [j]
        for k in range(j + 1, self.n):
            if self.parents[k] in out:
                out.append(k)
        return tuple(out)

    def ancestors(self, j: int) -> tuple[int, ...]:
        """Joints from the root to j (j included), root first."""
        path = []
        k = j
        while k >= 0:
            path.append(k)
            k = self.parents[k]
        return tuple(reversed(path))

    @property
    def local_terms(self) -> tuple:
        """Per joint, constant 4x4 matrices with Pre·Motion(q)·Post = C0 + s·C1 + (1 − c)·C2 (revolute,
        Rodrigues' formula, s = sin q, c = cos q) or C0 + q·C1 (prismatic); plus the axis direction and
        point in the parent frame (Pre's rotation times the axis, Pre's origin).  Built once (``derived``)."""
        return derived(self, "local_terms", Chain._local_terms)

    def _local_terms(self) -> tuple:
        out = []
        for j in range(self.n):
            a = self.axes[j]
            Kx = np.zeros((4, 4))
            if self.types[j] == REVOLUTE:
                Kx[:3, :3] = [[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]]
                terms = (self.pre[j] @ self.post[j], self.pre[j] @ Kx @ self.post[j], self.pre[j] @ (Kx @ Kx) @ self.post[j])
            else:
                Kx[:3, 3] = a
                terms = (self.pre[j] @ self.post[j], self.pre[j] @ Kx @ self.post[j], None)
            out.append((terms, self.pre[j][:3, :3] @ a, self.pre[j][:3, 3].copy()))
        return tuple(out)

    def with_extras(self, extras: tuple[tuple[str, ...], ...]) -> "Chain":
        from dataclasses import replace

        return replace(self, layout=ParamLayout(self.n, extras, self.layout.numbers, self.layout.massless))

    def with_coulomb_smoothing(self, velocity: float) -> "Chain":
        """The same chain with Coulomb columns tanh(qd / velocity) (0: sign(qd))."""
        from dataclasses import replace

        if not velocity >= 0.0:
            raise ValueError(f"the Coulomb smoothing velocity must be >= 0, got {velocity}")
        return replace(self, coulomb_smoothing=float(velocity))


def _inertial_to_standard(inertial) -> np.ndarray:
    """Mass, CoM, inertia about CoM -> Khalil's 10 standard parameters about the frame origin."""
    m = inertial.mass
    c = np.asarray(inertial.com, dtype=float)
    ixx, ixy, ixz, iyy, iyz, izz = inertial.inertia
    Ic = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    Io = Ic + m * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([Io[0, 0], Io[0, 1], Io[0, 2], Io[1, 1], Io[1, 2], Io[2, 2], *(m * c), m])


def build_chain(
    desc: RobotDescription,
    values: dict[str, float] | None = None,
    extras: tuple[tuple[str, ...], ...] | None = None,
) -> Chain:
    """Turn any description into the frozen chain.

    ``values`` overrides geometric values by symbol name (SI units), e.g. to
    rebuild the robot at another geometry.  ``extras`` overrides the extras
    declared in the file, per joint.
    """
    num = Numbers(False, values)
    mats = joint_matrices(desc, num)
    pre = np.array([np.array(p, dtype=float) for p, _, _ in mats])
    axes = np.array([np.array(a, dtype=float) for _, a, _ in mats])
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    post = np.array([np.array(p, dtype=float) for _, _, p in mats])
    if extras is None:
        extras = tuple(j.extras for j in desc.joints)
    tr = desc.transmission
    if tr is not None:  # the motor-side columns of the declared transmission, numbered by motor
        from minparam_cli.errors import UnsupportedError

        if any(j.mimic is not None or j.virtual for j in desc.joints):
            raise UnsupportedError("a transmission together with mimic joints or a floating base is not supported", desc.source)
        extras = tuple(tuple(k for k in EXTRA_ORDER if k in set(e) | set(tr.motor_extras[i])) for i, e in enumerate(extras))
    phi = None
    bodies = [j for j in desc.joints if not j.massless]
    if all(j.inertial is not None for j in bodies):
        phi = np.concatenate([_inertial_to_standard(j.inertial) for j in bodies])
    numbers = None
    if any(j.virtual for j in desc.joints):  # a floating base: the free link is link 0, massless virtual links have none
        it = iter(range(desc.dof))
        numbers = tuple(None if j.massless and j.virtual else next(it) for j in desc.joints)
    # MJCF's frames between the joints of one body: numbered (their joints' extras), no columns
    massless = tuple(k for k, j in enumerate(desc.joints) if j.massless and not j.virtual)
    lengths = [abs(x) for x in np.concatenate([pre[:, :3, 3].ravel(), post[:, :3, 3].ravel()]) if abs(x) > 0]
    return Chain(
        coupling=mimic_coupling(desc),
        floating_base=any(j.virtual for j in desc.joints),
        name=desc.name,
        source=desc.source,
        convention=desc.convention,
        joint_names=tuple(j.name for j in desc.joints),
        link_names=tuple(j.link_name for j in desc.joints),
        types=tuple(j.type for j in desc.joints),
        parents=tuple(j.parent for j in desc.joints),
        pre=pre,
        axes=axes,
        post=post,
        gravity=np.asarray(desc.gravity, dtype=float),
        gravity_source=desc.gravity_source,
        layout=ParamLayout(desc.dof, tuple(tuple(e) for e in extras), numbers, massless),
        phi_nominal=phi,
        limits=tuple(j.limits for j in desc.joints),
        velocity_limits=tuple(j.max_velocity for j in desc.joints),
        acceleration_limits=tuple(j.max_acceleration for j in desc.joints),
        effort_limits=tuple(j.max_effort for j in desc.joints),
        tool=None if desc.tool is None else np.asarray(desc.tool, dtype=float),
        length_scale=float(max(lengths)) if lengths else 1.0,
        exact_source=None if values else desc,
        transmission=tr,
        drive_gains=desc.drive_gains,
        nominal_extras=tuple(j.nominal_extras for j in desc.joints),
        link_geometry=tuple(j.geometry for j in desc.joints),
    )


def mimic_coupling(desc: RobotDescription) -> Coupling | None:
    """The coupling of the description's mimic joints (None when it has none)."""
    if all(j.mimic is None for j in desc.joints):
        return None
    coords = tuple(k for k, j in enumerate(desc.joints) if j.mimic is None)
    column = {k: i for i, k in enumerate(coords)}
    G = np.zeros((desc.dof, len(coords)))
    offset = np.zeros(desc.dof)
    for k, j in enumerate(desc.joints):
        if j.mimic is None:
            G[k, column[k]] = 1.0
        else:
            master, multiplier, offset[k] = j.mimic
            G[k, column[master]] = multiplier
    return Coupling(coords, G, offset)


def motion(kind: str, axis: np.ndarray, q: np.ndarray) -> np.ndarray:
    """4x4 joint motion transforms for a batch of joint values q (N,) -> (N, 4, 4)."""
    q = np.asarray(q, dtype=float)
    N = q.shape[0]
    T = np.zeros((N, 4, 4))
    T[:, 3, 3] = 1.0
    if kind == REVOLUTE:
        T[:, :3, :3] = rotation_about(axis, q)
    else:
        T[:, :3, :3] = np.eye(3)
        T[:, :3, 3] = q[:, None] * axis[None, :]
    return T


def rotation_about(axis: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Rodrigues' formula, batched: (N,) angles -> (N, 3, 3)."""
    k = np.asarray(axis, dtype=float)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    c, s = np.cos(q)[:, None, None], np.sin(q)[:, None, None]
    return np.eye(3) + s * K + (1 - c) * (K @ K)


def forward_kinematics(chain: Chain, q: np.ndarray):
    """World poses of every link frame and joint axis for a batch of q.

    q: (N, n).  Returns (T, z, o): T (N, n, 4, 4) link frames in the base frame,
    z (N, n, 3) joint axes and o (N, n, 3) points on them, in the base frame.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    N, n = q.shape
    if n != chain.n:
        raise ValueError(f"expected q with {chain.n} columns, got {n}")
    T = np.empty((N, n, 4, 4))
    z = np.empty((N, n, 3))
    o = np.empty((N, n, 3))
    for j, ((C0, C1, C2), axis, origin) in enumerate(chain.local_terms):
        qj = q[:, j, None, None]
        local = C0 + np.sin(qj) * C1 + (1.0 - np.cos(qj)) * C2 if C2 is not None else C0 + qj * C1
        p = chain.parents[j]
        if p < 0:
            T[:, j] = local
            z[:, j] = axis
            o[:, j] = origin
        else:
            P = T[:, p]
            np.matmul(P, local, out=T[:, j])
            z[:, j] = P[:, :3, :3] @ axis
            o[:, j] = P[:, :3, :3] @ origin + P[:, :3, 3]
    return T, z, o
