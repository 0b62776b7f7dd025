"""Formulas written against an array namespace, compiled into straight-line Python for floats (private).

The closed-form families (:mod:`labkit.kinematics.ik._family`), the finishing
step, the ranking of numeric IK's starts, the task error, the damped step
(on nested lists) and the rigid-transform test are written once against an
array namespace ``xp``. On :data:`~labkit.kinematics.ik._xp.FLOATS`
most of one target's time goes to interpreting them (attribute look-ups, calls
of small helpers, tuples built and unpacked, loops over branches and joints),
not to the arithmetic. :func:`compiled` runs such a function once on
:data:`TRACE`, whose values are symbols recording every operation on them, and
turns the record into one generated Python function of the same arguments, one
line per operation (``v12 = v3 * v7``, ``v13 = _atan2(v12, v9)``,
``v14 = v5 if v13 else v6``), returning the structure the function returns.
Callers compile once per robot (or solver) and keep the result.

The function computes bit for bit what ``fn(FLOATS, ...)`` computes: the same
functions (``math.sqrt`` ..., raising where they raise) on the same operands in
the association the formulas wrote. The only rewrites are those that cannot
change a bit: an operation on constants is computed while tracing (as FLOATS
computes it), ``x * 1.0``, ``x / 1.0``, ``x - 0.0``, ``x + -0.0`` and
``-(-x)`` are ``x``, an operation repeated on the same operands is computed
once, and a value nothing uses is dropped unless its operation can raise.
``x + 0.0`` and ``x * 0.0`` stay (``-0.0 + 0.0`` is ``+0.0``, ``inf * 0.0``
NaN).

Such code never branches on a value (it also runs on numpy rows). If it does
(a symbol's ``__bool__``) or uses anything :data:`TRACE` lacks, tracing stops
and :func:`compiled` returns None: the caller keeps the interpretive FLOATS
path, never a wrong answer.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

from labkit.kinematics.ik._xp import FLOATS

__all__ = ["TRACE", "compiled"]

#: the functions the generated code calls (bound as default arguments: local look-ups)
_FUNCTIONS = {"_sqrt": math.sqrt, "_atan2": math.atan2, "_acos": math.acos, "_cos": math.cos, "_sin": math.sin,
              "_tan": math.tan,
              "_abs": abs, "_hypot": math.hypot, "_isfinite": math.isfinite, "_wrap": FLOATS.wrap}
#: those that raise on some floats (kept even where nothing uses their value)
_RAISING = ("_sqrt(", "_acos(", "_cos(", "_sin(", "_tan(", "_wrap(")

#: the kind of a constant operand, by type
_CONSTANT_KINDS = {float: "float", int: "float", bool: "bool"}


class _Untraceable(Exception):
    """Tracing met something straight-line code cannot express (internal: the FLOATS path is kept)."""


def _kind(v):
    """``"float"``, ``"bool"`` or ``"other"``: what a value is at run time (identities hold for floats only)."""
    if isinstance(v, _Sym):
        return v.kind
    return _CONSTANT_KINDS.get(type(v), "other")


def _refuse(self, *args):
    raise _Untraceable("the family converts or branches on a traced value")


class _Sym:
    """A value of the traced target: the ``i``-th of its tape, of kind ``"float"``, ``"bool"`` or ``"other"``."""

    __slots__ = ("tape", "i", "kind")
    __array_ufunc__ = None  # numpy scalars defer to the reflected operators
    __hash__ = object.__hash__
    __bool__ = __float__ = __int__ = __index__ = __complex__ = _refuse

    def __init__(self, tape, i, kind):
        self.tape, self.i, self.kind = tape, i, kind

    def __neg__(self):
        template, args = self.tape.defs.get(self.i, (None, ()))
        if template == "-{0}":  # -(-x) is x
            return args[0]
        return self.tape.record("other" if self.kind == "bool" else self.kind, "-{0}", self)

    def __abs__(self):
        return TRACE.abs(self)


def _identity(symbol, a, b):
    """``a`` or ``b`` where ``a symbol b`` is it bit for bit (``x * 1.0``, ``x / 1.0``, ``x - 0.0``, ``x + -0.0``)."""
    for x, c, left in ((a, b, True), (b, a, False)):
        if not isinstance(x, _Sym) or x.kind != "float" or isinstance(c, _Sym) or _kind(c) != "float":
            continue
        if symbol == "*" and c == 1 or symbol == "/" and left and c == 1:
            return x
        if symbol == "-" and left and c == 0 and math.copysign(1.0, c) > 0:
            return x
        if symbol == "+" and c == 0 and math.copysign(1.0, c) < 0:
            return x
    return None


def _operator(symbol, result):
    """The method and the reflected method of a binary operator (``result``: kinds -> kind of the result)."""
    template = f"{{0}} {symbol} {{1}}"

    def apply(a, b):
        same = _identity(symbol, a, b)
        if same is not None:
            return same
        tape = (a if isinstance(a, _Sym) else b).tape
        return tape.record(result(_kind(a), _kind(b)), template, a, b, raises=symbol == "/" and (
            isinstance(b, _Sym) or b == 0))

    return apply, lambda self, other: apply(other, self)


def _arithmetic(x, y):
    return "float" if x == y == "float" else "other"


def _logic(x, y):
    return "bool" if x == y == "bool" else "other"


for _symbol, _names, _result in (("+", "add", _arithmetic), ("-", "sub", _arithmetic), ("*", "mul", _arithmetic),
                                 ("/", "truediv", _arithmetic), ("&", "and", _logic), ("|", "or", _logic)):
    _method, _reflected = _operator(_symbol, _result)
    setattr(_Sym, f"__{_names}__", _method)
    setattr(_Sym, f"__r{_names}__", _reflected)
for _symbol, _name in (("<", "lt"), ("<=", "le"), (">", "gt"), (">=", "ge"), ("==", "eq"), ("!=", "ne")):
    setattr(_Sym, f"__{_name}__", _operator(_symbol, lambda x, y: "bool")[0])


class _Tape:
    """The operations of one trace, in order: ``ops`` holds ``(symbol, template, args, raises)``."""

    def __init__(self):
        self.n, self.ops, self.defs, self.memo = 0, [], {}, {}

    def symbol(self, kind):
        """A new value: an input, or what an operation computes."""
        self.n += 1
        return _Sym(self, self.n - 1, kind)

    def record(self, kind, template, *args, raises=False):
        """The value of ``template`` formatted with ``args`` (the same operation on the same operands: once)."""
        key = (template, *((a.i,) if isinstance(a, _Sym) else (type(a), repr(a)) for a in args))
        out = self.memo.get(key)
        if out is None:
            out = self.memo[key] = self.symbol(kind)
            self.ops.append((out, template, args, raises or template.startswith(_RAISING)))
            self.defs[out.i] = (template, args)
        return out


def _function(name, template, result):
    """A member of :data:`TRACE`: the FLOATS function on constants, else a recorded operation."""
    floats = getattr(FLOATS, name)

    def traced(*args):
        sym = next((a for a in args if isinstance(a, _Sym)), None)
        if sym is None or name == "where" and not isinstance(args[0], _Sym):
            return floats(*args)
        return sym.tape.record(result(*map(_kind, args)), template, *args)

    return traced


def _choice(*kinds):
    """The kind of a value chosen among values of ``kinds``."""
    return kinds[0] if len(set(kinds)) == 1 else "other"


#: the FLOATS members on symbols (the same formulas recorded instead of evaluated)
TRACE = SimpleNamespace(
    sqrt=_function("sqrt", "_sqrt({0})", lambda x: "float"),
    arctan2=_function("arctan2", "_atan2({0}, {1})", lambda y, x: "float"),
    arccos=_function("arccos", "_acos({0})", lambda x: "float"),
    cos=_function("cos", "_cos({0})", lambda x: "float"),
    sin=_function("sin", "_sin({0})", lambda x: "float"),
    tan=_function("tan", "_tan({0})", lambda x: "float"),
    abs=_function("abs", "_abs({0})", lambda x: "float" if x == "float" else "other"),
    hypot=_function("hypot", "_hypot({0}, {1})", lambda x, y: "float"),
    where=_function("where", "{1} if {0} else {2}", lambda c, a, b: _choice(a, b)),
    clip=_function("clip", "{1} if {0} < {1} else {2} if {0} > {2} else {0}", _choice),
    maximum=_function("maximum", "{0} if {0} >= {1} else {1}", _choice),
    minimum=_function("minimum", "{0} if {0} <= {1} else {1}", _choice),
    logical_not=_function("logical_not", "not {0}", lambda c: "bool"),
    isfinite=_function("isfinite", "_isfinite({0})", lambda x: "bool"),
    wrap=_function("wrap", "_wrap({0})", lambda x: "float"),
    per_branch=FLOATS.per_branch, batch=False,
)


def _inputs(tape, shape):
    """Symbols for one argument of ``shape`` (``()``: a float, ``(k,)``: a list, ``(k, l)``: nested lists) and the
    generated code's name or unpacking target for it."""
    if not shape:
        s = tape.symbol("float")
        return s, f"v{s.i}"
    inner = [_inputs(tape, shape[1:]) for _ in range(shape[0])]
    return [sym for sym, _ in inner], "(" + ", ".join(text for _, text in inner) + ",)"


