"""Tests of the robot model (labkit.robot): limits, replace, DH table, robots built in code, servo calibration."""

import math

import numpy as np
import pytest

from labkit.exceptions import JointLimitError, RobotError, RobotFileError, ShapeError
from labkit.robot import Convention, JointType, Link, Robot, ServoCalibration


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


# -- constructors check what the robot-file loader checks, with the same messages --------

_LOADER_CASES = [  # (robot-file edit of MINIMAL, constructor call, field)
    (('type = "prismatic"', 'type = "spherical"'), lambda: Link(joint_type="spherical"), "type"),
    (("limits = [-90, 90]", "limits = [90]"), lambda: Link(limits=[90]), "limits"),
    (("limits = [-90, 90]", "limits = [90, -90]"), lambda: Link(limits=[90, -90]), "limits"),
    (("d = 10", 'd = "ten"'), lambda: Link(d="ten"), "d"),
    (("a = 100", "a = 100\nmax_velocity = 0"), lambda: Link(max_velocity=0), "max_velocity"),
    (("a = 100", "a = 100\nmax_acceleration = -5"), lambda: Link(max_acceleration=-5), "max_acceleration"),
    (("a = 100", "a = 100\nflip = 1"), lambda: Link(flip=1), "flip"),
    (("channel = 0,", "channel = 9,"), lambda: ServoCalibration(channel=9), "channel"),
    (("channel = 0,", "channel = true,"), lambda: ServoCalibration(channel=True), "channel"),
    (("zero = 90,", "zero = 90, direction = 2,"), lambda: ServoCalibration(channel=0, direction=2), "direction"),
    (("d = 10", 'd = 10\nname = "q1"'),
     lambda: Robot("mini", (Link(name="q1"), Link(name="q1"))), "joint.name"),
    (("limits = [0, 50]", "limits = [0, 50]\nservo = { channel = 0 }"),
     lambda: Robot("mini", (Link(servo=ServoCalibration(0)), Link(servo=ServoCalibration(0)))), "servo.channel"),
    (('convention = "standard"', 'convention = "dh"'), lambda: Robot("mini", (Link(),), convention="dh"),
     "convention"),
    (('name = "mini"\n', ""), lambda: Robot(None, (Link(),)), "name"),
]


@pytest.mark.parametrize("edit, build, field", _LOADER_CASES)
def test_constructors_reject_what_the_loader_rejects_with_the_same_message(tmp_path, edit, build, field):
    from tests.robot.test_robot_files import MINIMAL

    old, new = edit
    assert old in MINIMAL
    path = tmp_path / "bad.toml"
    path.write_text(MINIMAL.replace(old, new, 1))
    with pytest.raises(RobotFileError) as from_file:
        Robot.load(path)
    with pytest.raises(RobotError) as from_code:
        build()
    assert not isinstance(from_code.value, RobotFileError)
    assert isinstance(from_code.value, ValueError)
    tail = str(from_file.value).split("': ", 1)[1]  # after "<path>: field '<field>'"
    assert str(from_code.value).endswith(tail), (str(from_code.value), tail)
    assert from_code.value.field == field


def test_link_and_robot_validation_messages():
    assert Link(joint_type="prismatic", limits=(0, 1)).joint_type is JointType.PRISMATIC
    with pytest.raises(RobotError, match=r"Link 'elbow': field 'theta': expected a finite number, got nan"):
        Link(theta=float("nan"), name="elbow")
    with pytest.raises(RobotError, match=r"field 'links': expected at least one Link, got \(\)"):
        Robot("empty", ())
    with pytest.raises(RobotError, match=r"field 'links\[2\]': expected a Link, got \(0.1, 0.0\)"):
        Robot("rows", (Link(), (0.1, 0.0)))
    scaled = np.diag([2.0, 2.0, 2.0, 1.0])
    with pytest.raises(RobotError, match=r"field 'tool': expected a rigid transform .* max \|R R\^T - I\| = 3"):
        Robot("scaled", (Link(),), tool=scaled)
    mirrored = np.diag([1.0, 1.0, -1.0, 1.0])
    with pytest.raises(RobotError, match=r"field 'base': expected a rigid transform .*det -1"):
        Robot("mirrored", (Link(),), base=mirrored)
    projective = np.eye(4)
    projective[3, 0] = 0.5
    with pytest.raises(RobotError, match=r"last row \[0.5, 0.0, 0.0, 1.0\]"):
        Robot("projective", (Link(),), tool=projective)
    with pytest.raises(RobotError, match=r"units.length': expected one of \['cm', 'm', 'mm'\], got 'inch'"):
        Robot("u", (Link(),), length_unit="inch")
    assert Robot("craig", (Link(),), convention="craig").convention is Convention.MODIFIED
    # replace() and with_link() go through the same checks
    arm = Robot.load("arduino_arm_3dof")
    with pytest.raises(RobotError, match=r"field 'limits': expected lower < upper"):
        arm.with_link(0, limits=(1.0, -1.0))


def test_non_rigid_ik_target_names_the_problem():
    from labkit.kinematics import ik

    puma = Robot.load("puma560")
    T = puma.fk(np.full(6, 0.3))
    T[:3, :3] *= 1.5
    with pytest.raises(ShapeError, match=r"the target is not \(max \|R R\^T - I\| = 1.2") as info:
        ik(puma, T)
    assert "None" not in str(info.value)
    with pytest.raises(ShapeError, match=r"target \(1,\) is not"):
        ik(puma, np.stack([puma.fk(np.zeros(6)), T]))


def test_flip_field_and_mask():
    arm = Robot("two", (Link(a=1.0, flip=True), Link(a=1.0)))
    assert arm.flip.tolist() == [True, False] and arm.links[0].flip is True
    # q1 enters negated: the arm turns clockwise for positive q1
    assert np.allclose(arm.fk([0.5, 0.0])[:2, 3], [2 * np.cos(0.5), -2 * np.sin(0.5)])
