"""A recorded step against a linear model's prediction (``StepRecord.response`` / ``overshoot``), and on a virtual
servo bus: the servos' own loop gains changed through ``Arm``, each step predicted by the loop model.

The bus check is the control lab's (``08_control``): the servo's position loop
(:func:`labkit.arm.bus.position_loop` on :func:`labkit.arm.bus.loop_plant`) is the prediction, made before the
step with the gains read back from the servo; the step is small enough for the loop's output to stay below full
scale (half the stall torque at the stiffest gains). Tolerance on the overshoot: 3 percentage points plus one
encoder tick in percent of the step.
"""

import math

import control
import numpy as np
import pytest

from labkit.control import StepRecord, rate_limited_steps, record_step
from labkit.exceptions import OptionError, ShapeError


def _record(wn=20.0, zeta=0.4, delay=0.01, amplitude=0.2, rate=None):
    t = np.arange(-0.1, 0.8, 0.005)
    u = rate_limited_steps(t, 0.3, [(0.0, 0.3 + amplitude), (0.5, 0.3)], rate)
    system = control.tf([wn**2], [1, 2 * zeta * wn, wn**2])
    _, y = control.forced_response(system, T=t - t[0], U=np.interp(t - delay, t, u) - 0.3)
    return StepRecord("j", t, 0.3 + y, u, amplitude, rate), system


@pytest.mark.parametrize("amplitude", [0.2, -0.05])
def test_a_model_predicts_its_own_record_and_its_overshoot_is_the_closed_form(amplitude):
    rec, system = _record(amplitude=amplitude)
    assert np.abs(rec.response(system, delay=0.01) - rec.y).max() < 1e-3 * abs(amplitude)
    assert np.abs(rec.response(system) - rec.y).max() > 0.1 * abs(amplitude)  # the dead time matters
    zeta = 0.4
    closed_form = 100 * math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2))
    assert rec.overshoot() == pytest.approx(closed_form, abs=0.3)  # sampled at 5 ms
    assert rec.overshoot(rec.response(system, delay=0.01)) == pytest.approx(rec.overshoot(), abs=0.05)


def test_an_overdamped_response_stays_short_and_a_rate_limited_command_is_followed():
    rec, system = _record(zeta=1.5, rate=2.0)
    assert rec.overshoot() < 0
    assert rec.rest() == pytest.approx(0.3)
    assert np.abs(rec.response(system, delay=0.01) - rec.y).max() < 2e-4


def test_bad_models_and_responses_are_refused():
    rec, system = _record()
    with pytest.raises(OptionError, match="one input and one output"):
        rec.response(np.ones(3))
    with pytest.raises(OptionError, match="delay"):
        rec.response(system, delay=-0.1)
    with pytest.raises(ShapeError, match="one value per sample"):
        rec.overshoot(rec.y[:-1])


@pytest.mark.parametrize("robot, kind", [("openmanipulator_x", "dynamixel"), ("so101", "feetech")])
def test_a_gain_written_to_a_virtual_bus_servo_changes_the_step_as_its_loop_model_predicts(robot, kind):
    from labkit.arm import Arm, PhysicsConfig
    from labkit.arm.bus import bus_module, loop_plant, position_loop

    with Arm(robot, f"sim://{robot}?bus={kind}&clock=lockstep") as arm:
        bus, joint, q = bus_module(arm.robot.bus.protocol), 1, np.asarray(arm.read_joints())
        found = arm.servo_gains()[arm.robot.joint_names[joint]].to_dict()
        plant = loop_plant(arm.robot, joint, bus, q, PhysicsConfig())
        amplitude = -0.5 * bus.MOTOR["stall_torque"] / plant.stiffness(found)[0]
        tick = 100 * 2 * math.pi / arm.robot.links[joint].bus.resolution / abs(amplitude)  # % of the step
        measured, predicted = [], []
        for gains in (found, {**found, "kp": found["kp"] // 2}):
            now = arm.set_servo_gains(joint, **gains).to_dict()
            rec = record_step(arm, joint, amplitude)
            model = rec.response(position_loop(plant, now), delay=rec.fit().delay)
            measured.append(rec.overshoot())
            predicted.append(rec.overshoot(model))
            assert np.sqrt(np.mean((model - rec.y) ** 2)) < 0.1 * abs(amplitude)
    print(kind, "overshoot measured", np.round(measured, 1), "predicted", np.round(predicted, 1), "tick %", round(tick, 1))
    assert np.allclose(measured, predicted, atol=3.0 + tick)
    assert measured[0] - measured[1] > 5 and predicted[0] - predicted[1] > 5  # less P: less overshoot, as predicted
