"""Straight-line programs: arithmetic recorded on symbols, folded, and evaluated on numpy rows or floats (private).

:class:`_Builder` is the algebra :func:`labkit.kinematics._program.walk` runs
on to record a program: every value is a literal ``0``, ``+1`` or ``-1``, a
robot *number* (:class:`_Number`, an input bound per robot) or a signed
reference to a scratch row (:class:`_Sym`). Arithmetic on literals is folded,
multiplications by 0 and +-1 and additions of 0 vanish, negations are carried
as a sign, repeated products are shared, and arithmetic on numbers alone
becomes a prologue evaluated once per robot. :func:`_compile` drops what the
outputs do not need, places outputs and allocates scratch rows into a
:class:`_Program`; :meth:`_Program.bound` binds a robot's numbers
(:class:`_Bound`), evaluated as ufunc calls on rows or as generated Python code
on floats.
"""

from __future__ import annotations

import math
import operator

import numpy as np

_COMMUTATIVE = (np.multiply, np.add)


class _Signed:
    """Entry ``k`` of something, times ``sign`` (+1.0 or -1.0)."""

    __slots__ = ("k", "sign")

    def __init__(self, k, sign=1.0):
        self.k = k
        self.sign = sign

    def __neg__(self):
        return type(self)(self.k, -self.sign)

    def scaled(self, sign):
        return self if sign == 1.0 else -self


class _Number(_Signed):
    """A robot number: entry ``k`` of the values a program is bound to, signed."""

    __slots__ = ()

    def __eq__(self, other):  # (never equal to a literal: a number is neither 0 nor +-1)
        return isinstance(other, _Number) and self.k == other.k and self.sign == other.sign

    def __hash__(self):
        return hash((self.k, self.sign))


class _Sym(_Signed):
    """Row ``k`` of the scratch (a register), signed."""

    __slots__ = ()


def _neg(x):
    return -x if isinstance(x, _Signed) else -float(x)


def _is_literal(x):
    return not isinstance(x, _Signed)


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
                return y.scaled(x) if isinstance(y, _Number) else (_Sym(y.k, y.sign * x)
                                                                    if isinstance(y, _Sym) else x * float(y))
        if not isinstance(x, _Sym):
            if not isinstance(y, _Sym):
                return self.number_op(operator.mul, x, y)
            x, y = y, x
        if not isinstance(y, _Sym):
            return _Sym(self.emit(np.multiply, x.k, y.scaled(x.sign) if isinstance(y, _Number) else y * x.sign))
        return _Sym(self.emit(np.multiply, x.k, y.k), x.sign * y.sign)

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
            return _Sym(self.emit(np.add, x.k, y.scaled(x.sign) if isinstance(y, _Number) else y * x.sign),
                        x.sign)
        if x.sign == y.sign:
            return _Sym(self.emit(np.add, x.k, y.k), x.sign)
        if x.sign > 0:
            return _Sym(self.emit(np.subtract, x.k, y.k))
        return _Sym(self.emit(np.subtract, y.k, x.k))

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


class _Program:
    """A compiled chunk kernel of one robot structure: ``n_inputs`` input rows (trig rows, prismatic
    values) -> ``n_rows`` output rows (:func:`labkit.kinematics._program.program`), using ``n_scratch`` rows."""

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
        """The program with a robot's ``numbers`` (in the order :func:`program` found them); runs the prologue."""
        values = list(numbers)
        for func, a, b in self.prologue:
            values.append(func(_value(a, values), _value(b, values)))
        return _Bound(self, [v if k is None else v * values[k] for k, v in self._operands])

    def scalar(self):
        """The program as generated Python code ``f(q, c)`` (generated once, kept): the ``n_rows`` outputs of
        one configuration from its effective joint values ``q`` (floats) and the bound operands ``c``, by the
        same operations in the same order as the ufunc calls (with ``_forward._program_inputs``'s trigonometry)."""
        if self._scalar is None:
            self._scalar = _python_function(self)
        return self._scalar


def _value(v, values):
    """A literal, or a robot number's value from ``values``."""
    return v.sign * values[v.k] if isinstance(v, _Number) else v


class _Bound:
    """A :class:`_Program` bound to one robot's numbers, its ``operands`` (kept per robot on its chain)."""

    def __init__(self, program, operands):
        self.program = program
        self.operands = operands
        self.n_rows, self.n_scratch, self.n_inputs = program.n_rows, program.n_scratch, program.n_inputs
        self.ops = program.ops
        self.constants = [(row, operands[k]) for row, k in program.constants]  # (output row, value)
        self._scalar = None

    def scalar(self):
        """``f(q) -> list of float``: :meth:`_Program.scalar` with this robot's numbers."""
        if self._scalar is None:
            f, operands = self.program.scalar(), self.operands
            self._scalar = lambda q: f(q, operands)
        return self._scalar

    def bind(self, inputs, out_rows, scratch):
        """The calls ``(ufunc, a, b, out)`` in order on ``inputs`` (n_inputs, m), ``out_rows`` (n_rows rows (m,):
        contiguous rows or strided columns of the result; the constant ones are filled here) and ``scratch``."""
        rows = list(inputs) + list(out_rows) + list(scratch) + self.operands
        for row, value in self.constants:
            out_rows[row][...] = value
        return [(f, rows[a], rows[b], rows[o]) for f, a, b, o in self.ops]


_OPERATOR = {np.multiply: "*", np.add: "+", np.subtract: "-"}


def _python_function(prog):
    """Generate and compile the straight-line Python code ``f(q, c)`` of a :class:`_Program`."""
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


def _compile(b, outputs, n_rows, joints):
    """Dead-code elimination, output placement and scratch allocation of a recorded walk."""
    producer = {op[3]: k for k, op in enumerate(b.ops)}
    live = set()
    stack = [v.k for _, v in outputs if isinstance(v, _Sym)]
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
    constants, tail = [], []
    for row, v in outputs:
        if not isinstance(v, _Sym):
            constants.append((row, v if isinstance(v, _Number) else float(v)))
            continue
        if v.sign > 0 and v.k not in loc:
            loc[v.k] = ("o", row)
        else:
            tail.append((np.multiply, v.k, v.sign, ("o", row)))  # a copy, negated or not (exact)
    seq = ops + tail
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
    return _Program(program, constants, n_rows, n_scratch, b.n_inputs, joints, tuple(b.prologue))
