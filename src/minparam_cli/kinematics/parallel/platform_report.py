"""Renderers for the platform commands: results in, JSON-ready dicts or table text out (pure)."""

from __future__ import annotations

import math

import numpy as np

from minparam_cli.kinematics.parallel.platform import POSE_NAMES, PlatformModel, normal_from_rpy
from minparam_cli.kinematics.parallel.platform_fk import FKResult
from minparam_cli.kinematics.parallel.platform_truss import TrussFKResult, TrussModel
from minparam_cli.kinematics.parallel.platform_workspace import WorkspaceResult


def to_unit(angle: float, unit: str) -> float:
    return math.degrees(angle) if unit == "deg" else float(angle)


def pose_dict(pose, angle_unit: str) -> dict:
    return {k: (float(v) if i < 3 else to_unit(v, angle_unit)) for i, (k, v) in enumerate(zip(POSE_NAMES, pose, strict=True))}


def _units(length_unit: str, angle_unit: str | None = None) -> dict:
    out = {"length": length_unit}
    if angle_unit:
        out["angle"] = angle_unit
    return out


def _finite(x):
    return None if x is None or not math.isfinite(x) else float(x)


def _table(headers, rows, floatfmt):
    from tabulate import tabulate

    return tabulate(rows, headers=headers, floatfmt=floatfmt, disable_numparse=False)


# ---------------------------------------------------------------- inverse


def ik_dict(model: PlatformModel, pose, lengths, ok) -> dict:
    n = normal_from_rpy(*pose[3:])
    return {
        "model": model.name,
        "pose": pose_dict(pose, model.angle_unit),
        "normal": [float(v) for v in n],
        "lengths": [float(v) for v in lengths],
        "legs": [
            {"name": name, "nodes": [model.base_names[b], model.platform_names[p]], "length": float(length),
             "limits": None if not np.all(np.isfinite(lim)) else [float(v) for v in lim], "within_limits": bool(k)}
            for name, b, p, length, lim, k in zip(
                model.leg_names, model.leg_base, model.leg_platform, lengths, model.limits, ok, strict=True)
        ],
        "units": _units(model.length_unit, model.angle_unit),
    }


def ik_table(d: dict) -> str:
    u, a = d["units"]["length"], d["units"]["angle"]
    p = d["pose"]
    lines = [
        f"{d['model']}: inverse kinematics (Dang 2013 eq. 3)",
        "pose: " + ", ".join(f"{k} = {p[k]:.6g}" for k in POSE_NAMES) + f"   [{u}, {a}]",
        "platform normal n = R (0, 0, 1) = (" + ", ".join(f"{v:.6g}" for v in d["normal"]) + ")",
        "",
    ]
    rows = [[leg["name"], "-".join(leg["nodes"]), leg["length"],
             "none" if leg["limits"] is None else f"{leg['limits'][0]:g} .. {leg['limits'][1]:g}",
             "yes" if leg["within_limits"] else "NO"] for leg in d["legs"]]
    lines.append(_table(["leg", "nodes", f"length [{u}]", "limits", "within"], rows, ".6f"))
    return "\n".join(lines)


def truss_ik_dict(model: TrussModel, coords, lengths) -> dict:
    lim = model.limits
    return {
        "model": model.name,
        "nodes": {n: [float(v) for v in c] for n, c in zip(model.node_names, coords, strict=True)},
        "lengths": [float(v) for v in lengths],
        "legs": [
            {"name": name, "nodes": [model.node_names[a], model.node_names[b]], "length": float(length),
             "within_limits": bool(not np.all(np.isfinite(lim[k])) or lim[k, 0] <= length <= lim[k, 1])}
            for k, (name, (a, b), length) in enumerate(zip(model.leg_names, model.legs, lengths, strict=True))
        ],
        "units": _units(model.length_unit),
    }


def truss_ik_table(d: dict) -> str:
    u = d["units"]["length"]
    rows = [[leg["name"], "-".join(leg["nodes"]), leg["length"], "yes" if leg["within_limits"] else "NO"]
            for leg in d["legs"]]
    return f"{d['model']}: twelve leg lengths of the truss\n\n" + _table(
        ["leg", "nodes", f"length [{u}]", "within"], rows, ".6f")


