"""Reading a model file back (``model/file.py`` describes it): every problem is one ModelError
naming the file and the key."""

from __future__ import annotations

import json
import math
from typing import Literal, NoReturn, overload

import numpy as np

from minparam_cli.identify.passes.design import Term
from minparam_cli.dynamics.effects import EFFECTS, LEGACY_SPRING
from minparam_cli.model.file import DATA_KEYS, FORMAT, READS, LoadSettings, ModelError, PhysicalParameters, SavedModel
from minparam_cli.measured.records import DataOptions


class _Reader:
    def __init__(self, source: str):
        self.source = source

    def fail(self, where: str, what: str) -> NoReturn:
        raise ModelError(f"{self.source}: {where}: {what}")

    def get(self, d, key: str, where: str):
        if not isinstance(d, dict):
            self.fail(where, "expected a JSON object")
        if key not in d:
            self.fail(where, f"missing key '{key}'")
        return d[key]

    @overload
    def number(self, v, where: str, allow_none: Literal[False] = False) -> float: ...
    @overload
    def number(self, v, where: str, allow_none: bool) -> float | None: ...

    def number(self, v, where: str, allow_none: bool = False) -> float | None:
        if v is None and allow_none:
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            self.fail(where, f"expected a finite number, got {json.dumps(v)[:40]}")
        return float(v)

    def integer(self, v, where: str, lo: int | None = None) -> int:
        if isinstance(v, bool) or not isinstance(v, int) or (lo is not None and v < lo):
            self.fail(where, f"expected an integer{f' >= {lo}' if lo is not None else ''}, got {json.dumps(v)[:40]}")
        return int(v)

    def text(self, v, where: str) -> str:
        if not isinstance(v, str) or not v:
            self.fail(where, f"expected a non-empty string, got {json.dumps(v)[:40]}")
        return v

    def flag(self, v, where: str) -> bool:
        if not isinstance(v, bool):
            self.fail(where, f"expected true or false, got {json.dumps(v)[:40]}")
        return v

    def numbers(self, v, where: str, n: int | None = None, allow_none: bool = False) -> list:
        if not isinstance(v, list) or (n is not None and len(v) != n):
            self.fail(where, f"expected a list of {n} numbers" if n is not None else "expected a list of numbers")
        return [self.number(x, f"{where}[{i}]", allow_none) for i, x in enumerate(v)]

    def texts(self, v, where: str, n: int | None = None) -> tuple[str, ...]:
        if not isinstance(v, list) or (n is not None and len(v) != n):
            self.fail(where, f"expected a list of {n} names" if n is not None else "expected a list of names")
        return tuple(self.text(x, f"{where}[{i}]") for i, x in enumerate(v))


def read_model(path) -> "SavedModel":
    """Parse the model file at ``path``: a regular file of bounded size (a FIFO or /dev/zero given as
    the model would never end), UTF-8; ModelError in one line otherwise."""
    from pathlib import Path

    from minparam_cli.safety import read_bounded
    from minparam_cli.errors import DescriptionError

    path = Path(path)
    try:
        text = read_bounded(path).decode("utf-8")
    except DescriptionError as e:
        raise ModelError(f"cannot read the model file: {e}") from None
    except UnicodeDecodeError as e:
        raise ModelError(f"{path}: cannot read the model file (not UTF-8 text: {e.reason})") from None
    return parse_model(text, str(path))


