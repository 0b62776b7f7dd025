"""Numeric IK: closed-form seeds (the robot's own family or its idealised copy's) and plain LM."""

import numpy as np
import pytest

from labkit.kinematics import fk, ik_all, ik_numeric
from labkit.kinematics._ik_solvers import _lm, _starts
from labkit.exceptions import OptionError
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
    assert res.success.all() and res.residual.max() < 1e-10 * bent.reach  # the default tolerance
    assert bent.within_limits(res.q).all() and np.abs(fk(bent, res.q) - T).max() < 1e-9
    for k in range(3):  # one target at a time: a batch of one
        one = ik_numeric(bent, T[k])
        assert one.success and one.residual < 1e-10 * bent.reach and np.abs(fk(bent, one.q) - T[k]).max() < 1e-9


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
    ideal, solver = _starts.near_family(robot)
    assert solver is not None and solver.name == "spherical_wrist"
    assert ideal.links[4].a == 0.0 and ideal.links[2].a == robot.links[2].a  # a3 = 20 mm is not "small"
    assert all(abs(link.alpha / (np.pi / 2) - round(link.alpha / (np.pi / 2))) < 1e-12 for link in ideal.links)
    assert _starts.near_family(robot)[1] is solver  # cached per robot
    rng = np.random.default_rng(31)
    lim = robot.joint_limits
    T = fk(robot, rng.uniform(lim[:, 0], lim[:, 1], size=(300, 6)))
    starts = _starts.analytic_seeds(robot, "pose", T).all
    assert starts.shape == (300, 8, 6)
    assert (~np.isnan(starts[:, 0, 0])).mean() > 0.9  # nearly every target has a start
    off = np.abs(fk(robot, np.nan_to_num(starts[:, 0]))[:, :3, 3] - T[:, :3, 3]).max(axis=1)
    assert np.median(off) < 0.005  # millimetres from the target before any iteration
    seeded = ik_numeric(robot, T)
    assert seeded.success.all() and seeded.residual.max() < 1e-10 * robot.reach
    assert robot.within_limits(seeded.q).all() and np.abs(fk(robot, seeded.q) - T).max() < 1e-9
    plain = ik_numeric(robot, T, q0=np.random.default_rng(2).uniform(lim[:, 0], lim[:, 1], size=(300, 6)))
    assert plain.success.all()
    assert np.median(seeded.iterations) <= 6 < np.median(plain.iterations)
    assert seeded.iterations.mean() < 0.5 * plain.iterations.mean()


def test_no_idealised_copy_for_an_arm_far_from_every_family():
    far = Robot.load("puma560").with_link(4, a=0.1)  # 10 % of the arm's length: not a calibration error
    assert _starts.near_family(far) == (None, None)
    assert _starts.analytic_seeds(far, "pose", fk(far, np.zeros((2, 6)))) is None
    rng = np.random.default_rng(9)
    lim = far.joint_limits
    T = fk(far, rng.uniform(lim[:, 0], lim[:, 1], size=(60, 6)))
    res = ik_numeric(far, T)  # plain LM from random starts
    assert res.success.all() and res.residual.max() < 1e-10 * far.reach and far.within_limits(res.q).all()


def _flipped(robot, joints):
    """``robot`` with ``joints`` flipped (their limits mirrored): the same arm, other joint signs."""
    from dataclasses import replace

    return robot.replace(links=tuple(
        replace(lk, flip=True, limits=(-lk.limits[1], -lk.limits[0])) if j in joints else lk
        for j, lk in enumerate(robot.links)))


@pytest.mark.parametrize("kind, rows", [("pose", (0, 1, 2, 3, 4, 5)), ("pose", (0, 1, 2, 5)), ("position", (0, 1, 2)),
                                        ("position", (0, 2))])
