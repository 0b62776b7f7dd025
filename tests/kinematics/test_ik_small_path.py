"""The plain-Python small-batch IK path agrees with the batched solvers.

A handful of targets (``N <= SMALL_TARGETS``) of a ``yaw_pitch_pitch``,
``planar_3r`` or ``spherical_wrist`` arm runs through ``labkit.kinematics._ik_small``; setting
``SMALL_TARGETS`` to 0 forces the batched path. Random arms (flipped joints,
shoulder and lateral offsets, moved base and tool, limits wider than one turn)
and random targets (reachable, unreachable, out of limits, on the base axis):
every branch, reachability, validity and distance must agree to 1e-12, and
``ik`` must return the same solution or raise the same exception with the
same message and attributes.
"""

from dataclasses import replace

import numpy as np
import pytest

from labkit.exceptions import LabkitError
from labkit.kinematics import Solver, _ik_small, fk, ik, ik_all, solver_for
from labkit.robot import Robot
from labkit.rotations import rotation_z


def _flipped(robot, flips):
    return robot.replace(links=tuple(
        replace(lk, flip=True, limits=(-lk.limits[1], -lk.limits[0])) if f else lk
        for lk, f in zip(robot.links, flips)))


def _limits(robot, lims):
    return robot.replace(links=tuple(replace(lk, limits=lim) for lk, lim in zip(robot.links, lims)))


def _arms():
    arm = Robot.load("arduino_arm_3dof")
    wide = [(-2 * np.pi, 2 * np.pi), (-np.pi, np.pi), (-1.0, 4.0)]
    return {
        "arduino": arm,
        "arduino_flipped_1_3": _flipped(arm, [True, False, True]),
        "arduino_flipped_2": _flipped(arm, [False, True, False]),
        "arduino_lateral_offset": arm.with_link(2, d=0.02),
        "arduino_shoulder_offset_flipped": _flipped(arm.with_link(1, a=0.03), [True, True, True]),
        "arduino_wide_limits": _limits(arm, wide),
        "arduino_wide_limits_flipped": _flipped(_limits(arm, wide), [True, False, True]),
    }


def _planars():
    base = np.eye(4)
    base[:3, :3] = rotation_z(0.7)
    base[:3, 3] = [0.1, -0.2, 0.05]
    s3 = Robot.load("planar3r_seed003")
    s4 = Robot.load("planar3r_seed004")
    return {
        "seed003": s3,
        "seed003_135": Robot.load("planar3r_seed003_135"),
        "seed004": s4,
        "seed004_flipped": _flipped(s4, [True, False, True]),
        "seed003_moved_flipped": _flipped(
            s3.replace(base=base).with_link(1, theta=0.3).with_link(0, a=0.02), [False, True, True]),
        "seed004_wide_limits": _limits(s4, [(-2 * np.pi, 2 * np.pi), (-1.0, 4.0), (-4.0, 1.0)]),
    }


ROBOTS = {**_arms(), **_planars()}


