"""The arithmetic of the Levenberg-Marquardt loop, on numpy rows or on Python floats (private).

:func:`labkit.kinematics.ik._numeric.solve` runs one loop (restarts, stall
tests, the active set); what it computes per target comes from one of two
evaluators with the same methods:

* :class:`Batch` - the active targets as numpy rows: one call of the
  per-robot fk + Jacobian program (:func:`labkit.kinematics._forward.fk_jacobian_kernel`)
  and one batched linear solve per iteration for them all;
* :class:`Floats` - a few targets (at most ``FLOAT_TARGETS`` of the loop, also a
  batch's last few), each on Python floats: the program's generated Python
  code (:func:`labkit.kinematics._forward.fk_jacobian_kernel` with ``floats``)
  and the task error compiled together into one straight-line function, the
  damped step into another (a Cholesky solve of the normal equations), so one
  target makes no array call per iteration.

The task error (:func:`task_error`) and the damped step (:func:`step`) are
written once, for both: the step against a small linear algebra, numpy's
batched matrices (:data:`MATRICES`) or nested lists (:class:`Lists`).
"""

from __future__ import annotations

import functools
import operator

import numpy as np

from labkit.kinematics._chain import per_robot
from labkit.kinematics._forward import fk_jacobian_kernel
from labkit.kinematics.ik._step import MATRICES, Lists, step
from labkit.kinematics.ik._targets import target_shape, task_rows
from labkit.kinematics.ik._trace import compiled
from labkit.kinematics.ik._xp import FLOATS, NUMPY


def task_error(xp, kind, T, t, E, rows):
    """Task error and residual of one pose against its target, on components (written once).

    Parameters
    ----------
    xp : namespace
        :data:`~labkit.kinematics.ik._xp.NUMPY` (components are ``(N,)``
        arrays) or :data:`~labkit.kinematics.ik._xp.FLOATS` (floats).
    kind : {"position", "planar", "pose"}
        What the target fixes.
    T : nested components ``T[i][j]``
        Pose (rows 0-2 used) [m].
    t : nested components
        Target: ``t[i]`` for a point or ``(x, y, phi)``, ``t[i][j]`` for a pose.
    E : nested components or None
        ``R_t R^T`` for a pose target.
    rows : tuple of int
        Rows of ``[vx, vy, vz, wx, wy, wz]`` the task constrains.

    Returns
    -------
    e : list
        One component per row [m, rad].
    residual : ndarray or float
        Norm of the position error and, for a whole orientation,
        ``2 sin(angle / 2)`` (robust near pi; otherwise the orientation
        components' norm) [m, rad].
    """
    slots, squared, whole = _plan(kind, rows)
    if kind == "pose":
        comp, ang = _pose_error(xp, E, T, t)
    elif kind == "position":
        comp = (t[0] - T[0][3], t[1] - T[1][3], t[2] - T[2][3])
    else:  # planar: x, y and the heading
        comp = (t[0] - T[0][3], t[1] - T[1][3], xp.wrap(t[2] - xp.arctan2(T[1][0], T[0][0])))
    e = list(comp) if slots is None else [comp[i] for i in slots]
    res2 = 0.0
    for i in squared:
        res2 = res2 + e[i] * e[i]
    if whole:
        o = 2.0 * xp.sin(0.5 * ang)  # = |R - R_target|_F / sqrt(2), ~ angle
        res2 = res2 + o * o
    return e, xp.sqrt(res2)


@functools.cache
def _plan(kind, rows):
    """How :func:`task_error` reads a kind's components for ``rows`` (a tuple): which component each row is
    (None: all, in order), which rows' squares make the residual, and whether the whole orientation enters it
    as an angle instead."""
    slots = tuple(task_rows(kind).index(r) for r in rows)
    slots = None if slots == tuple(range(len(task_rows(kind)))) else slots  # (None: every component, in order)
    whole = kind == "pose" and sum(r >= 3 for r in rows) == 3
    return slots, tuple(i for i, r in enumerate(rows) if not (whole and r >= 3)), whole