def test_the_step_solves_the_damped_normal_equations(bent, kind, rows):
    rng = np.random.default_rng(5)
    lim = bent.joint_limits
    q = rng.uniform(lim[:, 0], lim[:, 1], size=(3, 6))
    T = fk(bent, rng.uniform(lim[:, 0], lim[:, 1], size=(3, 6)))
    target = T if kind == "pose" else T[:, :3, 3]
    from labkit.kinematics import fk_jacobian

    pose, J = fk_jacobian(bent, q)
    J = J[:, list(rows)]
    e, res = _lm.task_error(kind, pose, target, rows)
    lam = np.array([1e-2, 1e-6, 1.0])
    dq = _lm.damped_step(J, e, lam)
    for k in range(3):
        if len(rows) < 6:
            want = J[k].T @ np.linalg.solve(J[k] @ J[k].T + lam[k] * np.eye(len(rows)), e[k])
        else:
            want = np.linalg.solve(J[k].T @ J[k] + lam[k] * np.eye(6), J[k].T @ e[k])
        assert np.abs(dq[k] - want).max() < 1e-9
    assert np.allclose(_lm.damping(lam, np.array([True, False, True])), [1e-3, 1e-5, 0.1], rtol=1e-15)


def test_task_error_is_the_position_error_and_the_rotation_vector(bent):
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(6)
    lim = bent.joint_limits
    T, target = (fk(bent, rng.uniform(lim[:, 0], lim[:, 1], size=(50, 6))) for _ in range(2))
    e, res = _lm.task_error("pose", T, target, (0, 1, 2, 3, 4, 5))
    rotvec = Rotation.from_matrix(target[:, :3, :3] @ T[:, :3, :3].swapaxes(1, 2)).as_rotvec()
    assert np.abs(e[:, :3] - (target[:, :3, 3] - T[:, :3, 3])).max() < 1e-15
    assert np.abs(e[:, 3:] - rotvec).max() < 1e-9
    angle = np.linalg.norm(rotvec, axis=1)
    assert np.allclose(res, np.sqrt((e[:, :3] ** 2).sum(axis=1) + (2 * np.sin(angle / 2)) ** 2), rtol=1e-12)


@pytest.mark.parametrize("flips", [(), (1, 4)])
def test_one_target_at_a_time_solves_as_the_batch_does(bent, flips):
    """ik_numeric on single targets (batches of one) and on the batch reach every target."""
    robot = _flipped(bent, flips)
    rng = np.random.default_rng(11)
    lim = robot.joint_limits
    T = fk(robot, rng.uniform(lim[:, 0], lim[:, 1], size=(40, 6)))
    batch = ik_numeric(robot, T)
    single = [ik_numeric(robot, T[k]) for k in range(40)]
    assert batch.success.all() and all(r.success for r in single)
    q1 = np.array([r.q for r in single])
    assert robot.within_limits(q1).all()
    assert np.abs(fk(robot, q1) - T).max() < 1e-9 and np.abs(fk(robot, batch.q) - T).max() < 1e-9
    # the same loop: most targets take the same iterations either way
    assert np.mean(np.array([r.iterations for r in single]) == batch.iterations) > 0.8


@pytest.mark.parametrize("make", [lambda: Robot.load("puma560").with_link(4, a=0.002), lambda: Robot.load("puma560"),
                                  lambda: Robot.load("arduino_arm_3dof").with_link(1, d=0.004)])
def test_starts_of_one_target_are_those_of_the_batch(make):
    robot = make()
    kind = "pose" if robot.n == 6 else "position"
    rng = np.random.default_rng(17)
    lim = robot.joint_limits
    T = fk(robot, rng.uniform(lim[:, 0], lim[:, 1], size=(120, robot.n)))
    T[100:, :3, 3] *= 2.5  # out of reach: every branch solved and ranked
    target = T if kind == "pose" else T[:, :3, 3]
    batch = _starts.analytic_seeds(robot, kind, target)
    ones = [_starts.analytic_seeds(robot, kind, target[k:k + 1]) for k in range(len(target))]
    first = np.concatenate([s.all[:, 0] for s in ones])
    # one target runs the formulas on Python floats (math's functions): the same starts to the last units
    assert np.allclose(np.concatenate([s.all for s in ones]), batch.all, rtol=0, atol=1e-12, equal_nan=True)
    if _starts.detect(robot)[0] is not None:  # its own closed form: out of reach, no start
        assert np.isnan(first[100:]).any() and np.isfinite(first[:100]).all()
    else:  # an idealised copy's: every branch is a start
        assert np.isfinite(first).all()


