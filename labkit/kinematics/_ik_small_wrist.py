"""Closed-form IK of a 6R arm with a spherical wrist for a few pose targets, in plain Python (private).

The batched :class:`labkit.kinematics._ik_analytic.SphericalWrist` runs about a
hundred numpy operations per call, which for one target (``ik(puma, T)`` in a
loop, a widget callback, the seeds of numeric IK) cost far more than the
arithmetic. :func:`solve_pose` runs the same formulas in the same order on
Python floats: joints 1-3 through :func:`labkit.kinematics._ik_small.arm_branches`
(the wrist centre), joints 4-6 as Paden-Kahan subproblem 2 and subproblem 1.
Both paths agree to a few units in the last place (tested on every branch).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["flat_poses", "float_rows", "solve_pose"]


def float_rows(target, tail, most):
    """A small batch of arrays of shape ``tail`` as nested Python lists of floats (no value checks).

    Parameters
    ----------
    target : array_like, shape (..., *tail)
        The batch.
    tail : tuple of int
        Shape of one item, e.g. ``(3,)`` or ``(4, 4)``.
    most : int
        Largest number of items taken.

    Returns
    -------
    rows : list or None
        One nested list per item (C order); None when ``target`` is not a float
        array of shape ``(..., *tail)`` with at most ``most`` items.
    lead : tuple of int
        The batch shape (``()`` for one item).
    """
    try:
        arr = np.asarray(target, dtype=float)
    except (TypeError, ValueError):
        return None, ()
    shape, k = arr.shape, len(tail)
    if len(shape) < k or shape[len(shape) - k:] != tuple(tail) or arr.size > math.prod(tail) * most:
        return None, ()
    return arr.reshape((-1,) + tuple(tail)).tolist(), shape[:len(shape) - k]


def flat_poses(target, most):
    """Small batches of finite rigid ``(..., 4, 4)`` poses as nested Python lists.

    Accepts exactly what the batched path's validation accepts (rotation
    columns orthonormal to 1e-6, determinant >= 0, last row ``[0, 0, 0, 1]``
    to 1e-12); anything else returns None, so the batched path raises.

    Parameters
    ----------
    target : array_like, shape (..., 4, 4)
        Tool poses ``world_from_tool`` [m].
    most : int
        Largest number of poses taken.

    Returns
    -------
    rows : list of list of list of float, or None
        One 4 x 4 nested list per pose (C order); None when the input does not qualify.
    lead : tuple of int
        The batch shape (``()`` for one pose).
    """
    rows, lead = float_rows(target, (4, 4), most)
    if rows is None:
        return None, ()
    isfinite = math.isfinite
    for T in rows:
        r0, r1, r2, r3 = T
        if not all(isfinite(x) for x in r0 + r1 + r2 + r3):
            return None, ()
        if max(abs(r3[0]), abs(r3[1]), abs(r3[2]), abs(r3[3] - 1.0)) > 1e-12:
            return None, ()
        c0 = (r0[0], r1[0], r2[0])
        c1 = (r0[1], r1[1], r2[1])
        c2 = (r0[2], r1[2], r2[2])
        err = max(abs(_dot(c0, c0) - 1.0), abs(_dot(c1, c1) - 1.0), abs(_dot(c2, c2) - 1.0),
                  abs(_dot(c0, c1)), abs(_dot(c0, c2)), abs(_dot(c1, c2)))
        det = _dot(_cross(c0, c1), c2)
        if not err <= 1e-6 or det < 0:
            return None, ()
    return rows, lead


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _matvec(M, v):
    return (M[0][0] * v[0] + M[0][1] * v[1] + M[0][2] * v[2],
            M[1][0] * v[0] + M[1][1] * v[1] + M[1][2] * v[2],
            M[2][0] * v[0] + M[2][1] * v[1] + M[2][2] * v[2])


def _rot(k, angle, v):
    """Rodrigues about the unit axis ``k`` on one vector: ``v + sin(a) k x v + (1 - cos(a)) k x (k x v)``."""
    k0, k1, k2 = k
    v0, v1, v2 = v
    u0, u1, u2 = k1 * v2 - k2 * v1, k2 * v0 - k0 * v2, k0 * v1 - k1 * v0
    w0, w1, w2 = k1 * u2 - k2 * u1, k2 * u0 - k0 * u2, k0 * u1 - k1 * u0
    s, c1 = math.sin(angle), 1.0 - math.cos(angle)
    return (v0 + s * u0 + c1 * w0, v1 + s * u1 + c1 * w1, v2 + s * u2 + c1 * w2)


class _Constants:
    """The solver's vectors and matrices as Python floats (built once per solver)."""

    def __init__(self, impl):
        tl = lambda v: tuple(float(x) for x in v)  # noqa: E731
        self.w_tool = tl(impl.w_tool)
        self.R0 = [tl(row) for row in impl.R0]
        self.a4, self.a5, self.a6, self.x6 = tl(impl.a4), tl(impl.a5), tl(impl.a6), tl(impl.x6)
        self.axes = [(float(K[2][1]), float(K[0][2]), float(K[1][0])) for K in impl._K]  # axes 1, 2, 4, 5
        self.k12, self.a5p = float(impl._k12), float(impl._a5p)
        self.cr, self.c5, self.c6 = tl(impl._cr), tl(impl._c5), tl(impl._c6)
        self.cr2 = _dot(self.cr, self.cr)
        self.orthogonal45 = bool(impl.orthogonal45)
        self.noflip_sign = float(impl.noflip_sign)
        self.s3 = float(impl.arm.s3)


