"""Singular positions by screw theory (Glazunov 1985): known singularities, properties, the paper's example."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from minparam_cli.chain import build_chain, forward_kinematics
from minparam_cli.describe import load_description
from minparam_cli.errors import InputError, UnsupportedError
from minparam_cli.kinematics.defaults import DEFAULT_EPSILON
from minparam_cli.kinematics.serial.nearest_twist import check_nearest
from minparam_cli.kinematics.serial.plucker import normalised_matrices, rows_at_point
from minparam_cli.kinematics.serial.screws import analyse

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
D = np.radians

# PUMA 560 (robots/puma560.yaml) and UR5 (robots/ur5.yaml) geometry, metres
A2, A3, D4 = 0.4318, -0.0203, 0.4331
UA2, UA3, UD5 = -0.425, -0.39225, 0.09465


def chain(name: str, **values):
    return build_chain(load_description(ROBOTS / name), values=values or None)


@pytest.fixture(scope="module")
def puma():
    return chain("puma560.yaml")


@pytest.fixture(scope="module")
def ur5():
    return chain("ur5.yaml")


@pytest.fixture(scope="module")
def u15():
    return chain("universal15_glazunov.yaml")


def puma_elbow_q3() -> float:
    """Arm stretched: the wrist centre lies on the line of joint 3's link (d4 cos q3 - a3 sin q3 = 0)."""
    return float(np.arctan2(D4, A3))


def puma_shoulder_q2(q3: float, lo=-np.pi / 2, hi=-np.pi / 6) -> float:
    """Wrist centre over the shoulder: a2 c2 + a3 c23 + d4 s23 = 0 (its radial coordinate in the arm plane)."""
    return brentq(lambda x: A2 * np.cos(x) + A3 * np.cos(x + q3) + D4 * np.sin(x + q3), lo, hi, xtol=1e-15)


def ur5_shoulder_q2(q3: float, q4: float) -> float:
    """UR5 shoulder: a2 c2 + a3 c23 + d5 s234 = 0 (axes 5-6 crossing point in the plane of axes 1 and 2)."""
    f = lambda x: UA2 * np.cos(x) + UA3 * np.cos(x + q3) + UD5 * np.sin(x + q3 + q4)  # noqa: E731
    xs = np.linspace(-np.pi, np.pi, 721)
    v = f(xs)
    i = int(np.nonzero(v[:-1] * v[1:] < 0)[0][0])
    return brentq(f, xs[i], xs[i + 1], xtol=1e-15)


# --- known singular positions -----------------------------------------------------------------------


def test_puma_wrist_singularity_names_joints_4_and_6(puma):
    r = analyse(puma, D([10, -30, 40, 20, 0, 15]))
    assert r.singular and r.test.rank == 5
    assert r.dependent_joints == (3, 5)
    assert r.groups == ((3, 5),)
    assert r.test.sigma_min < 1e-12


def test_puma_elbow_singularity(puma):
    q = np.array([D(10), D(-30), puma_elbow_q3(), D(20), D(30), D(15)])
    r = analyse(puma, q)
    assert r.singular and r.test.rank == 5
    assert {1, 2} <= set(r.dependent_joints)  # joints 2 and 3 are involved
    assert 0 not in r.dependent_joints
    # the reciprocal screw is a force along the line from the shoulder (base origin) to the wrist centre
    T, _, _ = forward_kinematics(puma, q[None])
    wc = T[0, 3, :3, 3]
    (h,) = r.reciprocal
    assert h.kind == "force"
    assert np.allclose(np.cross(h.plucker[:3], wc / np.linalg.norm(wc)), 0, atol=1e-9)


def test_puma_shoulder_singularity(puma):
    q3 = D(40)
    q = np.array([D(10), puma_shoulder_q2(q3), q3, D(20), D(30), D(15)])
    r = analyse(puma, q)
    assert r.singular and 0 in r.dependent_joints
    # with the shoulder offset d2 the wrist centre is as close to axis 1 as it can be: |d2|
    T, _, _ = forward_kinematics(puma, q[None])
    assert np.hypot(*T[0, 3, :2, 3]) == pytest.approx(0.150, abs=1e-9)


