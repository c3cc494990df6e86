"""Rotations, the normal-vector conversion (Dang 2013 eq. 11-15), inverse kinematics, leg Jacobian."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from minparam_cli.describe.platform_yaml import load_platform
from minparam_cli.kinematics.parallel.platform import (
    canonical_pose,
    leg_jacobian,
    leg_lengths,
    matrix_from_rpy,
    normal_from_rpy,
    platform_model,
    pose_from_normal,
    pose_from_points,
    platform_points,
    rpy_from_matrix,
    rpy_from_normal,
)
from conftest import ROBOTS

RNG = np.random.default_rng(20130202)


@pytest.fixture(scope="module")
def paper():
    return platform_model(load_platform(ROBOTS / "dodekapod_dang2013.yaml"))


def test_rotation_is_rz_ry_rx_eq4():
    """Against an independent composition: scipy's intrinsic Z-Y-X Euler angles (yaw, pitch, roll)."""
    for _ in range(50):
        roll, pitch, yaw = RNG.uniform(-math.pi, math.pi, 3)
        expected = Rotation.from_euler("ZYX", [yaw, pitch, roll]).as_matrix()
        np.testing.assert_allclose(matrix_from_rpy(roll, pitch, yaw), expected, atol=1e-14)


def test_rotation_entries_of_eq4_by_hand():
    a, b, g = 0.3, -0.4, 0.7  # alpha about z, beta about y, gamma about x
    R = matrix_from_rpy(g, b, a)
    assert R[0, 1] == pytest.approx(math.cos(a) * math.sin(b) * math.sin(g) - math.sin(a) * math.cos(g), abs=1e-15)
    assert R[1, 2] == pytest.approx(math.sin(a) * math.sin(b) * math.cos(g) - math.cos(a) * math.sin(g), abs=1e-15)
    assert R[2, 0] == pytest.approx(-math.sin(b), abs=1e-15)


def test_rpy_round_trip():
    q = np.column_stack([RNG.uniform(-math.pi, math.pi, 200), RNG.uniform(-1.5, 1.5, 200),
                         RNG.uniform(-math.pi, math.pi, 200)])
    back = rpy_from_matrix(matrix_from_rpy(q[:, 0], q[:, 1], q[:, 2]))
    np.testing.assert_allclose(back, q, atol=1e-12)


def test_canonical_pose_keeps_the_rotation():
    q = np.array([1.0, 2.0, 3.0, 0.4, 2.9, -2.5])  # pitch beyond pi/2
    c = canonical_pose(q)
    assert abs(c[4]) <= math.pi / 2
    np.testing.assert_allclose(matrix_from_rpy(*c[3:]), matrix_from_rpy(*q[3:]), atol=1e-14)


def test_normal_is_third_column_eq12():
    a, b, g = 0.2, 0.5, -0.3
    n = normal_from_rpy(g, b, a)
    expected = [math.cos(a) * math.sin(b) * math.cos(g) + math.sin(a) * math.sin(g),
                math.sin(a) * math.sin(b) * math.cos(g) - math.cos(a) * math.sin(g),
                math.cos(b) * math.cos(g)]
    np.testing.assert_allclose(n, expected, atol=1e-15)


def test_normal_to_angles_with_zero_yaw_eq13():
    n = np.array([0.3, -0.2, 0.9])
    roll, pitch, yaw = rpy_from_normal(n)
    u = n / np.linalg.norm(n)
    assert yaw == 0
    assert math.tan(pitch) == pytest.approx(u[0] / u[2], rel=1e-14)  # tan beta = n_x / n_z
    assert math.sin(roll) == pytest.approx(-u[1], rel=1e-14)  # sin gamma = -n_y


def test_normal_round_trip_with_fixed_yaw_eq14_15():
    for _ in range(200):
        roll = RNG.uniform(-1.5, 1.5)
        pitch = RNG.uniform(-1.5, 1.5)
        yaw = RNG.uniform(-math.pi, math.pi)
        n = normal_from_rpy(roll, pitch, yaw) * RNG.uniform(0.1, 10)  # length must not matter
        np.testing.assert_allclose(rpy_from_normal(n, yaw), [roll, pitch, yaw], atol=1e-12)


def test_zero_normal_rejected():
    with pytest.raises(ValueError, match="non-zero"):
        rpy_from_normal([0.0, 0.0, 0.0])


def test_ik_by_hand_eq3(paper):
    """Translation straight up by h: l_ij^2 = |P_j - B_i|^2 + h^2 with the paper's radii and angles."""
    h = 200.0
    B1 = (90 * math.cos(math.pi / 2), 90 * math.sin(math.pi / 2))
    P2 = (81 * math.cos(math.pi / 6), 81 * math.sin(math.pi / 6))
    l12 = math.sqrt((P2[0] - B1[0]) ** 2 + (P2[1] - B1[1]) ** 2 + h * h)
    lengths = leg_lengths(paper, [0, 0, h, 0, 0, 0])
    assert lengths[0] == pytest.approx(l12, rel=1e-15)
    # yaw by 120 degrees turns P1 -> P3 position etc.; the legs then differ but all stay positive
    assert np.all(leg_lengths(paper, [0, 0, h, 0, 0, 2 * math.pi / 3]) > 0)


def test_ik_vectorised_equals_loop(paper):
    poses = np.column_stack([RNG.normal(0, 50, (20, 3)), RNG.uniform(-0.5, 0.5, (20, 3))])
    batch = leg_lengths(paper, poses)
    for q, row in zip(poses, batch, strict=True):
        R = matrix_from_rpy(*q[3:])
        for k, (b, p) in enumerate(zip(paper.leg_base, paper.leg_platform, strict=True)):
            v = -paper.base[b] + q[:3] + R @ paper.platform[p]
            assert row[k] == pytest.approx(np.linalg.norm(v), rel=1e-14)


def test_pose_from_normal(paper):
    q = pose_from_normal([1, 2, 3], normal_from_rpy(0.1, -0.2, 0.3), 0.3)
    np.testing.assert_allclose(q, [1, 2, 3, 0.1, -0.2, 0.3], atol=1e-14)


def test_leg_jacobian_against_finite_differences(paper):
    q = np.array([10.0, -20.0, 190.0, 0.2, -0.3, 0.4])
    J = leg_jacobian(paper, q)
    h = 1e-6
    for k in range(6):
        dq = np.zeros(6)
        dq[k] = h
        fd = (leg_lengths(paper, q + dq) - leg_lengths(paper, q - dq)) / (2 * h)
        np.testing.assert_allclose(J[:, k], fd, rtol=1e-6, atol=1e-6)


def test_pose_from_points_inverts_platform_points(paper):
    for _ in range(20):
        q = np.r_[RNG.normal(0, 80, 3), RNG.uniform(-math.pi, math.pi), RNG.uniform(-1.5, 1.5),
                  RNG.uniform(-math.pi, math.pi)]
        np.testing.assert_allclose(pose_from_points(paper, platform_points(paper, q)), q, atol=1e-10)
