"""Which regressor this install computes with, in words (``minparam --version``): the compiled kernel
(``_rnea.c``, built by setup.py when a C compiler is present) and how many samples it computes at a
time on this processor, or numpy.  Imports neither numpy nor the regressor: the version stays quick."""

from __future__ import annotations

# samples at a time -> how the kernel computes them (_rnea_lanes.h: one instance per width)
LANES = {4: "avx2 lanes (4 samples at a time)", 2: "16-byte vector lanes (2 samples at a time)", 1: "one sample at a time"}
NO_KERNEL = "numpy, no compiled kernel; reinstall with a C compiler for ~13x faster regressors"


def describe() -> str:
    """'compiled kernel, avx2 lanes (4 samples at a time)', or the numpy fallback and how to leave it."""
    try:
        from minparam_cli.dynamics import _rnea
    except ImportError:  # built without a C compiler (setup.py says so at install)
        return NO_KERNEL
    widest = max(_rnea.lane_widths())  # the kernel's default width: the widest this processor runs
    return "compiled kernel, " + LANES.get(widest, f"{widest} samples at a time")
