"""Closed-form inverse kinematics (private; the public API is :mod:`labkit.kinematics`).

The solvers do not parse DH tables by hand. They read the joint axes of the
robot at ``q = 0`` from :func:`labkit.kinematics.fk_frames` (world frame, base
and tool transforms included, either DH convention) and solve in that
geometry, product-of-exponentials style. Three structures are recognised:

``planar_3r``
    three revolute joints whose axes are all parallel to the world ``+z``
    axis, with a tool frame whose ``z`` is ``+z`` too. Target ``(x, y, phi)``,
    ``phi`` the angle of the tool ``x`` axis from world ``x``.
``yaw_pitch_pitch``
    three revolute joints: axis 1, axis 2 perpendicular to axis 1 and either
    intersecting it or offset from it along their common normal (a *shoulder
    offset*, ``a_1`` of IRB140 / KR5 arms), axis 3 parallel to axis 2; the
    tool point may lie off the arm plane by a constant lateral offset.
    Target: tool position.
``spherical_wrist``
    six revolute joints; joints 1-3 as ``yaw_pitch_pitch`` (with or without a
    shoulder offset: PUMA, IRB140, KR5) and axes 4, 5, 6 meeting in one point
    (the wrist centre), 4 not parallel to 5 and 5 not parallel to 6. Target:
    tool pose. Joints 1-3 place the wrist centre, joints 4-6 are a Paden-Kahan
    subproblem 2 + subproblem 1. With a shoulder offset the front and back
    arm solutions reach differently far: ``reachable`` is per branch.

Every solver returns raw arrays ``q (N, m, n)`` and ``reachable (N, m)`` and an
out-of-reach distance ``(N,)`` [m]; unreachable entries hold the finite
configuration obtained by clipping the cosine-law arguments (the arm stretched
or folded towards the target), never NaN.

Branch naming (geometric, so it does not depend on sign conventions):
*elbow up* is the branch whose elbow lies on the "up" side of the line from
the shoulder to the wrist centre (tool point). "Up" is the side of the
shoulder's horizontal plane (perpendicular to axis 1) that the elbow points to
at the middle of joint 2's range (the side the arm works on); if that is
ambiguous (elbow within 0.2 L1 of the plane) it is ``+axis 1``. For the
Arduino arm of seed 000 (frame 0 ``z`` points down, servos 0-180 deg) this is
``-z0`` and reproduces the seed's elbow-up formula; for the PUMAs it is
``+z0``. For ``planar_3r`` elbow up means the elbow lies to the left of the
line joint 1 -> joint 3 (above it for a target in front, ``x > 0``): the
relative elbow angle is negative (seed 004's "elbow minus").
"""

from __future__ import annotations

import math

import numpy as np

from labkit.kinematics._forward import fk_frames
from labkit.robot.types import Convention
from labkit.rotations import wrap_angle

_TOL = 1e-9  # geometric tolerance of the structure detection [m or rad]
_REACH_TOL = 1e-12  # slack on cosine-law arguments


class _NotThisStructure(Exception):
    """The robot does not have the structure a solver needs (reason in args)."""


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _feet(p1, d1, p2, d2):
    """Feet of the common normal of two non-parallel lines: the closest point on each."""
    w = p1 - p2
    b = d1 @ d2
    den = 1.0 - b * b
    t1 = (b * (d2 @ w) - (d1 @ w)) / den
    t2 = ((d2 @ w) - b * (d1 @ w)) / den
    return p1 + t1 * d1, p2 + t2 * d2


def _axes(robot):
    """Joint axes (unit directions) and points on them at q = 0, plus the tool frame."""
    n = robot.n
    F = fk_frames(robot, np.zeros(n))
    idx = np.arange(1, n + 1) if robot.convention is Convention.MODIFIED else np.arange(0, n)
    return F[idx, :3, 2].copy(), F[idx, :3, 3].copy(), F[n + 1]


def _scale(robot):
    return max(1.0, float(np.abs(robot.a).sum() + np.abs(robot.d).sum() + np.abs(robot.tool[:3, 3]).sum()))


# --------------------------------------------------------------------------
# Joint-angle bookkeeping shared by all solvers
# --------------------------------------------------------------------------

