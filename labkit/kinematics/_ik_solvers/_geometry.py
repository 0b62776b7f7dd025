"""Geometry shared by the closed-form families, each formula once (private).

* the joint axes of a robot at ``q = 0`` (:func:`joint_axes`), from the one DH walk
  (:func:`labkit.kinematics._program.walk`) on floats, so every family works in the world frame
  for either DH convention, base and tool included;
* the cosine law of a two-link chain (:class:`_CosineLaw`);
* Paden-Kahan subproblem 1, the angle about an axis taking one vector onto
  another (:func:`_angle_about`), and subproblem 2, two rotations about
  intersecting axes (:class:`_Subproblem2`);
* Rodrigues' rotation of vectors about a constant axis (:func:`_rotate`).

Vectors are 3-tuples of components, each an ``(N,)`` array (a batch of
targets); constant vectors (axes of the robot) are tuples of floats.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.kinematics._ik_solvers._elementwise import arctan2, clip, cos, maximum, sin, sqrt
from labkit.kinematics._chain import chain
from labkit.kinematics._program import PLAIN, walk

#: geometric tolerance of the structure tests [m or rad]
TOL = 1e-9
#: slack on cosine-law arguments
REACH_TOL = 1e-12


class NotThisFamily(Exception):
    """The robot does not have the structure a family needs (the reason in args)."""


def _unit(v):
    """``v`` (3,) divided by its norm, as a float array."""
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _floats(v):
    """A constant vector as a tuple of Python floats."""
    return tuple(float(x) for x in v)


def _perpendicular(axis):
    """A unit vector (3,) perpendicular to the unit ``axis``, from the world axis least along it (components
    within :data:`TOL` count as equal, the first wins: an axis along world ``z`` gives world ``x``)."""
    a = np.abs(axis)
    t = np.eye(3)[int(np.flatnonzero(a <= a.min() + TOL)[0])]
    return _unit(t - axis * (t @ axis))


def _feet(p1, d1, p2, d2):
    """The closest points [m] on two non-parallel lines (point ``p`` [m], unit direction ``d`` each)."""
    w = p1 - p2
    b = d1 @ d2
    den = 1.0 - b * b
    t1 = (b * (d2 @ w) - (d1 @ w)) / den
    t2 = ((d2 @ w) - b * (d1 @ w)) / den
    return p1 + t1 * d1, p2 + t2 * d2


def joint_axes(robot):
    """Joint axes, a point on each and the tool frame at ``q = 0``, in the world frame.

    Read by the one DH walk on floats (nothing is compiled for a robot's geometry).

    Parameters
    ----------
    robot : Robot

    Returns
    -------
    z, o, tool : ndarray, shape (n, 3), (n, 3), (4, 4)
        Unit axis directions, a point on each [m], ``world_from_tool`` [m].
    """
    c = chain(robot)
    revolute = [(cth, sth) for rev, _, _, _, _, _, cth, sth in c.steps if rev]
    steps = [(rev, a, ca, sa, d, cth, sth) for rev, a, ca, sa, d, _, cth, sth in c.steps]
    base = tuple(tuple(float(x) for x in robot.base[:3, k]) for k in range(4))
    frames, _ = walk(PLAIN, c.modified, base, steps, revolute.__getitem__, lambda i, d: d)
    frames = np.array([base, *frames], dtype=float)  # frames 0..n, columns (x, y, z, origin) each
    axes = frames[1:] if c.modified else frames[:-1]  # joint i's axis: z of frame i (modified DH), else i - 1
    last = np.eye(4)
    last[:3] = frames[-1].T
    return axes[:, 2].copy(), axes[:, 3].copy(), last @ robot.tool


def _length_scale(robot):
    """The length structure tolerances scale with: sum of ``|a|``, ``|d|`` and tool offset, at least 1 [m]."""
    return max(1.0, float(np.abs(robot.a).sum() + np.abs(robot.d).sum() + np.abs(robot.tool[:3, 3]).sum()))


def _need_joints(robot, n, prismatic=0):
    """Raise :class:`NotThisFamily` unless ``robot`` has ``n`` joints, ``prismatic`` of them prismatic."""
    if robot.n != n or int(np.count_nonzero(~robot.is_revolute)) != prismatic:
        raise NotThisFamily(f"needs exactly {n} joints, {prismatic} of them prismatic" if prismatic
                            else f"needs exactly {n} revolute joints")


def _need_parallel(u, v, reason):
    """Raise :class:`NotThisFamily` with ``reason`` unless the unit vectors ``u``, ``v`` (3,) are parallel."""
    if np.linalg.norm(np.cross(u, v)) > TOL:
        raise NotThisFamily(reason)


def _wrist_branches(shoulder, elbow=("up", "down")):
    """Branch names ``<shoulder>_<elbow>_<noflip|flip>`` (shoulder slowest) and their aliases (``"run"``)."""
    names = [(s, e, w) for s in shoulder for e in elbow for w in ("noflip", "flip")]
    return tuple(f"{s}_{e}_{w}" for s, e, w in names), {f"{s[0]}{e[0]}{w[0]}": f"{s}_{e}_{w}" for s, e, w in names}


def _in_chain_order(order, values):
    """Values of the joints ``order`` (indices, a permutation) as a tuple in the chain's order."""
    q = [None] * len(order)
    for j, v in zip(order, values):
        q[j] = v
    return tuple(q)


def _pose_matrices(R, p):
    """Homogeneous transforms (..., 4, 4) from rotations (..., 3, 3) and translations ``p`` (..., 3) [m]."""
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = p
    T[..., 3, 3] = 1.0
    return T


# -- vectors as component tuples ------------------------------------------------------------

def _dot(a, b):
    """``a . b`` of component 3-tuples (arrays or floats)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    """``a x b`` of component 3-tuples."""
    a0, a1, a2 = a
    b0, b1, b2 = b
    return (a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0)


def _reject(k, v):
    """The part of ``v`` perpendicular to the unit vector ``k``."""
    s = k[0] * v[0] + k[1] * v[1] + k[2] * v[2]
    return (v[0] - k[0] * s, v[1] - k[1] * s, v[2] - k[2] * s)


def _rotate(k, angle, *vectors):
    """Rodrigues: ``vectors`` (component 3-tuples) turned by ``angle`` [rad] about the unit axis ``k``,
    ``v + sin(a) k x v + (1 - cos(a)) k x (k x v)``, as a list."""
    k0, k1, k2 = k
    s, c1 = sin(angle), 1.0 - cos(angle)
    out = []
    for v0, v1, v2 in vectors:
        u0, u1, u2 = k1 * v2 - k2 * v1, k2 * v0 - k0 * v2, k0 * v1 - k1 * v0
        w0, w1, w2 = k1 * u2 - k2 * u1, k2 * u0 - k0 * u2, k0 * u1 - k1 * u0
        out.append((v0 + s * u0 + c1 * w0, v1 + s * u1 + c1 * w1, v2 + s * u2 + c1 * w2))
    return out


def _matvec(M, v):
    """``M v`` for a 3 x 3 ``M`` given as rows of component 3-tuples (three :func:`_dot` in one call)."""
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = M
    v0, v1, v2 = v
    return (m00 * v0 + m01 * v1 + m02 * v2, m10 * v0 + m11 * v1 + m12 * v2, m20 * v0 + m21 * v1 + m22 * v2)


# -- the shared subproblems -----------------------------------------------------------------

class _CosineLaw:
    """A two-link chain in a plane: link 1 (joint 1 to joint 2) and link 2 (to the point placed) as in-plane
    ``(x, y)`` vectors ``e``, ``f`` at ``q = 0`` [m]; :class:`NotThisFamily` with ``reason`` where a link is
    shorter than ``shortest`` [m]."""

    def __init__(self, e, f, shortest, reason):
        self.L1, self.L2 = L1, L2 = math.hypot(*e), math.hypot(*f)
        if L1 < shortest or L2 < shortest:
            raise NotThisFamily(reason)
        self.g1 = math.atan2(e[1], e[0])  # link 1's angle, and link 2's relative to it, at q = 0
        self.g21 = math.atan2(f[1], f[0]) - self.g1
        self.L1L1, self.L2L2, self.den = L1 * L1, L2 * L2, 2 * L1 * L2
        self.longest, self.shortest = L1 + L2, abs(L1 - L2)
        self.ok_below = 1.0 + REACH_TOL

    def solve(self, x, y):
        """The chain reaching the point ``(x, y)`` [m] from joint 1: ``reachable`` (the cosine-law argument
        in [-1, 1], slack :data:`REACH_TOL`), ``distance`` outside the annulus reached [m], and [rad] the
        ``elbow`` (magnitude of link 2's relative angle, argument clipped), the ``shoulder`` angle between
        the line to the point and link 1, and the point's ``direction``. The branch of sign ``s = -1, +1``
        has link 1 at ``direction - s shoulder`` and link 2 at ``s elbow`` relative to it."""
        L1, L2 = self.L1, self.L2
        r2 = x * x + y * y
        r = sqrt(r2)
        cb = (r2 - self.L1L1 - self.L2L2) / self.den
        ok = abs(cb) <= self.ok_below
        distance = maximum(maximum(r - self.longest, self.shortest - r), 0.0)
        cb = clip(cb, -1.0, 1.0)
        sb = sqrt(1.0 - cb * cb)
        return ok, distance, arctan2(sb, cb), arctan2(L2 * sb, L1 + L2 * cb), arctan2(y, x)

    def branches(self, x, y):
        """``reachable``, ``distance`` (as :meth:`solve`) and ``[(q1, q2) elbow up, (q1, q2) elbow down]``
        [rad] reaching ``(x, y)`` [m], turned from the links at ``q = 0`` (elbow up: link 2 turned negatively)."""
        ok, distance, elbow, shoulder, direction = self.solve(x, y)
        return ok, distance, [(direction - s * shoulder - self.g1, s * elbow - self.g21) for s in (-1.0, 1.0)]


def _angle_about(k, v, w):
    """Paden-Kahan subproblem 1: the angle in (-pi, pi] about the constant unit axis ``k`` turning ``v`` onto
    ``w`` (component 3-tuples), both projected perpendicular to ``k`` first (precise where that is tiny)."""
    vp, wp = _reject(k, v), _reject(k, w)
    return _angle_between(_cross(k, vp), vp, wp)


def _angle_between(n, vp, wp):
    """:func:`_angle_about` [rad] from the parts ``vp``, ``wp`` perpendicular to ``k`` and ``n = k x vp``."""
    w0, w1, w2 = wp
    return arctan2(n[0] * w0 + n[1] * w1 + n[2] * w2, vp[0] * w0 + vp[1] * w1 + vp[2] * w2)


class _Subproblem2:
    """Paden-Kahan subproblem 2, ``Rot(a4, t4) Rot(a5, t5) p = m``, for unit axes ``a4``, ``a5`` (3,) meeting in
    a point and a unit vector ``p`` (3,)."""

    def __init__(self, a4, a5, p):
        self.a4, self.a5, self.p = _floats(a4), _floats(a5), _floats(p)
        self.k12, self.a5p = float(np.dot(a4, a5)), float(np.dot(a5, p))
        self.cr = _floats(np.cross(a4, a5))
        self.cr2 = float(np.dot(self.cr, self.cr))
        self.c5 = _floats(np.cross(a5, p))
        self.orthogonal = abs(self.k12) < 1e-12
        self.den = self.k12 * self.k12 - 1.0
        self.k12a5p = self.k12 * self.a5p

    def solve(self, m):
        """Both solutions ``[(t4, t5) with +gamma, (t4, t5) with -gamma]`` [rad] for the unit direction ``m``."""
        (a40, a41, a42), (a50, a51, a52), (c0, c1, c2) = self.a4, self.a5, self.cr
        k12, a5p, den = self.k12, self.a5p, self.den
        m0, m1, m2 = m
        a4m = a40 * m0 + a41 * m1 + a42 * m2
        alpha = (self.k12a5p - a4m) / den
        beta = (k12 * a4m - a5p) / den
        # subproblem 1 about a4 below works on the explicit perpendicular parts (near the wrist
        # singularity they are tiny, and c.m - (a4.c)(a4.m) would cancel catastrophically)
        mp = (m0 - a40 * a4m, m1 - a41 * a4m, m2 - a42 * a4m)
        if self.orthogonal:
            # |a4 x c| = |a4 x m| = sqrt(beta^2 + gamma^2): accurate near the wrist singularity,
            # where 1 - alpha^2 - beta^2 would lose half the digits
            s45 = sqrt(_dot(mp, mp))
            b = abs(beta)
            g = sqrt(maximum((s45 - b) * (s45 + b), 0.0))
        else:
            g = sqrt(maximum((1.0 - alpha * alpha - beta * beta - 2 * alpha * beta * k12) / self.cr2, 0.0))
        # C = alpha a4 + beta a5 +- g (a4 x a5)
        b0, b1, b2 = alpha * a40 + beta * a50, alpha * a41 + beta * a51, alpha * a42 + beta * a52
        g0, g1, g2 = g * c0, g * c1, g * c2
        (d0, d1, d2), (p0, p1, p2) = self.c5, self.p
        out = []
        for C0, C1, C2 in ((b0 + g0, b1 + g1, b2 + g2), (b0 - g0, b1 - g1, b2 - g2)):
            t5 = arctan2(d0 * C0 + d1 * C1 + d2 * C2, (p0 * C0 + p1 * C1 + p2 * C2)
                            - a5p * (a50 * C0 + a51 * C1 + a52 * C2))
            # t4: subproblem 1 about a4 from C's part perpendicular to a4 (v) to m's
            a4C = a40 * C0 + a41 * C1 + a42 * C2
            v0, v1, v2 = C0 - a40 * a4C, C1 - a41 * a4C, C2 - a42 * a4C
            n = (a41 * v2 - a42 * v1, a42 * v0 - a40 * v2, a40 * v1 - a41 * v0)  # a4 x v
            out.append((_angle_between(n, (v0, v1, v2), mp), t5))
        return out


def _per_branch(f, branches, shared):
    """``f(*branch, *shared)`` of every branch in one call, on the branches' ``(N,)`` rows end to end."""
    k = len(branches)
    n = max((np.size(v) for v in (*branches[0], *shared) if type(v) is not float), default=1)
    if n == 1:  # one target: branch by branch on floats (cheaper than numpy rows of k elements)
        return [f(*(float(v) for v in (*branch, *shared))) for branch in branches]
    args = np.empty((len(branches[0]) + len(shared), k, n))
    for j, branch in enumerate(branches):
        for i, v in enumerate((*branch, *shared)):
            args[i, j] = v
    out = f(*args.reshape(len(args), k * n))
    return [tuple(o[j * n:(j + 1) * n] for o in out) for j in range(k)]


def _rotation_matrices(axis, angle):
    """Rotation matrices (N, 3, 3) about a constant unit axis (3,) by ``angle`` (N,) [rad]."""
    x, y, z = axis
    c, s = np.cos(angle), np.sin(angle)
    C = 1.0 - c
    R = np.empty(np.shape(angle) + (3, 3))
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
