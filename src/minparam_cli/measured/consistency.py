"""Whether a velocity column read from the file is the time derivative of the position column.

A q̇ in deg/s beside q in rad (or q in degrees beside q̇ in rad/s), a sign flipped, or the wrong
columns mapped make every velocity-dependent regressor column wrong, and the fit would blame
friction for it.  Both q and q̇ given: over every regular step (not across a gap, not a jump of
q larger than π, which is an angle wrapping), the secant slope y = Δq/Δt is compared with the mean
of q̇ at the two ends, x; these agree to second order in the step for smooth motion.

The statistic is robust, so that noise and a few wild samples (a spike, a value the fit refuses
later with its time) do not decide it: per joint, the ratio b = median(y / x) over the steps whose
|x| is at least the median |x| and above the standstill speed (where the ratio is not noise over
noise), with a standard error from the ratios' median absolute deviation (1.4826·MAD/√m).  The
steps are kept at a stride that doubles whenever more than KEEP are held (memory bounded, the
stride deterministic).

A joint is refused when |b − 1| > SLOPE_TOL (its q̇ is off by more than half) and by more than
SE_FACTOR standard errors; a joint with fewer than MIN_STEPS such steps is not judged.  On the
Panda recording (libfranka q̇, q to 6 significant digits) b is 1.006 to 1.012, standard error 0.0015
(tests/test_identify_data.py checks that it passes).
"""

from __future__ import annotations

import math

import numpy as np

from minparam_cli.errors import DataError

SLOPE_TOL = 0.5
SE_FACTOR = 10.0
KEEP = 50_000  # steps held per joint, at most
MIN_STEPS = 20
DEG = 180.0 / math.pi


class VelocityCheck:
    def __init__(self, n: int, gap_s: float, still_speed: float, path: str):
        self.gap, self.still, self.path, self.n = gap_s, still_speed, path, n
        self.xs: list[np.ndarray] = []
        self.ys: list[np.ndarray] = []
        self.held = 0
        self.stride = 1
        self.seen = 0  # steps seen so far (the stride's phase)
        self.last: tuple[float, np.ndarray, np.ndarray] | None = None

    def push(self, t: np.ndarray, q: np.ndarray, dq: np.ndarray) -> None:
        if self.last is not None:
            t = np.concatenate([[self.last[0]], t])
            q = np.vstack([self.last[1][None], q])
            dq = np.vstack([self.last[2][None], dq])
        if len(t) < 2:
            self.last = (float(t[-1]), q[-1].copy(), dq[-1].copy()) if len(t) else self.last
            return
        self.last = (float(t[-1]), q[-1].copy(), dq[-1].copy())
        take = np.flatnonzero((self.seen + np.arange(len(t) - 1)) % self.stride == 0)
        self.seen += len(t) - 1
        dt = (t[take + 1] - t[take])[:, None]
        dqq = q[take + 1] - q[take]
        ok = (dt > 0) & (dt <= self.gap) & (np.abs(dqq) < math.pi)
        with np.errstate(all="ignore"):
            y = np.where(ok, dqq / dt, np.nan)
            x = np.where(ok, 0.5 * (dq[take + 1] + dq[take]), np.nan)
        self.xs.append(x)
        self.ys.append(y)
        self.held += len(take)
        if self.held > KEEP:
            self._thin()

    def _thin(self) -> None:
        """Keep every other held step (by the global step index) and double the stride."""
        x, y = np.vstack(self.xs), np.vstack(self.ys)
        self.xs, self.ys = [x[::2]], [y[::2]]
        self.held = len(self.xs[0])
        self.stride *= 2
        # the held steps were at multiples of the old stride from 0: every other one is a multiple of the new

    def slopes(self) -> list[tuple[float, float] | None]:
        """Per joint (b, se), or None where the joint moves too little (or too few steps) to judge."""
        if not self.xs:
            return [None] * self.n
        x, y = np.vstack(self.xs), np.vstack(self.ys)
        out: list[tuple[float, float] | None] = []
        for j in range(self.n):
            good = np.isfinite(x[:, j]) & np.isfinite(y[:, j])
            xj, yj = x[good, j], y[good, j]
            if len(xj) < MIN_STEPS:
                out.append(None)
                continue
            ax = np.abs(xj)
            sel = (ax >= np.median(ax)) & (ax > self.still)
            if sel.sum() < MIN_STEPS:
                out.append(None)
                continue
            r = yj[sel] / xj[sel]
            b = float(np.median(r))
            se = 1.4826 * float(np.median(np.abs(r - b))) / math.sqrt(len(r))
            out.append((b, se))
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
