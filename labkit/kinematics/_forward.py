"""Forward kinematics and the geometric Jacobian (batched, both DH conventions).

All functions take joint values ``q`` with shape ``(..., n)`` [rad for revolute,
m for prismatic joints] and return arrays with the same leading dimensions.

Implementation note: the chain is evaluated column by column on
structure-of-arrays blocks (each rotation column and the origin stored as a
``(3, m)`` array), in cache-sized chunks. Each joint's cosine and sine are
computed once per chunk, for all joints together on one contiguous block
(through the half-angle tangent, see :mod:`labkit.kinematics._chain`); each DH
step is then a handful of vectorised multiply-adds instead of a batched 4x4
matrix product; an identity base or tool is skipped; and the results go
straight into the output array (written once, or into the caller's ``out``).
A handful of configurations (``N <= SMALL_BATCH``) takes the pure-Python path
of :mod:`labkit.kinematics._forward_small` instead, which skips the array
bookkeeping (same results to ~1e-16).

The Jacobian (with or without the pose) and the position of a bigger batch
run a program compiled once per robot by :mod:`labkit.kinematics._program`:
the same recursion with the robot's constant zeros, ones and signs folded
away, as ufunc calls on ``(m,)`` rows, written straight into the output
(few rows per configuration, or a small output) or through cache-sized
contiguous rows copied out transposed; it gives the walk's results bit for
bit. Below ``PROGRAM_BATCH_PER_CALL`` configurations per program call
the walk, with fewer calls on ``(3, m)`` blocks, is used instead.
"""

from __future__ import annotations

import numpy as np

from labkit.exceptions import OptionError, ShapeError
from labkit.kinematics import _forward_small as _small
from labkit.kinematics import _program
from labkit.kinematics._chain import check_out, half_angle_trig, prepare
from labkit.validation import as_vector

__all__ = ["fk", "fk_position", "fk_frames", "jacobian", "fk_jacobian"]

#: configurations per chunk of the batched kernels (blocks stay in the L2 cache)
_CHUNK = 8192
#: the generic walk's Jacobian scratch grows with n: chunks of _WALK_CHUNK_ENTRIES // n configurations
_WALK_CHUNK_ENTRIES = 12288
#: chunks of the compiled Jacobian programs: _PROGRAM_CHUNK_ENTRIES // n configurations
_PROGRAM_CHUNK_ENTRIES = 49152
#: a program with k calls runs for batches of at least PROGRAM_BATCH_PER_CALL * k configurations
#: (below that the generic walk, with fewer calls on (3, m) blocks, is faster)
PROGRAM_BATCH_PER_CALL = 2
#: at most this many configurations go through the pure-Python path
SMALL_BATCH = 4
#: a program with at most _DIRECT_ROWS output rows writes straight into the output, in chunks of
#: _DIRECT_BATCH configurations; so does one whose whole output has at most _DIRECT_ENTRIES entries
#: (one chunk); bigger outputs go through contiguous rows copied out transposed
_DIRECT_ROWS = 8
_DIRECT_BATCH = 16384
_DIRECT_ENTRIES = 2**18
_E = np.eye(3)[:, :, None]  # the unit columns as (3, 1) blocks
_ZERO = np.zeros((3, 1))


def _trig(c, qc):
    """Cosines and sines of the revolute joints for a chunk ``qc`` (m, n): two (r, m) blocks."""
    m = qc.shape[0]
    h = np.empty((c.revolute.size, m))
    np.multiply((qc if c.all_revolute else qc[:, c.revolute]).T, 0.5, out=h)
    if c.half_theta is not None:
        h += c.half_theta
    np.tan(h, out=h)
    return half_angle_trig(h)


def _comb(x, cx, y, cy):
    """``x * cx + y * cy`` for (3, 1) or (3, m) blocks, with one temporary."""
    r = x * cx
    s = y * cy
    if r.shape[-1] >= s.shape[-1]:
        r += s
        return r
    s += r
    return s


