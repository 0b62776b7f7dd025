"""Forward kinematics and the geometric Jacobian (batched, both DH conventions).

All functions take joint values ``q`` with shape ``(..., n)`` [rad for revolute,
m for prismatic joints] and return arrays with the same leading dimensions.

Implementation note: the chain is evaluated column by column on
structure-of-arrays blocks (each rotation column and the origin stored as a
``(3, N)`` array), in cache-sized chunks. Each DH step is then a handful of
vectorised multiply-adds instead of a batched 4x4 matrix product, which is what
makes batched FK run at millions of configurations per second in pure NumPy.
"""

from __future__ import annotations

import weakref

import numpy as np

from labkit.validation import as_vector
from labkit.robot.types import Convention
from labkit.exceptions import OptionError, ShapeError

__all__ = ["fk", "fk_position", "fk_frames", "jacobian", "fk_jacobian"]

_CHUNK = 8192
#: per-link constants per robot object (a keyed cache: Robot stays plain frozen data)
_PLANS = weakref.WeakKeyDictionary()


def _clean(v):
    """cos/sin of DH constants with exact zeros and ones (cos(pi/2) -> 0)."""
    return 0.0 if abs(v) < 1e-15 else (1.0 if abs(v - 1) < 1e-15 else (-1.0 if abs(v + 1) < 1e-15 else v))


def _plan(robot):
    """Per-link constants of the chain (cached per robot object)."""
    cached = _PLANS.get(robot)
    if cached is not None:
        return cached
    steps = []
    for lk in robot.links:
        steps.append(
            (
                lk.is_revolute,
                float(lk.a),
                _clean(np.cos(lk.alpha)),
                _clean(np.sin(lk.alpha)),
                float(lk.d),
                float(lk.theta),
            )
        )
    plan = (robot.convention is Convention.MODIFIED, tuple(steps))
    _PLANS[robot] = plan
    return plan


def _rotate_x(c1, c2, ca, sa):
    """Columns 1, 2 after post-multiplying by Rx(alpha)."""
    if sa == 0.0:
        if ca == 1.0:
            return c1, c2
        return -c1, -c2
    if ca == 0.0:
        return (c2, -c1) if sa > 0 else (-c2, c1)
    return ca * c1 + sa * c2, ca * c2 - sa * c1


def _walk(robot, q, *, axes=False, frames=False):
    """Run the chain for ``q`` of shape (N, n).

    Returns the final ``(c0, c1, c2, p)`` of frame n (before the tool), and
    optionally the joint axes/origins ``[(z_i, o_i)]`` and every frame.
    """
    modified, steps = _plan(robot)
    B = robot.base
    c0, c1, c2, p = (B[:3, k, None] for k in range(4))
    joint_axes = []
    all_frames = []
    for i, (rev, a, ca, sa, d, th) in enumerate(steps):
        qi = q[:, i]
        if rev:
            ang = qi + th if th != 0.0 else qi
            ct, st = np.cos(ang), np.sin(ang)
        else:
            ct, st = _clean(np.cos(th)), _clean(np.sin(th))
            dd = qi + d if d != 0.0 else qi
        if modified:
            c1, c2 = _rotate_x(c1, c2, ca, sa)
            if a != 0.0:
                p = p + a * c0
            if axes:
                joint_axes.append((c2, p))
            n0 = c0 * ct + c1 * st
            c1 = c1 * ct - c0 * st
            c0 = n0
            if rev:
                if d != 0.0:
                    p = p + d * c2
            else:
                p = p + c2 * dd
        else:
            if axes:
                joint_axes.append((c2, p))
            n0 = c0 * ct + c1 * st
            n1 = c1 * ct - c0 * st
            if rev:
                if d != 0.0:
                    p = p + d * c2
            else:
                p = p + c2 * dd
            if a != 0.0:
                p = p + a * n0
            c0 = n0
            c1, c2 = _rotate_x(n1, c2, ca, sa)
        if frames:
            all_frames.append((c0, c1, c2, p))
    return (c0, c1, c2, p), joint_axes, all_frames


def _apply_tool(robot, c0, c1, c2, p, point=None):
    T = robot.tool
    cols = []
    for k in range(3):
        t = T[:3, k]
        cols.append(c0 * t[0] + c1 * t[1] + c2 * t[2])
    t = T[:3, 3] if point is None else T[:3, 3] + T[:3, :3] @ point
    p = p + c0 * t[0] + c1 * t[1] + c2 * t[2]
    return cols[0], cols[1], cols[2], p


