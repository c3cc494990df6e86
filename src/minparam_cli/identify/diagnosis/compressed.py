"""The diagnosis sample, compressed to per-joint triangular factors.

Every quantity the diagnosis computes is a least-squares quantity over the
rows of each joint: residual sums of squares, Gram matrices, projections, for
weights that are constant per joint (Gautier's σ_j).  With A_j = [X_j | C_j | τ_j]
the rows of joint j (base columns, the columns of every candidate effect on
joint j - the catalogue -, measured torque) and A_j = Q_j T_j its QR
factorisation, ‖A_j v‖ = ‖T_j v‖ for every v.  So the N samples of each part
(training, held out) are replaced by T_j, K x K with K = p + catalogue + 1, and
a candidate costs O(K²) instead of O(N).

Columns of a design in this representation: each design column is, on joint j,
one catalogue column or zero (a term on another joint), given by ``selection``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.measured.records import Block
from minparam_cli.identify.passes.design import Design, Term
from minparam_cli.dynamics.effects import EFFECTS, source_columns
from minparam_cli.identify.estimate.errors import Errors
from minparam_cli.runtime import DIAGNOSIS_QR_ROWS

ZERO = -1  # selection index of a zero column (the factors carry a zero column last)


@dataclass(frozen=True)
class Catalogue:
    """Columns of joint j's factor: p base columns, each source's columns for joint j, τ_j last."""

    p: int
    sources: tuple[tuple[str, float | None], ...]
    start: dict  # (effect, hyper) -> first column
    y: int  # the column of τ_j, after the last source's

    @staticmethod
    def of(p: int, effects: tuple[str, ...], with_model: bool) -> "Catalogue":
        sources = tuple(
            (eid, h)
            for eid in effects
            if (with_model or not EFFECTS[eid].needs_model) and not (eid in ALIAS and ALIAS[eid] in effects)
            for h in EFFECTS[eid].grid or (None,)
        )
        return Catalogue(p, sources, *source_columns(sources, p))

    def columns(self, term: Term) -> list[int]:
        key = (term.effect, term.hyper)
        c0 = self.start[key] if key in self.start else self.start[(ALIAS[term.effect], term.hyper)]
        return list(range(c0, c0 + len(EFFECTS[term.effect].column_names)))


# effects with the same columns as another (one name where the data show its signature, the other where
# they do not): when both are searched, the catalogue holds the columns once
ALIAS = {"position_error": "cogging"}


def _factor(design: Design, b: Block, cat: Catalogue) -> list[np.ndarray]:
    """Per joint, T_j (with a zero column appended) of [X_j | catalogue columns of joint j | τ_j],
    accumulated DIAGNOSIS_QR_ROWS samples at a time (the catalogue is ~180 columns a joint).  The joints'
    QR factorisations run on threads, one a joint up to the CPUs (LAPACK releases the GIL); each
    joint's sequence of factorisations is the same as on one, so the factors are too."""
    from concurrent.futures import ThreadPoolExecutor

    from minparam_cli.identify.estimate.nogil_lapack import qr_r
    from minparam_cli.identify.passes.slots import sources_columns
    from minparam_cli.runtime import workers

    n = design.chain.dof
    T = [np.zeros((0, cat.y + 1))] * n
    with ThreadPoolExecutor(max_workers=workers(n), thread_name_prefix="minparam-qr") as pool:
        for s0 in range(0, len(b), DIAGNOSIS_QR_ROWS):
            sub = b.take(slice(s0, s0 + DIAGNOSIS_QR_ROWS))
            X = design.base_columns(sub)
            sig = design.signals(sub, X)
            A = np.concatenate([X] + sources_columns(cat.sources, sig, n) + [sub.tau[:, :, None]], axis=2)
            T = list(pool.map(lambda j, T=T, A=A: qr_r(T[j], A[:, j]), range(n)))
    return [np.hstack([Tj, np.zeros((Tj.shape[0], 1))]) for Tj in T]


@dataclass(frozen=True)
class Compressed:
    """Training and held-out factors of the diagnosis sample."""

    cat: Catalogue
    T: list  # training factors, per joint
    Th: list  # held-out factors, per joint
    N: int  # training samples
    Nh: int  # held-out samples

    @staticmethod
    def of(design: Design, train: Block, hold: Block, effects: tuple[str, ...]) -> "Compressed":
        from concurrent.futures import ThreadPoolExecutor

        cat = Catalogue.of(len(design.kept), effects, design.theta_model is not None)
        with ThreadPoolExecutor(max_workers=1, thread_name_prefix="minparam-hold") as side:  # both at once
            held = side.submit(_factor, design, hold, cat)
            T = _factor(design, train, cat)
            return Compressed(cat, T, held.result(), len(train), len(hold))

    @property
    def n(self) -> int:
        return len(self.T)

    def selection(self, design: Design) -> np.ndarray:
        """(n, design.p): the catalogue column of every design column on each joint (ZERO: none)."""
        sel = np.full((self.n, design.p), ZERO)
        sel[:, : self.cat.p] = np.arange(self.cat.p)
        c = self.cat.p
        for term in design.terms:
            cols = self.cat.columns(term)
            for j in term.joints:
                sel[j, c : c + len(cols)] = cols
                c += len(cols)
        return sel

    def stack(self, sel: np.ndarray, sigma: np.ndarray, hold: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Weighted design and torque, stacked over the joints (rows of joint j divided by σ_j)."""
        Ts = self.Th if hold else self.T
        M = np.vstack([T[:, s] / w for T, s, w in zip(Ts, sel, sigma, strict=True)])
        y = np.concatenate([T[:, self.cat.y] / w for T, w in zip(Ts, sigma, strict=True)])
        return M, y

    def joint_rss(self, sel: np.ndarray, theta: np.ndarray, hold: bool = False) -> np.ndarray:
        """Unweighted residual sum of squares of each joint for the design columns ``sel`` and ``theta``."""
        Ts = self.Th if hold else self.T
        return np.array([float(np.sum((T[:, self.cat.y] - T[:, s] @ theta) ** 2)) for T, s in zip(Ts, sel, strict=True)])

    def joint_sigma(self, sel: np.ndarray, weighted: bool = True) -> np.ndarray:
        """Gautier's weights: each joint's residual standard deviation after OLS (1 where it is zero);
        all ones when not ``weighted`` (OLS)."""
        if not weighted:
            return np.ones(self.n)
        M, y = self.stack(sel, np.ones(self.n))
        theta, *_ = np.linalg.lstsq(M, y, rcond=None)
        sigma = np.sqrt(self.joint_rss(sel, theta) / max(self.N - sel.shape[1] / self.n, 1))
        return np.where(sigma > 0, sigma, 1.0)

    def selection_errors(self, sel: np.ndarray, theta: np.ndarray) -> Errors:
        """Selection data (the held-out factors), unweighted: rms per joint, rms in all, ‖r‖/‖τ‖."""
        rss = self.joint_rss(sel, theta, hold=True)
        y2 = sum(float(np.sum(T[:, self.cat.y] ** 2)) for T in self.Th)
        return Errors(
            rms_total=float(np.sqrt(rss.sum() / (self.Nh * self.n))),
            rms_per_joint=tuple(float(x) for x in np.sqrt(rss / self.Nh)),
            relative_error=float(np.sqrt(rss.sum() / y2)),
        )