def normalize_angles(q, limits, revolute):
    """Wrap revolute angles into (-pi, pi], then shift by 2 pi where that enters the limits.

    Parameters
    ----------
    q : array_like, shape (..., n)
        Joint values [rad, m].
    limits : ndarray, shape (n, 2)
        Joint limits [rad, m].
    revolute : ndarray of bool, shape (n,)
        Which joints are revolute (only those are wrapped).

    Returns
    -------
    ndarray, shape (..., n)
        A new array.
    """
    q = np.array(q, dtype=float)
    two_pi = 2 * np.pi
    for j in np.flatnonzero(revolute):
        qj = q[..., j]
        qj[...] = wrap_angle(qj)
        lo, hi = limits[j]
        if hi > np.pi:  # a value in (-pi, pi] below the limits may enter them one turn up
            up = qj + two_pi
            qj[...] = np.where((qj < lo - 1e-9) & (up <= hi + 1e-9), up, qj)
        if lo < -np.pi + 1e-9:  # ... or one turn down (pi itself, when the range starts at -pi)
            dn = qj - two_pi
            qj[...] = np.where((qj > hi + 1e-9) & (dn >= lo - 1e-9), dn, qj)
    return q


def solve_one_branch(robot, impl, flat, idx, chunk):
    """One branch of validated, flattened targets, if every target is valid on it.

    Parameters
    ----------
    robot : Robot
    impl : analytic solver
        Without a ``solve_branch(target, k)`` method the answer is None.
    flat : ndarray, shape (N, ...)
        Targets.
    idx : int
        Branch index.
    chunk : int
        Targets per call of the solver.

    Returns
    -------
    ndarray, shape (N, n) or None
        ``q`` [rad, m] as ``ik_all`` gives it for that branch; None if a target
        is unreachable or outside the limits on it (the caller then takes the
        full path, which diagnoses every branch).
    """
    if not hasattr(impl, "solve_branch"):
        return None
    rev = robot.is_revolute
    flipped = np.flatnonzero(robot.flip)
    q = np.empty((flat.shape[0], robot.n))
    for s in range(0, flat.shape[0], chunk):
        qc, rc = impl.solve_branch(flat[s:s + chunk], idx)
        if not np.all(rc):
            return None
        if flipped.size:  # the solvers work in the chain's sense (theta_i = q_i + offset)
            qc[..., flipped] *= -1.0
        q[s:s + chunk] = normalize_angles(qc, robot.joint_limits, rev)
    if not np.isfinite(q.sum()) or not np.all(robot.within_limits(q)):
        return None
    return q


def wrist_branches(shoulder):
    """Branch names and their three-letter aliases of an 8-solution 6R arm.

    Parameters
    ----------
    shoulder : tuple of str
        The two shoulder names, in the solver's order (e.g. ``("right", "left")``).

    Returns
    -------
    branches : tuple of str
        ``"<shoulder>_<up|down>_<noflip|flip>"``, shoulder slowest.
    aliases : dict
        ``{"run": "right_up_noflip", ...}``.
    """
    names = [(s, e, w) for s in shoulder for e in ("up", "down") for w in ("noflip", "flip")]
    return tuple(f"{s}_{e}_{w}" for s, e, w in names), {f"{s[0]}{e[0]}{w[0]}": f"{s}_{e}_{w}" for s, e, w in names}


# --------------------------------------------------------------------------
# Planar 3R
# --------------------------------------------------------------------------

