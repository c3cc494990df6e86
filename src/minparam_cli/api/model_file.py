"""Opening a saved model file (``identify --save-model``) for ``evaluate``, ``codegen --model`` and
``Model.load`` (below the result classes, which call it), and writing the files identify writes
beside its report (the model file, the robot exports)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from minparam_cli.identify.passes.design import Design
    from minparam_cli.model.file import SavedModel


def open_model(model: str | Path, robot: str | Path | None = None) -> tuple[SavedModel, Path, Design]:
    """Read a model file, check its robot file's SHA-256 and rebuild its design: (model, robot file,
    design).  ``robot``: the robot file to use instead of the one the model names."""
    from minparam_cli.safety import read_bounded
    from minparam_cli.model.file import ModelError, check_robot, model_design
    from minparam_cli.model.parse import read_model
    from minparam_cli.robot import load_chain, require_fixed_base

    model = Path(model)
    m = read_model(model)
    robot_file = Path(robot) if robot is not None else Path(m.robot)
    if not robot_file.is_file():
        raise ModelError(f"{model}: robot file {robot_file} not found" + ("" if robot else " (give it with --robot)"))
    check_robot(m, str(model), str(robot_file), read_bounded(robot_file))
    from minparam_cli.loops.coupling import with_loops

    desc, chain = load_chain(robot_file, m.load.derive_options(m.seed), loops=True)
    chain = with_loops(desc, chain)  # a closed chain: the actuated joints, the loops as the coupling
    require_fixed_base(chain, "evaluate")
    chain = chain.with_coulomb_smoothing(m.load.coulomb_smoothing)
    return m, robot_file, model_design(m, chain, str(model))


def read_robot_bytes(robot: str | Path) -> bytes:
    """The robot file's bytes (for its hash): a regular file within the description size cap."""
    from minparam_cli.safety import read_bounded

    return read_bounded(Path(robot))


def write_identify_outputs(robot: Path, chain, robot_bytes: bytes, saved: SavedModel, data_name: str, physical_phi,
                           save_model: Path | None, export_urdf: Path | None, export_yaml: Path | None) -> None:
    """Write the files of one identify run beside its report, atomically: the model file (--save-model)
    and the robot with the physical fit's inertials (--export-urdf, --export-yaml)."""
    from minparam_cli.output import write_output

    if save_model is not None:
        from minparam_cli.model.file import dumps

        write_output(dumps(saved), save_model)
    if export_urdf is None and export_yaml is None:
        return
    from minparam_cli.model import export_robot

    note = f"inertials: physical fit of minparam identify on {data_name} (robot file {robot})"
    if export_urdf is not None:
        if robot.suffix.lower() == ".urdf":
            text = export_robot.urdf_with_inertials(robot_bytes, chain, physical_phi, note)
        else:
            text = export_robot.urdf_from_chain(chain, physical_phi, note)
        write_output(text, export_urdf)
    if export_yaml is not None:
        from minparam_cli.safety import read_yaml

        write_output(export_robot.yaml_with_inertials(read_yaml(robot), chain, physical_phi, note), export_yaml)