def parse_model(text: str, source: str) -> SavedModel:
    """The model in ``text`` (a model file's contents); ``source`` names it in errors."""
    r = _Reader(source)
    try:
        doc = json.loads(text)
    except ValueError as e:
        raise ModelError(f"{source}: not a JSON document ({e})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ModelError(f"{source}: not a minparam model file (expected \"format\": \"{FORMAT}\")")
    version = r.get(doc, "version", "version")
    if version not in READS:
        r.fail("version", f"format version {json.dumps(version)} is not supported (this minparam reads versions "
                          f"{', '.join(str(v) for v in READS)})")

    robot = r.get(doc, "robot", "robot")
    path = r.text(r.get(robot, "path", "robot"), "robot.path")
    sha = r.text(r.get(robot, "sha256", "robot"), "robot.sha256")
    if len(sha) != 64 or any(c not in "0123456789abcdef" for c in sha):
        r.fail("robot.sha256", "expected 64 lower-case hex digits")

    ld = r.get(doc, "load", "load")
    friction = r.texts(r.get(ld, "friction", "load"), "load.friction")
    gravity = r.get(ld, "gravity", "load")
    load = LoadSettings(
        friction=friction,
        rotor_inertia=r.flag(r.get(ld, "rotor_inertia", "load"), "load.rotor_inertia"),
        gravity=None if gravity is None else tuple(r.numbers(gravity, "load.gravity", 3)),
        coulomb_smoothing=r.number(r.get(ld, "coulomb_smoothing", "load"), "load.coulomb_smoothing"),
        mimic=r.text(r.get(ld, "mimic", "load"), "load.mimic"),
        floating_base=r.flag(r.get(ld, "floating_base", "load"), "load.floating_base"),
    )
    from minparam_cli.params import FRICTION_KINDS

    for k in load.friction:
        if k not in FRICTION_KINDS:
            r.fail("load.friction", f"unknown friction kind {k!r}")
    if load.coulomb_smoothing < 0:
        r.fail("load.coulomb_smoothing", "expected a velocity >= 0")

    base = r.get(doc, "base", "base")
    seed = r.integer(r.get(base, "seed", "base"), "base.seed")
    kept_raw = r.get(base, "kept", "base")
    if not isinstance(kept_raw, list) or not kept_raw:
        r.fail("base.kept", "expected a non-empty list of column indices")
    kept = tuple(r.integer(k, f"base.kept[{i}]", 0) for i, k in enumerate(kept_raw))
    base_names = r.texts(r.get(base, "names", "base"), "base.names", len(kept))

    dd = r.get(doc, "design", "design")
    terms_raw = r.get(dd, "terms", "design")
    if not isinstance(terms_raw, list):
        r.fail("design.terms", "expected a list")
    terms, evidence = [], []
    for i, t in enumerate(terms_raw):
        where = f"design.terms[{i}]"
        effect = r.text(r.get(t, "effect", where), f"{where}.effect")
        if version == 1 and effect == "spring":  # version 1's spring: columns q, sin q, cos q
            effect = LEGACY_SPRING
        if effect not in EFFECTS:
            r.fail(f"{where}.effect", f"unknown effect {effect!r}")
        joints_raw = r.get(t, "joints", where)
        if not isinstance(joints_raw, list) or not joints_raw:
            r.fail(f"{where}.joints", "expected a non-empty list of joint numbers (1-based)")
        joints = tuple(r.integer(j, f"{where}.joints", 1) - 1 for j in joints_raw)
        hyper = r.number(r.get(t, "hyper", where), f"{where}.hyper", allow_none=True)
        if (hyper is None) != (not EFFECTS[effect].grid):
            r.fail(f"{where}.hyper", f"effect {effect} {'needs' if EFFECTS[effect].grid else 'takes no'} grid value")
        terms.append(Term(effect, joints, hyper))
        ev = t.get("evidence") if isinstance(t, dict) else None  # version 2; absent in version 1
        if ev is not None and not isinstance(ev, dict):
            r.fail(f"{where}.evidence", "expected a JSON object or null")
        evidence.append(ev)
    tm = r.get(dd, "theta_model", "design")
    theta_model = None if tm is None else np.array(r.numbers(tm, "design.theta_model"))
    t0 = r.number(r.get(dd, "t0", "design"), "design.t0", allow_none=True)

    pp = r.get(doc, "parameters", "parameters")
    names = r.texts(r.get(pp, "names", "parameters"), "parameters.names")
    theta = np.array(r.numbers(r.get(pp, "theta", "parameters"), "parameters.theta", len(names)))
    std = tuple(r.numbers(r.get(pp, "std_percent", "parameters"), "parameters.std_percent", len(names), allow_none=True))
    if names[: len(kept)] != base_names:
        r.fail("parameters.names", "the first names are not the base names (base.names)")
    if theta_model is not None and len(theta_model) < len(kept):
        r.fail("design.theta_model", f"expected at least {len(kept)} numbers, one per base parameter")

    physical = None
    ph = r.get(doc, "physical", "physical")
    if ph is not None:
        phi_names = r.texts(r.get(ph, "phi_names", "physical"), "physical.phi_names")
        phi = np.array(r.numbers(r.get(ph, "phi", "physical"), "physical.phi", len(phi_names)))
        ptheta = np.array(r.numbers(r.get(ph, "theta", "physical"), "physical.theta", len(names)))
        physical = PhysicalParameters(phi_names, phi, ptheta)

    da = r.get(doc, "data", "data")
    for k in DATA_KEYS:
        r.get(da, k, "data")
    columns = da["columns"]
    if not isinstance(columns, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in columns.items()):
        r.fail("data.columns", "expected an object of KEY: NAME strings")
    decimate = da["decimate"]
    data = DataOptions(
        columns=dict(columns),
        cutoff_hz=r.number(da["cutoff_hz"], "data.cutoff_hz"),
        force_filter=r.flag(da["force_filter"], "data.force_filter"),
        chunk_rows=r.integer(da["chunk_rows"], "data.chunk_rows", 1),
        decimate=None if decimate is None else r.integer(decimate, "data.decimate", 1),
        step_s=r.number(da["step_s"], "data.step_s", allow_none=True),
        still_speed=r.number(da["still_speed"], "data.still_speed"),
        trim_still_s=r.number(da["trim_still_s"], "data.trim_still_s", allow_none=True),
        motor_side=_motor_side(r, da.get("motor_side")),
        rest_below_still=r.flag(da.get("rest_below_still", False), "data.rest_below_still"),
    )
    figures = doc.get("figures") or {}
    if not isinstance(figures, dict):
        r.fail("figures", "expected a JSON object")
    return SavedModel(path, sha, load, seed, kept, base_names, tuple(terms), theta_model, t0, names, theta, std,
                      data, physical, figures, _parse_uncertainty(r, doc, len(names)), tuple(evidence))


def _motor_side(r: _Reader, v) -> tuple | None:
    """data.motor_side of a saved model (optional; absent in files of joint-side data)."""
    if v is None:
        return None
    rows = r.get(v, "matrix", "data.motor_side")
    if not isinstance(rows, list) or not rows:
        r.fail("data.motor_side.matrix", "expected a square list of rows")
    n = len(rows)
    matrix = tuple(tuple(r.numbers(row, f"data.motor_side.matrix[{i}]", n)) for i, row in enumerate(rows))
    s = np.linalg.svd(np.array(matrix), compute_uv=False)
    if not s[-1] > 1e-10 * s[0]:
        r.fail("data.motor_side.matrix", "the coupling matrix is singular")
    zero = tuple(r.numbers(r.get(v, "zero", "data.motor_side"), "data.motor_side.zero", n))
    gains = v.get("gains")
    gains = None if gains is None else tuple(r.numbers(gains, "data.motor_side.gains", n))
    if gains is not None and not all(g > 0 for g in gains):
        r.fail("data.motor_side.gains", "a drive gain must be positive")
    return matrix, zero, gains


def _parse_uncertainty(r, doc: dict, p: int) -> dict | None:
    un = doc.get("uncertainty")
    if un is None:
        return None
    kind = r.text(r.get(un, "sigma", "uncertainty"), "uncertainty.sigma")
    cols_raw = r.get(un, "columns", "uncertainty")
    if not isinstance(cols_raw, list) or not cols_raw:
        r.fail("uncertainty.columns", "expected a non-empty list of design column indices")
    cols = [r.integer(c, f"uncertainty.columns[{i}]", 0) for i, c in enumerate(cols_raw)]
    if max(cols) >= p or len(set(cols)) != len(cols):
        r.fail("uncertainty.columns", f"expected distinct indices below {p}, one per fitted parameter")
    cov_raw = r.get(un, "covariance", "uncertainty")
    if not isinstance(cov_raw, list) or len(cov_raw) != len(cols):
        r.fail("uncertainty.covariance", f"expected {len(cols)} rows")
    cov = np.array([r.numbers(row, f"uncertainty.covariance[{i}]", len(cols)) for i, row in enumerate(cov_raw)])
    if not np.allclose(cov, cov.T, rtol=1e-9, atol=0.0) or np.any(np.diag(cov) < 0):
        r.fail("uncertainty.covariance", "expected a symmetric matrix with a non-negative diagonal")
    sig = r.numbers(r.get(un, "residual_sigma_per_joint", "uncertainty"), "uncertainty.residual_sigma_per_joint")
    if any(s < 0 for s in sig):
        r.fail("uncertainty.residual_sigma_per_joint", "expected numbers >= 0")
    return {"sigma": kind, "columns": cols, "covariance": cov.tolist(), "residual_sigma_per_joint": sig}