class Planar3R:
    """Closed-form IK of a planar 3R arm for targets (x, y, phi)."""

    name = "planar_3r"
    kind = "planar"
    branches = ("elbow_up", "elbow_down")
    aliases = {"elbow_minus": "elbow_up", "elbow_plus": "elbow_down", "up": "elbow_up", "down": "elbow_down"}

    def __init__(self, robot):
        if robot.n != 3 or not np.all(robot.is_revolute):
            raise _NotThisStructure("needs exactly 3 revolute joints")
        z, o, tool = _axes(robot)
        if np.any(np.abs(z[:, 2] - 1.0) > _TOL):
            raise _NotThisStructure("all joint axes must be parallel to world +z")
        if abs(tool[2, 2] - 1.0) > _TOL:
            raise _NotThisStructure("the tool z axis must be world +z")
        P = o[:, :2]
        e = P[1] - P[0]
        f = P[2] - P[1]
        self.base = P[0]
        self.L1, self.L2 = float(np.hypot(*e)), float(np.hypot(*f))
        if self.L1 < _TOL or self.L2 < _TOL:
            raise _NotThisStructure("links 1 and 2 must have non-zero length")
        self.g1 = math.atan2(e[1], e[0])
        self.g2 = math.atan2(f[1], f[0])
        self.psi0 = math.atan2(tool[1, 0], tool[0, 0])
        self.t0 = tool[:2, 3] - P[2]  # tool point relative to axis 3 at q = 0

    def solve(self, target):
        """Both elbow branches of planar targets.

        Parameters
        ----------
        target : ndarray, shape (N, 3)
            ``(x, y, phi)`` [m, m, rad].

        Returns
        -------
        q : ndarray, shape (N, 2, 3)
            Joint angles per branch [rad].
        reachable : ndarray of bool, shape (N, 2)
        distance : ndarray, shape (N,)
            How far outside the workspace each target lies [m] (0 inside).
        """
        x, y, phi = target[:, 0], target[:, 1], target[:, 2]
        rot = phi - self.psi0  # q1 + q2 + q3
        c, s = np.cos(rot), np.sin(rot)
        wx = x - (c * self.t0[0] - s * self.t0[1]) - self.base[0]
        wy = y - (s * self.t0[0] + c * self.t0[1]) - self.base[1]
        L1, L2 = self.L1, self.L2
        r2 = wx * wx + wy * wy
        cb = (r2 - L1 * L1 - L2 * L2) / (2 * L1 * L2)
        r = np.sqrt(r2)
        distance = np.maximum(np.maximum(r - (L1 + L2), abs(L1 - L2) - r), 0.0)
        ok = np.abs(cb) <= 1.0 + _REACH_TOL
        cb = np.clip(cb, -1.0, 1.0)
        sb = np.sqrt(1.0 - cb * cb)
        aw = np.arctan2(wy, wx)
        q = np.empty((x.shape[0], 2, 3))
        for k, sign in enumerate((-1.0, 1.0)):  # elbow up: theta_b < 0
            tb = sign * np.arctan2(sb, cb)
            ta = aw - np.arctan2(sign * L2 * sb, L1 + L2 * cb)
            q[:, k, 0] = ta - self.g1
            q[:, k, 1] = tb - (self.g2 - self.g1)
            q[:, k, 2] = rot - q[:, k, 0] - q[:, k, 1]
        return q, np.repeat(ok[:, None], 2, axis=1), distance


# --------------------------------------------------------------------------
# Yaw-pitch-pitch arm (3-DOF position, and the first half of the 6R solver)
# --------------------------------------------------------------------------

