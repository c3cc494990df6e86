"""Exact geometry for the symbolic route: the field of the geometry symbols, each joint's
transforms in it, the transfer of inertial parameters between frames, and the
Lagrangian's coefficient functions at one state.

Every function here is generic over its arithmetic: the same code runs on
floats (random geometry, to decide the structure) and on elements of the
rational function field Q(symbols) (``GeometryField``), where it is exact.

Symbols of the field (docs/methods/symbolic.md):

* a length (a, d, URDF x/y/z) that is not zero: its own symbol;
* an angle that is not a multiple of 90°: two symbols, its sine and cosine, with
  sin² + cos² = 1 kept by a normal form (``symbolic_poly``: exact zero test);
* gravity: ``g`` (its magnitude) when the file's gravity is along a base axis,
  else one symbol per nonzero component;
* the offset of a joint's own coordinate (θ of a revolute DH/MDH joint, d of a
  prismatic one) only shifts q: every column of the regressor is the same
  function of q + offset, so the regrouping cannot depend on it and the exact
  computation takes it as 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import TYPE_CHECKING, Any

from minparam_cli.base.symbolic_urdf import AXIS_THETA, MIMIC_OFFSET, axis_rotation_oblique, is_frame_axis
from minparam_cli.chain import PRISMATIC, REVOLUTE
from minparam_cli.errors import UnsupportedError

if TYPE_CHECKING:
    from minparam_cli.base.symbolic_poly import ExactContext

XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M = range(10)


@dataclass(frozen=True)
class FieldSymbols:
    """The names of the exact computation: geometry symbols, gravity symbols, shift symbols."""

    lengths: tuple[str, ...]
    angles: tuple[str, ...]  # each enters through sin_<name>, cos_<name>
    gravity: tuple[tuple[str, int, int], ...]  # (symbol, base axis 0..2, sign)
    gravity_values: dict
    shifts: tuple[str, ...]  # symbols that only shift a joint coordinate (taken as 0)


def shift_symbols(desc) -> set[str]:
    """Symbols used only as the offset of a joint's own coordinate."""
    shift: set[str] = set()
    other: set[str] = set()
    for jr in desc.joints:
        if jr.dh is not None:
            own = "theta" if jr.type == REVOLUTE else "d"
            for key, gv in jr.dh.items():
                (shift if key == own else other).add(gv.symbol)
        elif jr.origin is not None:
            other.update(gv.symbol for gv in jr.origin.values())
    return shift - other


def gravity_symbols(desc, taken: set[str]):
    """(symbol, axis, sign) per gravity term and the symbols' file values."""
    gvec = [float(x) for x in desc.gravity]
    nonzero = [k for k in range(3) if gvec[k] != 0.0]
    if not nonzero:
        return (), {}
    if len(nonzero) == 1:
        name = "g" if "g" not in taken else "g_0"
        k = nonzero[0]
        return ((name, k, 1 if gvec[k] > 0 else -1),), {name: abs(gvec[k])}
    names = [f"g{'xyz'[k]}" for k in nonzero]
    if set(names) & taken:
        names = [n + "_0" for n in names]
    return tuple((n, k, 1) for n, k in zip(names, nonzero, strict=True)), {n: gvec[k] for n, k in zip(names, nonzero, strict=True)}


def field_symbols(desc, symbols) -> FieldSymbols:
    shifts = shift_symbols(desc)
    lengths = tuple(s.name for s in symbols if not s.is_angle and s.name not in shifts)
    angles = tuple(s.name for s in symbols if s.is_angle and s.name not in shifts)
    grav, gvals = gravity_symbols(desc, {s.name for s in symbols})
    return FieldSymbols(lengths, angles, grav, gvals, tuple(sorted(shifts & {s.name for s in symbols})))


def refuse_unsupported(desc, chain) -> None:
    """Raise UnsupportedError (a property of the robot) before any work."""
    for jr in desc.joints:
        if jr.dh is None and jr.pre_fixed is not None:  # symbolic_urdf.symbolic_description lifts these
            raise UnsupportedError(f"joint '{jr.name}': lumped fixed transforms not rewritten as symbols", desc.source)


