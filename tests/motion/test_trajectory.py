"""Joint-space trajectories: the Trajectory result, moves, via points, limit and speed checks."""

import dataclasses

import numpy as np
import pytest

from labkit.robot import Robot
from labkit.exceptions import JointLimitError, ShapeError, TrajectoryError
from labkit.kinematics import ik
from labkit.motion import LawName
from labkit.motion import (
    Trajectory,
    check_joint_limits,
    check_speed,
    heuristic_velocities,
    joint_trajectory,
    speed_scale,
    via_law,
    via_trajectory,
)


@pytest.fixture(scope="module")
def planar003():
    return Robot.load("planar3r_seed003")


@pytest.fixture(scope="module")
def via_points(planar003):
    """Five via points of the 145/145/45 planar arm (seed 003 task 5), from Cartesian (x, y, phi)."""
    P = np.array([[0.30, 0.00, 0.0], [0.28, 0.08, 0.3], [0.24, 0.15, 0.5], [0.18, 0.20, 0.8], [0.10, 0.24, 1.0]])
    return ik(planar003, P, branch="elbow_down")


def test_seed003_task2_cubic_moves():
    traj = joint_trajectory(None, [0.0, 0.0, 1.57], [-0.8, 0.8, 0.8], 5.0, dt=0.1)
    a = traj.law.coefficients[0]  # (4, 3)
    np.testing.assert_allclose(a[2], [-0.096, 0.096, -0.0924])
    np.testing.assert_allclose(a[3], [0.0128, -0.0128, 0.01232])
    assert traj.q.shape == (51, 3)
    np.testing.assert_allclose(traj.q[0], [0.0, 0.0, 1.57])
    np.testing.assert_allclose(traj.q[-1], [-0.8, 0.8, 0.8], atol=1e-12)
    np.testing.assert_allclose(traj.qd[[0, -1]], 0.0, atol=1e-12)
    np.testing.assert_allclose(traj.qd[25], 1.5 * np.array([-0.8, 0.8, -0.77]) / 5.0)


def test_trajectory_is_frozen_and_validated():
    traj = joint_trajectory(None, [0.0], [1.0], 1.0, dt=0.5)
    with pytest.raises(dataclasses.FrozenInstanceError):
        traj.t = np.zeros(3)
    with pytest.raises(ValueError):
        traj.q[0, 0] = 5.0  # read-only array
    with pytest.raises(ShapeError, match=r"expected q with shape \(3, n\)"):
        Trajectory(np.arange(3.0), np.zeros((4, 2)), np.zeros((4, 2)), np.zeros((4, 2)))
    with pytest.raises(ShapeError, match="increasing"):
        Trajectory(np.array([0.0, 0.0]), np.zeros((2, 1)), np.zeros((2, 1)), np.zeros((2, 1)))
    with pytest.raises(ShapeError, match="both x and xd"):
        Trajectory(np.arange(2.0), np.zeros((2, 1)), np.zeros((2, 1)), np.zeros((2, 1)), x=np.zeros((2, 3)))


def test_to_dataframe_and_degrees(planar003):
    traj = joint_trajectory(planar003, np.radians([0, 10, 20]), np.radians([30, 40, 50]), 2.0, dt=0.5)
    df = traj.to_dataframe()
    assert df.index.name == "t" and list(df.index) == [0.0, 0.5, 1.0, 1.5, 2.0]
    assert list(df.columns[:3]) == ["q1", "q1_dot", "q1_ddot"]
    assert df["q3"].iloc[-1] == pytest.approx(np.radians(50))
    deg = traj.to_dataframe(degrees=True)
    assert deg["q3"].iloc[-1] == pytest.approx(50.0)
    assert deg.attrs["units"]["q2_dot"] == "deg/s"
    assert df.attrs["units"]["q2_ddot"] == "rad/s^2"