class _Arm:
    """Geometry of joints 1-3: base yaw, two parallel pitch axes, point W."""

    def __init__(self, robot, z, o, W0):
        a1, a2, a3 = (_unit(v) for v in z[:3])
        if abs(a1 @ a2) > _TOL:
            raise _NotThisStructure("axis 2 must be perpendicular to axis 1")
        if np.linalg.norm(np.cross(a2, a3)) > _TOL:
            raise _NotThisStructure("axis 3 must be parallel to axis 2")
        scale = _scale(robot)
        self.ev, self.en, self.er = a1, a2, np.cross(a2, a1)
        # the shoulder: foot of the common normal of axes 1 and 2 on axis 2, at the radial
        # distance Sr from axis 1 (the shoulder offset a_1 of IRB140 / KR5 arms; 0 for a PUMA)
        S1, S2 = _feet(o[0], a1, o[1], a2)
        self.S = S1
        self.Sr = float((S2 - S1) @ self.er)
        self.s3 = 1.0 if a3 @ a2 > 0 else -1.0
        E = o[2] - S2
        Er, Ev = E @ self.er, E @ self.ev
        Wd = W0 - S1
        Wr, Wv = Wd @ self.er, Wd @ self.ev
        self.off = float(Wd @ self.en)
        self.L1 = float(math.hypot(Er, Ev))
        self.L2 = float(math.hypot(Wr - self.Sr - Er, Wv - Ev))
        if self.L1 < _TOL * scale or self.L2 < _TOL * scale:
            raise _NotThisStructure("the elbow must be away from the shoulder and the wrist")
        self.g1 = math.atan2(Ev, Er)
        self.g2 = math.atan2(Wv - Ev, Wr - self.Sr - Er)
        # which sign of u is the "front" (q1 as atan2 of the target) and which side is "up"
        self.front = -1.0 if Wr < -_TOL * scale else 1.0
        lim = robot.joint_limits[1]
        mid = 0.5 * (lim[0] + lim[1]) if np.all(np.isfinite(lim)) else 0.0
        if robot.links[1].flip:  # limits are on q; the geometry here uses the chain's theta
            mid = -mid
        v_mid = self.L1 * math.sin(self.g1 - mid)
        self.up = -1.0 if v_mid < -0.2 * self.L1 else 1.0
        self.a = (a1, a2, a3)

    def solve(self, W, only=None):
        """W (3, N) -> list of 4 (q1, q2, q3) tuples, reachable (N, 4), distance (N,).

        Order: front elbow up, front elbow down, back elbow up, back elbow down.
        With ``only`` (0-3) just that branch is computed (the same operations):
        a list of one tuple, reachable (N, 1) and distance None.
        """
        d = W - self.S[:, None]
        hr = self.er @ d
        hn = self.en @ d
        w = self.ev @ d
        off = self.off
        rho2 = hr * hr + hn * hn
        u0 = np.sqrt(np.maximum(rho2 - off * off, 0.0))
        shoulder_ok = rho2 >= off * off * (1.0 - 1e-12) - _REACH_TOL
        L1, L2 = self.L1, self.L2
        lateral = np.maximum(abs(off) - np.sqrt(rho2), 0.0) if only is None else None
        az = np.arctan2(hn, hr)
        out, ok, distance = [], [], None
        sides = (self.front, -self.front)
        for side in sides if only is None else sides[only // 2:only // 2 + 1]:
            u = side * u0
            ur = u - self.Sr  # radial coordinate of W seen from the shoulder
            cb = (ur * ur + w * w - L1 * L1 - L2 * L2) / (2 * L1 * L2)
            side_ok = shoulder_ok & (np.abs(cb) <= 1.0 + _REACH_TOL)
            if only is None:
                D = np.sqrt(ur * ur + w * w)
                dist = np.maximum(np.maximum(np.maximum(D - (L1 + L2), abs(L1 - L2) - D), 0.0), lateral)
                distance = dist if distance is None else np.minimum(distance, dist)
            cb = np.clip(cb, -1.0, 1.0)
            sb = np.sqrt(1.0 - cb * cb)
            tb_abs = np.arctan2(sb, cb)
            beta = np.arctan2(L2 * sb, L1 + L2 * cb)  # interior angle at the shoulder
            q1 = az - np.arctan2(off, u)
            aw = np.arctan2(w, ur)
            # the shoulder -> W line points along +er' where ur > 0 (side when there is no offset)
            forward = np.where(np.abs(ur) > 1e-12, ur > 0, side > 0)
            for elbow_up in (True, False) if only is None else (only % 2 == 0,):
                # elbow above the shoulder->W line  <=>  (theta_b < 0) == (ur > 0), with up = +ev
                neg = forward == (self.up > 0)
                if not elbow_up:
                    neg = ~neg
                sign = np.where(neg, -1.0, 1.0)
                ta = aw - sign * beta
                q2 = self.g1 - ta
                q3 = self.s3 * (self.g2 - self.g1 - sign * tb_abs)
                out.append((q1, q2, q3))
                ok.append(side_ok)
        return out, np.stack(ok, axis=1), distance

    def rotation(self, q1, q23):
        """World rotation Rot(a1, q1) Rot(a2, q23) as (N, 3, 3) (q23 = q2 + s3 q3)."""
        return _rot_batch(self.a[0], q1) @ _rot_batch(self.a[1], q23)


def _rot_batch(axis, angle):
    """Rotation matrices about a fixed unit axis, angle (N,) -> (N, 3, 3)."""
    x, y, z = axis
    c, s = np.cos(angle), np.sin(angle)
    C = 1.0 - c
    R = np.empty(angle.shape + (3, 3))
    R[..., 0, 0] = c + x * x * C
    R[..., 0, 1] = x * y * C - z * s
    R[..., 0, 2] = x * z * C + y * s
    R[..., 1, 0] = y * x * C + z * s
    R[..., 1, 1] = c + y * y * C
    R[..., 1, 2] = y * z * C - x * s
    R[..., 2, 0] = z * x * C - y * s
    R[..., 2, 1] = z * y * C + x * s
    R[..., 2, 2] = c + z * z * C
    return R


def _skew(k):
    return np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])


def _rot(K, angle, v):
    """Rodrigues with a precomputed skew matrix K of the axis; v (3, M), angle (M,)."""
    Kv = K @ v
    return v + np.sin(angle) * Kv + (1.0 - np.cos(angle)) * (K @ Kv)


