"""The virtual arm's gravity sag comes from labkit.dynamics where the robot file has inertias."""

import numpy as np

from labkit.arm.board._physics import PhysicsConfig, gravity_sag
from labkit.dynamics import gravity_torques
from labkit.robot import Robot


def test_sag_is_compliance_times_the_dynamics_gravity_torques():
    arm = Robot.load("arduino_arm_3dof")
    q = np.random.default_rng(2).uniform(0.2, 2.8, (7, 3))
    cfg = PhysicsConfig(joint_compliance=(0.01, 0.04, 0.03), tool_mass=0.12)
    expected = -np.array(cfg.joint_compliance) * gravity_torques(arm.with_payload(0.12), q)
    assert np.allclose(gravity_sag(arm, q, cfg), expected, rtol=1e-12, atol=1e-15)
    # the seed arm's assumed inertias are the old lumped model (50 g at mid-link): the same sag
    lumped = gravity_sag(arm, q, PhysicsConfig(link_masses=(0.05, 0.05, 0.05), tool_mass=0.12,
                                               joint_compliance=cfg.joint_compliance))
    assert np.allclose(gravity_sag(arm, q, cfg), lumped, rtol=1e-12, atol=1e-15)
    assert np.abs(lumped).max() > 1e-3


def test_a_virtual_bus_reports_the_current_of_the_dynamics_gravity_torque():
    """Present current = the torque that holds the arm (gravity_torques, tool mass as a payload) over the
    robot file's torque constant: torques_from_current reads it back as the dynamics' torque."""
    from labkit.arm.bus._dynamixel import CURRENT_UNIT
    from labkit.arm.bus._emulator import BusEmulator
    from labkit.dynamics import torques_from_current

    omx = Robot.load("openmanipulator_x")  # inertias from its URDF, torque_constant from the XM430 datasheet
    assert [lk.bus.torque_constant for lk in omx.links] == [1.78] * 4
    cfg = PhysicsConfig(deadband=0.0, tool_mass=0.1)
    with BusEmulator(omx, cfg, q0=[0.3, -0.4, 0.6, 0.2]) as emu:
        for lk in omx.links:
            emu._put(lk.bus.id, "torque_enable", 1)
        emu._fresh = None
        emu._refresh()
        q = emu.model.shaft_q
        raw = [emu.get(lk.bus.id, "present_current") for lk in omx.links]
    counts = np.array([r - 65536 if r >= 32768 else r for r in raw])  # 16-bit two's complement
    truth = gravity_torques(omx.with_payload(0.1), q)
    assert np.array_equal(counts, np.rint(truth / 1.78 / CURRENT_UNIT).astype(int))
    assert np.abs(counts).max() > 50
    # read back as torque: the dynamics' holding torque to within one current count
    np.testing.assert_allclose(torques_from_current(omx, counts * CURRENT_UNIT), truth, atol=1.78 * CURRENT_UNIT)


def test_a_servo_direction_flips_the_current_not_the_torque():
    from labkit.arm.bus._emulator import BusEmulator
    from labkit.dynamics import torques_from_current

    omx = Robot.load("openmanipulator_x")
    flipped = omx.with_link(1, bus=omx.links[1].bus.__class__(12, 2048, -1, 4096, 4.1, 1.78))
    readings = []
    for robot in (omx, flipped):
        with BusEmulator(robot, PhysicsConfig(deadband=0.0), q0=[0.0, 0.5, 0.5, 0.0]) as emu:
            emu._put(12, "torque_enable", 1)
            emu._fresh = None
            emu._refresh()
            raw = emu.get(12, "present_current")
            readings.append(raw - 65536 if raw >= 32768 else raw)
    assert readings[0] == -readings[1] != 0
    amps = np.array([0.0, readings[1] * 2.69e-3, 0.0, 0.0])
    assert np.sign(torques_from_current(flipped, amps)[1]) == np.sign(readings[0])


def test_torques_from_current_needs_a_torque_constant():
    import pytest

    from labkit.dynamics import torques_from_current
    from labkit.exceptions import RobotError

    with pytest.raises(RobotError, match=r"joint 1 \(base_yaw\).*torque_constant"):
        torques_from_current(Robot.load("arduino_arm_3dof"), [0.1, 0.1, 0.1])


