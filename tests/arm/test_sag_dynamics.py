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
    from labkit.arm.bus._dynamixel import CURRENT_UNIT, TORQUE_CONSTANT
    from labkit.arm.bus._emulator import BusEmulator
    from labkit.robot import LinkInertia

    omx = Robot.load("openmanipulator_x")
    for j in range(omx.n):  # inertias on every link (the bundled file has none yet)
        omx = omx.with_link(j, inertial=LinkInertia(0.15, (-0.03, 0.0, 0.01), (1e-4, 2e-4, 2e-4, 0, 0, 0)))
    cfg = PhysicsConfig(deadband=0.0, tool_mass=0.1)
    with BusEmulator(omx, cfg) as emu:
        for lk in omx.links:
            emu._put(lk.bus.id, "torque_enable", 1)
        emu._fresh = None
        emu._refresh()
        q = emu.model.shaft_q
        amps = -gravity_torques(omx.with_payload(0.1), q) / TORQUE_CONSTANT * np.array([lk.bus.direction for lk in omx.links])
        raw = [emu.get(lk.bus.id, "present_current") for lk in omx.links]
        counts = np.array([r - 65536 if r >= 32768 else r for r in raw])  # 16-bit two's complement
    assert np.array_equal(counts, np.rint(amps / CURRENT_UNIT).astype(int))
    assert np.abs(counts).max() > 10


def test_a_geared_drive_sags_by_the_compliance_over_its_gear_ratio_squared():
    """The PUMA 560's motors (G = 53.7 to 107.8) hold its joints: sag = compliance / G^2 x gravity torque."""
    puma = Robot.load("puma560")
    q = np.array([0.0, 0.4, -0.3, 0.0, 0.5, 0.0])
    config = PhysicsConfig(tool_mass=0.0)
    gears = np.array([lk.motor.gear_ratio for lk in puma.links])
    expected = -config.joint_compliance / gears**2 * gravity_torques(puma, q)
    np.testing.assert_allclose(gravity_sag(puma, q, config), expected, rtol=1e-12, atol=1e-15)
    assert np.abs(gravity_sag(puma, q, config)).max() < np.radians(0.1)  # a PUMA barely yields