def test_puma_without_offset_shoulder_singularity_is_wrist_centre_on_axis_1():
    arm = chain("puma560.yaml", d2=0.0)
    q3 = D(40)
    q = np.array([D(10), puma_shoulder_q2(q3), q3, D(20), D(30), D(15)])
    T, _, _ = forward_kinematics(arm, q[None])
    assert np.hypot(*T[0, 3, :2, 3]) < 1e-12
    r = analyse(arm, q)
    assert r.singular and 0 in r.dependent_joints


def test_ur5_wrist_elbow_shoulder(ur5):
    wrist = analyse(ur5, D([10, -30, 40, 20, 0, 15]))
    assert wrist.singular and wrist.dependent_joints == (1, 2, 3, 5)  # axes 2, 3, 4, 6 all parallel
    elbow = analyse(ur5, D([10, -30, 0, 20, 30, 15]))
    assert elbow.singular and elbow.dependent_joints == (1, 2, 3)  # axes 2, 3, 4 coplanar
    q3, q4 = D(40), D(20)
    q = np.array([D(10), ur5_shoulder_q2(q3, q4), q3, q4, D(30), D(15)])
    shoulder = analyse(ur5, q)
    assert shoulder.singular and 0 in shoulder.dependent_joints
    _, z, o = forward_kinematics(ur5, q[None])
    normal = np.cross(z[0, 0], z[0, 1])
    assert abs((o[0, 5] - o[0, 0]) @ normal) < 1e-9  # axes 5-6 crossing in the plane of axes 1 and 2


def test_no_singularity_at_generic_configurations(puma, ur5):
    rng = np.random.default_rng(20240611)
    checked = 0
    for _ in range(200):
        q = rng.uniform(-np.pi, np.pi, 6)
        c2, c3, c23, s23, s234 = np.cos(q[1]), np.cos(q[2]), np.cos(q[1] + q[2]), np.sin(q[1] + q[2]), np.sin(q[1:4].sum())
        puma_far = (abs(np.sin(q[4])) > 0.2 and abs(D4 * c3 - A3 * np.sin(q[2])) > 0.05
                    and abs(A2 * c2 + A3 * c23 + D4 * s23) > 0.05)
        ur_far = (abs(np.sin(q[4])) > 0.2 and abs(np.sin(q[2])) > 0.2
                  and abs(UA2 * c2 + UA3 * c23 + UD5 * s234) > 0.05)
        if puma_far:
            r = analyse(puma, q)
            assert not r.singular and r.dependent_joints == () and r.reciprocal == ()
            checked += 1
        if ur_far:
            assert not analyse(ur5, q).singular
            checked += 1
    assert checked > 100


# --- properties on random singular configurations -----------------------------------------------------------


def _random_singular(rng, puma, ur5, u15):
    """(chain, q) pairs on known branches of the singular sets, with random free joints."""
    out = []
    for _ in range(6):
        q = rng.uniform(-np.pi, np.pi, 6)
        q[4] = rng.choice([0.0, np.pi])
        out.append((puma, q.copy()))
        q = rng.uniform(-np.pi, np.pi, 6)
        q[2] = puma_elbow_q3()
        out.append((puma, q.copy()))
        q = rng.uniform(-np.pi, np.pi, 6)
        q[2] = rng.uniform(D(10), D(70))
        q[1] = puma_shoulder_q2(q[2])
        out.append((puma, q.copy()))
        q = rng.uniform(-np.pi, np.pi, 6)
        q[2] = 0.0
        out.append((ur5, q.copy()))
        q = rng.uniform(-np.pi, np.pi, 6)
        q[4] = 0.0
        out.append((ur5, q.copy()))
        q = rng.uniform(-np.pi, np.pi, 6)
        q[3] = rng.uniform(0.15, 0.55)
        q[0] = rng.uniform(-0.3, 0.3)
        q[4] = -q[2]  # sin(q3 + q5) = 0: the arm straight, axes 2 and 6 coincide
        out.append((u15, q.copy()))
    return out


