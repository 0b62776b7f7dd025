"""Tests of the robot-file format (labkit.robot._files): bundled robots, units, errors, round trips."""

import math
import textwrap

import numpy as np
import pytest

from labkit.robot import Convention, JointType, Robot, bundled_robots
from labkit.exceptions import RobotFileError, ShapeError

BUNDLED = [
    "arduino_arm_3dof",
    "irb140",
    "kr5",
    "planar3r_seed003",
    "planar3r_seed003_135",
    "planar3r_seed004",
    "puma560",
    "puma600_seed002",
    "puma_wrist_seed002",
    "rpp_seed002",
    "ur5",
]

MINIMAL = """
format = "labkit-robot/1"
name = "mini"
convention = "standard"
units = { length = "mm", angle = "deg" }

[[joint]]
a = 100
alpha = 90
limits = [-90, 90]
servo = { channel = 0, zero = 90, range = [0, 180], pulse_us = [500, 2500] }

[[joint]]
type = "prismatic"
d = 10
limits = [0, 50]
"""


def test_every_bundled_robot_loads():
    found = bundled_robots()
    assert set(BUNDLED) <= set(found)
    for name in BUNDLED:
        r = Robot.load(name)
        assert r.name == name
        assert r.n == len(r.links) >= 3
        assert r.joint_limits.shape == (r.n, 2)
        assert np.all(r.joint_limits[:, 0] < r.joint_limits[:, 1])
        assert r.title and r.source
        assert Robot.load(found[name]).name == name  # by path too


def test_unit_conversion_mm_deg():
    arm = Robot.load("arduino_arm_3dof")
    assert arm.convention is Convention.MODIFIED
    assert np.allclose(arm.a, [0, 0, 0.094])
    assert np.allclose(arm.alpha, [0, -np.pi / 2, np.pi])
    assert np.allclose(arm.joint_limits, [[0, np.pi]] * 3)
    assert np.allclose(arm.tool[:3, 3], [0.180, 0, 0])
    assert arm.links[0].max_velocity == pytest.approx(math.radians(300))
    s = arm.links[1].servo
    assert s.channel == 1 and s.angle_range == pytest.approx((0, math.pi))
    assert arm.gripper.channel == 3 and arm.gripper.open_us == 1000
    assert (arm.length_unit, arm.angle_unit) == ("mm", "deg")
    puma = Robot.load("puma600_seed002")
    assert np.allclose(puma.d, [0.5, -0.2, 0, 0.4, 0, 0.15])


def test_prismatic_units(tmp_path):
    p = tmp_path / "mini.toml"
    p.write_text(MINIMAL)
    r = Robot.load(p)
    assert r.links[1].joint_type is JointType.PRISMATIC
    assert r.links[1].d == pytest.approx(0.010)
    assert r.links[1].limits == pytest.approx((0.0, 0.050))
    assert r.links[0].servo.zero == pytest.approx(math.pi / 2)
    assert r.links[0].servo.feedback_adc == (102.3, 920.7)  # default
    assert r.path == str(p)


def _write(tmp_path, text, name="bad.toml"):
    p = tmp_path / name
    p.write_text(textwrap.dedent(text))
    return p