def error(kind, T, target, rows):
    """:func:`task_error` of a batch: poses against targets.

    Parameters
    ----------
    kind : {"position", "planar", "pose"}
        What the targets fix.
    T : ndarray, shape (N, 4, 4)
        Poses [m].
    target : ndarray, shape (N, 3) or (N, 4, 4)
        Targets [m, rad].
    rows : sequence of int
        Task rows (of ``[vx, vy, vz, wx, wy, wz]``).

    Returns
    -------
    e : ndarray, shape (N, len(rows))
        Task error [m, rad].
    residual : ndarray, shape (N,)
        Its norm as :func:`task_error` measures it [m, rad].
    """
    E = None
    if kind == "pose":
        E = (target[:, :3, :3] @ T[:, :3, :3].swapaxes(-1, -2)).transpose(1, 2, 0)
    t = target.transpose((*range(1, target.ndim), 0))
    e, res = task_error(NUMPY, kind, T.transpose(1, 2, 0), t, E, tuple(rows))
    return np.stack(e, axis=1), res


class Batch:
    """The arithmetic of the LM loop on numpy rows: a batch of targets.

    The state of the active targets is numpy arrays: ``q`` (N, n), targets
    (N, ...), ``J`` (N, m, n), ``e`` (N, m), and the residuals, damping and
    squared errors (N,). :class:`Floats` has the same methods on lists.

    Parameters
    ----------
    robot, kind, rows : Robot, {"position", "planar", "pose"}, sequence of int
        The arm, what the targets fix and the task rows (of ``[vx, vy, vz,
        wx, wy, wz]``).
    """

    def __init__(self, robot, kind, rows):
        self.kind, self.rows = kind, tuple(rows)
        self.all_rows = len(rows) == 6
        self._kernel = fk_jacobian_kernel(robot)  # (no checks: q is made here)

    def enter(self, q, target, lam):
        """The state's form of joint values, targets and damping.

        Parameters
        ----------
        q : ndarray, shape (N, n)
            Joint values [rad, m].
        target : ndarray, shape (N, 3) or (N, 4, 4)
            Targets [m, rad].
        lam : ndarray, shape (N,)
            Damping.

        Returns
        -------
        tuple
            ``(q, target, lam)`` in the evaluator's form (here ``q`` copied, the rest unchanged).
        """
        return q.copy(), target, lam

    def arrays(self, q, target, J, e, res, lam, E, E_check):
        """The state as numpy arrays.

        Parameters
        ----------
        q, target, J, e, res, lam, E, E_check : state form
            Joint values, targets, Jacobian rows, errors, residuals, damping,
            squared errors and those of the last stall test, of N targets.

        Returns
        -------
        tuple of ndarray
            The same, as arrays of the shapes above (here unchanged).
        """
        return q, target, J, e, res, lam, E, E_check

    def state(self, q, target, J, e, res, lam, E, E_check):
        """:meth:`arrays` undone: numpy arrays back in the evaluator's form.

        Parameters
        ----------
        q, target, J, e, res, lam, E, E_check : ndarray
            As :meth:`arrays` returns them.

        Returns
        -------
        tuple
            The state in the evaluator's form (here unchanged).
        """
        return q, target, J, e, res, lam, E, E_check

    def evaluate(self, q, target):
        """Jacobian task rows, error, residual and ``e.e / 2`` at ``q``.

        Parameters
        ----------
        q : state form of joint values, N rows [rad, m]
        target : state form of the targets, N rows [m, rad]

        Returns
        -------
        tuple
            ``(J, e, res, E)`` in the state's form.
        """
        T, J = self._kernel(q)
        J = J if self.all_rows else J[:, self.rows]
        e, res = error(self.kind, T, target, self.rows)
        return J, e, res, 0.5 * np.einsum("ij,ij->i", e, e)

    def bounds(self, limits, free):
        """An attempt's joint bounds in the form :meth:`moved` takes them.

        Parameters
        ----------
        limits : labkit.kinematics.ik._numeric._Limits
            The robot's limits as the LM loop keeps them.
        free : bool
            The attempt ignores the revolute joints' limits.

        Returns
        -------
        tuple
            ``(lo, hi)``, arrays (n,) [rad, m].
        """
        return (limits.free_lo, limits.free_hi) if free else (limits.lo, limits.hi)

    def converged(self, res, tol):
        """Which residuals are below ``tol``.

        Parameters
        ----------
        res : state form of the residuals, N entries [m, rad]
        tol : float
            Convergence threshold [m, rad].

        Returns
        -------
        tuple
            ``(done, any, all)``: a mask (N,) and whether any / all are done.
        """
        done = res < tol
        any_done = done.any()
        return done, any_done, any_done and done.all()

    def moved(self, q, J, e, lam, lo, hi):
        """The damped step (:func:`step`) from ``q``, clipped to ``[lo, hi]``.

        Parameters
        ----------
        q, J, e, lam : state form
            Joint values, Jacobian rows, error and damping of N targets.
        lo, hi : ndarray, shape (n,), or list
            Bounds of this attempt [rad, m].

        Returns
        -------
        state form of joint values, N rows [rad, m]
        """
        qn = q + step(MATRICES, J, e, lam)
        np.maximum(qn, lo, out=qn)
        return np.minimum(qn, hi, out=qn)

    def accept(self, old, new):
        """Per target the better of two iterates, and the new damping.

        Parameters
        ----------
        old : tuple
            ``(q, J, e, res, E, lam)`` before the step.
        new : tuple
            ``(q, J, e, res, E)`` after it.

        Returns
        -------
        tuple
            ``(q, J, e, res, E, lam)``: ``new`` where its ``E`` is lower
            (damping / 10, at least 1e-12), else ``old`` (damping x 10, at
            most 1e8).
        """
        qa, J, e, res, E, lam = old
        better = new[4] < E
        if better.all():
            return (*new, np.maximum(lam * 0.1, 1e-12))
        return (np.where(better[:, None], new[0], qa), np.where(better[:, None, None], new[1], J),
                np.where(better[:, None], new[2], e), np.where(better, new[3], res), np.where(better, new[4], E),
                np.where(better, np.maximum(lam * 0.1, 1e-12), np.minimum(lam * 10.0, 1e8)))