def _generate(fn, shapes, label, stages=False):
    """Trace ``fn(TRACE, *args)`` for arguments of ``shapes`` and compile it: ``(function, source)``; raises when
    it cannot be traced. With ``stages``, ``fn`` returns a list and the function is a generator yielding its
    items in turn, each computed when asked for (see :func:`compiled`)."""
    tape = _Tape()
    inputs = [_inputs(tape, shape) for shape in shapes]
    result = fn(TRACE, *(sym for sym, _ in inputs))
    outputs = list(result) if stages else [result]
    bound, live = {}, set()

    def name(v):
        if isinstance(v, _Sym):
            return f"v{v.i}"
        if type(v) in (float, int, bool) and math.isfinite(v):
            return repr(v) if v >= 0 or type(v) is bool else f"({v!r})"
        bound[f"_k{len(bound)}"] = v  # inf, nan, numpy scalars: as they are
        return f"_k{len(bound) - 1}"

    def render(v):
        if isinstance(v, (list, tuple)):
            inner = ", ".join(render(x) for x in v) + ("," if type(v) is tuple and len(v) == 1 else "")
            return f"[{inner}]" if type(v) is list else f"({inner})"
        if isinstance(v, _Sym):
            live.add(v.i)
        elif _kind(v) == "other":
            raise _Untraceable(f"{label} returns a {type(v).__name__}")
        return name(v)

    returned = []
    for out in outputs:
        before = set(live)
        returned.append((render(out), live - before))
    ops, uses = [], dict.fromkeys(live, 2)  # (a returned value keeps its name)
    for op in reversed(tape.ops):  # drop what neither the result nor a raise needs
        sym, template, args, raises = op
        if sym.i in uses or raises:
            ops.append(op)
            for k, a in enumerate(args):
                if isinstance(a, _Sym):
                    uses[a.i] = uses.get(a.i, 0) + template.count(f"{{{k}}}")
    ops.reverse()
    stage = _stages(ops, [roots for _, roots in returned])
    ops.sort(key=lambda op: (stage[op[0].i], op[0].i))  # (tape order within a stage: operands first)
    body, inline, k = [], {}, 0
    for sym, template, args, raises in ops:
        while stages and stage[sym.i] > k:
            body.append(f"    yield {returned[k][0]}")
            k += 1
        text = template.format(*(f"({inline.pop(a.i)})" if isinstance(a, _Sym) and a.i in inline else name(a)
                                 for a in args))
        if not raises and uses.get(sym.i) == 1:
            inline[sym.i] = text  # a value read once, by an operation that cannot raise: written where it is read
        else:
            body.append(f"    v{sym.i} = {text}")
    if stages:
        body += [f"    yield {text}" for text, _ in returned[k:]]
    else:
        body.append(f"    return {returned[0][0]}")
    used = [f for f in _FUNCTIONS if any(f + "(" in line for line in body)]
    bound.update({f: _FUNCTIONS[f] for f in used})
    params = [text if not shape else f"a{k}" for k, ((_, text), shape) in enumerate(zip(inputs, shapes))]
    unpack = [f"    {text} = a{k}" for k, ((_, text), shape) in enumerate(zip(inputs, shapes)) if shape]
    signature = ", ".join(params + [f"{k}={k}" for k in bound])
    source = "\n".join([f"def compiled({signature}):", *unpack, *body])
    namespace = dict(bound)
    exec(compile(source, f"<labkit {label}, {len(ops)} operations>", "exec"), namespace)
    return namespace["compiled"], source


