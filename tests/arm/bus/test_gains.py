"""The servos' own position-loop gains through Arm, and the virtual servos' loop on the dynamics.

The overshoot check: a 1 ms step of the goal of the first joint (no gravity about its vertical axis),
recorded with Arm.stream at 200 Hz from the present position, against the step response of the
linearised loop (:func:`labkit.arm.bus.position_loop`, python-control's ``step_info``) with the gains
read back from the servo. Tolerance 3 percentage points: one encoder tick is 1.5 % of the 0.1 rad
Dynamixel step and 3.8 % of the 0.04 rad Feetech step (kept small so the loop output does not saturate).
"""

import math
import re
from pathlib import Path

import control
import numpy as np
import pytest

from labkit.arm import Arm
from labkit.arm.bus import bus_module, loop_plant, position_loop
from labkit.exceptions import DeviceError, OptionError

#: gains tried per bus, and the step [rad] that keeps each loop's output below full scale
CASES = {"dynamixel": ([{"kp": 800}, {"kp": 1600}, {"kp": 1600, "kd": 600}], 0.1),
         "feetech": ([{"kp": 16}, {"kp": 32}, {"kp": 32, "kd": 96}], 0.04)}
TOLERANCE = 3.0  # percentage points of overshoot


def _url(robot_file, kind):
    return f"sim://{robot_file}?bus={kind}&clock=lockstep"