class Arith:
    """Numbers of one computation: field elements (exact) or floats, and the geometry in them."""

    def __init__(self, fs: FieldSymbols, pins: dict, values: dict | None = None, rational: bool = False,
                 numbers: dict | None = None):
        """values None: the field Q(symbols); else floats (angles in rad) or, with ``rational``,
        Fractions (angles given by their half-angle tangent t).  ``numbers``: geometry taken as
        exact numbers, not symbols (``symbolic_urdf.exact_numbers``)."""
        self.fs, self.pins = fs, pins
        self.numbers = numbers or {}
        self.rational = rational
        self.F: ExactContext | None
        self.gen: dict[str, Any]
        self.one: Any  # Fraction, field element or float, as the arithmetic
        self.zero: Any
        if rational:
            assert values is not None  # the rational arithmetic is given its numbers
            self.F, self.gen = None, values
            self.one, self.zero = Fraction(1), Fraction(0)
            self.exact = False
        elif values is None:  # exact: fractions over Q[lengths, sin/cos of angles, gravity]
            from minparam_cli.base.symbolic_poly import ExactContext

            pairs = [(f"sin_{a}", f"cos_{a}") for a in fs.angles]
            names = list(fs.lengths) + [x for p in pairs for x in p] + [g for g, _, _ in fs.gravity]
            self.F = ExactContext(names, pairs)
            self.gen = {k: self.F.var(k) for k in names}
            self.one, self.zero = self.F.one, self.F.zero
            self.exact = True
        else:
            self.F, self.gen = None, values
            self.one, self.zero = 1.0, 0.0
            self.exact = False

    def const(self, x):
        if self.rational:
            return Fraction(x)
        if self.exact:
            assert self.F is not None  # the exact arithmetic is the field's
            return self.F.const(x)
        return float(x)

    def length(self, gv):
        if gv.symbol in self.fs.shifts or gv.value == 0.0:
            return self.zero
        if gv.symbol in self.numbers:
            return self.const(self.numbers[gv.symbol])
        return self.gen[gv.symbol]

    def cos_sin(self, gv):
        if gv.symbol in self.fs.shifts or gv.value == 0.0:
            return self.one, self.zero
        if gv.symbol in self.pins:
            k = round(self.pins[gv.symbol] / (math.pi / 2)) % 4
            c, s = [(1, 0), (0, 1), (-1, 0), (0, -1)][k]
            return self.const(c), self.const(s)
        if gv.symbol in self.numbers:
            c, s = self.numbers[gv.symbol]
            return self.const(c), self.const(s)
        if self.exact:
            return self.gen[f"cos_{gv.symbol}"], self.gen[f"sin_{gv.symbol}"]
        v = self.gen[gv.symbol]
        if self.rational:
            return (1 - v * v) / (1 + v * v), 2 * v / (1 + v * v)
        return math.cos(v), math.sin(v)

    def gravity(self):
        g = [self.zero, self.zero, self.zero]
        for name, k, sign in self.fs.gravity:
            g[k] = self.gen[name] * self.const(sign)
        return g


# --- small generic linear algebra on nested lists -----------------------------


def matmul(a, b, zero):
    return [[sum((a[i][k] * b[k][j] for k in range(len(b)) if a[i][k] and b[k][j]), zero) for j in range(len(b[0]))] for i in range(len(a))]


def transpose(a):
    return [list(r) for r in zip(*a, strict=True)]


def matvec(a, v, zero):
    return [sum((a[i][k] * v[k] for k in range(len(v)) if a[i][k] and v[k]), zero) for i in range(len(a))]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def skew(v, zero):
    return [[zero, -v[2], v[1]], [v[2], zero, -v[0]], [-v[1], v[0], zero]]