def _paper_set_sample(report, rng, around, count):
    """Twists whose rotation about O_c and translation are each reciprocal to every H (own construction)."""
    c = report.tool_point
    A = np.array([h.plucker[3:] - np.cross(c, h.plucker[:3]) for h in report.reciprocal]).reshape(-1, 3)
    B = np.array([h.plucker[:3] for h in report.reciprocal]).reshape(-1, 3)
    out = []
    for scale in (1e-4, 1e-2, 1.0):
        X = around + scale * rng.standard_normal((count, 6))
        for M, sl in ((A, slice(0, 3)), (B, slice(3, 6))):
            M = M[np.linalg.norm(M, axis=1) > 0]
            if M.size:
                Qm, _ = np.linalg.qr(M.T)
                X[:, sl] -= (X[:, sl] @ Qm) @ Qm.T
        out.append(X)
    return np.concatenate(out)


def test_properties_on_random_singular_configurations(puma, ur5, u15):
    rng = np.random.default_rng(7)
    cases = _random_singular(rng, puma, ur5, u15)
    for arm, q in cases:
        twist = rng.uniform(-1, 1, 6)
        r = analyse(arm, q, twist=twist)
        assert r.singular, (arm.name, q)
        sol = r.twist
        c = r.tool_point
        L = r.length_scale
        w, v = sol.nearest[:3], sol.nearest[3:]
        for h in r.reciprocal:
            v_origin = v + np.cross(c, w)
            assert abs(h.plucker[:3] @ v_origin + h.plucker[3:] @ w) < 1e-9
        Jc = rows_at_point(r.plucker, c)
        assert np.allclose(Jc @ sol.joint_rates, sol.nearest, atol=1e-9)
        assert all(sol.joint_rates[j] == 0.0 for j in r.held_joints)
        assert set(r.held_joints) <= set(r.dependent_joints)
        # brute force in the paper's metric: no twist of the paper's set is closer in |dw| or in |dv|
        d_w = np.linalg.norm(twist[:3] - w)
        d_v = np.linalg.norm(twist[3:] - v)
        cand = _paper_set_sample(r, rng, sol.nearest, 300)
        assert np.all(np.linalg.norm(cand[:, :3] - twist[:3], axis=1) >= d_w - 1e-12)
        assert np.all(np.linalg.norm(cand[:, 3:] - twist[3:], axis=1) >= d_v - 1e-12)
        # and least squares is the nearest feasible twist in the weighted metric (random joint rates)
        kept = [j for j in range(arm.n) if j not in r.held_joints]
        Jn = normalised_matrices(arm, r.plucker, c, L)[:, kept]
        target = np.concatenate([twist[:3], twist[3:] / L])
        ls = np.concatenate([sol.least_squares[:3], sol.least_squares[3:] / L])
        best = np.linalg.norm(ls - target)
        x0 = np.linalg.lstsq(Jn, ls, rcond=None)[0]
        for scale in (1e-4, 1e-2, 1.0):
            X = x0 + scale * rng.standard_normal((300, len(kept)))
            assert np.all(np.linalg.norm(X @ Jn.T - target, axis=1) >= best - 1e-12)


def test_seeded_check_is_deterministic(puma):
    r = analyse(puma, D([10, -30, 40, 20, 0, 15]), twist=[0.1, 0.2, 0.3, 0.1, 0.1, 0.1])
    a = check_nearest(r, puma, np.random.default_rng(3))
    b = check_nearest(r, puma, np.random.default_rng(3))
    assert a == b
    assert a.paper_set_closer == 0 and a.full_set_closer_than_lsq == 0
    # stated honestly: over the whole 5-system the projection is not the nearest in the weighted metric
    assert a.full_set_closer_than_paper > 0


