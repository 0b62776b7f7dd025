"""Formulas compiled to straight-line Python (``ik/_trace.py``): the closed-form families, finished, return bit
for bit what the interpretive float path returns, raise where it raises, and fall back to it where a family cannot
be traced; so do the task error, the damped step and the ranking of numeric IK's starts."""

import inspect
import math
import zlib

import numpy as np
import pytest

from labkit.kinematics import fk, jacobian, target_from_pose
from labkit.kinematics.ik._geometry import joint_axes
from labkit.kinematics.ik._registry import detect
from labkit.kinematics.ik._lm import Floats, _evaluate_one, _moved_one, arithmetic, error
from labkit.kinematics.ik._step import MATRICES, step
from labkit.kinematics.ik._starts import _branch_starts, _ranked, _seeder, near_family
from labkit.kinematics.ik._targets import _rigid_defects, _rigid_defects_floats, target_shape
from labkit.kinematics.ik._solve import finished_solver, joints, solve_finished, solve_floats
from labkit.kinematics.ik._trace import compiled
from labkit.kinematics.ik._xp import FLOATS
from labkit.kinematics.ik._yaw_pitch_pitch import YawPitchPitch
from labkit.robot import Robot
from labkit.robot._files import bundled_robots
from tests.kinematics.test_ik_families import ROBOTS


def _variants():
    """Every bundled robot, the extra robots of test_ik_families, and copies with a shoulder and a lateral offset."""
    out = {name: Robot.load(name) for name in bundled_robots()}
    out.update({name: make() for name, (make, _) in ROBOTS.items() if name not in out})
    for name, robot in list(out.items()):
        out[f"{name}+a1"] = robot.with_link(0, a=robot.links[0].a + 0.013)
        if robot.n > 2:
            out[f"{name}+d2"] = robot.with_link(1, d=robot.links[1].d + 0.011)
    return {name: robot for name, robot in out.items() if getattr(detect(robot)[0], "scalar", False)}


VARIANTS = _variants()


def _outcome(f, t):
    """``repr`` of what ``f(t)`` returns or raises: equal only for the same structure, types and float bits."""
    try:
        return repr(f(t))
    except (ValueError, ZeroDivisionError, OverflowError) as exc:
        return f"raises {type(exc).__name__}: {exc}"


def _targets(robot, family, rng):
    """Targets as solve_floats takes them: in the limits, singular, on the axes, signed zeros, out of reach."""
    lim = np.clip(robot.joint_limits, -4.0, 4.0)
    q = rng.uniform(lim[:, 0], lim[:, 1], size=(300, robot.n))
    grid = rng.choice([0.0, math.pi / 2, -math.pi / 2, math.pi, -math.pi], size=(100, robot.n))
    q = np.concatenate([q, np.clip(grid, lim[:, 0], lim[:, 1]), np.zeros((1, robot.n))])
    if robot.n == 6:
        q[:60, 4] = 0.0  # wrist singularity
    T = fk(robot, q)
    if family.kind == "pose":
        far = T.copy()
        far[:50, :3, 3] *= 4.0
        far[50:100, :3, 3] *= 0.0  # -0.0 where a component was negative
        return np.concatenate([T, far[:100]]).tolist()
    t = target_from_pose(robot, T)
    far = t[:150].copy()
    far[:50, :3] *= 4.0
    far[50:100, :3] *= 0.0
    far[100:, :3] *= rng.uniform(0.99, 1.01, size=(50, 1))  # around a fully stretched / folded arm
    return np.concatenate([t, far]).tolist()


def test_variants_cover_every_float_family():
    assert {detect(r)[0].name for r in VARIANTS.values()} == {
        "planar_2r", "planar_3r", "yaw_pitch_pitch", "yaw_pitch_pitch_pitch", "yaw_pitch_pitch_pitch_roll",
        "spherical_wrist"}


def _family_compiled(family):
    """The family's formulas alone, compiled (or None)."""
    return compiled(family.solve, (target_shape(family.kind),), f"ik {family.name}")


