"""The files `identify` writes beside its report: --save-model, --export-urdf, --export-yaml (atomically)."""

from __future__ import annotations

from pathlib import Path

from minparam_cli.output import write_output


def read_robot_bytes(robot: Path) -> bytes:
    """The robot file's bytes (for its hash): a regular file within the description size cap."""
    from minparam_cli.safety import read_bounded

    return read_bounded(Path(robot))


def write_identify_outputs(robot: Path, chain, load, opts, report: dict, art, save_model, export_urdf, export_yaml) -> None:
    """Write the model file and the robot exports of one identify run."""
    data = read_robot_bytes(robot)
    if save_model is not None:
        from minparam_cli.model.file import dumps, saved_model

        write_output(dumps(saved_model(str(robot), data, load, opts.data, opts.seed, art, report)), save_model)
    if export_urdf is None and export_yaml is None:
        return
    from minparam_cli.model import export_robot

    phi = art.physical.phi
    note = f"inertials: physical fit of minparam identify on {report['data']} (robot file {robot})"
    if export_urdf is not None:
        if robot.suffix.lower() == ".urdf":
            text = export_robot.urdf_with_inertials(data, chain, phi, note)
        else:
            text = export_robot.urdf_from_chain(chain, phi, note)
        write_output(text, export_urdf)
    if export_yaml is not None:
        from minparam_cli.safety import read_yaml

        write_output(export_robot.yaml_with_inertials(read_yaml(robot), chain, phi, note), export_yaml)
