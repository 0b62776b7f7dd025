"""Batched Levenberg-Marquardt inverse kinematics (private; see :func:`labkit.ik.ik_numeric`).

All targets iterate together: one :func:`labkit.kinematics.fk_jacobian` call
and one batched ``n x n`` solve per iteration for the targets still active.
Each target keeps its own damping ``lambda`` (divided by 10 after an accepted
step, multiplied by 10 after a rejected one), steps are projected onto the
joint limits, and targets that have not converged after ``max_iter``
iterations restart from a random configuration inside the limits.
"""

from __future__ import annotations

import numpy as np

from labkit import kinematics

# rows of the spatial velocity [vx, vy, vz, wx, wy, wz] used per target kind
ROWS = {"position": (0, 1, 2), "planar": (0, 1, 5), "pose": (0, 1, 2, 3, 4, 5)}


def _wrap(a):
    return np.remainder(a + np.pi, 2 * np.pi) - np.pi


def _error(kind, T, target, rows):
    """Task error e (N, len(rows)) and residual (N,) of poses T against targets."""
    if kind == "position":
        e = target - T[:, :3, 3]
        e = e[:, list(rows)]
        return e, np.sqrt((e * e).sum(axis=1))
    if kind == "planar":
        e = np.empty((T.shape[0], 3))
        e[:, 0] = target[:, 0] - T[:, 0, 3]
        e[:, 1] = target[:, 1] - T[:, 1, 3]
        e[:, 2] = _wrap(target[:, 2] - np.arctan2(T[:, 1, 0], T[:, 0, 0]))
        return e, np.sqrt((e * e).sum(axis=1))
    # pose: position error and rotation-vector error of R_target R^T
    R = T[:, :3, :3]
    Rt = target[:, :3, :3]
    E = Rt @ np.swapaxes(R, -1, -2)
    v = 0.5 * np.stack([E[:, 2, 1] - E[:, 1, 2], E[:, 0, 2] - E[:, 2, 0], E[:, 1, 0] - E[:, 0, 1]], axis=1)
    sv = np.sqrt((v * v).sum(axis=1))
    cos = 0.5 * (E[:, 0, 0] + E[:, 1, 1] + E[:, 2, 2] - 1.0)
    ang = np.arctan2(sv, cos)
    scale = np.where(sv > 1e-12, ang / np.where(sv > 1e-12, sv, 1.0), 1.0)
    full = np.concatenate([target[:, :3, 3] - T[:, :3, 3], v * scale[:, None]], axis=1)
    e = full[:, list(rows)]
    # residual: position error and 2 sin(angle/2) per orientation (robust near pi)
    pos = full[:, [r for r in rows if r < 3]] if any(r < 3 for r in rows) else np.zeros((T.shape[0], 0))
    res2 = (pos * pos).sum(axis=1)
    if any(r >= 3 for r in rows):
        if len([r for r in rows if r >= 3]) == 3:
            o = 2.0 * np.sin(0.5 * ang)  # = |R - R_target|_F / sqrt(2), ~ angle
            res2 = res2 + o * o
        else:
            o = full[:, [r for r in rows if r >= 3]]
            res2 = res2 + (o * o).sum(axis=1)
    return e, np.sqrt(res2)


def _random_q(rng, limits, size):
    lo = np.maximum(limits[:, 0], -np.pi * 4)
    hi = np.minimum(limits[:, 1], np.pi * 4)
    return lo + (hi - lo) * rng.random((size, limits.shape[0]))


def solve(robot, kind, target, q0, rows, *, tol, max_iter, restarts, rng, lam0=1e-3):
    """Run batched LM; target (N, ...) flattened, q0 (N, n) or None.

    Returns q (N, n), success (N,), iterations (N,), residual (N,).
    """
    N = target.shape[0]
    n = robot.n
    limits = robot.joint_limits
    lo, hi = limits[:, 0], limits[:, 1]
    q = _random_q(rng, limits, N) if q0 is None else np.clip(np.array(q0, dtype=float), lo, hi)
    success = np.zeros(N, dtype=bool)
    iterations = np.zeros(N, dtype=np.int64)
    residual = np.full(N, np.inf)
    best_q = q.copy()
    eye = np.eye(n)
    rows = tuple(rows)
    for attempt in range(restarts + 1):
        act = np.flatnonzero(~success)
        if act.size == 0:
            break
        if attempt > 0:
            q[act] = _random_q(rng, limits, act.size)
        qa = q[act]
        tg = target[act]
        T, J = kinematics.fk_jacobian(robot, qa)
        J = J[:, list(rows)]
        e, res = _error(kind, T, tg, rows)
        lam = np.full(act.size, lam0)
        E = 0.5 * (e * e).sum(axis=1)
        for _ in range(max_iter):
            done = res < tol
            if np.any(done):
                idx = act[done]
                q[idx] = qa[done]
                success[idx] = True
                residual[idx] = res[done]
                keep = ~done
                act, qa, tg, J, e, res, lam, E = (x[keep] for x in (act, qa, tg, J, e, res, lam, E))
            if act.size == 0:
                break
            iterations[act] += 1
            Jt = np.swapaxes(J, -1, -2)
            A = Jt @ J + (lam + E)[:, None, None] * eye
            g = (Jt @ e[:, :, None])[:, :, 0]
            dq = np.linalg.solve(A, g[:, :, None])[:, :, 0]
            qn = np.clip(qa + dq, lo, hi)
            Tn, Jn = kinematics.fk_jacobian(robot, qn)
            Jn = Jn[:, list(rows)]
            en, resn = _error(kind, Tn, tg, rows)
            En = 0.5 * (en * en).sum(axis=1)
            better = En < E
            qa = np.where(better[:, None], qn, qa)
            J = np.where(better[:, None, None], Jn, J)
            e = np.where(better[:, None], en, e)
            res = np.where(better, resn, res)
            E = np.where(better, En, E)
            lam = np.where(better, np.maximum(lam * 0.1, 1e-12), np.minimum(lam * 10.0, 1e8))
        # record the best so far for the ones still failing
        if act.size:
            better = res < residual[act]
            residual[act[better]] = res[better]
            best_q[act[better]] = qa[better]
            q[act] = qa
    fail = ~success
    q[fail] = best_q[fail]
    return q, success, iterations, residual
