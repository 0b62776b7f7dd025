"""The DH recursion, written once, compiled per robot *structure* into straight-line programs (private).

:func:`walk` is the one place the Denavit-Hartenberg chain is written (both
conventions, prismatic and revolute joints, base and tool). It runs on an
*algebra*: on floats and on sympy expressions (:data:`PLAIN`,
:mod:`labkit.kinematics.symbolic`) it is plain arithmetic; on the symbols of
:mod:`labkit.kinematics._straight_line` (literals ``0``, ``+-1``, the robot's
*numbers*, signed scratch rows) it is recorded, with the constants folded,
signs carried, repeated products shared and what the outputs do not need (the
last joint's rotation when only the Jacobian is asked for ...) dropped.

What is left, a :class:`_Program`, depends only on the robot's structure
(convention, joint types, flips, which numbers are 0 or +-1) and on the
output asked for (pose, position, every frame, Jacobian with or without the
pose). Programs are kept in one cache keyed by that structure, so a freshly
loaded robot, a ``with_link`` copy or the robots of a calibration with other
numbers compile nothing; a robot's numbers are bound to the program
(:meth:`_Program.bound`, microseconds). A bound program is evaluated two ways:
on numpy, as ufunc calls on ``(m,)`` rows with ``out=`` (no temporaries,
scratch rows reused as soon as a value is dead so a chunk's working set stays
in the L2 cache, each output row written once), and on Python floats, as the
same calls in generated straight-line Python code (:meth:`_Program.scalar`),
for a handful of configurations, where numpy's per-call overhead would cost
more than the arithmetic.

For the PUMA 560 the Jacobian needs about a third of the elementwise work of a
generic block walk: the first joints' frames are mostly zeros and ones.
"""

from __future__ import annotations

import itertools
import operator
import types

import numpy as np

from labkit.kinematics._straight_line import _Builder, _Number, _Sym, _compile, _neg

#: compiled programs by structure and output: {key: _Program} (see :func:`program`); cleared when full
_PROGRAMS = {}
_MAX_PROGRAMS = 256
#: literals folded into a program's structure; any other number is an input
_LITERALS = (0.0, 1.0, -1.0)


def _rotate_x(b, c1, c2, ca, sa):
    """Columns 1, 2 after post-multiplying by Rx(alpha)."""
    neg = b.neg
    if sa == 0:
        return (c1, c2) if ca == 1 else (tuple(map(neg, c1)), tuple(map(neg, c2)))
    if ca == 0:
        return (c2, tuple(map(neg, c1))) if sa > 0 else (tuple(map(neg, c2)), c1)
    return b.comb(c1, ca, c2, sa), b.comb(c2, ca, c1, neg(sa))


def _cross_lever(b, z, p, o):
    """``z x (p - o)``, each lever component computed as ``p - o`` or as ``-(o - p)``.

    Of the eight sign choices the one leaving the fewest components negated
    (a negation is an extra pass when the component is an output) is kept;
    the calls of the others are dropped as dead code.
    """
    best = None
    for signs in itertools.product((1.0, -1.0), repeat=3):
        e = tuple(b.sub(p[k], o[k]) if sg > 0 else _neg(b.sub(o[k], p[k])) for k, sg in enumerate(signs))
        v = tuple(b.sub(b.mul(z[(k + 1) % 3], e[(k + 2) % 3]), b.mul(z[(k + 2) % 3], e[(k + 1) % 3]))
                  for k in range(3))
        negated = sum(isinstance(x, _Sym) and x.sign < 0 for x in v)
        if best is None or negated < best[0]:
            best = negated, v
    return best[1]


#: what a program computes
POSE, POSITION, FRAMES, JACOBIAN = "pose", "position", "frames", "jacobian"


