"""Renderers of an ``excite`` result: summary text, JSON record, CSV samples (pure: result in, str out)."""

from __future__ import annotations

import io

import numpy as np

SERIES = ("q_j(t) = q0_j + sum_l a_jl/(w l) sin(w l t) - b_jl/(w l) cos(w l t), w = 2 pi base_frequency, "
          "l = 1..harmonics (Swevers et al. 1997); dq and ddq are its exact derivatives")


def csv_text(result) -> str:
    """t, q1..qn, dq1..dqn, ddq1..ddqn (SI): the header of ``simulate``'s data files without tau."""
    from minparam_cli.experiment.simulate_spec import data_columns

    n = result.q.shape[1]
    header = data_columns(n, True)[: 1 + 3 * n]
    table = np.hstack([result.t[:, None], result.q, result.dq, result.ddq])
    buf = io.StringIO()
    buf.write(",".join(header) + "\n")
    for row in table.tolist():
        buf.write(",".join(map(repr, row)) + "\n")
    return buf.getvalue()


def _num(x):
    return None if x is None or not np.isfinite(x) else float(x)


def joint_usage(result) -> list[dict]:
    """Per joint: range and largest rates used on the output samples against the limits."""
    lim = result.limits
    out = []
    for j in range(lim.n):
        row = {
            "joint": j + 1,
            "q_min": float(result.q[:, j].min()), "q_max": float(result.q[:, j].max()),
            "q_lower": float(lim.lower[j]), "q_upper": float(lim.upper[j]),
            "q_limits_defaulted": j in lim.defaulted,
            "range_used": float(np.ptp(result.q[:, j]) / (lim.upper[j] - lim.lower[j])),
            "max_abs_dq": float(np.abs(result.dq[:, j]).max()), "velocity_limit": _num(lim.velocity[j]),
            "max_abs_ddq": float(np.abs(result.ddq[:, j]).max()), "acceleration_limit": _num(lim.acceleration[j]),
            "max_abs_tau": None if result.tau is None else float(np.abs(result.tau[:, j]).max()),
            "effort_limit": _num(lim.effort[j]),
        }
        out.append(row)
    return out


def json_record(result, robot: str, robot_name: str, seed: int, effects: dict) -> dict:
    """Everything needed to regenerate the motion (coefficients), and how good and how safe it is."""
    o, traj, lim = result.options, result.trajectory, result.limits
    record = {
        "robot": robot,
        "robot_name": robot_name,
        "seed": seed,
        "trajectory": {
            "type": "fourier",
            "reference": "Swevers et al., IEEE T-RA 13(5), 1997",
            "series": SERIES,
            "harmonics": traj.harmonics,
            "base_frequency": traj.base_frequency,
            "period": 1.0 / traj.base_frequency,
            "q0": traj.q0.tolist(),
            "a": traj.a.tolist(),
            "b": traj.b.tolist(),
            "rest": o.rest,
        },
        "output": {"rate": o.rate, "periods": o.periods, "samples": int(result.t.size)},
        "criterion": {
            "name": o.criterion,
            "scaling": "columns" if o.scaled else "si",
            "value": result.criterion,
            "grid_points_per_period": result.grid_points,
        },
        "condition_number": {"column_scaled": result.cond_output, "si": result.cond_output_si, "on": "output samples"},
        "base_parameters": list(result.base_names),
        "effects": effects,
        "starts": [
            {"start": s.start_criterion, "end": s.end_criterion, "iterations": s.iterations, "message": s.message}
            for s in result.starts
        ],
        "best_start": result.best_start + 1,
        "repair_scale": list(result.repair_scale),
        "limits": {"margin": lim.margin, "joints": joint_usage(result)},
        "elapsed_s": round(result.elapsed_s, 3),
        "cpu_s": round(result.cpu_s, 3),
        "units": {"t": "s", "q": "rad or m", "dq": "rad/s or m/s", "ddq": "rad/s^2 or m/s^2", "tau": "N·m or N",
                  "a, b": "rad/s or m/s"},
    }
    if lim.box is not None:
        record["limits"]["box"] = [[_num(v) for v in row] for row in lim.box]
        record["limits"]["point"] = lim.point.tolist()
        p = result.box_path
        record["limits"]["point_range"] = [[float(p[:, c].min()), float(p[:, c].max())] for c in range(3)]
    if lim.floor is not None and result.lowest is not None:
        record["limits"]["floor"] = lim.floor
        record["limits"]["lowest_heights"] = [float(h) for h in result.lowest]  # link origins 1..n, then the tool point
    if result.collisions is not None:
        record["limits"]["collisions"] = dict(result.collisions, checked=True)
    return record


def summary_text(result, robot_name: str, seed: int) -> str:
    """A few lines for stderr: the criterion, the condition number, the limits used."""
    o = result.options
    kind = "κ" if o.criterion == "cond" else "−(1/p) log det"
    scaling = "column-scaled" if o.scaled else "SI units"
    starts = ", ".join(f"{s.start_criterion:.4g}→{s.end_criterion:.4g}" for s in result.starts)
    lines = [
        f"excite     {robot_name}: {o.harmonics} harmonics of {o.base_frequency:g} Hz, {o.periods} period(s) at {o.rate:g} Hz "
        f"({result.t.size} samples){', rest at both ends' if o.rest else ''}, seed {seed}",
        f"criterion  {o.criterion} ({kind}, base regressor, {scaling}): {result.criterion:.4g} on the grid; "
        f"starts {starts} (best {result.best_start + 1})",
        f"cond       {result.cond_output:.4g} column-scaled, {result.cond_output_si:.4g} in SI units "
        f"(base regressor, {len(result.base_names)} columns, output samples)",
    ]
    usage = joint_usage(result)
    lines.append("range used " + " ".join(f"{u['range_used']:.2f}" for u in usage)
                 + f" (of each joint's range; {100 * (1 - 2 * result.limits.margin):g}% allowed)")
    for label, key, lim in (("|dq|", "max_abs_dq", "velocity_limit"), ("|ddq|", "max_abs_ddq", "acceleration_limit"),
                            ("|tau|", "max_abs_tau", "effort_limit")):
        if any(u[lim] is not None for u in usage) and all(u[key] is not None for u in usage):
            ratios = " ".join("-" if u[lim] is None else f"{u[key] / u[lim]:.2f}" for u in usage)
            lines.append(f"{'limits' if label == '|dq|' else '':<10} max {label}/limit {ratios}")
    if result.box_path is not None:
        p = result.box_path
        lines.append("box        point " + ", ".join(f"{a} [{p[:, c].min():.3f}, {p[:, c].max():.3f}]" for c, a in enumerate("xyz"))
                     + " m")
    if result.lowest is not None:
        k = int(result.lowest.argmin())
        what = "the tool point" if k == result.lowest.size - 1 else f"link {k + 1}'s origin"
        lines.append(f"floor      lowest point {result.lowest[k]:.3f} m ({what}), floor {result.limits.floor:g} m")
    c = result.collisions
    if c is not None:
        lines.append(f"collisions smallest distance {1000 * c['smallest_distance']:.1f} mm ({c['closest_pair']}, t = {c['at_t']:.3f} s) "
                     f"over {c['checked_times']} times x {c['pairs']} pairs; clearance {1000 * c['clearance']:g} mm on "
                     f"{c['grid_points_per_period']} grid points")
    spent = "" if c is None else f"; {c['check_s']:.1f} s of the wall time in collision distances"
    lines.append(f"time       {result.elapsed_s:.1f} s ({result.cpu_s:.1f} s CPU{spent})")
    return "\n".join(lines) + "\n"
