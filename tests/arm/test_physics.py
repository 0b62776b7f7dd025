"""Tests of labkit.arm: servo dynamics, sag, offsets, noise, ruler, firmware adapter."""

import math

import numpy as np
import pytest

from labkit.robot import Robot, ServoCalibration
from labkit.kinematics import fk_position
from labkit.arm import ADC_MAX, ADC_VREF, ArmModel, FirmwareAdapter, PhysicsConfig, ServoBank, gravity_sag

ARM = Robot.load("arduino_arm_3dof")


def quiet(**kw):
    """A noise-free, offset-free, sag-free config (plus changes)."""
    base = dict(zero_offsets=(0.0, 0.0, 0.0), joint_compliance=0.0, feedback_noise=0.0, ruler_noise=0.0, deadband=0.0)
    base.update(kw)
    return PhysicsConfig(**base)


def test_step_response_matches_second_order():
    cfg = quiet(natural_frequency=20.0, damping_ratio=0.5, rate_limit=100.0)
    bank = ServoBank(ARM, cfg)
    bank.command([0.0, 0.2, 0.0])
    ys = []
    for _ in range(400):
        bank.step()
        ys.append(bank.position[1])
    ys = np.array(ys)
    overshoot = ys.max() / 0.2 - 1
    expected = math.exp(-math.pi * 0.5 / math.sqrt(1 - 0.25))  # 16.3 %
    assert overshoot == pytest.approx(expected, abs=0.01)
    assert ys[-1] == pytest.approx(0.2, abs=1e-6)
    assert np.allclose(bank.position[[0, 2]], 0.0)


def test_transfer_function_is_discretised_with_dt():
    bank = ServoBank(ARM, quiet(dt=0.01))
    assert bank.transfer_function.dt == 0.01
    assert float(bank.transfer_function.dcgain()) == pytest.approx(1.0)


def test_rate_limit_bounds_speed():
    cfg = quiet(natural_frequency=200.0, damping_ratio=1.0, rate_limit=1.0, dt=0.001)
    bank = ServoBank(ARM, cfg)
    bank.command([0.0, 2.0, 0.0])
    speeds = []
    for _ in range(1000):
        bank.step()
        speeds.append(bank.velocity[1])
    assert max(speeds) <= 1.0 + 1e-6
    assert max(speeds) > 0.95
    assert bank.position[1] == pytest.approx(1.0, abs=0.02)  # 1 s at 1 rad/s, minus the lag


def test_default_rate_limit_comes_from_robot_file():
    bank = ServoBank(ARM, quiet(natural_frequency=300.0, damping_ratio=1.0, dt=0.001))
    bank.command([3.0, 0.0, 0.0])
    bank.advance(0.2)
    assert bank.position[0] == pytest.approx(0.2 * math.radians(300), rel=0.05)


def test_deadband_ignores_small_commands():
    db = math.radians(0.5)
    bank = ServoBank(ARM, quiet(deadband=db))
    bank.command([0.0, 0.6 * db, 0.0])
    bank.advance(1.0)
    assert bank.position[1] == 0.0
    bank.command([0.0, 3 * db, 0.0])
    bank.advance(1.0)
    assert bank.position[1] == pytest.approx(3 * db, abs=1e-6)
    assert bank.settled()


def test_sag_lowers_the_gripper_along_gravity():
    q = np.radians([[0, 0, 0], [0, 45, 0], [30, 0, 45], [0, 90, 0]])
    cfg = PhysicsConfig()
    dq = gravity_sag(ARM, q, cfg)
    drop = fk_position(ARM, q + dq) - fk_position(ARM, q)
    g = -np.asarray(ARM.up)  # the default gravity: along -up (+z0 for this arm)
    np.testing.assert_array_equal(g, [0, 0, 1])
    along = drop @ g
    assert np.all(along[:3] > 1e-3) and np.all(along[:3] < 10e-3)  # a few mm, downwards
    assert abs(along[3]) < 1e-6  # arm hanging along gravity: no torque
    assert np.all(dq[:, 0] == 0.0)  # yaw axis parallel to gravity


def test_sag_scales_with_compliance_and_flips_with_gravity():
    q = np.radians([0, 20, 10])
    a = gravity_sag(ARM, q, PhysicsConfig(joint_compliance=0.02))
    b = gravity_sag(ARM, q, PhysicsConfig(joint_compliance=0.04))
    c = gravity_sag(ARM, q, PhysicsConfig(joint_compliance=0.04, gravity=(0, 0, -9.81)))
    np.testing.assert_allclose(b, 2 * a)
    np.testing.assert_allclose(c, -b)