def _rotate_x(c1, c2, ca, sa):
    """Columns 1, 2 after post-multiplying by Rx(alpha)."""
    if sa == 0.0:
        return (c1, c2) if ca == 1.0 else (-c1, -c2)
    if ca == 0.0:
        return (c2, -c1) if sa > 0 else (-c2, c1)
    return _comb(c1, ca, c2, sa), _comb(c2, ca, c1, -sa)


def _walk(c, qc, *, axes=None, frames=False):
    """Run the chain for a chunk ``qc`` of shape (m, n).

    Returns the final ``(c0, c1, c2, p)`` of frame n (before the tool) and,
    with ``frames``, every frame. ``axes``, a pair of (3, n, m) arrays,
    receives each joint's axis direction and a point on it. Blocks are never
    modified once made, so the stored frames stay valid.
    """
    cos, sin = _trig(c, qc)
    if c.base is None:
        c0, c1, c2, p = _E[0], _E[1], _E[2], _ZERO
    else:
        c0, c1, c2, p = (c.base[:3, k, None] for k in range(4))
    all_frames = []
    j = 0
    for i, (rev, a, ca, sa, d, _, cth, sth) in enumerate(c.steps):
        if rev:
            ct, st = cos[j], sin[j]
            j += 1
        else:
            ct, st = cth, sth
            dd = qc[:, i] + d if d != 0.0 else qc[:, i]
        if c.modified:
            c1, c2 = _rotate_x(c1, c2, ca, sa)
            if a != 0.0:
                p = p + a * c0
            if axes is not None:
                axes[0][:, i] = c2
                axes[1][:, i] = p
            c0, c1 = _comb(c0, ct, c1, st), _comb(c1, ct, c0, -st)
            if not rev:
                p = p + c2 * dd
            elif d != 0.0:
                p = p + d * c2
        else:
            if axes is not None:
                axes[0][:, i] = c2
                axes[1][:, i] = p
            n0, n1 = _comb(c0, ct, c1, st), _comb(c1, ct, c0, -st)
            if not rev:
                p = p + c2 * dd
            elif d != 0.0:
                p = p + d * c2
            if a != 0.0:
                p = p + a * n0
            c0 = n0
            c1, c2 = _rotate_x(n1, c2, ca, sa)
        if frames:
            all_frames.append((c0, c1, c2, p))
    return (c0, c1, c2, p), all_frames


def _tool_offset(c, point):
    """Origin of the output frame in frame-n coordinates [m] (None: frame n's origin)."""
    if c.tool is None:
        return point
    return c.tool[:3, 3] if point is None else c.tool[:3, 3] + c.tool[:3, :3] @ point


def _apply_tool(c, c0, c1, c2, p, point=None):
    """The final frame's columns after the tool transform, its origin moved to ``point``."""
    off = _tool_offset(c, point)
    if off is not None:
        p = _lincomb(p, (c0, c1, c2), off)
    if c.tool is not None and not np.array_equal(c.tool[:3, :3], np.eye(3)):
        R = c.tool
        c0, c1, c2 = (_lincomb(None, (c0, c1, c2), R[:3, k]) for k in range(3))
    return c0, c1, c2, p


def _lincomb(p, cols, w):
    """``p + sum_k cols[k] * w[k]`` (``p`` may be None), skipping zero weights."""
    for col, v in zip(cols, w):
        if v != 0.0:
            term = col * v
            p = term if p is None else p + term
    return p if p is not None else np.zeros_like(cols[0])


def _pose_buffer(m):
    """A (16, m) block for m poses, bottom rows ``[0, 0, 0, 1]`` already filled in."""
    W = np.empty((16, m))
    W[12:15] = 0.0
    W[15] = 1.0
    return W


def _write_pose(O, cols):
    """Write a (3, m) column set into rows 0-11 of ``O``, a (16, m) block of (m, 4, 4) poses."""
    for k, col in enumerate(cols):
        O[k:12:4] = col


def _as_point(point):
    """A tool-frame point of shape (3,) or None (validated)."""
    if point is None:
        return None
    pt = as_vector(point, 3, "point")
    if pt.ndim != 1:
        raise ShapeError(f"expected point with shape (3,), got {pt.shape}")
    return pt


def _output(out, shape):
    return np.empty(shape) if out is None else check_out(out, shape)


