"""The arithmetic of one Levenberg-Marquardt iteration, each rule written once (private).

On a batch of targets as numpy rows (one target is a batch of one): the task
error and residual (:func:`task_error`), the damped least-squares step
(:func:`damped_step`) and the damping rule (:func:`damping`);
:func:`labkit.kinematics._ik_solvers._numeric.solve` runs the loop around them.
"""

from __future__ import annotations

import functools

import numpy as np

from labkit.kinematics._ik_solvers._targets import task_rows
from labkit.rotations import wrap_angle

#: bounds of the damping
LAMBDA_MIN, LAMBDA_MAX = 1e-12, 1e8


@functools.cache
def _plan(kind, rows):
    """Which error components ``rows`` (a tuple) are, and for a pose with its three rotation rows (the whole
    orientation enters the residual as an angle) which of them are positions (else None)."""
    slots = [task_rows(kind).index(r) for r in rows]
    whole = kind == "pose" and sum(r >= 3 for r in rows) == 3
    return (slice(None) if slots == list(range(len(task_rows(kind)))) else slots), \
        ([i for i, r in enumerate(rows) if r < 3] if whole else None)


#: the rotation vector's components read off a rotation matrix: (R[i, j] - R[j, i]) / 2 for (i, j) = (2, 1) ...
_UPPER, _LOWER = np.array([2, 0, 1]), np.array([1, 2, 0])


def _norm(e):
    return np.sqrt(np.einsum("ij,ij->i", e, e))


def task_error(kind, T, target, rows):
    """Task error and residual of poses [m] against targets [m, rad] on the task ``rows`` of ``[v; w]``.

    Parameters
    ----------
    kind : {"position", "planar", "pose"}
    T : ndarray, shape (N, 4, 4)
    target : ndarray, shape (N, 3) or (N, 4, 4)
    rows : tuple of int

    Returns
    -------
    e : ndarray, shape (N, len(rows))
        Position error, then the rotation vector taking the pose's orientation to the target's
        (a planar target's ``phi`` error, wrapped) [m, rad].
    residual : ndarray, shape (N,)
        Norm of the position error and, for a whole orientation, ``2 sin(angle / 2)`` (robust
        near pi); else the norm of ``e`` [m, rad].
    """
    slots, position = _plan(kind, tuple(rows))
    if kind == "position":
        e = (target - T[:, :3, 3])[:, slots]
        return e, _norm(e)
    if kind == "planar":
        heading = wrap_angle(target[:, 2] - np.arctan2(T[:, 1, 0], T[:, 0, 0]))
        e = np.column_stack((target[:, :2] - T[:, :2, 3], heading))[:, slots]
        return e, _norm(e)
    R = target[:, :3, :3] @ T[:, :3, :3].swapaxes(-1, -2)  # from the pose's orientation to the target's
    e = np.empty((T.shape[0], 6))
    np.subtract(target[:, :3, 3], T[:, :3, 3], out=e[:, :3])
    v = e[:, 3:]
    np.subtract(R[:, _UPPER, _LOWER], R[:, _LOWER, _UPPER], out=v)
    v *= 0.5
    sv = _norm(v)
    angle = np.arctan2(sv, 0.5 * (np.trace(R, axis1=1, axis2=2) - 1.0))
    big = sv > 1e-12
    v *= np.where(big, angle / np.where(big, sv, 1.0), 1.0)[:, None]  # the rotation vector, axis * angle
    e = e[:, slots]
    if position is None:
        return e, _norm(e)
    p = e[:, position]
    return e, np.sqrt(np.einsum("ij,ij->i", p, p) + (2.0 * np.sin(0.5 * angle)) ** 2)


def damped_step(J, e, lam):
    """Damped least-squares step [rad, m]: ``(J^T J + lam I)^-1 J^T e``, or ``J^T (J J^T + lam I)^-1 e`` for a
    wide ``J``, from the task rows ``J``, the task error ``e`` [m, rad] and the damping ``lam``.

    Parameters
    ----------
    J : ndarray, shape (N, m, n)
    e : ndarray, shape (N, m)
    lam : ndarray, shape (N,)

    Returns
    -------
    ndarray, shape (N, n)
    """
    m, n = J.shape[-2:]
    Jt = J.swapaxes(-1, -2)
    wide = m < n
    A = J @ Jt if wide else Jt @ J
    diagonal = np.arange(A.shape[-1])
    A[:, diagonal, diagonal] += lam[:, None]  # + lam I
    if wide:
        return (Jt @ np.linalg.solve(A, e[:, :, None]))[:, :, 0]
    return np.linalg.solve(A, Jt @ e[:, :, None])[:, :, 0]


def damping(lam, accepted):
    """The damping after a step: ``lam / 10`` (at least 1e-12) where ``accepted``, else ``lam * 10`` (at most 1e8).

    Parameters
    ----------
    lam : ndarray, shape (N,)
    accepted : ndarray of bool, shape (N,)

    Returns
    -------
    ndarray, shape (N,)
    """
    return np.where(accepted, np.maximum(lam * 0.1, LAMBDA_MIN), np.minimum(lam * 10.0, LAMBDA_MAX))