def test_gravity_follows_the_robot_files_up():
    q = np.radians([0, 20, 10])
    assert PhysicsConfig().gravity is None
    np.testing.assert_array_equal(gravity_sag(ARM, q), gravity_sag(ARM, q, PhysicsConfig(gravity=(0, 0, 9.81))))
    puma = Robot.load("puma560")  # stands on its base: up = +z0, so gravity is -z
    np.testing.assert_allclose(puma.up, [0, 0, 1])
    for j in range(puma.n):  # driven by servos (its file's joints are ideal actuators, which do not yield)
        puma = puma.with_link(j, servo=ServoCalibration(channel=j, zero=90.0))
    qp = np.radians([0, 0, -90, 0, 0, 0])  # rtb's "ready" pose rotated down: upper arm horizontal
    dq = gravity_sag(puma, qp)
    np.testing.assert_array_equal(dq, gravity_sag(puma, qp, PhysicsConfig(gravity=(0, 0, -9.81))))
    drop = fk_position(puma, qp + dq) - fk_position(puma, qp)
    assert drop[2] < -1e-5  # the tool sags down, towards the floor (0.2 mm: its geared drives hold it)
    with pytest.raises(ValueError, match="3 finite components or None"):
        PhysicsConfig(gravity=(0, 9.81))


def test_offsets_are_seeded():
    a = ArmModel(ARM, PhysicsConfig(seed=7)).zero_offsets
    b = ArmModel(ARM, PhysicsConfig(seed=7)).zero_offsets
    c = ArmModel(ARM, PhysicsConfig(seed=8)).zero_offsets
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)
    assert np.all(np.abs(a) < math.radians(5))
    d = ArmModel(ARM, PhysicsConfig(zero_offsets=(0.01, -0.02, 0.03))).zero_offsets
    np.testing.assert_array_equal(d, [0.01, -0.02, 0.03])


def test_true_joint_includes_offset_but_feedback_does_not():
    off = (0.02, -0.03, 0.01)
    arm = ArmModel(ARM, quiet(zero_offsets=off))
    arm.command(np.radians([40, 30, 20]))
    arm.advance(2.0)
    np.testing.assert_allclose(arm.true_q - arm.shaft_q, off, atol=1e-9)
    # feedback: the pot reads the shaft, within one ADC count
    np.testing.assert_allclose(arm.sensed_q(), np.radians([40, 30, 20]), atol=math.radians(0.25))


def test_feedback_noise_level_and_quantisation():
    arm = ArmModel(ARM, PhysicsConfig(seed=1, feedback_noise=2.0))
    arm.command(np.radians([90, 90, 90]))
    arm.advance(2.0)
    adc = np.array([arm.feedback_adc() for _ in range(500)])
    assert adc.dtype.kind == "i" and adc.min() >= 0 and adc.max() <= ADC_MAX
    assert adc[:, 1].std() == pytest.approx(2.0, rel=0.15)
    volts = arm.feedback_volts()
    assert set(volts) == {0, 1, 2}
    assert all(0.0 <= v <= ADC_VREF for v in volts.values())


def test_ruler_resolution_and_accuracy():
    arm = ArmModel(ARM, PhysicsConfig(seed=0))
    arm.command(np.radians([45, 30, 10]))
    arm.advance(2.0)
    r = arm.ruler(400)
    assert r.shape == (400, 3)
    steps = r / 0.5e-3
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)
    np.testing.assert_allclose(r.mean(axis=0), arm.end_effector(), atol=0.1e-3)
    exact = ArmModel(ARM, quiet(ruler_resolution=0.0)).ruler(1)
    np.testing.assert_allclose(exact[0], fk_position(ARM, np.zeros(3)), atol=1e-12)


def test_seeded_runs_repeat():
    def run(seed):
        arm = ArmModel(ARM, PhysicsConfig(seed=seed))
        arm.command([0.3, 0.4, 0.5])
        arm.advance(1.0)
        return np.concatenate([arm.ruler(3).ravel(), arm.feedback_adc()])

    np.testing.assert_array_equal(run(4), run(4))
    assert not np.array_equal(run(4), run(5))


def test_commands_are_clipped_to_the_servo_travel():
    arm = ArmModel(ARM, quiet())
    arm.command([-1.0, 4.0, 1.0])
    arm.advance(3.0)
    np.testing.assert_allclose(arm.shaft_q, [0.0, math.pi, 1.0], atol=1e-4)


def test_firmware_adapter_maps_pulses_to_feedback_volts():
    fw = FirmwareAdapter(ARM, quiet(), feedback_pins={0: 14, 1: 15, 2: 16})
    volts = None
    for k in range(1, 201):
        volts = fw.on_tick(0.01 * k, {0: 1500.0, 1: 1000.0, 2: 2000.0, 3: 1900.0})
    q = [float(ARM.links[j].servo.joint_from_pulse(us)) for j, us in enumerate((1500.0, 1000.0, 2000.0))]
    np.testing.assert_allclose(fw.model.shaft_q, q, atol=1e-4)
    assert set(volts) == {14, 15, 16}
    for j, pin in enumerate((14, 15, 16)):
        expected = round(float(ARM.links[j].servo.adc_from_joint(q[j]))) * ADC_VREF / ADC_MAX
        assert volts[pin] == pytest.approx(expected, abs=ADC_VREF / ADC_MAX + 1e-9)
    assert fw.model.time == pytest.approx(2.0)


