"""Running a closed-form family on targets, and the one finishing step (private).

:func:`solve` runs a family's formulas on the validated targets as numpy rows
in cache-sized chunks (one target on Python floats, :mod:`._elementwise`), then
every joint value goes through :func:`finish`: flipped joints negated, revolute
angles wrapped into ``(-pi, pi]`` (:func:`labkit.rotations.wrap_angle`) and
shifted by a turn where that enters the limits; no NaN leaves (an unreachable
branch is a finite fill, :mod:`labkit.kinematics._ik`). Whether a configuration
lies inside the limits is :meth:`labkit.robot.Robot.within_limits`, and which
valid branch is nearest a preferred configuration is :func:`nearest`, both for
every solver.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.kinematics._chain import _per_robot
from labkit.rotations import wrap_angle

#: targets per numpy call of a family
_CHUNK = 8192
#: one turn [rad]
_TURN = 2 * math.pi
#: slack of the limits [rad] (as ``Robot.within_limits``)
_SLACK = 1e-9


def finish(robot, q, *, flipped=True, copy=True):
    """A solver's joint values [rad, m] as the robot's: revolute angles wrapped into (-pi, pi], then a turn
    up or down where that enters the joint's limits; non-finite values replaced by 0.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., n)
    flipped : bool
        ``q`` is in the chain's sense (a closed-form family's): negate the flipped joints.
    copy : bool
        False: overwrite ``q`` where it is a float array.

    Returns
    -------
    ndarray, shape (..., n)
    """
    q = np.array(q, dtype=float) if copy else np.asarray(q, dtype=float)
    flip, any_flip, rev, lo, hi, up, down = _joints(robot)
    if flipped and any_flip:
        q[..., flip] *= -1.0
    v = wrap_angle(q[..., rev])
    # a value below the limits may enter them one turn up, one above them one turn down (pi itself, when the
    # range starts at -pi); either only where the limits reach beyond (-pi, pi] (``up``, ``down``)
    if up:
        turned = v + _TURN
        v = np.where((v < lo) & (turned <= hi), turned, v)
    if down:
        turned = v - _TURN
        v = np.where((v > hi) & (turned >= lo), turned, v)
    q[..., rev] = v
    finite = np.isfinite(q)
    if not finite.all():
        q[~finite] = 0.0
    return q


@_per_robot
def _joints(robot):
    """Flipped joints (and whether any), revolute ones (a slice of all when all are: a view, not a copy),
    their limits with slack [rad], and whether a wrapped angle v can go a turn up (v < lo needs lo > -pi;
    v + 2 pi rounds to >= pi, so hi >= pi) or down."""
    lim, rev = robot.joint_limits, robot.is_revolute
    lo, hi = lim[rev, 0] - _SLACK, lim[rev, 1] + _SLACK
    up, down = bool(((lo > -math.pi) & (hi >= math.pi)).any()), bool(((hi < math.pi) & (lo <= -math.pi)).any())
    return robot.flip, bool(robot.flip.any()), slice(None) if rev.all() else rev, lo, hi, up, down


def solve(robot, family, flat):
    """Every branch of validated targets (``_targets.validate_targets``), finished.

    Parameters
    ----------
    robot : Robot
    family : Family
    flat : ndarray, shape (N, k) or (N, 4, 4)

    Returns
    -------
    q, reachable, valid, distance : ndarray, shape (N, m, n), (N, m), (N, m), (N,)
        Joint values [rad, m] per branch (unreachable: a finite fill), reachable, valid (reachable and
        inside the limits), and how far each target lies out of reach [m] (0 if a branch reaches it).
    """
    N, m, n = flat.shape[0], len(family.branches), robot.n
    q, reach, distance = np.empty((N, m, n)), np.empty((N, m), dtype=bool), np.empty(N)
    if N == 1:  # one target: its components as Python floats (the same formulas, :mod:`._elementwise`)
        qb, rb, d = _solve_one(family, flat[0])
        try:  # floats or numpy scalars: one array each
            q, reach, distance = (np.array(v, dtype=t).reshape(s) for v, t, s in
                                  ((qb, float, q.shape), (rb, bool, reach.shape), (d, float, distance.shape)))
        except ValueError:  # a family that answers one target with rows of one, some beside floats
            _gather(q, reach, distance, slice(0, 1), qb, rb, d)
    else:
        for s in range(0, N, _CHUNK):
            part = slice(s, s + _CHUNK)
            _gather(q, reach, distance, part, *family.solve(np.ascontiguousarray(np.moveaxis(flat[part], 0, -1))))
    q = finish(robot, q, copy=False)
    distance[reach.any(axis=1)] = 0.0
    return q, reach, reach & robot.within_limits(q), distance


def _gather(q, reach, distance, part, qb, rb, d):
    """Write a family's answer for the targets ``part`` (per branch, rows or scalars) into the arrays."""
    for k, (branch, ok) in enumerate(zip(qb, rb)):
        for j, v in enumerate(branch):
            q[part, k, j] = v
        reach[part, k] = ok
    distance[part] = d


def _solve_one(family, target):
    """The family on one target, its components as Python floats; on numpy scalars where a float operation
    raises (a division by an exact zero, ``sqrt`` of a negative number: numpy's inf/nan instead)."""
    try:
        return family.solve(target.tolist())
    except (ArithmeticError, ValueError):
        return family.solve(target)


def nearest(robot, q, valid, q_near):
    """Per target the valid branch nearest ``q_near`` (revolute differences wrapped), else the first valid one.

    Parameters
    ----------
    robot : Robot
    q : ndarray, shape (N, m, n)
        Every branch [rad, m].
    valid : ndarray of bool, shape (N, m)
    q_near : ndarray, shape (N, n) or None
        Preferred configurations [rad, m]; None: the first valid branch.

    Returns
    -------
    ndarray of int, shape (N,)
        0 where none is valid.
    """
    if q_near is None or q.shape[1] == 1:
        return np.argmax(valid, axis=1)
    d = q - q_near[:, None, :]
    d = np.where(robot.is_revolute, wrap_angle(d), d)
    return np.argmin(np.where(valid, (d * d).sum(axis=-1), np.inf), axis=1)
