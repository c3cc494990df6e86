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


def check_exportable(physical, chain, prior: str) -> None:
    """Refuse an export (one line, exit 2, before anything is written) when a link's body is not fixed:
    directions that neither the data nor the prior nor geometry with a mass bound hold, only the
    tie-break (identify/physical/provenance.py)."""
    if physical is None or not physical.not_fixed:
        return
    from minparam_cli.errors import InputError
    from minparam_cli.identify.physical.provenance import refusal

    b = next(x for x in physical.links if x["link"] == physical.not_fixed[0])
    ell = b.get("ellipsoid")
    raise InputError(refusal(b["name"], b["informed_directions"], len(physical.not_fixed) - 1, prior,
                             chain.phi_nominal is not None, None if ell is None else ell["source"]))


def write_identify_outputs(robot: Path, chain, robot_bytes: bytes, saved: SavedModel, data_name: str, physical_phi,
                           save_model: Path | None, export_urdf: Path | None, export_yaml: Path | None,
                           export_mjcf: Path | None = None, drive_gains=None) -> tuple[str, ...]:
    """Write the files of one identify run beside its report, atomically: the model file (--save-model)
    and the robot with the physical fit's inertials and joint terms (--export-urdf, --export-mjcf,
    --export-yaml; the first two with their side file FILE.extra.yaml of what the format cannot
    express).  ``drive_gains``: gains identified in this run (``--payload-data``), else the declared
    ones are used.  Returns the report's lines naming what went into each side file."""
    from minparam_cli.output import write_output

    if save_model is not None:
        from minparam_cli.model.file import dumps

        write_output(dumps(saved), save_model)
    if export_urdf is None and export_yaml is None and export_mjcf is None:
        return ()
    from minparam_cli.model import export_robot

    terms = _joint_terms(chain, saved, physical_phi, drive_gains)
    note = f"inertials: physical fit of minparam identify on {data_name} (robot file {robot})"
    notes = []
    if export_urdf is not None:
        from minparam_cli.model import export_urdf as urdf

        if robot.suffix.lower() == ".urdf":
            text = urdf.urdf_with_inertials(robot_bytes, chain, physical_phi, note, terms)
        else:
            text = urdf.urdf_from_chain(chain, physical_phi, note, terms)
        notes.append(_write_with_side(text, export_urdf, "urdf", str(robot), terms, chain.gravity, ("armature", "gear")))
    if export_mjcf is not None:
        from minparam_cli.model.export_mjcf import mjcf_from_chain

        text = mjcf_from_chain(chain, physical_phi, terms, note)
        notes.append(_write_with_side(text, export_mjcf, "mjcf", str(robot), terms, None, ()))
    if export_yaml is not None:
        from minparam_cli.safety import read_yaml

        write_output(export_robot.yaml_with_inertials(read_yaml(robot), chain, physical_phi, note, terms), export_yaml)
    return tuple(n for n in notes if n)


def _joint_terms(chain, saved: SavedModel, phi, identified=None):
    """The physical fit's per-joint terms (``model.export_extra.joint_terms``): φ's extras and the
    diagnosed effects' coefficients (the tail of the physical θ), with the drive gains (identified, or
    declared)."""
    from minparam_cli.model.export_extra import joint_terms

    tail = () if saved.physical is None else saved.physical.theta[len(saved.kept):]
    evidence = tuple(saved.term_evidence(i) for i in range(len(saved.terms)))
    if identified is not None:
        return joint_terms(chain, phi, saved.terms, tail, identified, "drive gains identified with --payload-data", evidence)
    gains = None
    if saved.data.motor_side is not None and saved.data.motor_side[2] is not None:
        gains = saved.data.motor_side[2]
    elif chain.transmission is not None and chain.transmission.drive_gains is not None:
        gains = chain.transmission.drive_gains
    return joint_terms(chain, phi, saved.terms, tail, gains, evidence=evidence)


def _write_with_side(text: str, path: Path, fmt: str, robot: str, terms, gravity, lacks: tuple[str, ...]) -> str:
    """Write an export and its side file together (always, so that no side file of an earlier run is left
    beside it); the report line naming what went there, empty when nothing did."""
    from minparam_cli.model.export_extra import dumps_side, side_document, side_path, side_summary
    from minparam_cli.output import write_outputs

    doc = side_document(fmt, Path(path).name, robot, terms, gravity, lacks)
    summary = side_summary(doc)
    write_outputs({Path(path): text, Path(side_path(path)): dumps_side(doc)})
    return f"{side_path(path)}: what {fmt.upper()} cannot express: {summary}" if summary else ""
