"""Running a closed-form family on targets, and the one finishing step (private).

:func:`solve` runs a family's formulas on the validated targets: a few targets
of a family with ``scalar = True`` on Python floats
(:data:`~labkit.kinematics.ik._xp.FLOATS`; the formulas and the finishing of
every branch compiled per robot and solver into straight-line code by
:mod:`labkit.kinematics.ik._trace`, :func:`finished_solver`), anything else
on numpy rows in cache-sized chunks (:data:`~labkit.kinematics.ik._xp.NUMPY`). Either way every
joint value then goes through :func:`finish`: flipped joints negated, revolute
angles wrapped into ``(-pi, pi]`` (:func:`labkit.rotations.wrap_angle`) and
shifted by a turn where that enters the limits, and the limit test.

No NaN ever leaves: where a branch cannot reach a target its ``reachable``
flag is False and its ``q`` holds the finite configuration obtained by
clipping the cosine-law arguments to [-1, 1] (the arm stretched or folded
towards the target), a fill, not a solution.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from labkit.kinematics._chain import per_robot
from labkit.kinematics.ik import _targets
from labkit.kinematics.ik._trace import compiled
from labkit.kinematics.ik._xp import FLOATS, NUMPY
from labkit.rotations import wrap_angle

#: targets per numpy call of a family
_CHUNK = 8192
#: one turn [rad]
_TURN = 2 * math.pi
#: slack of the limit test [rad, m] (as ``Robot.within_limits``)
_SLACK = 1e-9


@per_robot
def joints(robot):
    """Per joint what :func:`finish` needs (cached per robot object).

    Parameters
    ----------
    robot : Robot
        The arm whose links are read.

    Returns
    -------
    tuple of tuple
        ``(revolute, flip, lower, upper, turn_up, turn_down)`` per joint: the limits
        with the slack of the limit test [rad, m], and whether a turn up or down
        can enter them.
    """
    out = []
    for lk in robot.links:
        lo, hi = float(lk.limits[0]), float(lk.limits[1])
        # a value in (-pi, pi] below the limits may enter them one turn up, or one turn down above them
        # (pi itself, when the range starts at -pi)
        out.append((lk.is_revolute, lk.flip, lo - _SLACK, hi + _SLACK, hi > math.pi, lo < -math.pi + _SLACK))
    return tuple(out)


def finish(xp, v, joint):
    """One joint's values from a family, as the robot's joint values, and whether they are in the limits.

    Parameters
    ----------
    xp : namespace
        Array namespace of ``v``.
    v : ndarray or float
        Joint values in the chain's sense [rad, m].
    joint : tuple
        One joint's entry of :func:`joints`.

    Returns
    -------
    v : ndarray or float
        Negated for a flipped joint; for a revolute one wrapped into (-pi, pi],
        then a turn up or down where that enters the limits; non-finite
        values replaced by 0.
    inside : ndarray of bool or bool
        Inside the limits (slack 1e-9).
    """
    rev, flip, lo, hi, turn_up, turn_down = joint
    if flip:
        v = -v
    if rev:
        v = xp.wrap(v)
        # a turn can only apply outside the limits: one float inside them skips it (a batch, or a traced value,
        # takes it per element)
        if (turn_up or turn_down) and (type(v) is not float or not lo <= v <= hi):
            if turn_up:
                up = v + _TURN
                v = xp.where((v < lo) & (up <= hi), up, v)
            if turn_down:
                dn = v - _TURN
                v = xp.where((v > hi) & (dn >= lo), dn, v)
    if xp.batch:  # (the float formulas raise rather than return NaN)
        v = xp.where(xp.isfinite(v), v, 0.0)
    return v, (v >= lo) & (v <= hi)


def finish_all(robot, q, *, flipped=True):
    """:func:`finish` on every joint of ``q`` (..., n): a new array and the in-limits flags (...).

    ``flipped=False`` for joint values that are already the robot's (numeric IK): wrap and limits only.

    Parameters
    ----------
    robot : Robot
        The arm.
    q : array_like, shape (..., n)
        Joint values [rad, m].
    flipped : bool
        Negate flipped joints (values in the chain's sense).

    Returns
    -------
    q : ndarray, shape (..., n)
        Finished joint values [rad, m].
    inside : ndarray of bool, shape (...)
        Inside the joint limits.
    """
    q = np.array(q, dtype=float)
    inside = np.ones(q.shape[:-1], dtype=bool)
    for j, (rev, flip, *rest) in enumerate(joints(robot)):
        q[..., j], ok = finish(NUMPY, q[..., j], (rev, flip and flipped, *rest))
        inside &= ok
    return q, inside


def solve(robot, family, flat):
    """Every branch of validated targets, finished.

    Parameters
    ----------
    robot : Robot
        The arm.
    family : Family
        Its closed-form solver.
    flat : ndarray, shape (N, 3) or (N, 4, 4)
        Validated targets (:func:`labkit.kinematics.ik._targets.validate_targets`).

    Returns
    -------
    q : ndarray, shape (N, m, n)
        Joint values [rad, m] per branch (unreachable: a finite fill).
    reachable : ndarray of bool, shape (N, m)
    valid : ndarray of bool, shape (N, m)
        Reachable and inside the joint limits.
    distance : ndarray, shape (N,)
        How far each target lies out of reach [m] (0 if any branch reaches it).
    """
    N, m, n = flat.shape[0], len(family.branches), robot.n
    if family.scalar and N <= _targets.SMALL_TARGETS:
        Q, R, V, D = solve_floats(robot, family, flat.tolist())
        reach_valid = np.array((R, V), dtype=bool)  # (one array for both: one conversion)
        return np.array(Q, dtype=float), reach_valid[0], reach_valid[1], np.array(D, dtype=float)
    q = np.empty((N, m, n))
    reach = np.empty((N, m), dtype=bool)
    distance = np.empty(N)
    for s in range(0, N, _CHUNK):
        part = flat[s:s + _CHUNK]
        qb, rb, d = family.solve(NUMPY, np.ascontiguousarray(np.moveaxis(part, 0, -1)))
        for k, (branch, ok) in enumerate(zip(qb, rb)):
            for j, v in enumerate(branch):
                q[s:s + _CHUNK, k, j] = v
            reach[s:s + _CHUNK, k] = ok
        distance[s:s + _CHUNK] = d
    q, inside = finish_all(robot, q)
    distance[reach.any(axis=1)] = 0.0
    return q, reach, reach & inside, distance


@per_robot
def _finished_solvers(robot):
    """``{family: compiled function}`` of :func:`finished_solver` for ``robot`` (filled when asked)."""
    return {}


def finished_solver(robot, family):
    """``t -> (q, reachable, valid, distance)`` of one target: every branch of ``family``, finished for ``robot``.

    The family's formulas and :func:`finish` of every joint value of every
    branch, compiled together into one straight-line function
    (:func:`labkit.kinematics.ik._trace.compiled`; cached per robot and
    family; where tracing fails the same code runs on
    :data:`~labkit.kinematics.ik._xp.FLOATS`). ``family`` may be the solver
    of an idealised copy of ``robot`` (the same joints and limits).

    Parameters
    ----------
    robot : Robot
        The arm whose joints finish the values.
    family : Family
        A closed-form solver with ``scalar = True``.

    Returns
    -------
    callable
        Of one target (nested lists of floats,
        :func:`labkit.kinematics.ik._targets.small_targets`), returning per
        branch the finished joint values (lists of floats), whether it
        reaches the target, whether it also lies inside the limits, and the
        family's distance out of reach [m].
    """
    cache = _finished_solvers(robot)
    f = cache.get(family)
    if f is None:
        finished = functools.partial(solve_finished, family=family, js=joints(robot))
        f = (compiled(finished, (_targets.target_shape(family.kind),), f"ik {family.name}, finished for {robot.name}")
             or functools.partial(finished, FLOATS))
        cache[family] = f
    return f


def solve_finished(xp, t, family, js):
    """Every branch of ``family`` for target ``t``, finished (the function :func:`finished_solver` compiles).

    Parameters
    ----------
    xp : namespace
        Array namespace of the target's components.
    t : sequence
        The target's components (``t[i]``, or ``t[i][j]`` for a pose).
    family : Family
        The closed-form solver.
    js : tuple
        :func:`joints` of the robot.

    Returns
    -------
    q : list of list
        Per branch the finished joint values [rad, m].
    reachable, valid : list
        Per branch whether it reaches the target, and also lies inside the limits.
    distance : float or ndarray
        The family's distance out of reach [m].
    """
    qb, rb, d = family.solve(xp, t)
    rows, valid = [], []
    for branch, ok in zip(qb, rb):
        row = []
        for v, joint in zip(branch, js):
            v, inside = finish(xp, v, joint)
            row.append(v)
            ok = ok & inside
        rows.append(row)
        valid.append(ok)
    return rows, list(rb), valid, d


def solve_floats(robot, family, targets):
    """:func:`solve` on Python floats, for a few targets of a family with ``scalar = True``.

    Parameters
    ----------
    robot, family : Robot, Family
        The arm and its closed-form solver, as for :func:`solve`.
    targets : list
        Valid targets as nested lists of floats
        (:func:`labkit.kinematics.ik._targets.small_targets`).

    Returns
    -------
    q : list, shape (N, m, n)
    reachable, valid : list of list of bool, shape (N, m)
    distance : list of float, shape (N,)
        As :func:`solve`.
    """
    solve_one = finished_solver(robot, family)
    Q, R, V, D = [], [], [], []
    for t in targets:
        rows, rb, valid, d = solve_one(t)
        Q.append(rows)
        R.append(rb)
        V.append(valid)
        D.append(0.0 if any(rb) else d)
    return Q, R, V, D


def pick_floats(robot, family, targets, idx, q_near):
    """One solution per target on Python floats, as :func:`labkit.kinematics.ik` picks it, or None.

    Every branch is solved and finished by one compiled function
    (:func:`finished_solver`), then the one asked for, the first valid one,
    or the valid one nearest to ``q_near`` is taken.

    Parameters
    ----------
    robot : Robot
        The arm.
    family : Family
        Its closed-form solver (``scalar = True``).
    targets : list
        Valid targets as nested lists of floats
        (:func:`labkit.kinematics.ik._targets.small_targets`).
    idx : int or None
        The requested branch, or None for the valid branch nearest ``q_near``
        (the first valid one without it).
    q_near : list of float or None
        The preferred configuration [rad, m], one for every target.

    Returns
    -------
    list of list of float, shape (N, n), or None
        None when a target has no valid solution on the branch asked for (the
        batched path then says why).
    """
    rev = [j[0] for j in joints(robot)]
    solve_one = finished_solver(robot, family)
    out = []
    for t in targets:
        rows, _, valid, _ = solve_one(t)
        if idx is not None:
            if not valid[idx]:
                return None
            out.append(rows[idx])
            continue
        best, best_d = None, math.inf
        for row, ok in zip(rows, valid):  # (valid: reachable and inside the limits)
            if not ok:
                continue
            if q_near is None:
                best = row
                break
            dd = 0.0
            for x, y, r in zip(row, q_near, rev):
                e = wrap_angle(x - y) if r else x - y
                dd += e * e
            if dd < best_d:
                best, best_d = row, dd
        if best is None:
            return None
        out.append(best)
    return out
