"""Batched Levenberg-Marquardt inverse kinematics (private; see :func:`labkit.kinematics.ik_numeric`).

All targets iterate together: one :func:`labkit.kinematics.fk_jacobian` call
and one batched linear solve per iteration for the targets still active
(``n x n`` normal equations, or ``m x m`` in task space when there are fewer
task rows ``m`` than joints). Each target keeps its own damping ``lambda``
(divided by 10 after an accepted step, multiplied by 10 after a rejected one)
and steps are projected onto the joint limits. Converged targets leave the
active set at once; a target that stalls (squared error not down 100x in 8
iterations) or runs out of iterations restarts from a random configuration
inside the limits. Odd-numbered attempts ignore the revolute limits and wrap
the solution by 2 pi afterwards (accepted only if it then lies inside), which
escapes minima pinned against a limit. Finally the stragglers are copied up
to 64 times and the copies iterate together from independent starts.

One target is a batch of one: the same loop, whose arithmetic for at most
:data:`FLOAT_TARGETS` active targets (one target, or a batch's last few)
runs on Python floats (:class:`~labkit.kinematics.ik._lm.Floats`: the
per-robot program's generated Python code, the pose error on components, one
LAPACK solve per step) instead of numpy rows
(:class:`~labkit.kinematics.ik._lm.Batch`), so a single target costs few
array calls per iteration.

Without a caller's ``q0``, targets start from closed-form branches: the
robot's own family, or that of its idealised copy (:func:`near_family`, for
an arm a little off a family, e.g. after calibration), which also feed the
first restarts (:func:`analytic_seeds`).
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math

import numpy as np

from labkit.kinematics._chain import per_robot
from labkit.kinematics.ik._lm import Batch, Floats, arithmetic
from labkit.kinematics.ik._registry import detect
from labkit.kinematics.ik._solve import finish_all, joints, solve as solve_family, solve_finished
from labkit.kinematics.ik._targets import COMPONENTS, SMALL_TARGETS, task_rows
from labkit.kinematics.ik._trace import compiled
from labkit.kinematics.ik._xp import FLOATS, NUMPY


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
    """Uniform inside the limits (infinite limits replaced by +-2 pi); no draw for ``size = 0``."""
    if size == 0:
        return np.empty((0, limits.shape[0]))
    lo = np.where(np.isfinite(limits[:, 0]), limits[:, 0], -2 * np.pi)
    hi = np.where(np.isfinite(limits[:, 1]), limits[:, 1], 2 * np.pi)
    return lo + (hi - lo) * rng.random((size, limits.shape[0]))


#: most active targets :func:`_attempts` iterates on Python floats, one by one (beyond: numpy rows)
FLOAT_TARGETS = 3

#: snapping thresholds tried in turn, as fractions of the arm's length scale (sum of |a| + |d|)
SNAP_FRACTIONS = (1e-3, 1e-2, 3e-2)
#: largest twist-angle error snapped to a multiple of pi/2 [rad] (3 deg)
SNAP_ALPHA = np.radians(3.0)



def snapped(robot, fraction):
    """Copy of ``robot`` with small DH lengths set to 0 and near-right twists made exact.

    Parameters
    ----------
    robot : Robot
        The arm to idealise.
    fraction : float
        Lengths ``a``, ``d`` with ``|value| <= fraction * L`` become 0, where
        ``L`` is the sum of all ``|a| + |d|`` [m]; twists ``alpha`` within
        :data:`SNAP_ALPHA` of a multiple of pi/2 become that multiple.

    Returns
    -------
    Robot or None
        The idealised copy, or None when nothing changed.
    """
    scale = sum(abs(link.a) + abs(link.d) for link in robot.links)
    links, changed = [], False
    for link in robot.links:
        a = 0.0 if abs(link.a) <= fraction * scale else link.a
        d = 0.0 if abs(link.d) <= fraction * scale else link.d
        right = round(link.alpha / (0.5 * np.pi)) * 0.5 * np.pi
        alpha = right if abs(link.alpha - right) <= SNAP_ALPHA else link.alpha
        if (a, d, alpha) != (link.a, link.d, link.alpha):
            changed = True
            link = dataclasses.replace(link, a=a, d=d, alpha=alpha)
        links.append(link)
    return robot.replace(links=tuple(links)) if changed else None


@per_robot
def near_family(robot):
    """The closed-form solver of the nearest idealised copy of ``robot`` (cached), or ``(None, None)``.

    A calibrated arm (small link offsets, twists a fraction of a degree off 90)
    has no closed form, but its idealised copy (:func:`snapped`, the smallest
    threshold of :data:`SNAP_FRACTIONS` that works) often has; its solutions
    land millimetres from the target, which Levenberg-Marquardt then polishes
    on the real arm in a few iterations.

    Parameters
    ----------
    robot : Robot
        An arm without a closed-form family of its own.

    Returns
    -------
    ideal : Robot or None
        The idealised copy.
    solver : object or None
        Its analytic solver.
    """
    result = (None, None)
    for fraction in SNAP_FRACTIONS:
        ideal = snapped(robot, fraction)
        if ideal is None:
            continue
        found, _ = detect(ideal)
        if found is not None:
            result = (ideal, found)
            break
    return result


def analytic_seeds(robot, kind, target, rng):
    """Ranked starting configurations from a closed-form family of the robot or of its idealised copy, or None.

    When :func:`labkit.kinematics.ik._registry.detect` finds a solver for
    ``robot`` whose targets are of ``kind``, its branches that are reachable
    and inside the joint limits are the starts (so LM only polishes them).
    Otherwise the same is done with the solver of the nearest idealised copy
    of the robot (:func:`near_family`: small offsets removed), whose solutions
    are millimetres from the real ones; there every branch is a start, ranked:
    reachable and inside the limits first, then by how far it leaves the limits
    (clipped into them), then the copy's closest approaches to targets just out
    of its reach (the real arm may reach them). An attempt that stalls moves on
    to the next start (:func:`solve`); a target without any starts from a
    random configuration.

    Parameters
    ----------
    robot : Robot
        The arm to seed (with a closed form of its own, or near one).
    kind : {"position", "planar", "pose"}
        What the targets fix.
    target : ndarray, shape (N, 3) or (N, 4, 4)
        Targets [m, rad].
    rng : numpy.random.Generator
        Draws the random starts.

    Returns
    -------
    Starts or None
        Starting configurations [rad, m]: ``first`` (N, n) each target's best
        and ``all`` (N, m, n) every one, best first, with rows of NaN after a
        target's last usable start (all NaN: no start, :func:`solve` draws a
        random one). A few targets on floats solve only the branches their
        first start needs, the rest when ``all`` is read
        (:func:`_seeds_floats`). None when no closed form applies.
    """
    found, _ = detect(robot)
    exact = found is not None  # the robot's own family (else its idealised copy's)
    if not exact:
        _, found = near_family(robot)
    if found is None or found.kind != kind:
        return None
    if found.scalar and target.shape[0] <= SMALL_TARGETS:  # (as solve_family runs them on floats)
        return _seeds_floats(robot, found, kind, target, exact)
    q, reach, _, _ = solve_family(robot, found, target)  # the idealised copy has the robot's joints and limits
    N, m, n = q.shape
    lim = _limits(robot)
    starts, ranks = _ranked(NUMPY, lim.lo.tolist(), lim.hi.tolist(), exact,
                            [[q[:, k, j] for j in range(n)] for k in range(m)], [reach[:, k] for k in range(m)])
    inside = np.stack([np.stack(branch, axis=-1) for branch in starts], axis=1)
    rank = np.stack(ranks, axis=1)
    order = rank.argsort(axis=1, kind="stable")
    rows = np.arange(N)[:, None]
    seeds = inside[rows, order]
    if exact:
        seeds[np.isinf(rank[rows, order])] = np.nan
    elif m > 1:
        ops = arithmetic(robot)[Batch, kind, task_rows(kind)]
        res = ops.residuals(seeds[:, :2].reshape(-1, n), target.repeat(2, axis=0)).reshape(N, 2)
        top = rank[rows, order[:, :2]]
        swap = _second_first(res[:, 0], res[:, 1], top[:, 0], top[:, 1])
        seeds[swap, :2] = seeds[swap, 1::-1]
    return Starts(seeds[:, 0], lambda: seeds)


def _ranked(xp, lo, hi, exact, rows, reach):
    """Every branch as a start, and its rank (lower first; written once, for numpy rows and for floats).

    A start is the branch's joint values clipped into the limits; its rank is
    how far the branch leaves them (the sum over the joints). Of the robot's
    own family (``exact``) only reachable branches inside the limits rank 0,
    every other one infinity (no start); of an idealised copy's, branches out
    of reach rank 1000 more.

    Parameters
    ----------
    xp : namespace
        :data:`~labkit.kinematics.ik._xp.NUMPY` (components ``(N,)``) or
        :data:`~labkit.kinematics.ik._xp.FLOATS` (floats; compiled with the
        family's formulas by :func:`_seeder`).
    lo, hi : list of float
        Joint limits [rad, m].
    exact : bool
        The branches are the robot's own.
    rows : list of list, shape (m, n)
        Per branch its finished joint values [rad, m].
    reach : list, shape (m,)
        Per branch whether it reaches the target.

    Returns
    -------
    starts : list of list, shape (m, n)
        The clipped joint values [rad, m].
    ranks : list, shape (m,)
    """
    starts, ranks = [], []
    for row, ok in zip(rows, reach):
        inside = [xp.minimum(xp.maximum(v, a), b) for v, a, b in zip(row, lo, hi)]
        rank = 0.0
        for v, c in zip(row, inside):
            rank = rank + xp.abs(v - c)
        starts.append(inside)
        ranks.append(xp.where(ok & (rank == 0.0), 0.0, math.inf) if exact else xp.where(ok, rank, rank + 1e3))
    return starts, ranks


def _second_first(res0, res1, rank0, rank1):
    """Whether the second of an idealised copy's two best starts goes first: its residual on the real arm plus
    its rank is lower (e.g. of a wrist and its flip, a solution of the copy, only one is near a solution once
    a5 != 0)."""
    return res1 + rank1 < res0 + rank0


class Starts:
    """Ranked starting configurations of targets (:func:`analytic_seeds`): the best at once, the others when asked.

    Parameters
    ----------
    first : ndarray, shape (N, n)
        Each target's best start [rad, m] (NaN: none).
    complete : callable
        ``complete() -> ndarray (N, m, n)``, every start, best first (``first``
        is ``[:, 0]``); called once, when a restart first needs them.
    """

    def __init__(self, first, complete):
        self.first = first
        self._complete = complete
        self._all = None

    @property
    def all(self):
        """ndarray, shape (N, m, n): every start [rad, m], best first; rows of NaN after a target's last one."""
        if self._all is None:
            self._all = self._complete()
        return self._all


def _branch_starts(xp, t, family, js, lo, hi, exact):
    """Per branch of ``family`` for target ``t``: its start and rank (:func:`_ranked` of the finished branches).

    Compiled by :func:`_seeder` into a generator of the branches in turn.
    """
    rows, reach, _, _ = solve_finished(xp, t, family, js)
    starts, ranks = _ranked(xp, lo, hi, exact, rows, reach)
    return list(zip(starts, ranks))


@per_robot
def _seeders(robot):
    """``{(family, exact): seeder}`` of :func:`_seeder` for ``robot`` (filled when asked)."""
    return {}


def _seeder(robot, family, exact):
    """``t -> iterator of (start, rank)``, branch by branch: :func:`_branch_starts` compiled in stages (a branch's
    formulas run when it is asked for), else on FLOATS."""
    cache = _seeders(robot)
    f = cache.get((family, exact))
    if f is None:
        lim = _limits(robot)
        starts = functools.partial(_branch_starts, family=family, js=joints(robot), lo=lim.lo.tolist(),
                                   hi=lim.hi.tolist(), exact=exact)
        shape = (4, 4) if family.kind == "pose" else (len(COMPONENTS[family.kind]),)
        f = (compiled(lambda xp, t: starts(xp, t), (shape,), f"ik starts of {robot.name}", stages=True)
             or (lambda t: iter(starts(FLOATS, t))))
        cache[family, exact] = f
    return f


def _seeds_floats(robot, family, kind, target, exact):
    """:func:`analytic_seeds` of a few targets on floats, lazily: the first start of each target from as few
    branches as decide it, the rest when a restart asks for them.

    The best start is a branch of rank 0 (reachable, inside the limits); the
    first such branches in order are the best ones (the ranking is stable),
    so a target's branches are solved until one of them (the robot's own
    family) or two (an idealised copy's: the real arm's residuals order
    those two) are found, and all of them only where fewer exist.
    """
    seeder = _seeder(robot, family, exact)
    m, n = len(family.branches), robot.n
    ops = arithmetic(robot)[Floats, kind, task_rows(kind)]
    wanted = 1 if exact or m == 1 else 2
    firsts, pending = [], []
    for t in target.tolist():
        branches = seeder(t)
        got, zeros = [], []
        for start, rank in branches:
            got.append((start, rank))
            if rank == 0.0:
                zeros.append(len(got) - 1)
                if len(zeros) == wanted:
                    break
        top = zeros if len(zeros) == wanted else None  # (else every branch is solved: sorted below)
        if top is None:
            top = sorted(range(len(got)), key=lambda i: got[i][1])[:wanted]  # (stable, as argsort(kind="stable"))
        swap = (not exact and len(top) == 2
                and _second_first(*ops.residuals([got[i][0] for i in top], [t, t]), got[top[0]][1], got[top[1]][1]))
        best = got[top[1] if swap else top[0]]
        firsts.append(best[0] if best[1] != math.inf else [math.nan] * n)
        pending.append((branches, got, swap))

    def complete():
        rows = []
        for branches, got, swap in pending:
            got += branches  # (the branches not solved yet)
            order = sorted(range(m), key=lambda i: got[i][1])
            if swap:
                order[:2] = order[1::-1]
            rows += [got[i][0] if got[i][1] != math.inf else [math.nan] * n for i in order]
        return _floats_array(rows, (-1, m, n))

    return Starts(_floats_array(firsts, (-1, n)), complete)


def _floats_array(rows, shape):
    """Lists of floats as one array of ``shape`` (from the floats in order: less than half the cost of
    ``numpy.array`` on nested lists)."""
    return np.fromiter(itertools.chain.from_iterable(rows), float, sum(map(len, rows))).reshape(shape)


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
        (:func:`analytic_seeds`), else from random in-limit configurations.
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
            q0 = starts.first  # (_attempts copies it)
            none = np.isnan(q0[:, 0])
            if none.any():
                q0 = q0.copy()
                q0[none] = _random_q(rng, robot.joint_limits, int(none.sum()))
    q, success, iterations, residual = _attempts(
        robot, kind, target, q0, rows, tol=tol, max_iter=max_iter, restarts=restarts, rng=rng, starts=starts
    )
    n = robot.n
    for _ in range(restarts if multistart > 1 else 0):
        if success.all():
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
    iterations, or when its squared error has not dropped by 10x over the last
    ``check_every`` iterations (stalled, typically against a joint limit);
    it then restarts from a random configuration, up to ``restarts`` times.
    Rows come in consecutive groups of ``group`` copies of one target (the
    multi-start): once a copy converges, its siblings stop iterating.

    ``robot``, ``kind``, ``target``, ``rows``, ``tol``, ``max_iter``,
    ``restarts`` and ``rng`` are those of :func:`solve`; ``q0`` (N, n) or None
    (random in-limit starts); ``group`` is the size of the groups of copies of
    one target (1: every row its own); ``starts`` (:class:`Starts`), optional,
    the ranked starts of :func:`analytic_seeds`: attempt ``k < m`` restarts a
    target from ``starts.all[:, k]`` where that is not NaN, else randomly.
    Returns ``(q, success, iterations, residual)`` as :func:`solve`.
    """
    N = target.shape[0]
    group_done = np.zeros(-(-N // group), dtype=bool)
    n = robot.n
    lim = _limits(robot)
    lo, hi = lim.lo, lim.hi
    # (minimum of maximum: np.clip's result, with fewer calls; a new array either way)
    q = _random_q(rng, robot.joint_limits, N) if q0 is None else np.minimum(np.maximum(q0, lo), hi)
    near = np.zeros(N, dtype=bool) if starts is None else ~np.isnan(starts.first[:, 0])  # from a closed form
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
        alo, ahi = (lim.free_lo, lim.free_hi) if free else (lo, hi)
        act = (~success).nonzero()[0]
        if group > 1:
            act = act[~group_done[act // group]]
        if act.size == 0:
            break
        ops = evaluator(act.size)
        bounds = ops.bounds(alo, ahi)
        if attempt > 0:
            q[act] = _random_q(rng, robot.joint_limits, act.size)
            near[act] = False
            if starts is not None and attempt < 2 * starts.all.shape[1]:
                # the next closed-form start, jittered by a few degrees (two starts of an idealised copy can
                # coincide, and one on the far side of a stretched elbow crawls): no luck twice round, random
                nxt = starts.all[act, (attempt - 1) // 2 if attempt % 2 else attempt // 2]
                ok = ~np.isnan(nxt[:, 0])
                jitter = rng.normal(0.0, 0.05, size=(int(ok.sum()), n))
                q[act[ok]] = np.clip(nxt[ok] + jitter, lo, hi)
                near[act[ok]] = True
        sel = slice(None) if act.size == N else act  # (every target: views of the targets, not copies)
        qa, tg, lam = ops.enter(q[act], target[sel], np.where(near[sel], lam_near, lam0))
        J, e, res, E = ops.evaluate(qa, tg)
        E_check = E.copy()
        it = 0
        for it in range(1, max_iter + 1):
            done, any_done, all_done = ops.converged(res, tol)
            check = it % check_every == 0
            early = it == check_every // 2  # a closed-form start converges in a few steps, or is the wrong branch
            if all_done and not free:  # every active row converged (one target: the usual end)
                sel = slice(None) if act.size == N else act
                q[sel] = qa
                success[sel] = True
                residual[sel] = res
                iterations[sel] += it - 1
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
                        bounds = ops.bounds(alo, ahi)
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

    def inside(self, q):
        """``Robot.within_limits(q)`` (slack 1e-9) of ``q`` (k, n)."""
        return ((q >= self.lo_tol) & (q <= self.hi_tol)).all(axis=-1)


@per_robot
def _limits(robot):
    lim = robot.joint_limits
    lo, hi = lim[:, 0].copy(), lim[:, 1].copy()
    rev = robot.is_revolute
    return _Limits(lo, hi, np.where(rev, -np.inf, lo), np.where(rev, np.inf, hi), lo - 1e-9, hi + 1e-9)
