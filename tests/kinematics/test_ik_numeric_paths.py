"""Numeric IK: analytic seeds, the lean one-target path against the batched iteration, and plain LM.

The lean path (``labkit.kinematics._ik_lean``) runs the batched solver's iteration for a single
target on Python floats; it must take the same steps (same iterations, same answer).
"""

import numpy as np
import pytest

from labkit.kinematics import fk, fk_position, ik_all, ik_numeric
from labkit.kinematics import _ik_lean, _ik_numeric
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
    for k in range(3):  # one target at a time: the lean path
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


@pytest.mark.parametrize("kind,mask", [("pose", None), ("pose", [1, 1, 1, 0, 0, 1]), ("position", None)])
def test_lean_path_takes_the_batched_steps(bent, kind, mask):
    rng = np.random.default_rng(4)
    lim = bent.joint_limits
    for _ in range(4):
        q_true = rng.uniform(0.7 * lim[:, 0], 0.7 * lim[:, 1])
        T = fk(bent, q_true)
        target = T if kind == "pose" else T[:3, 3]
        q0 = np.clip(q_true + rng.uniform(-0.3, 0.3, 6), lim[:, 0], lim[:, 1])
        lean = ik_numeric(bent, target, q0=q0, kind=kind, mask=mask)  # one target: lean path
        # two identical rows stay together in the batched loop and finish at the same iteration
        batched = ik_numeric(bent, np.stack([target, target]), q0=[q0, q0], kind=kind, mask=mask)
        assert lean.success and batched.success.all()
        assert int(lean.iterations) == batched.iterations[0] == batched.iterations[1]
        np.testing.assert_allclose(batched.q[0], lean.q, rtol=0, atol=1e-12)


@pytest.mark.parametrize("kind,rows", [
    ("pose", (0, 1, 2, 3, 4, 5)), ("pose", (0, 1, 2, 5)), ("pose", (3, 4, 5)),
    ("position", (0, 1, 2)), ("position", (0, 2)), ("planar", (0, 1, 5)), ("planar", (0, 1)),
])
def test_lean_task_error_equals_the_batched_one(bent, kind, rows):
    rng = np.random.default_rng(len(rows))
    Tq = fk(bent, rng.uniform(-2, 2, size=(50, 6)))
    Tt = fk(bent, rng.uniform(-2, 2, size=(50, 6)))
    if kind == "pose":
        target = Tt
    elif kind == "position":
        target = Tt[:, :3, 3]
    else:
        target = np.c_[Tt[:, :2, 3], rng.uniform(-4, 4, 50)]
    e, res = _ik_numeric._error(kind, Tq, target, rows)
    for k in range(50):
        ek, rk = _ik_lean.error(kind, Tq[k].ravel().tolist(), target[k].tolist(), rows)
        # near a half turn the rotation vector divides by sin(angle): summation order shows at 1e-13
        np.testing.assert_allclose(ek, e[k], rtol=1e-12, atol=1e-14)
        assert abs(rk - res[k]) <= 1e-14 + 1e-12 * res[k]


def test_lean_path_reports_failure_like_the_batched_one():
    rpp = Robot.load("rpp_seed002")
    res = ik_numeric(rpp, [10.0, 0.0, 0.5], restarts=2)
    assert not res.success and np.isfinite(res.q).all() and res.residual > 1.0 and rpp.within_limits(res.q)
    assert np.isclose(res.residual, np.linalg.norm(fk_position(rpp, res.q) - [10.0, 0.0, 0.5]))


def test_seeds_of_a_few_targets_take_the_small_path_with_the_same_values(bent, monkeypatch):
    from labkit.kinematics import _ik_small

    rng = np.random.default_rng(4)
    lim = bent.joint_limits
    T = fk(bent, rng.uniform(lim[:, 0], lim[:, 1], size=(3, 6)))
    calls = []
    real = _ik_small.solve_raw
    monkeypatch.setattr(_ik_small, "solve_raw", lambda *a: calls.append(1) or real(*a))
    small = _ik_numeric.analytic_seeds(bent, "pose", T, np.random.default_rng(0))
    assert calls == [1]
    monkeypatch.setattr(_ik_small, "SMALL_TARGETS", 0)
    batched = _ik_numeric.analytic_seeds(bent, "pose", T, np.random.default_rng(0))
    assert calls == [1]
    assert np.array_equal(np.isnan(small), np.isnan(batched))
    d = np.nan_to_num(small - batched)
    np.testing.assert_allclose(np.angle(np.exp(1j * d)), 0.0, atol=1e-12)
