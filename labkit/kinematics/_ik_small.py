"""Closed-form IK for a handful of targets, in plain Python (private).

For one target (a loop over poses, a widget callback, ``arm.move_to``) the
array bookkeeping of the batched solvers in
:mod:`labkit.kinematics._ik_analytic` (numpy on one-element arrays, joint-angle
normalisation, limit checks) costs far more than the arithmetic. This module
runs the same formulas, in the same order, on Python floats for the families
students meet most: ``yaw_pitch_pitch`` (the 3-DOF arm of seed 000) and
``planar_3r`` (seeds 003 and 004), and ``spherical_wrist`` (PUMA-type 6R arms,
:mod:`labkit.kinematics._ik_small_wrist`). Both paths agree to a few units in the last
place; :mod:`labkit.kinematics._ik` uses this one automatically for batches of
at most :data:`SMALL_TARGETS` targets and falls back to the batched path for
everything else (other families, bigger batches, any target that fails, so
that errors are raised by one code path only).
"""

from __future__ import annotations

import math

import numpy as np

from labkit.kinematics._ik_analytic import _REACH_TOL, Planar3R, SphericalWrist, YawPitchPitch
from labkit.kinematics._ik_small_wrist import flat_poses, float_rows, solve_pose
from labkit.rotations import wrap_angle

#: largest number of targets that takes the plain-Python path
SMALL_TARGETS = 8

_PI = math.pi
_TWO_PI = 2 * math.pi


def flat_targets(target):
    """Small batches of finite ``(..., 3)`` targets as Python floats.

    Parameters
    ----------
    target : array_like, shape (..., 3)
        Positions [m] or planar ``(x, y, phi)`` [m, m, rad].

    Returns
    -------
    rows : list of list of float, or None
        One ``[t0, t1, t2]`` per target (C order); None when the input is not
        a finite float batch of shape ``(..., 3)`` with at most
        :data:`SMALL_TARGETS` targets (the caller then takes the batched path,
        which validates and raises).
    lead : tuple of int
        The batch shape (``()`` for one target).
    """
    rows, lead = float_rows(target, (3,), SMALL_TARGETS)
    if rows is None:
        return None, ()
    isfinite = math.isfinite
    for r in rows:
        if not (isfinite(r[0]) and isfinite(r[1]) and isfinite(r[2])):
            return None, ()
    return rows, lead


def _ypp(arm, t):
    """Branches of one position target: ``_Arm.solve`` on floats.

    Parameters
    ----------
    arm : _Arm
        Geometry of joints 1-3.
    t : list of float, length 3
        Tool-point position [m].

    Returns
    -------
    q : list of list of float, shape (4, 3)
        Joint angles per branch in the chain's sense [rad].
    reach : list of bool, length 4
        The branch reaches the target.
    distance : float
        How far outside the workspace the target lies [m].
    """
    S, er, en, ev = arm.S, arm.er, arm.en, arm.ev
    d0, d1, d2 = t[0] - S[0], t[1] - S[1], t[2] - S[2]
    hr = float(er[0] * d0 + er[1] * d1 + er[2] * d2)
    hn = float(en[0] * d0 + en[1] * d1 + en[2] * d2)
    w = float(ev[0] * d0 + ev[1] * d1 + ev[2] * d2)
    off = arm.off
    rho2 = hr * hr + hn * hn
    u0 = math.sqrt(max(rho2 - off * off, 0.0))
    shoulder_ok = rho2 >= off * off * (1.0 - 1e-12) - _REACH_TOL
    L1, L2 = arm.L1, arm.L2
    lateral = max(abs(off) - math.sqrt(rho2), 0.0)
    az = math.atan2(hn, hr)
    g1, g2, s3, up_pos = arm.g1, arm.g2, arm.s3, arm.up > 0
    q, reach, distance = [], [], None
    atan2 = math.atan2
    for side in (arm.front, -arm.front):
        u = side * u0
        ur = u - arm.Sr
        D = math.sqrt(ur * ur + w * w)
        cb = (ur * ur + w * w - L1 * L1 - L2 * L2) / (2 * L1 * L2)
        side_ok = shoulder_ok and abs(cb) <= 1.0 + _REACH_TOL
        dist = max(max(max(D - (L1 + L2), abs(L1 - L2) - D), 0.0), lateral)
        distance = dist if distance is None else min(distance, dist)
        cb = min(max(cb, -1.0), 1.0)
        sb = math.sqrt(1.0 - cb * cb)
        tb_abs = atan2(sb, cb)
        beta = atan2(L2 * sb, L1 + L2 * cb)
        q1 = az - atan2(off, u)
        aw = atan2(w, ur)
        forward = ur > 0 if abs(ur) > 1e-12 else side > 0
        for elbow_up in (True, False):
            neg = forward == up_pos
            if not elbow_up:
                neg = not neg
            sign = -1.0 if neg else 1.0
            q.append([q1, g1 - (aw - sign * beta), s3 * (g2 - g1 - sign * tb_abs)])
            reach.append(side_ok)
    return q, reach, distance


