"""Cartesian paths: seed 000 line, seed 004 arc, circles, waypoints, poses, errors."""

import numpy as np
import pytest

from labkit.motion import (
    arc_path,
    cartesian_trajectory,
    cartesian_via_trajectory,
    circle_path,
    line_path,
    path_law,
    waypoint_path,
)
from labkit.robot import Robot
from labkit.exceptions import JointLimitError, ShapeError, TrajectoryError, UnreachableError
from labkit.kinematics import fk, fk_position, jacobian
from labkit.motion import cubic_law

U0 = [0.0, 0.18, -0.094]
UF = [0.1, 0.15, -0.2]


@pytest.fixture(scope="module")
def arduino():
    return Robot.load("arduino_arm_3dof")


@pytest.fixture(scope="module")
def planar004():
    return Robot.load("planar3r_seed004")


@pytest.fixture(scope="module")
def seed000(arduino):
    return cartesian_trajectory(arduino, line_path(U0, UF), 5.0, dt=0.1, branch="elbow_up", check_speed_limits=True)


def test_seed000_line_matches_the_per_axis_cubic(seed000):
    """x(t) = p0 + s(t) (p1 - p0) with a cubic s equals the seed's per-axis cubics."""
    law = cubic_law(U0, UF, 5.0)
    assert seed000.t.size == 51
    np.testing.assert_allclose(seed000.x, law.position(seed000.t), atol=1e-15)
    np.testing.assert_allclose(seed000.xd, law.velocity(seed000.t), atol=1e-15)
    np.testing.assert_allclose(seed000.xdd, law.acceleration(seed000.t), atol=1e-15)
    speed = np.linalg.norm(seed000.xd, axis=1)
    assert speed.max() == pytest.approx(1.5 * np.linalg.norm(np.subtract(UF, U0)) / 5.0)
    assert speed.max() == pytest.approx(0.0446, abs=1e-4)  # the seed's 0.045 at two significant figures
    assert seed000.t[np.argmax(speed)] == pytest.approx(2.5)


def test_seed000_line_ik_reachable_on_line_within_limits(arduino, seed000):
    assert arduino.within_limits(seed000.q).all()
    assert np.all(seed000.q[:, 2] >= 0)  # one branch throughout
    p = fk_position(arduino, seed000.q)
    assert line_path(U0, UF).distance_from(p).max() < 1e-9
    np.testing.assert_allclose(p, seed000.x, atol=1e-9)
    np.testing.assert_allclose(np.degrees(seed000.q[0]), [90, 90, 90], atol=1e-9)  # the seed's home pose
    # rest to rest in joint space too
    np.testing.assert_allclose(seed000.qd[[0, -1]], 0.0, atol=1e-12)


def test_joint_rates_match_finite_differences(arduino):
    traj = cartesian_trajectory(arduino, line_path(U0, UF), 5.0, dt=0.001, branch="elbow_up")
    qd_fd = np.gradient(traj.q, traj.t, axis=0, edge_order=2)
    qdd_fd = np.gradient(traj.qd, traj.t, axis=0, edge_order=2)
    assert np.abs(qd_fd - traj.qd).max() < 1e-5
    assert np.abs(qdd_fd - traj.qdd).max() < 1e-4


def test_seed004_arc_elbow_minus(planar004):
    """Part D: 90 deg arc, centre (0.1, 0.25), R = 0.25, 0-2 s; start at -90 deg (the point (0.1, 0)),
    sweep +90 deg to (0.35, 0.25), the tool pointing radially outwards (phi from -90 to 0 deg)."""
    path = arc_path([0.1, 0.25], 0.25, -np.pi / 2, np.pi / 2)
    traj = cartesian_trajectory(planar004, path, 2.0, dt=0.02, orientation=[-np.pi / 2, 0.0],
                                branch="elbow_minus")
    T = fk(planar004, traj.q)
    assert path.distance_from(T[:, :3, 3]).max() < 1e-9
    assert path.distance_from(np.column_stack([traj.x[:, :2], np.zeros(len(traj))])).max() < 1e-12
    np.testing.assert_allclose(T[[0, -1], :2, 3], [[0.1, 0.0], [0.35, 0.25]], atol=1e-12)
    phi = np.arctan2(T[:, 1, 0], T[:, 0, 0])
    np.testing.assert_allclose(phi, traj.x[:, 2], atol=1e-12)
    assert np.all(traj.q[:, 1] < 0)  # elbow minus: theta2 < 0 along the whole arc
    radius = np.linalg.norm(T[:, :2, 3] - [0.1, 0.25], axis=1)
    np.testing.assert_allclose(radius, 0.25, atol=1e-9)
    assert traj.axis_names == ("x", "y", "phi")
    assert np.abs(np.diff(traj.q, axis=0)).max() < 0.1  # continuous