# ---------------------------------------------------------------- forward


def fk_dict(model: PlatformModel, result: FKResult, seed: int, elapsed: float) -> dict:
    sols = []
    for s in result.solutions:
        sols.append({
            "pose": pose_dict(s.pose, model.angle_unit),
            "normal": [float(v) for v in normal_from_rpy(*s.pose[3:])],
            "residual": float(s.residual),
            "starts": s.starts,
        })
    out = {
        "solutions": sols,
        "seed": seed,
        "elapsed_s": round(float(elapsed), 6),
        "model": model.name,
        "method": result.method,
        "lengths": [float(v) for v in result.target],
        "units": _units(model.length_unit, model.angle_unit),
        "tolerance": {"relative": result.rtol, "absolute": result.tolerance},
    }
    if result.certificate is not None:
        out["certificate"] = _cert_dict(result.certificate)
    if result.starts is not None:
        out["starts_run"] = result.starts
        out["failed_starts"] = result.failed_starts
        out["settings"] = result.settings
    if result.note:
        out["note"] = result.note
    return out


def _cert_dict(c) -> dict:
    return {"verified_roots": c.verified_roots, "bound": c.bound, "complete": c.complete,
            "imag_margin": _finite(c.imag_margin), "min_singular": _finite(c.min_singular),
            "interpolation_error": float(c.interpolation_error)}


def _cert_lines(c: dict | None) -> list[str]:
    if c is None:
        return []
    state = "complete" if c["complete"] else "INCOMPLETE: some real modes may be missing"
    margin = "none (all real)" if c["imag_margin"] is None else f"{c['imag_margin']:.3g}"
    sv = "n/a" if c["min_singular"] is None else f"{c['min_singular']:.3g}"
    return [
        f"certificate: {c['verified_roots']} of {c['bound']} roots of the degree-{c['bound']} eliminant "
        f"lifted to verified solutions ({state});",
        f"  smallest relative |Im| of a non-real solution {margin}; smallest Jacobian singular value of a "
        f"real one {sv} (relative); interpolation error {c['interpolation_error']:.1e}",
    ]


def fk_table(d: dict) -> str:
    u, a = d["units"]["length"], d["units"]["angle"]
    method = {"exact": "exact (elimination to a degree-16 polynomial)",
              "pso": "pso (particle swarm, multistart, Levenberg-Marquardt polish)",
              "multistart": "multistart (random starts, Levenberg-Marquardt)"}[d["method"]]
    lines = [f"{d['model']}: forward kinematics, method {method}",
             "lengths: " + ", ".join(f"{v:.10g}" for v in d["lengths"]) + f" [{u}]", ""]
    if d["solutions"]:
        rows = [[i + 1] + [s["pose"][k] for k in POSE_NAMES] + [s["residual"], "-" if s["starts"] is None else s["starts"]]
                for i, s in enumerate(d["solutions"])]
        headers = ["#", f"x [{u}]", f"y [{u}]", f"z [{u}]", f"roll [{a}]", f"pitch [{a}]", f"yaw [{a}]",
                   f"residual [{u}]", "starts"]
        lines.append(_table(headers, rows, ("", ".6f", ".6f", ".6f", ".6f", ".6f", ".6f", ".1e", "")))
    n = len(d["solutions"])
    above = sum(1 for s in d["solutions"] if s["pose"]["z"] > 0)
    lines += ["", f"{n} real assembly mode{'s' if n != 1 else ''} ({above} with z > 0, {n - above} with z <= 0)."]
    if d.get("note"):
        lines.append(d["note"])
    lines += _cert_lines(d.get("certificate"))
    if "starts_run" in d:
        lines.append(f"starts: {d['starts_run']} run, {d['failed_starts']} ended above the tolerance")
    t = d["tolerance"]
    lines.append(f"tolerance: max |l - l*| <= {t['relative']:g} x max l* = {t['absolute']:.3g} {u}")
    lines.append(f"seed {d['seed']}, {d['elapsed_s']:.3f} s")
    return "\n".join(lines)


