"""The DH recursion, written once, compiled per robot into straight-line programs (private).

:func:`walk` is the one place the Denavit-Hartenberg chain is written (both
conventions, prismatic and revolute joints, base and tool). It runs on an
*algebra*: :class:`_Builder` records it on *symbols*, where every vector
component is either a Python float known when the robot is loaded (the
base's columns, ``cos alpha = 0``, ``a = 0`` ...) or a signed reference to a
row of per-chunk scratch. Arithmetic on two constants is folded,
multiplications by 0 and +-1 and additions of 0 vanish, negations are carried
as a sign instead of computed, repeated products are shared, and whatever the
outputs do not need (the last joint's rotation when only the Jacobian is
asked for ...) is dropped. :mod:`labkit.kinematics.symbolic` runs the same
walk on sympy expressions.

What is left, a :class:`Program` per robot and output (pose, position, every
frame, Jacobian with or without the pose), is evaluated two ways:

* on numpy: a list of ufunc calls on ``(m,)`` rows with ``out=`` (no
  temporaries), scratch rows reused as soon as a value is dead so a chunk's
  working set stays in the L2 cache, each output row written once;
* on Python floats: the same calls as generated straight-line Python code
  (:meth:`Program.scalar`), for a handful of configurations, where numpy's
  per-call overhead would cost more than the arithmetic.

For the PUMA 560 the Jacobian needs about a third of the elementwise work of a
generic block walk: the first joints' frames are mostly zeros and ones.
"""

from __future__ import annotations

import itertools
import math
import weakref

import numpy as np

#: compiled programs per chain: {(point, frame, want_T): Program}; a few entries per robot at most
_PROGRAMS = weakref.WeakKeyDictionary()
_MAX_PER_CHAIN = 16

_COMMUTATIVE = (np.multiply, np.add)


class _Sym:
    """A row of the scratch, times ``sign`` (+1.0 or -1.0)."""

    __slots__ = ("reg", "sign")

    def __init__(self, reg, sign=1.0):
        self.reg = reg
        self.sign = sign

    def __neg__(self):
        return _Sym(self.reg, -self.sign)


def _neg(x):
    return -x if isinstance(x, _Sym) else -float(x)


class _Builder:
    """Records the ufunc calls of a symbolic walk, folding constants and signs."""

    def __init__(self, n_inputs):
        self.n_inputs = n_inputs  # registers 0 .. n_inputs - 1 are the inputs
        self.n_regs = n_inputs
        self.ops = []  # (ufunc, a, b, out): a, b a register (int) or a constant (float)
        self.memo = {}

    def emit(self, func, a, b):
        if func in _COMMUTATIVE and isinstance(b, int) and (not isinstance(a, int) or b < a):
            a, b = b, a
        key = (func, a, b)
        reg = self.memo.get(key)
        if reg is None:
            reg = self.memo[key] = self.n_regs
            self.n_regs += 1
            self.ops.append((func, a, b, reg))
        return reg

    def mul(self, x, y):
        if not isinstance(x, _Sym):
            if not isinstance(y, _Sym):
                return float(x) * float(y)
            x, y = y, x
        if not isinstance(y, _Sym):
            y = float(y)
            if y == 0.0:
                return 0.0
            if y == 1.0 or y == -1.0:
                return _Sym(x.reg, x.sign * y)
            return _Sym(self.emit(np.multiply, x.reg, y * x.sign))
        return _Sym(self.emit(np.multiply, x.reg, y.reg), x.sign * y.sign)

    def add(self, x, y):
        if not isinstance(x, _Sym):
            if not isinstance(y, _Sym):
                return float(x) + float(y)
            x, y = y, x
        if not isinstance(y, _Sym):
            y = float(y)
            if y == 0.0:
                return x
            return _Sym(self.emit(np.add, x.reg, y * x.sign), x.sign)
        if x.sign == y.sign:
            return _Sym(self.emit(np.add, x.reg, y.reg), x.sign)
        if x.sign > 0:
            return _Sym(self.emit(np.subtract, x.reg, y.reg))
        return _Sym(self.emit(np.subtract, y.reg, x.reg))

    def sub(self, x, y):
        return self.add(x, _neg(y))

    @staticmethod
    def neg(x):
        return _neg(x)

    # -- 3-vectors (tuples of three values) --
    def comb(self, x, cx, y, cy):
        """``x * cx + y * cy``."""
        return tuple(self.add(self.mul(x[k], cx), self.mul(y[k], cy)) for k in range(3))

    def axpy(self, p, v, w):
        """``p + v * w``."""
        return tuple(self.add(p[k], self.mul(v[k], w)) for k in range(3))

    def lincomb(self, p, cols, w):
        """``p + sum_k cols[k] * w[k]`` (``p`` may be None), skipping zero weights, left to right."""
        for col, v in zip(cols, w):
            if v != 0.0:
                term = tuple(self.mul(col[k], float(v)) for k in range(3))
                p = term if p is None else tuple(self.add(p[k], term[k]) for k in range(3))
        return p if p is not None else (0.0, 0.0, 0.0)


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