def test_unreachable_arc_names_first_sample(planar004):
    """Holding phi = 90 deg the end of the same arc is out of reach: the error says where and by how much."""
    path = arc_path([0.1, 0.25], 0.25, -np.pi / 2, np.pi / 2)
    with pytest.raises(UnreachableError, match=r"arc sample (\d+) at t = [\d.]+ s, point .* mm outside") as info:
        cartesian_trajectory(planar004, path, 2.0, dt=0.05, orientation=np.pi / 2, branch="elbow_minus")
    err = info.value
    assert err.distance > 0
    i = err.index
    t = np.arange(41) * 0.05
    s = path_law(path, 2.0).position(t)
    p = path.point(s)
    wrist = p[:, :2] - 0.12 * np.array([0.0, 1.0])
    reach = np.linalg.norm(wrist, axis=1)
    first_bad = int(np.argmax(reach > 0.35 + 1e-12))
    assert i == first_bad
    assert err.distance == pytest.approx(reach[i] - 0.35, abs=1e-9)


def test_joint_limit_violation_along_path(arduino):
    # y < 0 needs base yaw < 0, outside the 0..180 deg servo range on the elbow_up branch
    with pytest.raises(JointLimitError, match=r"line sample \d+ at t = .* joint 1") as info:
        cartesian_trajectory(arduino, line_path([0.1, 0.1, -0.1], [0.1, -0.1, -0.1]), 2.0, dt=0.1, branch="elbow_up")
    assert info.value.joint == 0 and info.value.index > 0


def test_over_speed_suggests_minimum_duration(arduino):
    path = line_path([0.2, 0.1, -0.1], [-0.2, 0.1, -0.1])
    with pytest.raises(TrajectoryError, match="minimum duration") as info:
        cartesian_trajectory(arduino, path, 0.3, dt=0.01, branch="elbow_up", check_speed_limits=True)
    T = info.value.minimum_duration
    assert T > 0.3
    ok = cartesian_trajectory(arduino, path, T * 1.001, dt=0.01, branch="elbow_up", check_speed_limits=True)
    assert ok.duration == pytest.approx(T * 1.001)


def test_branch_from_q_start(arduino):
    from labkit.kinematics import ik_all

    wide = arduino
    for j in range(3):  # +-180 deg joints, so that both elbows are valid
        wide = wide.with_link(j, limits=(-np.pi, np.pi))
    target = np.array([0.12, 0.12, -0.05])
    sols = ik_all(wide, target)
    for name in ("elbow_down", "elbow_up"):
        q_start = sols[name] + 0.01
        traj = cartesian_trajectory(wide, line_path(target, [0.12, 0.15, -0.08]), 1.0, dt=0.1, q_start=q_start)
        np.testing.assert_allclose(traj.q[0], sols[name], atol=1e-9)
        assert np.all(np.sign(traj.q[:, 2]) == np.sign(sols[name][2]))  # kept along the path


def test_circle_pose_robot_holds_orientation():
    puma = Robot.load("puma560")
    q0 = np.array([0.1, -0.6, 0.3, 0.2, 0.5, 0.1])
    T0 = fk(puma, q0)
    path = circle_path(T0[:3, 3] - [0.05, 0.0, 0.0], 0.05, normal=[0, 0, 1])
    traj = cartesian_trajectory(puma, path, 4.0, dt=0.05, q_start=q0)
    T = fk(puma, traj.q)
    assert path.distance_from(T[:, :3, 3]).max() < 1e-9
    assert np.abs(T[:, :3, :3] - T0[:3, :3]).max() < 1e-9
    np.testing.assert_allclose(traj.q[0], q0, atol=1e-9)
    np.testing.assert_allclose(T[-1, :3, 3], T[0, :3, 3], atol=1e-12)  # closed
    assert traj.x.shape == (81, 6)
    assert path.length == pytest.approx(2 * np.pi * 0.05)