def test_gains_are_read_checked_written_and_restored_on_close(robot_file, kind):
    with Arm(robot_file, _url(robot_file, kind)) as arm:
        emu = arm.port.emulator
        defaults = dict(emu.bus.DEFAULT_GAINS)
        gains = arm.servo_gains()
        assert list(gains) == list(arm.robot.joint_names)
        assert all(g.to_dict() == defaults for g in gains.values())
        name = arm.robot.joint_names[1]
        servo = arm.robot.links[1].bus.id
        new = arm.set_servo_gains(name, kp=defaults["kp"] // 2, kd=10)
        assert new.kp == defaults["kp"] // 2 and new.kd == 10 and new.ki == defaults["ki"]
        field = emu.bus.GAINS["kp"][0]
        assert emu.get(servo, field) == defaults["kp"] // 2  # the servo's own register
        assert emu.model.servos.gains[1]["kp"] == defaults["kp"] // 2  # and its loop runs with it
        top = emu.bus.GAINS["kp"][1]
        with pytest.raises(OptionError, match=rf"servo {servo} \(joint '{name}'\): expected kp .*0\.\.{top}, "
                                              rf"got {top + 1}; nothing was written"):
            arm.set_servo_gains(1, kp=top + 1, ki=1)
        for bad in (-1, 2.5, float("nan"), "800", True):
            with pytest.raises(OptionError):
                arm.set_servo_gains(1, kd=bad)
        with pytest.raises(OptionError, match="expected a joint name"):
            arm.set_servo_gains("nojoint", kp=1)
        assert arm.servo_gains()[name] == new  # nothing written by the refused calls
    assert emu.get(servo, field) == defaults["kp"] and emu.get(servo, emu.bus.GAINS["kd"][0]) == defaults["kd"]


def test_every_gain_range_fits_its_register_and_the_feetech_coefficients_are_one_byte_0_to_254():
    """Issue 41: the STS3215 position-loop P/D/I (addresses 21/22/23) are one byte each, 0..254 (sources in _feetech.py)."""
    for name in ("dynamixel", "feetech"):
        bus = bus_module(name)
        for gain, (field, top, _) in bus.GAINS.items():
            assert 0 < top < 2 ** (8 * bus.TABLE[field][1]), (name, gain)
    fee = bus_module("feetech")
    assert {g: (fee.TABLE[f], top) for g, (f, top, _) in fee.GAINS.items()} == {
        "kp": ((21, 1), 254), "kd": ((22, 1), 254), "ki": ((23, 1), 254)}


@pytest.mark.parametrize("gain", ["kp", "ki", "kd"])
def test_a_gain_at_its_limit_is_written_and_one_past_it_is_refused_naming_the_servo_and_field(robot_file, kind, gain):
    with Arm(robot_file, _url(robot_file, kind)) as arm:
        emu = arm.port.emulator
        field, top, _ = emu.bus.GAINS[gain]
        servo, name = arm.robot.links[2].bus.id, arm.robot.joint_names[2]
        assert getattr(arm.set_servo_gains(2, **{gain: top}), gain) == top and emu.get(servo, field) == top
        for bad in (top + 1, -1):
            with pytest.raises(OptionError, match=rf"^servo {servo} \(joint '{name}'\): expected {gain} \({field}\) a "
                                                  rf"whole number 0\.\.{top}, got {bad}; nothing was written$"):
                arm.set_servo_gains(name, **{gain: bad})
        assert emu.get(servo, field) == top


def test_a_hobby_servo_arm_has_no_gains_to_reach():
    with Arm("arduino_arm_3dof", "sim://?clock=lockstep") as arm:
        with pytest.raises(DeviceError, match="expected an arm on a servo bus"):
            arm.servo_gains()
        with pytest.raises(DeviceError, match="expected an arm on a servo bus"):
            arm.set_servo_gains(0, kp=1)


def _step_overshoot(arm, dq):
    """Overshoot [%] of joint 0's present position after a 1 ms step of ``dq`` [rad] of its goal."""
    q0 = [round(math.degrees(v) * 100) for v in arm.commanded_joints()]
    q1 = list(q0)
    q1[0] += round(math.degrees(dq) * 100)

    def hold(q, ms):
        return ms, 3, [c for v in q for c in (v, 0, 0, 0)]

    step = (1, 3, [c for a, b in zip(q0, q1) for c in (a, 0, 3 * (b - a), -2 * (b - a))])
    arm.run_trajectory([hold(q0, 60), step, hold(q1, 600)], wait=False)
    df = arm.stream(0.6, hz=200)
    y = df[f"q_{arm.robot.joint_names[0]}"].to_numpy()
    goal = math.radians(q1[0] / 100)
    assert abs(np.mean(y[-20:]) - goal) < math.radians(0.2)  # settled on the goal (no load about the first axis)
    overshoot = (y.max() - goal) / (goal - y[0]) * 100
    arm.sleep(0.2)
    return overshoot


def test_a_gain_change_changes_the_measured_overshoot_as_the_loop_model_predicts(tmp_path, robot_file, kind):
    # no speed limits in the robot file: the goal is a true step (the servo's profile does not ramp it)
    step_file = tmp_path / "step.toml"
    step_file.write_text(re.sub(r"^max_(velocity|acceleration).*\n", "", Path(robot_file).read_text(), flags=re.M))
    cases, dq = CASES[kind]
    measured, predicted = [], []
    with Arm(str(step_file), _url(step_file, kind)) as arm:
        emu = arm.port.emulator
        for gains in cases:
            now = arm.set_servo_gains(0, **gains)
            plant = loop_plant(arm.robot, 0, emu.bus, emu.model.servos.position, emu.model.config)
            predicted.append(control.step_info(position_loop(plant, now.to_dict()))["Overshoot"])
            measured.append(_step_overshoot(arm, dq))
    print(kind, "measured", np.round(measured, 1), "predicted", np.round(predicted, 1))
    assert np.allclose(measured, predicted, atol=TOLERANCE), (measured, predicted)
    assert measured[1] > measured[0] + 5 and measured[2] < measured[1] - 2  # more P: more; then D: less overshoot


def test_a_loaded_servo_droops_by_load_over_stiffness_until_integral_gain_removes_it():
    robot = "tests/arm/bus/omx_test.toml"
    with Arm(robot, _url(robot, "dynamixel")) as arm:
        emu = arm.port.emulator
        loops = emu.model.servos
        loops.gravity = True  # the loops carry the gravity load (BusEmulator(servo_load=True))
        arm.sleep(1.0)
        q = loops.position
        _, load = loops._pose()
        plant = loop_plant(arm.robot, 1, emu.bus, q, emu.model.config)
        kp, _, _ = plant.stiffness(arm.servo_gains()["shoulder"].to_dict())
        droop = arm.read_joints()[1] - arm.commanded_joints()[1]
        assert abs(load[1]) > 0.1 and droop == pytest.approx(load[1] / kp, abs=math.radians(0.1))
        arm.set_servo_gains("shoulder", ki=2000)
        arm.sleep(2.0)
        assert abs(arm.read_joints()[1] - arm.commanded_joints()[1]) < math.radians(0.1)