def _planar3r(impl, t):
    """Branches of one planar target: ``Planar3R.solve`` on floats.

    Parameters
    ----------
    impl : Planar3R
        The solver (its constants).
    t : list of float, length 3
        ``(x, y, phi)`` [m, m, rad].

    Returns
    -------
    q : list of list of float, shape (2, 3)
        Joint angles per branch in the chain's sense [rad].
    reach : list of bool, length 2
        The branch reaches the target.
    distance : float
        How far outside the workspace the target lies [m].
    """
    x, y, phi = t
    rot = phi - impl.psi0
    c, s = math.cos(rot), math.sin(rot)
    t0x, t0y = float(impl.t0[0]), float(impl.t0[1])
    wx = x - (c * t0x - s * t0y) - float(impl.base[0])
    wy = y - (s * t0x + c * t0y) - float(impl.base[1])
    L1, L2 = impl.L1, impl.L2
    r2 = wx * wx + wy * wy
    cb = (r2 - L1 * L1 - L2 * L2) / (2 * L1 * L2)
    r = math.sqrt(r2)
    distance = max(max(r - (L1 + L2), abs(L1 - L2) - r), 0.0)
    ok = abs(cb) <= 1.0 + _REACH_TOL
    cb = min(max(cb, -1.0), 1.0)
    sb = math.sqrt(1.0 - cb * cb)
    aw = math.atan2(wy, wx)
    q = []
    for sign in (-1.0, 1.0):
        tb = sign * math.atan2(sb, cb)
        ta = aw - math.atan2(sign * L2 * sb, L1 + L2 * cb)
        q0 = ta - impl.g1
        q1 = tb - (impl.g2 - impl.g1)
        q.append([q0, q1, rot - q0 - q1])
    return q, [ok, ok], distance



def _joints(robot):
    """Per joint: (revolute, flip, lower, upper) [rad, m]."""
    return [(lk.is_revolute, lk.flip, float(lk.limits[0]), float(lk.limits[1])) for lk in robot.links]


def _normalize(row, joints):
    """Flip, wrap and shift one branch's angles as ``_ik._solve_all`` does; in place.

    Parameters
    ----------
    row : list of float, length n
        Joint values in the chain's sense [rad, m].
    joints : list of tuple
        From :func:`_joints`.

    Returns
    -------
    in_limits : bool
        The row lies inside the joint limits (slack 1e-9), as ``Robot.within_limits``.
    """
    ok = True
    for j, (rev, flip, lo, hi) in enumerate(joints):
        v = row[j]
        if flip:
            v = -v
        if rev:
            v = wrap_angle(v)
            if hi > _PI:
                up = v + _TWO_PI
                if v < lo - 1e-9 and up <= hi + 1e-9:
                    v = up
            if lo < -_PI + 1e-9:
                dn = v - _TWO_PI
                if v > hi + 1e-9 and dn >= lo - 1e-9:
                    v = dn
        if not math.isfinite(v):  # as the batched path: never let NaN out
            v = 0.0
        row[j] = v
        if (math.isfinite(lo) and not v >= lo - 1e-9) or (math.isfinite(hi) and not v <= hi + 1e-9):
            ok = False
    return ok


def supports(impl):
    """Whether ``impl`` has a plain-Python small-batch path.

    Parameters
    ----------
    impl : object
        An analytic solver instance (or None).

    Returns
    -------
    bool
    """
    return isinstance(impl, (YawPitchPitch, Planar3R, SphericalWrist))


def solve_all(robot, impl, rows):
    """Every branch of a few targets, normalised and checked as ``_ik._solve_all``.

    Parameters
    ----------
    robot : Robot
        The arm.
    impl : YawPitchPitch, Planar3R or SphericalWrist
        Its analytic solver (:func:`supports` is True).
    rows : list
        Targets from :func:`flat_targets` (or 4 x 4 nested lists from
        :func:`labkit.kinematics._ik_small_wrist.flat_poses` for a spherical wrist).

    Returns
    -------
    q : list, shape (N, m, n)
        Joint values [rad] per target and branch (unreachable rows: finite fill).
    reach : list of list of bool, shape (N, m)
        The branch reaches the target (limits ignored).
    valid : list of list of bool, shape (N, m)
        Reachable and inside the joint limits.
    distance : list of float, length N
        How far out of reach each target lies [m] (0 if any branch reaches it).
    """
    joints = _joints(robot)
    solve, consts = _solver(impl)
    Q, R, V, D = [], [], [], []
    for t in rows:
        q, reach, dist = solve(consts, t)
        valid = [_normalize(row, joints) and r for row, r in zip(q, reach)]
        Q.append(q)
        R.append(reach)
        V.append(valid)
        D.append(0.0 if any(reach) else dist)
    return Q, R, V, D


