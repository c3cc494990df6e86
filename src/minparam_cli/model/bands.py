"""Prediction bands of a saved model: the parameter covariance propagated to the torque.

For a sample with design rows x_j (joint j, the fitted columns) the predicted
torque τ̂_j = x_jᵀθ has, from the parameters, the variance x_jᵀ C x_j (C: the
covariance identify stored, of the kind of its ``--sigma``); a new measurement
scatters about it by the residual σ_j of the fit (Gautier's weights).  The
band is

    τ̂_j ± z · sqrt(x_jᵀ C x_j + σ_j²),   z = Φ⁻¹((1 + level)/2)  (1.96 for 95 %),

and ``evaluate`` counts the share of samples whose measured torque lies in
it, per joint.  The parameter part alone (z·sqrt(x_jᵀ C x_j)) is reported as
its mean half-width: it says how much of the band the data's limited
information about θ contributes.  The residual part assumes the recording is
as noisy as the fit data; a share far below the level says the model or the
noise differs on that recording.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

DEFAULT_LEVEL = 0.95


@dataclass(frozen=True)
class Band:
    columns: np.ndarray  # design columns the covariance is over
    cov: np.ndarray
    sigma: np.ndarray  # residual σ per joint
    level: float = DEFAULT_LEVEL
    kind: str = "hac"

    @property
    def z(self) -> float:
        from scipy.stats import norm

        return float(norm.ppf(0.5 + self.level / 2))

    def half_widths(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N, n) half-widths of the band and of its parameter part, for design rows X (N, n, p)."""
        Xc = X[:, :, self.columns]
        v = np.einsum("tjk,kl,tjl->tj", Xc, self.cov, Xc)
        v = np.maximum(v, 0.0)
        z = self.z
        return z * np.sqrt(v + self.sigma**2), z * np.sqrt(v)


@dataclass
class BandCounts:
    """Per joint: samples, samples inside the band, Σ half-width, Σ parameter half-width."""

    rows: np.ndarray
    inside: np.ndarray
    half: np.ndarray
    half_param: np.ndarray

    @staticmethod
    def zeros(n: int) -> "BandCounts":
        return BandCounts(np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64), np.zeros(n), np.zeros(n))

    def add(self, tau: np.ndarray, pred: np.ndarray, half: np.ndarray, half_param: np.ndarray) -> None:
        self.rows += len(tau)
        self.inside += np.sum(np.abs(tau - pred) <= half, axis=0)
        self.half += half.sum(axis=0)
        self.half_param += half_param.sum(axis=0)

    def __add__(self, o: "BandCounts") -> "BandCounts":
        return BandCounts(self.rows + o.rows, self.inside + o.inside, self.half + o.half, self.half_param + o.half_param)

    def inside_per_joint(self) -> list[float]:
        """Per joint, the share of samples inside the band."""
        return [float(x) for x in self.inside / np.maximum(self.rows, 1)]

    def half_width_per_joint(self) -> list[float]:
        """Per joint, the band's mean half-width (N·m or N)."""
        return [float(x) for x in self.half / np.maximum(self.rows, 1)]

    def parameter_half_width_per_joint(self) -> list[float]:
        """Per joint, the mean half-width of the band's parameter part."""
        return [float(x) for x in self.half_param / np.maximum(self.rows, 1)]

    def as_dict(self) -> dict:
        return {
            "inside_per_joint": self.inside_per_joint(),
            "half_width_per_joint": self.half_width_per_joint(),
            "parameter_half_width_per_joint": self.parameter_half_width_per_joint(),
        }


def band_block(design, band: Band, block, rows: int = 4096) -> tuple[np.ndarray, np.ndarray]:
    """Half-widths (N, n) of the band and its parameter part for one block of samples."""
    N, n = block.tau.shape
    half, hp = np.empty((N, n)), np.empty((N, n))
    for s0 in range(0, N, rows):
        sub = block.take(slice(s0, s0 + rows))
        with np.errstate(over="ignore", invalid="ignore"):
            half[s0 : s0 + len(sub)], hp[s0 : s0 + len(sub)] = band.half_widths(design.columns(sub))
    return half, hp


def check_level(level: float) -> None:
    from minparam_cli.errors import InputError

    if not (math.isfinite(level) and 0 < level < 1):
        raise InputError(f"--band-level {level}: expected a probability strictly between 0 and 1 (0.95: a 95 % band)")