def test_resample_exact_and_hermite():
    traj = joint_trajectory(None, [0.0, 1.0], [1.0, -1.0], 5.0, dt=0.01)
    r = traj.resample(0.1)  # seed 000 sampling
    assert r.t.size == 51 and np.allclose(np.diff(r.t), 0.1)
    np.testing.assert_allclose(r.q, traj.law.position(r.t), atol=1e-15)
    # without its law: Hermite interpolation, accurate between samples
    bare = Trajectory(traj.t, traj.q, traj.qd, traj.qdd)
    h = bare.resample(0.037)
    np.testing.assert_allclose(h.q, traj.law.position(h.t), atol=1e-9)
    np.testing.assert_allclose(h.qd, traj.law.velocity(h.t), atol=1e-9)


@pytest.mark.parametrize("name", ["via_cubic", "spline"])
def test_five_via_points_continuity(planar003, via_points, name):
    traj = via_trajectory(planar003, via_points, durations=[1.0, 1.5, 1.0, 2.0], law=name, dt=0.01)
    law = traj.law
    assert law.n_segments == 4 and law.degree == 3
    assert law.name is LawName(name)
    times = law.breaks
    np.testing.assert_allclose(times, [0.0, 1.0, 2.5, 3.5, 5.5])
    np.testing.assert_allclose(law.position(times), via_points, atol=1e-12)  # passes through every via point
    np.testing.assert_allclose(law.velocity(times[[0, -1]]), 0.0, atol=1e-12)  # rest at both ends
    pp = law.ppoly
    for seg in range(1, law.n_segments):  # end of segment seg - 1 against start of segment seg
        c, tau = pp.c[:, seg - 1], times[seg] - times[seg - 1]
        left = [c[3] + c[2] * tau + c[1] * tau**2 + c[0] * tau**3,
                c[2] + 2 * c[1] * tau + 3 * c[0] * tau**2,
                2 * c[1] + 6 * c[0] * tau]
        right = [pp.c[3, seg], pp.c[2, seg], 2 * pp.c[1, seg]]
        np.testing.assert_allclose(left[0], right[0], atol=1e-9)
        np.testing.assert_allclose(left[1], right[1], atol=1e-9)  # velocity continuous
        if name == "spline":
            np.testing.assert_allclose(left[2], right[2], atol=1e-9)  # acceleration continuous
    if name == "via_cubic":  # cubic segments: acceleration jumps somewhere
        jumps = []
        for seg in range(1, 4):
            c, tau = pp.c[:, seg - 1], times[seg] - times[seg - 1]
            jumps.append(np.abs(2 * c[1] + 6 * c[0] * tau - 2 * pp.c[1, seg]).max())
        assert max(jumps) > 1e-3


def test_natural_spline_ends(via_points):
    law = via_law(None, via_points, durations=1.0, law="spline", ends="natural")
    np.testing.assert_allclose(law.acceleration(law.breaks[[0, -1]] + [1e-12, -1e-12]), 0.0, atol=1e-6)
    with pytest.raises(ValueError, match="'clamped', 'natural'"):
        via_law(None, via_points, durations=1.0, law="spline", ends="periodic")
    with pytest.raises(ValueError, match="'via_cubic', 'spline'"):
        via_law(None, via_points, durations=1.0, law="cubic")


def test_heuristic_and_given_via_velocities():
    P = np.array([[0.0], [1.0], [3.0], [2.0]])
    V = heuristic_velocities(P, [0.0, 1.0, 2.0, 3.0])
    np.testing.assert_allclose(V[:, 0], [0.0, 1.5, 0.0, 0.0])  # mean slope, zero where it turns back
    given = np.array([[0.0], [0.5], [-0.5], [0.0]])
    law = via_law(None, P, [0.0, 1.0, 2.0, 3.0], velocities=given)
    np.testing.assert_allclose(law.velocity([1.0, 2.0]), given[1:3], atol=1e-12)
    with pytest.raises(ShapeError, match="velocities"):
        via_law(None, P, [0.0, 1.0, 2.0, 3.0], velocities=np.zeros((3, 1)))
    with pytest.raises(TrajectoryError, match="increasing"):
        via_law(None, P, [0.0, 1.0, 1.0, 3.0])


