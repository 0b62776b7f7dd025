"""Tests of labkit.kinematics statics (seed 002 problems 3 and 4, power consistency, singularities)."""

import numpy as np
import pytest

from labkit.robot import Link, Robot
from labkit.exceptions import ShapeError
from labkit.kinematics import fk, jacobian
from labkit.rotations import skew
from labkit.kinematics import (
    condition_number,
    damping_factor,
    is_singular,
    joint_rates,
    joint_torques,
    manipulability,
    singular_values,
    transform_wrench,
    wrench_transform_matrix,
)


def test_seed002_problem3_rpp_joint_forces():
    rpp = Robot.load("rpp_seed002")
    J = jacobian(rpp, [0.0, 1.0, 1.0])
    tau = joint_torques(J, [1, 2, 3, 0, 0, 0])
    assert np.allclose(tau, [2, 3, 1], atol=1e-12)


def test_seed002_problem3_symbolic_tau_formula(rng):
    """tau = [n3 + d3 f2 c1 - d3 f1 s1, f3, f1 c1 + f2 s1] (seed 002 problem 3)."""
    rpp = Robot.load("rpp_seed002")
    q = np.column_stack([rng.uniform(-3, 3, 20), rng.uniform(0, 2, 20), rng.uniform(0, 2, 20)])
    F = rng.normal(size=(20, 6))
    tau = joint_torques(jacobian(rpp, q), F)
    t1, d3 = q[:, 0], q[:, 2]
    f1, f2, f3, n3 = F[:, 0], F[:, 1], F[:, 2], F[:, 5]
    expected = np.column_stack(
        [n3 + d3 * f2 * np.cos(t1) - d3 * f1 * np.sin(t1), f3, f1 * np.cos(t1) + f2 * np.sin(t1)]
    )
    assert np.allclose(tau, expected, atol=1e-12)


def test_power_consistency(rng):
    """F . v == tau . qd for any wrench and joint rates (virtual work)."""
    for name in ("puma560", "rpp_seed002", "arduino_arm_3dof", "puma600_seed002"):
        robot = Robot.load(name)
        lim = robot.joint_limits
        q = rng.uniform(lim[:, 0], lim[:, 1], size=(30, robot.n))
        qd = rng.normal(size=(30, robot.n))
        F = rng.normal(size=(30, 6))
        J = jacobian(robot, q)
        v = np.einsum("...in,...n->...i", J, qd)
        tau = joint_torques(J, F)
        assert np.allclose(np.sum(F * v, -1), np.sum(tau * qd, -1), atol=1e-12)


def test_skew_is_cross_product(rng):
    p, v = rng.normal(size=(2, 5, 3))
    assert np.allclose(np.einsum("...ij,...j->...i", skew(p), v), np.cross(p, v))
    assert np.allclose(skew(p), -np.swapaxes(skew(p), -1, -2))


def test_seed002_problem4_wrench_moved_to_frame3_gives_same_torques(rng):
    """tau from the wrench at tool point A == tau from the wrench moved to the frame-3 origin
    with [f; n_3] = [[I, 0], [p x, I]] [f; n_A] and the frame-3 Jacobian (seed 002 problem 4)."""
    wrist = Robot.load("puma_wrist_seed002")
    q = rng.uniform(-np.pi, np.pi, size=(10, 3))
    tool_in_3 = wrist.tool[:3, 3]
    J_A = jacobian(wrist, q)
    J_3 = jacobian(wrist, q, point=-tool_in_3)  # frame-3 origin, given in tool coordinates
    T = fk(wrist, q)
    p_3_to_A = T[:, :3, :3] @ tool_in_3  # vector from O3 to A in base axes
    F_A = rng.normal(size=(10, 6))
    F_3 = transform_wrench(F_A, p_3_to_A)
    assert np.allclose(F_3[:, :3], F_A[:, :3])
    assert np.allclose(F_3[:, 3:], F_A[:, 3:] + np.cross(p_3_to_A, F_A[:, :3]))
    assert np.allclose(joint_torques(J_3, F_3), joint_torques(J_A, F_A), atol=1e-12)


def test_wrench_transform_with_rotation(rng):
    from labkit.rotations import matrix_from_rpy

    R = matrix_from_rpy(rng.uniform(-1, 1, 3))
    p = rng.normal(size=3)
    w_C = rng.normal(size=6)
    w_B = transform_wrench(w_C, p, R)
    f = R @ w_C[:3]
    assert np.allclose(w_B, np.r_[f, R @ w_C[3:] + np.cross(p, f)])
    X = wrench_transform_matrix(np.zeros((4, 3)))
    assert X.shape == (4, 6, 6) and np.allclose(X, np.eye(6))


def test_planar_2r_manipulability_and_condition():
    arm = Robot("2r", (Link(a=1.0), Link(a=0.5)))
    q2 = np.linspace(0.1, 3.0, 7)
    q = np.column_stack([np.full_like(q2, 0.4), q2])
    J = jacobian(arm, q)
    assert np.allclose(manipulability(J, "linear"), 0.5 * np.abs(np.sin(q2)))
    assert np.all(condition_number(J, "linear") >= 1.0)
    assert singular_values(J).shape == (7, 2)


