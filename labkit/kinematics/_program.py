"""The DH recursion, written once, compiled per robot *structure* into straight-line programs (private).

:func:`walk` is the one place the Denavit-Hartenberg chain is written (both
conventions, prismatic and revolute joints, base and tool). It runs on an
*algebra*: :class:`_Builder` records it on *symbols*, where every vector
component is a literal ``0``, ``+1`` or ``-1`` (``cos alpha = 0``, ``a = 0``,
the base's columns ...), a robot *number* (a length, a twist's cosine: an
input of the program, :class:`_Number`) or a signed reference to a row of
per-chunk scratch. Arithmetic on literals is folded, multiplications by 0 and
+-1 and additions of 0 vanish, negations are carried as a sign instead of
computed, repeated products are shared, arithmetic on numbers alone becomes a
short prologue evaluated once per robot, and whatever the outputs do not need
(the last joint's rotation when only the Jacobian is asked for ...) is
dropped. :mod:`labkit.kinematics.symbolic` runs the same walk on sympy
expressions.

What is left, a :class:`Program`, depends only on the robot's structure
(convention, joint types, flips, which numbers are 0 or +-1) and on the
output asked for (pose, position, every frame, Jacobian with or without the
pose). Programs are kept in one cache keyed by that structure, so a freshly
loaded robot, a ``with_link`` copy or the robots of a calibration with other
numbers compile nothing; a robot's numbers are bound to the program
(:meth:`Program.bound`, microseconds). A bound program is evaluated two ways:

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
import operator

import numpy as np

#: compiled programs by structure and output: {key: Program} (see :func:`program`); cleared when full
_PROGRAMS = {}
_MAX_PROGRAMS = 256

_COMMUTATIVE = (np.multiply, np.add)
#: literals folded into a program's structure; any other number is an input
_LITERALS = (0.0, 1.0, -1.0)


class _Number:
    """A robot number (entry ``k`` of the values a program is bound to), times ``sign`` (+1.0 or -1.0)."""

    __slots__ = ("k", "sign")

    def __init__(self, k, sign=1.0):
        self.k = k
        self.sign = sign

    def __neg__(self):
        return _Number(self.k, -self.sign)

    def scaled(self, sign):
        return self if sign == 1.0 else _Number(self.k, -self.sign)

    def __eq__(self, other):  # (never equal to a literal: a number is neither 0 nor +-1)
        return isinstance(other, _Number) and self.k == other.k and self.sign == other.sign

    def __ne__(self, other):
        return not self == other

    def __hash__(self):
        return hash((self.k, self.sign))

    def __repr__(self):
        return f"{'-' if self.sign < 0 else ''}n{self.k}"


class _Sym:
    """A row of the scratch, times ``sign`` (+1.0 or -1.0)."""

    __slots__ = ("reg", "sign")

    def __init__(self, reg, sign=1.0):
        self.reg = reg
        self.sign = sign

    def __neg__(self):
        return _Sym(self.reg, -self.sign)


def _neg(x):
    return -x if isinstance(x, (_Sym, _Number)) else -float(x)


def _is_literal(x):
    return not isinstance(x, (_Sym, _Number))


class _Builder:
    """Records the ufunc calls of a symbolic walk, folding constants and signs."""

    def __init__(self, n_inputs, n_numbers):
        self.n_inputs = n_inputs  # registers 0 .. n_inputs - 1 are the inputs
        self.n_regs = n_inputs
        self.ops = []  # (ufunc, a, b, out): a, b a register (int), a literal (float) or a _Number
        self.memo = {}
        self.n_numbers = n_numbers  # the robot's numbers are values 0 .. n_numbers - 1
        self.prologue = []  # (operator, a, b): value n_numbers + k from numbers and literals

    def number_op(self, func, x, y):
        """``func(x, y)`` of literals and numbers: a literal, or a number made by the prologue."""
        if _is_literal(x) and _is_literal(y):
            return float(func(float(x), float(y)))
        key = (func, x, y)
        k = self.memo.get(key)
        if k is None:
            k = self.memo[key] = self.n_numbers + len(self.prologue)
            self.prologue.append(key)
        return _Number(k)

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
        if _is_literal(y):
            x, y = y, x
        if _is_literal(x):  # fold 0 and +-1
            x = float(x)
            if x == 0.0:
                return 0.0
            if x == 1.0 or x == -1.0:
                return y.scaled(x) if isinstance(y, _Number) else (_Sym(y.reg, y.sign * x)
                                                                    if isinstance(y, _Sym) else x * float(y))
        if not isinstance(x, _Sym):
            if not isinstance(y, _Sym):
                return self.number_op(operator.mul, x, y)
            x, y = y, x
        if not isinstance(y, _Sym):
            return _Sym(self.emit(np.multiply, x.reg, y.scaled(x.sign) if isinstance(y, _Number) else y * x.sign))
        return _Sym(self.emit(np.multiply, x.reg, y.reg), x.sign * y.sign)

    def add(self, x, y):
        if not isinstance(x, _Sym):
            if not isinstance(y, _Sym):
                if _is_literal(x) and float(x) == 0.0:
                    return y
                if _is_literal(y) and float(y) == 0.0:
                    return x
                return self.number_op(operator.add, x, y)
            x, y = y, x
        if not isinstance(y, _Sym):
            if _is_literal(y):
                y = float(y)
                if y == 0.0:
                    return x
            return _Sym(self.emit(np.add, x.reg, y.scaled(x.sign) if isinstance(y, _Number) else y * x.sign),
                        x.sign)
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
                term = tuple(self.mul(col[k], v) for k in range(3))
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
    """A compiled chunk kernel of one robot structure: inputs (trig rows, prismatic values) -> output rows.

    Attributes
    ----------
    n_rows : int
        Output rows: ``6 n`` Jacobian entries (row-major ``(6, n)``), then 16
        pose entries (row-major ``(4, 4)``) if the pose is wanted; or the 3
        coordinates of a position program.
    n_scratch : int
        Scratch rows needed.
    n_inputs : int
        Input rows.
    """

    def __init__(self, ops, constants, n_rows, n_scratch, n_inputs, joints, prologue):
        self.n_rows = n_rows
        self.n_scratch = n_scratch
        self.n_inputs = n_inputs
        self.prologue = prologue  # (operator, a, b) making the values after the robot's numbers
        # the operands that are not rows: literals and numbers, each once; ops index into the list bind() makes
        # (input, output and scratch rows, then these operands)
        start = {"i": 0, "o": n_inputs, "s": n_inputs + n_rows}
        self.operands = []
        index = {}

        def at(loc):
            if isinstance(loc, (float, _Number)):
                if loc not in index:
                    index[loc] = n_inputs + n_rows + n_scratch + len(self.operands)
                    self.operands.append(loc)
                return index[loc]
            return start[loc[0]] + loc[1]

        self.ops = [(f, at(a), at(b), at(o)) for f, a, b, o in ops]
        self.constants = [(row, at(v) - n_inputs - n_rows - n_scratch) for row, v in constants]  # (row, operand)
        # per joint (input row, operand index of half its theta offset, or None) or (input row, False): prismatic
        self.joints = tuple((row, False) if half is False else
                            (row, None if half == 0.0 else at(half) - n_inputs - n_rows - n_scratch)
                            for row, half in joints)
        self._operands = [(v.k, v.sign) if isinstance(v, _Number) else (None, v) for v in self.operands]
        self._scalar = None

    def bound(self, numbers):
        """The program with a robot's numbers: a :class:`Bound` (evaluates the prologue once).

        Parameters
        ----------
        numbers : sequence of float
            The robot's numbers in the order :func:`program` found them.

        Returns
        -------
        Bound
        """
        values = list(numbers)
        for func, a, b in self.prologue:
            values.append(func(_value(a, values), _value(b, values)))
        return Bound(self, [v if k is None else v * values[k] for k, v in self._operands])

    def scalar(self):
        """The program as generated Python code ``f(q, c) -> list of float`` (generated once, kept).

        Returns
        -------
        callable
            ``f(q, c)``: the ``n_rows`` outputs of one configuration from its
            ``n`` effective joint values ``q`` (a sequence of floats, flipped
            joints already negated) and the bound operands ``c``
            (:attr:`Bound.operands`), by the same operations in the same
            order as the ufunc calls, the half-angle trigonometry of
            :func:`labkit.kinematics._chain.half_angle_trig` included.
        """
        if self._scalar is None:
            self._scalar = _python_function(self)
        return self._scalar


def _value(v, values):
    """A literal, or a robot number's value from ``values``."""
    return v.sign * values[v.k] if isinstance(v, _Number) else v


