"""``minparam simulate``'s result: the synthetic data and the truth record."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np

SCHEMA = "minparam.simulate/1"


@dataclass(frozen=True)
class Simulation:
    """Synthetic measured data (``minparam simulate``): arrays t (N,), q, dq, ddq, tau (N, dof) in SI
    units, and the truth record (``to_dict()``, the JSON of ``--truth``)."""

    t: np.ndarray = field(repr=False)
    q: np.ndarray = field(repr=False)
    dq: np.ndarray = field(repr=False)
    ddq: np.ndarray = field(repr=False)
    tau: np.ndarray = field(repr=False)
    seed: int = 0
    truth: dict[str, Any] = field(default_factory=dict, repr=False)  # the truth record (experiment.simulate_truth)

    def to_dict(self) -> dict[str, Any]:
        """The truth record (``minparam simulate --truth``), a deep copy."""
        import copy

        return copy.deepcopy(self.truth)

    def arrays(self, ddq: bool = True) -> dict[str, np.ndarray]:
        """The data as ``identify`` reads them: {"t", "q", "dq", ["ddq",] "tau"} (the .npz members)."""
        out = {"t": self.t, "q": self.q, "dq": self.dq}
        if ddq:
            out["ddq"] = self.ddq
        out["tau"] = self.tau
        return out