def _assemble(cols, N):
    """(3, N) columns -> (N, 4, 4) homogeneous transforms."""
    out = np.zeros((N, 4, 4))
    for k, c in enumerate(cols):
        out[:, :3, k] = np.broadcast_to(c, (3, N)).T
    out[:, 3, 3] = 1.0
    return out


def _as_point(point):
    """A tool-frame point of shape (3,) or None (validated)."""
    if point is None:
        return None
    pt = as_vector(point, 3, "point")
    if pt.ndim != 1:
        raise ShapeError(f"expected point with shape (3,), got {pt.shape}")
    return pt


def _flipped(robot):
    """Indices of the joints whose variable enters the chain negated (``Link.flip``)."""
    return [i for i, lk in enumerate(robot.links) if lk.flip]


def _prepare(robot, q):
    """Validated ``q`` as (N, n) in the chain's sense (flipped joints negated), and the leading shape."""
    q = as_vector(q, robot.n, "q")
    lead = q.shape[:-1]
    q = q.reshape(-1, robot.n)
    flipped = _flipped(robot)
    if flipped:  # the one place q enters the chain: theta_i = -q_i + theta (d_i = -q_i + d)
        q = q.copy()
        q[:, flipped] *= -1.0
    return q, lead


def fk(robot, q):
    """End-effector pose ``world_from_tool`` for joint values ``q``.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., n)
        Joint values [rad for revolute, m for prismatic joints].

    Returns
    -------
    T : ndarray, shape (..., 4, 4)
        Homogeneous transforms of the tool frame in the world (base) frame [m].

    Raises
    ------
    ShapeError
        If ``q`` does not end in ``n`` or holds non-finite values.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> arm = Robot.load("arduino_arm_3dof")
    >>> np.round(fk(arm, np.radians([5.0, 0.0, 0.0]))[:3, 3], 4)
    array([0.273 , 0.0239, 0.    ])
    """
    q2, lead = _prepare(robot, q)
    N = q2.shape[0]
    out = np.empty((N, 4, 4))
    for s in range(0, N, _CHUNK):
        qc = q2[s:s + _CHUNK]
        (c0, c1, c2, p), _, _ = _walk(robot, qc)
        cols = _apply_tool(robot, c0, c1, c2, p)
        out[s:s + _CHUNK] = _assemble(cols, qc.shape[0])
    return out.reshape(lead + (4, 4))


def fk_position(robot, q, point=None):
    """End-effector position only (faster than :func:`fk` when orientation is not needed).

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., n)
        Joint values [rad, m].
    point : array_like, shape (3,), optional
        A point given in the tool frame [m]; default the tool-frame origin.

    Returns
    -------
    p : ndarray, shape (..., 3)
        Position in the world frame [m].

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> np.round(fk_position(Robot.load("planar3r_seed004"), [0.0, 0.0, np.pi / 2]), 3)
    array([0.35, 0.12, 0.  ])
    """
    q2, lead = _prepare(robot, q)
    pt = _as_point(point)
    N = q2.shape[0]
    out = np.empty((N, 3))
    for s in range(0, N, _CHUNK):
        (c0, c1, c2, p), _, _ = _walk(robot, q2[s:s + _CHUNK])
        T = robot.tool
        t = T[:3, 3] if pt is None else T[:3, 3] + T[:3, :3] @ pt
        p = p + c0 * t[0] + c1 * t[1] + c2 * t[2]
        out[s:s + _CHUNK] = np.broadcast_to(p, (3, min(_CHUNK, N - s))).T
    return out.reshape(lead + (3,))


def fk_frames(robot, q):
    """Every frame of the chain: base, frames 1..n, and the tool.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., n)
        Joint values [rad, m].

    Returns
    -------
    T : ndarray, shape (..., n + 2, 4, 4)
        ``T[..., 0]`` is the base (frame 0), ``T[..., i]`` frame i, and
        ``T[..., n + 1]`` the tool frame, all in world coordinates [m].

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> fk_frames(Robot.load("puma560"), np.zeros(6)).shape
    (8, 4, 4)
    """
    q2, lead = _prepare(robot, q)
    N = q2.shape[0]
    n = robot.n
    out = np.empty((N, n + 2, 4, 4))
    B = robot.base
    out[:, 0] = B
    for s in range(0, N, _CHUNK):
        qc = q2[s:s + _CHUNK]
        m = qc.shape[0]
        (c0, c1, c2, p), _, frames = _walk(robot, qc, frames=True)
        for i, cols in enumerate(frames):
            out[s:s + m, i + 1] = _assemble(cols, m)
        out[s:s + m, n + 1] = _assemble(_apply_tool(robot, c0, c1, c2, p), m)
    return out.reshape(lead + (n + 2, 4, 4))


