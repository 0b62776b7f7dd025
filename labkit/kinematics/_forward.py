"""Forward kinematics and the geometric Jacobian (batched, both DH conventions).

All functions take joint values ``q`` with shape ``(..., n)`` [rad for revolute,
m for prismatic joints] and return arrays with the same leading dimensions.

Implementation note: every function here evaluates a program compiled once
per robot structure and output by :mod:`labkit.kinematics._program` from the
one DH recursion (:func:`labkit.kinematics._program.walk`), with the robot's
constant zeros, ones and signs folded away. A batch runs the program as ufunc
calls on ``(m,)`` rows, written straight into the output (few rows per
configuration, or a small output) or through cache-sized contiguous rows
copied out transposed; a handful of configurations (``N <= SMALL_BATCH``) runs
the same program as generated Python code on floats, which skips numpy's
per-call overhead.

Joint angles enter through the half-angle tangent ``t = tan(theta / 2)``:
``cos theta = 2 / (1 + t^2) - 1`` and ``sin theta = t * 2 / (1 + t^2)``. One
``tan`` per joint instead of a ``sin`` and a ``cos``: NumPy evaluates float64
``tan`` with SIMD but ``sin``/``cos`` one element at a time on AVX2 machines,
so this is about 5x cheaper, and it agrees with ``sin``/``cos`` to a few
units in the last place (the programs' Python code uses the same formula).
"""

from __future__ import annotations

import math

import numpy as np

from labkit.exceptions import OptionError, ShapeError
from labkit.kinematics import _program
from labkit.kinematics._chain import chain, prepare, _varied
from labkit.validation import as_vector

__all__ = ["fk", "fk_position", "fk_position_with", "fk_frames", "fk_frames_with", "jacobian", "fk_jacobian"]

#: chunks of the compiled programs with many output rows: _PROGRAM_CHUNK_ENTRIES // n configurations
_PROGRAM_CHUNK_ENTRIES = 49152
#: at most this many configurations run the program's Python code on floats (the crossover with the
#: ufunc calls is at about 20 configurations for the PUMA 560)
SMALL_BATCH = 16
#: a program with at most _DIRECT_ROWS output rows writes straight into the output, in chunks of
#: _DIRECT_BATCH configurations; so does one whose whole output has at most _DIRECT_ENTRIES entries
#: (one chunk); bigger outputs go through contiguous rows copied out transposed
_DIRECT_ROWS = 8
_DIRECT_BATCH = 16384
_DIRECT_ENTRIES = 2**18


def _tool_offset(c, point):
    """Origin of the output frame in frame-n coordinates [m] (None: frame n's origin)."""
    if c.tool is None:
        return point
    return c.tool[:3, 3] if point is None else c.tool[:3, 3] + c.tool[:3, :3] @ point


def _as_point(point, length=3, name="point"):
    """A vector of shape (length,) (a tool-frame point by default) or None (validated)."""
    if point is None:
        return None
    pt = as_vector(point, length, name)
    if pt.ndim != 1:
        raise ShapeError(f"expected {name} with shape ({length},), got {pt.shape}")
    return pt


def _output(out, shape):
    """A new array of ``shape``, or the caller's ``out`` checked (float64, C-contiguous, writeable, shaped)."""
    if out is None:
        return np.empty(shape)
    if not isinstance(out, np.ndarray) or out.dtype != np.float64 or not out.flags.c_contiguous \
            or not out.flags.writeable or out.shape != tuple(shape):
        got = f"{type(out).__name__} {getattr(out, 'dtype', '')} {getattr(out, 'shape', '')}".strip()
        raise ShapeError(f"expected out as a writeable C-contiguous float64 array of shape {tuple(shape)}, "
                         f"got {got}")
    return out


def _result(c, prog, q2, shape, out=None):
    """The single output of a program over ``q2`` (N, n), as an array of ``shape`` (into ``out`` if given)."""
    if out is None and q2.shape[0] <= SMALL_BATCH:
        return _small(prog, q2).reshape(shape)
    res = _output(out, shape)
    _evaluate(c, prog, q2, (res.reshape(q2.shape[0], prog.n_rows),))
    return res


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
    return _result(c, _point_program(c, _program.POSE), q2, lead + (4, 4), out)


