"""One Levenberg-Marquardt attempt for a single target, without batch bookkeeping (private).

The batched solver in :mod:`labkit.kinematics.ik._numeric` spends ~100 NumPy
calls per iteration on masks, compaction and batched linear algebra; for one
target (``ik`` in a loop, ``arm.move_to``, the last stragglers of a batch)
that overhead dominates. :func:`attempt` runs the same iteration (same task
error, damping schedule, limit projection, stall test and 2 pi wrap of free
attempts) on Python floats and the pure-Python chain of
:mod:`labkit.kinematics._forward_small`, with NumPy only for the ``n x n``
solve.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.kinematics._forward import fk_jacobian
from labkit.rotations import wrap_angle




def error(kind, T, target, rows):
    """Task error (list, one entry per row) and residual of one pose ``T`` (16 floats, C order).

    Parameters
    ----------
    kind : {"position", "planar", "pose"}
        What the target fixes.
    T : list of float, length 16
        The pose [m].
    target : ndarray, shape (3,) or (4, 4)
        The target [m, rad].
    rows : tuple of int
        Rows of the spatial velocity the task constrains.

    Returns
    -------
    e : list of float
        Error per task row [m, rad].
    residual : float
        As :func:`labkit.kinematics.ik._numeric._error` [m, rad].
    """
    if kind == "position":
        full = (target[0] - T[3], target[1] - T[7], target[2] - T[11])
        e = [full[r] for r in rows]
        return e, math.sqrt(sum(v * v for v in e))
    if kind == "planar":
        full = {0: target[0] - T[3], 1: target[1] - T[7], 5: wrap_angle(target[2] - math.atan2(T[4], T[0]))}
        e = [full[r] for r in rows]
        return e, math.sqrt(sum(v * v for v in e))
    G = target
    # E = R_target R^T: E[i][j] = sum_k G[i, k] R[j, k]
    E = [[G[i][0] * T[4 * j] + G[i][1] * T[4 * j + 1] + G[i][2] * T[4 * j + 2] for j in range(3)] for i in range(3)]
    v = (0.5 * (E[2][1] - E[1][2]), 0.5 * (E[0][2] - E[2][0]), 0.5 * (E[1][0] - E[0][1]))
    sv = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    ang = math.atan2(sv, 0.5 * (E[0][0] + E[1][1] + E[2][2] - 1.0))
    scale = ang / sv if sv > 1e-12 else 1.0
    full = (G[0][3] - T[3], G[1][3] - T[7], G[2][3] - T[11], v[0] * scale, v[1] * scale, v[2] * scale)
    e = [full[r] for r in rows]
    res2 = sum(full[r] ** 2 for r in rows if r < 3)
    rot = [r for r in rows if r >= 3]
    if len(rot) == 3:
        o = 2.0 * math.sin(0.5 * ang)
        res2 += o * o
    else:
        res2 += sum(full[r] ** 2 for r in rot)
    return e, math.sqrt(res2)


def attempt(robot, c, kind, target, q, rows, *, lo, hi, free, tol, max_iter, check_every, lam0, normalize,
            first=1, E_check=None, checked=False):
    """One LM attempt for one target, as an attempt of the batched solver for that row.

    Parameters
    ----------
    robot : Robot
        The arm (for its joint limits).
    c : Chain
        Its chain constants.
    kind : {"position", "planar", "pose"}
        What the target fixes.
    target : ndarray, shape (3,) or (4, 4)
        The target [m, rad].
    q : ndarray, shape (n,)
        Starting configuration [rad, m].
    rows : list of int
        Rows of the spatial velocity the task constrains.
    lo, hi : ndarray, shape (n,)
        Bounds the steps are projected onto [rad, m].
    free : bool
        A free attempt (revolute limits ignored): a converged solution is
        wrapped by ``normalize`` and kept only if it then lies in the limits.
    tol : float
        Residual at which the target counts as solved [m, rad].
    max_iter : int
        Most iterations.
    check_every : int
        Stall test period (squared error not down 100x in that many iterations).
    lam0 : float
        Initial damping.
    normalize : callable
        ``normalize(q (1, n)) -> (1, n)``: the 2 pi wrap into the limits.
    first : int
        Number of the first iteration (> 1 when a batched attempt hands its
        last target over, with its damping as ``lam0``).
    E_check : float, optional
        Half squared error at the last stall test (default: at the start).
    checked : bool
        The convergence and stall tests of iteration ``first`` were already
        made (by the batched attempt handing over).

    Returns
    -------
    q : ndarray, shape (n,)
        Final configuration [rad, m].
    residual : float
        Its residual [m, rad].
    iterations : int
        Steps taken.
    outcome : {"done", "stalled", "exhausted"}
        Converged (inside the limits), gave up early, or ran out of iterations.
    """
    n = c.n
    tgt = target.tolist()
    wide = len(rows) < n
    all_rows = len(rows) == 6
    eye = np.eye(len(rows) if wide else n)

    def evaluate(qq):
        T, J = fk_jacobian(robot, qq)
        e, res = error(kind, T.ravel().tolist(), tgt, rows)
        return (J if all_rows else J[rows]), np.array(e), res

    J, e, res = evaluate(q)
    lam = lam0
    E = 0.5 * float(e @ e)
    E_check = E if E_check is None else E_check
    for it in range(first, max_iter + 1):
        if checked and it == first:
            pass
        elif res < tol:
            if not free:
                return q, res, it - first, "done"
            q = normalize(q[None])[0]
            return q, res, it - first, ("done" if robot.within_limits(q) else "stalled")
        elif it % check_every == 0:
            if E > 0.01 * E_check:
                return q, res, it - first, "stalled"
            E_check = E
        if wide:  # dq = J^T (J J^T + lam I)^-1 e
            dq = J.T @ np.linalg.solve(J @ J.T + lam * eye, e)
        else:  # dq = (J^T J + lam I)^-1 J^T e
            dq = np.linalg.solve(J.T @ J + lam * eye, J.T @ e)
        qn = np.minimum(np.maximum(q + dq, lo), hi)
        Jn, en, resn = evaluate(qn)
        En = 0.5 * float(en @ en)
        if En < E:
            q, J, e, res, E = qn, Jn, en, resn, En
            lam = max(lam * 0.1, 1e-12)
        else:
            lam = min(lam * 10.0, 1e8)
    return q, res, max_iter + 1 - first, "exhausted"
