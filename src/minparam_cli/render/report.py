"""The derive report: the JSON contract, built once from a chain and its base set.

Every renderer (table, Markdown, LaTeX, JSON) reads this dict, so JSON out ->
in -> any format is a round trip.
"""

from __future__ import annotations

import numpy as np

from minparam_cli.base.result import BaseSet
from minparam_cli.chain import Chain

UNITS = {"length": "m", "mass": "kg", "first_moment": "kg·m", "inertia": "kg·m²", "torque": "N·m or N"}


def format_coefficient(c: float) -> str:
    return f"{c:.6g}"


def expression(terms: dict[str, float]) -> str:
    """{'ZZ1': 1, 'YY2': 1, 'M3': 0.18645} -> 'ZZ1 + YY2 + 0.18645*M3'."""
    out = ""
    for name, c in terms.items():
        sign = "-" if c < 0 else "+"
        mag = abs(c)
        coef = format_coefficient(mag)
        body = name if coef == "1" else f"{coef}*{name}"
        out = (f"-{body}" if sign == "-" else body) if not out else f"{out} {sign} {body}"
    return out


def base_report(chain: Chain, base: BaseSet, elapsed_s: float) -> dict:
    names = list(base.standard_names)
    base_params = []
    for i, bname in enumerate(base.base_names):
        terms = base.terms(i)
        base_params.append({"name": bname, "expression": expression(terms), "terms": terms})
    links = []
    for j, number in enumerate(chain.layout.link_numbers):
        links.append(
            {
                "index": number,
                "joint": chain.joint_names[j],
                "link": chain.link_names[j],
                "type": chain.types[j],
                # the parent link's number; 0 is the fixed base (or, on a floating base, the free link)
                "parent": chain.layout.link_numbers[chain.parents[j]] if chain.parents[j] >= 0 else (None if chain.floating_base else 0),
            }
        )
    coupling = chain.coupling
    if coupling is not None:
        for j in range(chain.n):
            if j not in coupling.coordinates:
                i = int(np.flatnonzero(coupling.G[j])[0]) if np.any(coupling.G[j]) else 0
                master = coupling.coordinates[i]
                links[j]["mimic"] = {"joint": chain.joint_names[master], "multiplier": float(coupling.G[j, i]), "offset": float(coupling.offset[j])}
    report = {
        "robot": chain.name,
        "source": chain.source,
        "method": base.method,
        "dof": chain.dof,
        "floating_base": chain.floating_base,
        "convention": chain.convention,
        "gravity": [float(g) for g in chain.gravity],
        "gravity_source": chain.gravity_source,
        "seed": base.seed,
        "samples": base.samples,
        "exact": bool(base.exact),
        "units": UNITS,
        "standard_parameters": names,
        "base_parameters": base_params,
        "unidentifiable": [names[i] for i in base.unidentifiable],
        "n_standard": base.n_standard,
        "n_base": base.n_base,
        "rank_margin": _jsonable(base.rank_margin),
        "links": links,
        "elapsed_s": round(float(elapsed_s), 6),
    }
    if base.extra:
        report["diagnostics"] = _jsonable(base.extra)
    return report


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    return x