class YawPitchPitch:
    """Closed-form position IK of a 3R yaw-pitch-pitch arm (seed 000's Arduino arm)."""

    name = "yaw_pitch_pitch"
    kind = "position"
    branches = ("elbow_up", "elbow_down", "back_elbow_up", "back_elbow_down")
    aliases = {"up": "elbow_up", "down": "elbow_down"}

    def __init__(self, robot):
        if robot.n != 3 or not np.all(robot.is_revolute):
            raise _NotThisStructure("needs exactly 3 revolute joints")
        z, o, tool = _axes(robot)
        self.arm = _Arm(robot, z, o, tool[:3, 3])

    def solve(self, target):
        """The four branches (front/back, elbow up/down) of position targets.

        Parameters
        ----------
        target : ndarray, shape (N, 3)
            Tool-point positions [m].

        Returns
        -------
        q : ndarray, shape (N, 4, 3)
            Joint angles per branch [rad].
        reachable : ndarray of bool, shape (N, 4)
        distance : ndarray, shape (N,)
            How far outside the workspace each target lies [m] (0 inside).
        """
        sols, ok, distance = self.arm.solve(target.T)
        q = np.empty((target.shape[0], 4, 3))
        for k, (q1, q2, q3) in enumerate(sols):
            q[:, k, 0], q[:, k, 1], q[:, k, 2] = q1, q2, q3
        return q, ok, distance

    def solve_branch(self, target, k):
        """Branch ``k`` of :meth:`solve` alone (same operations, a quarter of the work).

        Parameters
        ----------
        target : ndarray, shape (N, 3)
            Tool-point positions [m].
        k : int
            Index into ``branches``.

        Returns
        -------
        q : ndarray, shape (N, 3)
            Joint angles [rad].
        reachable : ndarray of bool, shape (N,)
        """
        sols, ok, _ = self.arm.solve(target.T, only=k)
        q = np.empty((target.shape[0], 3))
        q[:, 0], q[:, 1], q[:, 2] = sols[0]
        return q, ok[:, 0]


# --------------------------------------------------------------------------
# 6R with a spherical wrist
# --------------------------------------------------------------------------

