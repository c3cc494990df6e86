"""minparam excite --collisions: a design that collides without the flag is free of collisions with it, as
MuJoCo's own contact detection (not the distances the design used) finds on a fine grid; the distances'
gradient against finite differences; one test per kind of broken input."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT
from typer.testing import CliRunner

mujoco = pytest.importorskip("mujoco")

runner = CliRunner()
FAST = ["--starts", "1", "--max-iterations", "30", "--harmonics", "3", "--rate", "20", "-q"]
CLEARANCE = 0.01

INERTIAL = ('<inertial><origin xyz="0 0 0.15"/><mass value="1"/>'
            '<inertia ixx="0.01" iyy="0.01" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial>')


def arm_urdf(shape: str = '<cylinder radius="0.03" length="0.24"/>') -> str:
    """Three links of 0.3 m pitching about y on a pillar: the third can fold back into the first, the
    second and third into the pillar (ranges ±3 rad)."""
    parts = ['<robot name="folding">',
             '<link name="base"><collision><origin xyz="0 0 0.2"/><geometry><box size="0.1 0.1 0.4"/></geometry></collision></link>']
    parent, z = "base", 0.45
    for k in (1, 2, 3):
        parts.append(f'<joint name="j{k}" type="revolute"><parent link="{parent}"/><child link="l{k}"/><origin xyz="0 0 {z}"/>'
                     '<axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="500" velocity="3"/></joint>')
        parts.append(f'<link name="l{k}">{INERTIAL}<collision><origin xyz="0 0 0.15"/><geometry>{shape}</geometry></collision></link>')
        parent, z = f"l{k}", 0.3
    return "\n".join(parts + ["</robot>"])


@pytest.fixture(scope="module")
def app():
    from minparam_cli.cli.app import app as real_app

    return real_app


@pytest.fixture(scope="module")
def folding(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("coll") / "folding.urdf"
    path.write_text(arm_urdf())
    return path


def contacts_on_a_fine_grid(robot: Path, record: dict, margin: float) -> list[tuple[str, str, float]]:
    """MuJoCo's contact detection (mj_forward) at 2001 times of the JSON's series, every geom given
    ``margin``: the contacts (closer than the margin) between bodies that are not parent and child."""
    tr = record["trajectory"]
    text = robot.read_text().replace("<robot name=\"folding\">",
                                     '<robot name="folding"><mujoco><compiler discardvisual="true"/></mujoco>')
    model = mujoco.MjModel.from_xml_string(text)
    model.geom_margin[:] = margin
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_FILTERPARENT  # parents: filtered below, the world too
    data = mujoco.MjData(model)
    w = 2 * np.pi * tr["base_frequency"]
    t = np.linspace(0.0, tr["period"], 2001)
    a, b, q0 = np.array(tr["a"]), np.array(tr["b"]), np.array(tr["q0"])
    l = np.arange(1, a.shape[1] + 1)
    q = q0[None, :] + np.einsum("jl,tl->tj", a / (w * l), np.sin(w * l * t[:, None])) \
        - np.einsum("jl,tl->tj", b / (w * l), np.cos(w * l * t[:, None]))
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt)]
    order = [names.index(f"j{k}") for k in (1, 2, 3)]
    found = []
    for qs in q:
        data.qpos[[model.jnt_qposadr[j] for j in order]] = qs
        mujoco.mj_forward(model, data)
        for c in data.contact[: data.ncon]:
            b1, b2 = model.geom_bodyid[c.geom1], model.geom_bodyid[c.geom2]
            if model.body_parentid[b1] == b2 or model.body_parentid[b2] == b1:
                continue
            found.append((mujoco.mj_id2name(model, 1, b1), mujoco.mj_id2name(model, 1, b2), float(c.dist)))
    return found


def test_the_flag_turns_a_colliding_design_into_a_free_one(tmp_path, app, folding):
    free, kept = tmp_path / "free.json", tmp_path / "kept.json"
    r = runner.invoke(app, ["excite", str(folding), "-o", str(tmp_path / "a.csv"), "--json", str(free), *FAST])
    assert r.exit_code == 0, r.output
    assert contacts_on_a_fine_grid(folding, json.loads(free.read_text()), 0.0), "the plain design should collide"
    r = runner.invoke(app, ["excite", str(folding), "-o", str(tmp_path / "b.csv"), "--json", str(kept), "--collisions", *FAST])
    assert r.exit_code == 0, r.output
    record = json.loads(kept.read_text())
    assert contacts_on_a_fine_grid(folding, record, CLEARANCE / 2) == []
    check = record["limits"]["collisions"]
    assert check["checked"] and check["clearance"] == CLEARANCE and check["smallest_distance"] >= CLEARANCE / 2
    assert check["pairs"] == 3 and check["checked_times"] > 1000  # pillar-l2, pillar-l3, l1-l3


def test_the_distance_gradient_matches_finite_differences(folding):
    from minparam_cli.experiment.excite.collision_model import load_collisions
    from minparam_cli.experiment.excite.design import chain_limits
    from minparam_cli.robot import DeriveOptions, load_chain

    _, chain = load_chain(folding, DeriveOptions())
    shapes, _ = load_collisions(folding, chain, chain_limits(chain, 0.1), CLEARANCE, 0.0, np.random.default_rng(0))
    q = np.random.default_rng(1).uniform(-2.5, 2.5, (40, 3))
    d, g = shapes.distances(q, gradients=True)
    near = np.argwhere((d > -0.02) & (d < 0.05))
    assert len(near) >= 5
    step = 1e-6
    for s, k in near:
        numeric = [(shapes.distances(q[s] + step * e)[0][0, k] - shapes.distances(q[s] - step * e)[0][0, k]) / (2 * step)
                   for e in np.eye(3)[:, None, :]]
        assert np.allclose(numeric, g[s, k], atol=1e-4)


def one_line_exit_2(r) -> str:
    assert r.exit_code == 2, r.output
    assert len(r.output.strip().splitlines()) == 1 and "Traceback" not in r.output
    return r.output


def test_a_dh_yaml_robot_has_no_collision_shapes(tmp_path, app):
    out = one_line_exit_2(runner.invoke(app, ["excite", str(ROOT / "robots" / "puma560.yaml"), "-o", str(tmp_path / "a.csv"),
                                              "--collisions", *FAST]))
    assert "DH/MDH YAML description has none" in out
    assert not (tmp_path / "a.csv").exists()


def test_a_urdf_without_collision_elements(tmp_path, app):
    out = one_line_exit_2(runner.invoke(app, ["excite", str(ROOT / "robots" / "ur5.urdf"), "-o", str(tmp_path / "a.csv"),
                                              "--collisions", *FAST]))
    assert "no collision shapes on the moving links" in out


def test_a_missing_collision_mesh_is_named(tmp_path, app):
    robot = tmp_path / "meshy.urdf"
    robot.write_text(arm_urdf('<mesh filename="package://nowhere/meshes/link.stl"/>'))
    out = one_line_exit_2(runner.invoke(app, ["excite", str(robot), "-o", str(tmp_path / "a.csv"), "--collisions", *FAST]))
    assert "package://nowhere/meshes/link.stl" in out and "link 'l1'" in out


def test_a_collision_mesh_mujoco_cannot_read_is_named(tmp_path, app):
    (tmp_path / "link.dae").write_text("<COLLADA/>")
    robot = tmp_path / "dae.urdf"
    robot.write_text(arm_urdf('<mesh filename="link.dae"/>'))
    out = one_line_exit_2(runner.invoke(app, ["excite", str(robot), "-o", str(tmp_path / "a.csv"), "--collisions", *FAST]))
    assert "link.dae" in out and "not .dae" in out
    assert not (tmp_path / "a.csv").exists()


def test_shapes_that_never_separate_leave_no_pair_to_check(tmp_path, app):
    """Spheres of 2 m on 0.3 m links overlap in every position: every pair is left out, and nothing is left to check."""
    robot = tmp_path / "huge.urdf"
    robot.write_text(arm_urdf('<sphere radius="2"/>'))
    out = one_line_exit_2(runner.invoke(app, ["excite", str(robot), "-o", str(tmp_path / "a.csv"), "--collisions", *FAST]))
    assert "no pair of collision shapes to check" in out


def test_without_the_mujoco_extra(tmp_path, app, folding, monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)  # import mujoco now raises ImportError
    out = one_line_exit_2(runner.invoke(app, ["excite", str(folding), "-o", str(tmp_path / "a.csv"), "--collisions", *FAST]))
    assert "minparam[mujoco]" in out


@pytest.mark.parametrize("value", ["0", "-0.01", "nan", "2"])
def test_a_clearance_that_is_not_a_small_distance(tmp_path, app, folding, value):
    out = one_line_exit_2(runner.invoke(app, ["excite", str(folding), "-o", str(tmp_path / "a.csv"), "--collisions",
                                              "--clearance", value, *FAST]))
    assert "--clearance" in out


def test_a_clearance_without_the_flag(tmp_path, app, folding):
    out = one_line_exit_2(runner.invoke(app, ["excite", str(folding), "-o", str(tmp_path / "a.csv"), "--clearance", "0.02", *FAST]))
    assert "--clearance needs --collisions" in out


def test_a_design_that_still_collides_is_refused_naming_the_pair(tmp_path, app, folding, monkeypatch):
    """With the optimiser's collision constraint switched off (the starts and the dense check still on)
    and no repair or step bound, the motion folds through the pillar: the dense check refuses it in one line (exit 2)
    that names the two bodies, the time and the depth, and writes nothing."""
    from minparam_cli.experiment.excite import collisions, constraints, rounds

    monkeypatch.setattr(constraints, "REPAIR_STEPS", 1)
    monkeypatch.setattr(rounds, "STEP_FRACTION", 1e3)  # steps as large as plain SLSQP's

    monkeypatch.setattr(collisions.Collisions, "constraint",
                        lambda self, chain, Bq, n, m: {"type": "ineq", "fun": lambda x: np.ones(1), "jac": lambda x: np.zeros((1, x.size))})
    out = one_line_exit_2(runner.invoke(app, ["excite", str(folding), "-o", str(tmp_path / "a.csv"), "--collisions", *FAST]))
    assert "collision: " in out and " deep at t = " in out
    assert any(f"{a} and {b}" in out for a, b in (("world", "l2"), ("world", "l3"), ("l1", "l3")))
    assert not (tmp_path / "a.csv").exists()


def arm_mjcf() -> str:
    """The folding arm as MJCF: the same collision shapes (contype 1), and a large visual sphere per link
    (contype = conaffinity = 0) that --collisions must ignore."""
    inertial = '<inertial pos="0 0 0.15" mass="1" diaginertia="0.01 0.01 0.002"/>'
    visual = '<geom type="sphere" size="0.2" contype="0" conaffinity="0" group="1"/>'
    body = ""
    for k in (3, 2, 1):
        z = 0.45 if k == 1 else 0.3
        body = (f'<body name="l{k}" pos="0 0 {z}">{inertial}<joint name="j{k}" type="hinge" axis="0 1 0" range="-3 3" limited="true"/>'
                f'<geom type="cylinder" size="0.03 0.12" pos="0 0 0.15"/>{visual}{body}</body>')
    return (f'<mujoco model="folding"><worldbody><geom type="box" size="0.05 0.05 0.2" pos="0 0 0.2"/>{body}'
            '</worldbody></mujoco>')


def test_an_mjcf_gives_the_same_distances_as_the_urdf(tmp_path, folding):
    """The same arm read from MJCF (visual spheres ignored) and from URDF: the same pairs, the same distances."""
    from minparam_cli.experiment.excite.collision_model import load_collisions
    from minparam_cli.experiment.excite.design import chain_limits
    from minparam_cli.robot import DeriveOptions, load_chain

    xml = tmp_path / "folding.xml"
    xml.write_text(arm_mjcf())
    out = []
    for path in (folding, xml):
        _, chain = load_chain(path, DeriveOptions())
        shapes, notes = load_collisions(path, chain, chain_limits(chain, 0.1), CLEARANCE, None, np.random.default_rng(0))
        assert notes == [] and len(shapes.pairs) == 3
        out.append(shapes.distances(np.random.default_rng(2).uniform(-2.5, 2.5, (50, 3)), reach=10.0)[0])
    assert np.allclose(out[0], out[1], atol=1e-9)


def test_the_library_call_takes_the_same_flag(folding):
    import minparam

    result = minparam.excite(folding, collisions=True, clearance=0.02, harmonics=3, rate=20, starts=1, max_iterations=20)
    check = result.to_dict()["limits"]["collisions"]
    assert check["checked"] and check["clearance"] == 0.02 and check["smallest_distance"] >= 0.01


def test_a_pair_that_never_separates_is_left_out_and_named(tmp_path, app):
    """A sphere on l1 around joint 2 (radius 0.35 m) always holds l3's start (0.3 m from joint 2): that pair
    cannot be kept apart anywhere; it is left out, with a note, and the others are still checked."""
    robot = tmp_path / "fat.urdf"
    robot.write_text(arm_urdf().replace(
        '<link name="l1">' + INERTIAL,
        '<link name="l1">' + INERTIAL + '<collision><origin xyz="0 0 0.3"/><geometry><sphere radius="0.35"/></geometry></collision>'))
    r = runner.invoke(app, ["excite", str(robot), "-o", str(tmp_path / "a.csv"), "--json", str(tmp_path / "a.json"), "--collisions",
                            *FAST[:-1]])
    assert r.exit_code == 0, r.output
    note = [line for line in r.output.splitlines() if "left out" in line]
    assert len(note) == 1 and "l1 (shape 1 of 2) and l3" in note[0]
    check = json.loads((tmp_path / "a.json").read_text())["limits"]["collisions"]
    assert check["left_out"] == ["l1 (shape 1 of 2) and l3"] and check["pairs"] >= 3