@pytest.mark.parametrize("name", sorted(VARIANTS))
def test_compiled_equals_interpretive_bit_for_bit(name):
    robot = VARIANTS[name]
    family, _ = detect(robot)
    f = _family_compiled(family)
    assert f.__code__.co_filename.startswith(f"<labkit ik {family.name},")  # compiled, not the fallback
    done = finished_solver(robot, family)
    assert done.__code__.co_filename.startswith(f"<labkit ik {family.name}, finished for")
    assert finished_solver(robot, family) is done  # once per robot and solver
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    targets = _targets(robot, family, rng)
    diff = [t for t in targets if _outcome(f, t) != _outcome(lambda t: family.solve(FLOATS, t), t)]
    assert not diff, f"{len(diff)} of {len(targets)} targets differ, first {diff[0]}"
    js = joints(robot)
    diff = [t for t in targets if _outcome(done, t) != _outcome(lambda t: solve_finished(FLOATS, t, family, js), t)]
    assert not diff, f"finished: {len(diff)} of {len(targets)} targets differ, first {diff[0]}"
    # the targets reach both the reachable and the unreachable branches, inside and outside the limits
    reach = [r for t in targets for r in f(t)[1]]
    assert any(reach) and not all(reach)
    valid = [v for t in targets for v in done(t)[2]]
    assert any(valid) and not all(valid)


def test_outcome_tells_signed_zeros_and_types_apart():
    assert _outcome(lambda t: [(0.0,)], None) != _outcome(lambda t: [(-0.0,)], None)
    assert _outcome(lambda t: [(1.0,)], None) != _outcome(lambda t: [[1.0]], None)
    assert _outcome(lambda t: True, None) != _outcome(lambda t: 1.0, None)


def _axes():
    return joint_axes(Robot.load("arduino_arm_3dof"))


class _Raising(YawPitchPitch):
    """Formulas that raise on some targets, one of them on a value nothing uses."""

    def solve(self, xp, t):
        xp.arccos(t[1])  # unused, but FLOATS raises here for |y| > 1
        q = (xp.sqrt(t[0] - 0.5), t[2] / t[0], -(-t[2]) * 1.0 + -0.0)
        return [q], [t[0] > 0.0], xp.maximum(t[0] - 0.0, 0.0)


def test_the_compiled_code_raises_where_floats_raises():
    family = _Raising(Robot.load("arduino_arm_3dof"), *_axes())
    f = _family_compiled(family)
    assert f.__code__.co_filename.startswith("<labkit ik")
    cases = [[1.0, 0.5, -0.0], [0.2, 0.5, 1.0], [1.0, 2.0, 1.0], [0.0, 0.5, 1.0], [0.7, -1.0, 3.0]]
    outcomes = [_outcome(f, t) for t in cases]
    assert outcomes == [_outcome(lambda t: family.solve(FLOATS, t), t) for t in cases]
    assert sum(o.startswith("raises ValueError") for o in outcomes) == 3  # sqrt, the unused arccos, sqrt(-0.5)


class _Branchy(YawPitchPitch):
    """A family with a data-dependent ``if`` (not allowed, but it must still answer right)."""

    def solve(self, xp, t):
        if t[2] < 0.0:
            t = [t[0], t[1], -t[2]]
        return super().solve(xp, t)


class _Converting(YawPitchPitch):
    """A family calling ``math`` directly on a component."""

    def solve(self, xp, t):
        return super().solve(xp, [math.copysign(t[0], 1.0), t[1], t[2]])


@pytest.mark.parametrize("cls", [_Branchy, _Converting])
def test_an_untraceable_family_keeps_the_interpretive_path(cls):
    robot = Robot.load("arduino_arm_3dof")
    family = cls(robot, *_axes())
    assert _family_compiled(family) is None
    f = finished_solver(robot, family)
    assert not hasattr(f, "__code__") and f.args == (FLOATS,)  # the interpretive path
    rng = np.random.default_rng(3)
    T = fk(robot, rng.uniform(robot.joint_limits[:, 0], robot.joint_limits[:, 1], size=(50, 3)))
    targets = T[:, :3, 3].tolist()
    targets += [[x, y, -z] for x, y, z in targets]
    js = joints(robot)
    assert [_outcome(f, t) for t in targets] == [_outcome(lambda t: solve_finished(FLOATS, t, family, js), t)
                                                 for t in targets]
    q, reach, _, _ = solve_floats(robot, family, targets)
    expected = [family.solve(FLOATS, t) for t in targets]
    assert reach == [r for _, r, _ in expected]


def _rotation(axis, angle):
    """A rotation matrix about a unit axis."""
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


#: robots, target kinds and task rows of the LM's compiled functions: square, tall and wide Jacobians
TASKS = [("puma560", "pose", (0, 1, 2, 3, 4, 5)), ("puma560", "pose", (0, 1, 2, 5)), ("puma560", "position", (0, 1, 2)),
         ("arduino_arm_3dof", "position", (0, 1, 2)), ("planar3r_seed003", "planar", (0, 1, 5))]


