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
