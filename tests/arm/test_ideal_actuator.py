"""Joints that are not hobby servos (issue 42): ideal actuators on the virtual arm, and calibration rows that do
not fit the protocol's fields refused before anything is sent."""

import math
from pathlib import Path

import numpy as np
import pytest

from labkit.arm import Arm, ArmModel, PhysicsConfig, ServoBank, VirtualBoard
from labkit.arm.link._segments import feasible_ranges
from labkit.exceptions import LabkitError, RobotError
from labkit.robot import Robot

FIXTURES = Path(__file__).parents[1] / "labs" / "robots"
#: a cylindrical RPP arm without servo tables: turn -150..150 deg, lift 50..250 mm, reach 100..300 mm
RPP = Robot.load(FIXTURES / "cylindrical_rpp.toml")

#: a SCARA whose prismatic quill has an RC linear-servo table (50 mm over 1000-2000 us): issue 42's overflow, which
#: fits the protocol since a linear servo counts 1/18000 of its stroke on the wire
QUILL_SERVO = """format = "labkit-robot/1"
name = "quill_servo"
convention = "standard"
units = { length = "mm", angle = "deg" }

[[joint]]
name = "shoulder"
d = 200
a = 150
limits = [-90, 90]
servo = { channel = 0, zero = 90 }

[[joint]]
name = "quill"
type = "prismatic"
limits = [0, 50]
servo = { channel = 1, range = [0, 50], pulse_us = [1000, 2000] }
"""


def quiet():
    return PhysicsConfig(zero_offsets=(0.0, 0.0, 0.0), joint_compliance=0.0, feedback_noise=0.0, deadband=0.0)


def test_an_ideal_actuator_moves_over_its_limits_within_its_speed_and_acceleration():
    bank = ServoBank(RPP, quiet(), q0=[0.0, 0.1, 0.15])
    target = [math.radians(140.0), 0.24, 0.29]  # 140 deg: beyond any 180-degree servo window centred on 0
    bank.command(target)
    ys = [bank.position]
    for _ in range(int(4.0 / bank.config.dt)):
        bank.step()
        ys.append(bank.position)
    ys = np.array(ys)
    v = np.diff(ys, axis=0) / bank.config.dt
    a = np.diff(v, axis=0) / bank.config.dt
    vmax = np.array([lk.max_velocity for lk in RPP.links])
    amax = np.array([math.radians(360.0), 2.0, 2.0])  # turn: the stated default; lift and reach: the file's
    assert np.all(np.abs(v).max(axis=0) <= vmax * (1 + 1e-9))
    assert np.all(np.abs(a).max(axis=0) <= amax * (1 + 1e-6))
    assert np.abs(v).max(axis=0) == pytest.approx(vmax, rel=1e-6), "cruises at its max_velocity"
    assert np.allclose(ys[-1], target, atol=1e-12), "reaches its command exactly, no overshoot"
    # braking in whole steps of dt: an overshoot below 1e-5 (a hundredth of an encoder count) at most
    assert np.all(ys.max(axis=0) - target <= 1e-5)


def test_an_ideal_actuator_is_clipped_to_the_robot_files_limits_and_has_no_horn_offset():
    model = ArmModel(RPP, PhysicsConfig(seed=3, feedback_noise=0.0))
    assert np.all(model.zero_offsets == 0.0)
    model.command([math.radians(170.0), 0.4, 0.0])
    model.advance(10.0)
    assert np.allclose(model.shaft_q, [math.radians(150.0), 0.25, 0.1])
    # the encoder spans the limits with the 10-bit count
    assert model.feedback_adc().tolist() == [1023, 1023, 0]


def test_the_virtual_board_drives_ideal_actuators_over_their_limits_and_reads_them_back():
    assert feasible_ranges(RPP) == [(-15000, 15000), (286, 1432), (573, 1719)]  # no 0..180 deg window
    with Arm(RPP, f"sim://{FIXTURES / 'cylindrical_rpp.toml'}?clock=lockstep&seed=0") as arm:
        q = np.array([math.radians(-140.0), 0.2, 0.12])
        arm.move_joints(q, wait=True, max_wait=20.0)
        read = arm.read_joints()
        assert np.abs(read - q).max() < 0.3 * np.ptp(RPP.joint_limits, axis=1).max() / 1023 + 1e-3
        assert np.allclose(arm.virtual_model.true_q, q, atol=1e-3)
    board = VirtualBoard(RPP)
    assert board.valid(0, -14000, [500, 2500, 0, 1, 0, 18000])  # -140 deg: the robot file's limits, not a servo's
    assert not board.valid(0, -15100, [500, 2500, 0, 1, 0, 18000])


