"""The records of measured joint data shared by every reader and the processing: the options
(``DataOptions``), a block of samples (``Block``), what was read and dropped (``DataReport``), and
the sampling step of time stamps.  Below the readers (``measured/reading.py`` and the other ``measured/*``) and the
processing (``measured/filtering.py``, ``measured/blocks.py``), so that none of them imports another
to get these."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from minparam_cli.runtime import CHUNK_ROWS  # rows read at a time (re-exported: DataOptions' default)

DEFAULT_CUTOFF_HZ = 5.0
FILTER_ORDER = 4
KEYS = ("t", "q", "dq", "ddq", "tau")
# a time step that differs from the sampling step by more than this share (longer or shorter) is irregular
IRREGULAR_TOL = 0.1
# a time step longer than this many sampling steps is a gap (a logging pause): it splits the record into
# segments that are filtered and differentiated apart (measured/filtering.py).  The Panda recording's
# longest step, after its sample-and-hold rows are dropped, is 15.5 steps (15.5 ms at 1 kHz)
GAP_STEPS = 25
STAMP_ULPS = 2  # two time stamps' steps that differ by at most this many units in the last place are the same step


@dataclass(frozen=True)
class DataOptions:
    columns: dict[str, str] = field(default_factory=dict)  # key -> column name (t) or spec (q, dq, ...: measured/columns.py)
    cutoff_hz: float = DEFAULT_CUTOFF_HZ
    force_filter: bool = False
    chunk_rows: int = CHUNK_ROWS
    decimate: int | None = None  # None: automatic (about 10x the cut-off)
    step_s: float | None = None  # sampling step; None: from the steps of the first chunk (see sampling_step)
    still_speed: float = 0.01  # rad/s or m/s: joint j is still at a sample when |dq_j| < still_speed
    trim_still_s: float | None = None  # drop every run of all-joints-still samples longer than this (s); None: keep all
    # a velocity derived by the filter (not read from the file) below still_speed is set to 0: the joint
    # is at rest as far as the data can tell, and sign(q̇) of the noise would put its Coulomb friction at ±Fc
    rest_below_still: bool = True
    time_unit: str = "s"  # unit of a CSV or .npz time column: s, ms, us or ns (measured.columns.TIME_UNITS)
    topic: str | None = None  # a ROS bag's JointState topic; None: the bag's only one
    joint_names: tuple[str, ...] = ()  # names of the independent coordinates, in order (ROS bags match by name)
    # motor-side data (identify --side motor): (N rows, zero, gains or None); q = N⁻¹θ + zero,
    # τ = Nᵀ diag(gains) τ_m, applied as the rows are read (dynamics/transmission.py); None: joint side
    motor_side: tuple | None = None


@dataclass
class Block:
    t: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    tau: np.ndarray

    def __len__(self) -> int:
        return len(self.t)

    def take(self, idx) -> "Block":
        return Block(self.t[idx], self.q[idx], self.dq[idx], self.ddq[idx], self.tau[idx])

    @staticmethod
    def concat(blocks: list["Block"]) -> "Block":
        return Block(*(np.concatenate([getattr(b, k) for b in blocks]) for k in KEYS))


@dataclass
class DataReport:
    """What happened to the file: counts and choices, for the report."""

    path: str
    rows_read: int = 0
    dropped: dict = field(default_factory=lambda: {"nan": 0, "repeated_sample": 0})
    irregular_steps: int = 0
    segments: int = 1  # pieces of the record between gaps (steps longer than GAP_STEPS sampling steps)
    gap_s: float = 0.0  # the gaps' total length (s)
    trim_s: float | None = None  # dropped at both ends of every segment by the filter (s); None: not filtered
    median_step_s: float | None = None
    derived: list = field(default_factory=list)
    filter: str | None = None
    decimation: int = 1
    samples: int = 0  # samples yielded (after decimation and standstill trimming)
    still_share: list = field(default_factory=list)  # per joint: share of the samples (before trimming) in which it is still
    still_all_share: float = 0.0  # share of the samples (before trimming) in which every joint is still
    trimmed_segments: int = 0  # standstills dropped by trim_still_s (their samples: dropped["standstill"])
    rest_below: float | None = None  # derived |q̇| below this speed was set to 0 (DataOptions.rest_below_still); None: not

    def as_dict(self) -> dict:
        return {
            "rows_read": self.rows_read,
            "dropped": dict(self.dropped),
            "irregular_steps": self.irregular_steps,
            "segments": self.segments,
            "gap_s": self.gap_s,
            "gap_steps": GAP_STEPS,
            "trim_s": self.trim_s,
            "median_step_s": self.median_step_s,
            "derived": list(self.derived),
            "filter": self.filter,
            "decimation": self.decimation,
            "samples": self.samples,
            "still_share": [float(x) for x in self.still_share],
            "still_all_share": float(self.still_all_share),
            "trimmed_segments": self.trimmed_segments,
            "rest_below": self.rest_below,
        }


def sampling_step(t: np.ndarray) -> float | None:
    """The sampling step of time stamps ``t`` (NaN and non-increasing steps ignored), or None.

    The median step, refined as the mean of the steps that equal it up to the rounding of the
    stamps (STAMP_ULPS units in the last place of the largest stamp).  The median alone carries
    that rounding: a double resolves raw controller stamps (t ≈ 1.7e9 s) to 0.24 µs, so a 2 ms step
    reads 1.99986 or 2.00010 ms and the median is one of them, which moves a long resampling grid
    by samples; the mean over those steps is the true step to the stamps' resolution divided by
    their count, so that a record and its re-zeroed copy are resampled alike.  Jitter larger than
    the rounding (logged stamps) is left out of the mean, which stays the median then.
    """
    t = t[np.isfinite(t)]
    d = np.diff(t)
    d = d[d > 0]
    if not len(d):
        return None
    med = float(np.median(d))
    same = d[np.abs(d - med) <= STAMP_ULPS * float(np.spacing(np.max(np.abs(t))))]
    return float(same.mean()) if len(same) else med
