"""Text and JSON renderings of ``minparam singular`` results (pure: data in, str or dict out).

The local test at one configuration, the singular-set scan and the symbolic
minors each have a table and a JSON form; JSON keeps every number, the table
prints 6 significant digits and zeros below 1e-12 of the row's scale.
"""

from __future__ import annotations

import math

import numpy as np


def _num(x: float, scale: float = 1.0) -> str:
    """Short number; values below 1e-12 of ``scale`` print as 0 (JSON keeps them)."""
    x = float(x)
    if math.isinf(x):
        return "inf"
    if abs(x) < 1e-12 * max(scale, 1e-300):
        return "0"
    return f"{x:.6g}"


def _vec(v, scale=None) -> str:
    v = np.asarray(v, dtype=float)
    s = float(np.max(np.abs(v))) if scale is None and v.size else (scale or 1.0)
    return "(" + ", ".join(_num(x, s) for x in v) + ")"


def _joints1(js) -> list[int]:
    return [int(j) + 1 for j in js]


def _q_text(chain_types, q, angle) -> str:
    out = []
    for t, v in zip(chain_types, q, strict=True):
        if t == "revolute":
            out.append(_num(math.degrees(v) if angle == "deg" else v, 1.0))
        else:
            out.append(_num(v, 1.0) + " m")
    return ", ".join(out)


def json_safe(obj):
    """JSON-safe: numpy to Python, inf/nan to None."""
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        x = float(obj)
        return x if math.isfinite(x) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def local_json(report, check, seed: int) -> dict:
    from minparam_cli.kinematics.serial.nearest_twist import twist_distances
    from minparam_cli.kinematics.serial.plucker import SCREW_CONVENTION, TWIST_CONVENTION

    t = report.test
    out = {
        "joint_names": list(report.joint_names),
        "joint_types": list(report.types),
        "q": report.q,
        "units": {"q": "rad (revolute), m (prismatic)", "joint_rates": "rad/s (revolute), m/s (prismatic)",
                  "twist": "rad/s, m/s", "lengths": "m"},
        "twist_convention": TWIST_CONVENTION,
        "screw_convention": SCREW_CONVENTION,
        "tool_point": report.tool_point,
        "length_scale": report.length_scale,
        "plucker_matrix": report.plucker,
        "det": t.det,
        "sigma_min": t.sigma_min,
        "singular_values": t.singular_values,
        "epsilon": t.epsilon,
        "epsilon_meaning": "relative: sigma_i / sigma_max of the screw matrix with linear rows at O_c divided by length_scale "
        "and prismatic columns multiplied by it",
        "rank": t.rank,
        "full_rank": t.full_rank,
        "singular": t.singular,
        "cut_ratio": t.cut_ratio,
        "deletion_ranks": list(report.deletion_ranks),
        "dependent_joints": _joints1(report.dependent_joints),
        "dependent_groups": [_joints1(g) for g in report.groups],
        "null_space": report.null_space.T,
        "held_joints": _joints1(report.held_joints),
        "reciprocal_screws": [h.plucker for h in report.reciprocal],
        "reciprocal_screw_details": [
            {"kind": h.kind, "pitch": None if h.kind == "couple" else h.pitch, "axis_point": h.axis_point,
             "direction": None if h.kind == "couple" else h.plucker[:3], "moment_at_tool": h.moment_at_tool}
            for h in report.reciprocal
        ],
        "requested_twist": None,
        "nearest_twist": None,
        "joint_rates": None,
        "notes": list(report.notes),
    }
    sol = report.twist
    if sol is not None:
        L = report.length_scale
        dist = {}
        for name, tw in (("nearest", sol.nearest), ("least_squares", sol.least_squares), ("damped", sol.damped)):
            dw, dv, w = twist_distances(sol.requested, tw, L)
            dist[name] = {"angular": dw, "linear": dv, "weighted": w}
        out.update(
            {
                "requested_twist": sol.requested,
                "nearest_twist": sol.nearest,
                "joint_rates": sol.joint_rates,
                "nearest_method": "Glazunov: angular part projected on the polar plane(s) of H through O_c, "
                "linear part on the plane(s) perpendicular to h",
                "least_squares_twist": sol.least_squares,
                "least_squares_rates": sol.least_squares_rates,
                "damped_twist": sol.damped,
                "damped_rates": sol.damped_rates,
                "damping": sol.damping,
                "distances": dist,
                "distance_weighting": "weighted = sqrt(|dw|^2 + (|dv| / length_scale)^2)",
                "reciprocity_residual": sol.reciprocity_residual,
                "reproduction_residual": sol.reproduction_residual,
            }
        )
        if check is not None:
            out["nearest_check"] = {
                "seed": seed,
                "samples": check.samples,
                "closer_in_paper_set": check.paper_set_closer,
                "closer_than_least_squares": check.full_set_closer_than_lsq,
                "closer_than_nearest_in_weighted_metric": check.full_set_closer_than_paper,
            }
    out["seed"] = seed
    return out


