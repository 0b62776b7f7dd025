"""Joint rates and accelerations of Cartesian trajectories against independent computations.

``cartesian_trajectory`` gives ``qd = J^-1 xd`` and ``qdd = J^-1 (xdd - Jdot qd)``
(adjugate for 3x3 Jacobians, ``Jdot qd`` from a second difference of the tool
position). Checked here against what does not share that code: the
pseudo-inverse of the Jacobian (``numpy.linalg.pinv``), ``Jdot qd`` from central
differences of the Jacobian along ``qd``, and finite differences of the IK path
in time; for the 3-DOF arm (position rows), a planar 3R (``x, y, phi`` rows),
an arm with a flipped joint and the PUMA 560 (all six rows).
"""

from dataclasses import replace

import numpy as np
import pytest

from labkit.kinematics import fk, jacobian
from labkit.motion import arc_path, cartesian_trajectory, line_path
from labkit.motion._rates import ROWS, solver3
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
    rows = list(ROWS[kind])
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


def test_adjugate_solver_from_rows_equals_the_batch_solver():
    rng = np.random.default_rng(4)
    J = rng.normal(size=(300, 3, 3))
    J[5, :, 1] = 2.0 * J[5, :, 0]  # singular
    b = rng.normal(size=(300, 3))
    x = solver3(J)(b)
    ok = np.ones(300, dtype=bool)
    ok[5] = False
    np.testing.assert_allclose(x[ok], np.linalg.solve(J[ok], b[ok][..., None])[..., 0], rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(x[5], np.linalg.pinv(J[5]) @ b[5], atol=1e-12)
