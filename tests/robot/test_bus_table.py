"""The robot file's ``[bus]`` table and per-joint ``bus`` servos: parsing, checks naming file and field, ticks <-> rad."""

import math
from pathlib import Path

import numpy as np
import pytest

from labkit.exceptions import RobotError, RobotFileError
from labkit.robot import Bus, BusServo, Robot

OMX = Path(__file__).parents[1] / "arm" / "bus" / "omx_test.toml"


def test_bus_table_loads_into_si_units():
    robot = Robot.load(OMX)
    assert robot.bus == Bus("dynamixel", 1_000_000, 4096)
    assert [lk.bus.id for lk in robot.links] == [11, 12, 13, 14]
    assert robot.links[1].bus == BusServo(12, 2048.0, -1, 4096)
    assert all(lk.servo is None for lk in robot.links)


def test_ticks_radians_round_trip():
    rng = np.random.default_rng(25)
    for _ in range(50):
        servo = BusServo(int(rng.integers(0, 253)), float(rng.integers(0, 4096)), int(rng.choice([-1, 1])),
                         int(rng.choice([1024, 4096, 1_003_846])))
        ticks = rng.integers(0, servo.resolution, 20)
        assert np.array_equal(servo.ticks(servo.joint(ticks)), ticks)
        q = rng.uniform(-3, 3, 20)
        assert np.all(np.abs(servo.joint(servo.ticks(q)) - q) <= math.pi / servo.resolution + 1e-12)
    assert int(BusServo(1, 2048, 1).ticks(math.pi / 2)) == 3072  # a quarter turn is 1024 ticks


def test_dump_round_trips_the_bus(tmp_path):
    robot = Robot.load(OMX)
    path = tmp_path / "omx.toml"
    path.write_text(robot.to_toml() if hasattr(robot, "to_toml") else robot.dumps(), encoding="utf-8")
    again = Robot.load(path)
    assert again.bus == robot.bus and [lk.bus for lk in again.links] == [lk.bus for lk in robot.links]


def _edit(tmp_path, old, new):
    text = OMX.read_text(encoding="utf-8")
    assert old in text
    path = tmp_path / "arm.toml"
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    return path


@pytest.mark.parametrize("old, new, field, words", [
    ('protocol = "dynamixel"', 'protocol = "Dynamixel 2.0"', "bus.protocol", "expected a bus protocol name"),
    ('protocol = "dynamixel"', 'kind = "dynamixel"', "bus.kind", "unknown key"),
    ("baudrate = 1000000", "baudrate = 1e6", "bus.baudrate", "expected an integer 9600..4500000"),
    ("resolution = 4096", "resolution = 0", "bus.resolution", "ticks/turn"),
    ("bus = { id = 11, zero = 2048, direction = 1 }", "bus = { id = 300, zero = 2048 }", "joint[1].bus.id",
     "expected an integer 0..252"),
    ("bus = { id = 11, zero = 2048, direction = 1 }", "bus = { id = 11, zero = 5000 }", "joint[1].bus.zero",
     "0..4095 ticks"),
    ("bus = { id = 11, zero = 2048, direction = 1 }", "bus = { id = 11, direction = 2 }", "joint[1].bus.direction",
     "expected 1 or -1"),
    ("bus = { id = 11, zero = 2048, direction = 1 }", "bus = { id = 11, offset = 3 }", "joint[1].bus.offset",
     "unknown key"),
    ("bus = { id = 11, zero = 2048, direction = 1 }", "", "joint[1].bus", "on every joint"),
    ("bus = { id = 11, zero = 2048, direction = 1 }", "bus = { id = 12 }", "joint.bus.id", "distinct servo ids"),
    ("limits = [-160, 160]", "limits = [-190, 160]", "joint[1].limits", "inside the servo's position range"),
    ("bus = { id = 11, zero = 2048, direction = 1 }",
     "bus = { id = 11 }\nservo = { channel = 0 }", "joint[1].bus", "got both"),
])
def test_a_bad_bus_table_names_file_and_field(tmp_path, old, new, field, words):
    path = _edit(tmp_path, old, new)
    with pytest.raises(RobotFileError, match=words) as info:
        Robot.load(path)
    assert str(path) in str(info.value) and f"field '{field}'" in str(info.value)


def test_a_bus_servo_without_a_bus_table(tmp_path):
    text = OMX.read_text(encoding="utf-8")
    start = text.index("[bus]")
    path = tmp_path / "arm.toml"
    path.write_text(text[:start] + text[text.index("[[joint]]"):], encoding="utf-8")
    with pytest.raises(RobotFileError, match=r"field 'joint\[1\]\.bus': expected a \[bus\] table"):
        Robot.load(path)


def test_robot_in_code_checks_the_bus_too():
    robot = Robot.load(OMX)
    with pytest.raises(RobotError, match="expected a bus servo"):
        robot.replace(links=(robot.links[0].__class__(limits=(-1, 1)),) + robot.links[1:])
    with pytest.raises(RobotError, match="expected a"):
        Robot(name="x", links=robot.links, bus=None)
