"""Where numeric IK starts (private): closed-form branches, of the robot or of its idealised copy, ranked.

:func:`analytic_seeds` gives :func:`labkit.kinematics.ik._numeric.solve` its
starts: the branches of the robot's own closed-form family, or of the family
of its idealised copy (:func:`near_family`: small offsets removed, twists made
right angles), ranked by one rule (:func:`_ranked`): reachable and inside the
limits first, then by how far they leave them. A batch ranks them on numpy
rows; a few targets on floats solve their branches lazily, one by one, through
the family, its finishing and the ranking compiled in stages
(:func:`_seeder`), until the first start is decided, and the rest only when a
restart reads them (:class:`Starts`).
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
import operator

import numpy as np

from labkit.kinematics._chain import per_robot
from labkit.kinematics.ik._registry import detect
from labkit.kinematics.ik._solve import joints, solve as solve_family, solve_finished
from labkit.kinematics.ik._targets import SMALL_TARGETS, target_shape
from labkit.kinematics.ik._trace import compiled
from labkit.kinematics.ik._xp import FLOATS, NUMPY

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
        return _seeds_floats(robot, found, target, exact)
    q, reach, _, _ = solve_family(robot, found, target)  # the idealised copy has the robot's joints and limits
    N, m, n = q.shape
    lo, hi = _bounds(robot)
    starts, ranks = _ranked(NUMPY, lo, hi, exact,
                            [[q[:, k, j] for j in range(n)] for k in range(m)], [reach[:, k] for k in range(m)])
    inside = np.stack([np.stack(branch, axis=-1) for branch in starts], axis=1)
    rank = np.stack(ranks, axis=1)
    order = rank.argsort(axis=1, kind="stable")
    rows = np.arange(N)[:, None]
    seeds = inside[rows, order]
    if exact:
        seeds[np.isinf(rank[rows, order])] = np.nan
    some = ~np.isnan(seeds[:, 0, 0])
    return Starts(seeds[:, 0], lambda: seeds, some, bool(some.all()))


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


class Starts:
    """Ranked starting configurations of targets (:func:`analytic_seeds`): the best at once, the others when asked.

    Parameters
    ----------
    first : ndarray, shape (N, n)
        Each target's best start [rad, m] (NaN: none).
    complete : callable
        ``complete() -> ndarray (N, m, n)``, every start, best first (``first``
        is ``[:, 0]``); called once, when a restart first needs them.
    found : ndarray of bool, shape (N,)
        Which targets have a start (``first`` not NaN).
    every : bool
        Every target has one (``found.all()``, as its maker knows it).
    """

    def __init__(self, first, complete, found, every):
        self.first = first
        self.found = found
        self.every = every
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
        lo, hi = _bounds(robot)
        starts = functools.partial(_branch_starts, family=family, js=joints(robot), lo=lo, hi=hi, exact=exact)
        f = (compiled(starts, (target_shape(family.kind),), f"ik starts of {robot.name}", stages=True)
             or (lambda t: iter(starts(FLOATS, t))))
        cache[family, exact] = f
    return f


def _seeds_floats(robot, family, target, exact):
    """:func:`analytic_seeds` of a few targets on floats, lazily: the first start of each target from as few
    branches as decide it, the rest when a restart asks for them.

    The best start is a branch of rank 0 (reachable, inside the limits), the
    first in order if there are several (the ranking is stable), so a
    target's branches are solved until the first one of rank 0, and all of
    them only where there is none.
    """
    seeder = _seeder(robot, family, exact)
    m, n = len(family.branches), robot.n
    firsts, found, pending = [], [], []
    for t in target.tolist():
        branches = seeder(t)
        got = []
        for start, rank in branches:
            got.append((start, rank))
            if rank == 0.0:
                break
        best = min(got, key=operator.itemgetter(1))  # (the first of the lowest rank, as argsort(kind="stable"))
        firsts.append(best[0] if best[1] != math.inf else [math.nan] * n)
        found.append(firsts[-1][0] == firsts[-1][0])  # (not NaN)
        pending.append((branches, got))

    def complete():
        rows = []
        for branches, got in pending:
            got += branches  # (the branches not solved yet)
            order = sorted(range(m), key=lambda i: got[i][1])
            rows += [got[i][0] if got[i][1] != math.inf else [math.nan] * n for i in order]
        return _floats_array(rows, (-1, m, n))

    return Starts(_floats_array(firsts, (-1, n)), complete, np.array(found), all(found))


def _floats_array(rows, shape):
    """Lists of floats as one array of ``shape`` (from the floats in order: less than half the cost of
    ``numpy.array`` on nested lists)."""
    return np.fromiter(itertools.chain.from_iterable(rows), float, sum(map(len, rows))).reshape(shape)


@per_robot
def _bounds(robot):
    """The robot's joint limits as two lists of floats ``(lower, upper)`` [rad, m] (cached per robot)."""
    lim = robot.joint_limits
    return lim[:, 0].tolist(), lim[:, 1].tolist()
