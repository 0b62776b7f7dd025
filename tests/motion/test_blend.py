"""Blended multi-segment paths (labkit.motion._blend): straight segments, parabolic blends near via points."""

import numpy as np
import pytest

from labkit.exceptions import ShapeError, TrajectoryError
from labkit.motion import blended_law, blended_trajectory, cartesian_blended_trajectory, via_trajectory
from labkit.robot import Robot

P = np.array([[0.0, 0.0, 0.0], [1.0, 0.5, -0.2], [1.2, 1.5, 0.4], [0.2, 0.3, 0.1]])


def _via_times(durations, tau):
    return tau / 2 + np.concatenate([[0.0], np.cumsum(durations)])


def test_hand_example_and_corner_formula():
    law = blended_law(None, [[0.0], [1.0], [1.0]], durations=1.0, blend_time=0.5)
    assert law.duration == pytest.approx(2.5) and law.degree == 2
    # v goes 0 -> 1 -> 0; at the via time the blend misses the corner by |dv| tau / 8
    assert float(law.position(1.25)[0]) == pytest.approx(1.0 - 0.5 / 8, abs=1e-15)
    d, tau = np.array([1.0, 1.5, 0.8]), 0.3
    law = blended_law(None, P, durations=d, blend_time=tau)
    T = _via_times(d, tau)
    v = np.vstack([np.zeros(3), np.diff(P, axis=0) / d[:, None], np.zeros(3)])
    miss = np.asarray(law.position(T)) - P
    assert np.allclose(miss, np.diff(v, axis=0) * tau / 8, atol=1e-14)
    assert np.allclose(law.position([0.0, law.tf]), P[[0, -1]], atol=1e-15)  # the ends are reached at rest


def test_straight_at_constant_speed_between_blends_and_c1_everywhere():
    d, tau = np.array([1.0, 1.5, 0.8]), 0.3
    law = blended_law(None, P, durations=d, blend_time=tau)
    T = _via_times(d, tau)
    for k in range(len(d)):
        t = np.linspace(T[k] + tau / 2, T[k + 1] - tau / 2, 7)
        x = np.asarray(law.position(t))
        # on the line through P_k and P_k+1, timed so that the line passes P_k at T_k
        assert np.allclose(x, P[k] + np.outer(t - T[k], (P[k + 1] - P[k]) / d[k]), atol=1e-14)
        assert np.allclose(law.velocity(t), (P[k + 1] - P[k]) / d[k], atol=1e-14)
    b = law.breaks
    for f in (law.position, law.velocity):
        left, right = np.asarray(f(b[1:-1] - 1e-12)), np.asarray(f(b[1:-1] + 1e-12))
        assert np.abs(left - right).max() < 1e-9
    assert np.allclose(law.position([0.0, law.tf]), P[[0, -1]], atol=1e-15)
    assert np.abs(np.asarray(law.velocity([0.0, law.tf]))).max() < 1e-15


def test_automatic_timing_respects_and_reaches_the_bounds():
    v_max, a_max = np.array([1.0, 2.0, 0.5]), np.array([4.0, 4.0, 3.0])
    traj = blended_trajectory(None, P, v_max=v_max, a_max=a_max, dt=0.001)
    assert np.all(np.abs(traj.qd) <= v_max * (1 + 1e-9))
    assert np.all(np.abs(traj.qdd) <= a_max * (1 + 1e-9))
    # time-optimal in this scheme: some coordinate at v_max on every segment, some blend at a_max
    assert np.any(np.isclose(np.abs(traj.qd), v_max, rtol=1e-9))
    assert np.any(np.isclose(np.abs(traj.qdd), a_max, rtol=1e-6))
    assert np.allclose(traj.q[[0, -1]], P[[0, -1]], atol=1e-12)


def test_robot_bounds_limits_and_beside_the_through_points_trajectory():
    arm = Robot.load("arduino_arm_3dof")
    Q = np.radians([[20, 40, 60], [60, 80, 100], [120, 70, 90], [160, 30, 50]])
    blended = blended_trajectory(arm, Q, dt=0.01)
    assert blended.law.name.value == "blended"
    v, a = np.radians(300), np.radians(1500)
    assert np.abs(blended.qd).max() <= v * (1 + 1e-9) and np.abs(blended.qdd).max() <= a * (1 + 1e-6)
    through = via_trajectory(arm, Q, durations=np.diff(blended.law.breaks).sum() / 3)
    assert through.q.shape[1] == blended.q.shape[1] == 3
    from labkit.plotting import plot_time_series

    ax = plot_time_series(through, "q")
    plot_time_series(blended, "q", ax, names=[f"{n} (blended)" for n in arm.joint_names])  # both on one figure
    assert len(ax.lines) == 6
    # the through-points trajectory hits every via point, the blended one only the ends
    assert np.allclose(through.law.position(through.law.breaks), Q, atol=1e-12)
    tau = blended.law.breaks[1]  # the first blend runs from 0 to tau
    via_t = tau / 2 + np.r_[0.0, np.cumsum(np.diff(blended.law.breaks)[1::2] + tau)][:4]
    miss = np.abs(np.asarray(blended.law.position(via_t)) - Q).max(axis=1)
    assert miss[1:-1].min() > 1e-4  # interior via points are passed near, not through
    assert np.abs(np.asarray(blended.law.position([0.0, blended.law.tf])) - Q[[0, -1]]).max() < 1e-12
    with pytest.raises(TrajectoryError, match="overlap"):
        blended_law(None, Q, durations=[1.0, 0.1, 1.0], blend_time=0.5)
    with pytest.raises(TrajectoryError, match=r"blend at via point 1 coordinate \d needs .* > a_max"):
        blended_law(arm, Q, durations=1.0, blend_time=0.01)
    with pytest.raises(TrajectoryError, match="expected durations, or a finite v_max"):
        blended_law(None, Q)
    with pytest.raises(ShapeError, match="m >= 2"):
        blended_law(None, [[0.0, 1.0]], durations=1.0, blend_time=0.1)


def test_cartesian_blend_is_straight_between_blends_and_solved_by_ik():
    arm = Robot.load("arduino_arm_3dof")
    V = np.array([[0.15, 0.02, -0.10], [0.20, 0.10, -0.05], [0.10, 0.18, -0.10]])
    traj = cartesian_blended_trajectory(arm, V, durations=[1.0, 1.2], blend_time=0.3, branch="elbow_up", dt=0.01)
    assert traj.axis_names == ("x", "y", "z")
    assert np.abs(arm.fk(traj.q)[:, :3, 3] - traj.x).max() < 1e-9  # IK on every sample
    J = arm.jacobian(traj.q)[:, :3]
    assert np.abs(np.einsum("nij,nj->ni", J, traj.qd) - traj.xd).max() < 1e-9
    mid = (traj.t > 0.3) & (traj.t < 1.0)  # first straight piece: collinear with V0 -> V1
    u = (V[1] - V[0]) / np.linalg.norm(V[1] - V[0])
    r = traj.x[mid] - V[0]
    assert np.abs(r - np.outer(r @ u, u)).max() < 1e-12
    with pytest.raises(ShapeError, match="not poses"):
        cartesian_blended_trajectory(Robot.load("puma560"), V, durations=1.0, blend_time=0.2)
