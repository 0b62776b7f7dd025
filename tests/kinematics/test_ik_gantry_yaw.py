"""A gantry with a wrist turn (``cartesian_yaw``: three slides and a revolute joint anywhere in the chain,
targets x y z yaw, one branch), and where numeric IK starts for revolute joints with huge or no limits."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from labkit.kinematics import fk, ik, ik_all, ik_numeric, solver_for, target_from_pose, target_kind
from labkit.kinematics._ik_solvers._registry import build
from labkit.kinematics._ik_solvers._starts import start_window
from labkit.robot import Convention, JointType, Link, Robot
from labkit.rotations import matrix_from_rpy, wrap_angle

ROBOTS = Path(__file__).resolve().parent / "robots"


def _gap(robot, reached, target):
    d = reached - target
    d[..., 3] = wrap_angle(d[..., 3])
    return np.abs(d).max()


def test_pppr_gantry_takes_x_y_z_and_yaw_and_numeric_ik_the_same_target():
    """The fixture's yaw is the heading of the tool x axis from world x; its wrist is flipped, so a positive
    joint value turns the tool clockwise seen from above; closed form and numeric IK agree on 4 values."""
    robot = Robot.load(ROBOTS / "gantry_pppr.toml")
    assert target_kind(robot) == "position_yaw" and solver_for(robot).value == "cartesian_yaw"
    rng = np.random.default_rng(7)
    lim = robot.joint_limits
    q = rng.uniform(lim[:, 0], lim[:, 1], size=(50, 4))
    T = fk(robot, q)
    target = target_from_pose(robot, T)
    assert np.abs(target[:, 3] - np.arctan2(T[:, 1, 0], T[:, 0, 0])).max() < 1e-12
    turned = q.copy()
    turned[:, 3] += 0.1
    assert np.abs(wrap_angle(target_from_pose(robot, fk(robot, turned))[:, 3] - target[:, 3] + 0.1)).max() < 1e-12
    sols = ik_all(robot, target)
    assert sols.branches == ("unique",) and sols.valid.all()
    assert np.abs(wrap_angle(sols.q[:, 0] - q)).max() < 1e-9
    assert _gap(robot, target_from_pose(robot, fk(robot, sols.q[:, 0])), target) < 1e-12
    assert np.abs(wrap_angle(ik(robot, target[0]) - q[0])).max() < 1e-9
    res = ik_numeric(robot, target[:10])
    assert res.success.all() and np.abs(wrap_angle(res.q - q[:10])).max() < 1e-6
    assert ik_numeric(robot, target[:10], kind="position_yaw").success.all()


def _random_3p1r(rng, convention):
    """Three slides and a revolute joint at a random place, random twists (multiples of 90 deg), lengths, angle
    offsets and flips, on a random base with a random tool."""
    rev = int(rng.integers(4))
    links = []
    for j in range(4):
        links.append(Link(
            a=float(rng.uniform(-0.2, 0.2)) if rng.random() < 0.5 else 0.0,
            alpha=float(rng.choice([0.0, np.pi / 2, -np.pi / 2, np.pi])),
            d=float(rng.uniform(-0.2, 0.2)) if rng.random() < 0.5 else 0.0,
            theta=float(rng.choice([0.0, np.pi / 2, -np.pi / 2, rng.uniform(-np.pi, np.pi)])),
            joint_type=JointType.REVOLUTE if j == rev else JointType.PRISMATIC,
            limits=(-np.pi, np.pi) if j == rev else (-0.5, 0.5), flip=bool(rng.random() < 0.3),
        ))
    base, tool = np.eye(4), np.eye(4)
    base[:3, :3] = matrix_from_rpy(rng.uniform(-np.pi, np.pi, 3))
    tool[:3, :3] = matrix_from_rpy(rng.uniform(-np.pi, np.pi, 3))
    tool[:3, 3] = rng.uniform(-0.1, 0.1, 3)
    return Robot("gantry", tuple(links), convention=convention, base=base, tool=tool)


@pytest.mark.parametrize("convention", [Convention.STANDARD, Convention.MODIFIED])
def test_random_three_slides_and_a_turn_either_convention(convention):
    """Every layout (PPPR, PPRP, PRPP, RPPP) whose slides stay independent at every turn is the family: FK of
    its one branch is the target and the configuration the target came from; the others say why not."""
    rng = np.random.default_rng(8 if convention is Convention.STANDARD else 9)
    fitted, layouts, tries = 0, set(), 0
    while fitted < 24 and tries < 600:
        tries += 1
        robot = _random_3p1r(rng, convention)
        found, reason = build(robot, "cartesian_yaw")
        if found is None:
            assert "linearly independent at every turn" in reason
            continue
        fitted += 1
        layouts.add(int(np.flatnonzero(robot.is_revolute)[0]))
        q = rng.uniform(robot.joint_limits[:, 0], robot.joint_limits[:, 1], size=(30, 4))
        target = target_from_pose(robot, fk(robot, q))
        sols = ik_all(robot, target)
        assert sols.reachable.all()
        assert _gap(robot, target_from_pose(robot, fk(robot, sols.q[:, 0])), target) < 1e-9
        assert np.abs(wrap_angle(sols.q[:, 0] - q)).max() < 1e-9
    assert fitted == 24 and layouts == {0, 1, 2, 3}


def test_slides_that_become_dependent_at_some_turn_are_not_the_family():
    """Slide 1 perpendicular to the turn's axis, slide 2 along it, slide 3 turned with it perpendicular to it:
    at some turn slide 3 is parallel to slide 1 (no closed form; numeric IK on x y z)."""
    links = (Link(alpha=np.pi / 2, joint_type="prismatic", limits=(-0.5, 0.5)),
             Link(a=0.1, limits=(-np.pi, np.pi)),
             Link(alpha=np.pi / 2, joint_type="prismatic", limits=(-0.5, 0.5)),
             Link(d=0.05, joint_type="prismatic", limits=(-0.5, 0.5)))
    robot = Robot("prpp", links)
    found, reason = build(robot, "cartesian_yaw")
    assert found is None and "linearly independent at every turn" in reason
    assert solver_for(robot).value == "numeric" and target_kind(robot) == "position"


def _huge(robot, limit):
    return robot.replace(links=tuple(dataclasses.replace(lk, limits=(-limit, limit)) if lk.is_revolute else lk
                                     for lk in robot.links))


@pytest.mark.parametrize("limit", [np.radians(1e300), np.inf])
def test_numeric_ik_starts_revolute_joints_within_a_turn_of_zero(limit):
    """Limits of +-1e300 deg (or none) used to draw starts around 1e297 rad, where no target converged;
    now starts lie within half a turn of 0 and every target converges inside the limits."""
    puma = Robot.load("puma560")
    # off every closed form (link offsets and twists changed): numeric IK starts from random configurations
    off = puma.replace(links=tuple(dataclasses.replace(lk, a=lk.a + 0.03, alpha=lk.alpha + 0.2) for lk in puma.links))
    robot = _huge(off, limit)
    assert solver_for(robot).value == "numeric"
    lo, hi = start_window(robot)
    assert np.allclose(lo, -np.pi) and np.allclose(hi, np.pi)
    q = np.random.default_rng(10).uniform(-np.pi, np.pi, (12, 6))
    T = fk(robot, q)
    res = ik_numeric(robot, T)
    assert res.success.all() and np.abs(res.q).max() < 10.0
    assert np.abs(fk(robot, res.q) - T).max() < 1e-8


def test_start_window_of_a_range_beside_zero_and_of_slides():
    links = (Link(limits=(2.0, 100.0)), Link(limits=(-100.0, -3.0)), Link(limits=(-0.5, 0.25)),
             Link(joint_type="prismatic", limits=(-30.0, 40.0)))
    lo, hi = start_window(Robot("window", links))
    assert np.allclose(lo, [2.0, -3.0 - np.pi, -0.5, -30.0]) and np.allclose(hi, [2.0 + np.pi, -3.0, 0.25, 40.0])