def _constants(impl):
    """The solver's :class:`_Constants`, built on first use and kept on the solver."""
    k = getattr(impl, "_small_constants", None)
    if k is None:
        k = impl._small_constants = _Constants(impl)
    return k


def solve_pose(impl, T, arm_branches):
    """The eight branches of one pose target: ``SphericalWrist.solve`` on floats.

    Parameters
    ----------
    impl : SphericalWrist
        The solver (its constants).
    T : list of list of float, shape (4, 4)
        Target pose ``world_from_tool`` [m].
    arm_branches : callable
        ``arm_branches(arm, W) -> (q (4, 3), reach (4,), distance)`` for the
        wrist centre ``W`` (:func:`labkit.kinematics._ik_small.arm_branches`).

    Returns
    -------
    q : list of list of float, shape (8, 6)
        Joint angles per branch in the chain's sense [rad].
    reach : list of bool, length 8
        The branch reaches the target.
    distance : float
        How far outside the workspace the wrist centre lies [m].
    """
    k = _constants(impl)
    R = [T[0][:3], T[1][:3], T[2][:3]]
    wt = _matvec(R, k.w_tool)
    W = [T[0][3] + wt[0], T[1][3] + wt[1], T[2][3] + wt[2]]
    arm_q, arm_ok, distance = arm_branches(impl.arm, W)
    R0 = k.R0
    RR0t = [[R[i][0] * R0[j][0] + R[i][1] * R0[j][1] + R[i][2] * R0[j][2] for j in range(3)] for i in range(3)]
    m = _matvec(RR0t, k.a6)
    mx = _matvec(RR0t, k.x6)
    ax1, ax2, ax4, ax5 = k.axes
    a4, a5, p, k12, a5p, cr = k.a4, k.a5, k.a6, k.k12, k.a5p, k.cr
    den = k12 * k12 - 1.0
    q = [None] * 8
    reach = [False] * 8
    atan2, sqrt = math.atan2, math.sqrt
    for side in (0, 1):
        q1 = arm_q[2 * side][0]
        m1, mx1 = _rot(ax1, -q1, m), _rot(ax1, -q1, mx)
        for elbow in (0, 1):
            b = 2 * side + elbow
            _, q2, q3 = arm_q[b]
            q23 = q2 + k.s3 * q3
            m6, MX = _rot(ax2, -q23, m1), _rot(ax2, -q23, mx1)
            a4m = _dot(a4, m6)
            alpha = (k12 * a5p - a4m) / den
            beta = (k12 * a4m - a5p) / den
            if k.orthogonal45:
                c = _cross(ax4, m6)
                s45 = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2])
                bb = abs(beta)
                g = sqrt(max((s45 - bb) * (s45 + bb), 0.0))
            else:
                g = sqrt(max((1.0 - alpha * alpha - beta * beta - 2 * alpha * beta * k12) / k.cr2, 0.0))
            a4dm = _dot(a4, m6)
            Mp = (m6[0] - a4[0] * a4dm, m6[1] - a4[1] * a4dm, m6[2] - a4[2] * a4dm)
            wrist = []
            for gg in (g, -g):
                C = tuple(alpha * a4[i] + beta * a5[i] + gg * cr[i] for i in range(3))
                t5 = atan2(_dot(k.c5, C), _dot(p, C) - a5p * _dot(a5, C))
                a4c = _dot(a4, C)
                Cp = (C[0] - a4[0] * a4c, C[1] - a4[1] * a4c, C[2] - a4[2] * a4c)
                t4 = atan2(_dot(_cross(ax4, Cp), Mp), _dot(Cp, Mp))
                Y = _rot(ax5, -t5, _rot(ax4, -t4, MX))
                t6 = atan2(_dot(k.c6, Y), _dot(k.x6, Y))
                wrist.append((t4, t5, t6))
            plus, minus = wrist
            swap = (math.sin(plus[1]) * k.noflip_sign) < 0
            first, second = (minus, plus) if swap else (plus, minus)
            q[2 * b] = [q1, q2, q3, *first]
            q[2 * b + 1] = [q1, q2, q3, *second]
            reach[2 * b] = reach[2 * b + 1] = arm_ok[b]
    return q, reach, distance