class Floats(Batch):
    """The arithmetic of the LM loop on Python floats, target by target: a few targets.

    One target's evaluation is one straight-line function, compiled per
    robot (:mod:`labkit.kinematics.ik._trace`) from the per-robot program's
    generated code and :func:`task_error`; its step is another, :func:`step`
    on :class:`Lists` and the clip into the bounds (should rounding leave the
    normal matrix not positive definite, that target's step is :class:`Batch`'s,
    LU). The state is lists with one entry per
    target (joint values, targets and errors as lists of floats, a
    Jacobian as its ``m * n`` entries row by row). Parameters and methods
    as :class:`Batch`.
    """

    def __init__(self, robot, kind, rows):
        super().__init__(robot, kind, rows)
        self.n = n = robot.n
        # one target's evaluation compiled into one straight-line function: the per-robot program's
        # generated code run on symbols (its tangent recorded) and the task error (else the same on FLOATS)
        shapes = ((n,), target_shape(kind))
        one = functools.partial(_evaluate_one, robot=robot, kind=kind, rows=self.rows)
        self._one = compiled(one, shapes, f"ik {kind} evaluation") or functools.partial(one, FLOATS)
        # and one target's clipped damped step, the same way (the normal equations solved by Cholesky)
        shapes = ((n,), (len(self.rows) * n,), (len(self.rows),), (), (n,), (n,))
        moved = functools.partial(_moved_one, rows=self.rows, n=n)
        self._moved = compiled(moved, shapes, "ik damped step") or functools.partial(moved, FLOATS)

    def enter(self, q, target, lam):
        return q.tolist(), target.tolist(), lam.tolist()

    def arrays(self, q, target, J, e, res, lam, E, E_check):
        N = len(q)
        m = len(self.rows)
        return (np.array(q, dtype=float).reshape(N, self.n), np.array(target, dtype=float),
                np.array(J, dtype=float).reshape(N, m, self.n), np.array(e, dtype=float).reshape(N, m),
                *(np.array(x, dtype=float) for x in (res, lam, E, E_check)))

    def state(self, q, target, J, e, res, lam, E, E_check):
        N = q.shape[0]
        return (q.tolist(), target.tolist(), J.reshape(N, -1).tolist(), e.tolist(), res.tolist(), lam.tolist(),
                E.tolist(), E_check.tolist())

    def evaluate(self, q, target):
        Js, es, rs, Es = [], [], [], []
        for qk, tk in zip(q, target):
            J, e, res, E = self._one(qk, tk)
            Js.append(J)
            es.append(e)
            rs.append(res)
            Es.append(E)
        return Js, es, rs, Es

    def bounds(self, limits, free):
        return limits.lists[free]

    def converged(self, res, tol):
        done = list(map(float(tol).__gt__, res))  # (r < tol for each float residual r)
        return done, any(done), all(done)

    def moved(self, q, J, e, lam, lo, hi):
        out = []
        for qk, Jk, ek, lk in zip(q, J, e, lam):
            try:
                out.append(self._moved(qk, Jk, ek, lk, lo, hi))
            except (ValueError, ZeroDivisionError):  # rounding left J^T J + lam I not positive definite:
                out.append(super().moved(  # the batch path's step (LU) on this one target
                    np.array([qk]), np.reshape(Jk, (1, len(self.rows), self.n)), np.array([ek]), np.array([lk]),
                    np.asarray(lo), np.asarray(hi))[0].tolist())
        return out

    def accept(self, old, new):
        lam = old[5]
        if all(map(operator.lt, new[4], old[4])):
            return (*new, [max(lk * 0.1, 1e-12) for lk in lam])
        better = list(map(operator.lt, new[4], old[4]))
        return (*([x if g else y for g, x, y in zip(better, a, b)] for a, b in zip(new, old)),
                [max(lk * 0.1, 1e-12) if g else min(lk * 10.0, 1e8) for g, lk in zip(better, lam)])