def local_table(report, check, seed: int, angle: str) -> str:
    t = report.test
    unit = "deg" if angle == "deg" else "rad"
    lines = [
        f"q          {_q_text(report.types, report.q, angle)}   (revolute in {unit})",
        f"O_c        {_vec(report.tool_point, 1.0)} m   (tool point, base frame)",
    ]
    if t.det is not None:
        lines.append(f"det (3)    {_num(t.det, 1.0)}   (matrix (3), SI units, moments about the base origin)")
    sv = ", ".join(_num(x, 1.0) for x in t.singular_values)
    lines.append(f"sigma/max  {sv}")
    verdict = "SINGULAR" if t.singular else "not singular"
    margin = f"cut ratio {_num(t.cut_ratio, 1.0)}" if t.singular else f"sigma_min/eps = {_num(t.sigma_min / t.epsilon, 1.0)}"
    lines.append(f"rank       {t.rank} of {t.full_rank}: {verdict}   (sigma_min/sigma_max = {_num(t.sigma_min, 1.0)}, "
                 f"epsilon = {t.epsilon:g} relative; {margin})")
    if report.dependent_joints or t.singular:
        lines.append(f"dependent  joints {_joints1(report.dependent_joints)}   (column-deletion test)")
        for g in report.groups:
            lines.append(f"  group    {_joints1(g)}: {len(g)} screws in a {len(g) - 1}-system")
    if report.held_joints:
        lines.append(f"held       joint(s) {_joints1(report.held_joints)} at zero rate")
    for i, h in enumerate(report.reciprocal, 1):
        if h.kind == "couple":
            desc = f"pure couple (pitch inf), moment direction {_vec(h.plucker[3:], 1.0)}"
        else:
            desc = f"pitch {_num(h.pitch, 1.0)} m, axis through {_vec(h.axis_point, 1.0)} along {_vec(h.plucker[:3], 1.0)}"
        lines.append(f"H{i}         (h; h0) = {_vec(h.plucker, 1.0)}   {desc}")
    sol = report.twist
    if sol is not None:
        from tabulate import tabulate

        L = report.length_scale
        from minparam_cli.kinematics.serial.nearest_twist import twist_distances

        rows = []
        for name, tw in (("requested", sol.requested), ("nearest (Glazunov)", sol.nearest),
                         ("least squares", sol.least_squares), (f"damped LS (lambda={sol.damping:g})", sol.damped)):
            dw, dv, w = twist_distances(sol.requested, tw, L)
            rows.append([name, *[_num(x, 1.0) for x in tw], _num(dw, 1.0), _num(dv, 1.0)])
        lines.append("")
        lines.append("twist at O_c (rad/s, m/s; base frame)")
        lines.append(tabulate(rows, headers=["", "wx", "wy", "wz", "vx", "vy", "vz", "|dw|", "|dv|"], tablefmt="simple"))
        rows = []
        for j, name in enumerate(report.joint_names):
            u = "rad/s" if report.types[j] == "revolute" else "m/s"
            mark = " (held)" if j in report.held_joints else ""
            rows.append([f"{j + 1} {name}{mark}", u, _num(sol.joint_rates[j], 1.0), _num(sol.least_squares_rates[j], 1.0),
                         _num(sol.damped_rates[j], 1.0)])
        lines.append("")
        lines.append(tabulate(rows, headers=["joint", "unit", "nearest", "least squares", "damped LS"], tablefmt="simple"))
        lines.append(f"checks     reciprocity {_num(sol.reciprocity_residual, 1.0)}, reproduction {_num(sol.reproduction_residual, 1.0)}")
        if check is not None:
            lines.append(
                f"           {check.samples} random feasible twists (seed {seed}): {check.paper_set_closer} closer in the paper's "
                f"set, {check.full_set_closer_than_lsq} closer than least squares, "
                f"{check.full_set_closer_than_paper} closer than the projection in the weighted metric"
            )
    for note in report.notes:
        lines.append(f"note       {note}")
    return "\n".join(lines)