class Program:
    """A compiled chunk kernel: inputs (trig rows, prismatic values) -> output rows.

    Attributes
    ----------
    n_rows : int
        Output rows: ``6 n`` Jacobian entries (row-major ``(6, n)``), then 16
        pose entries (row-major ``(4, 4)``) if the pose is wanted; or the 3
        coordinates of a position program.
    n_scratch : int
        Scratch rows needed.
    """

    def __init__(self, ops, constants, n_rows, n_scratch, n_inputs, joints=None):
        self.joints = joints  # per joint (input row, half theta) or (input row, None): see _build
        self.constants = constants  # (output row, value) filled once per buffer
        self.n_rows = n_rows
        self.n_scratch = n_scratch
        self.n_inputs = n_inputs
        # each call as (ufunc, a, b, out), all four indices into the list bind() makes: the input,
        # output and scratch rows, then the constant operands
        start = {"i": 0, "o": n_inputs, "s": n_inputs + n_rows}
        self.constant_args = []
        index = {}

        def at(loc):
            if isinstance(loc, float):
                if loc not in index:
                    index[loc] = n_inputs + n_rows + n_scratch + len(self.constant_args)
                    self.constant_args.append(loc)
                return index[loc]
            return start[loc[0]] + loc[1]

        self.ops = [(f, at(a), at(b), at(o)) for f, a, b, o in ops]

    def scalar(self, tan=None):
        """The program as a Python function of joint values (generated once, kept on the program).

        Parameters
        ----------
        tan : callable, optional
            The tangent the code calls, instead of ``math.tan``: e.g. one
            recording it on symbols (:mod:`labkit.kinematics.ik._trace`); the
            function is then compiled anew and not kept.

        Returns
        -------
        callable
            ``f(q) -> list of float``: the ``n_rows`` outputs of one
            configuration from its ``n`` effective joint values ``q`` (a
            sequence of floats, flipped joints already negated), by the same
            operations in the same order as the ufunc calls, the half-angle
            trigonometry of :func:`labkit.kinematics._chain.half_angle_trig`
            included.
        """
        if tan is not None and tan is not math.tan:
            return _python_function(self, tan)
        f = getattr(self, "_scalar", None)
        if f is None:
            f = self._scalar = _python_function(self)
        return f

    def bind(self, inputs, out_rows, scratch):
        """The calls for one buffer set: a list of ``(ufunc, a, b, out)`` with arrays bound.

        Parameters
        ----------
        inputs : ndarray, shape (n_inputs, m)
            Filled per chunk (``_forward._program_inputs``).
        out_rows : sequence of ndarray, n_rows rows of shape (m,)
            Where the outputs go (contiguous rows, or strided columns of the
            result); the constant rows are filled here.
        scratch : ndarray, shape (n_scratch, m)

        Returns
        -------
        list of tuple
            The calls in order; run each as ``ufunc(a, b, out)``.
        """
        rows = list(inputs) + list(out_rows) + list(scratch) + self.constant_args
        for row, value in self.constants:
            out_rows[row][...] = value
        return [(f, rows[a], rows[b], rows[o]) for f, a, b, o in self.ops]