def fk(robot, q, *, out=None):
    """End-effector pose ``world_from_tool`` for joint values ``q``.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., n)
        Joint values [rad for revolute, m for prismatic joints].
    out : ndarray, shape (..., 4, 4), optional
        C-contiguous float64 array to write the result into (and return).

    Returns
    -------
    T : ndarray, shape (..., 4, 4)
        Homogeneous transforms of the tool frame in the world (base) frame [m].

    Raises
    ------
    ShapeError
        If ``q`` does not end in ``n`` or holds non-finite values, or ``out``
        does not fit.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> arm = Robot.load("arduino_arm_3dof")
    >>> np.round(fk(arm, np.radians([5.0, 0.0, 0.0]))[:3, 3], 4)
    array([0.273 , 0.0239, 0.    ])
    """
    c, q2, lead = prepare(robot, q)
    N = q2.shape[0]
    shape = lead + (4, 4)
    if N <= SMALL_BATCH and out is None:
        return np.array(_small.fk(c, q2.tolist(), _tool_offset(c, None))).reshape(shape)
    res = _output(out, shape)
    flat = res.reshape(N, 16)
    W = _pose_buffer(min(N, _CHUNK))
    for s in range(0, N, _CHUNK):
        qc = q2[s:s + _CHUNK]
        m = qc.shape[0]
        cols, _ = _walk(c, qc)
        _write_pose(W[:, :m], _apply_tool(c, *cols))
        np.copyto(flat[s:s + m], W[:, :m].T)
    return res


def fk_position(robot, q, point=None, *, out=None):
    """End-effector position only (faster than :func:`fk` when orientation is not needed).

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., n)
        Joint values [rad, m].
    point : array_like, shape (3,), optional
        A point given in the tool frame [m]; default the tool-frame origin.
    out : ndarray, shape (..., 3), optional
        C-contiguous float64 array to write the result into (and return).

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
    c, q2, lead = prepare(robot, q)
    off = _tool_offset(c, _as_point(point))
    N = q2.shape[0]
    shape = lead + (3,)
    if N <= SMALL_BATCH and out is None:
        return np.array(_small.position(c, q2.tolist(), off)).reshape(shape)
    res = _output(out, shape)
    flat = res.reshape(N, 3)
    prog = _program.program(c, off, None, None, position_only=True)
    if N >= PROGRAM_BATCH_PER_CALL * len(prog.ops):
        _run_program(c, prog, q2, (flat,))
        return res
    for s in range(0, N, _CHUNK):
        (c0, c1, c2, p), _ = _walk(c, q2[s:s + _CHUNK])
        if off is not None:
            p = _lincomb(p, (c0, c1, c2), off)
        flat[s:s + _CHUNK].T[...] = p
    return res


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
    c, q2, lead = prepare(robot, q)
    N = q2.shape[0]
    n = c.n
    out = np.empty((N, n + 2, 4, 4))
    out[:, 0] = robot.base
    flat = out.reshape(N, n + 2, 16)
    for s in range(0, N, _CHUNK):
        qc = q2[s:s + _CHUNK]
        cols, frames = _walk(c, qc, frames=True)
        for i, fr in enumerate(frames + [_apply_tool(c, *cols)]):
            O = flat[s:s + _CHUNK, i + 1].T
            _write_pose(O, fr)
            O[12:15] = 0.0
            O[15] = 1.0
    return out.reshape(lead + (n + 2, 4, 4))


def _jacobian_chunk(c, qc, pt, frame, W, WJ, axes):
    """Pose (into ``W``, (16, m), unless None) and Jacobian (into ``WJ``, (6n, m)) of a chunk.

    ``axes`` is scratch: two (3, n, m) arrays.
    """
    n, m = c.n, qc.shape[0]
    Z, O = axes[0][:, :, :m], axes[1][:, :, :m]
    V, Wr = WJ[:3 * n].reshape(3, n, m), WJ[3 * n:].reshape(3, n, m)
    (c0, c1, c2, p), _ = _walk(c, qc, axes=(Wr, O))  # axes straight into the angular rows
    t0, t1, t2, pe = _apply_tool(c, c0, c1, c2, p, pt)
    np.subtract(pe[:, None, :], O, out=O)  # lever arms pe - o_i, all joints at once
    for k in range(3):
        k1, k2 = (k + 1) % 3, (k + 2) % 3
        np.multiply(Wr[k1], O[k2], out=V[k])
        np.multiply(Wr[k2], O[k1], out=Z[k])
        V[k] -= Z[k]
    for i, step in enumerate(c.steps):
        if not step[0]:  # prismatic: the axis moves the point, no rotation
            V[:, i] = Wr[:, i]
            Wr[:, i] = 0.0
    if frame == "tool":  # rows of R^T J: tool axis k dotted with the linear and the angular parts
        for part in (V, Wr):
            P = part.copy()
            for k, t in enumerate((t0, t1, t2)):
                np.multiply(P[0], t[0], out=part[k])
                part[k] += P[1] * t[1]
                part[k] += P[2] * t[2]
    if W is not None:
        _write_pose(W, (t0, t1, t2, pe))


def _program_inputs(c, qc, inputs):
    """Fill a program's input rows for a chunk ``qc`` (m, n): cosines, sines, prismatic values."""
    r = c.revolute.size
    h, w = inputs[r:2 * r], inputs[:r]
    np.multiply((qc if c.all_revolute else qc[:, c.revolute]).T, 0.5, out=h)
    if c.half_theta is not None:
        h += c.half_theta
    np.tan(h, out=h)
    half_angle_trig(h, cos_out=w)
    if not c.all_revolute:
        inputs[2 * r:] = qc[:, [i for i, step in enumerate(c.steps) if not step[0]]].T


