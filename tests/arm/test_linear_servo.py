"""RC linear servos (issue 42): a prismatic joint driven by a standard RC pulse over its stroke, end to end on the
virtual arm (``sim://``); the firmware in simavr is in ``test_firmware.py``.

The bundled ``cylindrical_l16`` rig turns on a hobby servo and lifts (100 mm) and reaches (50 mm) on Actuonix
L16-R linear servos, 1000-2000 us over their strokes, 20 mm/s."""

import math

import numpy as np
import pytest

from labkit.arm import Arm, ArmModel, PhysicsConfig, ServoBank, WireUnits
from labkit.arm._protocol import wire_calibrations, wire_speed_limits
from labkit.data import robots_dir
from labkit.exceptions import JointLimitError, LabkitError, RobotError
from labkit.robot import Robot

L16 = Robot.load("cylindrical_l16")
#: a target inside every stroke: 30 deg, lift 62.5 mm, reach 31.25 mm (both at 1625 us)
TARGET = np.array([math.radians(30.0), 0.0625, 0.03125])


def quiet(**kw):
    return PhysicsConfig(**{"zero_offsets": (0.0, 0.0, 0.0), "joint_compliance": 0.0, "feedback_noise": 0.0, **kw})


def test_a_linear_servo_counts_its_stroke_in_18000_units_on_the_wire():
    units = WireUnits(L16)
    assert units.metres[0] is None  # the turn: centidegrees, as every hobby servo
    assert units.metres[1] == pytest.approx(0.100 / 18000) and units.metres[2] == pytest.approx(0.050 / 18000)
    # 0.01 mm resolution and better for every L16 stroke (50, 100, 140 mm)
    assert all(stroke / 18000 < 1e-5 for stroke in (0.050, 0.100, 0.140))
    assert units.positions(TARGET) == [3000, 11250, 11250]
    assert np.allclose(units.joints([3000, 11250, 11250]), TARGET, rtol=0, atol=1e-12)
    # CAL: the stroke's pulses, its start at q = 0, the limits over the stroke; LIMITS in units/s
    joints, _ = wire_calibrations(L16)
    assert joints == [[500, 2500, 9000, 1, -9000, 9000], [1000, 2000, 0, 1, 0, 18000], [1000, 2000, 0, 1, 0, 18000]]
    vmax, amax = wire_speed_limits(L16)
    assert vmax == [11999, 2699, 5399]  # 15 mm/s: 15/100 and 15/50 of 18000 units/s, rounded down
    assert amax == [60000, 18000, 36000]


def test_the_linear_servo_uses_the_hobby_servos_calibration():
    """position [m] <-> pulse [us]: the one ServoCalibration map, metres in place of radians."""
    lift = L16.links[1].servo
    assert float(lift.pulse_us(0.0625)) == pytest.approx(1625.0)
    assert float(lift.joint_from_pulse(1625.0)) == pytest.approx(0.0625)
    assert lift.no_load_speed == pytest.approx(0.020)  # the datasheet's 20 mm/s, in SI


def test_the_virtual_linear_servo_moves_at_its_datasheet_speed_and_stops_on_its_command():
    bank = ServoBank(L16, quiet(deadband=0.0, linear_deadband=0.0), q0=[0.0, 0.0, 0.0])
    bank.command([0.0, 0.080, 0.040])
    ys = [bank.position]
    for _ in range(int(6.0 / bank.config.dt)):
        bank.step()
        ys.append(bank.position)
    v = np.abs(np.diff(np.array(ys), axis=0)).max(axis=0) / bank.config.dt
    assert v[1:] == pytest.approx([0.020, 0.020], rel=0.02), "the L16's no-load 20 mm/s, not a hobby servo's 300 deg/s"
    assert np.allclose(ys[-1][1:], [0.080, 0.040], atol=1e-6)
    model = ArmModel(L16, PhysicsConfig(seed=5))
    assert model.zero_offsets[0] != 0.0 and np.all(model.zero_offsets[1:] == 0.0), "a linear servo has no horn"


def test_a_linear_servo_within_its_deadband_holds():
    bank = ServoBank(L16, quiet(), q0=[0.0, 0.050, 0.025])
    bank.command([0.0, 0.050 + 0.2e-3, 0.025 + 0.3e-3])  # 0.2 mm: inside the 0.25 mm deadband; 0.3 mm: beyond
    bank.advance(1.0)
    assert bank.position[1] == pytest.approx(0.050, abs=1e-9)
    assert bank.position[2] == pytest.approx(0.0253, abs=1e-6)