def scan_json(r) -> dict:
    from minparam_cli.kinematics.serial.singular_scan import MAX_POINTS_KEPT

    listed = min(r.points.shape[0], 5000)
    return {
        "swept_joints": [a.joint + 1 for a in r.axes],
        "grid": {str(a.joint + 1): {"from": float(a.values[0]), "to": float(a.values[-1]), "points": int(a.values.size),
                                    "step": a.step, "periodic": a.periodic} for a in r.axes},
        "q_fixed": r.q_fixed,
        "epsilon": r.epsilon,
        "nodes": r.nodes,
        "node_hits": r.node_hits,
        "crossings": r.crossings,
        "sigma_min_on_grid": r.sigma_grid_min,
        "points_total": int(r.points.shape[0]),
        "points_kept_limit": MAX_POINTS_KEPT,
        "points": r.points[:listed],
        "points_sigma": r.sigma[:listed],
        "points_set": r.point_set[:listed],
        "sets": [
            {
                "dependent_joints": _joints1(s.dependent_joints),
                "groups": [_joints1(g) for g in s.groups],
                "groups_agree_with_deletion_test": s.consistent,
                "rank": s.rank,
                "count": s.count,
                "example_q": s.example,
                "constant": {str(j + 1): list(v) for j, v in s.constant.items()},
                "ranges": {str(j + 1): list(v) for j, v in s.ranges.items()},
            }
            for s in r.sets
        ],
        "notes": list(r.notes),
    }


def joint_value_text(types, j, v, angle) -> str:
    """Joint j's value v as text: degrees or radians (``angle``) for a revolute joint, metres otherwise."""
    if types[j] == "revolute":
        return _num(math.degrees(v) if angle == "deg" else v, 1.0)
    return _num(v, 1.0) + " m"


def scan_table(r, types, angle: str) -> str:
    from tabulate import tabulate

    lines = ["scan (Glazunov's global problem)"]
    if not r.axes:
        lines.append("  no joint changes the relative position of the axes")
    for a in r.axes:
        lines.append(
            f"  joint {a.joint + 1}: {a.values.size} values from {joint_value_text(types, a.joint, a.values[0], angle)} "
            f"to {joint_value_text(types, a.joint, a.values[-1], angle)}{' (one turn)' if a.periodic else ''}, "
            f"step {joint_value_text(types, a.joint, a.step, angle)}"
        )
    lines.append(f"  grid nodes {r.nodes}; nodes with sigma_min/sigma_max <= {r.epsilon:g}: {r.node_hits}; "
                 f"crossings located between nodes: {r.crossings}; smallest value on the grid {_num(r.sigma_grid_min, 1.0)}")
    lines.append(f"  singular points found: {r.points.shape[0]}, in {len(r.sets)} set(s) by dependent joints")
    rows = []
    for s in r.sets:
        const = "; ".join(f"q{j + 1} in {{{', '.join(joint_value_text(types, j, v, angle) for v in vals)}}}"
                          for j, vals in s.constant.items())
        groups = " ".join(str(_joints1(g)) for g in s.groups) + ("" if s.consistent else " (near the cut)")
        rows.append([str(_joints1(s.dependent_joints)), groups, s.rank, s.count, const or "-"])
    if rows:
        lines.append(tabulate(rows, headers=["dependent", "groups", "rank", "points", "constant over the set"], tablefmt="simple"))
    lines.append("  (revolute values in " + ("degrees" if angle == "deg" else "radians") + ", prismatic in m)")
    for note in r.notes:
        lines.append(f"note       {note}")
    return "\n".join(lines)


