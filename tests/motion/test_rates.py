"""Joint rates and accelerations of Cartesian trajectories against independent computations.

``cartesian_trajectory`` gives ``qd = joint_rates(J, xd)`` and
``qdd = joint_rates(J, xdd - Jdot qd)`` with the one rule of
:func:`labkit.kinematics.joint_rates` (exact away from singularities, damped
least squares near them; evaluated by the adjugate for certified 3x3 samples,
``Jdot qd`` from a second difference of the tool position). Checked here
against what does not share that code: the pseudo-inverse of the Jacobian
(``numpy.linalg.pinv``) away from singularities, ``Jdot qd`` from central
differences of the Jacobian along ``qd``, and finite differences of the IK path
in time; for the 3-DOF arm (position rows), a planar 3R (``x, y, phi`` rows),
an arm with a flipped joint and the PUMA 560 (all six rows). Near a
singularity the rates are the damped ones of ``kinematics.joint_rates``.
"""

from dataclasses import replace

import numpy as np
import pytest

from labkit.kinematics import damping_factor, fk, fk_position, jacobian, joint_rates, task_rows
from labkit.motion import arc_path, cartesian_trajectory, line_path
from labkit.motion._rates import solver3
from labkit.robot import Robot


def _cases():
    arm = Robot.load("arduino_arm_3dof")
    flipped = arm.replace(links=(replace(arm.links[0], flip=True, limits=(-np.pi, 0.0)),) + arm.links[1:])
    puma = Robot.load("puma560")
    q0 = np.array([0.1, 0.5, -0.3, 0.2, 0.4, 0.1])
    T0 = fk(puma, q0)
    return {
        "arm": (arm, "position", dict(path=line_path([0.0, 0.18, -0.094], [0.1, 0.15, -0.2]), duration=5.0,
                                      branch="elbow_up")),
        "arm_flipped": (flipped, "position", dict(path=line_path([0.0, 0.18, -0.094], [0.1, 0.15, -0.2]),
                                                  duration=5.0, branch="elbow_up")),
        "planar": (Robot.load("planar3r_seed004"), "planar",
                   dict(path=arc_path([0.1, 0.25], 0.25, -np.pi / 2, np.pi / 2), duration=2.0,
                        orientation=[-np.pi / 2, 0.0], branch="elbow_minus")),
        "puma": (puma, "pose", dict(path=line_path(T0[:3, 3], T0[:3, 3] + [0.05, -0.05, 0.05]), duration=2.0,
                                    q_start=q0)),
    }


CASES = _cases()


@pytest.mark.parametrize("name", sorted(CASES))
def test_rates_match_pseudo_inverse_and_jacobian_differences(name):
    robot, kind, kw = CASES[name]
    kw = dict(kw)
    traj = cartesian_trajectory(robot, kw.pop("path"), kw.pop("duration"), dt=0.002, **kw)
    rows = list(task_rows(kind))
    J = jacobian(robot, traj.q)[:, rows, :]
    qd = np.einsum("nij,nj->ni", np.linalg.pinv(J), traj.xd)  # for a pose, xd holds (v, omega)
    np.testing.assert_allclose(traj.qd, qd, rtol=1e-10, atol=1e-12)
    # Jdot qd from central differences of the Jacobian along qd (not the position second difference)
    h = 1e-6
    Jdot_qd = np.einsum("nij,nj->ni", (jacobian(robot, traj.q + h * traj.qd)[:, rows, :]
                                       - jacobian(robot, traj.q - h * traj.qd)[:, rows, :]) / (2 * h), traj.qd)
    qdd = np.einsum("nij,nj->ni", np.linalg.pinv(J), np.asarray(traj.xdd) - Jdot_qd)
    np.testing.assert_allclose(traj.qdd, qdd, rtol=0, atol=1e-6 * max(1.0, np.abs(qdd).max()))
    # and the IK path differentiated in time
    qd_fd = np.gradient(traj.q, traj.t, axis=0, edge_order=2)
    assert np.abs(qd_fd - traj.qd).max() < 1e-4 * max(1.0, np.abs(traj.qd).max())
    qdd_fd = np.gradient(traj.qd, traj.t, axis=0, edge_order=2)
    assert np.abs(qdd_fd[2:-2] - traj.qdd[2:-2]).max() < 1e-3 * max(1.0, np.abs(traj.qdd).max())