def test_an_rc_linear_servo_moves_on_the_virtual_arm_to_its_command():
    with Arm(L16, "sim://cylindrical_l16?clock=lockstep&seed=0") as arm:
        arm.move_joints(TARGET, wait=True, tol=1e-3, max_wait=30.0)
        assert np.allclose(arm.commanded_joints(), TARGET, rtol=0, atol=1e-9)
        pulses = arm.port.board.pulses
        # the pulse the board emits is the calibration's, to the board's 0.5 us
        for j in (1, 2):
            assert abs(pulses[j] - float(L16.links[j].servo.pulse_us(TARGET[j]))) <= 0.25
        true = arm.virtual_model.true_q
        assert np.abs(true[1:] - TARGET[1:]).max() <= PhysicsConfig().linear_deadband
        sensed = arm.read_joints()
        # the feedback pot: 818 counts over the stroke, +-1 count of noise and one of quantisation
        count = np.array([0.100, 0.050]) / (920.7 - 102.3)
        assert np.all(np.abs(sensed[1:] - TARGET[1:]) <= 3 * count), (sensed - TARGET) * 1000


def test_a_trajectory_of_linear_servos_runs_through_segments_in_their_units():
    from labkit.motion import joint_trajectory

    with Arm(L16, "sim://cylindrical_l16?clock=lockstep&seed=1") as arm:
        start = arm.commanded_joints()
        goal = np.array([math.radians(-20.0), 0.030, 0.045])
        report = arm.run_trajectory(joint_trajectory(L16, start, goal, 4.0, dt=0.1), order=5, min_duration=0.2)
        assert report.segments >= 10 and report.underruns == 0
        held = arm.stop()
        assert np.allclose(held, goal, rtol=0, atol=np.array([math.radians(0.01), 1e-5, 1e-5]))
        assert abs(arm.port.board.pulses[2] - 1900.0) <= 0.25  # 45 of 50 mm


def _wide(tmp_path, limits, name="wide_l16"):
    """The bundled rig with other limits on its reach (a 50 mm L16-R)."""
    src = (robots_dir() / "cylindrical_l16.toml").read_text()
    src = src.replace('name = "cylindrical_l16"', f'name = "{name}"')
    src = src.replace("limits = [0, 50]", f"limits = {limits}")
    path = tmp_path / f"{name}.toml"
    path.write_text(src)
    return path


def test_a_position_outside_the_pulse_range_is_refused_naming_joint_and_field_and_nothing_moves(tmp_path):
    """The reach's limits run 10 mm past its 50 mm stroke: 55 mm would need 2100 us, past its pulse_us."""
    path = _wide(tmp_path, "[0, 60]")
    robot = Robot.load(path)
    with Arm(robot, f"sim://{path}?clock=lockstep&seed=0") as arm:
        before = arm.status()
        sent = arm.stats.sent
        with pytest.raises(JointLimitError, match=r"joint 3 \('reach'\): 55 mm needs a pulse of 2100\.0 us, outside its "
                                                  r"servo's pulse_us 1000\.\.2000 us") as err:
            arm.move_joints([0.0, 0.05, 0.055])
        assert isinstance(err.value, LabkitError) and err.value.joint == 2
        after = arm.status()
        assert after.last == before.last and after.done == before.done, "no MOVE reached the board"
        assert np.array_equal(after.q, before.q)
        assert arm.stats.sent == sent + 1  # the STATUS above only


def test_a_calibration_row_past_the_protocols_fields_is_refused_before_anything_is_sent(tmp_path):
    """Limits of -100..100 mm on a 50 mm stroke: -36000 units do not fit CAL's int16 field."""
    path = _wide(tmp_path, "[-100, 100]", name="far_l16")
    robot = Robot.load(path)
    with pytest.raises(RobotError, match=r"far_l16: joint 'reach': calibration field lo = -36000 units of 2\.78 um "
                                         r"does not fit the board's protocol \(expected -32000\.\.32000") as err:
        wire_calibrations(robot)
    assert err.value.field == "servo.lo"
    with pytest.raises(LabkitError, match="joint 'reach': calibration field lo"):
        Arm(robot, f"sim://{path}?clock=lockstep&seed=0&calibrated=1")