def symbolic_json(sym) -> dict:
    def cond(c):
        return {"expression": c.expression, "joints": _joints1(c.joints), "multiplicity": c.multiplicity,
                "solutions": None if c.solutions is None else list(c.solutions)}

    return {
        "what": sym.what,
        "variables": "q1..qn in rad (revolute) and m (prismatic); geometry read exactly from the file" if sym.exact_geometry
        else "q1..qn; geometry from floating-point values converted exactly",
        "conditions": [cond(c) for c in sym.conditions],
        "groups": [
            {"joints": _joints1(g.group), "minors": g.minors, "status": g.status, "conditions": [cond(c) for c in g.conditions]}
            for g in sym.groups if g.status != "never"
        ],
    }


def symbolic_table(sym, chain, angle: str) -> str:
    what = "det of matrix (3) = 0" if sym.what == "det" else f"all {sym.what} of matrix (3) vanish"
    lines = [f"symbolic conditions ({what}; each factor is one branch of the singular set)"]
    if not sym.conditions:
        lines.append("  no common factor: the singular set needs several simultaneous conditions")
    for c in sym.conditions:
        sol = ""
        if c.solutions is not None:
            sol = "   ->  " + ", ".join(f"q{c.joints[0] + 1} = {joint_value_text(chain.types, c.joints[0], v, angle)}" for v in c.solutions)
        mult = f"  (multiplicity {c.multiplicity})" if c.multiplicity > 1 else ""
        lines.append(f"  {c.expression}{mult}{sol}")
    shown = [g for g in sym.groups if g.status in ("when", "always")]
    system = [g for g in sym.groups if g.status == "system"]
    if shown:
        lines.append("small groups (k screws in a (k-1)-system when all k-minors vanish):")
        for g in shown:
            if g.status == "always":
                lines.append(f"  joints {_joints1(g.group)}: always dependent")
            else:
                cs = " or ".join(c.expression.replace(" = 0", "") + " = 0" for c in g.conditions)
                lines.append(f"  joints {_joints1(g.group)}: when {cs}")
    if system:
        lines.append(f"  {len(system)} other group(s) of 2-3 joints have minors without a common factor "
                     "(dependent only where several conditions hold together, if ever; see --scan)")
    return "\n".join(lines)


def singular_text(result) -> str:
    """``minparam singular``'s table output of a ``Singularity``: the robot and tool point, then the
    local test, the scan, the map's line and the symbolic conditions that were asked for."""
    angle = "deg" if result.degrees else "rad"
    sections = [f"robot      {result.robot}  ({result.source})\n{result.tool.line}"]
    if result.local is not None:
        sections.append(local_table(result.local, result.check, result.seed, angle))
    if result.scan is not None:
        sections.append(scan_table(result.scan, result.chain.types, angle))
    if result.map is not None:
        a, b = result.map.pair
        sections.append(f"map of sigma_min/sigma_max over joints {a + 1} and {b + 1} written to {result.map.file}")
    if result.symbolic is not None:
        sections.append(symbolic_table(result.symbolic, result.chain, angle))
    return "\n\n".join(sections)

