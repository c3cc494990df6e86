"""Opening a saved model file (``identify --save-model``) for ``evaluate``, ``codegen --model`` and
``Model.load``: below the result classes, which call it."""

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
    _, chain = load_chain(robot_file, m.load.derive_options(m.seed))
    require_fixed_base(chain, "evaluate")
    chain = chain.with_coulomb_smoothing(m.load.coulomb_smoothing)
    return m, robot_file, model_design(m, chain, str(model))