def test_slerp_orientation_and_angular_velocity():
    puma = Robot.load("puma560")
    q0 = np.array([0.1, -0.6, 0.3, 0.2, 0.5, 0.1])
    T0 = fk(puma, q0)
    R1 = T0[:3, :3] @ np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])  # +90 deg about the tool x
    traj = cartesian_trajectory(puma, line_path(T0[:3, 3], T0[:3, 3] + [0, 0.05, 0]), 2.0, dt=0.01,
                                orientation=[T0[:3, :3], R1], q_start=q0)
    T = fk(puma, traj.q)
    np.testing.assert_allclose(T[-1, :3, :3], R1, atol=1e-9)
    w = traj.xd[:, 3:]
    axis = T0[:3, 0]  # world-frame rotation axis
    np.testing.assert_allclose(np.cross(w, axis), 0.0, atol=1e-12)
    rate = w @ axis
    angle = np.sum(0.5 * (rate[1:] + rate[:-1]) * np.diff(traj.t))  # trapezoid rule (numpy 1.26 too)
    assert angle == pytest.approx(np.pi / 2, rel=1e-3)
    J = puma.jacobian(traj.q)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", J, traj.qd), traj.xd, atol=1e-9)


def test_waypoints_stop_at_each(arduino):
    P = np.array([[0.0, 0.18, -0.094], [0.1, 0.15, -0.094], [0.1, 0.15, -0.2]])  # over the object, then down
    path = waypoint_path(P)
    traj = cartesian_trajectory(arduino, path, [2.0, 3.0], dt=0.1, branch="elbow_up")
    assert traj.t[-1] == pytest.approx(5.0)
    i = int(np.argmin(np.abs(traj.t - 2.0)))
    np.testing.assert_allclose(traj.x[i], P[1], atol=1e-12)
    np.testing.assert_allclose(traj.xd[i], 0.0, atol=1e-12)
    assert path.distance_from(fk_position(arduino, traj.q)).max() < 1e-9
    split = path_law(path, 5.0)  # one total: split by segment length
    lengths = np.linalg.norm(np.diff(P, axis=0), axis=1)
    np.testing.assert_allclose(np.diff(split.breaks)[[0, -1]], 5.0 * lengths / lengths.sum())


def test_resample_is_exact(seed000, arduino):
    r = seed000.resample(0.05)
    assert r.t.size == 101
    assert line_path(U0, UF).distance_from(fk_position(arduino, r.q)).max() < 1e-9
    df = r.to_dataframe(degrees=True, millimetres=True)
    assert df["x"].iloc[-1] == pytest.approx(100.0)
    assert df["base_yaw"].iloc[0] == pytest.approx(90.0)


def test_path_errors():
    with pytest.raises(ShapeError, match="expected radius as a positive"):
        arc_path([0, 0], -1.0, 0.0, 1.0)
    with pytest.raises(ShapeError, match="not both"):
        arc_path([0, 0, 0], 1.0, 0.0, 1.0, normal=[0, 0, 1], plane_axes=[[1, 0, 0], [0, 1, 0]])
    with pytest.raises(ShapeError, match="non-zero sweep"):
        arc_path([0, 0, 0], 1.0, 0.0, 0.0)
    with pytest.raises(ShapeError, match=r"shape \(..., 3\)"):
        line_path([0, 0, 0, 0], [1, 1, 1])
    a = arc_path([0, 0, 1.0], 0.2, 0.0, np.pi, plane_axes=[[0, 1, 0], [0, 0, 1]])
    np.testing.assert_allclose(a.normal, [1, 0, 0])
    np.testing.assert_allclose(a.point([0.5]), [[0, 0, 1.2]], atol=1e-15)
    c = circle_path([0, 0, 0], 1.0, normal=[0, 0, -1])
    assert c.shape == "circle" and c.distance_from(c.point(np.linspace(0, 1, 9))).max() < 1e-15


def test_planar_needs_orientation(planar004):
    with pytest.raises(TrajectoryError, match="orientation"):
        cartesian_trajectory(planar004, line_path([0.3, 0.0], [0.3, 0.1]), 1.0)
    traj = cartesian_trajectory(planar004, line_path([0.3, 0.0], [0.3, 0.1]), 1.0, dt=0.1,
                                q_start=[0.2, 0.5, -0.7])
    np.testing.assert_allclose(traj.x[:, 2], 0.0, atol=1e-12)  # phi of q_start held


