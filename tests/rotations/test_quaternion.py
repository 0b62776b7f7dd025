"""Quaternions, axis-angle, rotation vectors, exp/log, slerp (labkit.rotations._quaternion)."""

import subprocess
import sys

import numpy as np
import pytest
from conftest import require

from labkit.exceptions import LabkitError, RotationMatrixError, ShapeError
from labkit.rotations import (
    axis_angle_from_matrix,
    matrix_exp,
    matrix_from_axis_angle,
    matrix_from_euler,
    matrix_from_quaternion,
    matrix_from_rotation_vector,
    matrix_log,
    quaternion_from_matrix,
    rotation_about,
    rotation_vector_from_matrix,
    skew,
    slerp,
)


@pytest.fixture
def rotations(rng):
    return matrix_from_euler(rng.uniform(-np.pi, np.pi, size=(4, 5, 3)), "ZYZ")


def test_importing_rotations_does_not_import_scipy():
    code = "import sys, labkit.rotations; print(any(m.startswith('scipy') for m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_quaternion_round_trip_batched_scalar_first(rotations):
    q = quaternion_from_matrix(rotations)
    assert q.shape == (4, 5, 4) and np.all(q[..., 0] >= 0)
    assert np.allclose((q * q).sum(-1), 1.0, atol=1e-14)
    assert np.abs(matrix_from_quaternion(q) - rotations).max() < 1e-14
    # hand-made: 90 deg about z is (cos 45, 0, 0, sin 45); the sign is canonical (w >= 0)
    assert np.allclose(quaternion_from_matrix(rotation_about("z", np.pi / 2)), [np.sqrt(0.5), 0, 0, np.sqrt(0.5)])
    assert np.allclose(matrix_from_quaternion([-np.sqrt(0.5), 0, 0, -np.sqrt(0.5)]), rotation_about("z", np.pi / 2))
    # Hamilton product convention: q(R1 R2) = q(R1) * q(R2)
    R1, R2 = rotations[0, 0], rotations[0, 1]
    a, b = quaternion_from_matrix(R1), quaternion_from_matrix(R2)
    prod = np.array([a[0] * b[0] - a[1:] @ b[1:], *(a[0] * b[1:] + b[0] * a[1:] + np.cross(a[1:], b[1:]))])
    prod *= np.sign(prod[0])
    assert np.allclose(quaternion_from_matrix(R1 @ R2), prod, atol=1e-14)


def test_quaternion_errors():
    with pytest.raises(ShapeError, match=r"unit quaternions .* normalize=True .* got \|q\| = 2"):
        matrix_from_quaternion([2.0, 0, 0, 0])
    assert np.allclose(matrix_from_quaternion([2.0, 0, 0, 0], normalize=True), np.eye(3))
    with pytest.raises(ShapeError, match="non-zero quaternion"):
        matrix_from_quaternion([0.0, 0, 0, 0], normalize=True)
    with pytest.raises(ShapeError, match=r"shape \(\.\.\., 4\), got \(3,\)"):
        matrix_from_quaternion([1.0, 0, 0])
    with pytest.raises(RotationMatrixError, match="orthonormal"):
        quaternion_from_matrix(np.diag([1.0, 1.0, 2.0]))  # scipy would silently orthonormalise
    with pytest.raises(RotationMatrixError, match="det"):
        quaternion_from_matrix(np.diag([1.0, 1.0, -1.0]))


def test_axis_angle_and_rotation_vector(rotations, rng):
    axis, angle = axis_angle_from_matrix(rotations)
    assert axis.shape == (4, 5, 3) and angle.shape == (4, 5)
    assert np.all((angle >= 0) & (angle <= np.pi))
    assert np.abs(matrix_from_axis_angle(axis, angle) - rotations).max() < 1e-13
    v = rotation_vector_from_matrix(rotations)
    assert np.allclose(v, axis * angle[..., None], atol=1e-14)
    assert np.abs(matrix_from_rotation_vector(v) - rotations).max() < 1e-13
    # against the elementary rotation about an arbitrary axis, including angle pi
    k = rng.normal(size=3)
    k /= np.linalg.norm(k)
    for theta in (0.0, 1e-9, 0.3, np.pi - 1e-9, np.pi):
        R = matrix_from_axis_angle(k * 3.0, theta)  # axis need not be unit
        K = skew(k)
        rodrigues = np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K
        assert np.abs(R - rodrigues).max() < 1e-15
        a, t = axis_angle_from_matrix(R)
        assert abs(t - theta) < 1e-8
        if theta > 1e-6:
            assert min(np.abs(a - k).max(), np.abs(a + k).max() if theta > np.pi - 1e-6 else 1) < 1e-8
    a, t = axis_angle_from_matrix(np.eye(3))
    assert t == 0.0 and a.tolist() == [1.0, 0.0, 0.0]
    with pytest.raises(ShapeError, match="non-zero rotation axis"):
        matrix_from_axis_angle([0, 0, 0], 1.0)
    with pytest.raises(ShapeError, match="broadcastable"):
        matrix_from_axis_angle(np.ones((2, 3)), [1.0, 2.0, 3.0])


def test_exp_log_are_inverse_and_match_modern_robotics(rotations):
    mr = require("modern_robotics")
    S = matrix_log(rotations)
    assert np.allclose(S, -np.swapaxes(S, -1, -2))
    assert np.abs(matrix_exp(S) - rotations).max() < 1e-13
    for R in rotations.reshape(-1, 3, 3)[:6]:
        assert np.abs(matrix_log(R) - mr.MatrixLog3(R)).max() < 1e-9
        assert np.abs(matrix_exp(matrix_log(R)) - mr.MatrixExp3(mr.MatrixLog3(R))).max() < 1e-12
    assert np.allclose(skew([1, 2, 3]) @ [4, 5, 6], np.cross([1, 2, 3], [4, 5, 6]))
    with pytest.raises(ShapeError, match="skew-symmetric"):
        matrix_exp(np.eye(3))


def test_slerp_constant_angular_speed_and_shortest_arc(rng):
    R0, R1 = matrix_from_euler(rng.uniform(-3, 3, size=(2, 3)), "XYZ")
    s = np.linspace(0, 1, 11)
    path = slerp(R0, R1, s)
    assert path.shape == (11, 3, 3)
    assert np.abs(path[0] - R0).max() < 1e-14 and np.abs(path[-1] - R1).max() < 1e-14
    _, total = axis_angle_from_matrix(R0.T @ R1)
    steps = axis_angle_from_matrix(np.swapaxes(path[:-1], -1, -2) @ path[1:])[1]
    assert np.allclose(steps, total / 10, atol=1e-12)  # equal steps, summing to the shortest arc
    # against the closed form R0 exp(s log(R0^T R1))
    closed = R0 @ matrix_exp(s[:, None, None] * matrix_log(R0.T @ R1))
    assert np.abs(path - closed).max() < 1e-12
    assert slerp(R0, R1, np.full((2, 3), 0.5)).shape == (2, 3, 3, 3)
    with pytest.raises(ShapeError, match=r"s in \[0, 1\]"):
        slerp(R0, R1, 1.5)
    with pytest.raises(RotationMatrixError, match="R_end: expected an orthonormal"):
        slerp(R0, 2 * R1, 0.5)
    with pytest.raises(LabkitError, match=r"R_start with shape \(3, 3\)"):
        slerp(np.stack([R0, R0]), R1, 0.5)