def test_10k_sample_line_rates_are_the_pseudo_inverse_rates():
    """The benchmark's line (10,000 samples): the adjugate solve agrees with pinv to 1e-12."""
    robot, _, kw = CASES["arm"]
    t = np.linspace(0.0, 5.0, 10_000)
    traj = cartesian_trajectory(robot, kw["path"], 5.0, t=t, branch="elbow_up")
    J = jacobian(robot, traj.q)[:, :3, :]
    np.testing.assert_allclose(traj.qd, np.einsum("nij,nj->ni", np.linalg.pinv(J), traj.xd), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", J, traj.qd), traj.xd, rtol=0, atol=1e-13)


def test_adjugate_solver_is_the_kinematics_rule():
    """Certified samples by the adjugate, the rest by joint_rates: the values of joint_rates everywhere."""
    rng = np.random.default_rng(4)
    J = 0.1 * rng.normal(size=(300, 3, 3))  # arm-sized columns [m/rad]: some samples have s_min < epsilon
    J[5, :, 1] = 2.0 * J[5, :, 0]  # singular
    J[6] = 0.0
    b = rng.normal(size=(300, 3))
    x = solver3(J)(b)
    s_min = np.linalg.svd(J, compute_uv=False)[:, -1]
    assert np.sum(damping_factor(s_min, 1e-2, 5e-2) > 0) >= 5  # the damped branch is exercised
    np.testing.assert_allclose(x, joint_rates(J, b), rtol=1e-9, atol=1e-9)
    assert np.all(np.isfinite(x))


def test_rates_near_a_singularity_are_the_damped_kinematics_rates():
    """The 3-DOF arm stretching out towards full reach (q3 -> 0): one rule for the rates, damped there.

    ``qd`` equals ``kinematics.joint_rates(J, xd)`` at every sample, damped ones
    included, and ``qdd`` equals ``joint_rates(J, xdd - Jdot qd)`` with ``Jdot qd``
    from central differences of the Jacobian.
    """
    arm = Robot.load("arduino_arm_3dof")
    q_near = np.array([0.3, 0.4, 0.02])  # s_min of the position rows below epsilon = 0.01
    q_far = np.array([0.3, 0.4, 0.8])
    path = line_path(fk_position(arm, q_far), fk_position(arm, q_near))
    traj = cartesian_trajectory(arm, path, 2.0, dt=0.01, q_start=q_far, max_joint_step=0.5)
    J = jacobian(arm, traj.q)[:, :3, :]
    lam = damping_factor(np.linalg.svd(J, compute_uv=False)[:, -1], 1e-2, 5e-2)
    assert lam[-10:].min() > 0 and lam[:20].max() == 0  # damped at the end, exact at the start
    np.testing.assert_allclose(traj.qd, joint_rates(J, traj.xd), rtol=1e-9, atol=1e-12)
    exact = np.einsum("nij,nj->ni", np.linalg.pinv(J), traj.xd)
    damped = lam > 0
    np.testing.assert_allclose(traj.qd[~damped], exact[~damped], rtol=1e-10, atol=1e-12)
    h = 1e-6
    Jdot_qd = np.einsum("nij,nj->ni", (jacobian(arm, traj.q + h * traj.qd)[:, :3, :]
                                       - jacobian(arm, traj.q - h * traj.qd)[:, :3, :]) / (2 * h), traj.qd)
    qdd = joint_rates(J, np.asarray(traj.xdd) - Jdot_qd)
    np.testing.assert_allclose(traj.qdd, qdd, rtol=0, atol=1e-6 * max(1.0, np.abs(qdd).max()))
