"""The result every base-parameter route returns, and the keep rule they share."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from minparam_cli.params import split_name

# entries of the normalised regrouping matrix below this are rounding noise
COEFFICIENT_CUTOFF = 1e-10


@dataclass(frozen=True, eq=False)
class BaseSet:
    """Base (minimal) parameters of a chain: phi_base = K · phi.

    ``K`` has one row per base parameter; row i holds 1 at column kept[i] and
    the regrouping coefficients beta on dependent columns (base = kept + β·dependent).
    """

    standard_names: tuple[str, ...]
    kept: tuple[int, ...]
    K: np.ndarray  # (n_base, n_standard)
    unidentifiable: tuple[int, ...]  # columns with no effect at all
    method: str
    rank_margin: dict
    exact: bool = False
    seed: int | None = None
    samples: int | None = None
    elapsed_s: float = 0.0
    extra: dict = field(default_factory=dict)
    K_exact: tuple | None = field(default=None, repr=False)  # rows of Fractions in exact mode

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
    def base_names(self) -> tuple[str, ...]:
        """Khalil-style names: XXR2 when a parameter regroups others, plain XX2 otherwise."""
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

    def terms(self, i: int) -> dict[str, float]:
        """{standard name: coefficient} of base parameter i, kept parameter first."""
        col = self.kept[i]
        out = {self.standard_names[col]: float(self.K[i, col])}
        for c in np.flatnonzero(self.K[i]):
            if c != col:
                out[self.standard_names[c]] = float(self.K[i, c])
        return out


def regrouping_matrix(kept: list[int], beta: np.ndarray, dropped: list[int], n: int) -> np.ndarray:
    """Assemble K from the kept columns and β over the dropped columns."""
    K = np.zeros((len(kept), n))
    for i, c in enumerate(kept):
        K[i, c] = 1.0
    if dropped:
        K[:, dropped] = beta
    return K
