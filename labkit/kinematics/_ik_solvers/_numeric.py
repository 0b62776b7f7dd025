"""Batched Levenberg-Marquardt inverse kinematics (private; see :func:`labkit.kinematics.ik_numeric`).

All targets iterate together on numpy rows; one target is a batch of one.
Per iteration the targets still active make one
:func:`labkit.kinematics._forward._fk_jacobian_kernel` call and one batched
linear solve (:mod:`labkit.kinematics._ik_solvers._lm`: the task error, the
damped step and the damping rule). Steps are clipped into the joint limits.
Lengths count in units of the arm's reach (position errors divided by it,
prismatic steps made in it), so a 5 cm and a 7 m arm of one shape iterate alike.

A target leaves the active set when it converges, when it stalls (squared
error not down 100x in 8 iterations; from a closed-form start, also in its
first 4) or after ``max_iter`` iterations; it then restarts (an *attempt* per
start) from the next closed-form start (jittered) or a random configuration
in the start window (:func:`labkit.kinematics._ik_solvers._starts.start_window`).
Odd-numbered attempts ignore the revolute limits and wrap the solution by 2 pi
afterwards (accepted only if it then lies inside), which escapes minima pinned
against a limit. Finally the stragglers are copied up to :data:`MULTISTART`
times and the copies iterate together from independent random starts.

Without a caller's ``q0``, targets start from closed-form branches: the
robot's own family, or that of its idealised copy (for an arm a little off a
family, e.g. after calibration), which also feed the first restarts
(:func:`labkit.kinematics._ik_solvers._starts.analytic_seeds`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from labkit.kinematics._forward import _fk_jacobian_kernel
from labkit.kinematics._ik_solvers._lm import damped_step, damping, task_error
from labkit.kinematics._ik_solvers._solve import finish
from labkit.kinematics._ik_solvers._starts import analytic_seeds, start_window

#: iterations between stall tests; damping of a random start and of a closed-form one
CHECK_EVERY, LAMBDA_RANDOM, LAMBDA_NEAR = 8, 1e-2, 1e-6
#: the default success threshold on the residual, per metre of the arm's reach (``Robot.reach``)
TOL_PER_METRE = 1e-10
#: most copies of a failing target in a multi-start round (at most about 8192 copies in all)
MULTISTART = 64


class LazyGenerator:
    """``numpy.random.default_rng(seed)``, created when first drawn from (that costs more than polishing one
    target that starts on a closed-form branch, which never draws)."""

    def __init__(self, seed):
        self._seed = seed

    def __getattr__(self, name):
        rng = self.__dict__.get("_generator")
        if rng is None:
            rng = self._generator = np.random.default_rng(self._seed)
        return getattr(rng, name)


@dataclasses.dataclass(frozen=True)
class _Problem:
    """What every attempt shares: the arm, its kernel and limits, the targets and the options."""

    robot: object
    kind: str
    rows: tuple
    target: np.ndarray
    tol: float
    max_iter: int
    rng: object
    kernel: object
    lo: np.ndarray
    hi: np.ndarray
    row_scale: np.ndarray
    joint_scale: np.ndarray

    def random_q(self, size):
        """``(size, n)`` uniform in the start window (:func:`start_window`); no draw for ``size = 0``."""
        if size == 0:
            return np.empty((0, self.lo.size))
        lo, hi = start_window(self.robot)
        return lo + (hi - lo) * self.rng.random((size, lo.size))

    def evaluate(self, q, target):
        """Jacobian task rows (k, m, n) and error (k, m) in units of the reach, residual (k,) [m, rad] and
        ``e.e / 2`` (k,) of the scaled error at ``q`` (k, n)."""
        T, J = self.kernel(q)
        e, res = task_error(self.kind, T, target, self.rows)
        e *= self.row_scale  # (both fresh arrays: scaled in place)
        J = J if len(self.rows) == 6 else J[:, self.rows]
        J *= self.row_scale[:, None] * self.joint_scale
        return J, e, res, 0.5 * np.einsum("ij,ij->i", e, e)


@dataclasses.dataclass
class _Outcome:
    """Per target of the batch: the best configuration so far, whether it converged, iterations, residual."""

    q: np.ndarray
    success: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    best_q: np.ndarray
    group: int = 1
    group_done: np.ndarray = None

    @classmethod
    def start(cls, q, group=1):
        N = q.shape[0]
        return cls(q.copy(), np.zeros(N, dtype=bool), np.zeros(N, dtype=np.int64), np.full(N, np.inf), q.copy(),
                   group, np.zeros(-(-N // group), dtype=bool))

    def pending(self, attempt):
        """The rows an attempt runs on: all at first, then those not converged (nor a sibling copy)."""
        rows = np.arange(self.q.shape[0]) if attempt == 0 else (~self.success).nonzero()[0]
        return rows[~self.group_done[rows // self.group]]

    def converged(self, rows, q, res):
        self.q[rows], self.success[rows], self.residual[rows] = q, True, res
        self.group_done[rows // self.group] = True

    def keep_best(self, rows, q, res, inside):
        better = (res < self.residual[rows]) & inside
        self.residual[rows[better]] = res[better]
        self.best_q[rows[better]] = q[better]


@dataclasses.dataclass
class _Active:
    """The rows still iterating in an attempt, and their LM state."""

    rows: np.ndarray
    q: np.ndarray
    target: np.ndarray
    lam: np.ndarray
    near: np.ndarray  # started on a closed-form branch
    J: np.ndarray = None
    e: np.ndarray = None
    res: np.ndarray = None
    E: np.ndarray = None
    E_check: np.ndarray = None

    def keep(self, mask):
        return _Active(*(getattr(self, f.name)[mask] for f in dataclasses.fields(self)))


def solve(robot, kind, target, q0, rows, *, tol, max_iter, restarts, rng):
    """Batched LM with restarts, then up to ``restarts`` multi-start rounds for the stragglers.

    Parameters
    ----------
    robot : Robot
    kind : {"position", "planar", "pose"}
    target : ndarray, shape (N, 3) or (N, 4, 4)
        Targets [m, rad].
    q0 : ndarray, shape (N, n) or None
        Starting configurations [rad, m]; None: closed-form starts, else random ones.
    rows : tuple of int
        Rows of the 6 x n Jacobian the task constrains.
    tol, max_iter, restarts, rng
        Residual of success [m, rad] (None: :data:`TOL_PER_METRE` times the reach, at least 1 mm), LM
        iterations per attempt, restarts, the random generator.

    Returns
    -------
    q, success, iterations, residual : ndarray, shape (N, n), (N,), (N,), (N,)
        Joint values [rad, m], converged, iterations, final task error norm [m, rad].
    """
    lim, size = robot.joint_limits, max(robot.reach, 1e-3)  # lengths in units of the reach: any size iterates alike
    p = _Problem(robot, kind, tuple(rows), target, TOL_PER_METRE * size if tol is None else tol, max_iter, rng,
                 _fk_jacobian_kernel(robot), lim[:, 0], lim[:, 1], np.where(np.array(rows) < 3, 1.0 / size, 1.0),
                 np.where(robot.is_revolute, 1.0, size))
    starts = analytic_seeds(robot, kind, target) if q0 is None else None
    if starts is not None:
        q0 = starts.all[:, 0].copy()
        q0[~starts.found] = p.random_q(int((~starts.found).sum()))
    elif q0 is None:
        q0 = p.random_q(target.shape[0])
    out = _attempts(p, np.clip(q0, p.lo, p.hi), restarts, starts)
    for _ in range(restarts):
        if out.success.all() or not _multistart_round(p, out):
            break
    return out.q, out.success, out.iterations, out.residual


def _first_success(K, q, ok, it, res):
    """Per target of ``K`` consecutive copies (rows of ``q`` (N K, n), ``ok``, ``it``, ``res`` (N K,)) the first
    copy that succeeded, else the one of least residual: its ``q`` (N, n), ``ok``, ``it`` and ``res`` (N,)."""
    ok, it, res = ok.reshape(-1, K), it.reshape(-1, K), res.reshape(-1, K)
    pick = np.where(ok.any(axis=1), np.argmax(ok, axis=1), np.argmin(res, axis=1))
    each = np.arange(ok.shape[0])
    return q.reshape(-1, K, q.shape[-1])[each, pick], ok[each, pick], it[each, pick], res[each, pick]


def _multistart_round(p, out):
    """One multi-start round for the failing targets (updates ``out``); False when there are too many."""
    fail = (~out.success).nonzero()[0]
    K = int(min(MULTISTART, max(1, 8192 // fail.size)))
    if K < 2:
        return False
    copies = dataclasses.replace(p, target=np.repeat(p.target[fail], K, axis=0))
    got = _attempts(copies, copies.random_q(fail.size * K), 1, None, group=K)
    q, ok, it, res = _first_success(K, got.q, got.success, got.iterations, got.residual)
    out.iterations[fail] += it
    improve = ok | (res < out.residual[fail])
    out.q[fail[improve]], out.residual[fail[improve]] = q[improve], res[improve]
    out.success[fail] = ok
    return True


def _attempts(p, q0, restarts, starts, group=1):
    """Up to ``restarts + 1`` attempts of every target not yet converged; an :class:`_Outcome`.

    Rows come in consecutive groups of ``group`` copies of one target (the
    multi-start): once a copy converges, its siblings stop iterating.
    """
    out = _Outcome.start(q0, group)
    near = np.zeros(q0.shape[0], dtype=bool) if starts is None else starts.found
    q = q0
    for attempt in range(restarts + 1):
        rows = out.pending(attempt)
        if rows.size == 0:
            break
        if attempt > 0:
            q, near = _restart(p, rows, attempt, starts, out.q)
        _attempt(p, out, _Active(rows, q[rows], p.target[rows], np.where(near[rows], LAMBDA_NEAR, LAMBDA_RANDOM),
                                 near[rows]), free=attempt % 2 == 1)
    fail = ~out.success
    out.q[fail] = np.clip(out.best_q[fail], p.lo, p.hi)
    return out


def _restart(p, rows, attempt, starts, q):
    """Starting configurations of attempt ``attempt > 0`` for ``rows`` (a copy of ``q``), and which are closed-form.

    Attempts 1, 2 take the second closed-form start, 3, 4 the third ...
    jittered by a few degrees (two starts of an idealised copy can coincide,
    and one on the far side of a stretched elbow crawls); without one, a
    random configuration.
    """
    q, near = q.copy(), np.zeros(q.shape[0], dtype=bool)
    fresh = rows
    if starts is not None and attempt < 2 * starts.all.shape[1]:
        nxt = starts.all[rows, (attempt - 1) // 2 if attempt % 2 else attempt // 2]
        ok = ~np.isnan(nxt[:, 0])
        jitter = p.rng.normal(0.0, 0.05, size=(int(ok.sum()), q.shape[1]))
        q[rows[ok]] = np.clip(nxt[ok] + jitter, p.lo, p.hi)
        near[rows[ok]] = True
        fresh = rows[~ok]
    q[fresh] = p.random_q(fresh.size)
    return q, near


def _attempt(p, out, a, *, free):
    """Iterate the active rows ``a`` until each converges, stalls or runs out of iterations (updates ``out``)."""
    lo, hi = (np.where(p.robot.is_revolute, -np.inf, p.lo), np.where(p.robot.is_revolute, np.inf, p.hi)) if free \
        else (p.lo, p.hi)
    a.J, a.e, a.res, a.E = p.evaluate(a.q, a.target)
    a.E_check = a.E.copy()
    for it in range(1, p.max_iter + 1):
        done = a.res < p.tol
        if done.any() or it % CHECK_EVERY == 0 or it == CHECK_EVERY // 2:
            a = _leave(p, out, a, done, it, free)
            if a.rows.size == 0:
                return
        _step(p, a, lo, hi)
    out.iterations[a.rows] += p.max_iter
    inside = p.robot.within_limits(a.q)
    done = (a.res < p.tol) & inside
    out.converged(a.rows[done], a.q[done], a.res[done])
    out.keep_best(a.rows, a.q, a.res, inside)
    out.q[a.rows[~done]] = a.q[~done]


def _step(p, a, lo, hi):
    """One LM iteration of the active rows: the damped step, clipped, kept where it lowers the error."""
    q = np.clip(a.q + damped_step(a.J, a.e, a.lam) * p.joint_scale, lo, hi)
    J, e, res, E = p.evaluate(q, a.target)
    better = E < a.E
    a.lam = damping(a.lam, better)
    if better.all():
        a.q, a.J, a.e, a.res, a.E = q, J, e, res, E
        return
    a.q[better], a.J[better], a.e[better], a.res[better], a.E[better] = q[better], J[better], e[better], \
        res[better], E[better]


def _leave(p, out, a, done, it, free):
    """Record the rows that converged or stalled at iteration ``it``; the rows that go on.

    A free attempt's solution is wrapped into the limits and counts only if
    it then lies inside; a row stalls when its squared error has not dropped
    100x since the last test (every :data:`CHECK_EVERY` iterations; a
    closed-form start also at half of that, the test after measuring from
    there).
    """
    stalled = np.zeros_like(done)
    if free and done.any():
        idx = np.flatnonzero(done)
        a.q[idx] = finish(p.robot, a.q[idx], flipped=False)
        outside = idx[~p.robot.within_limits(a.q[idx])]
        done[outside], stalled[outside] = False, True  # converged outside the limits: restart
    slow = ~done & (a.E > 0.01 * a.E_check)
    if it % CHECK_EVERY == 0:
        stalled |= slow
        a.E_check = a.E.copy()
    elif it == CHECK_EVERY // 2:  # a closed-form start converges in a few steps, or is the wrong branch
        stalled |= slow & a.near
        a.E_check = np.where(a.near, a.E, a.E_check)
    leave = done | stalled
    if not leave.any():
        return a
    out.converged(a.rows[done], a.q[done], a.res[done])
    out.iterations[a.rows[leave]] += it - 1
    if stalled.any():
        out.keep_best(a.rows[stalled], a.q[stalled], a.res[stalled], p.robot.within_limits(a.q[stalled]))
    keep = ~leave & ~out.group_done[a.rows // out.group]  # (a converged copy stops its siblings)
    out.iterations[a.rows[~leave & ~keep]] += it - 1
    return a.keep(keep)