@pytest.mark.parametrize(
    "old, new, field, message",
    [
        ('name = "mini"\n', "", "name", "non-empty string"),
        ('convention = "standard"', 'convention = "dh"', "convention", "standard.*modified.*craig.*got 'dh'"),
        ('length = "mm"', 'length = "inch"', "units.length", r"\['cm', 'm', 'mm'\], got 'inch'"),
        ('angle = "deg"', 'angle = "grad"', "units.angle", r"\['deg', 'rad'\], got 'grad'"),
        ("limits = [-90, 90]", "limits = [90]", r"joint\[1\].limits", r"\[lower, upper\], got \[90\]"),
        ("limits = [-90, 90]", "limits = [90, -90]", r"joint\[1\].limits", "lower < upper"),
        ("limits = [-90, 90]", 'limits = ["a", 1]', r"joint\[1\].limits", "finite number"),
        ("a = 100", "a = 100\nlength = 3", r"joint\[1\].length", "unknown key; expected one of: a, alpha"),
        ('name = "mini"', 'name = "mini"\ncolour = "red"', "colour", "unknown key"),
        ("channel = 0,", "channel = 0, speed = 2,", r"joint\[1\].servo.speed", "unknown key"),
        ("channel = 0,", "channel = 9,", r"joint\[1\].servo.channel", "integer 0-5, got 9"),
        ("channel = 0,", 'channel = "A0",', r"joint\[1\].servo.channel", "integer 0-5, got 'A0'"),
        ("channel = 0,", "channel = true,", r"joint\[1\].servo.channel", "integer 0-5, got True"),
        ("zero = 90,", "zero = 90, direction = 2,", r"joint\[1\].servo.direction", "1 or -1, got 2"),
        ('type = "prismatic"', 'type = "spherical"', r"joint\[2\].type", "'revolute' or 'prismatic', got 'spherical'"),
        ("limits = [0, 50]", "", r"joint\[2\].limits", "required for a prismatic joint"),
        ("d = 10", 'd = "ten"', r"joint\[2\].d", "finite number, got 'ten'"),
        ('format = "labkit-robot/1"', 'format = "labkit-robot/9"', "format", "expected 'labkit-robot/1'"),
        ("a = 100", "a = 100\nmax_velocity = 0", r"joint\[1\].max_velocity", "positive number >= 1e-06, got 0"),
        ("a = 100", "a = 100\nmax_acceleration = -5", r"joint\[1\].max_acceleration", "positive number >= 1e-06, got -5"),
        ("d = 10", 'd = 10\nname = "q1"', "joint.name", "distinct joint names, got 'q1' twice"),
        ("[[joint]]\na = 100", '[[joint]]\nname = "q2"\na = 100', "joint.name", "got 'q2' twice"),
        # issue 13: wrong types gave tracebacks or were accepted silently
        ('length = "mm"', "length = [1]", "units.length", r"\['cm', 'm', 'mm'\], got \[1\]"),
        ('angle = "deg"', "angle = {x = 1}", "units.angle", r"got \{'x': 1\}"),
        ('convention = "standard"', "convention = [1]", "convention", r"got \[1\]"),
        ('name = "mini"', 'name = "mini"\ntitle = ["a"]', "title", r"expected a string, got \['a'\]"),
        ("a = 100", "a = 100\nname = 5", r"joint\[1\].name", "expected a string, got 5"),
        ('type = "prismatic"', "type = 1", r"joint\[2\].type", "got 1"),
        ("pulse_us = [500, 2500]", "pulse_us = [-1e5, 1e9]", r"joint\[1\].servo.pulse_us",
         r"within 400..2600 us \(RC servo pulses\), got \[-100000.0, 1000000000.0\]"),
        ("zero = 90,", "zero = 90, feedback_adc = [0, 5000],", r"joint\[1\].servo.feedback_adc", "within 0..1023"),
    ],
)
def test_malformed_file_names_file_and_field(tmp_path, old, new, field, message):
    assert old in MINIMAL
    p = _write(tmp_path, MINIMAL.replace(old, new, 1))
    with pytest.raises(RobotFileError, match=message) as info:
        Robot.load(p)
    assert str(p) in str(info.value)
    assert "field '" in str(info.value)
    import re

    assert re.fullmatch(field, info.value.field), info.value.field
    assert isinstance(info.value, ValueError)


def test_no_joints(tmp_path):
    text = MINIMAL.split("[[joint]]")[0]
    with pytest.raises(RobotFileError, match=r"field 'joint': expected at least one \[\[joint\]\]"):
        Robot.load(_write(tmp_path, text))


def test_duplicate_servo_channels(tmp_path):
    text = MINIMAL.replace('limits = [0, 50]', 'limits = [0, 50]\nservo = { channel = 0 }')
    with pytest.raises(RobotFileError, match=r"distinct servo channels, got \[0, 0\]") as info:
        Robot.load(_write(tmp_path, text))
    assert info.value.field == "servo.channel"
    gripper = MINIMAL + "\n[gripper]\nchannel = 0\nopen_us = 1000\nclosed_us = 2000\n"
    with pytest.raises(RobotFileError, match=r"distinct servo channels, got \[0, 0\]"):
        Robot.load(_write(tmp_path, gripper, "g.toml"))


def test_tool_frame_errors(tmp_path):
    bad = MINIMAL + "\n[tool]\ntranslation = [1, 2]\n"
    with pytest.raises(RobotFileError, match=r"field 'tool.translation': expected a list of 3 numbers"):
        Robot.load(_write(tmp_path, bad))
    bad = MINIMAL + "\n[tool]\nrotation = [0, 0, 0]\n"
    with pytest.raises(RobotFileError, match=r"field 'tool.rotation': unknown key; expected one of: rpy, translation"):
        Robot.load(_write(tmp_path, bad, "b.toml"))