_OPERATOR = {np.multiply: "*", np.add: "+", np.subtract: "-"}


def _python_function(prog, tan=math.tan):
    """Generate and compile the straight-line Python code of a :class:`Program` on joint values (calling ``tan``)."""
    n_in, n_out = prog.n_inputs, prog.n_rows
    r = sum(half is not None for _, half in prog.joints)

    def name(k):
        if k < n_in:
            return f"x{k}"
        if k < n_in + n_out:
            return f"o{k - n_in}"
        if k < n_in + n_out + prog.n_scratch:
            return f"s{k - n_in - n_out}"
        return repr(prog.constant_args[k - n_in - n_out - prog.n_scratch])

    lines = ["def f(q):"]
    if prog.joints:
        lines.append("    " + "".join(f"q{i}, " for i in range(len(prog.joints))) + "= q")
    for i, (row, half) in enumerate(prog.joints):
        if half is None:  # prismatic: the joint value itself
            lines.append(f"    x{row} = q{i}")
            continue
        # cos and sin from the half-angle tangent, as half_angle_trig does on rows
        arg = f"q{i} * 0.5" + (f" + {half!r}" if half else "")
        lines += [f"    t = tan({arg})", "    w = 2.0 / (t * t + 1.0)", f"    x{row} = w - 1.0",
                  f"    x{row + r} = t * w"]
    lines += [f"    o{row} = {value!r}" for row, value in prog.constants]
    lines += [f"    {name(o)} = {name(a)} {_OPERATOR[func]} {name(b)}" for func, a, b, o in prog.ops]
    lines.append("    return [" + ", ".join(f"o{k}" for k in range(n_out)) + "]")
    namespace = {"tan": tan}
    exec(compile("\n".join(lines), f"<labkit kinematics program, {len(prog.ops)} operations>", "exec"), namespace)
    return namespace["f"]


def _negate(ops, producer, used, reg):
    """Rewrite the calls producing ``reg`` so that it holds its negative, if that costs nothing.

    Only values read exactly once (by the caller) may be rewritten:
    ``x - y -> y - x``, ``x * c -> x * (-c)``, ``x * y -> (-x) * y``,
    ``x + y -> (-x) - y``, ``x + c -> (-x) + (-c)``. Each is exact in IEEE
    arithmetic. Returns whether it succeeded.
    """
    k = producer.get(reg)
    if k is None or used.get(reg) != 1:
        return False
    f, x, y, o = ops[k]
    if f is np.subtract:
        ops[k] = (f, y, x, o)
        return True
    if f is np.multiply:
        if not isinstance(y, int):
            ops[k] = (f, x, -y, o)
            return True
        return _negate(ops, producer, used, x) or _negate(ops, producer, used, y)
    if f is np.add:
        if not isinstance(y, int):
            if _negate(ops, producer, used, x):
                ops[k] = (f, x, -y, o)
                return True
            return False
        if _negate(ops, producer, used, x):
            ops[k] = (np.subtract, x, y, o)
            return True
        if _negate(ops, producer, used, y):
            ops[k] = (np.subtract, y, x, o)
            return True
    return False