def axis_rotation(axis, ar: Arith):
    """A 4x4 rotation R_u with R_u·e_z = u for u = ±e_x, ±e_y, ±e_z."""
    k = max(range(3), key=lambda i: abs(float(axis[i])))
    sign = 1 if float(axis[k]) > 0 else -1
    o, z, m = ar.one, ar.zero, -ar.one
    if k == 2:
        R = [[o, z, z], [z, o, z], [z, z, o]] if sign > 0 else [[o, z, z], [z, m, z], [z, z, m]]
    elif k == 0:  # Ry(±90)
        R = [[z, z, o], [z, o, z], [m, z, z]] if sign > 0 else [[z, z, m], [z, o, z], [o, z, z]]
    else:  # Rx(∓90)
        R = [[o, z, z], [z, z, o], [z, m, z]] if sign > 0 else [[o, z, z], [z, z, m], [z, o, z]]
    return [R[0] + [z], R[1] + [z], R[2] + [z], [z, z, z, o]]


def joint_transforms(desc, ar: Arith):
    """Per joint: (P, A) with F_j = F_parent · P · Motion_z(q_j) · A, the motion about/along z.

    P = Pre·R_u and A = R_uᵀ·Post, R_u turning z onto the joint axis u."""
    from minparam_cli.joint_matrices import joint_matrices

    class _Num:  # joint_matrices.Numbers' accessor interface, in this arithmetic
        exact = True
        one, zero = ar.one, ar.zero
        length = staticmethod(ar.length)
        cos_sin = staticmethod(ar.cos_sin)

    out = []
    for (pre, _axis, post), jr in zip(joint_matrices(_RecordsOnly(desc), _Num), desc.joints, strict=True):
        if jr.origin is not None and AXIS_THETA in jr.origin:
            Ru = axis_rotation_oblique(jr, ar)
        else:
            Ru = axis_rotation(jr.axis if jr.dh is None else (0.0, 0.0, 1.0), ar)
        P = matmul(pre, Ru, ar.zero)
        if jr.origin is not None and MIMIC_OFFSET in jr.origin:  # q = m·q_master + o: Motion(o) joins P
            P = matmul(P, _motion_z(jr, jr.origin[MIMIC_OFFSET], ar), ar.zero)
        out.append((P, matmul(transpose(Ru), post, ar.zero)))
    return out


def _motion_z(jr, gv, ar: Arith):
    """Rz(o) (revolute) or Tz(o) (prismatic), 4x4, in the arithmetic ``ar``."""
    o, z = ar.one, ar.zero
    if jr.type == PRISMATIC:
        return [[o, z, z, z], [z, o, z, z], [z, z, o, ar.length(gv)], [z, z, z, o]]
    c, s = ar.cos_sin(gv)
    return [[c, -s, z, z], [s, c, z, z], [z, z, o, z], [z, z, z, o]]


class _RecordsOnly:
    """A description whose URDF axes read as exact integers (±e_k; an oblique axis, turned onto z
    by ``axis_rotation_oblique``, reads as e_z: ``joint_matrices`` only returns it)."""

    def __init__(self, desc):
        self.convention = desc.convention
        self.joints = tuple(_AxisInt(j) for j in desc.joints)


class _AxisInt:
    def __init__(self, jr):
        self._jr = jr
        self.axis = tuple(round(float(c)) for c in jr.axis) if is_frame_axis(jr.axis) else (0, 0, 1)

    def __getattr__(self, name):
        return getattr(self._jr, name)


# --- inertial parameters between frames ---------------------------------------


def params_to_frame(phi, T, zero):
    """Khalil's 10 parameters of a body given in frame B, expressed in frame A, x_A = T·x_B.

    c_A = R c_B + m p,  I_A = R I_B Rᵀ − S(Rc)S(p) − S(p)S(Rc) − m S(p)²  (S = skew)."""
    R = [row[:3] for row in T[:3]]
    p = [T[i][3] for i in range(3)]
    m = phi[M]
    I = [[phi[XX], phi[XY], phi[XZ]], [phi[XY], phi[YY], phi[YZ]], [phi[XZ], phi[YZ], phi[ZZ]]]
    Rc = matvec(R, [phi[MX], phi[MY], phi[MZ]], zero)
    c = [Rc[i] + m * p[i] for i in range(3)]
    RI = matmul(matmul(R, I, zero), transpose(R), zero)
    Sp, Sc = skew(p, zero), skew(Rc, zero)
    A = matmul(Sc, Sp, zero)
    B = matmul(Sp, Sc, zero)
    C = matmul(Sp, Sp, zero)
    J = [[RI[i][k] - A[i][k] - B[i][k] - m * C[i][k] for k in range(3)] for i in range(3)]
    return [J[0][0], J[0][1], J[0][2], J[1][1], J[1][2], J[2][2], c[0], c[1], c[2], m]


