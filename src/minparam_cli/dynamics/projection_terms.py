"""Method of projections, part 1: trigonometric decomposition of the joint transforms.

Krutikov (2011), paper 000, eq. (1): every joint transform is a sum of constant
matrices times the functions of one joint coordinate in X_k.  The chain model
writes a joint as A(q) = Pre · Motion(q) · Post with an arbitrary unit axis k
(K = [k]x its cross-product matrix), so for any joint the chain allows (DH,
MDH, URDF):

* revolute, Motion = E + sin q K + (1 - cos q) K² (Rodrigues):

      A = A¹ + A² cos q + A³ sin q,
      A¹ = Pre [E+K² 0; 0 1] Post,  A² = Pre [-K² 0; 0 0] Post,  A³ = Pre [K 0; 0 0] Post;

* prismatic, Motion = [E q k; 0 1]:

      A = A¹ + A² q,  A¹ = Pre Post,  A² = Pre [0 k; 0 0] Post.

The derivative dA/dq in the same basis is (0, A³, -A²) for a revolute joint
and (A², 0) for a prismatic one (the paper's D_k A_k).

Products of two such expansions are re-expanded in Y_k (eq. 12-13, with the
paper's preferred basis): Y = {1, cos, sin, cos², sin cos} for a revolute
joint, where sin·sin = 1 - cos²; Y = {1, q, q²} for a prismatic one.  Matrix
factors keep their order.

Every recursion step of the paper has the form X' = Σ c_ab (Lᵃ)ᵀ X Rᵇ.  For a
batch of 4x4 matrices stored as the columns of a (16, n) array (row-major
vec), that is one constant (16·|Y|) x 16 matrix times the batch (see
:func:`kron_map`), so the whole recursion is a short sequence of matrix
products.

Exact mode: when ``chain.exact`` holds rational geometry with right angles,
the lengths are rescaled by the least common denominator λ (and gravity by
its own), which makes every matrix an integer matrix.  The recursion then
runs on integers held in float64 while a bound proves every intermediate
below 2**53 (so no rounding happens), else on Python integers.  Rescaling
the length unit only rescales rows and columns of Z (see ``column_scales``).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from math import lcm

import numpy as np

from minparam_cli.chain import PRISMATIC, REVOLUTE, Chain

# number of functions in X_k (transform: 1, cos, sin or 1, q) and Y_k (products of two transforms:
# 1, cos, sin, cos², sin·cos or 1, q, q²)
X_SIZE = {REVOLUTE: 3, PRISMATIC: 2}
Y_SIZE = {REVOLUTE: 5, PRISMATIC: 3}

# x^a x^b = Σ coef y^c  (eq. 12-13): (a, b) -> ((c, coef), ...)
PRODUCT_RULES: dict[str, dict[tuple[int, int], tuple[tuple[int, int], ...]]] = {
    REVOLUTE: {
        (0, 0): ((0, 1),),
        (0, 1): ((1, 1),),
        (1, 0): ((1, 1),),
        (0, 2): ((2, 1),),
        (2, 0): ((2, 1),),
        (1, 1): ((3, 1),),
        (1, 2): ((4, 1),),
        (2, 1): ((4, 1),),
        (2, 2): ((0, 1), (3, -1)),  # sin² = 1 - cos²
    },
    PRISMATIC: {
        (0, 0): ((0, 1),),
        (0, 1): ((1, 1),),
        (1, 0): ((1, 1),),
        (1, 1): ((2, 1),),
    },
}

FLOAT_EXACT_LIMIT = float(2**53)  # integers below this are exact in float64


class InexactFloat(Exception):
    """An integer computation held in float64 could exceed 2**53: redo it with Python integers."""


@dataclass(frozen=True)
class JointTerms:
    """The expansion of one joint transform and of its derivative on X_k."""

    kind: str
    A: tuple  # |X_k| constant 4x4 matrices
    D: tuple  # |X_k| constant 4x4 matrices or None where the term vanishes


def _skew(k, zero):
    return [[zero, -k[2], k[1]], [k[2], zero, -k[0]], [-k[1], k[0], zero]]


def _block(R3, t3, corner, dtype, zero):
    m = np.full((4, 4), zero, dtype=dtype)
    for i in range(3):
        for j in range(3):
            m[i, j] = R3[i][j]
        m[i, 3] = t3[i]
    m[3, 3] = corner
    return m


def joint_terms(kind: str, pre: np.ndarray, axis, post: np.ndarray) -> JointTerms:
    """Trigonometric decomposition of A(q) = Pre · Motion(q) · Post (eq. 1), any unit axis.

    Works on float arrays and on object arrays of Fractions alike.
    """
    dtype = pre.dtype
    zero = pre[3, 0] * 0
    one = zero + 1
    k = list(axis)
    K = _skew(k, zero)
    K2 = [[sum((K[i][m] * K[m][j] for m in range(3)), zero) for j in range(3)] for i in range(3)]
    E3 = [[one if i == j else zero for j in range(3)] for i in range(3)]
    z3 = [zero, zero, zero]
    motions: tuple[np.ndarray, ...]
    D: tuple[np.ndarray | None, ...]
    if kind == REVOLUTE:
        motions = (
            _block([[E3[i][j] + K2[i][j] for j in range(3)] for i in range(3)], z3, one, dtype, zero),
            _block([[-K2[i][j] for j in range(3)] for i in range(3)], z3, zero, dtype, zero),
            _block(K, z3, zero, dtype, zero),
        )
    elif kind == PRISMATIC:
        motions = (
            _block(E3, z3, one, dtype, zero),
            _block([[zero] * 3 for _ in range(3)], k, zero, dtype, zero),
        )
    else:
        raise ValueError(f"unknown joint type {kind!r}")
    A = tuple(pre @ m @ post for m in motions)
    if kind == REVOLUTE:
        D = (None, A[2], -A[1])
    else:
        D = (A[1], None)
    return JointTerms(kind, A, D)


def kron_map(kind: str, L: tuple, R: tuple, dtype) -> np.ndarray:
    """The matrix of X -> Σ_ab (Lᵃ)ᵀ X Rᵇ x^a x^b, re-expanded on Y (eq. 13).

    Returns M with shape (|Y|·16, 16): for a batch X stored as (16, n) columns
    (row-major vec of each 4x4 matrix), ``(M @ X).reshape(|Y|, 16, n)[c]`` is
    the coefficient on y^c.  vec(Lᵀ X R)[4a+b] = Σ_rs L[r,a] R[s,b] X[r,s].
    """
    nY = Y_SIZE[kind]
    M = np.zeros((nY, 16, 16), dtype=dtype)
    if np.dtype(dtype).kind == "O":  # sympy entries: zeros as Python ints, not None
        M[...] = 0
    for (a, b), targets in PRODUCT_RULES[kind].items():
        if L[a] is None or R[b] is None:
            continue
        kab = np.einsum("ra,sb->abrs", L[a], R[b]).reshape(16, 16)
        for c, coef in targets:
            M[c] += coef * kab
    return M.reshape(nY * 16, 16)


def constant_map(kind: str, A: tuple, dtype) -> np.ndarray:
    """16x16 matrix of X -> the y = 1 coefficient of Aᵀ X A (the C⁰ map)."""
    return kron_map(kind, A, A, dtype)[:16]


def potential_map(A: tuple, dtype) -> np.ndarray:
    """Matrix of v -> ((Aᶜ)ᵀ v)_c for row vectors v = g̃ᵀ T stored as (4, n) columns: (|X|·4, 4)."""
    return np.concatenate([np.asarray(a, dtype=dtype).T for a in A], axis=0)


# parameter extraction: 2 <H, G> as a linear map of vec(G), for the 10 parameters of one link
def phi_matrix(dtype) -> np.ndarray:
    """(10, 16): 2·⟨H(p), G⟩ = p · (Φ vec G), H the pseudo-inertia [J s; sᵀ m] with J = tr(I)/2 E - I.

    Rows in parameter order XX XY XZ YY YZ ZZ MX MY MZ M; tensor entries, so
    J_xy = -XY.  The factor 2 keeps every entry an integer.
    """
    P = np.zeros((10, 16), dtype=dtype)
    if np.dtype(dtype).kind == "O":  # sympy entries: zeros as Python ints, not None
        P[...] = 0

    def g(a, b):
        return 4 * a + b

    # XX: -G11 + G22 + G33 ; YY: G11 - G22 + G33 ; ZZ: G11 + G22 - G33
    for row, signs in ((0, (-1, 1, 1)), (3, (1, -1, 1)), (5, (1, 1, -1))):
        for a, s in enumerate(signs):
            P[row, g(a, a)] = s
    for row, (a, b) in ((1, (0, 1)), (2, (0, 2)), (4, (1, 2))):
        P[row, g(a, b)] = -2
        P[row, g(b, a)] = -2
    for row, a in ((6, 0), (7, 1), (8, 2)):
        P[row, g(a, 3)] = 2
        P[row, g(3, a)] = 2
    P[9, g(3, 3)] = 2
    return P


# symmetric coordinates of a 4x4 matrix: the diagonal, then G_ab + G_ba for a < b
SYM_PAIRS: tuple[tuple[int, int], ...] = tuple((a, a) for a in range(4)) + tuple(
    (a, b) for a in range(4) for b in range(a + 1, 4)
)


def sym_matrix(dtype) -> np.ndarray:
    """(10, 16): vec(G) -> (G11, G22, G33, G44, G12+G21, G13+G31, G14+G41, G23+G32, G24+G42, G34+G43)."""
    S = np.zeros((10, 16), dtype=dtype)
    if np.dtype(dtype).kind == "O":  # sympy entries: zeros as Python ints, not None
        S[...] = 0
    for i, (a, b) in enumerate(SYM_PAIRS):
        S[i, 4 * a + b] = 1
        S[i, 4 * b + a] = 1
    return S


@dataclass(frozen=True, eq=False)
class ProjectionGeometry:
    """Everything the recursion needs, in one arithmetic (float, or exact integers)."""

    chain: Chain
    exact: bool
    dtype: type  # np.float64 or object (Python integers)
    terms: tuple[JointTerms, ...]
    maps: tuple[dict[str, np.ndarray], ...]  # per joint: AA, DA, AD, DD (|Y|·16 x 16), A0 (16x16), X (|X|·4 x 4)
    gravity: np.ndarray  # (4,) g̃ = (g, 0), scaled in exact mode
    length_scale: Fraction  # λ: lengths are in units of 1/λ m (1 in float mode)
    kinetic_scale: int  # kinetic rows hold this multiple of the Lagrangian coordinates
    potential_scale: Fraction  # potential rows hold this multiple (of the rescaled Lagrangian)

    @property
    def n(self) -> int:
        return self.chain.n

    def column_scales(self) -> list[Fraction]:
        """s_c with p'_c = s_c p_c: the parameters in the rescaled unit system.

        Z' (rescaled units) = rows · Z_SI · diag(λ²/s_c), so a column relation
        Z'_d = Σ β'_k Z'_k becomes β_k = β'_k s_d / s_k in SI.
        """
        lam = self.length_scale
        s = []
        for _ in range(self.n):
            s += [lam**2] * 6 + [lam] * 3 + [Fraction(1)]
        for j, kind in self.chain.layout.extra_columns:
            rev = self.chain.types[j] == REVOLUTE
            if kind in ("rotor_inertia", "offset"):
                s.append(lam**2 if rev else (Fraction(1) if kind == "rotor_inertia" else lam))
            else:
                s.append(Fraction(1))
        return s


def _maps(terms: JointTerms, dtype) -> dict[str, np.ndarray]:
    A, D, kind = terms.A, terms.D, terms.kind
    return {
        "AA": kron_map(kind, A, A, dtype),
        "DA": kron_map(kind, D, A, dtype),
        "AD": kron_map(kind, A, D, dtype),
        "DD": kron_map(kind, D, D, dtype),
        "A0": constant_map(kind, A, dtype),
        "X": potential_map(A, dtype),
    }


def float_geometry(chain: Chain) -> ProjectionGeometry:
    """Floating-point geometry in SI units."""
    terms = tuple(
        joint_terms(chain.types[j], chain.pre[j].astype(float), chain.axes[j], chain.post[j].astype(float))
        for j in range(chain.n)
    )
    return ProjectionGeometry(
        chain=chain,
        exact=False,
        dtype=np.float64,
        terms=terms,
        maps=tuple(_maps(t, np.float64) for t in terms),
        gravity=np.concatenate([np.asarray(chain.gravity, dtype=float), [0.0]]),
        length_scale=Fraction(1),
        kinetic_scale=2,
        potential_scale=Fraction(1),
    )


def _decimal(x: float) -> Fraction:
    return Fraction(repr(float(x)))


def exact_geometry(chain: Chain, python_ints: bool = False) -> ProjectionGeometry:
    """Integer geometry from ``chain.exact``: lengths in units of 1/λ m, λ the common denominator.

    With ``python_ints`` every array holds Python integers (dtype object);
    otherwise float64 holding integers, which the recursion guards against
    exceeding 2**53.
    """
    if chain.exact is None:
        raise ValueError("chain has no exact geometry")
    dens = [1]
    for pre, _, post in chain.exact:
        for m in (pre, post):
            dens += [Fraction(m[i][3]).denominator for i in range(3)]
    lam = lcm(*dens)
    grav = [_decimal(g) for g in chain.gravity]
    gam = lcm(*[g.denominator for g in grav])
    terms = []
    for j, (pre, axis, post) in enumerate(chain.exact):
        mats = []
        for m in (pre, post):
            a = np.empty((4, 4), dtype=object)
            for r in range(4):
                for c in range(4):
                    v = Fraction(m[r][c])
                    a[r, c] = v * lam if (c == 3 and r < 3) else v
            mats.append(a)
        t = joint_terms(chain.types[j], mats[0], [Fraction(x) for x in axis], mats[1])
        terms.append(t)
    # every entry is now an integer
    ints = []
    for t in terms:
        ints.append(
            JointTerms(t.kind, tuple(_to_int(a) for a in t.A), tuple(None if d is None else _to_int(d) for d in t.D))
        )
    gravity = np.array([int(g * gam * lam) for g in grav] + [0], dtype=object)
    biggest = max(max(abs(int(x)) for x in a.ravel()) for t in ints for a in t.A)
    dtype = object if (python_ints or biggest >= FLOAT_EXACT_LIMIT) else np.float64
    if dtype is np.float64:
        ints = [
            JointTerms(t.kind, tuple(a.astype(np.float64) for a in t.A), tuple(None if d is None else d.astype(np.float64) for d in t.D))
            for t in ints
        ]
        gravity = gravity.astype(np.float64)
    return ProjectionGeometry(
        chain=chain,
        exact=True,
        dtype=dtype,
        terms=tuple(ints),
        maps=tuple(_maps(t, dtype) for t in ints),
        gravity=gravity,
        length_scale=Fraction(lam),
        kinetic_scale=2,
        potential_scale=Fraction(gam),
    )


def _to_int(a: np.ndarray) -> np.ndarray:
    out = np.empty(a.shape, dtype=object)
    for idx, v in np.ndenumerate(a):
        v = Fraction(v)
        if v.denominator != 1:
            raise ValueError(f"geometry entry {v} is not an integer after rescaling")
        out[idx] = int(v)
    return out