def test_feasible_twist_is_moved_by_the_projection_but_not_by_least_squares(puma):
    """A twist the arm can already make is changed by the paper's projection (a documented limitation)."""
    q = D([10, -30, 40, 20, 0, 15])
    r0 = analyse(puma, q)
    rates = np.array([0.1, -0.2, 0.3, 0.2, -0.1, 0.0])
    feasible = rows_at_point(r0.plucker, r0.tool_point) @ rates
    r = analyse(puma, q, twist=feasible)
    assert np.allclose(r.twist.least_squares, feasible, atol=1e-12)
    assert np.linalg.norm(r.twist.nearest - feasible) > 1e-3


def test_near_singular_is_detected_and_still_exact(puma):
    r = analyse(puma, D([10, -30, 40, 20, 0.01, 15]), twist=[0.1, 0.2, 0.3, 0.1, 0.1, 0.1])
    assert r.singular and 0 < r.test.sigma_min <= DEFAULT_EPSILON
    assert r.dependent_joints == (3, 5)
    assert r.twist.reciprocity_residual < 1e-12 and r.twist.reproduction_residual < 1e-12
    assert not analyse(puma, D([10, -30, 40, 20, 0.01, 15]), epsilon=1e-6).singular


# --- rank drops above one, other joint counts ---------------------------------------------------------------


def test_ur5_double_rank_drop_is_reported(ur5):
    r = analyse(ur5, D([0, 0, 0, 90, 0, 0]), twist=[0.1, 0.2, 0.3, 0.1, 0.1, 0.1])
    assert r.test.rank == 4
    assert set(r.groups) == {(1, 2, 3), (1, 2, 5), (1, 3, 5), (2, 3, 5)}  # axes 2, 3, 4, 6 parallel and coplanar
    assert r.null_space.shape == (6, 2)
    assert len(r.held_joints) == 2 and len(r.reciprocal) == 2
    assert any("rank drops by 2" in n for n in r.notes)
    assert r.twist.reciprocity_residual < 1e-12 and r.twist.reproduction_residual < 1e-12
    # null-space joint rates give no tool motion
    Jc = rows_at_point(r.plucker, r.tool_point)
    assert np.allclose(Jc @ r.null_space, 0, atol=1e-12)


def test_universal15_double_rank_drop():
    arm = chain("universal15_glazunov.yaml")
    r = analyse(arm, np.array([0.0, D(90), 0.0, 0.4, 0.0, 0.0]))
    assert r.test.rank == 4 and set(r.groups) == {(1, 5), (0, 2, 4)}


def test_redundant_panda_collinear_axes():
    arm = chain("panda.yaml")
    r = analyse(arm, np.zeros(7), twist=[0.1, 0.0, 0.2, 0.1, 0.0, 0.1])
    assert r.test.full_rank == 6 and r.test.rank == 5 and r.singular
    assert set(r.groups) == {(0, 2), (0, 4), (2, 4)}  # axes 1, 3, 5 on one vertical line
    assert len(r.held_joints) == 2
    assert r.twist.reproduction_residual < 1e-12
    generic = analyse(arm, D([10, -30, 20, -100, 15, 90, 30]))
    assert not generic.singular and generic.reciprocal == ()


def test_planar_3r_and_scara():
    p3 = chain("planar3r.yaml")
    assert analyse(p3, D([10, 0, 30])).groups == ((0, 1, 2),)
    generic = analyse(p3, D([10, 40, 30]))
    assert not generic.singular and len(generic.reciprocal) == 3  # a 3-system has a 3-system of reciprocal screws
    scara = chain("scara.yaml")
    assert analyse(scara, np.array([D(20), 0.0, 0.1, D(10)])).dependent_joints == (0, 1, 3)
    assert not analyse(scara, np.array([D(20), D(60), 0.1, D(10)])).singular


# --- the paper's worked example (robots/universal15_glazunov.yaml) -----------------------------------------


def paper_to_base(v):
    """The YAML's base frame is the paper's frame relabelled: (px, py, pz) -> (py, pz, px)."""
    v = np.asarray(v, float)
    return np.array([v[1], v[2], v[0]])


def base_to_paper(v):
    v = np.asarray(v, float)
    return np.array([v[2], v[0], v[1]])


