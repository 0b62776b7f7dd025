"""The servo torque budget: stall torques from the robot file against the dynamics' torques."""

import numpy as np
import pytest

from labkit import dynamics as D
from labkit.exceptions import RobotError, RobotFileError
from labkit.robot import Robot


def test_budget_over_a_pose_map_with_a_payload():
    arm = Robot.load("arduino_arm_3dof")
    grid = np.stack(np.meshgrid(np.linspace(0, np.pi, 5), np.linspace(0, np.pi, 7), indexing="ij"), -1)
    q = np.concatenate([np.full(grid.shape[:-1] + (1,), 0.5), grid], -1)  # (5, 7, 3): shoulder x elbow map
    empty = D.torque_budget(arm, q)
    loaded = D.torque_budget(arm, q, payload=0.4)
    assert empty.margin.shape == (5, 7) and empty.load.shape == (5, 7, 3)
    assert np.all(loaded.margin <= empty.margin)
    assert np.allclose(loaded.torque, D.gravity_torques(arm.with_payload(0.4), q))
    assert np.allclose(loaded.load, np.abs(loaded.torque) / 0.92)
    assert loaded.ok.any() and not loaded.ok.all()  # 400 g is too much stretched out, fine folded up
    assert np.all(loaded.worst_joint[~loaded.ok] == 1)  # the shoulder gives up first
    moving = D.torque_budget(arm, q[0, 0], qd=[0.0, 1.0, 0.0], qdd=[0.0, 20.0, 0.0])
    assert moving.torque[1] != pytest.approx(empty.torque[0, 0, 1])


def test_stall_torque_is_read_written_and_required(tmp_path):
    omx = Robot.load("openmanipulator_x")
    assert D.stall_torques(omx).tolist() == [4.1] * 4
    again = tmp_path / "omx.toml"
    again.write_text(omx.to_toml())
    assert D.stall_torques(Robot.load(again)).tolist() == [4.1] * 4
    with pytest.raises(RobotError, match="stall_torque"):
        D.stall_torques(Robot.load("puma560"))
    bad = tmp_path / "bad.toml"
    bad.write_text(Robot.load("arduino_arm_3dof").to_toml().replace("stall_torque = 0.92", "stall_torque = -1", 1))
    with pytest.raises(RobotFileError, match="torque > 0") as info:
        Robot.load(bad)
    assert info.value.field == "joint[1].servo.stall_torque"


def test_torque_constant_is_read_written_and_checked(tmp_path):
    omx = Robot.load("openmanipulator_x")
    again = tmp_path / "omx.toml"
    again.write_text(omx.to_toml())
    assert [lk.bus.torque_constant for lk in Robot.load(again).links] == [1.78] * 4
    assert np.allclose(D.torques_from_current(Robot.load(again), [[1.0, 1.0, -1.0, 0.0]]), [[1.78, 1.78, -1.78, 0.0]])
    bad = tmp_path / "bad.toml"
    bad.write_text(omx.to_toml().replace("torque_constant = 1.78", "torque_constant = 0", 1))
    with pytest.raises(RobotFileError, match="torque constant > 0") as info:
        Robot.load(bad)
    assert info.value.field == "joint[1].bus.torque_constant"


def test_a_motion_plan_that_overdraws_a_servo_is_warned_about():
    import warnings

    from labkit.exceptions import ShapeError, TorqueWarning
    from labkit.motion import joint_trajectory

    arm = Robot.load("arduino_arm_3dof")
    plan = joint_trajectory(arm, [1.5, 1.0, 1.0], [1.5, 0.2, 0.6], 1.0, law="quintic")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # within budget: no warning
        fine = D.check_torque_budget(arm, plan)
    assert fine.margin.shape == (len(plan.t),) and fine.ok.all()
    np.testing.assert_allclose(fine.torque, D.inverse_dynamics(arm, plan.q, plan.qd, plan.qdd))
    with pytest.warns(TorqueWarning, match=r"shoulder_pitch for 1\.\d+ N m .* stall torque of 0\.92 N m") as record:
        heavy = D.check_torque_budget(arm, plan, payload=0.5)
    assert len(record) == 1 and not heavy.ok.any()
    with pytest.raises(RobotError, match="stall_torque"):
        D.check_torque_budget(Robot.load("puma560"), joint_trajectory(Robot.load("puma560"), np.zeros(6), np.full(6, 0.1), 1.0))
    with pytest.raises(ShapeError, match="trajectory"):
        D.check_torque_budget(arm, plan.q)
