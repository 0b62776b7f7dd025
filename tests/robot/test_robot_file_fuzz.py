"""Issue 27: every bad robot file is a RobotFileError naming the file and the field (probes kept as tests)."""

from __future__ import annotations

import math
import re

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from labkit.exceptions import LabkitError, RobotFileError
from labkit.robot import Robot
from labkit.robot._files import _resolve

BASE = _resolve("arduino_arm_3dof").read_text(encoding="utf-8")
SERVO0 = "servo = { channel = 0, zero = 0, direction = 1, range = [0, 180], pulse_us = [500, 2500], stall_torque = 0.92 }"


def _file(tmp_path, text, name="arm.toml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("old, new, field", [
    (SERVO0, SERVO0.replace("direction = 1", "direction = 1.0"), "joint[1].servo.direction"),
    (SERVO0, SERVO0.replace("range = [0, 180]", "range = [0, 1e-300]"), "joint[1].servo.range"),
    ('name = "arduino_arm_3dof"', 'name = "arm\\u0000x"', "name"),
    ('name = "base_yaw"', 'name = "base\\u0000yaw"', "joint[1].name"),
    ("max_velocity = 300      # deg/s", "max_velocity = 1e-320 # deg/s", "joint[1].max_velocity"),
])
def test_the_probed_robot_files_are_refused_naming_file_and_field(tmp_path, old, new, field):
    assert old in BASE
    path = _file(tmp_path, BASE.replace(old, new, 1))
    with pytest.raises(RobotFileError) as info:
        Robot.load(path)
    assert str(path) in str(info.value) and f"'{field}'" in str(info.value), str(info.value)


def test_a_gripper_that_cannot_move_is_refused(tmp_path):
    m = re.search(r"open_us = (\d+)", BASE)
    assert m, "the bundled arm has a gripper"
    text = re.sub(r"closed_us = \d+", f"closed_us = {m.group(1)}", BASE)
    path = _file(tmp_path, text)
    with pytest.raises(RobotFileError, match=r"field 'gripper.closed_us'") as info:
        Robot.load(path)
    assert str(path) in str(info.value)


VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**6, 10**6), st.booleans(),
    st.sampled_from(["", "x", "\x00", "1e-320", "[]"]), st.just([]), st.lists(st.floats(), max_size=3),
)
FIELDS = ["a", "alpha", "d", "theta", "limits", "max_velocity", "max_acceleration", "name", "type"]


def _toml(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v == math.inf else "-inf" if v == -math.inf else repr(v))
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"').replace("\x00", "\\u0000") + '"'
    return "[" + ", ".join(_toml(x) for x in v) + "]"


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(field=st.sampled_from(FIELDS), value=VALUES, joint=st.integers(1, 3))
def test_fuzzed_joint_fields_load_or_name_the_file(tmp_path, field, value, joint):
    blocks = BASE.split("[[joint]]")
    lines = blocks[joint].split("\n")
    lines = [ln for ln in lines if not ln.startswith(f"{field} ")]
    lines.insert(1, f"{field} = {_toml(value)}")
    path = _file(tmp_path, "[[joint]]".join(blocks[:joint] + ["\n".join(lines)] + blocks[joint + 1:]))
    try:
        robot = Robot.load(path)
    except RobotFileError as exc:
        assert str(path) in str(exc)
        return
    except LabkitError as exc:  # pragma: no cover - the failure this test exists for
        pytest.fail(f"not a RobotFileError naming the file: {type(exc).__name__}: {exc}")
    for lk in robot.links:  # what loads is sane
        assert all(math.isfinite(x) for x in (lk.a, lk.alpha, lk.d, lk.theta))
        assert lk.max_velocity >= 1e-6 and lk.max_acceleration >= 1e-6
        assert "\x00" not in lk.name
