"""labkit.dynamics: properties that hold for any robot, checked against independent derivations.

The kinetic energy from finite differences of the link frames (fk_frames), the gravity torques
as the gradient of the potential energy, M symmetric positive definite, dM/dt - 2C
skew-symmetric, energy conserved in a frictionless free swing; shapes, defaults and errors.
"""

import numpy as np
import pytest

from labkit import dynamics as D
from labkit.exceptions import DynamicsError, OptionError, RobotError, ShapeError
from labkit.kinematics import fk_frames
from labkit.robot import Convention, JointType, Link, LinkInertia, Motor, Robot
from labkit.rotations import matrix_from_rpy


def _random_robot(rng, convention, motors=False):
    n = int(rng.integers(2, 7))
    links = []
    for _ in range(n):
        prismatic = rng.random() < 0.3
        A = rng.normal(size=(3, 3)) * 0.05
        links.append(Link(
            a=float(rng.uniform(-0.5, 0.5)), alpha=float(rng.uniform(-3, 3)), d=float(rng.uniform(-0.5, 0.5)),
            theta=float(rng.uniform(-3, 3)), joint_type=JointType.PRISMATIC if prismatic else JointType.REVOLUTE,
            limits=(-1.0, 1.0) if prismatic else (-np.pi, np.pi), flip=bool(rng.random() < 0.4),
            inertial=LinkInertia.from_matrix(float(rng.uniform(0.2, 3)), rng.uniform(-0.2, 0.2, 3),
                                             A @ A.T + 1e-3 * np.eye(3)),
            motor=Motor(float(rng.uniform(0, 1e-4)), float(rng.uniform(-80, 80)), 1e-4, (0.01, -0.02))
            if motors else None,
        ))
    base = np.eye(4)
    base[:3, :3] = matrix_from_rpy(rng.uniform(-np.pi, np.pi, 3))
    base[:3, 3] = rng.uniform(-0.3, 0.3, 3)
    return Robot(name="random", links=tuple(links), convention=convention, base=base)


ROBOTS = [_random_robot(np.random.default_rng(k), c) for k in range(4) for c in Convention]


def _kinetic_from_frames(robot, q, qd, h=1e-6):
    """sum of m v_c^2 / 2 + w^T I w / 2 with velocities from central differences of the link frames."""
    Tp, Tm, T = fk_frames(robot, q + h * qd), fk_frames(robot, q - h * qd), fk_frames(robot, q)
    K = 0.0
    for i, lk in enumerate(robot.links):
        c = np.r_[lk.inertial.com, 1.0]
        v = (Tp[i + 1] @ c - Tm[i + 1] @ c)[:3] / (2 * h)
        R = T[i + 1, :3, :3]
        W = (Tp[i + 1, :3, :3] - Tm[i + 1, :3, :3]) / (2 * h) @ R.T
        w = np.array([W[2, 1], W[0, 2], W[1, 0]])
        K += 0.5 * lk.inertial.mass * v @ v + 0.5 * w @ (R @ lk.inertial.matrix @ R.T) @ w
    return K


@pytest.mark.parametrize("robot", ROBOTS, ids=lambda r: f"{r.convention.value}-{r.n}")
def test_mass_matrix_is_the_kinetic_energy_of_the_moving_frames(robot):
    rng = np.random.default_rng(robot.n)
    for _ in range(3):
        q, qd = rng.uniform(-1, 1, (2, robot.n))
        assert 0.5 * qd @ D.mass_matrix(robot, q) @ qd == pytest.approx(_kinetic_from_frames(robot, q, qd), rel=1e-7)


