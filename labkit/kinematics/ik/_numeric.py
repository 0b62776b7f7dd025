"""Batched Levenberg-Marquardt inverse kinematics (private; see :func:`labkit.kinematics.ik_numeric`).

All targets iterate together: one :func:`labkit.kinematics.fk_jacobian` call
and one batched linear solve per iteration for the targets still active
(``n x n`` normal equations, or ``m x m`` in task space when there are fewer
task rows ``m`` than joints). Each target keeps its own damping ``lambda``
(divided by 10 after an accepted step, multiplied by 10 after a rejected one)
and steps are projected onto the joint limits. Converged targets leave the
active set at once; a target that stalls (squared error not down 100x in 8
iterations; from a closed-form start, in each of its first two spans of 4)
or runs out of iterations restarts from the next closed-form start (jittered)
or a random configuration inside the limits. Odd-numbered attempts ignore the
revolute limits and wrap the solution by 2 pi afterwards (accepted only if it
then lies inside), which escapes minima pinned against a limit. Finally the
stragglers are copied up to 64 times and the copies iterate together from
independent starts.

One target is a batch of one: the same loop, whose arithmetic for at most
:data:`FLOAT_TARGETS` active targets (one target, or a batch's last few)
runs on Python floats (:class:`~labkit.kinematics.ik._lm.Floats`: the
per-robot program's generated Python code, the pose error on components and
the damped step compiled into straight-line code) instead of numpy rows
(:class:`~labkit.kinematics.ik._lm.Batch`), so a single target makes no
array call per iteration.

Without a caller's ``q0``, targets start from closed-form branches: the
robot's own family, or that of its idealised copy (for an arm a little off a
family, e.g. after calibration), which also feed the first restarts
(:func:`labkit.kinematics.ik._starts.analytic_seeds`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from labkit.kinematics._chain import per_robot
from labkit.kinematics.ik._lm import Batch, Floats, arithmetic
from labkit.kinematics.ik._solve import finish_all
from labkit.kinematics.ik._starts import _bounds, analytic_seeds


class LazyGenerator:
    """``numpy.random.default_rng(seed)``, created when first drawn from.

    Creating a generator costs more than polishing one target that starts on a
    closed-form branch, which never draws.

    Parameters
    ----------
    seed : int
        Seed of the generator.
    """

    def __init__(self, seed):
        self._seed = seed

    def __getattr__(self, name):
        rng = self.__dict__.get("_generator")
        if rng is None:
            rng = self._generator = np.random.default_rng(self._seed)
        return getattr(rng, name)


def _random_q(rng, limits, size):
    """``(size, n)`` uniform inside ``limits`` (:class:`_Limits`; infinite ones replaced by +-2 pi); no draw for
    ``size = 0``."""
    if size == 0:
        return np.empty((0, limits.lo.size))
    return limits.draw_lo + limits.draw_span * rng.random((size, limits.lo.size))


#: most active targets :func:`_attempts` iterates on Python floats, one by one (beyond: numpy rows)
FLOAT_TARGETS = 3

def solve(robot, kind, target, q0, rows, *, tol, max_iter, restarts, rng, multistart=64):
    """Batched LM with restarts, then batched multi-start for the stragglers.

    After ``restarts`` sequential restarts, every target still failing is
    copied ``K`` times (``K <= multistart``, at most ~8192 copies in all) and
    the copies iterate together from independent random starts, for up to
    ``restarts`` more rounds; the first copy that succeeds wins.

    Parameters
    ----------
    robot : Robot
        The arm.
    kind : {"position", "planar", "pose"}
        What the targets fix.
    target : ndarray, shape (N, 3) or (N, 4, 4)
        Targets [m, rad].
    q0 : ndarray, shape (N, n) or None
        Starting configurations [rad, m]; None starts from the closed-form
        solution where a closed-form family fits the robot
        (:func:`~labkit.kinematics.ik._starts.analytic_seeds`), else from random in-limit configurations.
    rows : tuple of int
        Rows of the 6 x n Jacobian the task constrains.
    tol : float
        Residual at which a target counts as solved [m, rad].
    max_iter : int
        Levenberg-Marquardt iterations per attempt.
    restarts : int
        Sequential restarts, then multi-start rounds, for failing targets.
    rng : numpy.random.Generator
        Draws the random starts (seeded by the caller).
    multistart : int
        Most copies per failing target in a multi-start round.

    Returns
    -------
    q : ndarray, shape (N, n)
        Joint values [rad, m].
    success : ndarray of bool, shape (N,)
    iterations : ndarray of int, shape (N,)
    residual : ndarray, shape (N,)
        Final task-space error norm [m, rad].
    """
    starts = None
    if q0 is None:
        starts = analytic_seeds(robot, kind, target, rng)
        if starts is not None:
            q0 = starts.first  # (inside the limits; _attempts copies it)
            if not starts.every:
                q0 = q0.copy()
                q0[~starts.found] = _random_q(rng, _limits(robot), int((~starts.found).sum()))
    else:
        lim = _limits(robot)
        q0 = np.minimum(np.maximum(q0, lim.lo), lim.hi)  # (np.clip's result, with fewer calls)
    q, success, iterations, residual = _attempts(
        robot, kind, target, q0, rows, tol=tol, max_iter=max_iter, restarts=restarts, rng=rng, starts=starts
    )
    n = robot.n
    for _ in range(restarts if multistart > 1 else 0):
        if _every(success):
            break
        fail = (~success).nonzero()[0]
        K = int(min(multistart, max(1, 8192 // fail.size)))
        if K < 2:
            break
        tg = np.repeat(target[fail], K, axis=0)
        qr, okr, itr, resr = _attempts(
            robot, kind, tg, None, rows, tol=tol, max_iter=max_iter, restarts=1, rng=rng, group=K
        )
        okr = okr.reshape(-1, K)
        resr = resr.reshape(-1, K)
        pick = np.where(okr.any(axis=1), np.argmax(okr, axis=1), np.argmin(resr, axis=1))
        rowsel = np.arange(fail.size)
        qpick = qr.reshape(-1, K, n)[rowsel, pick]
        rpick = resr[rowsel, pick]
        iterations[fail] += itr.reshape(-1, K)[rowsel, pick]
        improve = okr.any(axis=1) | (rpick < residual[fail])
        q[fail[improve]] = qpick[improve]
        residual[fail[improve]] = rpick[improve]
        success[fail] = okr.any(axis=1)
    return q, success, iterations, residual


def _attempts(robot, kind, target, q0, rows, *, tol, max_iter, restarts, rng, lam0=1e-2, check_every=8, group=1,
              starts=None, lam_near=1e-6):
    """Run batched LM; target (N, ...) flattened, q0 (N, n) or None.

    An attempt ends for a target when it converges, after ``max_iter``
    iterations, or when its squared error has not dropped by 100x over the last
    ``check_every`` iterations (stalled, typically against a joint limit), nor,
    from a closed-form start, over the first ``check_every / 2`` and the
    next ``check_every / 2`` (the wrong branch, or a crawl near a singularity);
    it then restarts, up to ``restarts`` times.
    Rows come in consecutive groups of ``group`` copies of one target (the
    multi-start): once a copy converges, its siblings stop iterating.

    ``robot``, ``kind``, ``target``, ``rows``, ``tol``, ``max_iter``,
    ``restarts`` and ``rng`` are those of :func:`solve`; ``q0`` (N, n) inside
    the limits, or None (random in-limit starts); ``group`` is the size of the groups of copies of
    one target (1: every row its own); ``starts``
    (:class:`~labkit.kinematics.ik._starts.Starts`), optional, the ranked
    starts of :func:`~labkit.kinematics.ik._starts.analytic_seeds`: attempt ``k < m`` restarts a
    target from ``starts.all[:, k]`` where that is not NaN, else randomly.
    Returns ``(q, success, iterations, residual)`` as :func:`solve`.
    """
    N = target.shape[0]
    group_done = np.zeros(-(-N // group), dtype=bool) if group > 1 else None
    n = robot.n
    lim = _limits(robot)
    lo, hi = lim.lo, lim.hi
    q = _random_q(rng, lim, N) if q0 is None else q0.copy()
    near = np.zeros(N, dtype=bool) if starts is None else starts.found  # from a closed form (copied before a restart)
    success = np.zeros(N, dtype=bool)
    iterations = np.zeros(N, dtype=np.int64)
    residual = np.full(N, np.inf)
    best_q = q.copy()
    # a few active targets one by one on floats, more on numpy rows: the same loop below
    rows = tuple(rows)

    def evaluator(active):
        return _evaluator(robot, kind, rows, active, group)

    for attempt in range(restarts + 1):
        # odd attempts ignore revolute limits and wrap the solution by 2 pi afterwards
        free = attempt % 2 == 1
        act = np.arange(N) if attempt == 0 else (~success).nonzero()[0]
        if group > 1:
            act = act[~group_done[act // group]]
        if act.size == 0:
            break
        ops = evaluator(act.size)
        bounds = ops.bounds(lim, free)
        if attempt > 0:
            near = near.copy() if attempt == 1 else near
            near[act] = False
            fresh = act  # (restarting from a random configuration)
            if starts is not None and attempt < 2 * starts.all.shape[1]:
                # the next closed-form start, jittered by a few degrees (two starts of an idealised copy can
                # coincide, and one on the far side of a stretched elbow crawls): no luck twice round, random
                nxt = starts.all[act, (attempt - 1) // 2 if attempt % 2 else attempt // 2]
                ok = ~np.isnan(nxt[:, 0])
                jitter = rng.normal(0.0, 0.05, size=(int(ok.sum()), n))
                q[act[ok]] = np.minimum(np.maximum(nxt[ok] + jitter, lo), hi)
                near[act[ok]] = True
                fresh = act[~ok]
            q[fresh] = _random_q(rng, lim, fresh.size)
        sel = slice(None) if act.size == N else act  # (every target: views of the targets, not copies)
        qa, tg, lam = ops.enter(q[sel], target[sel], np.where(near[sel], lam_near, lam0))
        J, e, res, E = ops.evaluate(qa, tg)
        E_check = E.copy()
        it = 0
        for it in range(1, max_iter + 1):
            done, any_done, all_done = ops.converged(res, tol)
            check = it % check_every == 0
            early = it == check_every // 2  # a closed-form start converges in a few steps, or is the wrong branch
            if all_done and not free:  # every active row converged (one target: the usual end)
                if act.size == N:  # every target at once: nothing else to do
                    q[:] = qa
                    success.fill(True)
                    residual[:] = res
                    iterations += it - 1
                    return q, success, iterations, residual
                q[act] = qa
                success[act] = True
                residual[act] = res
                iterations[act] += it - 1
                if group > 1:
                    group_done[act // group] = True
                act = act[:0]
                break
            if any_done or check or early:
                qa, tg, J, e, res, lam, E, E_check = ops.arrays(qa, tg, J, e, res, lam, E, E_check)
                done = np.asarray(done, dtype=bool)
                stalled = np.zeros_like(done)
                if free and any_done:
                    idx = np.flatnonzero(done)
                    qw = finish_all(robot, qa[idx], flipped=False)[0]
                    qa[idx] = qw
                    bad = idx[~lim.inside(qw)]
                    done[bad] = False
                    stalled[bad] = True  # converged outside the limits: restart
                if check:
                    stalled |= (~done) & (E > 0.01 * E_check)
                    E_check = E.copy()
                elif early:
                    stalled |= (~done) & (E > 0.01 * E_check) & near[act]
                    # and the next test measures a closed-form start's progress from here: a restart's start is
                    # jittered far off its branch, so against the attempt's first error a crawl passed at 8
                    E_check = np.where(near[act], E, E_check)
                leave = done | stalled
                if leave.any():
                    idx = act[done]
                    q[idx] = qa[done]
                    success[idx] = True
                    residual[idx] = res[done]
                    iterations[act[leave]] += it - 1
                    s_idx = act[stalled]
                    better = (res[stalled] < residual[s_idx]) & lim.inside(qa[stalled])
                    residual[s_idx[better]] = res[stalled][better]
                    best_q[s_idx[better]] = qa[stalled][better]
                    keep = ~leave
                    if group > 1 and done.any():  # a copy converged: its siblings stop
                        group_done[act[done] // group] = True
                        sib = keep & group_done[act // group]
                        iterations[act[sib]] += it - 1
                        keep &= ~sib
                    act, qa, tg, J, e, res, lam, E, E_check = (
                        x[keep] for x in (act, qa, tg, J, e, res, lam, E, E_check)
                    )
                    if act.size == 0:
                        break
                    if evaluator(act.size) is not ops:  # the batch is down to a few targets: on floats
                        ops = evaluator(act.size)
                        bounds = ops.bounds(lim, free)
                qa, tg, J, e, res, lam, E, E_check = ops.state(qa, tg, J, e, res, lam, E, E_check)
            qn = ops.moved(qa, J, e, lam, *bounds)
            qa, J, e, res, E, lam = ops.accept((qa, J, e, res, E, lam), (qn, *ops.evaluate(qn, tg)))
        else:
            it = max_iter + 1
        if act.size:
            qa, tg, J, e, res, lam, E, E_check = ops.arrays(qa, tg, J, e, res, lam, E, E_check)
            iterations[act] += it - 1
            inside = lim.inside(qa)
            done = (res < tol) & inside
            success[act[done]] = True
            better = (res < residual[act]) & inside
            residual[act[better]] = res[better]
            best_q[act[better]] = qa[better]
            q[act] = qa
    if not success.all():
        fail = ~success
        q[fail] = np.clip(best_q[fail], lo, hi)
    return q, success, iterations, residual


def _every(mask):
    """``mask.all()`` as a bool (for a few entries through a list: a third of a numpy reduction's cost)."""
    return all(mask.tolist()) if mask.size <= FLOAT_TARGETS else bool(mask.all())


def _evaluator(robot, kind, rows, active, group=1):
    """The LM arithmetic for ``active`` targets: on floats for at most :data:`FLOAT_TARGETS` (not multi-start copies)."""
    return arithmetic(robot)[Floats if active <= FLOAT_TARGETS and group == 1 else Batch, kind, tuple(rows)]


@dataclasses.dataclass(frozen=True)
class _Limits:
    """A robot's joint limits as the LM loop uses them."""

    lo: np.ndarray
    hi: np.ndarray
    free_lo: np.ndarray  # revolute joints unbounded (the odd attempts)
    free_hi: np.ndarray
    lo_tol: np.ndarray  # with the slack of Robot.within_limits
    hi_tol: np.ndarray
    lists: tuple  # (lo, hi) and (free_lo, free_hi) as lists of floats, by ``free`` (Floats.bounds)
    draw_lo: np.ndarray  # where random starts are drawn from (_random_q): infinite limits as +-2 pi
    draw_span: np.ndarray

    def inside(self, q):
        """``Robot.within_limits(q)`` (slack 1e-9) of ``q`` (k, n)."""
        return ((q >= self.lo_tol) & (q <= self.hi_tol)).all(axis=-1)


@per_robot
def _limits(robot):
    lim = robot.joint_limits
    lo, hi = lim[:, 0].copy(), lim[:, 1].copy()
    rev = robot.is_revolute
    free_lo, free_hi = np.where(rev, -np.inf, lo), np.where(rev, np.inf, hi)
    lists = (_bounds(robot), (free_lo.tolist(), free_hi.tolist()))
    draw_lo = np.where(np.isfinite(lo), lo, -2 * np.pi)
    draw_span = np.where(np.isfinite(hi), hi, 2 * np.pi) - draw_lo
    return _Limits(lo, hi, free_lo, free_hi, lo - 1e-9, hi + 1e-9, lists, draw_lo, draw_span)