def _cross(a, b):
    return np.stack(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def _jacobian_chunk(robot, qc, point, frame):
    m = qc.shape[0]
    (c0, c1, c2, p), joint_axes, _ = _walk(robot, qc, axes=True)
    t0, t1, t2, pe = _apply_tool(robot, c0, c1, c2, p, point)
    J = np.zeros((m, 6, robot.n))
    for i, ((z, o), lk) in enumerate(zip(joint_axes, robot.links)):
        z = np.broadcast_to(z, (3, m))
        if lk.is_revolute:
            J[:, :3, i] = _cross(z, pe - o).T
            J[:, 3:, i] = z.T
        else:
            J[:, :3, i] = z.T
    T = _assemble((t0, t1, t2, pe), m)
    if frame == "tool":
        Rt = np.swapaxes(T[:, :3, :3], -1, -2)
        J[:, :3] = Rt @ J[:, :3]
        J[:, 3:] = Rt @ J[:, 3:]
    return T, J


def fk_jacobian(robot, q, *, point=None, frame="base"):
    """Pose and geometric Jacobian together (one pass over the chain).

    Same results as :func:`fk` and :func:`jacobian`, cheaper than calling both.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., n)
        Joint values [rad for revolute, m for prismatic joints].
    point : array_like, shape (3,), optional
        Point in tool-frame coordinates [m] (default: tool-frame origin); ``J``
        maps to its velocity and ``T`` has it as origin (tool orientation).
    frame : {"base", "tool"}
        Frame the velocity is expressed in.

    Returns
    -------
    T : ndarray, shape (..., 4, 4)
        Pose of the tool frame moved to ``point``, in the world (base) frame [m].
    J : ndarray, shape (..., 6, n)
        Rows ``vx, vy, vz, wx, wy, wz``; columns per joint [m/rad or 1].

    Raises
    ------
    ShapeError
        If ``q`` does not end in ``n`` or holds non-finite values.
    ValueError
        If ``frame`` is neither "base" nor "tool".
    """
    if frame not in ("base", "tool"):
        raise OptionError(f"expected frame 'base' or 'tool', got {frame!r}")
    q2, lead = _prepare(robot, q)
    pt = _as_point(point)
    N = q2.shape[0]
    T = np.empty((N, 4, 4))
    J = np.empty((N, 6, robot.n))
    for s in range(0, N, _CHUNK):
        T[s:s + _CHUNK], J[s:s + _CHUNK] = _jacobian_chunk(robot, q2[s:s + _CHUNK], pt, frame)
    flipped = _flipped(robot)
    if flipped:  # d/dq_i = -d/dtheta_i for a flipped joint
        J[:, :, flipped] *= -1.0
    return T.reshape(lead + (4, 4)), J.reshape(lead + (6, robot.n))


def jacobian(robot, q, *, point=None, frame="base"):
    """Geometric Jacobian of a point fixed to the tool frame.

    Maps joint rates to the spatial velocity ``[v; omega]`` of the point:
    ``v`` its linear velocity [m/s] and ``omega`` the angular velocity of the
    tool frame [rad/s].

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., n)
        Joint values [rad, m].
    point : array_like, shape (3,), optional
        Point in tool-frame coordinates [m] (default: tool-frame origin).
    frame : {"base", "tool"}
        Frame the velocity is expressed in.

    Returns
    -------
    J : ndarray, shape (..., 6, n)
        Rows ``vx, vy, vz, wx, wy, wz``; columns per joint [m/rad or 1].

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> rpp = Robot.load("rpp_seed002")
    >>> np.round(jacobian(rpp, [0.0, 1.0, 1.0], point=None), 6)[:, 0]
    array([0., 1., 0., 0., 0., 1.])
    """
    return fk_jacobian(robot, q, point=point, frame=frame)[1]