def _stages(ops, roots):
    """Per operation the first output that needs it (``{symbol index: stage}``): operations of output ``k``'s
    values not already computed for an earlier one; those nothing needs (kept because they can raise) in the
    first."""
    deps = {sym.i: [a.i for a in args if isinstance(a, _Sym)] for sym, _, args, _ in ops}
    needed = set()
    stack = [i for r in roots for i in r]
    while stack:
        i = stack.pop()
        if i in deps and i not in needed:
            needed.add(i)
            stack += deps[i]
    roots = [set(r) for r in roots] or [set()]
    roots[0] |= {i for i in deps if i not in needed}
    stage = {}
    for k, r in enumerate(roots):
        stack = list(r)
        while stack:
            i = stack.pop()
            if i in deps and i not in stage:
                stage[i] = k
                stack += deps[i]
    return stage


def compiled(fn, shapes, label, stages=False):
    """``fn(FLOATS, *args)`` as one generated straight-line function of ``args``, or None where it cannot be traced.

    Parameters
    ----------
    fn : callable
        ``fn(xp, *args)``, formulas written against an array namespace.
    shapes : tuple of tuple
        Per argument its nesting: ``()`` a float, ``(3,)`` a list of 3, ``(4, 4)`` 4 lists of 4.
    label : str
        Names the generated code (``<labkit {label}, N operations>``).
    stages : bool
        ``fn`` returns a list whose items can be computed one by one (the
        branches of a family ...): the function is then a generator yielding
        them in turn, each item's operations run only when it is asked for
        (those of an earlier item first; operations nothing needs but that can
        raise, first of all).

    Returns
    -------
    callable or None
        Taking the arguments as floats / nested lists of floats, returning
        bit for bit what ``fn(FLOATS, *args)`` returns (raising where it
        raises), or with ``stages`` yielding its items so (an item not asked
        for is not computed, nor does it raise).
    """
    try:
        return _generate(fn, shapes, label, stages)[0]
    except Exception:  # anything tracing cannot record: the interpretive path computes (or raises) it
        return None
