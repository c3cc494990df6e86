"""``minparam simulate``'s summary on stderr: what was simulated and where it went."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from minparam_cli.output import is_stdout


def _joints_text(joints: tuple[int, ...], n: int) -> str:
    js = [j + 1 for j in joints]
    if len(js) == n and n > 1:
        return "all"
    if len(js) > 2 and js == list(range(js[0], js[-1] + 1)):
        return f"{js[0]}-{js[-1]}"
    return "+".join(str(j) for j in js)


def summary_text(sim, limits, robot_name: str, seed: int, output: Path | None, truth: Path | None,
                 given_from: str | None = None) -> str:
    """A few lines for stderr: what was simulated (a ``Plan`` or a ``Simulation``) and where it went
    (``given_from``: the --trajectory file)."""
    o = sim.options
    n = sim.tau_rigid.shape[1]
    rms_rigid = np.sqrt(np.mean(sim.tau_rigid**2, axis=0))
    lines = [
        f"simulated  {robot_name}: {sim.samples} samples, {o.duration:g} s at {o.rate:g} Hz, seed {seed}",
        (f"motion     Fourier series, {sim.trajectory.harmonics} harmonics of {sim.trajectory.base_frequency:g} Hz, "
         + (f"from {given_from}" if given_from else f"inside {100 * (1 - 2 * o.margin):g}% of each joint range"))
        if hasattr(sim.trajectory, "harmonics") else f"motion     samples of {sim.trajectory.source}",
        f"inertia    {'from the description' if sim.inertia_source == 'description' else 'random, physically consistent'}",
        "rigid RMS  " + " ".join(f"{x:.3g}" for x in rms_rigid) + " (N·m or N per joint)",
    ]
    if sim.effects:
        items = []
        for e in sim.effects:
            tag = f"[{e.hyper_name}={e.hyper:g}]" if e.hyper is not None else ""
            items.append(f"{e.effect}{tag}@{_joints_text(e.joints, n)}")
        lines.append("effects    " + ", ".join(items))
    else:
        lines.append("effects    none")
    noise = f"torque σ {o.noise:g}" + (f", q σ {o.noise_q:g}" if o.noise_q > 0 else "")
    lines.append(f"noise      {noise}")
    lim = limits
    if lim is not None and lim.any_given():
        for label, given, seen in (("|dq|", lim.velocity, lim.max_abs_dq), ("|ddq|", lim.acceleration, lim.max_abs_ddq),
                                   ("|tau|", lim.effort, lim.max_abs_tau)):
            if any(v is not None for v in given):
                ratios = " ".join("-" if v is None else f"{x / v:.2f}" for v, x in zip(given, seen, strict=True))
                lines.append(f"{'limits' if label == '|dq|' else '':<10} max {label}/limit {ratios}")
    wrote = ["stdout" if is_stdout(p) else str(p) for p in (output, truth) if p is not None]
    if wrote:
        lines.append("wrote      " + ", ".join(wrote))
    return "\n".join(lines) + "\n"
