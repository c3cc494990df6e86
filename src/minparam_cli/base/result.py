"""The result every base-parameter route returns, and the keep rule they share."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from minparam_cli.params import split_name

if TYPE_CHECKING:
    import numpy as np

    from minparam_cli.base.report import Derivation

# entries of the normalised regrouping matrix below this are rounding noise
COEFFICIENT_CUTOFF = 1e-10
# The rank cut of both numeric routes (docs/methods/qr.md, "The rank cut"): with every column in
# physical units, lengths in units of the robot's size (``physical_scales``), a column is kept when
# its part orthogonal to the kept columns before it exceeds RANK_RTOL times the largest column.
# Rounding leaves ~1e-13 on exactly dependent columns (69 real URDFs); any real effect above
# 1e-8 of the largest is kept, those below WEAK_RTOL only where no full-size column later in the
# scan carries the same direction (``scan_in_order``).
RANK_RTOL = 1e-8
# kept parameters whose relative residual is below this are weakly identifiable: they are
# named with their margin and, where one is found, the near-special geometry that keeps them
WEAK_RTOL = 1e-4
# A column smaller than the cut cannot be kept, but it is not "without effect" when its size is a
# real effect (above SMALL_RTOL of the largest column: rounding leaves ~1e-16 on a zero column)
# that the kept columns reproduce to REGROUP_RTOL of its own size: it regroups with its β (icub's
# left_hand_mk3, XY4 YZ4 XY5 YZ5 at 2e-9..1e-8 in SI units, reproduced to 1e-15: docs/methods/qr.md,
# "Small columns").  Those the kept columns do not reproduce are below the cut and have no effect.
SMALL_RTOL = 1e-12
REGROUP_RTOL = 1e-6
# β is accurate to ~1e-13 relative; 12 significant digits drop only rounding noise (1 - 2e-16 -> 1)
BETA_DIGITS = 12


@dataclass(frozen=True, eq=False)
class BaseSet:
    """Base (minimal) parameters of a chain: ``beta_base = K @ phi`` for standard parameters ``phi``.

    ``K`` has one row per base parameter; row i holds 1 at column ``kept[i]`` and the regrouping
    coefficients on the ``dependent`` columns (base = kept + β·dependent).  ``kept``, ``dependent``
    and ``unidentifiable`` (no effect at all) are column numbers in ``standard_names`` (their names:
    ``kept_names``, ``dependent_names``, ``unidentifiable_names``).  ``names[i]`` is base parameter
    i (Khalil's: XXR2 when it regroups others), ``terms[i]`` its coefficients by standard name,
    ``expressions[i]`` its regrouping as text (``"ZZ1 - M1 - M2"``, in the geometry symbols when
    derived with ``symbolic=True``); ``beta`` the coefficients on the dependent columns.

    A base set from ``derive`` also carries its ``derivation`` (the robot, notes, weakly
    identifiable parameters, symbolic set): ``to_dict()`` is then ``minparam derive``'s JSON and
    ``table()``, ``markdown()``, ``latex()`` its other formats.
    """

    standard_names: tuple[str, ...]
    kept: tuple[int, ...]
    K: np.ndarray = field(repr=False)  # (n_base, n_standard)
    unidentifiable: tuple[int, ...]  # columns with no effect at all
    method: str
    rank_margin: dict = field(repr=False)
    exact: bool = False
    seed: int | None = None
    samples: int | None = None
    elapsed_s: float = 0.0
    extra: dict = field(default_factory=dict, repr=False)
    K_exact: tuple | None = field(default=None, repr=False)  # rows of Fractions in exact mode
    derivation: Derivation | None = field(default=None, repr=False)

    @property
    def n_base(self) -> int:
        return len(self.kept)

    @property
    def n_standard(self) -> int:
        return len(self.standard_names)

    @property
    def dependent(self) -> tuple[int, ...]:
        """Columns that are neither kept nor without effect: they regroup."""
        skip = set(self.kept) | set(self.unidentifiable)
        return tuple(i for i in range(self.n_standard) if i not in skip)

    @property
    def beta(self) -> np.ndarray:
        """β with base = kept + β · dependent (rows: base params, columns: ``dependent``)."""
        return self.K[:, list(self.dependent)]

    @property
    def kept_names(self) -> tuple[str, ...]:
        return tuple(self.standard_names[i] for i in self.kept)

    @property
    def dependent_names(self) -> tuple[str, ...]:
        return tuple(self.standard_names[i] for i in self.dependent)

    @property
    def unidentifiable_names(self) -> tuple[str, ...]:
        return tuple(self.standard_names[i] for i in self.unidentifiable)

    @property
    def base_names(self) -> tuple[str, ...]:
        """Khalil-style names: XXR2 when a parameter regroups others, plain XX2 otherwise."""
        import numpy as np

        out = []
        for i, col in enumerate(self.kept):
            name = self.standard_names[col]
            row = self.K[i].copy()
            row[col] = 0.0
            if np.any(row != 0):
                kind, link = split_name(name)
                name = f"{kind}R{link}"
            out.append(name)
        return tuple(out)

    @property
    def names(self) -> tuple[str, ...]:
        """The base parameters' names (``base_names``)."""
        return self.base_names

    @property
    def terms(self) -> tuple[dict[str, float], ...]:
        """{standard name: coefficient} of each base parameter, kept parameter first."""
        import numpy as np

        out = []
        for i, col in enumerate(self.kept):
            row = {self.standard_names[col]: float(self.K[i, col])}
            for c in np.flatnonzero(self.K[i]):
                if c != col:
                    row[self.standard_names[c]] = float(self.K[i, c])
            out.append(row)
        return tuple(out)

    @property
    def numeric_expressions(self) -> tuple[str, ...]:
        """Each base parameter's regrouping as text with the numeric coefficients."""
        from minparam_cli.base.report import expression

        return tuple(expression(t) for t in self.terms)

    @property
    def expressions(self) -> tuple[str, ...]:
        """Each base parameter's regrouping as text: in the geometry symbols where the derivation has a
        symbolic set for the file's geometry, else with the numeric coefficients."""
        d = self.derivation
        numeric = self.numeric_expressions
        if d is None or d.symbolic is None or d.symbolic.parameters is None:
            return numeric
        return tuple(s.get("symbolic") or e for s, e in zip(d.symbolic.parameters, numeric, strict=True))

    @property
    def robot(self) -> str:
        return self.derivation.about.robot if self.derivation is not None else ""

    @property
    def warnings(self) -> tuple[str, ...]:
        return self.derivation.warnings if self.derivation is not None else ()

    def to_dict(self) -> dict:
        """``minparam derive --format json`` (a new dict each call)."""
        from minparam_cli.base.report import report_dict

        return report_dict(self)

    def table(self) -> str:
        """``minparam derive`` (the terminal table)."""
        from minparam_cli.base.text import table

        return table(self)

    def markdown(self) -> str:
        """``minparam derive --format markdown``."""
        from minparam_cli.base.text import markdown

        return markdown(self)

    def latex(self) -> str:
        """The base parameters as a LaTeX ``align*`` block (``minparam derive --format latex``)."""
        from minparam_cli.base.text import latex

        return latex(self)


def physical_scales(layout, types, length: float, row_types=None) -> tuple[np.ndarray, np.ndarray]:
    """Column and per-joint row factors that put the regressor in physical units with lengths in
    units of ``length`` (L, the robot's size), masses in kg and time in s.

    Column c is multiplied by u_c / L² with u_c the unit of its parameter in those units
    (inertia and revolute rotor inertia kg·L² -> 1, first moment kg·L -> 1/L, mass and prismatic
    rotor inertia kg -> 1/L², friction and offset of a prismatic joint kg·L/s² -> 1/L, of a
    revolute joint 1); joint k's rows by L² / v_k (revolute torque kg·L²/s² -> 1, prismatic
    force kg·L/s² -> L).  So a mass whose only effect is a² times an inertia's (a point mass at
    distance a from an axis) has relative size (a/L)², not 1 as after scaling columns to unit norm.
    ``types``: of every joint (the extras' columns); ``row_types``: of the regressor's rows, the
    independent coordinates when some joints mimic others (default: ``types``).
    """
    import numpy as np

    L = float(length) if length > 0 else 1.0
    col = []
    for _ in layout.links_with_columns:
        col += [1.0] * 6 + [1.0 / L] * 3 + [1.0 / L**2]
    for j, kind in layout.extra_columns:
        rev = types[j] == "revolute"
        if kind == "rotor_inertia":
            col.append(1.0 if rev else 1.0 / L**2)
        else:
            col.append(1.0 if rev else 1.0 / L)
    row = np.array([1.0 if t == "revolute" else L for t in (types if row_types is None else row_types)])
    return np.array(col), row


def scan_in_order(A: np.ndarray, rel: np.ndarray, block: int = 64) -> tuple[list[int], np.ndarray]:
    """The keep rule of both numeric routes (docs/methods/qr.md, "The rank cut").

    ``A``: unit-norm columns in the standard order (zero for columns without effect), any number
    of rows with the same inner products as the regressor's columns (its R factor will do);
    ``rel``: each column's size in physical units relative to the largest (0: no effect).

    Gautier & Khalil's rule: scan the columns in order and keep a column unless it is a
    combination of the *kept* columns before it.  r[i] is the distance of column i from the span
    of the kept columns (Gram–Schmidt, each projection done twice), times rel[i].  The scan runs
    twice: first it keeps the columns with r above WEAK_RTOL only, then, over the columns left,
    those above RANK_RTOL.  A column that is independent only by a hair (a tilt of 4e-8 rad
    written in the file) is so kept only where no full-size column of the scan carries the same
    direction: kept first, it would make that column a combination of itself and the other kept
    ones to within ~ε/r (~1e-8 for r ~ 1e-8, the size of the cut), and every later decision
    ambiguous.  Without such columns (every exact geometry) both passes give the one-pass scan.

    Returns the kept columns (ascending) and r: for a kept column its residual when it was kept,
    for the others their residual against the final kept set.
    """
    import numpy as np

    rows, P = A.shape
    Q = np.zeros((rows, min(rows, P)))
    r = np.zeros(P)
    is_kept = np.zeros(P, dtype=bool)
    k = 0
    for tol in (WEAK_RTOL, RANK_RTOL):
        todo = [i for i in range(P) if not is_kept[i] and rel[i] > 0]
        for start in range(0, len(todo), block):
            idx = todo[start : start + block]
            V = A[:, idx].copy()
            Qk = Q[:, :k]
            for _ in range(2):  # against the kept basis so far, as one matrix product
                V -= Qk @ (Qk.T @ V)
            k0 = k
            for b, i in enumerate(idx):  # then column by column against the block's own kept ones
                v = V[:, b]
                Qb = Q[:, k0:k]
                for _ in range(2):
                    v -= Qb @ (Qb.T @ v)
                res = float(np.linalg.norm(v))
                r[i] = res * rel[i]
                if r[i] > tol and k < Q.shape[1]:
                    Q[:, k] = v / res
                    k += 1
                    is_kept[i] = True
    return [int(i) for i in np.flatnonzero(is_kept)], r


def regrouping_matrix(kept: list[int], beta: np.ndarray, dropped: list[int], n: int) -> np.ndarray:
    """Assemble K from the kept columns and β over the dropped columns."""
    import numpy as np

    K = np.zeros((len(kept), n))
    for i, c in enumerate(kept):
        K[i, c] = 1.0
    if dropped:
        K[:, dropped] = beta
    return K


def round_significant(x: np.ndarray, digits: int = BETA_DIGITS) -> np.ndarray:
    """x rounded to ``digits`` significant digits."""
    import numpy as np

    out = np.zeros_like(x)
    nz = x != 0
    mag = np.floor(np.log10(np.abs(x[nz])))
    scale = 10.0 ** (digits - 1 - mag)
    out[nz] = np.round(x[nz] * scale) / scale
    return out


def beta_from_unit_columns(beta_n: np.ndarray, norms: np.ndarray, effect: np.ndarray, kept: list[int], dropped: list[int],
                           noise: dict[int, float] | None = None) -> np.ndarray:
    """β in the standard parameters' units from β over unit-norm columns: noise cut (COEFFICIENT_CUTOFF,
    or ten times ``noise[column]``, a small column's own rounding), then rounding."""
    import numpy as np

    cut = np.array([max(COEFFICIENT_CUTOFF, 10.0 * (noise or {}).get(d, 0.0)) for d in dropped])
    beta_n = np.where(np.abs(beta_n) < cut[None, :], 0.0, beta_n)
    scale_d = np.where(effect[dropped], norms[dropped], 0.0)
    return round_significant(beta_n / norms[kept][:, None] * scale_d[None, :])


def small_columns_that_regroup(A: np.ndarray, kept: list[int], small: list[int]) -> dict[int, float]:
    """Of the ``small`` columns of ``A`` (unit norm, below the cut), those within REGROUP_RTOL of the
    span of the ``kept`` columns, with that distance: they regroup instead of having no effect (see
    SMALL_RTOL).  The distance is the column's own rounding (~1e-9 for a column at 1e-8 of the
    largest): the entries of its normalised β below ten times it are noise (``beta_from_unit_columns``)."""
    import numpy as np

    if not small or not kept:
        return {}
    Q = np.linalg.qr(A[:, kept])[0]
    S = A[:, small]
    S = S - Q @ (Q.T @ S)
    S = S - Q @ (Q.T @ S)  # projected twice (Gram–Schmidt's rule) for a residual at rounding level
    return {c: float(rho) for c, rho in zip(small, np.linalg.norm(S, axis=0), strict=True) if rho < REGROUP_RTOL}


def scan_margin(r: np.ndarray, kept: list[int], dropped: list[int], effect: np.ndarray, criterion: str, tol: float, rows: int) -> dict:
    """The rank margin of a scan-order elimination: smallest kept and largest dropped residual,
    and the kept columns below WEAK_RTOL (``weak``: column index and relative residual)."""
    kept_r = r[kept]
    dropped_r = r[[i for i in dropped if effect[i]]]
    return {
        "criterion": criterion,
        "tolerance": tol,
        "last_kept": float(kept_r.min()) if len(kept_r) else None,
        "first_dropped": float(dropped_r.max()) if len(dropped_r) else None,
        "weak_bound": WEAK_RTOL,
        "weak": [[int(c), float(r[c])] for c in kept if r[c] < WEAK_RTOL],
        "coefficient_cutoff": COEFFICIENT_CUTOFF,
        "coefficient_digits": BETA_DIGITS,
        "rows": rows,
    }