def _targets(robot, rng, N=48):
    """Reachable (some out of limits), unreachable, and degenerate targets."""
    planar = solver_for(robot) is Solver.PLANAR_3R
    q = rng.uniform(-np.pi, np.pi, size=(N, 3))
    T = fk(robot, q)
    if planar:
        t = np.stack([T[:, 0, 3], T[:, 1, 3], np.arctan2(T[:, 1, 0], T[:, 0, 0])], axis=1)
    else:
        t = T[:, :3, 3].copy()
    t[: N // 3, :2] *= rng.uniform(0.2, 1.8, size=(N // 3, 1))  # many of these out of reach
    t[N // 3: N // 3 + 4, 2] *= 3.0
    if not planar:  # on the base axis (world z here; u = 0: the branch side falls back to its sign)
        t[-3:] = [[0, 0, 0.05], [0, 0, -0.1], [0, 0, 0.0]]
    return t


def _batched(monkeypatch, func, *args, **kwargs):
    with monkeypatch.context() as m:
        m.setattr(_ik_small, "SMALL_TARGETS", 0)
        return _outcome(func, *args, **kwargs)


def _outcome(func, *args, **kwargs):
    try:
        return func(*args, **kwargs)
    except LabkitError as exc:
        return exc


def _same(a, b):
    if isinstance(b, Exception):
        assert type(a) is type(b) and str(a) == str(b)
        for attr in ("distance", "index", "joint"):
            assert getattr(a, attr, None) == getattr(b, attr, None)
        return
    assert not isinstance(a, Exception), a
    assert a.shape == b.shape and a.dtype == b.dtype
    _same_angles(a, b)


def _same_angles(a, b):
    """Equal to 1e-12 as angles: an angle at +-pi may come out as pi on one path and -pi on the other."""
    d = np.asarray(a) - np.asarray(b)
    np.testing.assert_allclose(np.angle(np.exp(1j * d)), 0.0, rtol=0, atol=1e-12)
    assert np.all((np.abs(d) < 1e-9) | (np.abs(np.abs(d) - 2 * np.pi) < 1e-9))


def _same_solutions(a, b):
    assert a.branches == b.branches and a.solver == b.solver
    assert a.q.shape == b.q.shape and a.distance.shape == b.distance.shape
    _same_angles(a.q, b.q)
    assert np.array_equal(a.reachable, b.reachable) and a.reachable.dtype == bool
    assert np.array_equal(a.valid, b.valid) and a.valid.dtype == bool
    np.testing.assert_allclose(a.distance, b.distance, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_small_path_equals_batched_solvers(name, monkeypatch):
    robot = ROBOTS[name]
    assert solver_for(robot) in (Solver.YAW_PITCH_PITCH, Solver.PLANAR_3R)
    calls = []
    real = _ik_small.solve_all
    monkeypatch.setattr(_ik_small, "solve_all", lambda *a: calls.append(1) or real(*a))
    rng = np.random.default_rng(sorted(ROBOTS).index(name))
    targets = _targets(robot, rng)
    branches = ik_all(robot, targets[0]).branches
    kinds = {"fail": 0, "ok": 0}
    for t in targets:
        _same_solutions(ik_all(robot, t), _batched(monkeypatch, ik_all, robot, t))
        q_near = rng.uniform(-np.pi, np.pi, 3)
        for branch in (None,) + branches:
            for near in (None, q_near):
                small = _outcome(ik, robot, t, branch=branch, q_near=near)
                _same(small, _batched(monkeypatch, ik, robot, t, branch=branch, q_near=near))
                kinds["fail" if isinstance(small, Exception) else "ok"] += 1
    assert kinds["fail"] > 0 and kinds["ok"] > 0  # both outcomes exercised
    # small batches with a batch shape, as arrays and as nested lists
    for shape in ((_ik_small.SMALL_TARGETS,), (2, 2), (1,)):
        k = int(np.prod(shape))
        t = targets[rng.choice(len(targets), k, replace=False)].reshape(shape + (3,))
        _same_solutions(ik_all(robot, t.tolist()), _batched(monkeypatch, ik_all, robot, t))
        for branch in (None,) + branches:
            _same(_outcome(ik, robot, t, branch=branch),
                  _batched(monkeypatch, ik, robot, t, branch=branch))
    assert calls  # the small path did run


def test_small_path_is_used_only_for_small_batches_and_its_families(monkeypatch):
    calls = []
    real = _ik_small.solve_all
    monkeypatch.setattr(_ik_small, "solve_all", lambda *a: calls.append(len(a[2])) or real(*a))
    arm = Robot.load("arduino_arm_3dof")
    t = fk(arm, np.radians([[45.0, 60.0, 30.0]] * (_ik_small.SMALL_TARGETS + 1)))[:, :3, 3]
    ik_all(arm, t[0])
    ik(arm, t[:_ik_small.SMALL_TARGETS], branch="elbow_up")
    assert calls == [1, _ik_small.SMALL_TARGETS]
    ik_all(arm, t)  # one target too many: the batched path
    puma = Robot.load("puma560")
    ik_all(puma, fk(puma, np.full(6, 0.3)))
    ik_all(puma, fk(puma, np.full((_ik_small.SMALL_TARGETS + 1, 6), 0.3)))  # batched
    ur5 = Robot.load("ur5")  # three_parallel: no small path
    ik_all(ur5, fk(ur5, np.full(6, 0.3)))
    assert calls == [1, _ik_small.SMALL_TARGETS, 1]


def _wrists():
    puma = Robot.load("puma560")
    base = np.eye(4)
    base[:3, :3] = rotation_z(0.4)
    base[:3, 3] = [0.05, -0.1, 0.3]
    tool = np.eye(4)
    tool[:3, 3] = [0.0, 0.01, 0.08]
    return {
        "puma560": puma,
        "puma600_seed002": Robot.load("puma600_seed002"),
        "irb140": Robot.load("irb140"),
        "kr5": Robot.load("kr5"),
        "puma_flipped_2_4_6": _flipped(puma, [False, True, False, True, False, True]),
        "puma_moved_base_tool": puma.replace(base=base, tool=tool),
        "puma_oblique_wrist": puma.with_link(3, alpha=puma.links[3].alpha * 2 / 3),  # axes 4, 5 at 60 deg
        "puma_wide_limits": _limits(puma, [(-2 * np.pi, 2 * np.pi)] * 6),
    }


WRISTS = _wrists()


@pytest.mark.parametrize("name", sorted(WRISTS))
def test_small_path_equals_the_batched_spherical_wrist(name, monkeypatch):
    robot = WRISTS[name]
    assert solver_for(robot) is Solver.SPHERICAL_WRIST
    calls = []
    real = _ik_small.solve_all
    monkeypatch.setattr(_ik_small, "solve_all", lambda *a: calls.append(1) or real(*a))
    rng = np.random.default_rng(sorted(WRISTS).index(name) + 100)
    T = fk(robot, rng.uniform(-np.pi, np.pi, size=(30, 6)))
    T[:8, :3, 3] *= rng.uniform(0.3, 2.5, size=(8, 1))  # many out of reach
    T[8:10, :3, 3] = [[0.0, 0.0, 0.4], [0.0, 0.0, -0.2]]  # wrist centre near the base axis
    T[10] = fk(robot, np.zeros(6))  # wrist singularity (q5 = 0 on a PUMA)
    branches = ik_all(robot, T[0]).branches
    kinds = {"fail": 0, "ok": 0}
    for t in T:
        _same_solutions(ik_all(robot, t), _batched(monkeypatch, ik_all, robot, t))
        q_near = rng.uniform(-np.pi, np.pi, 6)
        for branch in (None,) + branches[::3]:
            for near in (None, q_near):
                small = _outcome(ik, robot, t, branch=branch, q_near=near)
                _same(small, _batched(monkeypatch, ik, robot, t, branch=branch, q_near=near))
                kinds["fail" if isinstance(small, Exception) else "ok"] += 1
    assert kinds["fail"] > 0 and kinds["ok"] > 0
    for shape in ((_ik_small.SMALL_TARGETS,), (2, 2)):
        t = T[rng.choice(len(T), int(np.prod(shape)), replace=False)].reshape(shape + (4, 4))
        _same_solutions(ik_all(robot, t.tolist()), _batched(monkeypatch, ik_all, robot, t))
    assert calls


def test_bad_poses_raise_as_before(monkeypatch):
    puma = Robot.load("puma560")
    T = fk(puma, np.full(6, 0.3))
    skew = T.copy()
    skew[:3, :3] *= 1.001
    mirror = T.copy()
    mirror[:3, 0] *= -1
    row = T.copy()
    row[3, 0] = 1e-9
    nan = T.copy()
    nan[0, 3] = np.nan
    far = T.copy()
    far[:3, 3] *= 5
    for target in (skew, mirror, row, nan, T[:3], np.stack([T, skew]), far, "abc"):
        for func in (ik, ik_all):
            small = _outcome(func, puma, target)
            batched = _batched(monkeypatch, func, puma, target)
            if func is ik_all and not isinstance(batched, Exception):
                _same_solutions(small, batched)
                continue
            assert isinstance(small, Exception) and type(small) is type(batched)
            assert str(small) == str(batched)


def test_bad_input_raises_as_before(monkeypatch):
    arm = Robot.load("arduino_arm_3dof")
    planar = Robot.load("planar3r_seed004")
    t = fk(arm, np.radians([45.0, 60.0, 30.0]))[:3, 3]
    cases = [
        (arm, [0.1, np.nan, 0.0], {}),
        (arm, [0.1, 0.2], {}),
        (arm, "abc", {}),
        (arm, [[0.1, 0.2, 0.3]] * 2 + [[0.1, 0.2]], {}),
        (arm, t, {"branch": "sideways"}),
        (arm, t, {"q_near": [0.1, 0.2]}),
        (arm, t, {"q_near": [0.1, np.inf, 0.2]}),
        (arm, np.stack([t, t]), {"q_near": np.zeros((3, 3))}),
        (planar, [0.3, 0.2, np.inf], {"branch": "elbow_minus"}),
        (planar, [5.0, 0.2, 0.0], {}),
    ]
    for robot, target, kw in cases:
        for func in (ik, ik_all):
            if func is ik_all and kw:
                continue
            try:
                small = _outcome(func, robot, target, **kw)
            except ValueError as exc:  # numpy's own (ragged input, broadcasting), not ours
                small = exc
            try:
                batched = _batched(monkeypatch, func, robot, target, **kw)
            except ValueError as exc:
                batched = exc
            if func is ik_all and not isinstance(batched, Exception):  # out of reach: no error
                _same_solutions(small, batched)
                continue
            assert isinstance(small, Exception) and type(small) is type(batched)
            assert str(small) == str(batched)
    # q_near broadcast over a small batch (shape (2, 3)) still works, through the batched path
    q = ik(arm, np.stack([t, t]), q_near=np.radians([[45.0, 60.0, 30.0]] * 2))
    np.testing.assert_allclose(q, np.radians([[45.0, 60.0, 30.0]] * 2), atol=1e-12)
