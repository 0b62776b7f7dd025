"""Inertial parameters in robot files (mass, com, inertia, motor), LinkInertia/Motor, with_payload."""

import numpy as np
import pytest

from labkit.exceptions import RobotError, RobotFileError
from labkit.kinematics import jacobian
from labkit.robot import LinkInertia, Motor, Robot

FILE = """format = "labkit-robot/1"
name = "two"
convention = "standard"
units = { length = "mm", angle = "deg" }

[[joint]]
a = 300
mass = 2.0
com = [-150, 0, 10]
inertia = [1000, 20000, 20000, 0, 0, 5]
motor = { inertia = 2e-5, gear_ratio = -50, viscous = 1e-4, coulomb = [0.01, -0.02] }

[[joint]]
a = 200
mass = 1.0
com = [-100, 0, 0]
"""


def _write(tmp_path, text, name="two.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_keys_load_in_si_units(tmp_path):
    robot = Robot.load(_write(tmp_path, FILE))
    first, second = robot.links
    assert first.inertial.mass == 2.0
    assert np.allclose(first.inertial.com, [-0.15, 0, 0.01])
    assert np.allclose(first.inertial.matrix, [[1e-3, 0, 5e-6], [0, 2e-2, 0], [5e-6, 0, 2e-2]])
    assert first.motor == Motor(2e-5, -50.0, 1e-4, (0.01, -0.02))
    assert second.inertial.inertia == (0.0,) * 6 and second.motor is None
    again = Robot.load(_write(tmp_path, robot.to_toml(), "again.toml"))
    assert again.links == robot.links
    metres = Robot.load(_write(tmp_path, robot.to_toml(length_unit="m"), "m.toml"))
    assert np.allclose(metres.links[0].inertial.matrix, first.inertial.matrix, rtol=1e-14, atol=0)


def test_a_robot_without_inertias_round_trips_without_them():
    arm = Robot.load("planar3r_seed004")
    assert all(lk.inertial is None and lk.motor is None for lk in arm.links)
    assert "mass =" not in arm.to_toml() and "motor =" not in arm.to_toml()


@pytest.mark.parametrize("old, new, field, message", [
    ("mass = 1.0\n", "mass = -1.0\n", "joint[2].mass", "mass >= 0"),
    ("mass = 1.0\n", "", "joint[2].mass", "missing"),
    ("mass = 1.0\n", "mass = 1.0\nmasse = 2\n", "joint[2].masse", "unknown key"),
    ("com = [-100, 0, 0]", "com = [-100, 0]", "joint[2].com", "list of 3 numbers"),
    ("inertia = [1000, 20000, 20000, 0, 0, 5]", "inertia = [1000, 20000, 20000, 0, 0, 50000]", "joint[1].inertia",
     "positive semi-definite"),
    ("inertia = [1000, 20000, 20000, 0, 0, 5]", "inertia = [1000, 20000]", "joint[1].inertia", "list of 6 numbers"),
    ("gear_ratio = -50", "gear_ratio = 0", "joint[1].motor.gear_ratio", "non-zero"),
    ("gear_ratio = -50", "gear = -50", "joint[1].motor.gear", "unknown key"),
    ("coulomb = [0.01, -0.02]", "coulomb = [-0.01, -0.02]", "joint[1].motor.coulomb", "plus >= 0"),
    ("viscous = 1e-4", "viscous = true", "joint[1].motor.viscous", "finite number"),
])
def test_bad_inertial_keys_name_the_field(tmp_path, old, new, field, message):
    assert old in FILE
    with pytest.raises(RobotFileError, match=message) as info:
        Robot.load(_write(tmp_path, FILE.replace(old, new, 1)))
    assert info.value.field == field


def test_link_inertia_and_motor_check_their_fields():
    with pytest.raises(RobotError, match="mass >= 0"):
        LinkInertia(-1.0)
    with pytest.raises(RobotError, match="positive semi-definite"):
        LinkInertia(1.0, (0, 0, 0), (1, 1, 1, 2, 0, 0))
    with pytest.raises(RobotError, match="3 numbers"):
        LinkInertia(1.0, (0, 0))
    with pytest.raises(RobotError, match="non-zero"):
        Motor(gear_ratio=0)
    I = LinkInertia.from_matrix(2.0, [0, 0, 1], [[1, 0.1, 0], [0.1, 2, 0], [0, 0, 3]])
    assert I.inertia == (1.0, 2.0, 3.0, 0.1, 0.0, 0.0)


def test_payload_adds_the_gravity_of_a_point_mass_at_the_tool():
    from labkit.dynamics import gravity_torques

    puma = Robot.load("puma560")
    tool = np.eye(4)
    tool[:3, 3] = [0.0, 0.02, 0.1]
    puma = puma.replace(tool=tool)
    point, mass = np.array([0.05, -0.03, 0.08]), 2.5
    loaded = puma.with_payload(mass, point)
    assert loaded.links[-1].inertial.mass == pytest.approx(puma.links[-1].inertial.mass + mass)
    q = np.random.default_rng(3).uniform(-1.5, 1.5, (5, 6))
    g = np.array([0.0, 0.0, -9.81])
    extra = gravity_torques(loaded, q) - gravity_torques(puma, q)
    J = jacobian(puma, q, point=point)[..., :3, :]
    assert np.allclose(extra, -np.einsum("...ij,i->...j", J, mass * g), atol=1e-12)  # tau = -J^T (m g)
    with pytest.raises(RobotError, match="mass >= 0"):
        puma.with_payload(-1.0)
    with pytest.raises(ValueError, match=r"shape \(3,\)"):
        puma.with_payload(1.0, [0, 0])
