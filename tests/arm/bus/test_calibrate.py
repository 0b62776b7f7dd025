"""Guided bus calibration: the arithmetic on recorded ticks, and end to end on the virtual buses.

The virtual arms are mounted at random (:func:`assembled_servos`: zeros anywhere, some servos turning the
other way, one joint's range across the encoder's seam) and moved by the emulator's hand; the calibrated
robot file must read the true joint angles, through the homing offset the calibration wrote.
"""

from __future__ import annotations

import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from labkit.arm import calibrate_bus
from labkit.arm.bus import (BusEmulator, BusCalibration, VirtualServo, assembled_servos, calibrate_servos,
                            bus_module, open_bus_board, solve_joint, unwrap_ticks)
from labkit.arm.bus._hardware import homing_offset, present_ticks
from labkit.cli import main
from labkit.data import robots_dir
from labkit.exceptions import BusCalibrationError, LabkitError, OptionError, PortURLError
from labkit.robot import Robot, edit_bus_calibration

RES = 4096
PER_DEG = RES / 360.0


def _path(zero, degrees, direction=1):
    """Present ticks of a joint moved through ``degrees`` (joint angles) from tick ``zero``."""
    return [int(round(zero + direction * d * PER_DEG)) % RES for d in degrees]


def _sweep(lo, hi, plus=20.0, step=5.0):
    """Joint angles [deg] of a labelled move to ``plus`` then a sweep to ``hi``, ``lo`` and back to 0; plus_end."""
    up = list(np.arange(0, plus + step, step))
    rest = list(np.arange(plus, hi, step)) + [hi] + list(np.arange(hi, lo, -step)) + [lo] + list(np.arange(lo, 0, step))
    return up + rest, len(up) - 1


@pytest.fixture(scope="module")
def so101():
    return Robot.load("so101")


def test_unwrap_removes_the_seam_jumps():
    assert unwrap_ticks([10, 4090, 4000, 5, 100], RES).tolist() == [0, -16, -106, -5, 90]
    assert unwrap_ticks([4095, 0], RES, start=4094).tolist() == [1, 2]


def test_a_range_inside_one_turn_gives_the_zero_and_direction(so101):
    degrees, plus_end = _sweep(-113, 113)
    cal = solve_joint(so101, 0, 1500, _path(1500, degrees, -1), plus_end)
    assert (cal.zero, cal.direction, cal.offset) == (1500, -1, None)
    assert cal.limits == so101.links[0].limits  # the stops lie past the file's limits: limits kept
    assert cal.swept[0] == pytest.approx(math.radians(-113), abs=1e-3)


def test_a_range_across_the_seam_is_rehomed_within_the_offset_limit(so101):
    # wrist_flex (+-95 deg) with its zero 100 ticks above tick 0: the lower limit is past the seam
    degrees, plus_end = _sweep(-98, 98)
    path = _path(100, degrees)
    assert max(np.abs(np.diff(path))) > RES / 2  # the readings jump at the seam
    cal = solve_joint(so101, 3, 100, path, plus_end, offset=0, homing=(-1, 2047))
    lo, hi = so101.links[3].limits
    assert cal.offset is not None and abs(cal.offset) <= 2047
    shift = (cal.zero - 100) % RES
    assert (-cal.offset) % RES == shift  # Feetech: present = actual - offset
    ends = [cal.zero + q * RES / (2 * math.pi) for q in (lo, hi)]
    assert 0 <= round(min(ends)) and round(max(ends)) <= RES - 1
    assert abs((min(ends) + max(ends)) / 2 - (RES - 1) / 2) <= 1.5  # the middle of the range at half a turn
    assert "seam" in " ".join(cal.notes)


def test_the_offset_that_would_be_2048_is_never_written(so101):
    # LeRobot's "magnitude exceeds 2047": a joint whose ideal shift is exactly half a turn on a Feetech servo
    # (the ideal offset 2048 is out of range; -2048 too): labkit moves the middle of the range by one tick instead
    joint = so101.links[3]
    span = (joint.limits[1] - joint.limits[0]) * RES / (2 * math.pi)
    zero = 0  # the range's middle at tick 0: the ideal shift is 2047.5 -> offset -2048 or -2047
    degrees, plus_end = _sweep(-98, 98)
    cal = solve_joint(so101, 3, zero, _path(zero, degrees), plus_end, offset=0, homing=(-1, 2047))
    assert abs(cal.offset) <= 2047 and span < RES - 1
    # with an existing offset near the limit, the new one wraps into range instead of exceeding it
    cal = solve_joint(so101, 3, zero, _path(zero, degrees), plus_end, offset=2000, homing=(-1, 2047))
    assert abs(cal.offset) <= 2047


