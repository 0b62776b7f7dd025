"""The cheaper evaluations of one IK target and of a robot copy give what the general ones give."""

import math

import numpy as np
import pytest

from labkit.exceptions import RobotError
from labkit.kinematics import fk, ik_all
from labkit.kinematics._ik_solvers import _solve
from labkit.robot import Robot

EDGES = [-2 * math.pi, -math.pi - 1e-9, -math.pi, -3.0, 0.0, 3.0, math.pi, math.pi + 1e-9, 2 * math.pi]


@pytest.mark.parametrize("lo", EDGES[:6])
@pytest.mark.parametrize("hi", EDGES[3:])
def test_finish_skips_a_turn_only_where_none_can_enter_the_limits(monkeypatch, lo, hi):
    if hi <= lo:
        return
    robot = Robot.load("puma560").with_link(0, limits=(lo, hi))
    eps = np.array([-1e-9, -1e-12, 0.0, 1e-12, 1e-9])
    q = np.zeros((5 * len(EDGES), 6))
    q[:, 0] = (np.array(EDGES)[:, None] + eps).ravel()
    got = _solve.finish(robot, q)
    flip, any_flip, rev, lo_s, hi_s, _, _ = _solve._joints(robot)
    monkeypatch.setattr(_solve, "_joints", lambda r: (flip, any_flip, rev, lo_s, hi_s, True, True))
    assert np.array_equal(got, _solve.finish(robot, q))  # both turn steps run: the same values, bit for bit


@pytest.mark.parametrize("name", ["arduino_arm_3dof", "planar3r_seed004", "puma560", "ur5", "so101"])
def test_one_target_on_floats_equals_the_batch_rows(name):
    robot = Robot.load(name)
    rng = np.random.default_rng(5)
    lim = np.clip(robot.joint_limits, -3, 3)
    T = fk(robot, rng.uniform(lim[:, 0], lim[:, 1], (6, robot.n)))
    kind = {"arduino_arm_3dof": "p", "planar3r_seed004": "planar"}.get(name, "pose")
    t = T[:, :3, 3] if kind == "p" else T if kind == "pose" else \
        np.stack([T[:, 0, 3], T[:, 1, 3], np.arctan2(T[:, 1, 0], T[:, 0, 0])], -1)
    batch = ik_all(robot, np.concatenate([t, t]))  # a batch runs the formulas on numpy rows
    for k in range(len(t)):
        one = ik_all(robot, t[k])  # one target runs them on Python floats
        assert np.allclose(one.q, batch.q[k], rtol=0, atol=1e-12)
        assert np.array_equal(one.valid, batch.valid[k])


def test_replace_checks_the_changed_fields_and_keeps_the_rest():
    puma = Robot.load("puma560")
    bent = puma.with_link(4, a=0.002)
    assert bent.links[4].a == 0.002 and puma.links[4].a == 0.0
    assert bent.tool is puma.tool and bent.base is puma.base  # not copied nor checked again
    assert not bent.joint_limits.flags.writeable
    with pytest.raises(RobotError, match="rigid transform"):
        puma.replace(tool=np.ones((4, 4)))
    with pytest.raises(RobotError, match="distinct joint names"):
        puma.replace(links=(puma.links[0], puma.links[0]))
    with pytest.raises(TypeError, match="unexpected keyword"):
        puma.replace(nonsense=1)
    assert puma.replace(convention="craig").convention.value == "modified"
    q = np.zeros((2, 6))
    q[1, 0] = 10.0
    assert puma.within_limits(q).tolist() == [True, False]


@pytest.mark.parametrize("name", ["arduino_arm_3dof", "puma560", "so101", "al5d", "ur5", "planar3r_seed004"])
def test_joint_axes_on_floats_are_the_frames_of_fk(name):
    from labkit.kinematics import fk_frames
    from labkit.kinematics._ik_solvers._geometry import joint_axes

    robot = Robot.load(name)
    for r in (robot, robot.with_link(0, a=0.01, d=0.02), robot.with_link(robot.n - 1, theta=0.3)):
        F = fk_frames(r, np.zeros(r.n))  # the compiled program
        idx = np.arange(1, r.n + 1) if r.convention.value == "modified" else np.arange(r.n)
        z, o, tool = joint_axes(r)  # the DH walk on floats
        assert np.allclose(z, F[idx, :3, 2], rtol=0, atol=1e-14) and np.allclose(o, F[idx, :3, 3], rtol=0, atol=1e-14)
        assert np.allclose(tool, F[-1], rtol=0, atol=1e-14)