def transfer_matrix(T, ar: Arith):
    """The 10x10 matrix X(T) of ``params_to_frame`` (column k: the image of unit parameter k)."""
    cols = []
    for k in range(10):
        e = [ar.one if i == k else ar.zero for i in range(10)]
        cols.append(params_to_frame(e, T, ar.zero))
    return [[cols[k][i] for k in range(10)] for i in range(10)]


# --- the Lagrangian's coefficient functions at one state ----------------------


def energy_coefficients(desc, transforms, ar: Arith, cq, sq, q, qd, upto: int | None = None):
    """Per joint j, the 10 functions e with L_j = e · φ'_j for link j's parameters φ'_j in its
    joint frame J'_j = F_parent · P_j · Motion_z(q_j) (see ``joint_transforms``).

    cq, sq: cos and sin of each revolute joint's q (any numbers of the arithmetic with
    cq² + sq² = 1); q: each prismatic joint's q; qd: every joint's rate.  ``upto``: only the
    joints up to this index (a link's energy depends on its ancestors only)."""
    zero, one = ar.zero, ar.one
    g0 = ar.gravity()
    n = len(desc.joints)
    frames: list[Any] = [None] * n  # (R, o, omega, v) of F_j in the base frame
    out = []
    half = ar.const(Fraction(1, 2))
    for j, jr in enumerate(desc.joints):
        if upto is not None and j > upto:
            break
        P, A = transforms[j]
        if jr.parent < 0:
            R0 = [[one, zero, zero], [zero, one, zero], [zero, zero, one]]
            o0, w0, v0 = [zero] * 3, [zero] * 3, [zero] * 3
        else:
            R0, o0, w0, v0 = frames[jr.parent]
        RP = matmul(R0, [r[:3] for r in P[:3]], zero)
        oP = [o0[i] + sum((R0[i][k] * P[k][3] for k in range(3)), zero) for i in range(3)]
        z = [RP[i][2] for i in range(3)]
        if jr.type == PRISMATIC:
            RJ = RP
            oJ = [oP[i] + q[j] * z[i] for i in range(3)]
            w = w0
            wxr = cross(w0, [oJ[i] - o0[i] for i in range(3)])
            vJ = [v0[i] + wxr[i] + qd[j] * z[i] for i in range(3)]
        else:
            c, s = cq[j], sq[j]
            Rz = [[c, -s, zero], [s, c, zero], [zero, zero, one]]
            RJ = matmul(RP, Rz, zero)
            oJ = oP
            w = [w0[i] + qd[j] * z[i] for i in range(3)]
            wxr = cross(w0, [oJ[i] - o0[i] for i in range(3)])
            vJ = [v0[i] + wxr[i] for i in range(3)]
        # link-frame quantities of J'
        RJt = transpose(RJ)
        wl = matvec(RJt, w, zero)
        vl = matvec(RJt, vJ, zero)
        gl = matvec(RJt, g0, zero)
        vxw = cross(vl, wl)
        e = [half * wl[0] * wl[0], wl[0] * wl[1], wl[0] * wl[2], half * wl[1] * wl[1], wl[1] * wl[2], half * wl[2] * wl[2],
             vxw[0] + gl[0], vxw[1] + gl[1], vxw[2] + gl[2],
             half * sum((x * x for x in vl), zero) + sum((g0[i] * oJ[i] for i in range(3)), zero)]
        out.append(e)
        # F_j = J' · A
        RF = matmul(RJ, [r[:3] for r in A[:3]], zero)
        oF = [oJ[i] + sum((RJ[i][k] * A[k][3] for k in range(3)), zero) for i in range(3)]
        wxr = cross(w, [oF[i] - oJ[i] for i in range(3)])
        frames[j] = (RF, oF, w, [vJ[i] + wxr[i] for i in range(3)])
    return out
