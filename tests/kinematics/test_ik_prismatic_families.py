"""The closed-form families with a prismatic joint: SCARA (x y z yaw, two elbows), cylindrical (RPP) and
Cartesian (PPP), on the robot-file fixtures of ``tests/kinematics/robots``."""

from pathlib import Path

import numpy as np
import pytest

from labkit.exceptions import JointLimitError, OptionError, ShapeError, UnreachableError
from labkit.kinematics import (
    fk, fk_frames, ik, ik_all, ik_numeric, pose_from_position_pitch, solver_for, target_from_pose, target_kind,
)
from labkit.robot import Robot
from labkit.rotations import wrap_angle

ROBOTS = Path(__file__).resolve().parent / "robots"


def _load(name):
    return Robot.load(ROBOTS / f"{name}.toml")


def _targets(robot, rng, size):
    lim = robot.joint_limits
    q = rng.uniform(lim[:, 0], lim[:, 1], size=(size, robot.n))
    return q, target_from_pose(robot, fk(robot, q))


@pytest.mark.parametrize("name, quill_sign", [("scara_standard", -1.0), ("scara_modified", 1.0)])
def test_scara_target_is_x_y_z_and_yaw_about_the_vertical(name, quill_sign):
    """Both fixtures stand upright: yaw is the heading of the tool x axis from world x, and the quill moves
    the tool straight down (standard fixture, alpha2 = 180 deg) or up (modified)."""
    robot = _load(name)
    assert target_kind(robot) == "position_yaw" and solver_for(robot).value == "scara"
    q, target = _targets(robot, np.random.default_rng(1), 200)
    T = fk(robot, q)
    assert np.abs(target[:, 3] - np.arctan2(T[:, 1, 0], T[:, 0, 0])).max() < 1e-12
    moved = q.copy()
    moved[:, 2] += 0.01
    dz = fk(robot, moved)[:, :3, 3] - T[:, :3, 3]
    assert np.abs(dz - [0.0, 0.0, 0.01 * quill_sign]).max() < 1e-12
    sols = ik_all(robot, target)
    assert sols.reachable.all()
    reached = target_from_pose(robot, fk(robot, sols.q))
    d = reached - target[:, None]
    d[..., 3] = wrap_angle(d[..., 3])
    assert np.abs(d).max() < 1e-12


@pytest.mark.parametrize("name", ["scara_standard", "scara_modified"])
def test_scara_elbow_left_and_right_are_the_sides_of_the_elbow_seen_from_above(name):
    """Seen from above, the elbow axis lies left of the line shoulder axis -> wrist axis on ``elbow_left``
    and right of it on ``elbow_right`` (the makers' lefty/righty, accepted as aliases)."""
    robot = _load(name)
    rng = np.random.default_rng(2)
    _, target = _targets(robot, rng, 100)
    sols = ik_all(robot, target)
    axes = [0, 1, 3] if robot.convention.value == "standard" else [1, 2, 4]  # frames on axes 1, 2 and 4
    for b, side in ((0, 1.0), (1, -1.0)):
        shoulder, elbow, wrist = np.moveaxis(fk_frames(robot, sols.q[:, b])[:, axes][..., :2, 3], 1, 0)
        line, to_elbow = wrist - shoulder, elbow - shoulder
        cross = line[:, 0] * to_elbow[:, 1] - line[:, 1] * to_elbow[:, 0]
        assert np.all(side * cross > 0), sols.branches[b]
    i = int(np.flatnonzero(sols.valid.all(axis=1))[0])
    assert np.allclose(ik(robot, target[i], branch="righty"), sols.q[i, 1])
    assert np.allclose(ik(robot, target[i], branch="lefty"), sols.q[i, 0])
    with pytest.raises(OptionError, match="expected one of elbow_left, elbow_right"):
        ik(robot, target[i], branch="elbow_up")


def test_scara_poses_out_of_reach_limits_and_numeric_ik_on_the_same_target():
    robot = _load("scara_standard")
    q = np.radians([30.0, 60.0, 0.0, -20.0])
    q[2] = 0.05
    target = target_from_pose(robot, fk(robot, q))
    # the pose the target stands for, and poses as targets: both elbows where the orientation is the yaw's
    T = pose_from_position_pitch(robot, target)
    assert np.abs(T - fk(robot, q)).max() < 1e-12
    sols = ik_all(robot, T)
    assert sols.reachable.all() and np.abs(fk(robot, sols.q) - T).max() < 1e-12
    tilted = T.copy()
    tilted[:3, :3] = tilted[:3, :3] @ np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    with pytest.raises(UnreachableError, match="no configuration takes the orientation.*takes x y z yaw"):
        ik(robot, tilted)
    # beyond the arm's 450 mm reach, by 50 mm
    with pytest.raises(UnreachableError, match=r"out of reach by 0.05 m") as info:
        ik(robot, [0.5, 0.0, 0.2, 0.0])
    assert info.value.distance == pytest.approx(0.05, abs=1e-12)
    # a height the quill cannot take: the quill is named
    with pytest.raises(JointLimitError, match="quill") as info:
        ik(robot, [0.3, 0.1, 0.5, 0.0])
    assert info.value.joint == 2
    with pytest.raises(ShapeError, match="this arm takes x y z yaw; yaw missing"):
        ik(robot, [0.3, 0.1, 0.2])
    # numeric IK takes the same target and lands on one of the closed-form branches
    res = ik_numeric(robot, target)
    assert res.success
    assert np.abs(sols.q - res.q).max(axis=-1).min() < 1e-8
    assert np.allclose(ik(robot, target, solver="numeric"), res.q)


def test_cylindrical_front_back_and_the_offset_radial_slide():
    """The radial slide passes 40 mm beside the axis: nothing nearer the axis is reachable, by the gap."""
    robot = _load("cylindrical_rpp")
    assert solver_for(robot).value == "cylindrical" and target_kind(robot) == "position"
    sols = ik_all(robot, [0.2, 0.3, 0.25])
    assert sols.branches == ("front", "back") and sols.reachable.all()
    assert sols.valid.tolist() == [True, False]  # the back branch runs the slide through the axis
    assert np.abs(fk(robot, sols.q)[:, :3, 3] - [0.2, 0.3, 0.25]).max() < 1e-12
    assert sols.q[1, 2] < 0 < sols.q[0, 2]
    with pytest.raises(UnreachableError, match="out of reach by 0.03 m") as info:
        ik(robot, [0.01, 0.0, 0.2])
    assert info.value.distance == pytest.approx(0.03, abs=1e-12)


def test_cartesian_gantry_is_one_linear_solve_with_a_flipped_axis():
    robot = _load("gantry_ppp")
    assert solver_for(robot).value == "cartesian"
    q = np.array([0.3, 0.2, 0.1])
    p = fk(robot, q)[:3, 3]
    assert p[2] == pytest.approx(-0.1)  # the flipped quill: a positive value lowers the tool
    sols = ik_all(robot, p)
    assert sols.branches == ("unique",) and np.allclose(sols.q[0], q, atol=1e-15)
    with pytest.raises(JointLimitError, match="joint 1 \\(x\\)"):
        ik(robot, [-0.1, 0.3, -0.1])
