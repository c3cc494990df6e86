"""Whether a velocity column read from the file is the time derivative of the position column.

A q̇ in deg/s beside q in rad (or q in degrees beside q̇ in rad/s), a sign flipped, or the wrong
columns mapped make every velocity-dependent regressor column wrong, and the fit would blame
friction for it.  Both q and q̇ given: over every regular step (not across a gap, not a jump of
q larger than π, which is an angle wrapping), the secant slope y = Δq/Δt is compared with the mean
of q̇ at the two ends, x; these agree to second order in the step for smooth motion.  Per joint,
the least-squares slope b = Σxy / Σxx through the origin and its standard error
se = sqrt(Σ(y − bx)² / (N − 1) / Σxx) are streamed (sums only, no samples held).

A joint is refused when |b − 1| > SLOPE_TOL (its q̇ is off by more than half) and by more than
SE_FACTOR standard errors; a joint whose rms q̇ is below the standstill speed is not judged.
Measured noise only lowers b a little (noise in q̇ attenuates the slope; noise in q adds scatter
that se measures): on the Panda recording (libfranka q̇, q to 6 significant digits) b is within
2 % of 1 on every joint (1.018 to 1.020, se 0.002) (tests/test_identify_data.py checks that it passes).
"""

from __future__ import annotations

import math

import numpy as np

from minparam_cli.errors import DataError

SLOPE_TOL = 0.5
SE_FACTOR = 10.0
DEG = 180.0 / math.pi


class VelocityCheck:
    def __init__(self, n: int, gap_s: float, still_speed: float, path: str):
        self.gap, self.still, self.path = gap_s, still_speed, path
        self.sxx, self.sxy, self.syy = np.zeros(n), np.zeros(n), np.zeros(n)
        self.count = np.zeros(n, dtype=np.int64)
        self.last: tuple[float, np.ndarray, np.ndarray] | None = None

    def push(self, t: np.ndarray, q: np.ndarray, dq: np.ndarray) -> None:
        if self.last is not None:
            t = np.concatenate([[self.last[0]], t])
            q = np.vstack([self.last[1][None], q])
            dq = np.vstack([self.last[2][None], dq])
        if len(t) < 2:
            self.last = (float(t[-1]), q[-1].copy(), dq[-1].copy()) if len(t) else self.last
            return
        dt = np.diff(t)[:, None]
        dqq = np.diff(q, axis=0)
        ok = (dt > 0) & (dt <= self.gap) & (np.abs(dqq) < math.pi)
        with np.errstate(all="ignore"):
            y = np.where(ok, dqq / dt, 0.0)
        x = np.where(ok, 0.5 * (dq[1:] + dq[:-1]), 0.0)
        self.sxx += np.sum(x * x, axis=0)
        self.sxy += np.sum(x * y, axis=0)
        self.syy += np.sum(y * y, axis=0)
        self.count += ok.sum(axis=0)
        self.last = (float(t[-1]), q[-1].copy(), dq[-1].copy())

    def slopes(self) -> list[tuple[float, float] | None]:
        """Per joint (b, se), or None where the joint moves too little (or too few steps) to judge."""
        out: list[tuple[float, float] | None] = []
        for sxx, sxy, syy, m in zip(self.sxx, self.sxy, self.syy, self.count, strict=True):
            if m < 3 or sxx <= m * self.still**2:
                out.append(None)
                continue
            b = sxy / sxx
            resid = max(syy - 2 * b * sxy + b * b * sxx, 0.0)
            out.append((float(b), float(math.sqrt(resid / (m - 1) / sxx))))
        return out

    def finish(self) -> None:
        for j, s in enumerate(self.slopes()):
            if s is None:
                continue
            b, se = s
            if abs(b - 1) <= SLOPE_TOL or abs(b - 1) <= SE_FACTOR * se:
                continue
            if abs(b / DEG - 1) < 0.1:
                why = f"dq/dt of q is {b:.4g} x dq: q in degrees? (q must be in rad, dq in rad/s)"
            elif abs(b * DEG - 1) < 0.1:
                why = f"dq/dt of q is {b:.4g} x dq (1/{1 / b:.4g}): dq in deg/s? (dq must be in rad/s)"
            elif abs(b + 1) <= SLOPE_TOL:
                why = f"dq/dt of q is {b:.4g} x dq: the sign of dq is flipped"
            else:
                why = f"dq/dt of q is {b:.4g} x dq (± {se:.2g}): not the same joint's velocity, or another unit"
            raise DataError(f"{self.path}: joint {j + 1}: the velocity column disagrees with the positions: {why}")