def test_paper_example_reconstruction(u15):
    q = np.array([0.0, 0.0, 0.0, 0.4, 0.0, 0.0])  # S4 = 0.4 m, the arm straight
    twist = np.concatenate([paper_to_base([0.2, 0.1, 0.1]), paper_to_base([0.4, 0.2, 0.4])])
    r = analyse(u15, q, twist=twist)
    assert np.allclose(base_to_paper(r.tool_point), [0, 0.8, 0], atol=1e-12)  # O_c = (0, 0.8, 0)
    assert r.singular and r.dependent_joints == (1, 5)  # axes 2 and 6 coincide
    assert r.held_joints == (5,)  # dφ6 = 0, as in the paper
    (h,) = r.reciprocal
    assert h.kind == "couple" and np.allclose(base_to_paper(h.plucker[3:]), [0, 0, 1])
    # matches the paper: Ω' = (0.2, 0.1, 0), V' = (0.4, 0.2, 0.4)
    assert np.allclose(base_to_paper(r.twist.nearest[:3]), [0.2, 0.1, 0.0], atol=1e-12)
    assert np.allclose(base_to_paper(r.twist.nearest[3:]), [0.4, 0.2, 0.4], atol=1e-12)
    rates = r.twist.joint_rates
    # matches the paper: V1 = 0.4 m/s, Ω2 = 0.1, V4 = 0.2 m/s, Ω6 = 0
    assert rates[0] == pytest.approx(0.4) and rates[1] == pytest.approx(0.1)
    assert rates[3] == pytest.approx(0.2) and rates[5] == 0.0
    # does not match: the paper prints Ω3 = 0, Ω5 = 0.2; this geometry needs 0.9 and -0.7
    assert rates[2] == pytest.approx(0.9) and rates[4] == pytest.approx(-0.7)


def test_paper_printed_rates_do_not_reproduce_its_twist(u15):
    """With the printed rates the tool point moves at 0.04 m/s along the paper's z, not 0.4."""
    q = np.array([0.0, 0.0, 0.0, 0.4, 0.0, 0.0])
    r = analyse(u15, q)
    printed = np.array([0.4, 0.1, 0.0, 0.2, 0.2, 0.0])
    tw = rows_at_point(r.plucker, r.tool_point) @ printed
    assert np.allclose(base_to_paper(tw[:3]), [0.2, 0.1, 0.0])
    assert np.allclose(base_to_paper(tw[3:]), [0.4, 0.2, 0.04])


# --- bad input --------------------------------------------------------------------------------------------------


def test_wrong_joint_count(puma):
    with pytest.raises(InputError, match="expected 6 joint values"):
        analyse(puma, [0.0] * 5)


def test_epsilon_out_of_range(puma):
    with pytest.raises(InputError, match="epsilon must lie in"):
        analyse(puma, np.zeros(6), epsilon=0.0)


def test_hold_outside_dependent_group(puma):
    with pytest.raises(InputError, match="loses rank"):
        analyse(puma, np.zeros(6), hold=(0,))


def test_hold_at_full_rank(puma):
    with pytest.raises(InputError, match="only at a singular position"):
        analyse(puma, D([10, -30, 40, 20, 30, 15]), hold=(5,))


def test_non_finite_twist(puma):
    with pytest.raises(InputError, match="six finite numbers"):
        analyse(puma, np.zeros(6), twist=[0, 0, np.nan, 0, 0, 0])


def test_branched_chain_refused(puma):
    from dataclasses import replace

    branched = replace(puma, parents=(-1, 0, 1, 1, 3, 4))
    with pytest.raises(UnsupportedError, match="serial chain"):
        analyse(branched, np.zeros(6))


def _long_arm(tmp_path, n: int):
    """A redundant arm of n revolute joints with runs of parallel axes (alpha 0) between twisted ones:
    at a configuration of right angles it has many small dependent groups."""
    rows = "\n".join(f"  - {{type: revolute, a: 0.1, alpha: {(-90, 0, 0, 90)[j % 4]}, d: 0.05, theta: 0}}" for j in range(n))
    f = tmp_path / f"arm{n}.yaml"
    f.write_text(f"name: arm{n}\nconvention: dh\nunits: {{length: m, angle: deg}}\njoints:\n{rows}\n")
    return build_chain(load_description(f))