@pytest.mark.parametrize("name", ["openmanipulator_x", "so101", "al5d", "scara"])
def test_numeric_ik_takes_the_closed_form_target_kind(name):
    """x y z pitch (OpenMANIPULATOR-X), x y z pitch roll (SO-101, AL5D) and x y z yaw (a SCARA) go to
    ik_numeric as they go to ik: every target is reached (also those the arm reaches over its back, whose
    tool pose differs from the front one) and each answer is one of the closed-form branches."""
    from pathlib import Path

    from labkit.kinematics import target_from_pose, target_kind
    from labkit.rotations import wrap_angle

    robot = Robot.load(Path(__file__).parent / "robots" / "scara_standard.toml") if name == "scara" \
        else Robot.load(name)
    rng = np.random.default_rng(11)
    lim = robot.joint_limits
    target = target_from_pose(robot, fk(robot, rng.uniform(lim[:, 0], lim[:, 1], size=(24, robot.n))))
    assert target.shape == (24, {"position_pitch": 4, "position_pitch_roll": 5, "position_yaw": 4}[target_kind(robot)])
    res = ik_numeric(robot, target, seed=3)
    assert res.success.all() and robot.within_limits(res.q).all()
    d = target_from_pose(robot, fk(robot, res.q)) - target
    d[:, 3:] = wrap_angle(d[:, 3:])
    assert np.abs(d).max() < 1e-8
    sols = ik_all(robot, target)
    gap = np.where(sols.valid, np.abs(wrap_angle(sols.q - res.q[:, None])).max(axis=-1), np.inf).min(axis=-1)
    assert gap.max() < 1e-6
    # one target, and a target kind the arm does not take
    one = ik_numeric(robot, target[0])
    assert one.success and one.q.shape == (robot.n,)
    other = "position_yaw" if name != "scara" else "position_pitch"
    with pytest.raises(OptionError, match="targets are defined by the closed form"):
        ik_numeric(robot, np.zeros(4), kind=other)


def _scaled(robot, s):
    """``robot`` with every length (DH a and d, prismatic limits, base and tool offsets) times ``s``."""
    import dataclasses

    links = tuple(dataclasses.replace(lk, a=lk.a * s, d=lk.d * s,
                                      limits=lk.limits if lk.is_revolute else (lk.limits[0] * s, lk.limits[1] * s))
                  for lk in robot.links)
    base, tool = robot.base.copy(), robot.tool.copy()
    base[:3, 3] *= s
    tool[:3, 3] *= s
    return robot.replace(links=links, base=base, tool=tool)


@pytest.mark.parametrize("reach", [0.05, 7.0])
@pytest.mark.parametrize("make", [lambda: Robot.load("ur5").with_link(4, a=0.002),
                                  lambda: Robot.load("rpp_seed002").with_link(1, alpha=0.01)],
                         ids=["bent ur5", "tilted rpp"])
def test_the_default_tolerance_scales_with_the_arm(bent, make, reach):
    """A 5 cm micro-arm and a 7 m arm of the same shape (no closed form: plain LM) solve the same targets
    to the same precision relative to their reach (1e-10 of it), in the same iterations."""
    robot = make()
    small = _scaled(robot, reach / robot.reach)
    assert small.reach == pytest.approx(reach)
    rng = np.random.default_rng(5)
    lim = robot.joint_limits
    q = rng.uniform(np.maximum(lim[:, 0], -np.pi), np.minimum(lim[:, 1], np.pi), size=(60, robot.n))
    kind = "pose" if robot.n == 6 else "position"
    iterations = []
    for arm, scale in ((robot, 1.0), (small, reach / robot.reach)):
        T = fk(arm, np.where(arm.is_revolute, q, q * scale))
        res = ik_numeric(arm, T if kind == "pose" else T[:, :3, 3], kind=kind)
        assert res.success.all()
        assert res.residual.max() <= 1e-10 * arm.reach
        iterations.append(res.iterations)
    assert abs(iterations[0].mean() - iterations[1].mean()) <= 0.5  # lengths count in units of the reach
    # the closed-form answer of ik/ik_all on a numeric arm reaches its target to the same relative precision
    sols = ik_all(small, fk(small, np.where(small.is_revolute, q[0], q[0] * reach / robot.reach))[:3, 3]
                  if kind == "position" else fk(small, q[0]))
    assert sols.reachable.all() and sols.distance == 0.0