@pytest.mark.parametrize("robot", ROBOTS, ids=lambda r: f"{r.convention.value}-{r.n}")
def test_gravity_torques_are_the_gradient_of_the_potential_energy(robot):
    rng = np.random.default_rng(robot.n + 10)
    g = rng.normal(size=3) * 5
    q = rng.uniform(-1, 1, robot.n)
    h = 1e-6
    grad = [(D.potential_energy(robot, q + h * e, gravity=g) - D.potential_energy(robot, q - h * e, gravity=g)) / (2 * h)
            for e in np.eye(robot.n)]
    assert np.allclose(D.gravity_torques(robot, q, gravity=g), grad, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("robot", ROBOTS, ids=lambda r: f"{r.convention.value}-{r.n}")
def test_mass_matrix_spd_and_dm_minus_2c_skew(robot):
    rng = np.random.default_rng(robot.n + 20)
    q, qd = rng.uniform(-1, 1, (2, 5, robot.n))
    M = D.mass_matrix(robot, q)
    assert np.array_equal(M, np.swapaxes(M, -1, -2))
    assert np.all(np.linalg.eigvalsh(M)[:, 0] > 0)
    h = 1e-6
    dM = (D.mass_matrix(robot, q + h * qd) - D.mass_matrix(robot, q - h * qd)) / (2 * h)
    S = dM - 2 * D.coriolis_matrix(robot, q, qd)
    assert np.abs(S + np.swapaxes(S, -1, -2)).max() < 1e-6 * np.abs(dM).max()


def test_inverse_dynamics_is_m_qdd_plus_c_qd_plus_g_plus_friction():
    robot = _random_robot(np.random.default_rng(7), Convention.MODIFIED, motors=True)
    rng = np.random.default_rng(8)
    q, qd, qdd = rng.uniform(-1, 1, (3, 2, 3, robot.n))  # batch (2, 3)
    tau = D.inverse_dynamics(robot, q, qd, qdd)
    assert tau.shape == (2, 3, robot.n)
    parts = (np.einsum("...ij,...j->...i", D.mass_matrix(robot, q), qdd)
             + np.einsum("...ij,...j->...i", D.coriolis_matrix(robot, q, qd), qd)
             + D.gravity_torques(robot, q) + D.friction_torques(robot, qd))
    assert np.allclose(tau, parts, rtol=1e-12, atol=1e-12)
    assert np.allclose(D.forward_dynamics(robot, q, qd, tau), qdd, rtol=1e-9, atol=1e-9)
    assert np.allclose(tau[1, 2], D.inverse_dynamics(robot, q[1, 2], qd[1, 2], qdd[1, 2]), rtol=1e-14, atol=1e-14)


def test_a_big_batch_runs_in_chunks_with_the_same_numbers():
    from labkit.dynamics._model import CHUNK

    robot = _random_robot(np.random.default_rng(11), Convention.STANDARD, motors=True)
    q, qd, qdd = np.random.default_rng(12).uniform(-1, 1, (3, 2 * CHUNK + 5, robot.n))
    tail = slice(2 * CHUNK, None)
    for big, small in [
        (D.inverse_dynamics(robot, q, qd, qdd), D.inverse_dynamics(robot, q[tail], qd[tail], qdd[tail])),
        (D.mass_matrix(robot, q), D.mass_matrix(robot, q[tail])),
        (D.coriolis_matrix(robot, q, qd), D.coriolis_matrix(robot, q[tail], qd[tail])),
        (D.gravity_torques(robot, q), D.gravity_torques(robot, q[tail])),
        (D.forward_dynamics(robot, q, qd, qdd), D.forward_dynamics(robot, q[tail], qd[tail], qdd[tail])),
    ]:
        assert big.shape[0] == 2 * CHUNK + 5 and np.array_equal(big[tail], small)


def test_a_flipped_joint_is_the_unflipped_joint_run_backwards():
    robot = _random_robot(np.random.default_rng(9), Convention.STANDARD, motors=True)
    plain = robot.replace(links=tuple(lk.__class__(**{**lk.__dict__, "flip": False}) for lk in robot.links))
    sign = np.where(robot.flip, -1.0, 1.0)
    rng = np.random.default_rng(10)
    q, qd, qdd = rng.uniform(-1, 1, (3, robot.n))
    assert robot.flip.any()
    # friction and armature are even in the joint direction: compare the rigid-body part
    tau = D.inverse_dynamics(robot, q, qd, qdd, friction=False)
    assert np.allclose(tau, sign * D.inverse_dynamics(plain, sign * q, sign * qd, sign * qdd, friction=False),
                       rtol=1e-12, atol=1e-12)


def test_default_gravity_points_along_minus_up():
    arm = Robot.load("puma560")
    q = np.random.default_rng(1).uniform(-1, 1, 6)
    assert np.allclose(D.gravity_torques(arm, q), D.gravity_torques(arm, q, gravity=[0, 0, -9.81]))
    upside_down = arm.replace(up=[0.0, 0.0, -1.0])
    assert np.allclose(D.gravity_torques(upside_down, q), -D.gravity_torques(arm, q))
    assert D.STANDARD_GRAVITY == 9.81


def _two_link():
    links = tuple(Link(a=0.4, inertial=LinkInertia(1.5, (-0.2, 0.0, 0.0), (1e-3, 0.02, 0.02, 0, 0, 0)))
                  for _ in range(2))
    return Robot(name="two_link", links=links, up=[0.0, 1.0, 0.0])  # swings in the xy plane


def test_free_swing_conserves_energy():
    puma = Robot.load("puma560")
    run = D.simulate(puma, [0.2, 0.8, -0.5, 0.3, 0.4, 0.1], np.zeros(6), [0.0, 0.1, 0.2], friction=False)
    E = D.kinetic_energy(puma, run.q, run.qd) + D.potential_energy(puma, run.q)
    assert np.ptp(E) < 1e-8 * abs(E[0])
    assert np.ptp(run.q[:, 1]) > 0.01  # it did swing
    arm = _two_link()
    swing = D.simulate(arm, [0.3, 0.5], [0.0, 0.0], np.linspace(0, 1.0, 9), friction=False, rtol=1e-9, atol=1e-9)
    E = D.kinetic_energy(arm, swing.q, swing.qd) + D.potential_energy(arm, swing.q)
    assert np.ptp(E) < 1e-7 * np.ptp(D.potential_energy(arm, swing.q))
    assert swing.to_dataframe().shape == (9, 1 + 3 * 2)


def test_a_controller_holds_a_pose_and_batches_simulate_together():
    arm = _two_link()
    target = np.array([0.4, -0.6])

    def controller(time, q, qd):  # PD with gravity compensation
        return 40.0 * (target - q) - 8.0 * qd + D.gravity_torques(arm, q)

    held = D.simulate(arm, [0.0, 0.0], [0.0, 0.0], np.linspace(0, 3.0, 4), torque=controller, solver="RK45",
                      rtol=1e-5, atol=1e-7)
    assert np.abs(held.q[-1] - target).max() < 1e-3 < np.abs(held.q[0] - target).max()
    assert np.allclose(held.tau[-1], D.gravity_torques(arm, held.q[-1]), atol=0.05)
    batch = D.simulate(arm, np.zeros((3, 2)), np.zeros((3, 2)), [0.0, 0.3], torque=[1.0, 0.0], rtol=1e-6)
    assert batch.q.shape == (2, 3, 2) and np.allclose(batch.q[-1], batch.q[-1, 0])


def test_errors_say_what_was_expected():
    puma = Robot.load("puma560")
    with pytest.raises(RobotError, match="no inertial parameters"):
        D.mass_matrix(Robot.load("planar3r_seed004"), np.zeros(3))
    with pytest.raises(ShapeError, match=r"\(\.\.\., 6\)"):
        D.inverse_dynamics(puma, np.zeros(5), np.zeros(6), np.zeros(6))
    with pytest.raises(ShapeError, match="one batch shape"):
        D.inverse_dynamics(puma, np.zeros((2, 6)), np.zeros((3, 6)), np.zeros(6))
    with pytest.raises(ShapeError, match="finite"):
        D.gravity_torques(puma, [np.nan] * 6)
    with pytest.raises(ShapeError, match="gravity"):
        D.gravity_torques(puma, np.zeros(6), gravity=[0, 9.81])
    with pytest.raises(OptionError, match="RK45"):
        D.simulate(puma, np.zeros(6), np.zeros(6), [0, 1], solver="euler")
    with pytest.raises(ShapeError, match="increasing"):
        D.simulate(puma, np.zeros(6), np.zeros(6), [1, 0])
    with pytest.raises(ShapeError, match="torque"):
        D.simulate(puma, np.zeros(6), np.zeros(6), [0, 1], torque=np.zeros(4))
    massless = puma.with_link(5, inertial=None, motor=None)
    with pytest.raises(DynamicsError, match="singular"):
        D.forward_dynamics(massless, np.zeros(6), np.zeros(6), np.zeros(6))