for _name in ("enter", "arrays", "state", "evaluate", "bounds", "converged", "moved", "accept"):
    getattr(Floats, _name).__doc__ = getattr(Batch, _name).__doc__  # the same contract on lists
del _name


def _evaluate_one(xp, q, t, robot, kind, rows):
    """One target's Jacobian task rows (their ``m * n`` entries row by row), task error, residual and
    ``e.e / 2`` at joint values ``q`` (:meth:`Floats.evaluate`, compiled)."""
    out = fk_jacobian_kernel(robot, floats=True, tan=xp.tan)(q)
    n = robot.n
    J = out[:6 * n] if len(rows) == 6 else [x for r in rows for x in out[r * n:(r + 1) * n]]
    e, res = _one_error(xp, out[6 * n:], t, kind, rows)
    E = 0.0
    for v in e:
        E = E + v * v
    return J, e, res, 0.5 * E


def _moved_one(xp, q, J, e, lam, lo, hi, rows, n):
    """One target's damped step (:func:`step` on :class:`Lists`) from ``q``, clipped to ``[lo, hi]``
    (:meth:`Floats.moved`, compiled): ``J`` its ``m * n`` entries row by row."""
    dq = step(Lists(xp), [J[r * n:(r + 1) * n] for r in range(len(rows))], e, lam)
    return [xp.clip(v + d, a, b) for v, d, a, b in zip(q, dq, lo, hi)]


def _one_error(xp, pose, t, kind, rows):
    """:func:`task_error` of one pose ``pose`` (its 16 entries row by row, as the per-robot programs give it)
    against target ``t``, on components."""
    T = (pose[0:4], pose[4:8], pose[8:12])
    E = None
    if kind == "pose":  # R_t R^T: E[i][j] = t[i] . T[j] (rotation parts)
        p0, p1, p2, _, p4, p5, p6, _, p8, p9, p10 = pose[:11]
        E = [(a * p0 + b * p1 + c * p2, a * p4 + b * p5 + c * p6, a * p8 + b * p9 + c * p10) for a, b, c, _ in t[:3]]
    return task_error(xp, kind, T, t, E, rows)


def _pose_error(xp, E, T, t):
    """Position error and rotation vector of pose ``T`` against target ``t`` (components ``[i][j]``).

    ``E`` is ``R_t R^T`` (components); the rotation vector is its axis times
    its angle. Returns the six components ``(dx, dy, dz, rx, ry, rz)`` [m,
    rad] and the angle [rad].
    """
    v0, v1, v2 = 0.5 * (E[2][1] - E[1][2]), 0.5 * (E[0][2] - E[2][0]), 0.5 * (E[1][0] - E[0][1])
    sv = xp.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    ang = xp.arctan2(sv, 0.5 * (E[0][0] + E[1][1] + E[2][2] - 1.0))
    big = sv > 1e-12
    scale = xp.where(big, ang / xp.where(big, sv, 1.0), 1.0)
    return (t[0][3] - T[0][3], t[1][3] - T[1][3], t[2][3] - T[2][3], v0 * scale, v1 * scale, v2 * scale), ang


class _Arithmetic(dict):
    """``{(class, kind, rows): instance}`` of :class:`Batch` / :class:`Floats`, made when first asked for."""

    def __init__(self, robot):
        super().__init__()
        self.robot = robot

    def __missing__(self, key):
        cls, kind, rows = key
        made = self[key] = cls(self.robot, kind, rows)
        return made


@per_robot
def arithmetic(robot):
    """The robot's evaluators, ``arithmetic(robot)[Floats, kind, rows]`` (made once per robot, kind and rows).

    Parameters
    ----------
    robot : Robot
        Whose evaluators.

    Returns
    -------
    dict
        ``{(Batch or Floats, kind, rows): evaluator}``, filled when asked for.
    """
    return _Arithmetic(robot)