def test_numeric_ik_robot_follows_path_continuously():
    """Seed 002 problem 4: the PUMA wrist's tool point draws a circle about z0 (numeric IK, chained)."""
    wrist = Robot.load("puma_wrist_seed002")
    q0 = np.array([-0.5008, -0.6606, 0.3153])  # the seed's initial joint angles
    p0 = fk_position(wrist, q0)
    radius = np.hypot(p0[0], p0[1])
    assert radius == pytest.approx(np.hypot(150, 100) * np.sin(np.pi / 4 - np.arctan(100 / 150)) / 1e3, abs=1e-4)
    path = circle_path([0, 0, p0[2]], radius, start_angle=np.arctan2(p0[1], p0[0]))
    traj = cartesian_trajectory(wrist, path, 2 * np.pi, law="linear", dt=0.1, q_start=q0)
    assert path.distance_from(fk_position(wrist, traj.q)).max() < 1e-9
    np.testing.assert_allclose(traj.q[0], q0, atol=1e-6)
    assert np.abs(np.diff(traj.q, axis=0)).max() < 0.1  # no jumps between neighbouring samples
    assert np.all(np.isfinite(traj.qd)) and np.all(np.isfinite(traj.qdd))
    # the tool-point Jacobian has rank 2 everywhere: damping only the lost direction still meets xd
    J = jacobian(wrist, traj.q)[:, :3, :]
    assert np.linalg.svd(J, compute_uv=False)[:, -1].max() < 1e-12
    miss = np.linalg.norm(np.einsum("nij,nj->ni", J, traj.qd) - traj.xd, axis=1)
    assert miss.max() < 1e-9 * np.linalg.norm(traj.xd, axis=1).max()


def test_cartesian_via_points_seed003_task5():
    """Five Cartesian via points of the 145/145/45 arm, joint-space spline through their IK."""
    arm = Robot.load("planar3r_seed003")
    P = np.array([[0.30, 0.00, 0.0], [0.28, 0.08, 0.3], [0.24, 0.15, 0.5], [0.18, 0.20, 0.8], [0.10, 0.24, 1.0]])
    traj = cartesian_via_trajectory(arm, P, durations=1.0, branch="elbow_down", dt=0.05)
    assert traj.axis_names == ("x", "y", "phi") and traj.law.n_segments == 4
    at_via = np.searchsorted(traj.t, traj.law.breaks)
    np.testing.assert_allclose(traj.x[at_via], P, atol=1e-12)
    np.testing.assert_allclose(traj.xd[[0, -1]], 0.0, atol=1e-12)
    J = arm.jacobian(traj.q)[:, [0, 1, 5]]
    np.testing.assert_allclose(np.einsum("nij,nj->ni", J, traj.qd), traj.xd, atol=1e-12)
    r = traj.resample(0.25)
    assert r.x is not None and r.t.size == 17
    np.testing.assert_allclose(r.x[::4], P, atol=1e-12)
    bad = P.copy()
    bad[2] = [0.40, 0.10, 0.0]
    with pytest.raises(UnreachableError, match=r"waypoints sample 2 at t = 2 s"):
        cartesian_via_trajectory(arm, bad, durations=1.0, branch="elbow_down")


def test_batched_3x3_solver_matches_numpy_and_damps_at_singular_samples():
    from labkit.kinematics import joint_rates
    from labkit.motion._rates import solver3

    rng = np.random.default_rng(11)
    J = rng.normal(size=(500, 3, 3))
    J[7, :, 2] = J[7, :, 0] + J[7, :, 1]  # singular: dependent columns
    J[9] = 0.0  # singular: all zero
    b = rng.normal(size=(500, 3))
    x = solver3(J)(b)
    ok = np.linalg.svd(J, compute_uv=False)[:, -1] >= 1e-2  # outside joint_rates' singular region: exact
    assert not ok[[7, 9]].any() and ok.sum() > 450
    np.testing.assert_allclose(x[ok], np.linalg.solve(J[ok], b[ok][..., None])[..., 0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(x[~ok], joint_rates(J[~ok], b[~ok]), atol=1e-12)  # damped least squares
    np.testing.assert_allclose(x[9], 0.0)
    assert np.all(np.isfinite(x))