def test_dependent_groups_are_the_minimal_rank_deficient_sets(tmp_path):
    """The batched search against the definition, set by set: a group is a set of k columns of rank
    k - 1 none of whose proper subsets is such a set (rank by numpy's matrix_rank at the same cut)."""
    from itertools import combinations

    from minparam_cli.kinematics.serial.plucker import plucker_matrices
    from minparam_cli.kinematics.serial.screws import dependent_groups

    arm = _long_arm(tmp_path, 9)
    rng = np.random.default_rng(3)
    counts = []
    for q in (rng.choice([0.0, np.pi / 2, np.pi], 9), rng.uniform(-3, 3, 9)):
        J0, c = plucker_matrices(arm, q[None])
        Jn = normalised_matrices(arm, J0[0], c[0], float(arm.length_scale))
        cut = DEFAULT_EPSILON * np.linalg.svd(Jn, compute_uv=False)[0]
        expect: list[tuple[int, ...]] = []
        for k in range(1, 7):
            for S in combinations(range(9), k):
                if np.linalg.matrix_rank(Jn[:, S], tol=cut) < k and not any(set(g) <= set(S) for g in expect):
                    expect.append(S)
        assert dependent_groups(Jn, cut) == tuple(expect)
        counts.append(len(expect))
    assert counts[0] >= 3  # the right angles: several groups, of several sizes, for the minimality rule to act on


def test_a_chain_too_long_for_the_whole_group_search_searches_smaller_groups_and_says_so(tmp_path, monkeypatch):
    """Past MAX_GROUP_SETS sets (35 joints and more at the real bound; 9 joints at a bound of 300 here)
    the search stops at the largest group size that fits, and the report's notes say which."""
    from minparam_cli.kinematics.serial import screws
    from minparam_cli.kinematics.serial.plucker import plucker_matrices

    assert screws.group_search_size(34) == 6 and screws.group_search_size(35) == 5
    arm = _long_arm(tmp_path, 9)
    q = np.pi / 2 * np.array([-1, -1, 1, 2, -1, 2, -1, 2, 2])  # groups of 4, 5 and 6 joints
    monkeypatch.setattr(screws, "MAX_GROUP_SETS", 300)  # 9 joints: 255 sets up to size 4, 381 up to 5
    r = analyse(arm, q)
    assert any("groups of more than 4 joints not searched: 9 joints have 465 sets of up to 6" in note for note in r.notes)
    J0, c = plucker_matrices(arm, q[None])
    Jn = normalised_matrices(arm, J0[0], c[0], float(arm.length_scale))
    monkeypatch.undo()
    whole = screws.dependent_groups(Jn, DEFAULT_EPSILON * np.linalg.svd(Jn, compute_uv=False)[0])
    assert any(len(g) > 4 for g in whole)  # the bound left some out here
    assert r.groups == tuple(g for g in whole if len(g) <= 4) != ()


def test_groups_of_joints_beyond_the_63rd_are_told_apart(monkeypatch):
    """Past 63 joints a bit mask of joint indices no longer fits a machine integer: two groups among
    joints 64..70 must still be found, each once, and minimal (synthetic screws; the search bounded
    to three joints so that the 70-column case stays small)."""
    from minparam_cli.kinematics.serial import screws

    rng = np.random.default_rng(5)
    Jn = rng.standard_normal((6, 70))
    Jn[:, 65] = Jn[:, 64]  # a pair: one axis twice
    Jn[:, 68] = Jn[:, 66] + Jn[:, 67]  # a triple in a 2-system, no pair of it dependent
    monkeypatch.setattr(screws, "MAX_GROUP_SETS", 60_000)  # 70 joints: 57,225 sets of up to 3
    groups = screws.dependent_groups(Jn, 1e-9)
    assert groups == ((64, 65), (66, 67, 68))