def test_config_validation_messages():
    with pytest.raises(ValueError, match="expected dt > 0"):
        PhysicsConfig(dt=0.0)
    with pytest.raises(ValueError, match="expected feedback_noise >= 0"):
        PhysicsConfig(feedback_noise=-1)
    with pytest.raises(ValueError, match="expected zero_offsets as a scalar or 3 values"):
        ArmModel(ARM, PhysicsConfig(zero_offsets=(0.1, 0.2)))


@pytest.mark.firmware
@pytest.mark.slow
@pytest.mark.xdist_group("firmware")
def test_same_physics_drives_the_firmware_in_simavr():
    """Firmware-in-the-loop: real firmware pulses -> FirmwareAdapter -> feedback volts -> READ.

    The port is stepped (``clock="lockstep"``): simulated time runs only while the host waits, so
    the host's STATUS polls during the timed MOVE reach the firmware at the same simulated times on
    a loaded machine as on an idle one (its 500 ms host-silence timer never sees a slow host).
    """
    from labkit.arm import FirmwareSim, SimavrPort
    from labkit.arm import Arm

    adapter = FirmwareAdapter(ARM, PhysicsConfig(seed=0))
    with FirmwareSim(on_tick=adapter.on_tick, tick_period=0.005) as sim:
        port = sim.open_port(baudrate=115200, timeout=0.05)
        assert isinstance(port, SimavrPort) and port.clock == "lockstep" and sim.stepped
        with Arm("arduino_arm_3dof", port, timeout=0.5) as arm:
            np.testing.assert_allclose(arm.read_joints(), np.radians([90, 90, 90]), atol=math.radians(1.5))
            arm.move_joints(np.radians([30.0, 60.0, 120.0]))
            t_moved = sim.time()
            sim.sleep(1.5)
            sensed = arm.read_joints()
            assert not any(name == "HOLD" for name, _ in arm.events), arm.events
        t_sim = sim.time()
    assert t_sim - t_moved >= 1.5  # the host's waits were simulated time
    # within the deadband (0.45 deg) plus ADC noise (a few counts of 0.22 deg)
    np.testing.assert_allclose(sensed, np.radians([30.0, 60.0, 120.0]), atol=math.radians(1.5))
    np.testing.assert_allclose(adapter.model.shaft_q, np.radians([30.0, 60.0, 120.0]), atol=math.radians(0.5))
    assert adapter.model.time == pytest.approx(t_sim, abs=0.05)


@pytest.mark.firmware
@pytest.mark.slow
@pytest.mark.xdist_group("firmware")
def test_simavr_url_with_physics_closes_the_loop_like_sim():
    """``simavr://?physics=...``: the same arm model behind the real firmware, from a URL."""
    import serial

    from labkit.arm import Arm
    from labkit.arm.urlhandler import register

    register()
    port = serial.serial_for_url("simavr://?physics=arduino_arm_3dof&seed=1", baudrate=115200, timeout=0.05)
    assert isinstance(port.physics, FirmwareAdapter)
    assert port.clock == "lockstep"  # the default with pace=0: the link waits in simulated time
    with Arm("arduino_arm_3dof", port, timeout=0.5) as arm:
        arm.move_joints(np.radians([30.0, 60.0, 120.0]))
        assert abs(arm.ping() - port.board_time) < 0.005  # the link's clock is the board's (ms + the reply)
        port.sim.sleep(1.5)
        sensed = arm.read_joints()
        shaft = port.physics.model.shaft_q.copy()
        assert not any(name == "HOLD" for name, _ in arm.events), arm.events
    np.testing.assert_allclose(sensed, np.radians([30.0, 60.0, 120.0]), atol=math.radians(1.5))
    np.testing.assert_allclose(shaft, np.radians([30.0, 60.0, 120.0]), atol=math.radians(0.5))


def test_simavr_url_options_are_checked():
    from serial import SerialException

    from labkit.arm.urlhandler.protocol_simavr import parse_url

    assert parse_url("simavr://?physics=1&seed=4") == (
        None, {"pace": 0.0, "tick": 0.005, "physics": "arduino_arm_3dof", "seed": 4, "clock": "lockstep"})
    assert parse_url("simavr://fw.elf?physics=0")[1]["physics"] == ""
    assert parse_url("simavr://?pace=1")[1]["clock"] == "realtime"  # paced: the wall clock leads
    assert parse_url("simavr://?clock=realtime")[1] == {**parse_url("simavr://")[1], "clock": "realtime"}
    with pytest.raises(SerialException, match=r"clock=lockstep.*cannot also be paced"):
        parse_url("simavr://?pace=1&clock=lockstep")
    with pytest.raises(SerialException, match=r"option 'clock'.*one of lockstep, realtime, got 'wall'"):
        parse_url("simavr://?clock=wall")
    with pytest.raises(SerialException, match=r"option 'seed'.*must be an integer, got '1.5'"):
        parse_url("simavr://?seed=1.5")
    with pytest.raises(SerialException, match=r"unknown option 'robot'.*valid options"):
        parse_url("simavr://?robot=x")
