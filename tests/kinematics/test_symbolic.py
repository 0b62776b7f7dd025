"""Tests of labkit.kinematics.symbolic against the seeds' hand derivations and the numeric kinematics."""

import numpy as np
import pytest
import sympy as sp

from labkit.robot import Robot
from labkit.kinematics import fk, jacobian
from labkit.kinematics.symbolic import (
    dh_matrix,
    end_effector_position,
    forward_kinematics,
    geometric_jacobian,
    joint_symbols,
    lambdify_joints,
    latex,
    link_transforms,
)

q1, q2, q3 = sp.symbols("q1 q2 q3", real=True)


def test_seed000_end_effector_position_closed_form():
    """x = L2 c1 cos(q2-q3) + L1 c1 c2, y = L2 s1 cos(q2-q3) + L1 s1 c2, z = L2 sin(q3-q2) - L1 s2."""
    arm = Robot.load("arduino_arm_3dof")
    L1, L2 = sp.symbols("L1 L2", positive=True)
    p = end_effector_position(arm, lengths={"L1": 0.094, "L2": 0.180})
    seed = sp.Matrix(
        [
            L2 * sp.cos(q1) * sp.cos(q2 - q3) + L1 * sp.cos(q1) * sp.cos(q2),
            L2 * sp.sin(q1) * sp.cos(q2 - q3) + L1 * sp.sin(q1) * sp.cos(q2),
            L2 * sp.sin(q3 - q2) - L1 * sp.sin(q2),
        ]
    )
    assert all(sp.simplify(e) == 0 for e in p - seed)
    # with exact numbers (metres) instead of names
    pn = end_effector_position(arm)
    assert all(sp.simplify(e) == 0 for e in pn - seed.subs({L1: sp.Rational(94, 1000), L2: sp.Rational(180, 1000)}))


