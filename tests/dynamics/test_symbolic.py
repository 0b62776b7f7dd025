"""The numeric dynamics against the symbolic Lagrangian derivation (labkit.dynamics.symbolic)."""

import numpy as np
import pytest

from labkit import dynamics as D
from labkit.dynamics.symbolic import lagrangian_dynamics
from labkit.exceptions import RobotError
from labkit.robot import Link, LinkInertia, Motor, Robot


def _planar(n):
    links = tuple(Link(a=0.3 - 0.05 * i, inertial=LinkInertia(1.0 - 0.2 * i, (-0.1, 0.01 * i, 0.0),
                                                               (1e-3, 5e-3, 6e-3, 1e-4, 0, 2e-4)),
                       motor=Motor(1e-5, 30.0) if i == 0 else None)
                  for i in range(n))
    return Robot(name=f"planar{n}r", links=links, up=[0.0, 1.0, 0.0])


def _check(robot, dyn, rng):
    M, C, g = dyn.numeric("M"), dyn.numeric("C"), dyn.numeric("g")
    for _ in range(3):
        q, qd = rng.uniform(-2, 2, (2, robot.n))
        assert np.allclose(D.mass_matrix(robot, q), M(q), rtol=1e-12, atol=1e-14)
        assert np.allclose(D.coriolis_matrix(robot, q, qd), C(q, qd), rtol=1e-10, atol=1e-13)
        assert np.allclose(D.gravity_torques(robot, q), g(q), rtol=1e-12, atol=1e-13)


def test_planar_2r_matches_and_shows_as_latex():
    robot = _planar(2)
    dyn = lagrangian_dynamics(robot, lengths={"L1": 0.3, "L2": 0.25})
    _check(robot, dyn, np.random.default_rng(1))
    text = dyn.latex()
    assert text.startswith("M(q) = ") and "C(q, \\dot{q})" in text and "L_{1}" in text and "m_{2}" in text


def test_planar_3r_and_the_seed_000_arm_match():
    rng = np.random.default_rng(2)
    for robot in (_planar(3), Robot.load("arduino_arm_3dof")):
        _check(robot, lagrangian_dynamics(robot, simplify=False), rng)


def test_links_without_inertias_are_refused():
    with pytest.raises(RobotError, match="joint 1"):
        lagrangian_dynamics(Robot.load("planar3r_seed004"))
