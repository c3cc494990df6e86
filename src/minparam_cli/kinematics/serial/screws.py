"""Joint screws, singular positions and the nearest feasible twist (Glazunov 1985, paper 004).

Notation of the paper.  Joint i has the unit screw E_i with Plücker
coordinates (x_i, y_i, z_i; l_i, m_i, n_i) in the base frame: the unit axis
direction and its moment about the base origin (revolute joint), or
(0, 0, 0; direction) (prismatic joint).  The tool twist is the sum of the
joint screws times the joint rates (eq. 1), i.e. six linear equations whose
6 × n coefficient matrix is the paper's matrix (3):

    (dφ ; dS + r_c × dφ) = Σ E_i dφ_i                              (eq. 2)

dφ is the angular velocity, dS the velocity of the tool point O_c at r_c,
so dS + r_c × dφ is the velocity of the body point at the base origin.

Decisions (every tolerance is relative and reported):

* Singular position: the matrix is normalised (linear rows taken at O_c and
  divided by the chain's length scale L; prismatic columns multiplied by L)
  and its singular values divided by the largest.  The configuration is
  singular when σ_k/σ_1 ≤ ε with k = min(6, n), ε = ``DEFAULT_EPSILON``
  unless given.  The numerical rank is the number of σ_i/σ_1 > ε.
* Dependent joints: the paper's column-deletion test (joint i belongs when
  deleting its column leaves the rank unchanged).  Dependent groups: the
  minimal sets of k ≤ 6 screws lying in a (k-1)-system, found by testing
  column subsets against the same cut.  Their union equals the deletion set
  for n ≤ 6; the right null space (joint-rate combinations that give no
  tool motion) is reported with them, which covers rank drops above one.
* Held joints: n - rank joints of the dependent set are held at zero rate
  (the paper holds dφ6 = 0); the kept columns are a basis of the screw
  system.  The reciprocal screws H are computed from the kept columns, as
  the paper computes H from the five remaining screws, so the projected
  twist is reproduced exactly by the kept joints.

The matrix itself lives in ``plucker``, the control step (projection, joint
rates, the seeded nearest check) in ``nearest_twist``; callers import their
names from there.  Indices are 0-based here; renderers number joints from 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from itertools import chain as concatenated
from math import comb

import numpy as np

from minparam_cli.chain import Chain
from minparam_cli.errors import ComputationError, InputError
from minparam_cli.kinematics.defaults import DEFAULT_DAMPING, DEFAULT_EPSILON
from minparam_cli.kinematics.serial.nearest_twist import (
    TwistSolution,
    solve_twist,
)
from minparam_cli.kinematics.serial.plucker import (
    ReciprocalScrew,
    ZERO_COMPONENT,
    column_scale,
    normalised_matrices,
    plucker_matrices,
    require_serial,
)

TIE_RTOL = 1e-9
"""Conditioning scores equal to this relative tolerance are a tie; the later joint is held."""


# --- result records -------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class RankTest:
    """The local test: relative singular values, rank and the margin of the decision."""

    singular_values: np.ndarray  # σ_i / σ_max, descending, min(6, n) of them
    epsilon: float
    rank: int
    full_rank: int  # min(6, n)
    det: float | None  # det of matrix (3) in SI units, six joints only

    @property
    def sigma_min(self) -> float:
        return float(self.singular_values[self.full_rank - 1])

    @property
    def singular(self) -> bool:
        return self.rank < self.full_rank

    @property
    def cut_ratio(self) -> float | None:
        """σ_rank / σ_rank+1 across the cut (how clear the rank decision was); None when not singular."""
        if not self.singular:
            return None
        below = float(self.singular_values[self.rank])
        return float("inf") if below == 0 else float(self.singular_values[self.rank - 1]) / below


@dataclass(frozen=True, eq=False)
class SingularReport:
    """Everything the local analysis finds at one configuration."""

    robot: str
    source: str
    joint_names: tuple[str, ...]
    types: tuple[str, ...]
    q: np.ndarray  # rad / m
    tool_point: np.ndarray  # O_c in the base frame, m
    length_scale: float  # L, m
    plucker: np.ndarray  # (6, n) matrix (3), moments about the base origin
    test: RankTest
    deletion_ranks: tuple[int, ...]  # rank of the matrix with column i deleted
    dependent_joints: tuple[int, ...]
    groups: tuple[tuple[int, ...], ...]
    null_space: np.ndarray  # (n, n - rank) joint-rate combinations giving no tool motion
    held_joints: tuple[int, ...]
    reciprocal: tuple[ReciprocalScrew, ...]
    twist: TwistSolution | None
    notes: tuple[str, ...]

    @property
    def singular(self) -> bool:
        return self.test.singular


# --- numerical helpers ---------------------------------------------------------------


def _rank(M: np.ndarray, cut: float) -> int:
    if M.shape[1] == 0:
        return 0
    return int(np.sum(np.linalg.svd(M, compute_uv=False) > cut))


def _sigma_k(M: np.ndarray, k: int) -> float:
    """k-th largest singular value (1-based), 0 when there are fewer."""
    s = np.linalg.svd(M, compute_uv=False)
    return float(s[k - 1]) if 0 < k <= s.size else 0.0


MAX_GROUP_SETS = 2_000_000  # sets dependent_groups tests at most (34 joints, sizes up to 6: 1.7 M sets, 12 s)
SVD_BATCH = 50_000  # sets whose singular values one numpy call computes (50,000 x 6 x 6: 14 MB)


def group_sets(n: int, max_size: int = 6) -> int:
    """How many sets of 1..max_size of n joints ``dependent_groups`` tests."""
    return sum(comb(n, k) for k in range(1, min(max_size, n) + 1))


def group_search_size(n: int, max_size: int = 6) -> int:
    """The largest group size up to ``max_size`` whose search over n joints stays within MAX_GROUP_SETS sets."""
    return max([k for k in range(1, max_size + 1) if group_sets(n, k) <= MAX_GROUP_SETS] or [1])


def _set_codes(sets: np.ndarray, n: int) -> np.ndarray:
    """One number per row of sorted joint indices (rows of one length): Σ S[i]·n^i."""
    return sets @ (n ** np.arange(sets.shape[1], dtype=np.int64))


def dependent_groups(Jn: np.ndarray, cut: float, max_size: int = 6) -> tuple[tuple[int, ...], ...]:
    """Minimal sets of k ≤ max_size columns with rank k - 1 (the paper's k screws in a (k-1)-system).

    Every set of k columns is tested (σ_k ≤ cut), in batches of SVD_BATCH sets a numpy call, and a
    dependent set is kept when none of its proper subsets was kept before (looked up by number, all
    the dependent sets of one size at once).  The sets grow as n^6: on chains with more than
    MAX_GROUP_SETS of them (35 joints and more) the search stops at ``group_search_size`` (the caller
    says so); an 18-joint arm at a configuration with many small groups took 29 s when each set was
    compared with every group found, 0.6 s now."""
    n = Jn.shape[1]
    max_size = min(max_size, group_search_size(n, max_size))
    found: list[tuple[int, ...]] = []
    codes: dict[int, np.ndarray] = {}  # per size, the groups found as numbers Σ S[i]·n^i (< n^6: int64 up to 1,500 joints)
    for k in range(1, min(max_size, n) + 1):
        count = comb(n, k)
        sets = np.fromiter(concatenated.from_iterable(combinations(range(n), k)), dtype=np.int64, count=count * k).reshape(count, k)
        hit = []
        for b0 in range(0, len(sets), SVD_BATCH):
            idx = sets[b0 : b0 + SVD_BATCH]
            s = np.linalg.svd(Jn[:, idx].transpose(1, 0, 2), compute_uv=False)  # (sets, 6, k): σ in descending order
            hit.append(b0 + np.flatnonzero(s[:, k - 1] <= cut))
        dependent = sets[np.concatenate(hit)]
        known = np.zeros(len(dependent), dtype=bool)  # holds a smaller group already found: not minimal
        for size, groups in codes.items():
            for part in combinations(range(k), size):
                known |= np.isin(_set_codes(dependent[:, part], n), groups)
        new = dependent[~known]
        if len(new):
            found += [tuple(int(j) for j in S) for S in new]
            codes[k] = _set_codes(new, n)
    return tuple(found)


def deletion_test(Jn: np.ndarray, cut: float, rank: int) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """The paper's test: the rank after deleting each column, and the columns whose deletion keeps it."""
    n = Jn.shape[1]
    ranks = tuple(_rank(np.delete(Jn, i, axis=1), cut) for i in range(n))
    return ranks, tuple(i for i in range(n) if ranks[i] == rank)


def choose_held(Jn: np.ndarray, candidates: tuple[int, ...], rank: int, cut: float) -> tuple[int, ...]:
    """Hold n - rank joints from ``candidates`` so that the kept columns are the best-conditioned basis.

    Greedy: each step holds the candidate whose removal leaves the largest σ_rank; on a tie
    (``TIE_RTOL``) the later joint is held, as the paper holds dφ6.
    """
    kept = list(range(Jn.shape[1]))
    held: list[int] = []
    while len(kept) > rank:
        scores = {}
        for c in candidates:
            if c in kept:
                score = _sigma_k(Jn[:, [k for k in kept if k != c]], rank)
                if score > cut:
                    scores[c] = score
        if not scores:
            raise ComputationError("no joint of the dependent group can be held without losing rank")
        top = max(scores.values())
        best = max(c for c, v in scores.items() if v >= top * (1 - TIE_RTOL))
        kept.remove(best)
        held.append(best)
    return tuple(sorted(held))


def reciprocal_screws(
    chain: Chain, Jn_kept: np.ndarray, c: np.ndarray, L: float
) -> tuple[ReciprocalScrew, ...]:
    """Screws reciprocal to the kept columns: the left null space of the normalised matrix.

    For u with uᵀ·Jn = 0, the wrench (h0_c; h) = (u_w; u_v / L) annihilates every feasible
    twist at O_c: h0_c·w + h·v_c = 0.  About the base origin h0 = h0_c + r_c × h.
    """
    r = Jn_kept.shape[1]
    if r >= 6:
        return ()
    U, _, _ = np.linalg.svd(Jn_kept, full_matrices=True) if r else (np.eye(6), None, None)
    out = []
    for k in range(r, 6):
        u = U[:, k]
        uw, uv = u[:3].copy(), u[3:].copy()
        if np.linalg.norm(uw) <= ZERO_COMPONENT:
            uw[:] = 0.0
        if np.linalg.norm(uv) <= ZERO_COMPONENT:
            h = np.zeros(3)
            h0c = uw / np.linalg.norm(uw)
            kind, pitch, point = "couple", float("inf"), None
            h0 = h0c.copy()
        else:
            h = uv / L
            h0c = uw
            scale = np.linalg.norm(h)
            h, h0c = h / scale, h0c / scale
            h0 = h0c + np.cross(c, h)
            pitch = float(h @ h0)
            point = np.cross(h, h0)
            kind = "force" if abs(pitch) <= ZERO_COMPONENT * L else "screw"
        lead = np.concatenate([h, h0]) if kind != "couple" else h0
        sign = np.sign(lead[np.argmax(np.abs(lead))]) or 1.0
        out.append(
            ReciprocalScrew(
                plucker=sign * np.concatenate([h, h0]) + 0.0,
                moment_at_tool=sign * h0c + 0.0,
                kind=kind,
                pitch=pitch,
                axis_point=point,
            )
        )
    return tuple(out)


# --- the analysis -----------------------------------------------------------------------


def analyse(
    chain: Chain,
    q,
    twist=None,
    epsilon: float = DEFAULT_EPSILON,
    hold: tuple[int, ...] | None = None,
    damping: float = DEFAULT_DAMPING,
) -> SingularReport:
    """Glazunov's local test and control step at one configuration q (rad / m).

    ``twist`` (6,) is the requested (w; v at O_c).  ``hold`` (0-based) overrides
    the held joints; they must be n - rank joints of the dependent set.
    """
    require_serial(chain)
    if not 0 < epsilon < 1:
        raise InputError(f"epsilon must lie in (0, 1), got {epsilon}")
    if not damping >= 0:
        raise InputError(f"damping must be non-negative, got {damping}")
    q = np.asarray(q, dtype=float).reshape(-1)
    n = chain.n
    if q.size != n:
        raise InputError(f"expected {n} joint values for {chain.name}, got {q.size}")
    if not np.all(np.isfinite(q)):
        raise InputError("joint values must be finite")
    L = float(chain.length_scale)
    J0, c = plucker_matrices(chain, q[None])
    J0, c = J0[0], c[0]
    Jn = normalised_matrices(chain, J0, c, L)
    k_full = min(6, n)
    U, s, Vt = np.linalg.svd(Jn)
    smax = float(s[0])
    if smax == 0:
        raise ComputationError("every joint screw vanishes; nothing to analyse")
    rel = s[:k_full] / smax
    cut = epsilon * smax
    rank = int(np.sum(s > cut))
    det = float(np.linalg.det(J0)) if n == 6 else None
    test = RankTest(singular_values=rel, epsilon=epsilon, rank=rank, full_rank=k_full, det=det)
    notes: list[str] = []

    groups = dependent_groups(Jn, cut)
    searched = group_search_size(n)
    if searched < min(6, n):
        notes.append(f"groups of more than {searched} joints not searched: {n} joints have "
                     f"{group_sets(n):,} sets of up to 6 (at most {MAX_GROUP_SETS:,} are tested)")
    ranks, deleted = deletion_test(Jn, cut, rank)
    if n <= 6:
        dependent = deleted
        if set(dependent) != {j for g in groups for j in g}:
            notes.append("the column-deletion test and the minimal groups disagree near the cut; both reported")
    else:
        dependent = tuple(sorted({j for g in groups for j in g}))
    if test.singular and k_full - rank > 1:
        notes.append(
            f"rank drops by {k_full - rank}: the dependent set may join several groups; "
            "the null space gives the joint-rate combinations"
        )
    if n > 6 and groups and not test.singular:
        notes.append("a group of screws is dependent, but the redundant arm keeps full rank")
    cs = column_scale(chain, L)
    null = (Vt[rank:].T * cs[:, None]) if rank < n else np.zeros((n, 0))

    # held joints and the kept basis
    if hold is not None:
        held = tuple(sorted(set(hold)))
        if any(not 0 <= h < n for h in held):
            raise InputError(f"held joints must be numbered 1..{n}")
        if not test.singular:
            raise InputError("--hold applies only at a singular position; this configuration has full rank")
        if len(held) != n - rank:
            raise InputError(f"hold exactly {n - rank} joint(s) at rank {rank}, got {len(held)}")
        kept = [j for j in range(n) if j not in held]
        if _rank(Jn[:, kept], cut) < rank:
            names = ", ".join(str(j + 1) for j in dependent)
            raise InputError(f"holding joint(s) {', '.join(str(h + 1) for h in held)} loses rank; hold joints from {{{names}}}")
    elif test.singular:
        held = choose_held(Jn, dependent if n <= 6 else tuple(range(n)), rank, cut)
    else:
        held = ()
    kept = [j for j in range(n) if j not in held]
    use_basis = test.singular or n <= 6
    screws = reciprocal_screws(chain, Jn[:, kept], c, L) if use_basis else ()

    solution = None
    if twist is not None:
        T = np.asarray(twist, dtype=float).reshape(-1)
        if T.size != 6 or not np.all(np.isfinite(T)):
            raise InputError("the twist needs six finite numbers wx,wy,wz,vx,vy,vz")
        solution = solve_twist(chain, J0, Jn, c, L, U, s, Vt, rank, kept, use_basis, screws, T, damping)

    return SingularReport(
        robot=chain.name,
        source=chain.source,
        joint_names=chain.joint_names,
        types=chain.types,
        q=q,
        tool_point=c,
        length_scale=L,
        plucker=J0,
        test=test,
        deletion_ranks=ranks,
        dependent_joints=tuple(dependent),
        groups=groups,
        null_space=null,
        held_joints=held,
        reciprocal=screws,
        twist=solution,
        notes=tuple(notes),
    )


__all__ = [
    "RankTest",
    "SingularReport",
    "analyse",
    "choose_held",
    "deletion_test",
    "dependent_groups",
    "reciprocal_screws",
]