def _solver(impl):
    """The per-target function and its constants for ``impl``."""
    if isinstance(impl, SphericalWrist):
        return (lambda k, t: solve_pose(k, t, _ypp)), impl
    return (_ypp, impl.arm) if isinstance(impl, YawPitchPitch) else (_planar3r, impl)


def solve_raw(impl, target):
    """``impl.solve(target)`` for a few validated targets, on floats (no normalisation).

    Parameters
    ----------
    impl : YawPitchPitch, Planar3R or SphericalWrist
        The analytic solver (:func:`supports` is True).
    target : ndarray, shape (N, 3) or (N, 4, 4)
        Validated targets [m, rad] (a few: this path is for N <= :data:`SMALL_TARGETS`).

    Returns
    -------
    q : ndarray, shape (N, m, n)
        Joint angles per branch in the chain's sense [rad].
    reachable : ndarray of bool, shape (N, m)
    distance : ndarray, shape (N,)
        As the batched ``solve``.
    """
    solve, consts = _solver(impl)
    out = [solve(consts, t) for t in target.tolist()]
    return (np.array([o[0] for o in out], dtype=float), np.array([o[1] for o in out], dtype=bool),
            np.array([o[2] for o in out], dtype=float))


def solve_small(robot, impl, target):
    """:func:`solve_all` of ``target`` if the small-batch path applies.

    Parameters
    ----------
    robot : Robot
        The arm.
    impl : object
        Its analytic solver instance (or None for the numeric solver).
    target : array_like, shape (..., 3) or (..., 4, 4)
        The targets as the user passed them [m, rad].

    Returns
    -------
    sols : tuple or None
        ``(q, reach, valid, distance)`` from :func:`solve_all`; None when the
        solver has no small path or the targets are not a small finite
        ``(..., 3)`` batch (rigid ``(..., 4, 4)`` poses for a spherical wrist).
    lead : tuple of int
        The batch shape.
    """
    if not supports(impl):
        return None, ()
    if isinstance(impl, SphericalWrist):
        rows, lead = flat_poses(target, SMALL_TARGETS)
    else:
        rows, lead = flat_targets(target)
    if rows is None:
        return None, ()
    return solve_all(robot, impl, rows), lead


def arrays(sols, lead, m, n):
    """The arrays of an ``IKSolutions`` from :func:`solve_all` lists.

    Parameters
    ----------
    sols : tuple
        ``(q, reach, valid, distance)`` from :func:`solve_all`.
    lead : tuple of int
        The batch shape.
    m, n : int
        Number of branches and of joints.

    Returns
    -------
    q : ndarray, shape (*lead, m, n)
        Joint values [rad].
    reachable, valid : ndarray of bool, shape (*lead, m)
        As ``IKSolutions``.
    distance : ndarray, shape lead
        Out-of-reach distance [m].
    """
    Q, R, V, D = sols
    return (np.array(Q).reshape(lead + (m, n)), np.array(R, dtype=bool).reshape(lead + (m,)),
            np.array(V, dtype=bool).reshape(lead + (m,)), np.array(D).reshape(lead))


def pick(robot, sols, idx, q_near):
    """One solution per target, as ``_ik.ik`` picks it, when every target has one.

    Parameters
    ----------
    robot : Robot
        The arm.
    sols : tuple
        ``(q, reach, valid, distance)`` from :func:`solve_all`.
    idx : int or None
        The requested branch's column, or None for the nearest / first valid.
    q_near : array_like or None
        Preferred configuration [rad]; only shape ``(n,)`` is handled here.

    Returns
    -------
    list of list of float, shape (N, n), or None
        None when a target has no valid solution or ``q_near`` is not a
        finite ``(n,)`` vector: the caller then takes the batched path, which
        raises the errors or broadcasts ``q_near``.
    """
    Q, _, V, _ = sols
    if idx is not None:
        if not all(v[idx] for v in V):
            return None
        return [q[idx] for q in Q]
    if not all(any(v) for v in V):
        return None
    if q_near is None:
        return [q[v.index(True)] for q, v in zip(Q, V)]
    try:
        qn = np.asarray(q_near, dtype=float)
    except (TypeError, ValueError):
        return None
    if qn.shape != (robot.n,):
        return None
    qn = qn.tolist()
    if not all(math.isfinite(x) for x in qn):
        return None
    rev = [lk.is_revolute for lk in robot.links]
    out = []
    for q, v in zip(Q, V):
        best, best_d = None, math.inf
        for row, ok in zip(q, v):
            if not ok:
                continue
            dd = 0.0
            for x, y, r in zip(row, qn, rev):
                e = wrap_angle(x - y) if r else x - y
                dd += e * e
            if best is None or dd < best_d:
                best, best_d = row, dd
        out.append(best)
    return out
