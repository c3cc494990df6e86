"""``minparam platform ik|fk|workspace``'s output of a ``PlatformResult``: JSON, or the tables of
``kinematics.parallel.platform_report`` (which read the result's JSON view), and the workspace plot."""

from __future__ import annotations


def platform_text(result, fmt: str) -> str:
    import json

    d = result.to_dict()
    if fmt == "json":
        return json.dumps(d, indent=2)
    from minparam_cli.kinematics.parallel import platform_report as rep

    if result.kind == "ik":
        return (rep.truss_ik_table if result.truss else rep.ik_table)(d)
    if result.kind == "fk":
        return (rep.truss_fk_table if result.truss else rep.fk_table)(d)
    text = rep.workspace_table(d)
    if result.plot is not None:
        text = text.rstrip("\n") + f"\n\nplot of the reachable positions written to {result.plot}"
    return text


def workspace_plot(result):
    """The figure of the reachable positions (a matplotlib Figure)."""
    from minparam_cli.kinematics.parallel.platform_workspace import workspace_figure

    return workspace_figure(result.model, result.solved, result.model.length_unit)
