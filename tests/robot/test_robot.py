"""Tests of the robot model (labkit.robot): limits, replace, DH table, robots built in code, servo calibration."""

import math

import numpy as np
import pytest

from labkit.exceptions import JointLimitError
from labkit.robot import Convention, Link, Robot, ServoCalibration


def test_limits_helpers():
    arm = Robot.load("arduino_arm_3dof")
    q = np.radians([[10, 20, 30], [10, 200, 30]])
    assert arm.within_limits(q).tolist() == [True, False]
    message = r"joint 2 \(shoulder_pitch\) = 200 deg outside its limits \[0, 180\] deg"
    with pytest.raises(JointLimitError, match=message) as info:
        arm.check_limits(q)
    assert info.value.joint == 1 and info.value.index == (1,)
    arm.check_limits(q[0])


def test_with_link_replace_and_dh_table():
    arm = Robot.load("arduino_arm_3dof")
    longer = arm.with_link(2, a=0.1)
    assert longer.links[2].a == 0.1 and arm.links[2].a == pytest.approx(0.094)
    with pytest.raises(AttributeError):
        arm.name = "x"
    assert arm.tool.flags.writeable is False
    table = arm.dh_table()
    assert list(table.columns[:6]) == ["joint", "type", "a_{i-1}", "alpha_{i-1}", "d_i", "theta_i"]
    assert table.loc[3, "a_{i-1}"] == pytest.approx(94.0) and table.loc[2, "alpha_{i-1}"] == pytest.approx(-90.0)
    assert "a_i" in Robot.load("puma560").dh_table().columns
    assert repr(arm) == "Robot(name='arduino_arm_3dof', n=3, convention='modified')"


def test_robot_in_code_and_bad_frame_shape():
    r = Robot("two", (Link(a=1.0), Link(a=1.0)))
    assert r.n == 2 and r.convention is Convention.STANDARD and r.joint_names == ("q1", "q2")
    with pytest.raises(ValueError, match=r"tool with shape \(4, 4\), got \(3, 3\)"):
        Robot("bad", (Link(),), tool=np.eye(3))


def test_servo_calibration_round_trips():
    s = ServoCalibration(channel=2, zero=math.pi / 2, direction=-1)
    q = np.radians([-80, 0, 45, 90])
    us = s.pulse_us(q)
    assert np.allclose(us, 500 + (90 - np.degrees(q)) / 180 * 2000)
    assert np.allclose(s.joint_from_pulse(us), q)
    assert np.allclose(s.joint_from_adc(s.adc_from_joint(q)), q)
    assert s.adc_from_joint(math.pi / 2) == pytest.approx(102.3)  # servo angle 0
    with pytest.raises(JointLimitError, match="servo channel 2"):
        s.pulse_us(np.radians(100))