class Bound:
    """A :class:`Program` bound to one robot's numbers (kept per robot on its chain).

    Parameters
    ----------
    program : Program
        The structure's program.
    operands : list of float
        Its operands with this robot's values.
    """

    def __init__(self, program, operands):
        self.program = program
        self.operands = operands
        self.n_rows, self.n_scratch, self.n_inputs = program.n_rows, program.n_scratch, program.n_inputs
        self.ops = program.ops
        self.constants = [(row, operands[k]) for row, k in program.constants]  # (output row, value)
        f = program.scalar()
        self._scalar = lambda q: f(q, operands)

    def scalar(self):
        """The program's Python code with this robot's numbers.

        Returns
        -------
        callable
            ``f(q) -> list of float`` (see :meth:`Program.scalar`).
        """
        return self._scalar

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
        rows = list(inputs) + list(out_rows) + list(scratch) + self.operands
        for row, value in self.constants:
            out_rows[row][...] = value
        return [(f, rows[a], rows[b], rows[o]) for f, a, b, o in self.ops]


_OPERATOR = {np.multiply: "*", np.add: "+", np.subtract: "-"}


def _python_function(prog):
    """Generate and compile the straight-line Python code ``f(q, c)`` of a :class:`Program`."""
    n_in, n_out, n_s = prog.n_inputs, prog.n_rows, prog.n_scratch
    r = sum(half is not False for _, half in prog.joints)

    def name(k):
        if k < n_in:
            return f"x{k}"
        if k < n_in + n_out:
            return f"o{k - n_in}"
        if k < n_in + n_out + n_s:
            return f"s{k - n_in - n_out}"
        return f"c{k - n_in - n_out - n_s}"

    lines = ["def f(q, c):"]
    if prog.operands:
        lines.append("    " + "".join(f"c{k}, " for k in range(len(prog.operands))) + "= c")
    if prog.joints:
        lines.append("    " + "".join(f"q{i}, " for i in range(len(prog.joints))) + "= q")
    for i, (row, half) in enumerate(prog.joints):
        if half is False:  # prismatic: the joint value itself
            lines.append(f"    x{row} = q{i}")
            continue
        # cos and sin from the half-angle tangent, as half_angle_trig does on rows
        arg = f"q{i} * 0.5" + (f" + c{half}" if half is not None else "")
        lines += [f"    t = tan({arg})", "    w = 2.0 / (t * t + 1.0)", f"    x{row} = w - 1.0",
                  f"    x{row + r} = t * w"]
    lines += [f"    o{row} = c{k}" for row, k in prog.constants]
    lines += [f"    {name(o)} = {name(a)} {_OPERATOR[func]} {name(b)}" for func, a, b, o in prog.ops]
    lines.append("    return [" + ", ".join(f"o{k}" for k in range(n_out)) + "]")
    namespace = {"tan": math.tan}
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
            constants.append((row, v if isinstance(v, _Number) else float(v)))
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
    return Program(program, constants, n_rows, n_scratch, b.n_inputs, joints, tuple(b.prologue))