def truss_fk_dict(model: TrussModel, result: TrussFKResult, seed: int, elapsed: float) -> dict:
    out = {
        "solutions": [{"nodes": {n: [float(v) for v in c] for n, c in zip(model.node_names, s.nodes, strict=True)},
                       "residual": float(s.residual), "starts": None} for s in result.solutions],
        "seed": seed,
        "elapsed_s": round(float(elapsed), 6),
        "model": model.name,
        "method": "exact",
        "frame": [model.node_names[i] for i in result.frame],
        "lengths": [float(v) for v in result.target],
        "units": _units(model.length_unit),
        "tolerance": {"relative": result.rtol, "absolute": result.tolerance},
    }
    if result.certificate is not None:
        out["certificate"] = _cert_dict(result.certificate)
    if result.note:
        out["note"] = result.note
    return out


def truss_fk_table(d: dict) -> str:
    u = d["units"]["length"]
    a, b, c = d["frame"]
    lines = [f"{d['model']}: forward kinematics of the 12-leg truss, method exact (elimination, degree 16)",
             f"frame: {a} at the origin, {b} on +x, {c} in the xy-plane (y > 0); mirror images come in pairs", ""]
    for i, s in enumerate(d["solutions"]):
        rows = [[n] + list(xyz) for n, xyz in s["nodes"].items()]
        lines.append(f"solution {i + 1}: residual {s['residual']:.1e} {u}")
        lines.append(_table(["node", f"x [{u}]", f"y [{u}]", f"z [{u}]"], rows, ".6f"))
        lines.append("")
    lines.append(f"{len(d['solutions'])} real configurations.")
    if d.get("note"):
        lines.append(d["note"])
    lines += _cert_lines(d.get("certificate"))
    t = d["tolerance"]
    lines.append(f"tolerance: max |l - l*| <= {t['relative']:g} x max l* = {t['absolute']:.3g} {u}")
    lines.append(f"seed {d['seed']}, {d['elapsed_s']:.3f} s")
    return "\n".join(lines)


# ---------------------------------------------------------------- workspace


def workspace_dict(model: PlatformModel, result: WorkspaceResult, elapsed: float) -> dict:
    vol, se = result.volume
    return {
        "model": model.name,
        "samples": result.samples,
        "reachable": result.count,
        "fraction": result.fraction,
        "volume": vol,
        "volume_se": se,
        "box": {k: [float(lo), float(hi)] if i < 3 else [to_unit(lo, model.angle_unit), to_unit(hi, model.angle_unit)]
                for i, (k, (lo, hi)) in enumerate(zip(POSE_NAMES, result.box, strict=True))},
        "legs": [{"name": n, "limits": [float(v) for v in lim], "too_short": int(s), "too_long": int(lg)}
                 for n, lim, s, lg in zip(model.leg_names, model.limits, result.too_short, result.too_long, strict=True)],
        "centroid": [float(v) for v in result.reachable[:, :3].mean(axis=0)] if result.count else None,
        "units": _units(model.length_unit, model.angle_unit),
        "seed": result.seed,
        "elapsed_s": round(float(elapsed), 6),
    }


def workspace_table(d: dict) -> str:
    u, a = d["units"]["length"], d["units"]["angle"]
    box = ", ".join(f"{k} {lo:g}..{hi:g}" for k, (lo, hi) in d["box"].items())
    lines = [
        f"{d['model']}: workspace by sampling (every leg within its limits)",
        f"box: {box}   [{u}, {a}]",
        f"reachable: {d['reachable']} of {d['samples']} samples ({100 * d['fraction']:.2f} %)",
        f"reachable position volume: {d['volume']:.6g} ± {d['volume_se']:.2g} {u}^3 (binomial standard error)",
        "",
        _table(["leg", "limits", "too short", "too long"],
               [[leg["name"], f"{leg['limits'][0]:g} .. {leg['limits'][1]:g}", leg["too_short"], leg["too_long"]]
                for leg in d["legs"]], "g"),
        "",
        f"seed {d['seed']}, {d['elapsed_s']:.3f} s",
    ]
    return "\n".join(lines)
