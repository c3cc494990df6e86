"""The design matrix of an identification: base regressor columns plus effect columns."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.chain import Chain
from minparam_cli.dynamics.regressor import regressor, regressor_columns
from minparam_cli.measured.records import Block
from minparam_cli.dynamics.effects import EFFECTS, Signals


@dataclass(frozen=True)
class Term:
    """One effect on a set of joints (0-based), with its grid parameter if any."""

    effect: str
    joints: tuple[int, ...]
    hyper: float | None = None

    def label(self) -> str:
        j = ",".join(str(k + 1) for k in self.joints)
        h = f", {EFFECTS[self.effect].grid_name}={self.hyper:g}" if self.hyper is not None else ""
        return f"{self.effect} (joint{'s' if len(self.joints) > 1 else ''} {j}{h})"

    def width(self) -> int:
        return len(self.joints) * len(EFFECTS[self.effect].column_names)

    def names(self) -> list[str]:
        out = []
        for j in self.joints:
            out += EFFECTS[self.effect].names(j, self.hyper)
        return out


def term_columns(term: Term, s: Signals, n: int) -> np.ndarray:
    """(N, n, width) extra columns of one term: joint j's columns act on joint j only."""
    e = EFFECTS[term.effect]
    m = len(e.column_names)
    out = np.zeros((len(s.t), n, m * len(term.joints)))
    for i, j in enumerate(term.joints):
        out[:, j, i * m : (i + 1) * m] = e.columns(s, j, term.hyper)
    return out


@dataclass(frozen=True)
class Design:
    chain: Chain  # with the declared extras in its layout
    kept: tuple[int, ...]  # base columns of the chain's full regressor
    base_names: tuple[str, ...]
    terms: tuple[Term, ...] = ()
    theta_model: np.ndarray | None = None  # base-parameter values giving the rigid model torque (load effects)
    t0: float | None = None  # time origin of the drift column: the same for every block, training and held out

    @property
    def names(self) -> tuple[str, ...]:
        out = list(self.base_names)
        for t in self.terms:
            out += t.names()
        return tuple(out)

    @property
    def p(self) -> int:
        return len(self.kept) + sum(t.width() for t in self.terms)

    def with_term(self, term: Term) -> "Design":
        from dataclasses import replace

        return replace(self, terms=self.terms + (term,))

    def base_columns(self, b: Block) -> np.ndarray:
        Y = regressor(self.chain, b.q, b.dq, b.ddq)
        return np.take(Y, self.kept, axis=2)

    def signals(self, b: Block, Xb: np.ndarray | None = None, tau_model: np.ndarray | None = None) -> Signals:
        """The signals the effects are built from; the model torque (load effects) from ``tau_model``
        when given, else from the base columns ``Xb`` (N, n, kept) or, without them, computed."""
        if self.theta_model is None:
            tau_model = None
        elif tau_model is None:
            Xb = self.base_columns(b) if Xb is None else Xb
            tau_model = Xb @ self.theta_model[: len(self.kept)]
        motor = None
        if self.chain.transmission is not None:  # the motor-side effects of coupled motors
            motor = np.asarray(self.chain.transmission.matrix, dtype=float)
        return Signals(b.t, b.q, b.dq, b.ddq, tau_model, self.t0, self.chain.coulomb_smoothing, motor)

    def model_torque(self, rows: np.ndarray, N: int) -> np.ndarray | None:
        """(N, n) model torque X θ_model from joint-major rows (``rows`` below), None without θ_model."""
        if self.theta_model is None:
            return None
        k = len(self.kept)
        return np.stack([rows[j, :k, :N].T @ self.theta_model[:k] for j in range(rows.shape[0])], axis=1)

    def rows(self, b: Block, out: np.ndarray) -> np.ndarray:
        """The design columns of the block joint-major, ``columns(b)`` transposed: out[k, i, s] =
        columns(b)[s, k, i] written into out[:, :p, :N] (out: C-contiguous (n, ≥ p, ≥ N)), the base
        columns by the compiled kernel straight into place (``regressor_columns``)."""
        N, k = len(b), len(self.kept)
        regressor_columns(self.chain, b.q, b.dq, b.ddq, self.kept, out=out)
        if self.terms:
            s = self.signals(b, tau_model=self.model_torque(out, N))
            for t in self.terms:
                w = t.width()
                out[:, k : k + w, :N] = term_columns(t, s, self.chain.dof).transpose(1, 2, 0)
                k += w
        return out

    def columns(self, b: Block) -> np.ndarray:
        Xb = self.base_columns(b)
        if not self.terms:
            return Xb
        s = self.signals(b, Xb)
        return np.concatenate([Xb] + [term_columns(t, s, self.chain.dof) for t in self.terms], axis=2)
