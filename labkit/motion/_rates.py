"""Joint rates and accelerations along a Cartesian path (private to :mod:`labkit.motion`).

``qd = J^-1 xd`` and ``qdd = J^-1 (xdd - Jdot qd)`` at every sample of an IK
solution. For 3x3 Jacobians (the 3-DOF arm's position rows, a planar 3R's
``x, y, phi`` rows) the inverse is the adjugate over the determinant, built
once per trajectory on structure-of-arrays rows (each ``J[:, i, j]`` one
contiguous ``(N,)`` row) and applied twice; every product goes into a reused
scratch row (``out=``), so the only arrays of the trajectory's size that are
allocated are the ones returned. ``Jdot qd`` of the position rows is a
central second difference of the tool position along ``qd``.
"""

from __future__ import annotations

import numpy as np

from labkit import kinematics

#: Jacobian rows that match each target kind's velocity
ROWS = {"position": (0, 1, 2), "planar": (0, 1, 5), "pose": (0, 1, 2, 3, 4, 5)}


def _solver3_rows(A, J_bad):
    """``b -> J^-1 b`` for 3x3 matrices given as rows ``A[i, j] = J[:, i, j]`` (3, 3, N).

    ``J_bad(ok)`` returns the (k, 3, 3) matrices of the samples where ``ok``
    is False (a singular arm); they get the least-squares, minimum-norm
    solution.
    """
    N = A.shape[-1]
    tmp = np.empty(N)
    cof = np.empty_like(A)  # rows of the adjugate: cross products of the columns (c_k . column_k = det)
    for k in range(3):
        j1, j2 = (k + 1) % 3, (k + 2) % 3
        for i in range(3):
            i1, i2 = (i + 1) % 3, (i + 2) % 3
            np.multiply(A[i1, j1], A[i2, j2], out=cof[k, i])
            np.multiply(A[i2, j1], A[i1, j2], out=tmp)
            cof[k, i] -= tmp
    det = np.multiply(cof[0, 0], A[0, 0])
    for i in (1, 2):
        np.multiply(cof[0, i], A[i, 0], out=tmp)
        det += tmp
    scale = None  # product of the column norms
    for j in range(3):
        col = np.multiply(A[0, j], A[0, j])
        for i in (1, 2):
            np.multiply(A[i, j], A[i, j], out=tmp)
            col += tmp
        np.sqrt(col, out=col)
        scale = col if scale is None else np.multiply(scale, col, out=scale)
    scale += 1e-300
    scale *= 1e-12
    ok = np.abs(det, out=tmp) > scale
    inv_det = np.divide(1.0, det, out=np.zeros_like(det), where=ok)
    pinv = np.linalg.pinv(J_bad(ok)) if not np.all(ok) else None
    acc = scale  # scratch from here on

    def solve(b):
        bt = b.T
        x = np.empty_like(b)
        for k in range(3):
            np.multiply(cof[k, 0], bt[0], out=acc)
            for i in (1, 2):
                np.multiply(cof[k, i], bt[i], out=tmp)
                np.add(acc, tmp, out=acc)
            np.multiply(acc, inv_det, out=x[:, k])
        if pinv is not None:  # singular samples: least squares (finite, the minimum-norm rate)
            x[~ok] = np.einsum("nij,nj->ni", pinv, b[~ok])
        return x

    return solve


def solver3(J):
    """``b -> J^-1 b`` for a batch of 3x3 matrices J (N, 3, 3), factored once (adjugate).

    Rows whose determinant is below 1e-12 of the product of the column norms
    (a singular arm) get the least-squares, minimum-norm solution instead.

    Parameters
    ----------
    J : ndarray, shape (N, 3, 3)

    Returns
    -------
    callable
        ``solve(b)``, ``b`` of shape (N, 3) -> ``x`` of shape (N, 3).
    """
    A = np.ascontiguousarray(J.transpose(1, 2, 0))
    return _solver3_rows(A, lambda ok: J[~ok])


def joint_rates(robot, kind, q, xd, xdd):
    """``qd = J^-1 xd`` and ``qdd = J^-1 (xdd - Jdot qd)``, ``Jdot qd`` by finite differences.

    Parameters
    ----------
    robot : Robot
    kind : {"position", "planar", "pose"}
        Target kind: selects the Jacobian rows (:data:`ROWS`).
    q : ndarray, shape (N, n)
        Joint values along the path [rad, m].
    xd, xdd : ndarray, shape (N, k)
        Cartesian velocity and acceleration [m/s, rad/s; m/s^2, rad/s^2].

    Returns
    -------
    qd, qdd : ndarray, shape (N, n)
        Joint rates [rad/s, m/s] and accelerations [rad/s^2, m/s^2].
    """
    rows = ROWS[kind]
    J = kinematics.jacobian(robot, q)
    if len(rows) == 3 == J.shape[-1]:
        A = np.empty((3, 3, q.shape[0]))  # A[i, j] = J[:, rows[i], j]: contiguous rows for the adjugate
        for i, r in enumerate(rows):
            np.copyto(A[i], J[:, r, :].T)
        del J
        solve = _solver3_rows(A, lambda ok: np.ascontiguousarray(A[:, :, ~ok].transpose(2, 0, 1)))
    else:
        Jinv = np.linalg.pinv(J[:, list(rows), :])

        def solve(b):
            return np.einsum("nij,nj->ni", Jinv, b)

    qd = solve(xd)
    if kind == "pose":
        h = 1e-6
        Jp = kinematics.jacobian(robot, q + h * qd)[:, list(rows), :]
        Jm = kinematics.jacobian(robot, q - h * qd)[:, list(rows), :]
        jdot_qd = np.einsum("nij,nj->ni", (Jp - Jm) / (2 * h), qd)
    else:
        # Jdot qd of the position rows = qd^T (d2p/dq2) qd: a central second
        # difference of the tool position along qd (cheaper than two Jacobians);
        # the planar phi row is linear in q, so its Jdot qd is 0.
        speed = np.linalg.norm(qd, axis=1)
        h = 1e-4 / np.maximum(speed, 1e-12)
        step = h[:, None] * qd
        qs = np.add(q, step)
        second = kinematics.fk_position(robot, qs)  # p(q + step) + p(q - step) - 2 p(q)
        np.subtract(q, step, out=qs)
        second += kinematics.fk_position(robot, qs)
        centre = kinematics.fk_position(robot, q, out=qs) if q.shape[1] == 3 else kinematics.fk_position(robot, q)
        centre *= 2.0
        second -= centre
        h *= h
        second /= h[:, None]
        if kind == "planar":
            second[:, 2] = 0.0
        jdot_qd = second
    qdd = solve(xdd - jdot_qd)
    return qd, qdd