class SphericalWrist:
    """Closed-form pose IK of a 6R arm with a spherical wrist: all 8 solutions."""

    name = "spherical_wrist"
    kind = "pose"

    def __init__(self, robot):

        if robot.n != 6 or not np.all(robot.is_revolute):
            raise _NotThisStructure("needs exactly 6 revolute joints")
        z, o, tool = _axes(robot)
        a4, a5, a6 = (_unit(v) for v in z[3:])
        if np.linalg.norm(np.cross(a4, a5)) < 1e-6 or np.linalg.norm(np.cross(a5, a6)) < 1e-6:
            raise _NotThisStructure("wrist axes 4-5 and 5-6 must not be parallel")
        # wrist centre: least-squares intersection of axes 4, 5, 6
        A = np.zeros((3, 3))
        b = np.zeros(3)
        for d, p in zip((a4, a5, a6), o[3:]):
            P = np.eye(3) - np.outer(d, d)
            A += P
            b += P @ p
        C = np.linalg.solve(A, b)
        scale = _scale(robot)
        for d, p in zip((a4, a5, a6), o[3:]):
            if np.linalg.norm(np.cross(C - p, d)) > _TOL * scale:
                raise _NotThisStructure("wrist axes 4, 5, 6 do not meet in one point")
        self.arm = _Arm(robot, z, o, C)
        self.a4, self.a5, self.a6 = a4, a5, a6
        self._K = tuple(_skew(k) for k in (self.arm.a[0], self.arm.a[1], a4, a5))
        self.orthogonal45 = abs(a4 @ a5) < 1e-12
        self.R0 = tool[:3, :3].copy()  # tool orientation at q = 0
        self.w_tool = tool[:3, :3].T @ (C - tool[:3, 3])  # wrist centre in tool coordinates
        # a vector perpendicular to axis 6, to recover q6
        t = np.eye(3)[int(np.argmin(np.abs(a6)))]
        self.x6 = _unit(t - a6 * (t @ a6))
        # constants of the wrist subproblems (per robot, not per call)
        self._k12 = float(a4 @ a5)
        self._cr = np.cross(a4, a5)
        self._a5p = float(a5 @ a6)
        self._c5 = np.cross(a5, a6)
        self._c6 = np.cross(a6, self.x6)
        # "no flip" as roboticstoolbox-python: sign(q5) = -sign(alpha_4) (alpha between axes 4 and 5)
        alpha4 = robot.links[4].alpha if robot.convention is Convention.MODIFIED else robot.links[3].alpha
        self.noflip_sign = -1.0 if math.sin(alpha4) > 0 else 1.0
        self.branches, self.aliases = wrist_branches(("right", "left"))

    def solve(self, T):
        """The eight branches (arm x elbow x wrist) of pose targets.

        Parameters
        ----------
        T : ndarray, shape (N, 4, 4)
            Target poses ``world_from_tool`` [m].

        Returns
        -------
        q : ndarray, shape (N, 8, 6)
            Joint angles per branch [rad].
        reachable : ndarray of bool, shape (N, 8)
        distance : ndarray, shape (N,)
            How far outside the workspace each wrist centre lies [m] (0 inside).
        """
        N = T.shape[0]
        R = T[:, :3, :3]
        W = T[:, :3, 3] + R @ self.w_tool
        arm_sols, ok, distance = self.arm.solve(W.T)
        # M = R123^T R R0^T; the wrist only needs its action on a6 and on x6 (perpendicular to a6)
        RR0t = R @ self.R0.T
        V = np.concatenate([(RR0t @ self.a6).T, (RR0t @ self.x6).T], axis=1)  # (3, 2N)
        a4, a5, p = self.a4, self.a5, self.a6
        K1, K2, K4, K5 = self._K
        k12, cr, a5p, c5, c6 = self._k12, self._cr, self._a5p, self._c5, self._c6
        den = k12 * k12 - 1.0
        cr2 = cr @ cr
        q = np.empty((N, 8, 6))
        reach = np.repeat(ok, 2, axis=1)  # arm solution k -> wrist branches 2k, 2k + 1
        for side in (0, 1):
            q1 = arm_sols[2 * side][0]
            V1 = _rot(K1, np.concatenate([-q1, -q1]), V)  # undo joint 1
            for elbow in (0, 1):
                k = 2 * side + elbow
                _, q2, q3 = arm_sols[k]
                q23 = q2 + self.arm.s3 * q3
                V2 = _rot(K2, np.concatenate([-q23, -q23]), V1)  # undo joints 2 and 3
                m6 = V2[:, :N]
                M6 = np.concatenate([m6, m6], axis=1)
                MX = np.concatenate([V2[:, N:], V2[:, N:]], axis=1)
                # subproblem 2: Rot(a4, t4) Rot(a5, t5) a6 = m6, both signs of gamma at once
                a4m = a4 @ m6
                alpha = (k12 * a5p - a4m) / den
                beta = (k12 * a4m - a5p) / den
                if self.orthogonal45:
                    # |a4 x c| = |a4 x m6| = sqrt(beta^2 + gamma^2): accurate near the wrist singularity,
                    # where 1 - alpha^2 - beta^2 would lose half the digits
                    s45 = np.sqrt(((_skew(a4) @ m6) ** 2).sum(axis=0))
                    b = abs(beta) if np.ndim(beta) == 0 else np.abs(beta)
                    g = np.sqrt(np.maximum((s45 - b) * (s45 + b), 0.0))
                else:
                    g = np.sqrt(np.maximum((1.0 - alpha * alpha - beta * beta - 2 * alpha * beta * k12) / cr2, 0.0))
                alpha2, beta2 = np.concatenate([alpha, alpha]), np.concatenate([beta, beta])
                C = alpha2 * a4[:, None] + beta2 * a5[:, None] + np.concatenate([g, -g]) * cr[:, None]
                t5 = np.arctan2(c5 @ C, p @ C - a5p * (a5 @ C))
                # subproblem 1 about a4 on the explicit perpendicular parts (near the wrist
                # singularity they are tiny, and c.m - (a4.c)(a4.m) would cancel catastrophically)
                Cp = C - a4[:, None] * (a4 @ C)
                Mp = M6 - a4[:, None] * (a4 @ M6)
                t4 = np.arctan2(((K4 @ Cp) * Mp).sum(axis=0), (Cp * Mp).sum(axis=0))
                Y = _rot(K5, -t5, _rot(K4, -t4, MX))
                t6 = np.arctan2(c6 @ Y, self.x6 @ Y)
                # noflip first: swap the pair where q5 has the "flip" sign
                swap = (np.sin(t5[:N]) * self.noflip_sign) < 0
                for col, first in ((2 * k, True), (2 * k + 1, False)):
                    take_plus = ~swap if first else swap
                    q[:, col, 0], q[:, col, 1], q[:, col, 2] = q1, q2, q3
                    for j, t in ((3, t4), (4, t5), (5, t6)):
                        q[:, col, j] = np.where(take_plus, t[:N], t[N:])
        return q, reach, distance
