"""edit_bus_calibration: a calibration's values written into a robot file, everything else kept."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import pytest

from labkit.exceptions import OptionError, RobotFileError
from labkit.robot import Robot, edit_bus_calibration

OMX_TEST = Path(__file__).resolve().parents[1] / "arm" / "bus" / "omx_test.toml"


def test_values_in_the_files_units_and_every_other_line_kept(tmp_path):
    source = tmp_path / "arm.toml"
    shutil.copy(OMX_TEST, source)
    robot = Robot.load(source)
    changes = [{} for _ in robot.links]
    changes[0] = {"zero": 1990, "direction": -1, "limits": (math.radians(-150.004), math.radians(151.2379))}
    changes[1] = {"limits": robot.links[1].limits}  # unchanged limits: the line stays as written
    before, after, backup = edit_bus_calibration(source, changes)
    old, new = before.splitlines(), after.splitlines()
    changed = [(a, b) for a, b in zip(old, new) if a != b]
    assert len(old) == len(new) and changed == [
        ("limits = [-160, 160]", "limits = [-150.0, 151.23]"),  # degrees, rounded inwards to 0.01 deg
        ("bus = { id = 11, zero = 2048, direction = 1 }", "bus = { id = 11, zero = 1990, direction = -1 }")]
    assert backup == tmp_path / "arm.toml.bak" and backup.read_text() == before
    again = edit_bus_calibration(source, changes)[2]
    assert again == tmp_path / "arm.toml.bak2"  # an older backup is never overwritten
    loaded = Robot.load(source)
    assert (loaded.links[0].bus.zero, loaded.links[0].bus.direction) == (1990, -1)


def test_a_new_file_leaves_the_source_alone_and_bad_changes_are_errors(tmp_path):
    out = tmp_path / "calibrated.toml"
    n = Robot.load(OMX_TEST).n
    before, after, backup = edit_bus_calibration(OMX_TEST, [{"zero": 2000}] + [{}] * (n - 1), out=out)
    assert backup is None and out.read_text() == after and OMX_TEST.read_text() == before
    with pytest.raises(RobotFileError, match="expected 3 \\[\\[joint\\]\\] tables"):
        edit_bus_calibration(OMX_TEST, [{}] * 3, out=out)
    with pytest.raises(OptionError, match="one dict of changes per joint"):
        edit_bus_calibration(OMX_TEST, "zero", out=out)
    with pytest.raises(OptionError, match="regular file"):
        edit_bus_calibration(OMX_TEST, [{}] * n, out=tmp_path)
    hobby = tmp_path / "hobby.toml"
    shutil.copy(Path(__file__).resolve().parents[2] / "labkit" / "data" / "robots" / "arduino_arm_3dof.toml", hobby)
    with pytest.raises(RobotFileError, match="expected bus = "):
        edit_bus_calibration(hobby, [{"zero": 1}] * 3)