def fk_position(robot, q, point=None, *, out=None):
    """End-effector position only (faster than :func:`fk` when orientation is not needed).

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., n)
        Joint values [rad, m], one configuration or a batch.
    point : array_like, shape (3,), optional
        A point given in the tool frame [m]; default the tool-frame origin
        (the position of a marker or a fingertip, for instance).
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
    return _position(*prepare(robot, q), point, out)


def _position(c, q2, lead, point, out):
    return _result(c, _point_program(c, _program.POSITION, point), q2, lead + (3,), out)


def fk_position_with(robot, q, *, theta=None, a=None, d=None, base_position=None, tool_position=None):
    """Tool position of ``robot`` with some of its numbers replaced, without building that robot.

    The model a calibration fits: :func:`fk_position` of the robot with these
    DH columns and base and tool translations, the same numbers bit for bit,
    for a fraction of the cost of building that robot (the numbers are inputs
    of the programs of the robot's structure).

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., n)
        Joint values [rad, m].
    theta, a, d : array_like, shape (n,), optional
        DH columns to use instead of the robot's [rad, m].
    base_position, tool_position : array_like, shape (3,), optional
        Translation of the ``base`` (world from frame 0) and ``tool`` (frame n
        from tool) transforms to use instead of the robot's [m].

    Returns
    -------
    p : ndarray, shape (..., 3)
        Position of the tool in the world frame [m].

    Raises
    ------
    ShapeError
        If ``q`` does not end in ``n``, or a column or translation has another shape or a non-finite value.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> arm = Robot.load("arduino_arm_3dof")
    >>> longer = arm.with_link(2, a=arm.links[2].a + 0.01)
    >>> q = [0.1, 0.2, 0.3]
    >>> bool(np.array_equal(fk_position_with(arm, q, a=longer.a), fk_position(longer, q)))
    True
    """
    return _position(*prepare(robot, q, _varied_chain(robot, theta, a, d, base_position, tool_position)), None, None)


def _varied_chain(robot, theta, a, d, base_position, tool_position):
    """The robot's chain with the given DH columns and base and tool translations (validated; None: keep)."""
    c = chain(robot)
    columns = {}
    for name, v, length in (("theta", theta, c.n), ("a", a, c.n), ("d", d, c.n), ("base_position", base_position, 3),
                            ("tool_position", tool_position, 3)):
        if v is not None and not (type(v) is list and len(v) == length  # (a list of finite floats as it is)
                                  and all(type(x) is float and math.isfinite(x) for x in v)):
            v = _as_point(v, length, name).tolist()
        columns[name] = v
    return _varied(c, **columns)


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
    return _frames(*prepare(robot, q))


def fk_frames_with(robot, q, *, theta=None, a=None, d=None, base_position=None, tool_position=None):
    """Every frame of ``robot`` with some of its numbers replaced, without building that robot.

    :func:`fk_frames` of the robot with these DH columns and base and tool
    translations, as :func:`fk_position_with` gives its tool position (the
    frames a calibration's parameter derivatives are read from).

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., n)
        Joint values [rad, m].
    theta, a, d, base_position, tool_position : array_like, optional
        As :func:`fk_position_with` [rad, m].

    Returns
    -------
    T : ndarray, shape (..., n + 2, 4, 4)
        Base (frame 0), frames 1..n and the tool frame in world coordinates [m].

    Raises
    ------
    ShapeError
        If ``q`` does not end in ``n``, or a column or translation has another shape or a non-finite value.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> arm = Robot.load("arduino_arm_3dof")
    >>> longer = arm.with_link(2, a=arm.links[2].a + 0.01)
    >>> bool(np.array_equal(fk_frames_with(arm, [0.1, 0.2, 0.3], a=longer.a), fk_frames(longer, [0.1, 0.2, 0.3])))
    True
    """
    return _frames(*prepare(robot, q, _varied_chain(robot, theta, a, d, base_position, tool_position)))


def _frames(c, q2, lead):
    return _result(c, _point_program(c, _program.FRAMES), q2, lead + (c.n + 2, 4, 4))


def _program_inputs(c, qc, inputs):
    """Fill a program's input rows for a chunk ``qc`` (m, n): cosines, sines, prismatic values."""
    r = c.revolute.size
    t, w = inputs[r:2 * r], inputs[:r]  # the sines and the cosines from the half-angle tangents, in place
    np.multiply((qc if c.all_revolute else qc[:, c.revolute]).T, 0.5, out=t)
    if c.half_theta is not None:
        t += c.half_theta
    np.tan(t, out=t)
    np.multiply(t, t, out=w)
    w += 1.0
    np.divide(2.0, w, out=w)
    t *= w
    w -= 1.0
    if not c.all_revolute:
        inputs[2 * r:] = qc[:, [i for i, step in enumerate(c.steps) if not step[0]]].T


def _run(bound):
    for f, a, b, o in bound:
        f(a, b, o)


def _small(prog, q2):
    """The outputs (N, n_rows) of a few configurations ``q2`` (N, n) from the program's Python code."""
    if not len(q2):  # (an empty batch)
        return np.empty((0, prog.n_rows))
    f = prog.scalar()
    return np.array([f(x) for x in q2.tolist()])