def test_a_seam_without_rehoming_says_how_to_rehome(so101):
    degrees, plus_end = _sweep(-98, 98)
    for kwargs in ({"homing": (-1, 2047), "rehome": False}, {"homing": None}):
        with pytest.raises(BusCalibrationError, match=r"across the encoder's seam.*homing offset"):
            solve_joint(so101, 3, 100, _path(100, degrees), plus_end, **kwargs)


def test_a_joint_that_stops_short_gets_limits_inside_its_stops(so101):
    # a wrist roll that stops at 150 deg each way (300 deg) where the file says +-160 deg
    degrees, plus_end = _sweep(-150, 150)
    cal = solve_joint(so101, 4, 2047, _path(2047, degrees), plus_end, margin=math.radians(1.0))
    assert cal.limits == pytest.approx((math.radians(-149), math.radians(149)), abs=2e-3)
    assert any("stops" in note for note in cal.notes)


def test_a_move_too_small_or_a_sweep_on_one_side_is_refused(so101):
    with pytest.raises(BusCalibrationError, match=r"move towards \+ turned the servo 11 ticks .*at least 5 deg"):
        solve_joint(so101, 0, 2047, _path(2047, [0, 0.5, 1.0]), 2)
    degrees = [0, 10, 20, 30, 40, 30, 20, 10, 2]  # never below the zero mark
    with pytest.raises(BusCalibrationError, match="on both sides"):
        solve_joint(so101, 0, 2047, _path(2047, degrees), 2)


def _truth_reads_through(robot_file, emu):
    """The calibrated file maps the emulator's true joint angles to what its servos report (offsets included)."""
    robot = Robot.load(robot_file)
    for j, lk in enumerate(robot.links):
        for q in np.linspace(*lk.limits, 7):
            assert abs(int(lk.bus.ticks(q)) - present_ticks(emu, j, q)) <= 1, (lk.name, q)


def test_virtual_openmanipulator_end_to_end(tmp_path):
    """calibrate_servos on a virtual OpenMANIPULATOR-X mounted at random: the written file reads the true angles,
    and a bus board opened with it on the same bus reads the arm where the hand left it."""
    source = tmp_path / "omx.toml"
    shutil.copy(robots_dir() / "openmanipulator_x.toml", source)
    robot = Robot.load(source)
    servos = list(assembled_servos(robot, seed=0, seam=(1,)))
    assert [s.direction for s in servos] != [lk.bus.direction for lk in robot.links]  # a bad direction to find
    # joint4 stops at 100 deg where the file says 1.97 rad (112.9 deg): its upper limit becomes 99 deg
    servos[3] = VirtualServo(servos[3].zero, servos[3].direction, (servos[3].stops[0], math.radians(100.0)))
    with BusEmulator(robot, servos=servos) as emu:
        steps = []

        def ask(step):
            steps.append((step.index, step.move))
            emu.hand.answer(step)

        result = calibrate_servos(robot, emu.path, ask=ask, say=lambda text: None, latency=100.0)
        assert steps == [(j, kind) for j in range(4) for kind in ("zero", "plus", "range")]
        assert [c.direction for c in result.joints] == [s.direction for s in servos]
        assert result.joints[1].offset is not None and homing_offset(emu, 12) == result.joints[1].offset
        assert [c.offset for c in result.joints[2:]] == [None, None]
        assert result.joints[0].swept is None and result.joints[0].limits == robot.links[0].limits  # a full turn
        assert result.joints[3].limits == pytest.approx((robot.links[3].limits[0], math.radians(99.0)), abs=2e-3)
        assert "before the file's limit" in result.table()
        before, after, backup = edit_bus_calibration(source, result.changes())
        assert backup.read_text() == before and "[OMX] id, [DRV] zero and direction" in after  # comments kept
        _truth_reads_through(source, emu)
        emu.hand.move(2, 0.3)
        board = open_bus_board(source, emu.path, model=emu.model, latency=100.0)  # goal writes are read back
        try:
            assert board.read_servos().q == pytest.approx(emu.model.shaft_q, abs=2 * 2 * math.pi / RES)
        finally:
            board.shutdown()
    with BusEmulator(robot, servos=servos) as emu:  # the old file on the same arm reads wrong angles
        with pytest.raises(AssertionError):
            _truth_reads_through(robot.path, emu)