def test_unreadable_file(tmp_path):
    p = tmp_path / "latin1.toml"
    p.write_bytes(MINIMAL.replace("mini", "mini\xe9").encode("utf-8").replace(b"\xc3\xa9", b"\xe9"))
    line = MINIMAL.splitlines().index('name = "mini"') + 1
    with pytest.raises(RobotFileError, match=f"expected UTF-8 text, got byte 0xe9 on line {line}; save the file as "
                       "UTF-8") as info:
        Robot.load(p)
    assert info.value.field == "<file>" and str(info.value.path) == str(p)
    d = tmp_path / "folder.toml"
    d.mkdir()
    with pytest.raises(RobotFileError, match="expected a robot file, got a folder"):
        Robot.load(d)


def test_byte_order_mark_is_not_part_of_the_file(tmp_path):
    # Windows Notepad saves UTF-8 with a byte-order mark: the file is the same robot
    p = tmp_path / "bom.toml"
    p.write_bytes(b"\xef\xbb\xbf" + MINIMAL.lstrip().encode("utf-8"))
    bom, plain = Robot.load(p), Robot.load(_write(tmp_path, MINIMAL, "plain.toml"))
    assert bom.name == "mini" and bom.links == plain.links


def test_invalid_toml(tmp_path):
    p = _write(tmp_path, MINIMAL.replace("a = 100", "a = = 100"))
    with pytest.raises(RobotFileError, match="not valid TOML") as info:
        Robot.load(p)
    assert str(p) in str(info.value) and info.value.field == "<toml>"


def test_unknown_robot_name_lists_valid_names():
    with pytest.raises(RobotFileError, match="unknown robot") as info:
        Robot.load("puma_9000")
    for name in BUNDLED:
        assert name in str(info.value)
    with pytest.raises(RobotFileError, match="no such robot file"):
        Robot.load("/nonexistent/robot.toml")


def test_robot_search_path_env(tmp_path, monkeypatch):
    _write(tmp_path, MINIMAL.replace('name = "mini"', 'name = "my_arm"'), "my_arm.toml")
    monkeypatch.setenv("LABKIT_ROBOT_PATH", str(tmp_path))
    assert "my_arm" in bundled_robots()
    assert Robot.load("my_arm").n == 2


@pytest.mark.parametrize("name", BUNDLED)
@pytest.mark.parametrize("units", [None, ("m", "rad"), ("mm", "deg"), ("cm", "deg")])
def test_to_toml_round_trip(tmp_path, name, units):
    r = Robot.load(name)
    kw = {} if units is None else {"length_unit": units[0], "angle_unit": units[1]}
    path = tmp_path / f"{name}.toml"
    text = r.to_toml(path, **kw)
    assert path.read_text() == text
    r2 = Robot.load(path)
    assert r2.name == r.name and r2.title == r.title and r2.convention is r.convention
    assert r2.n == r.n
    for a, b in zip(r.links, r2.links):
        assert a.joint_type is b.joint_type and a.name == b.name
        for f in ("a", "alpha", "d", "theta", "max_velocity", "max_acceleration"):
            assert getattr(b, f) == pytest.approx(getattr(a, f), abs=1e-11)
        assert b.limits == pytest.approx(a.limits, abs=1e-11)
        assert (a.servo is None) == (b.servo is None)
        if a.servo:
            assert b.servo.channel == a.servo.channel and b.servo.direction == a.servo.direction
            assert b.servo.zero == pytest.approx(a.servo.zero, abs=1e-11)
            assert b.servo.angle_range == pytest.approx(a.servo.angle_range, abs=1e-11)
            assert b.servo.pulse_range == pytest.approx(a.servo.pulse_range)
    assert np.allclose(r2.tool, r.tool, atol=1e-11) and np.allclose(r2.base, r.base, atol=1e-11)
    assert r2.gripper == r.gripper


def test_to_toml_round_trip_rotated_tool_and_quotes(tmp_path):
    from labkit.rotations import matrix_from_rpy

    T = np.eye(4)
    T[:3, :3] = matrix_from_rpy([0.3, np.pi / 2, -1.0])  # gimbal lock: stored with yaw = 0
    T[:3, 3] = [0.01, 0.02, 0.03]
    r = Robot.load("puma560").replace(tool=T, base=T, title='Corke\'s "PUMA" \\ 560')
    r2 = Robot.load(tmp_path / "x.toml") if r.to_toml(tmp_path / "x.toml") else None
    assert np.allclose(r2.tool, T, atol=1e-11) and np.allclose(r2.base, T, atol=1e-11)
    assert r2.title == r.title


def test_docs_example_file_is_valid_and_matches_bundled_arm(tmp_path):
    """The example in docs/robot-files.md loads and describes the bundled arduino arm."""
    from pathlib import Path

    from labkit.kinematics import fk

    doc = (Path(__file__).resolve().parents[2] / "docs" / "robot-files.md").read_text()
    example = doc.split("```toml\n", 1)[1].split("```", 1)[0]
    p = tmp_path / "example.toml"
    p.write_text(example)
    r = Robot.load(p)
    ref = Robot.load("arduino_arm_3dof")
    q = np.radians([[10, 20, 30], [170, 90, 5]])
    assert np.allclose(fk(r, q), fk(ref, q))
    assert [lk.servo.channel for lk in r.links] == [0, 1, 2] and r.gripper == ref.gripper