def test_a_geared_drive_sags_by_the_compliance_over_its_gear_ratio_squared():
    """The PUMA 560's motors (G = 53.7 to 107.8), driven as servos, hold its joints: sag = compliance / G^2 x gravity
    torque; as the robot file has it (no servo tables: ideal actuators) it does not yield at all."""
    from labkit.robot import ServoCalibration

    puma = Robot.load("puma560")
    q = np.array([0.0, 0.4, -0.3, 0.0, 0.5, 0.0])
    config = PhysicsConfig(tool_mass=0.0)
    assert np.array_equal(gravity_sag(puma, q, config), np.zeros(6))
    servos = puma
    for j in range(puma.n):
        servos = servos.with_link(j, servo=ServoCalibration(channel=j, zero=90.0))
    gears = np.array([lk.motor.gear_ratio for lk in puma.links])
    expected = -config.joint_compliance / gears**2 * gravity_torques(puma, q)
    np.testing.assert_allclose(gravity_sag(servos, q, config), expected, rtol=1e-12, atol=1e-15)
    assert 0 < np.abs(gravity_sag(servos, q, config)).max() < np.radians(0.1)  # a PUMA barely yields


def test_an_ideal_actuator_holds_a_heavy_link_without_sagging(tmp_path):
    """UR10-like links (12.7 kg, 0.61 m) on joints without a servo: a hobby servo's compliance (0.04 rad/(N m))
    would sag them by radians (the FK check of such an arm was off by 0.6 m); an ideal actuator holds its joint,
    while a servo on the same joint yields by its compliance times the gravity torque."""
    from labkit.robot import ServoCalibration

    text = ('format = "labkit-robot/1"\nname = "heavy2r"\nconvention = "standard"\n'
            '[[joint]]\nalpha = 1.5707963267948966\nd = 0.1273\n'
            '[[joint]]\na = -0.612\nmass = 12.7\ncom = [0.38, 0.0, 0.158]\n')
    path = tmp_path / "heavy2r.toml"
    path.write_text(text)
    arm = Robot.load(path)
    q = np.array([0.3, -1.0])
    config = PhysicsConfig()
    assert np.array_equal(gravity_sag(arm, q, config), np.zeros(2))
    servo = arm.with_link(1, servo=ServoCalibration(channel=1, zero=90.0))
    torque = gravity_torques(servo.with_payload(config.tool_mass), q)
    np.testing.assert_allclose(gravity_sag(servo, q, config), [0.0, -config.joint_compliance * torque[1]], rtol=1e-12)
    assert abs(torque[1]) > 10.0  # N m: what made the sag radians


def test_link_masses_are_point_masses_at_mid_link_fed_to_the_dynamics(tmp_path):
    """A standard-DH 2R arm in a vertical plane: the sag of point masses at mid-link against the textbook torques."""
    from labkit.arm.board import point_mass_links

    path = tmp_path / "vertical2r.toml"
    path.write_text('format = "labkit-robot/1"\nname = "vertical2r"\nconvention = "standard"\n'
                    'units = { length = "mm", angle = "deg" }\nup = [0, 1, 0]\n'
                    '[[joint]]\na = 300\nlimits = [-90, 90]\nservo = { channel = 0, zero = 90 }\n'
                    '[[joint]]\na = 200\nlimits = [-90, 90]\nservo = { channel = 1, zero = 90 }\n')
    arm = Robot.load(path)  # hobby servos (an ideal actuator does not yield)
    m1, m2, tool, l1, l2, g = 0.4, 0.25, 0.1, 0.3, 0.2, 9.81
    q = np.random.default_rng(3).uniform(-2.5, 2.5, (6, 2))
    c1, c12 = np.cos(q[:, 0]), np.cos(q[:, 0] + q[:, 1])
    tau = np.column_stack([m1 * g * l1 / 2 * c1 + m2 * g * (l1 * c1 + l2 / 2 * c12) + tool * g * (l1 * c1 + l2 * c12),
                           m2 * g * l2 / 2 * c12 + tool * g * l2 * c12])
    cfg = PhysicsConfig(link_masses=(m1, m2), tool_mass=tool, joint_compliance=(0.02, 0.05))
    np.testing.assert_allclose(gravity_sag(arm, q, cfg), -np.array([0.02, 0.05]) * tau, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose([lk.inertial.com for lk in point_mass_links(arm, (m1, m2)).links],
                               [[-l1 / 2, 0, 0], [-l2 / 2, 0, 0]], atol=1e-15)  # frame i sits at the link's far end