def test_durations_from_limits(planar003, via_points):
    """max_velocity 90 deg/s per joint: each segment gets the shortest cubic duration."""
    traj = via_trajectory(planar003, via_points, law="via_cubic", check_speed_limits=False)
    assert traj.law.n_segments == 4
    d = np.diff(traj.law.breaks)
    dq = np.abs(np.diff(via_points, axis=0)).max(axis=1)
    np.testing.assert_allclose(d, 1.5 * dq / np.radians(90), rtol=1e-9)
    move = joint_trajectory(planar003, np.radians([0, 0, 0]), np.radians([45, -30, 10]), dt=0.01)
    assert move.duration == pytest.approx(0.75)  # 1.5 x 45 deg / (90 deg/s)
    check_speed(planar003, move)  # exactly at the bound: no error
    k, joint, what = speed_scale(planar003, move)
    assert (round(k, 9), joint, what) == (1.0, 0, "velocity")


def test_over_speed_error_suggests_duration(planar003):
    with pytest.raises(TrajectoryError, match=r"joint 1 \(q1\) velocity .* minimum duration 1.5 s") as info:
        joint_trajectory(planar003, np.radians([0, 0, 0]), np.radians([90, 0, 0]), 1.0,
                         check_speed_limits=True)
    assert info.value.minimum_duration == pytest.approx(1.5)
    assert info.value.joint == 0
    ok = joint_trajectory(planar003, np.radians([0, 0, 0]), np.radians([90, 0, 0]), info.value.minimum_duration, check_speed_limits=True)
    assert ok.duration == pytest.approx(1.5)


def test_acceleration_bound():
    arm = Robot.load("arduino_arm_3dof")  # 300 deg/s, 1500 deg/s^2
    traj = joint_trajectory(None, np.radians([90, 90, 90]), np.radians([100, 90, 90]), 0.1)
    k, j, what = speed_scale(arm, traj)
    assert what == "acceleration" and j == 0
    assert k == pytest.approx(np.sqrt(6 * 10 / 0.01 / 1500))
    with pytest.raises(TrajectoryError, match="acceleration"):
        check_speed(arm, traj)


def test_joint_limit_error_names_time_and_joint(planar003):
    with pytest.raises(JointLimitError, match=r"at t = .* s \(sample \d+\).*joint 2 \(q2\)") as info:
        joint_trajectory(planar003, np.radians([0, 0, 0]), np.radians([0, 120, 0]), 2.0, dt=0.1)
    assert info.value.joint == 1
    i = info.value.index
    traj = joint_trajectory(None, np.radians([0, 0, 0]), np.radians([0, 120, 0]), 2.0, dt=0.1)
    assert np.degrees(traj.q[i, 1]) > 90 >= np.degrees(traj.q[i - 1, 1])
    check_joint_limits(planar003, joint_trajectory(None, [0, 0, 0], [0.1, 0.1, 0.1], 1.0))


def test_other_laws_and_errors(planar003):
    q = joint_trajectory(None, [0.0, 0.0], [1.0, 2.0], 3.0, law="lspb", dt=0.1)
    assert q.law.name is LawName.LSPB
    assert joint_trajectory(None, [0.0], [1.0], 1.0, law="quintic").law.degree == 5
    with pytest.raises(TrajectoryError, match="give a duration"):
        joint_trajectory(None, [0.0], [1.0])
    with pytest.raises(ShapeError, match="3 joints"):
        joint_trajectory(planar003, [0.0, 0.0], [1.0, 1.0], 1.0)
    with pytest.raises(ShapeError, match=r"qf with shape \(..., 2\)"):
        joint_trajectory(None, [0.0, 0.0], [1.0, 1.0, 1.0], 1.0)


@pytest.mark.parametrize("duration", [1e-9, 0.0, -1.0, float("nan"), float("inf"), "2"])
def test_a_duration_shorter_than_one_step_is_refused(duration):
    """Issue 13: joint_trajectory(None, q0, qf, 1e-9) returned one sample at q0 (the move never happened)."""
    from labkit.exceptions import TrajectoryError
    from labkit.motion import joint_trajectory

    with pytest.raises(TrajectoryError, match="at least one step dt = 0.01 s"):
        joint_trajectory(None, [0.0, 0.0], [1.0, 1.0], duration)
    traj = joint_trajectory(None, [0.0, 0.0], [1.0, 1.0], 0.01)
    np.testing.assert_allclose(traj.q[-1], [1.0, 1.0])