def test_singular_configurations_detected():
    arm = Robot.load("arduino_arm_3dof")
    q2 = np.radians(60.0)
    q3_over_axis = q2 - np.arccos(-0.094 * np.cos(q2) / 0.180)  # x = y = 0: point on the base axis
    q = np.array([np.radians([30, 40, 0]), np.radians([30, 40, 90]), [0.5, q2, q3_over_axis],
                  np.radians([0, 0, 180])])
    J = jacobian(arm, q)
    assert np.allclose(fk(arm, q[2])[:2, 3], 0.0, atol=1e-12)
    # q3 = 0: stretched out; q3 = 180 deg: folded back; point on the base axis: yaw does not move it
    assert is_singular(J, "linear").tolist() == [True, False, True, True]
    kappa = condition_number(J, "linear")
    assert np.isinf(kappa[0]) or kappa[0] > 1e12
    assert np.isclose(manipulability(J, "linear")[0], 0.0, atol=1e-12)
    puma = Robot.load("puma560")
    Jp = jacobian(puma, np.array([[0.1, 0.5, -0.3, 0.2, 0.0, 0.3], [0.1, 0.5, -0.3, 0.2, 0.7, 0.3]]))
    assert is_singular(Jp).tolist() == [True, False]  # q5 = 0: wrist singularity


def test_part_validation():
    with pytest.raises(ValueError, match=r"expected part as one of 'full', 'linear', 'angular', got 'xyz'"):
        manipulability(np.zeros((6, 3)), "xyz")
    with pytest.raises(ShapeError, match=r"\(\.\.\., 6, n\), got \(3, 3\)"):
        manipulability(np.zeros((3, 3)))
    with pytest.raises(ShapeError, match=r"\(\.\.\., 6\), got \(3,\)"):
        joint_torques(np.zeros((6, 3)), [1, 2, 3])


def test_damping_switches_on_only_near_singularity():
    lam = damping_factor([0.5, 0.02, 0.01, 0.005, 0.0], epsilon=0.01, max_damping=0.05)
    assert lam[0] == 0 and lam[1] == 0 and lam[2] == 0
    assert 0 < lam[3] < 0.05 and lam[4] == 0.05


def test_joint_rates_exact_away_from_singularity(rng):
    puma = Robot.load("puma560")
    q = rng.uniform(-1, 1, size=(50, 6))
    q[:, 4] = rng.uniform(0.5, 1.2, size=50)  # keep away from the wrist singularity
    q[:, 2] = rng.uniform(-1.2, -0.2, size=50)  # and from the elbow one
    J = jacobian(puma, q)
    v = rng.normal(size=(50, 6))
    qd = joint_rates(J, v)
    assert np.allclose(np.einsum("...in,...n->...i", J, qd), v, atol=1e-9)
    assert np.allclose(qd, np.linalg.solve(J, v[..., None])[..., 0], atol=1e-9)


def test_joint_rates_finite_and_bounded_at_singularity():
    arm = Robot.load("arduino_arm_3dof")
    q = np.radians([[30, 40, 0], [30, 40, 1e-6], [30, 40, 0.5]])
    Jv = jacobian(arm, q)[:, :3]
    v = np.array([0.05, 0.0, 0.0])  # partly along the lost direction
    qd = joint_rates(Jv, v, epsilon=0.01, max_damping=0.05)
    assert np.all(np.isfinite(qd))
    assert np.abs(qd).max() < 0.05 / (2 * 0.01) * 5
    undamped = np.linalg.pinv(Jv[1]) @ v
    assert np.abs(undamped).max() > 100 * np.abs(qd[1]).max()


def test_joint_rates_redundant_minimum_norm(rng):
    arm = Robot("3r", (Link(a=0.3), Link(a=0.2), Link(a=0.1)))
    J = jacobian(arm, [0.2, 0.5, 0.4])[:2]
    v = np.array([0.1, -0.2])
    qd = joint_rates(J, v)
    assert np.allclose(J @ qd, v)
    assert np.allclose(qd, np.linalg.pinv(J) @ v)
    with pytest.raises(ShapeError, match=r"twist with shape \(\.\.\., 2\)"):
        joint_rates(J, [1.0, 2.0, 3.0])


def test_task_rows_name_the_jacobian_rows_of_each_target_kind():
    from labkit.exceptions import OptionError
    from labkit.kinematics import target_kind, task_rows

    assert task_rows("position") == (0, 1, 2)
    assert task_rows("planar") == (0, 1, 5)  # x, y and the rotation rate about z (phi)
    assert task_rows("pose") == (0, 1, 2, 3, 4, 5)
    for name in ("arduino_arm_3dof", "planar3r_seed004", "puma560"):  # the task block of each is square
        robot = Robot.load(name)
        assert jacobian(robot, [0.1] * robot.n)[list(task_rows(target_kind(robot)))].shape == (robot.n, robot.n)
    with pytest.raises(OptionError, match="unknown target kind 'orientation'; expected one of 'position', 'planar', 'pose'"):
        task_rows("orientation")
    with pytest.raises(OptionError, match="unknown target kind"):
        task_rows(["position"])