#: what a program computes
POSE, POSITION, FRAMES, JACOBIAN = "pose", "position", "frames", "jacobian"


def program(c, output, point_offset=None, tool_frame=False, want_T=False, *, structure=None):
    """The program of chain ``c`` for one output, bound to its numbers (compiled once per structure).

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
    structure : tuple, optional
        :func:`chain_structure` of the chain and ``point_offset``, if known.

    Returns
    -------
    Bound
        Inputs: the revolute joints' cosines (rows ``0 .. r-1``), sines (rows
        ``r .. 2r-1``), then the prismatic joints' values (rows ``2r ..``), in
        joint order. Flipped joints' Jacobian columns are already negated.
    """
    if output != JACOBIAN:
        tool_frame = want_T = None
    skeleton, numbers = structure or chain_structure(c.steps, c.base, c.tool, point_offset)
    key = (output, tool_frame, want_T, c.modified, tuple(c.flipped.tolist()), skeleton)
    prog = _PROGRAMS.get(key)
    if prog is None:
        if len(_PROGRAMS) >= _MAX_PROGRAMS:
            _PROGRAMS.clear()
        prog = _PROGRAMS[key] = _build(c, _numbered(skeleton), len(numbers), output, tool_frame, want_T)
    return prog.bound(numbers)


#: where a skeleton has a robot number (see :func:`chain_structure`)
NUMBER = "#"


def chain_structure(steps, base, tool, off):
    """A chain as a structure (the key of its programs), and its numbers.

    Parameters
    ----------
    steps : tuple of tuple
        :attr:`labkit.kinematics._chain.Chain.steps`.
    base, tool : ndarray, shape (4, 4) or None
        World-from-base and frame-n-from-tool transforms (None: identity).
    off : ndarray, shape (3,) or None
        The output point in frame-n coordinates [m] (None: frame n's origin).

    Returns
    -------
    skeleton : tuple
        ``(steps, base columns, tool rotation columns or None, point or None)``
        with every number other than 0 and +-1 replaced by :data:`NUMBER`.
    numbers : list of float
        Those numbers, in order.
    """
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
    rotated = tool is not None and not np.array_equal(tool[:3, :3], np.eye(3))
    tool = tuple(tuple(v(x) for x in tool[:3, k]) for k in range(3)) if rotated else None
    return (steps, base_cols, tool, None if off is None else tuple(v(x) for x in off)), numbers


_EYE_COLUMNS = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, 0.0))


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
    lin, ang = [], []
    for (z, o), step in zip(axes, steps):
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