def _compile(b, outputs, n_rows, joints):
    """Dead-code elimination, output placement and scratch allocation of a recorded walk."""
    producer = {op[3]: k for k, op in enumerate(b.ops)}
    live = set()
    stack = [v.reg for _, v in outputs if isinstance(v, _Sym)]
    while stack:
        r = stack.pop()
        if r in live:
            continue
        live.add(r)
        if r in producer:
            _, x, y, _ = b.ops[producer[r]]
            stack.extend(v for v in (x, y) if isinstance(v, int))
    ops = [op for op in b.ops if op[3] in live]
    # each output row is written by the call producing its value (if positive and not yet placed)
    loc = {r: ("i", r) for r in range(b.n_inputs)}
    producer = {op[3]: k for k, op in enumerate(ops)}
    used = {}
    for _, x, y, _ in ops:
        for v in (x, y):
            if isinstance(v, int):
                used[v] = used.get(v, 0) + 1
    for _, v in outputs:
        if isinstance(v, _Sym):
            used[v.reg] = used.get(v.reg, 0) + 1
    constants, tail = [], []
    for row, v in outputs:
        if not isinstance(v, _Sym):
            constants.append((row, float(v)))
            continue
        if v.reg not in loc and v.sign < 0 and _negate(ops, producer, used, v.reg):
            v = _Sym(v.reg)
        if v.sign > 0 and v.reg not in loc:
            loc[v.reg] = ("o", row)
        else:
            tail.append((np.multiply, v.reg, v.sign, ("o", row)))  # a copy, negated or not (exact)
    seq = [(f, x, y, o) for f, x, y, o in ops] + tail
    last = {}
    for k, (_, x, y, _) in enumerate(seq):
        for v in (x, y):
            if isinstance(v, int):
                last[v] = k
    free, n_scratch, program = [], 0, []
    for k, (f, x, y, o) in enumerate(seq):
        args = [v if not isinstance(v, int) else loc[v] for v in (x, y)]
        for v in (x, y):  # a value read for the last time frees its row (the call may write in place)
            if isinstance(v, int) and last.get(v) == k and loc[v][0] == "s":
                free.append(loc[v][1])
                last[v] = -1
        if isinstance(o, int):
            if o not in loc:
                if free:
                    loc[o] = ("s", free.pop())
                else:
                    loc[o] = ("s", n_scratch)
                    n_scratch += 1
            o = loc[o]
        program.append((f, args[0], args[1], o))
    return Program(program, constants, n_rows, n_scratch, b.n_inputs, joints)


#: what a program computes
POSE, POSITION, FRAMES, JACOBIAN = "pose", "position", "frames", "jacobian"


def program(c, output, point_offset=None, tool_frame=False, want_T=False):
    """The compiled program of chain ``c`` for one output (cached per chain and options).

    Parameters
    ----------
    c : Chain
        From :func:`labkit.kinematics._chain.chain`.
    output : {"pose", "position", "frames", "jacobian"}
        The pose of the point (16 rows, row-major (4, 4)), its position (3
        rows), every frame (base, frames 1..n, tool: 16 rows each) or the
        Jacobian (6 n rows, row-major (6, n), then the pose's 16 rows if
        ``want_T``).
    point_offset : ndarray, shape (3,) or None
        Origin of the output frame in frame-n coordinates [m]
        (``_forward._tool_offset``); None for frame n's origin.
    tool_frame : bool
        Jacobian only: express the velocities in the tool frame (``R^T J``).
    want_T : bool
        Jacobian only: also write the pose.

    Returns
    -------
    Program
        Inputs: the revolute joints' cosines (rows ``0 .. r-1``), sines (rows
        ``r .. 2r-1``), then the prismatic joints' values (rows ``2r ..``), in
        joint order. Flipped joints' Jacobian columns are already negated.
    """
    if output != JACOBIAN:
        tool_frame = want_T = None
    key = (output, None if point_offset is None else tuple(float(v) for v in point_offset), tool_frame, want_T)
    per_chain = _PROGRAMS.get(c)
    if per_chain is None:
        per_chain = _PROGRAMS[c] = {}
    prog = per_chain.get(key)
    if prog is None:
        if len(per_chain) >= _MAX_PER_CHAIN:
            per_chain.clear()
        prog = per_chain[key] = _build(c, output, point_offset, tool_frame, want_T)
    return prog


