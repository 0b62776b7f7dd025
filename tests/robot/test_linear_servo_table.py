"""Servo tables of RC linear servos (a prismatic joint's ``servo = {...}``, issue 42): stroke, pulses, speed."""

import math

import numpy as np
import pytest

from labkit.exceptions import RobotFileError
from labkit.robot import Robot, servo_travel, servo_window

QUILL = """format = "labkit-robot/1"
name = "quill"
convention = "standard"
units = { length = "mm", angle = "deg" }

[[joint]]
name = "shoulder"
a = 150
limits = [-90, 90]
servo = { channel = 0, zero = 90, no_load_speed = 350 }

[[joint]]
name = "quill"
type = "prismatic"
limits = [5, 60]
servo = { channel = 1, range = [0, 50], pulse_us = [1000, 2000], no_load_speed = 20 }
"""


def test_a_linear_servos_stroke_defaults_to_the_joints_limits(tmp_path):
    path = tmp_path / "quill.toml"
    path.write_text(QUILL.replace("range = [0, 50], ", ""))
    assert Robot.load(path).links[1].servo.angle_range == pytest.approx((0.005, 0.060))  # not 180 "deg" of mm


def test_a_linear_servos_table_is_in_the_files_length_unit_and_round_trips(tmp_path):
    path = tmp_path / "quill.toml"
    path.write_text(QUILL)
    robot = Robot.load(path)
    s = robot.links[1].servo
    assert s.angle_range == pytest.approx((0.0, 0.050)) and s.pulse_range == (1000.0, 2000.0)
    assert s.no_load_speed == pytest.approx(0.020)  # mm/s -> m/s
    assert robot.links[0].servo.no_load_speed == pytest.approx(math.radians(350))  # deg/s -> rad/s
    assert servo_travel(robot.links[1]) == pytest.approx((0.0, 0.050))  # the stroke, not 180 "deg" of metres
    assert servo_travel(robot.links[0]) == pytest.approx((0.0, math.pi))
    # the joint reaches 5..50 mm: its limits within the stroke
    assert np.allclose(servo_window(robot)[1], [0.005, 0.050])
    again = tmp_path / "again.toml"
    robot.to_toml(again, length_unit="mm", angle_unit="deg")
    back = Robot.load(again)
    assert back.links[1].servo == s
    assert back.links[0].servo.no_load_speed == pytest.approx(robot.links[0].servo.no_load_speed)


@pytest.mark.parametrize("old, new, field, message", [
    ("no_load_speed = 20 }", "no_load_speed = 0 }", r"joint\[2\].servo.no_load_speed", "expected a positive number"),
    ("pulse_us = [1000, 2000]", "pulse_us = [1000, 3000]", r"joint\[2\].servo.pulse_us", r"within 400..2600 us"),
])
def test_a_linear_servos_table_is_checked(tmp_path, old, new, field, message):
    path = tmp_path / "bad.toml"
    path.write_text(QUILL.replace(old, new))
    with pytest.raises(RobotFileError, match=f"{field}.*{message}"):
        Robot.load(path)
