"""Text of ``identify --payload-data``: the payload's parameters and the drive gains, with σ."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from minparam_cli.identify.physical.report import PayloadReport


def render_payload(p: PayloadReport) -> str:
    head = (f"payload (about the origin of {p.frame}; files {', '.join(p.files)}; "
            f"{p.samples[0]} + {p.samples[1]} samples, ‖r‖/‖τ‖ {100 * p.relative_error:.3g} %)")
    lines = [head]
    lines.append("  given        " + (", ".join(f"{k} = {v:.6g}" for k, v in p.known.items()) or "nothing"))
    for k, e in p.parameters.items():
        lines.append(f"  {k:<12} {e.value:.6g}  (σ {e.std:.3g}, {e.std_percent:.3g} %)")
    if p.com is not None:
        lines.append("  centre of mass " + ", ".join(f"{c:.4g}" for c in p.com) + " m")
    if p.not_identifiable:
        lines.append("  not identifiable from torques on this robot (regrouped): " + ", ".join(p.not_identifiable))
    for k, e in (p.drive_gains or {}).items():
        lines.append(f"  gain {k:<8} {e.value:.6g}  (σ {e.std:.3g}, {e.std_percent:.3g} %)")
    tls = p.total_least_squares
    if tls:
        lines.append("  gains by total least squares (Gautier & Briot 2014; beside the fit above, see docs/methods/transmission.md):")
        lines.append("    " + ", ".join(f"{k.split()[-1]}: {e.value:.6g} (σ {e.std:.2g})" for k, e in tls.drive_gains.items()))
    if p.base_parameters:
        lines.append("  (the model's parameters in the unit the known mass fixes: 'payload.base_parameters' in --format json)")
    return "\n".join(lines) + "\n"