def walk(b, modified, base, steps, trig, joint_value):
    """The DH recursion: every frame of the chain and each joint's axis, on the algebra ``b``.

    Parameters
    ----------
    b : algebra
        ``mul``, ``add``, ``comb``, ``axpy`` and ``neg`` on its values
        (:class:`_Builder`, or sympy's in :mod:`labkit.kinematics.symbolic`).
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
    frames : list of tuple
        Frames 1..n as columns ``(x, y, z, origin)``.
    axes : list of tuple
        Per joint ``(direction, point)`` of its axis, in world coordinates.
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
        if modified:
            c1, c2 = _rotate_x(b, c1, c2, ca, sa)
            if a != 0:
                p = b.axpy(p, c0, a)
            axes.append((c2, p))
            c0, c1 = b.comb(c0, ct, c1, st), b.comb(c1, ct, c0, b.neg(st))
            if not rev or d != 0:
                p = b.axpy(p, c2, d)
        else:
            axes.append((c2, p))
            c0, c1 = b.comb(c0, ct, c1, st), b.comb(c1, ct, c0, b.neg(st))
            if not rev or d != 0:
                p = b.axpy(p, c2, d)
            if a != 0:
                p = b.axpy(p, c0, a)
            c1, c2 = _rotate_x(b, c1, c2, ca, sa)
        frames.append((c0, c1, c2, p))
    return frames, axes


def _pose_rows(first, cols):
    """(output row, value) of a (4, 4) pose written row-major from row ``first``."""
    rows = [(first + 4 * r + k, col[r]) for k, col in enumerate(cols) for r in range(3)]
    return rows + [(first + 12 + k, v) for k, v in enumerate((0.0, 0.0, 0.0, 1.0))]


def _build(c, output, off, tool_frame, want_T):
    n, r = c.n, c.revolute.size
    b = _Builder(2 * r + (n - r))
    base = np.eye(4) if c.base is None else c.base
    base_cols = tuple(tuple(float(v) for v in base[:3, k]) for k in range(4))
    prismatic = {i: 2 * r + k for k, i in enumerate(i for i, step in enumerate(c.steps) if not step[0])}
    # where each joint's value enters: the cosine row (sine r rows on) and half the theta offset of a
    # revolute joint, the row of a prismatic one (None)
    rev_row = {int(i): j for j, i in enumerate(c.revolute)}
    joints = tuple((rev_row[i], 0.5 * step[5]) if step[0] else (prismatic[i], None) for i, step in enumerate(c.steps))
    frames, axes = walk(b, c.modified, base_cols, [(rev, a, ca, sa, d, cth, sth) for rev, a, ca, sa, d, _, cth, sth
                                                   in c.steps],
                        lambda j: (_Sym(j), _Sym(r + j)), lambda i, d: b.add(_Sym(prismatic[i]), d))
    c0, c1, c2, p = frames[-1] if frames else base_cols
    cols = (c0, c1, c2)
    if off is not None:
        p = b.lincomb(p, cols, off)
    if output == POSITION:
        return _compile(b, list(enumerate(p)), 3, joints)
    if c.tool is not None and not np.array_equal(c.tool[:3, :3], np.eye(3)):
        cols = tuple(b.lincomb(None, cols, c.tool[:3, k]) for k in range(3))
    if output == POSE:
        return _compile(b, _pose_rows(0, cols + (p,)), 16, joints)
    if output == FRAMES:
        outputs = _pose_rows(0, base_cols)
        for i, frame in enumerate(frames):
            outputs += _pose_rows(16 * (i + 1), frame)
        return _compile(b, outputs + _pose_rows(16 * (n + 1), cols + (p,)), 16 * (n + 2), joints)
    # Jacobian columns: z_i x (p_e - o_i) and z_i (revolute), z_i and 0 (prismatic)
    lin, ang = [], []
    for (z, o), step in zip(axes, c.steps):
        if not step[0]:
            lin.append(z)
            ang.append((0.0, 0.0, 0.0))
            continue
        lin.append(_cross_lever(b, z, p, o))
        ang.append(z)
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