def _run(bound):
    for f, a, b, o in bound:
        f(a, b, o)


def _jacobian_walk(c, q2, pt, frame, fJ, fT):
    """The generic walk's Jacobian (and pose): (3, m) blocks in chunks, copied out transposed."""
    n, N = c.n, q2.shape[0]
    chunk = max(256, _WALK_CHUNK_ENTRIES // n)
    m = min(N, chunk)
    W = _pose_buffer(m) if fT is not None else None
    WJ = np.empty((6 * n, m))
    axes = np.empty((3, n, m)), np.empty((3, n, m))
    for s in range(0, N, chunk):
        qc = q2[s:s + chunk]
        k = qc.shape[0]
        _jacobian_chunk(c, qc, pt, frame, None if W is None else W[:, :k], WJ[:, :k], axes)
        np.copyto(fJ[s:s + k], WJ[:, :k].T)
        if fT is not None:
            np.copyto(fT[s:s + k], W[:, :k].T)


def _run_program(c, prog, q2, outs):
    """Run a compiled program (:mod:`labkit.kinematics._program`) over ``q2`` (N, n).

    ``outs`` are (N, k) C-contiguous arrays whose columns, side by side, are
    the program's output rows.
    """
    N = q2.shape[0]
    if prog.n_rows <= _DIRECT_ROWS or N * prog.n_rows <= _DIRECT_ENTRIES:
        # the calls write straight into the outputs' (strided) rows: a few rows per configuration
        # in chunks, or one chunk whose output stays in the cache
        m = min(N, _DIRECT_BATCH)
        inputs, scratch = np.empty((prog.n_inputs, m)), np.empty((prog.n_scratch, m))
        for s in range(0, N, m):
            qc = q2[s:s + m]
            k = qc.shape[0]
            if k < m:
                inputs, scratch = inputs[:, :k], scratch[:, :k]
            _program_inputs(c, qc, inputs)
            _run(prog.bind(inputs, [row for o in outs for row in o[s:s + k].T], scratch))
        return
    # chunks: contiguous output rows (the calls stay in the cache), copied out transposed
    chunk = max(256, _PROGRAM_CHUNK_ENTRIES // c.n)
    m = min(N, chunk)
    inputs, rows, scratch = np.empty((prog.n_inputs, m)), np.empty((prog.n_rows, m)), np.empty((prog.n_scratch, m))
    bound = prog.bind(inputs, list(rows), scratch)
    for s in range(0, N, chunk):
        qc = q2[s:s + chunk]
        k = qc.shape[0]
        if k < m:  # the last, shorter chunk
            inputs, rows, scratch = inputs[:, :k], rows[:, :k], scratch[:, :k]
            bound = prog.bind(inputs, list(rows), scratch)
        _program_inputs(c, qc, inputs)
        _run(bound)
        first = 0
        for o in outs:
            np.copyto(o[s:s + k], rows[first:first + o.shape[1]].T)
            first += o.shape[1]


def _jacobian_call(robot, q, point, frame, want_T, out_T, out_J):
    if frame not in ("base", "tool"):
        raise OptionError(f"expected frame 'base' or 'tool', got {frame!r}")
    c, q2, lead = prepare(robot, q)
    pt = _as_point(point)
    off = _tool_offset(c, pt)
    N, n = q2.shape[0], c.n
    if N <= SMALL_BATCH and out_T is None and out_J is None:
        T, J = _small.fk_jacobian(c, q2.tolist(), off, frame == "tool", want_T)
        J = np.array(J).reshape(lead + (6, n))
        if c.flipped.size:  # d/dq_i = -d/dtheta_i for a flipped joint
            J[..., c.flipped] *= -1.0
        return (np.array(T).reshape(lead + (4, 4)) if want_T else None), J
    J = _output(out_J, lead + (6, n))
    T = _output(out_T, lead + (4, 4)) if want_T else None
    fJ = J.reshape(N, 6 * n)
    fT = T.reshape(N, 16) if want_T else None
    prog = _program.program(c, off, frame == "tool", want_T)
    if N < PROGRAM_BATCH_PER_CALL * len(prog.ops):  # few configurations: the walk's fewer, bigger calls win
        _jacobian_walk(c, q2, pt, frame, fJ, fT)
        if c.flipped.size:  # d/dq_i = -d/dtheta_i for a flipped joint
            J[..., c.flipped] *= -1.0
    else:
        _run_program(c, prog, q2, (fJ,) if fT is None else (fJ, fT))  # flipped joints included
    return T, J


def fk_jacobian(robot, q, *, point=None, frame="base", out=None):
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
    out : tuple of ndarray, optional
        ``(T_out, J_out)``, C-contiguous float64 arrays of shapes
        ``(..., 4, 4)`` and ``(..., 6, n)`` to write the results into.

    Returns
    -------
    T : ndarray, shape (..., 4, 4)
        Pose of the tool frame moved to ``point``, in the world (base) frame [m].
    J : ndarray, shape (..., 6, n)
        Rows ``vx, vy, vz, wx, wy, wz``; columns per joint [m/rad or 1].

    Raises
    ------
    ShapeError
        If ``q`` does not end in ``n`` or holds non-finite values, or ``out``
        does not fit.
    OptionError
        If ``frame`` is neither "base" nor "tool".

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> T, J = fk_jacobian(Robot.load("puma560"), np.zeros((10, 6)))
    >>> T.shape, J.shape
    ((10, 4, 4), (10, 6, 6))
    """
    if out is None:
        out_T = out_J = None
    else:
        try:
            out_T, out_J = out
        except (TypeError, ValueError):
            raise ShapeError(f"expected out as a pair (T_out, J_out), got {type(out).__name__}") from None
    return _jacobian_call(robot, q, point, frame, True, out_T, out_J)


def jacobian(robot, q, *, point=None, frame="base", out=None):
    """Geometric Jacobian of a point fixed to the tool frame.

    Maps joint rates to the spatial velocity ``[v; omega]`` of the point:
    ``v`` its linear velocity [m/s] and ``omega`` the angular velocity of the
    tool frame [rad/s]. Poses are not materialised.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., n)
        Joint values [rad, m].
    point : array_like, shape (3,), optional
        Point in tool-frame coordinates [m] (default: tool-frame origin).
    frame : {"base", "tool"}
        Frame the velocity is expressed in.
    out : ndarray, shape (..., 6, n), optional
        C-contiguous float64 array to write the result into (and return).

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
    return _jacobian_call(robot, q, point, frame, False, None, out)[1]
