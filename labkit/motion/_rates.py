"""Joint rates and accelerations along a Cartesian path (private to :mod:`labkit.motion`).

At every sample of an IK solution ``qd`` solves ``J qd = xd`` and ``qdd``
solves ``J qdd = xdd - Jdot qd``, ``J`` being the rows of the geometric
Jacobian that the target kind fixes (:func:`labkit.kinematics.task_rows`).
Both solves follow the one rule for rates from a twist,
:func:`labkit.kinematics.joint_rates`: the exact (minimum-norm) solution while
the smallest singular value ``s_min >= epsilon``, damped least squares inside
the singular region.

For 3x3 blocks (the 3-DOF arm's position rows, a planar 3R's ``x, y, phi``
rows) that rule is evaluated without an SVD wherever the determinant
certifies that the sample is outside the singular region: since
``s1 s2 = |adj J|_2 <= |adj J|_F``, ``|det J| >= epsilon |adj J|_F`` implies
``s_min = |det J| / (s1 s2) >= epsilon``, where the damping is zero and the
rule is ``J^-1``, the adjugate over the determinant. The adjugate is built
once per trajectory on structure-of-arrays rows (each ``J[:, i, j]`` one
contiguous ``(N,)`` row) and applied twice; every product goes into a reused
scratch row (``out=``). The samples without the certificate (near a
singularity) are solved by :func:`labkit.kinematics.joint_rates` itself.
``Jdot qd`` of the position rows is a central second difference of the tool
position along ``qd``.
"""

from __future__ import annotations

import numpy as np

from labkit import kinematics


def _epsilon():
    """``epsilon`` of :func:`labkit.kinematics.joint_rates` (its default: the rule's singular region)."""
    return kinematics.joint_rates.__kwdefaults__["epsilon"]


def _solver3_rows(A, J_uncertified):
    """``b -> joint_rates(J, b)`` for 3x3 matrices given as rows ``A[i, j] = J[:, i, j]`` (3, 3, N).

    ``J_uncertified(ok)`` returns the (k, 3, 3) matrices of the samples where
    ``ok`` is False (no certificate that ``s_min >= epsilon``); they are solved
    by :func:`labkit.kinematics.joint_rates`, the others by the adjugate.
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
    bound = np.zeros(N)  # epsilon |adj J|_F
    for k in range(3):
        for i in range(3):
            np.multiply(cof[k, i], cof[k, i], out=tmp)
            bound += tmp
    np.sqrt(bound, out=bound)
    bound *= _epsilon()
    ok = np.abs(det, out=tmp) >= bound
    ok &= bound > 0  # an all-zero J has no certificate
    inv_det = np.divide(1.0, det, out=np.zeros_like(det), where=ok)
    J_bad = J_uncertified(ok) if not np.all(ok) else None
    acc = bound  # scratch from here on

    def solve(b):
        bt = b.T
        x = np.empty_like(b)
        for k in range(3):
            np.multiply(cof[k, 0], bt[0], out=acc)
            for i in (1, 2):
                np.multiply(cof[k, i], bt[i], out=tmp)
                np.add(acc, tmp, out=acc)
            np.multiply(acc, inv_det, out=x[:, k])
        if J_bad is not None:  # near a singularity: the damped rule
            x[~ok] = kinematics.joint_rates(J_bad, b[~ok])
        return x

    return solve


def solver3(J):
    """``b -> joint_rates(J, b)`` for a batch of 3x3 matrices J (N, 3, 3), factored once.

    The adjugate where the determinant certifies ``s_min >= epsilon``,
    :func:`labkit.kinematics.joint_rates` elsewhere (the same values).

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


def joint_rates_and_accelerations(robot, kind, q, xd, xdd):
    """Joint rates and accelerations along a Cartesian path, by the rule of :func:`labkit.kinematics.joint_rates`.

    ``qd = joint_rates(J, xd)`` and ``qdd = joint_rates(J, xdd - Jdot qd)``,
    ``Jdot qd`` by finite differences.

    Parameters
    ----------
    robot : Robot
    kind : {"position", "planar", "pose"}
        Target kind: selects the Jacobian rows (:func:`labkit.kinematics.task_rows`).
    q : ndarray, shape (N, n)
        Joint values along the path [rad, m].
    xd, xdd : ndarray, shape (N, k)
        Cartesian velocity and acceleration [m/s, rad/s; m/s^2, rad/s^2].

    Returns
    -------
    qd, qdd : ndarray, shape (N, n)
        Joint rates [rad/s, m/s] and accelerations [rad/s^2, m/s^2]; damped
        (finite) near singularities.
    """
    rows = kinematics.task_rows(kind)
    J = kinematics.jacobian(robot, q)
    if len(rows) == 3 == J.shape[-1]:
        A = np.empty((3, 3, q.shape[0]))  # A[i, j] = J[:, rows[i], j]: contiguous rows for the adjugate
        for i, r in enumerate(rows):
            np.copyto(A[i], J[:, r, :].T)
        del J
        solve = _solver3_rows(A, lambda ok: np.ascontiguousarray(A[:, :, ~ok].transpose(2, 0, 1)))
    else:
        Jr = J[:, list(rows), :]

        def solve(b):
            return kinematics.joint_rates(Jr, b)

    qd = solve(xd)
    if len(rows) == 6:  # poses (also the Cartesian paths of 4- and 5-DOF arms)
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