def _copy_out(outs, s, rows):
    """Copy output rows (n_rows, k) into configurations ``s .. s + k`` of ``outs`` (columns side by side)."""
    first = 0
    for o in outs:
        np.copyto(o[s:s + rows.shape[1]], rows[first:first + o.shape[1]].T)
        first += o.shape[1]


def _evaluate(c, prog, q2, outs):
    """Run a compiled program over ``q2`` (N, n) into ``outs``, (N, k) C-contiguous arrays whose columns, side by
    side, are its output rows: the Python code on floats for a few configurations, else the ufunc calls."""
    N = q2.shape[0]
    if N <= SMALL_BATCH:
        _copy_out(outs, 0, _small(prog, q2).T)
        return
    # the calls write straight into the outputs' (strided) rows: a few rows per configuration in chunks,
    # or one chunk whose output stays in the cache; else into contiguous rows (the calls stay in the cache),
    # copied out transposed
    direct = prog.n_rows <= _DIRECT_ROWS or N * prog.n_rows <= _DIRECT_ENTRIES
    m = min(N, _DIRECT_BATCH if direct else max(256, _PROGRAM_CHUNK_ENTRIES // c.n))
    inputs, rows, scratch = np.empty((prog.n_inputs, m)), np.empty((prog.n_rows, 0 if direct else m)), \
        np.empty((prog.n_scratch, m))
    bound = None if direct else prog.bind(inputs, list(rows), scratch)
    for s in range(0, N, m):
        qc = q2[s:s + m]
        k = qc.shape[0]
        if k < m:  # the last, shorter chunk
            inputs, rows, scratch = inputs[:, :k], rows[:, :k], scratch[:, :k]
            bound = None if direct else prog.bind(inputs, list(rows), scratch)
        _program_inputs(c, qc, inputs)
        _run(prog.bind(inputs, [row for o in outs for row in o[s:s + k].T], scratch) if direct else bound)
        if not direct:
            _copy_out(outs, s, rows)


def _jacobian_call(robot, q, point, frame, want_T, out_T, out_J):
    if frame not in ("base", "tool"):
        raise OptionError(f"expected frame 'base' or 'tool', got {frame!r}")
    c, q2, lead = prepare(robot, q)
    prog = _point_program(c, _program.JACOBIAN, point, frame == "tool", want_T)
    return _jacobian_result(c, prog, q2, lead, want_T, out_T, out_J)


def _jacobian_result(c, prog, q2, lead, want_T, out_T=None, out_J=None):
    """Pose (or None) and Jacobian of a Jacobian program over ``q2`` (N, n) (into ``out_T``, ``out_J``)."""
    N, n = q2.shape[0], c.n
    if N <= SMALL_BATCH and out_T is None and out_J is None:
        rows = _small(prog, q2)
        J = rows[:, :6 * n].reshape(lead + (6, n))
        return (rows[:, 6 * n:].reshape(lead + (4, 4)) if want_T else None), J
    J = _output(out_J, lead + (6, n))
    T = _output(out_T, lead + (4, 4)) if want_T else None
    fJ = J.reshape(N, 6 * n)
    _evaluate(c, prog, q2, (fJ,) if T is None else (fJ, T.reshape(N, 16)))  # flipped joints included
    return T, J


def _fk_jacobian_kernel(robot):
    """``f(q)``: :func:`fk_jacobian` without the checks, for a solver's own finite float64 ``q`` (N, n):
    poses (N, 4, 4) and base-frame Jacobians of the tool point (N, 6, n)."""
    c = chain(robot)
    prog = _point_program(c, _program.JACOBIAN, None, False, True)

    def f(q):
        if c.flipped.size:  # theta_i = -q_i + theta_i, as prepare() does
            q = q.copy()
            q[:, c.flipped] *= -1.0
        return _jacobian_result(c, prog, q, q.shape[:1], True)

    return f


def _point_program(c, output, point=None, tool_frame=False, want_T=False):
    """The program of ``output`` for ``point`` [m] in tool coordinates (None: the tool point's, kept on the chain)."""
    if point is not None:
        return _program.program(c, output, _tool_offset(c, _as_point(point)), tool_frame, want_T)
    key = (output, tool_frame, want_T)
    prog = c.programs.get(key)
    if prog is None:
        prog = c.programs[key] = _program.program(c, output, _tool_offset(c, None), tool_frame, want_T,
                                                  structure=c.structure)
    return prog


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
    >>> np.round(jacobian(rpp, [0.0, 1.0, 1.0], point=None), 6)[:, 0] + 0.0  # + 0.0: no signed zeros
    array([0., 1., 0., 0., 0., 1.])
    """
    return _jacobian_call(robot, q, point, frame, False, None, out)[1]