def program(c, output, point_offset=None, tool_frame=False, want_T=False, *, structure=None):
    """The program of chain ``c`` for one output, bound to its numbers (compiled once per structure).

    Parameters
    ----------
    c : Chain
    output : {"pose", "position", "frames", "jacobian"}
        The point's pose (16 rows, row-major), its position (3 rows), every frame (base, 1..n,
        tool: 16 rows each) or the Jacobian (6 n rows, row-major (6, n), then the pose if ``want_T``).
    point_offset : ndarray, shape (3,) or None
        Origin of the output frame in frame-n coordinates [m] (None: frame n's origin).
    tool_frame, want_T : bool
        Jacobian only: velocities in the tool frame (``R^T J``); also write the pose.
    structure : tuple, optional
        :func:`_chain_structure` of the chain and ``point_offset``, if known.

    Returns
    -------
    _Bound
        Inputs: the revolute joints' cosines (rows ``0 .. r-1``), sines (``r .. 2r-1``), then the
        prismatic joints' values, in joint order. Flipped joints' Jacobian columns come negated.
    """
    if output != JACOBIAN:
        tool_frame = want_T = None
    skeleton, numbers = structure or _chain_structure(c.steps, c.base, c.tool, point_offset)
    key = (output, tool_frame, want_T, c.modified, tuple(c.flipped.tolist()), skeleton)
    prog = _PROGRAMS.get(key)
    if prog is None:
        if len(_PROGRAMS) >= _MAX_PROGRAMS:
            _PROGRAMS.clear()
        prog = _PROGRAMS[key] = _build(c, _numbered(skeleton), len(numbers), output, tool_frame, want_T)
    return prog.bound(numbers)


#: where a skeleton has a robot number (see :func:`_chain_structure`)
NUMBER = "#"


def _chain_structure(steps, base, tool, off):
    """A chain as a structure, the key of its programs: ``(steps, base columns, tool rotation columns or
    None, output point or None)`` with every number but 0 and +-1 replaced by :data:`NUMBER`, and those
    numbers in order; ``steps`` as :attr:`Chain.steps`, ``base``, ``tool`` (4, 4) and the point ``off`` (3,)
    [m] or None."""
    numbers = []

    def v(x):
        x = float(x)
        if x in _LITERALS:
            return x + 0.0  # (-0.0 as 0.0)
        numbers.append(x)
        return NUMBER

    # per link (revolute, a, cos alpha, sin alpha, d, half theta of a revolute joint (False: prismatic), cos and
    # sin theta of a prismatic one)
    steps = tuple((rev, v(a), v(ca), v(sa), v(d), v(0.5 * th) if rev else False,
                   0.0 if rev else v(cth), 0.0 if rev else v(sth)) for rev, a, ca, sa, d, th, cth, sth in steps)
    base_cols = tuple(tuple(v(x) for x in base[:3, k]) if base is not None else _EYE_COLUMNS[k] for k in range(4))
    rotated = tool is not None and (tool[:3, :3] != _EYE3).any()
    tool = tuple(tuple(v(x) for x in tool[:3, k]) for k in range(3)) if rotated else None
    return (steps, base_cols, tool, None if off is None else tuple(v(x) for x in off)), numbers


_EYE_COLUMNS = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
_EYE3 = np.eye(3)


def _numbered(x, counter=None):
    """The skeleton with its :data:`NUMBER` marks replaced by :class:`_Number` 0, 1, ... in order."""
    counter = itertools.count() if counter is None else counter
    if isinstance(x, tuple):
        return tuple(_numbered(v, counter) for v in x)
    return _Number(next(counter)) if x == NUMBER else x


def walk(b, modified, base, steps, trig, joint_value):
    """The DH recursion: every frame of the chain and each joint's axis, on the algebra ``b``.

    Parameters
    ----------
    b : algebra
        ``comb``, ``axpy`` and ``neg`` on its values (:class:`_Builder`, :data:`PLAIN`).
    modified : bool
        Modified (Craig) DH convention, else standard.
    base : tuple
        Frame 0 as columns ``(x, y, z, origin)``, each a 3-tuple.
    steps : sequence of tuple
        Per link ``(revolute, a, cos alpha, sin alpha, d, cos theta, sin theta)``
        (the last two used for prismatic joints), values of the algebra.
    trig : callable
        ``trig(j) -> (cos, sin)`` of the j-th revolute joint's angle (offset included).
    joint_value : callable
        ``joint_value(i, d) -> d_i`` of the prismatic joint ``i`` (offset ``d`` included).

    Returns
    -------
    frames, axes : list of tuple
        Frames 1..n as columns ``(x, y, z, origin)``; per joint ``(direction, point)`` of its axis.
    """
    c0, c1, c2, p = base
    frames, axes, j = [], [], 0
    for i, (rev, a, ca, sa, d, cth, sth) in enumerate(steps):
        if rev:
            ct, st = trig(j)
            j += 1
        else:
            ct, st = cth, sth
            d = joint_value(i, d)
        if modified:  # Craig: Rx(alpha) Tx(a) before Rz(theta) Tz(d); standard DH: Tx(a) Rx(alpha) after them
            c1, c2 = _rotate_x(b, c1, c2, ca, sa)
            if a != 0:
                p = b.axpy(p, c0, a)
        axes.append((c2, p))
        c0, c1 = b.comb(c0, ct, c1, st), b.comb(c1, ct, c0, b.neg(st))  # Rz(theta) Tz(d)
        if not rev or d != 0:
            p = b.axpy(p, c2, d)
        if not modified:
            if a != 0:
                p = b.axpy(p, c0, a)
            c1, c2 = _rotate_x(b, c1, c2, ca, sa)
        frames.append((c0, c1, c2, p))
    return frames, axes