@pytest.mark.parametrize("name, seed", [("so101", 3), ("openmanipulator_x", 1)])
def test_calibrate_bus_cli_on_a_virtual_arm_with_a_joint_across_the_seam(tmp_path, capsys, name, seed):
    """`labkit calibrate-bus` on a virtual SO-101 / OpenMANIPULATOR-X mounted at random (joint seed mod n across
    the seam): the file written holds the true zeros (shifted by the homing offset written) and directions."""
    source = tmp_path / f"{name}.toml"
    shutil.copy(robots_dir() / f"{name}.toml", source)
    robot = Robot.load(source)
    codec = bus_module(robot.bus.protocol)
    seam = seed % robot.n
    servos = assembled_servos(robot, seed, seam=(seam,))
    assert servos[seam].crosses_seam(robot.links[seam].limits, RES)
    assert main(["calibrate-bus", str(source), "--port", f"sim://?bus={robot.bus.protocol}&seed={seed}"]) == 0
    out = capsys.readouterr().out
    assert "before -> after:" in out and f"wrote {source}" in out
    new = Robot.load(source)
    found = re.search(rf"{robot.links[seam].name}: range crossed .*homing offset 0 -> (-?\d+)", out)
    offset = int(found.group(1))
    assert abs(offset) <= codec.HOMING_LIMIT
    for j, (lk, servo) in enumerate(zip(new.links, servos)):
        assert lk.bus.direction == servo.direction
        shift = codec.HOMING_SIGN * offset if j == seam else 0  # present = actual + sign * offset
        assert lk.bus.zero == (servo.zero + shift) % RES
    assert (tmp_path / f"{name}.toml.bak").read_text() == (robots_dir() / f"{name}.toml").read_text()


def test_the_hand_needs_torque_off_and_bad_input_is_a_labkit_error(tmp_path, capsys):
    robot = Robot.load("so101")
    with BusEmulator(robot) as emu:
        emu.memory[1][40] = 1  # torque on
        with pytest.raises(OptionError, match="torque off"):
            emu.hand.move(0, 0.1)
    with pytest.raises(OptionError, match="direction 1 or -1"):
        VirtualServo(2048, 0, (-1, 1))
    with pytest.raises(PortURLError, match="sim://\\?bus=feetech"):
        calibrate_bus(str(robots_dir() / "so101.toml"), "sim://?bus=dynamixel", write=False)
    with pytest.raises(PortURLError, match="bus URL"):
        calibrate_bus(str(robots_dir() / "so101.toml"), "/dev/ttyUSB0", write=False)
    with pytest.raises(OptionError, match="\\[bus\\] table"):
        calibrate_bus("arduino_arm_3dof", "sim://?bus=feetech", write=False)
    # a bundled robot is never changed in place
    assert main(["calibrate-bus", "so101", "--port", "sim://?bus=feetech&seed=1"]) == 2
    assert "bundled robot files are never changed" in capsys.readouterr().err
    for argv, words in (([str(tmp_path / "none.toml"), "--port", "feetech:///dev/null"], "no such robot file"),
                        ([str(robots_dir() / "so101.toml"), "--port", f"feetech://{tmp_path}/none"], "cannot open"),
                        ([str(robots_dir() / "so101.toml"), "--port", "dynamixel:///dev/ttyUSB0"], "feetech://")):
        assert main(["calibrate-bus", *argv, "--dry-run"]) == 2
        err = capsys.readouterr().err
        assert words in err and err.count("\n") == 1, err


def test_a_calibration_the_loader_refuses_is_never_written(tmp_path):
    source = tmp_path / "so101.toml"
    shutil.copy(robots_dir() / "so101.toml", source)
    text = source.read_text()
    changes = [{}] * 4 + [{"zero": 4000}]  # wrist_roll's +-160 deg from tick 4000 leaves the servo's turn
    with pytest.raises(LabkitError, match="inside the servo's position range") as info:
        edit_bus_calibration(source, changes)
    assert isinstance(info.value, LabkitError)
    assert source.read_text() == text and not (tmp_path / "so101.toml.bak").exists()
    with pytest.raises(OptionError, match="never changed"):
        edit_bus_calibration("so101", [{}] * 5)
    assert isinstance(BusCalibration("x", ()).table(), str)


def test_a_dry_run_writes_no_homing_offset_and_no_file():
    robot = Robot.load(Path(__file__).with_name("so101_test.toml"))
    servos = assembled_servos(robot, seed=5, seam=(0,))
    with BusEmulator(robot, servos=servos) as emu:
        result = calibrate_servos(robot, emu.path, ask=emu.hand.answer, say=lambda text: None, latency=100.0,
                                  write_offsets=False)
        assert result.joints[0].offset is not None and homing_offset(emu, robot.links[0].bus.id) == 0
        assert "not written (dry run)" in result.table()
        assert [c.direction for c in result.joints] == [s.direction for s in servos]


def test_homing_offsets_in_the_registers_of_both_buses():
    from labkit.arm.bus._calibrate import offset_from_register, offset_to_register

    feetech, dynamixel = bus_module("feetech"), bus_module("dynamixel")
    assert offset_to_register(feetech, -1975) == 1975 | 1 << 11  # sign-magnitude, sign in bit 11 (STS3215 "Ofs")
    assert offset_to_register(dynamixel, -1975) == -1975  # two's complement, masked to 4 bytes when written
    for codec in (feetech, dynamixel):
        for offset in (-2047, -1, 0, 1, 2047):
            value = offset_to_register(codec, offset) & ((1 << 8 * codec.HOMING_OFFSET[1]) - 1)
            assert offset_from_register(codec, value) == offset