def test_a_calibration_that_does_not_fit_the_protocol_is_refused_naming_the_joint_and_the_field(tmp_path):
    path = tmp_path / "quill.toml"
    path.write_text(QUILL_SERVO)
    from labkit.arm._protocol import wire_calibrations

    # issue 42's RC linear servo fits now: its 50 mm stroke is the board's 18000 units at 1000..2000 us
    assert wire_calibrations(Robot.load(path))[0][1] == [1000, 2000, 0, 1, 0, 18000]
    # a hobby servo whose 1000..2000 us cover 90 deg would need 3000 us at 180 deg
    path.write_text(QUILL_SERVO.replace("servo = { channel = 0, zero = 90 }",
                                        "servo = { channel = 0, zero = 45, range = [0, 90], pulse_us = [1000, 2000] }"))
    robot = Robot.load(path)
    with pytest.raises(RobotError, match=r"joint 'shoulder': calibration field pmax = 3000 us .*expected 400\.\.2600 us") as err:
        wire_calibrations(robot)
    assert err.value.field == "servo.pmax"
    with pytest.raises(RobotError, match="joint 'shoulder'"):  # the board's EEPROM image: no struct.error
        VirtualBoard(robot, saved_calibration=True)
    with pytest.raises(LabkitError, match="joint 'shoulder': calibration field pmax"):
        Arm(robot, f"sim://{path}?clock=lockstep&seed=0&calibrated=1")


def test_limits_past_the_int16_field_are_refused(tmp_path):
    path = tmp_path / "wide.toml"
    path.write_text(QUILL_SERVO.replace("limits = [-90, 90]\nservo = { channel = 0, zero = 90 }",
                                        "limits = [-340, 340]\nservo = { channel = 0, zero = 90 }"))
    from labkit.arm._protocol import wire_calibrations

    with pytest.raises(RobotError, match=r"joint 'shoulder': calibration field lo = -34000 cdeg"):
        wire_calibrations(Robot.load(path))


def test_a_long_prismatic_axis_settles_within_a_millimetre_or_its_feedback_counts():
    """wait_settled's default tolerance is per joint, in the joint's own unit: 1 deg, 1 mm, or three counts of a
    coarser feedback (a 10-bit encoder over 600 mm: 0.59 mm a count), never a radian figure read as metres."""
    from labkit.arm import settle_tolerance
    from labkit.exceptions import OptionError

    gantry = Robot.load(Path(__file__).parents[1] / "kinematics" / "robots" / "gantry_pppr.toml")
    tol = settle_tolerance(gantry)
    travel = np.diff(np.array(gantry.joint_limits), axis=1)[:, 0]
    np.testing.assert_allclose(tol[:3], np.maximum(1e-3, 3 * travel[:3] / 1023), rtol=1e-9)
    assert tol[3] == pytest.approx(max(math.radians(1.0), 3 * travel[3] / 1023))
    np.testing.assert_allclose(settle_tolerance(Robot.load("arduino_arm_3dof")), math.radians(1.0))
    lim = np.array(gantry.joint_limits)
    with Arm(gantry, "sim://") as arm:
        for f in (0.1, 0.3, 0.45):
            q = lim.mean(axis=1) + f * (lim[:, 1] - lim[:, 0])
            arm.move_joints(q, wait=True)
            sensed = arm.wait_settled(q)
            assert np.all(np.abs(sensed - q) <= tol), (f, (sensed - q) * 1e3)
        arm.wait_settled(q, tol=[0.01, 0.01, 0.01, 0.1])  # one tolerance per joint [m, m, m, rad]
        with pytest.raises(OptionError, match="expected tol as one number or 4"):
            arm.wait_settled(q, tol=[0.01, 0.01])


@pytest.mark.parametrize("call, message", [
    (lambda lab: lab.ideal_speed_limits(RPP, 3), r"expected j \(a joint index\) as an integer 0\.\.2, got 3"),
    (lambda lab: lab.ideal_speed_limits(RPP, "1"), r"as an integer 0\.\.2, got '1'"),
    (lambda lab: lab.ideal_speed_limits("cylindrical_rpp", 0), r"expected a labkit\.robot\.Robot, got str"),
    (lambda lab: lab.is_ideal(RPP), r"expected a labkit\.robot\.Link \(robot\.links\[j\]\), got Robot"),
])
def test_the_ideal_actuator_helpers_labkit_new_uses_refuse_bad_input(call, message):
    """``labkit.arm.ideal_speed_limits`` and ``is_ideal`` are public (``labkit new`` times its moves with them)."""
    import labkit.arm

    assert labkit.arm.ideal_speed_limits(RPP, 0) == (math.radians(90.0), math.radians(360.0))  # the file's 90 deg/s, the default 360 deg/s^2
    assert labkit.arm.ideal_speed_limits(RPP, 1) == (0.1, 2.0)  # the file's 100 mm/s, 2000 mm/s^2
    with pytest.raises(LabkitError, match=message):
        call(labkit.arm)