@pytest.mark.parametrize("name, kind, rows", TASKS)
def test_compiled_evaluation_equals_interpretive(name, kind, rows):
    # the per-robot program's generated code and the task error, compiled together
    robot = Robot.load(name)
    ops = arithmetic(robot)[Floats, kind, rows]
    assert ops._one.__code__.co_filename.startswith(f"<labkit ik {kind} evaluation")  # compiled
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    q = rng.uniform(robot.joint_limits[:, 0], robot.joint_limits[:, 1], size=(60, robot.n))
    T = fk(robot, q)
    # targets: the pose itself (no error, no rotation), moved, turned a little, turned by pi (the robust angle)
    goal = T.copy()
    goal[20:, :3, 3] += rng.normal(0.0, 0.01, size=(40, 3))
    for k in range(20, 60):
        goal[k, :3, :3] = _rotation(rng.normal(size=3), 0.3 if k < 40 else math.pi - 1e-9 * (k - 40)) @ T[k, :3, :3]
    if kind == "pose":
        targets = goal.tolist()
    elif kind == "position":
        targets = goal[:, :3, 3].tolist()
    else:
        targets = np.stack([goal[:, 0, 3], goal[:, 1, 3], np.arctan2(goal[:, 1, 0], goal[:, 0, 0]) + 7.0], 1).tolist()
    cases = list(zip(q.tolist(), targets))
    got = [_outcome(lambda a: ops._one(*a), c) for c in cases]
    assert got == [_outcome(lambda a: _evaluate_one(FLOATS, *a, robot, kind, rows), c) for c in cases]
    assert len(set(got[20:])) == 40  # (distinct where the target differs: the comparison sees them)
    # and what they compute is the batch path's task error (away from a half turn, where the rotation
    # vector's direction hangs on the last bits of R_t R^T)
    J, e, res, E = ops.evaluate(*map(list, zip(*cases[:40])))
    eb, rb = error(kind, T[:40], goal[:40] if kind == "pose" else np.array(targets[:40]), rows)
    assert np.allclose(e, eb, rtol=0, atol=1e-12) and np.allclose(res, rb, rtol=0, atol=1e-12)
    assert np.allclose(E, 0.5 * (eb * eb).sum(axis=1), rtol=1e-12, atol=1e-15)
    Jb = jacobian(robot, q[:40])[:, list(rows)]
    assert np.allclose(np.reshape(J, Jb.shape), Jb, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", ["puma560", "arduino_arm_3dof", "planar3r_seed003"])
@pytest.mark.parametrize("exact", [True, False])
def test_compiled_ranking_of_starts_equals_interpretive(name, exact):
    robot = Robot.load(name)
    m = 8
    lim = robot.joint_limits
    lo, hi = lim[:, 0].tolist(), lim[:, 1].tolist()
    rank = compiled(lambda xp, rows, reach: _ranked(xp, lo, hi, exact, rows, reach), ((m, robot.n), (m,)), "ranks")
    assert rank.__code__.co_filename.startswith("<labkit ranks")
    rng = np.random.default_rng(5)
    cases = []
    for _ in range(50):
        rows = rng.uniform(lim[:, 0] - 0.5, lim[:, 1] + 0.5, size=(m, robot.n))
        rows[rng.random(size=rows.shape) < 0.5] = 0.0  # many inside the limits
        cases.append((rows.tolist(), (rng.random(m) < 0.7).tolist()))
    got = [_outcome(lambda a: rank(*a), c) for c in cases]
    assert got == [_outcome(lambda a: _ranked(FLOATS, lo, hi, exact, *a), c) for c in cases]
    ranks = [r for c in cases for r in rank(*c)[1]]
    if exact:  # a start or none
        assert set(ranks) == {0.0, math.inf}
    else:  # inside the limits, how far outside, out of reach
        assert 0.0 in ranks and any(0.0 < r < 1e3 for r in ranks) and any(r >= 1e3 for r in ranks)


@pytest.mark.parametrize("name", ["puma560", "puma560+a5", "arduino_arm_3dof+d2", "planar3r_seed003"])
def test_staged_starts_yield_the_branches_in_turn_bit_for_bit(name):
    robot = Robot.load(name.split("+")[0])
    if name.endswith("+a5"):
        robot = robot.with_link(4, a=0.002)
    elif name.endswith("+d2"):
        robot = robot.with_link(1, d=robot.links[1].d + 0.004)
    family, _ = detect(robot)
    exact = family is not None
    if not exact:
        _, family = near_family(robot)
    seeder = _seeder(robot, family, exact)
    code = seeder.__code__
    assert code.co_filename.startswith("<labkit ik starts") and code.co_flags & inspect.CO_GENERATOR
    lim = np.clip(robot.joint_limits, -4.0, 4.0)
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    T = fk(robot, rng.uniform(lim[:, 0], lim[:, 1], size=(60, robot.n)))
    T[40:, :3, 3] *= 3.0  # out of reach
    targets = T.tolist() if family.kind == "pose" else target_from_pose(robot, T).tolist()
    lo, hi = robot.joint_limits[:, 0].tolist(), robot.joint_limits[:, 1].tolist()
    for t in targets:
        branches = seeder(t)
        first = next(branches)  # one branch computed
        expected = _branch_starts(FLOATS, t, family, joints(robot), lo, hi, exact)
        assert repr([first, *branches]) == repr(expected)
    assert any(r == 0.0 for t in targets for _, r in seeder(t)) and any(r != 0.0 for t in targets for _, r in seeder(t))


def test_a_stage_not_asked_for_is_not_computed():
    def fn(xp, x):
        return [x + 1.0, xp.sqrt(x) * 2.0, xp.cos(x) - 1.0]

    gen = compiled(fn, ((),), "stages", stages=True)
    it = gen(4.0)
    assert next(it) == 5.0 and list(it) == [4.0, math.cos(4.0) - 1.0]
    it = gen(-1.0)
    assert next(it) == 0.0  # the square root of -1 (raising) is the second stage's: not computed yet
    with pytest.raises(ValueError):
        next(it)


def test_compiled_rigid_transform_test_equals_interpretive():
    rng = np.random.default_rng(11)
    T = fk(Robot.load("puma560"), rng.uniform(-2, 2, size=(40, 6)))
    T[10:20, :3, :3] *= 1.0 + 1e-5  # not orthonormal
    T[20:30, :3, 0] *= -1.0  # a reflection
    T[30:, 3, :3] = 1e-9  # last row off
    f = _rigid_defects_floats()
    assert f.__code__.co_filename.startswith("<labkit ik rigid-transform test")
    got = [_outcome(f, t) for t in T.tolist()]
    assert got == [_outcome(lambda t: _rigid_defects(FLOATS, t), t) for t in T.tolist()]
    assert len(set(got)) > 30  # (the comparison sees the defects)


@pytest.mark.parametrize("name, kind, rows", TASKS)
def test_compiled_damped_step_equals_interpretive(name, kind, rows):
    # one target's step (the normal equations by Cholesky) and the clip, compiled: tall, square and wide Jacobians
    robot = Robot.load(name)
    ops = arithmetic(robot)[Floats, kind, rows]
    assert ops._moved.__code__.co_filename.startswith("<labkit ik damped step")
    rng = np.random.default_rng(zlib.crc32(name.encode()) + len(rows))
    lim = robot.joint_limits
    q = rng.uniform(lim[:, 0], lim[:, 1], size=(40, robot.n))
    J = jacobian(robot, q)[:, list(rows)] * rng.uniform(0.5, 2.0, size=(40, 1, 1))
    e = rng.normal(0.0, 0.01, size=(40, len(rows)))
    lam = 10.0 ** rng.uniform(-12, 0, size=40)
    lo, hi = (lim[:, 0] + 0.5).tolist(), (lim[:, 1] - 0.5).tolist()  # (some steps clipped)
    cases = [(q[k].tolist(), J[k].ravel().tolist(), e[k].tolist(), float(lam[k]), lo, hi) for k in range(40)]
    got = [_outcome(lambda a: ops._moved(*a), c) for c in cases]
    assert got == [_outcome(lambda a: _moved_one(FLOATS, *a, rows, robot.n), c) for c in cases]
    assert len(set(got)) > 30  # (distinct but where the clip took every joint to its bound)
    # what it computes is the damped least-squares step of the batch path (numpy, LU)
    step_b = step(MATRICES, J, e, lam)
    assert np.allclose(np.array([ops._moved(*c) for c in cases]), np.clip(q + step_b, lo, hi), rtol=0, atol=1e-9)
