"""Numeric IK: closed-form seeds (the robot's own family or its idealised copy's) and plain LM."""

import numpy as np
import pytest

from labkit.kinematics import fk, ik_all, ik_numeric
from labkit.kinematics.ik import _numeric as _ik_numeric
from labkit.robot import Robot


@pytest.fixture(scope="module")
def bent():
    """The PUMA 560 with a 2 mm offset a5: no closed form fits, so ik_numeric runs plain LM."""
    return Robot.load("puma560").with_link(4, a=0.002)


def test_bent_puma_has_no_closed_form(bent):
    from labkit.kinematics import solver_for

    assert solver_for(bent).value == "numeric"
    assert solver_for(Robot.load("puma560")).value == "spherical_wrist"


def test_analytic_seeds_make_the_iteration_a_polish():
    puma = Robot.load("puma560")
    rng = np.random.default_rng(21)
    lim = puma.joint_limits
    T = fk(puma, rng.uniform(lim[:, 0], lim[:, 1], size=(300, 6)))
    res = ik_numeric(puma, T)
    assert res.success.all() and res.residual.max() < 1e-12
    assert res.iterations.max() <= 1  # started on a closed-form solution
    assert puma.within_limits(res.q).all() and np.abs(fk(puma, res.q) - T).max() < 1e-12
    # each answer is one of the closed-form branches
    sols = ik_all(puma, T[:20])
    for k in range(20):
        assert np.min(np.abs(sols.q[k] - res.q[k]).max(axis=1)) < 1e-9
    # an explicit q0 still wins over the seeds
    q0 = np.clip(res.q[:3] + 0.05, lim[:, 0], lim[:, 1])
    res0 = ik_numeric(puma, T[:3], q0=q0)
    assert res0.success.all() and (res0.iterations >= 1).all()


def test_lm_keeps_full_success_without_a_closed_form(bent):
    rng = np.random.default_rng(8)
    lim = bent.joint_limits
    T = fk(bent, rng.uniform(lim[:, 0], lim[:, 1], size=(150, 6)))
    res = ik_numeric(bent, T)
    assert res.success.all() and res.residual.max() < 1e-10
    assert bent.within_limits(res.q).all() and np.abs(fk(bent, res.q) - T).max() < 1e-9
    for k in range(3):  # one target at a time: a batch of one
        one = ik_numeric(bent, T[k])
        assert one.success and one.residual < 1e-10 and np.abs(fk(bent, one.q) - T[k]).max() < 1e-9


def calibrated_puma():
    """A PUMA 560 as a calibration would report it: twists and lengths a little off (no closed form)."""
    puma = Robot.load("puma560")
    r = puma.with_link(0, alpha=puma.links[0].alpha + np.radians(0.4)).with_link(2, d=puma.links[2].d + 0.001)
    return r.with_link(4, a=0.0015).with_link(3, alpha=puma.links[3].alpha - np.radians(0.3))


@pytest.mark.parametrize("make", [lambda: Robot.load("puma560").with_link(4, a=0.002), calibrated_puma])
def test_an_idealised_copy_seeds_an_arm_a_little_off_a_closed_form(make):
    from labkit.kinematics import solver_for

    robot = make()
    assert solver_for(robot).value == "numeric"
    ideal, solver = _ik_numeric.near_family(robot)
    assert solver is not None and solver.name == "spherical_wrist"
    assert ideal.links[4].a == 0.0 and ideal.links[2].a == robot.links[2].a  # a3 = 20 mm is not "small"
    assert all(abs(link.alpha / (np.pi / 2) - round(link.alpha / (np.pi / 2))) < 1e-12 for link in ideal.links)
    assert _ik_numeric.near_family(robot)[1] is solver  # cached per robot
    rng = np.random.default_rng(31)
    lim = robot.joint_limits
    T = fk(robot, rng.uniform(lim[:, 0], lim[:, 1], size=(300, 6)))
    starts = _ik_numeric.analytic_seeds(robot, "pose", T, rng)
    assert starts.shape == (300, 8, 6)
    assert (~np.isnan(starts[:, 0, 0])).mean() > 0.9  # nearly every target has a start
    off = np.abs(fk(robot, np.nan_to_num(starts[:, 0]))[:, :3, 3] - T[:, :3, 3]).max(axis=1)
    assert np.median(off) < 0.005  # millimetres from the target before any iteration
    seeded = ik_numeric(robot, T)
    assert seeded.success.all() and seeded.residual.max() < 1e-10
    assert robot.within_limits(seeded.q).all() and np.abs(fk(robot, seeded.q) - T).max() < 1e-9
    plain = ik_numeric(robot, T, q0=_ik_numeric._random_q(np.random.default_rng(2), lim, 300))
    assert plain.success.all()
    assert np.median(seeded.iterations) <= 6 < np.median(plain.iterations)
    assert seeded.iterations.mean() < 0.5 * plain.iterations.mean()


def test_no_idealised_copy_for_an_arm_far_from_every_family():
    far = Robot.load("puma560").with_link(4, a=0.1)  # 10 % of the arm's length: not a calibration error
    assert _ik_numeric.near_family(far) == (None, None)
    assert _ik_numeric.analytic_seeds(far, "pose", fk(far, np.zeros((2, 6))), np.random.default_rng(0)) is None
    rng = np.random.default_rng(9)
    lim = far.joint_limits
    T = fk(far, rng.uniform(lim[:, 0], lim[:, 1], size=(60, 6)))
    res = ik_numeric(far, T)  # plain LM from random starts
    assert res.success.all() and res.residual.max() < 1e-10 and far.within_limits(res.q).all()
