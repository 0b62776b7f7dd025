"""The machinery of the bad-input sweep of the Python API (tests/test_api_bad_input.py).

A :class:`Call` is one working call of a public function, with the kind of each argument
(``array``, ``number``, ``positive``, ``count``, ``option``, ``robot``, ``object``, ``text``).
:func:`variants` replaces one argument at a time by the bad values of its kind, and
:func:`outcome` runs one variant and names what happened: ``"ok"`` (returned, no NaN),
``"labkit"`` (a LabkitError that says what was expected), or a failure (``"leak: TypeError: ..."``,
``"nan"``, ``"hang"``, ``"unclear: ..."``).
"""

from __future__ import annotations

import dataclasses
import inspect
import math
import signal
import warnings

import numpy as np

from labkit.exceptions import LabkitError

#: seconds one call may take before the sweep calls it a hang
HANG_SECONDS = 10


class _Hang(Exception):
    pass


@dataclasses.dataclass
class Call:
    """A working call ``func(*args, **kwargs)``; ``kinds`` names the kind of each swept argument."""

    name: str
    func: object
    args: tuple
    kwargs: dict
    kinds: dict

    def bound(self):
        return inspect.signature(self.func).bind(*self.args, **self.kwargs)


def call(title, func, *args, kinds, **kwargs):
    """A :class:`Call`; ``kinds`` is ``{"argument": "kind"}`` or a string ``"arg:kind arg:kind"``."""
    if isinstance(kinds, str):
        kinds = dict(item.split(":") for item in kinds.split())
    return Call(title, func, args, kwargs, kinds)


def _array_bads(valid):
    arr = np.asarray(valid, dtype=float)
    out = {}
    if arr.size:
        for label, value in (("nan", math.nan), ("inf", math.inf)):
            bad = arr.copy()
            bad.flat[0] = value
            out[label] = bad
    if arr.ndim >= 1:
        out["scalar"] = 0.5
        out["longer"] = np.concatenate([arr, arr[..., :1]], axis=-1)
    out.update({"ragged": [[1.0], [2.0, 3.0]], "string": "x", "none": None, "dict": {},
                "empty": np.empty((0,)), "bool": True})
    return out


_NUMBER = {"nan": math.nan, "inf": math.inf, "string": "x", "none": None, "dict": {}, "list": [1.0, 2.0],
           "bool": True}
BADS = {
    "array": _array_bads,
    "number": lambda valid: dict(_NUMBER),
    "positive": lambda valid: {**_NUMBER, "zero": 0.0, "negative": -1.0},
    "count": lambda valid: {"nan": math.nan, "string": "x", "none": None, "zero": 0, "negative": -1,
                            "fraction": 2.5, "bool": True},
    "option": lambda valid: {"unknown": "no_such_option", "number": 3, "none": None, "dict": {}},
    "robot": lambda valid: {"unknown": "no_such_robot", "number": 3, "dict": {}, "list": [1.0, 2.0]},
    "object": lambda valid: {"string": "x", "number": 3, "none": None, "dict": {}},
    "text": lambda valid: {"number": 3, "none": None, "list": [1.0]},
}


def variants(c):
    """``(argument, label, call arguments, call keywords)`` for each bad value of each swept argument."""
    params = inspect.signature(c.func).parameters
    names = list(params)
    for arg, kind in c.kinds.items():
        default = params[arg].default if arg in params else inspect.Parameter.empty
        positional = arg in params and arg not in c.kwargs and names.index(arg) < len(c.args)
        valid = c.args[names.index(arg)] if positional else c.kwargs.get(arg, default)
        for label, bad in BADS[kind](valid).items():
            if bad is None and default is None:
                continue  # None is the documented default: "absent"
            if positional:
                args = list(c.args)
                args[names.index(arg)] = bad
                yield arg, label, tuple(args), c.kwargs
            else:
                yield arg, label, c.args, {**c.kwargs, arg: bad}


def _has_nan(out, depth=0):
    if isinstance(out, (float, np.floating)):
        return math.isnan(out)
    if isinstance(out, np.ndarray):
        return out.dtype.kind in "fc" and bool(np.isnan(out).any())
    if isinstance(out, tuple) and depth < 2:
        return any(_has_nan(v, depth + 1) for v in out)
    return False


def _alarm(signum, frame):
    raise _Hang()


def outcome(func, args, kwargs):
    """What one call did: ``"ok"``, ``"labkit"`` or what went wrong (``"leak: ..."``, ``"nan"``...)."""
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(HANG_SECONDS)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out = func(*args, **kwargs)
    except _Hang:
        return "hang"
    except LabkitError as exc:
        return "labkit" if "expect" in str(exc) else f"unclear: {type(exc).__name__}: {exc}"
    except Exception as exc:  # noqa: BLE001 - the sweep names every other exception a leak
        return f"leak: {type(exc).__name__}: {str(exc)[:200]}"
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    return "nan" if _has_nan(out) else "ok"


def sweep(c, accepted, *, nan_passes=(), after=None):
    """Run every bad variant of call ``c``; return what went wrong and the accepted cases that no longer return.

    Parameters
    ----------
    c : Call
        A working call (:func:`call`).
    accepted : dict
        ``(call name, argument) -> (labels, reason)``: variants whose normal return is right.
    nan_passes : set of (str, str), optional
        ``(call name, argument)`` pairs where NaN out of a NaN-labelled variant is right.
    after : callable, optional
        Run after each variant (e.g. closing figures).

    Returns
    -------
    failures : list of str
        ``"name(arg=label): outcome"`` for each variant that was neither a LabkitError nor accepted.
    stale : list of (str, str)
        Accepted ``(arg, label)`` cases of this call that no longer return.
    """
    failures, returned = [], set()
    for arg, label, args, kwargs in variants(c):
        out = outcome(c.func, args, kwargs)
        if after is not None:
            after()
        if out == "labkit":
            continue
        labels, _ = accepted.get((c.name, arg), ((), ""))
        if label in labels and (out == "ok" or (out == "nan" and (c.name, arg) in nan_passes)):
            returned.add((arg, label))
            continue
        failures.append(f"{c.name}({arg}={label}): {out}")
    stale = {(arg, label) for (name, arg), (labels, _) in accepted.items() if name == c.name for label in labels}
    return failures, sorted(stale - returned)
