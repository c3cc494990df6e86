"""identify's speed settings (runtime.py: chunk rows, pyarrow's block, regressor blocks, queue depths,
the diagnosis's QR blocks) cut the same arithmetic up differently and change no result beyond
rounding: the whole report, with each of them changed at once against the defaults.  The fitted
parameters agree to 1e-10 relative; their relative σ (718 % for a parameter near zero), the
diagnosis's statistics and the coefficients of the candidates it rejected (fits of nearly dependent
columns: a condition number of 1e5-1e6 on the rounding) to 1e-8; everything else (the effects
chosen, counts, names, flags) exactly."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest
from test_identify_scale import _panda_sample

from minparam_cli.identify import stage
from minparam_cli.identify.diagnosis import compressed
from minparam_cli.identify.passes import stream
from minparam_cli.measured import arrow_csv
from minparam_cli.robot import DeriveOptions, load_chain

RTOL = 1e-10  # the fitted parameters (base parameters and the coefficients of the effects added)
ATOL = 1e-12  # a coefficient fitted to noise (3e-5 N·m, say) moves by 6e-15 N·m: 2e-10 of itself
RTOL_DIAGNOSIS = 1e-8  # every other number of the report


def _numbers(x, path=""):
    """(path, value) of every number in a report, the run's own timings left out."""
    if isinstance(x, dict):
        for k, v in x.items():
            if "elapsed" not in k:
                yield from _numbers(v, f"{path}.{k}")
    elif isinstance(x, (list, tuple)):
        for i, v in enumerate(x):
            yield from _numbers(v, f"{path}[{i}]")
    elif isinstance(x, float):
        yield path, x
    else:
        yield path, x  # names, counts, flags: equal exactly


def _report(path: Path, opts: stage.IdentifyOptions) -> dict:
    _, chain = load_chain(Path("robots/panda.yaml"), DeriveOptions())
    result, _ = stage.identify(chain, path, opts)
    return result.to_dict()


# 6000 samples: 3,600 fit samples, every one in the diagnosis sample, 6 regressor blocks where the default makes
# 1; 2500 (the fast tier's case): 1,500 fit samples, still 3 blocks of each tuned setting where the default makes 1
@pytest.mark.parametrize("samples", [6000, 2500])
def test_the_speed_settings_change_no_result(tmp_path, monkeypatch, samples):
    path = _panda_sample(tmp_path, samples=samples)
    opts = stage.IdentifyOptions()
    default = _report(path, opts)

    monkeypatch.setattr(stream, "REGRESSOR_ROWS", 700)  # several blocks of rows where the default makes 1
    monkeypatch.setattr(stream, "READ_AHEAD", 3)
    monkeypatch.setattr(stream, "ROWS_AHEAD", 1)
    monkeypatch.setattr(arrow_csv, "BLOCK_BYTES", 8192)  # pyarrow batches of ~28 lines (with pyarrow)
    monkeypatch.setattr(compressed, "DIAGNOSIS_QR_ROWS", 500)
    tuned = _report(path, replace(opts, data=replace(opts.data, chunk_rows=1000)))

    a, b = list(_numbers(default)), list(_numbers(tuned))
    assert [p for p, _ in a] == [p for p, _ in b]
    assert any(isinstance(v, float) and v != w for (_, v), (_, w) in zip(a, b, strict=True)), \
        "the settings should change the order of the sums somewhere"
    for (p, v), (_, w) in zip(a, b, strict=True):
        if isinstance(v, float):
            fitted = (p.startswith(".parameters.") and p.endswith(".value")) or (p.startswith(".effects[") and ".coefficients." in p)
            rtol = RTOL if fitted else RTOL_DIAGNOSIS
            assert (math.isnan(v) and math.isnan(w)) or abs(v - w) <= rtol * max(abs(v), abs(w)) + ATOL, (p, v, w)
        else:
            assert v == w, p