#: :func:`walk`'s algebra as plain arithmetic: on Python floats (one configuration, evaluated at once, nothing
#: compiled) or on sympy expressions (:mod:`labkit.kinematics.symbolic`)
PLAIN = types.SimpleNamespace(
    neg=operator.neg,
    comb=lambda x, cx, y, cy: tuple(x[k] * cx + y[k] * cy for k in range(3)),
    axpy=lambda p, v, w: tuple(p[k] + v[k] * w for k in range(3)),
)


def _pose_rows(first, cols):
    """(output row, value) of a (4, 4) pose written row-major from row ``first``."""
    rows = [(first + 4 * r + k, col[r]) for k, col in enumerate(cols) for r in range(3)]
    return rows + [(first + 12 + k, v) for k, v in enumerate((0.0, 0.0, 0.0, 1.0))]


def _build(c, skeleton, n_numbers, output, tool_frame, want_T):
    steps, base_cols, tool, off = skeleton
    n, r = c.n, c.revolute.size
    b = _Builder(2 * r + (n - r), n_numbers)
    prismatic = {i: 2 * r + k for k, i in enumerate(i for i, step in enumerate(steps) if not step[0])}
    # where each joint's value enters: the cosine row (sine r rows on) and half the theta offset of a
    # revolute joint, the row of a prismatic one (False)
    rev_row = {int(i): j for j, i in enumerate(c.revolute)}
    joints = tuple((rev_row[i], step[5]) if step[0] else (prismatic[i], False) for i, step in enumerate(steps))
    frames, axes = walk(b, c.modified, base_cols, [(rev, a, ca, sa, d, cth, sth) for rev, a, ca, sa, d, _, cth, sth
                                                   in steps],
                        lambda j: (_Sym(j), _Sym(r + j)), lambda i, d: b.add(_Sym(prismatic[i]), d))
    c0, c1, c2, p = frames[-1] if frames else base_cols
    cols = (c0, c1, c2)
    if off is not None:
        p = b.lincomb(p, cols, off)
    if output == POSITION:
        return _compile(b, list(enumerate(p)), 3, joints)
    if tool is not None:
        cols = tuple(b.lincomb(None, cols, tool[k]) for k in range(3))
    if output == POSE:
        return _compile(b, _pose_rows(0, cols + (p,)), 16, joints)
    if output == FRAMES:
        outputs = _pose_rows(0, base_cols)
        for i, frame in enumerate(frames):
            outputs += _pose_rows(16 * (i + 1), frame)
        return _compile(b, outputs + _pose_rows(16 * (n + 1), cols + (p,)), 16 * (n + 2), joints)
    # Jacobian columns: z_i x (p_e - o_i) and z_i (revolute), z_i and 0 (prismatic)
    lin = [_cross_lever(b, z, p, o) if step[0] else z for (z, o), step in zip(axes, steps)]
    ang = [z if step[0] else (0.0, 0.0, 0.0) for (z, _), step in zip(axes, steps)]
    if tool_frame:  # rows of R^T J: tool axis k dotted with each column
        def rotate(v):
            return tuple(b.add(b.add(b.mul(v[0], t[0]), b.mul(v[1], t[1])), b.mul(v[2], t[2])) for t in cols)

        lin, ang = [rotate(v) for v in lin], [rotate(v) for v in ang]
    flipped = {int(i) for i in c.flipped}
    outputs = []
    for i in range(n):
        for k in range(3):
            for part, row in ((lin, k), (ang, k + 3)):
                v = part[i][k]
                outputs.append((row * n + i, _neg(v) if i in flipped else v))
    n_rows = 6 * n
    if want_T:
        outputs += _pose_rows(n_rows, cols + (p,))
        n_rows += 16
    return _compile(b, outputs, n_rows, joints)