# -- the world's up direction (key ``up``) ---------------------------------------------------

def test_up_defaults_to_plus_z_and_is_read_normalised(tmp_path):
    assert np.array_equal(Robot.load(_write(tmp_path, MINIMAL)).up, [0.0, 0.0, 1.0])
    r = Robot.load(_write(tmp_path, MINIMAL.replace('convention = "standard"', 'convention = "standard"\nup = [0, 0, -2]')))
    assert np.array_equal(r.up, [0.0, 0.0, -1.0])
    with pytest.raises(ValueError):
        r.up[2] = 1.0  # frozen data
    assert np.array_equal(Robot.load("arduino_arm_3dof").up, [0.0, 0.0, -1.0])  # frame 0: z down


@pytest.mark.parametrize("value, message", [
    ("[0, 0]", "expected a list of 3 numbers"),
    ('"down"', "expected a list of 3 numbers"),
    ("[0, 0, 0]", "non-zero direction"),
    ('[0, 0, "up"]', "finite number"),
    ("[0, 0, nan]", "finite number"),
])
def test_bad_up_names_the_field(tmp_path, value, message):
    text = MINIMAL.replace('convention = "standard"', f'convention = "standard"\nup = {value}')
    with pytest.raises(RobotFileError, match=message) as info:
        Robot.load(_write(tmp_path, text))
    assert "up" in str(info.value)


def test_up_round_trips_and_is_validated_in_code(tmp_path):
    r = Robot.load("puma560").replace(up=[0.0, 1.0, 1.0])
    assert np.allclose(r.up, [0.0, np.sqrt(0.5), np.sqrt(0.5)])
    for units in (("m", "rad"), ("mm", "deg")):
        r.to_toml(tmp_path / "u.toml", length_unit=units[0], angle_unit=units[1])
        assert np.allclose(Robot.load(tmp_path / "u.toml").up, r.up, atol=1e-12)
    arm = Robot.load("arduino_arm_3dof")
    text = arm.to_toml(tmp_path / "a.toml")
    assert "up = [0, 0, -1]" in text and np.array_equal(Robot.load(tmp_path / "a.toml").up, arm.up)
    assert "up =" not in Robot.load("puma560").to_toml()  # the default is not written
    with pytest.raises(ShapeError, match=r"up with shape \(3,\)"):
        r.replace(up=[0.0, 1.0])
    with pytest.raises(ShapeError, match="non-zero"):
        r.replace(up=[0.0, 0.0, 0.0])


def test_flip_key_loads_and_is_written_back(tmp_path):
    text = MINIMAL.replace("a = 100", "a = 100\nflip = true").replace("d = 10", "d = 10\nflip = false")
    r = Robot.load(_write(tmp_path, text, "flip.toml"))
    assert [lk.flip for lk in r.links] == [True, False]
    out = r.to_toml(length_unit="mm", angle_unit="deg")
    assert out.count("flip = true") == 1 and "flip = false" not in out
    r2 = Robot.load(_write(tmp_path, out, "flip2.toml"))
    assert [lk.flip for lk in r2.links] == [True, False]
    q = np.array([[0.3, 0.02], [-1.0, 0.04]])
    assert np.abs(r2.fk(q) - r.fk(q)).max() < 1e-12
    # the variable enters negated: flipping joint 1 is q1 -> -q1
    unflipped = Robot.load(_write(tmp_path, MINIMAL, "plain.toml"))
    assert np.abs(r.fk(q) - unflipped.fk(q * [-1, 1])).max() < 1e-12
    with pytest.raises(RobotFileError, match=r"field 'joint\[1\].flip': expected true or false, got 'yes'"):
        Robot.load(_write(tmp_path, MINIMAL.replace("a = 100", 'a = 100\nflip = "yes"'), "b.toml"))


def test_gripper_pulses_are_checked(tmp_path):
    text = MINIMAL + "\n[gripper]\nchannel = 3\nopen_us = -5\nclosed_us = 1900\n"
    with pytest.raises(RobotFileError, match=r"field 'gripper.open_us': expected values within 400..2600 us.*got -5"):
        Robot.load(_write(tmp_path, text))
    ok = Robot.load(_write(tmp_path, text.replace("open_us = -5", "open_us = 1000")))
    assert ok.gripper.open_us == 1000 and ok.gripper.closed_us == 1900