def test_seed000_link_transforms_match_the_report():
    """0_1T, 1_2T, 2_3T of seed 000 section II.3 (modified DH)."""
    arm = Robot.load("arduino_arm_3dof")
    A1, A2, A3 = link_transforms(arm, lengths={"L1": 0.094})
    L1 = sp.Symbol("L1", positive=True)
    c, s = sp.cos, sp.sin
    assert A1 == sp.Matrix([[c(q1), -s(q1), 0, 0], [s(q1), c(q1), 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    assert A2 == sp.Matrix([[c(q2), -s(q2), 0, 0], [0, 0, 1, 0], [-s(q2), -c(q2), 0, 0], [0, 0, 0, 1]])
    assert A3 == sp.Matrix([[c(q3), -s(q3), 0, L1], [-s(q3), -c(q3), 0, 0], [0, 0, -1, 0], [0, 0, 0, 1]])


def test_seed002_problem3_rpp_jacobian():
    rpp = Robot.load("rpp_seed002")
    th1, d2, d3 = joint_symbols(rpp, ["theta1", "d2", "d3"])
    J = geometric_jacobian(rpp, q=[th1, d2, d3])
    seed = sp.Matrix(
        [
            [-d3 * sp.sin(th1), 0, sp.cos(th1)],
            [d3 * sp.cos(th1), 0, sp.sin(th1)],
            [0, 1, 0],
            [0, 0, 0],
            [0, 0, 0],
            [1, 0, 0],
        ]
    )
    assert sp.simplify(J - seed) == sp.zeros(6, 3)
    # the seed leaves l1 symbolic: it does not enter the Jacobian
    assert sp.simplify(geometric_jacobian(rpp, q=[th1, d2, d3], lengths="symbolic") - seed) == sp.zeros(6, 3)


def test_seed002_problem4_puma_wrist_jacobian_of_frame3_origin():
    """The published matrix (in mm) is the Jacobian of the frame-3 origin, not of tool point A:
    the seed's cal_Ji uses the product of joints 1..3 only. Checked exactly."""
    wrist = Robot.load("puma_wrist_seed002")
    t1, t2, t3 = joint_symbols(wrist, ["theta1", "theta2", "theta3"])
    tool = wrist.tool[:3, 3]
    J3 = geometric_jacobian(wrist, point=-tool, q=[t1, t2, t3], length_unit="mm")
    s, c = sp.sin, sp.cos
    seed = sp.Matrix(
        [
            [-100 * s(t1) * s(t2), 100 * c(t1) * c(t2), 0],
            [100 * c(t1) * s(t2), 100 * s(t1) * c(t2), 0],
            [0, -100 * s(t2), 0],
            [0, -s(t1), c(t1) * s(t2)],
            [0, c(t1), s(t1) * s(t2)],
            [1, 0, c(t2)],
        ]
    )
    assert sp.simplify(J3 - seed) == sp.zeros(6, 3)
    # at tool point A the linear rows differ (third column no longer zero)
    JA = geometric_jacobian(wrist, q=[t1, t2, t3], length_unit="mm")
    assert sp.simplify(JA[:3, 2]) != sp.zeros(3, 1)
    assert sp.simplify(JA[3:, :] - seed[3:, :]) == sp.zeros(3, 3)


@pytest.mark.parametrize(
    "name, simplify",
    [
        ("arduino_arm_3dof", True),
        ("planar3r_seed003", False),
        ("planar3r_seed004", True),
        ("rpp_seed002", False),
        ("puma_wrist_seed002", True),
        ("puma600_seed002", False),
        ("puma560", False),
    ],
)
def test_lambdified_symbolic_equals_numeric(name, simplify, rng):
    robot = Robot.load(name)
    T = forward_kinematics(robot, simplify=simplify)
    J = geometric_jacobian(robot, simplify=simplify)
    fT, fJ = lambdify_joints(robot, T), lambdify_joints(robot, J)
    lim = robot.joint_limits
    for q in rng.uniform(lim[:, 0], lim[:, 1], size=(5, robot.n)):
        assert np.allclose(fT(q), fk(robot, q), atol=1e-12)
        assert np.allclose(fJ(q), jacobian(robot, q), atol=1e-12)


def test_tool_point_and_base_transform(rng):
    from labkit.rotations import matrix_from_rpy

    robot = Robot.load("planar3r_seed003")
    base = np.eye(4)
    base[:3, :3] = matrix_from_rpy([0, 0, np.pi / 2])
    base[:3, 3] = [0.1, 0.0, 0.05]
    robot = robot.replace(base=base)
    point = [0.01, 0.02, 0.0]
    p = lambdify_joints(robot, end_effector_position(robot, point=point))
    J = lambdify_joints(robot, geometric_jacobian(robot, point=point))
    from labkit.kinematics import fk_position

    for q in rng.uniform(-1, 1, size=(4, 3)):
        assert np.allclose(p(q).ravel(), fk_position(robot, q, point=point), atol=1e-12)
        assert np.allclose(J(q), jacobian(robot, q, point=point), atol=1e-12)
    # the base rotation pi/2 is kept exact
    assert forward_kinematics(robot, simplify=False).has(sp.pi) is False
    assert sp.simplify(forward_kinematics(robot)[0, 0] + sp.sin(q1 + q2 + q3)) == 0


def test_exact_twists_and_lengths():
    puma = Robot.load("puma600_seed002")
    A = link_transforms(puma, length_unit="mm")
    assert A[0][2, 3] == 500 and A[1][2, 3] == -200 and A[1][0, 3] == 500 * sp.cos(sp.Symbol("q2", real=True))
    assert A[0][2, 1] == 1  # sin(pi/2) exactly, no 6.1e-17
    A_m = link_transforms(puma)
    assert A_m[3][2, 3] == sp.Rational(2, 5)


def test_symbolic_lengths_and_dh_matrix_conventions():
    arm = Robot.load("planar3r_seed004")
    T = forward_kinematics(arm, lengths="symbolic")
    a1, a2, a3 = sp.symbols("a_1 a_2 a_3", real=True)
    assert T.free_symbols == {q1, q2, q3, a1, a2, a3}
    a, al, d, th = sp.symbols("a alpha d theta", real=True)
    S = dh_matrix(a, al, d, th, "standard")
    M = dh_matrix(a, al, d, th, "modified")
    Rz, Rx = sp.eye(4), sp.eye(4)
    Rz[:3, :3] = sp.rot_ccw_axis3(th)
    Rx[:3, :3] = sp.rot_ccw_axis1(al)
    Tz, Tx = sp.eye(4), sp.eye(4)
    Tz[2, 3], Tx[0, 3] = d, a
    assert sp.simplify(S - Rz * Tz * Tx * Rx) == sp.zeros(4, 4)
    assert sp.simplify(M - Rx * Tx * Rz * Tz) == sp.zeros(4, 4)


def test_latex_and_errors():
    arm = Robot.load("rpp_seed002")
    text = latex(geometric_jacobian(arm, q=["theta1", "d2", "d3"]))
    assert r"\sin{\left(\theta_{1} \right)}" in text and r"\begin{matrix}" in text
    with pytest.raises(ValueError, match="expected 3 joint symbols"):
        joint_symbols(arm, ["a", "b"])
    with pytest.raises(ValueError, match=r"expected length_unit as one of 'm', 'mm', 'cm', got 'in'"):
        forward_kinematics(arm, length_unit="in")
    with pytest.raises(ValueError, match="lengths None, 'numeric', 'symbolic'"):
        forward_kinematics(arm, lengths="exact")
    with pytest.raises(ValueError, match=r"q with shape \(3,\)"):
        lambdify_joints(arm, forward_kinematics(arm))([0.0, 1.0])


def test_flipped_joints_enter_negated_symbolically():
    from dataclasses import replace

    arm = Robot.load("arduino_arm_3dof")
    flipped = arm.replace(links=(arm.links[0], replace(arm.links[1], flip=True), arm.links[2]))
    T = forward_kinematics(flipped, simplify=False)
    J = geometric_jacobian(flipped, simplify=False)
    qv = np.array([0.4, 0.9, 1.3])
    assert np.abs(lambdify_joints(flipped, T)(qv) - fk(flipped, qv)).max() < 1e-12
    assert np.abs(lambdify_joints(flipped, J)(qv) - jacobian(flipped, qv)).max() < 1e-12
    assert np.abs(fk(flipped, qv) - fk(arm, qv * [1, -1, 1])).max() < 1e-12
