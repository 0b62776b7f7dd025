"""The values a check reads, handed from the student's kernel to the checker as plain data.

At each check of a graded notebook the student's kernel runs, instead of the check,
``export(globals(), names, key)`` (:func:`export_source`): the values of the names the
check reads go out as one JSON document (a display output of a private MIME type).
Only data crosses: ``None``, booleans, numbers, strings, lists, tuples, dicts with
string keys, numpy arrays and scalars of a numeric or boolean dtype, paths, enums,
pandas tables, exceptions (type name and data arguments) and frozen dataclasses of
labkit (class name and data fields; a field holding behaviour, such as a resampling
function, is left to its default). Modules, functions, classes and every other object
are left out: the checker takes those from the instructor's own imports and
definitions. :func:`decode` rebuilds the values in the checker with the instructor's
code: a dataclass or exception class is looked up by name among labkit's (and
builtins') classes only, never run from the data.

Nothing here is trusted by the grader: the student's code may patch this module in its
kernel, and then only hands out different data, which is all it could do anyway.

Example
-------
>>> import numpy as np
>>> from labkit.course._wire import decode, encode
>>> doc = encode({"x": 0.5, "q": np.arange(3.0), "f": print})
>>> sorted(doc)
['q', 'x']
>>> decode(doc)["q"]
array([0., 1., 2.])
"""

from __future__ import annotations

import base64
import dataclasses
import enum
import importlib
import json
import math
from pathlib import PurePath

__all__ = ["MIME", "MAX_EXPORT_BYTES", "encode", "decode", "dumps", "loads", "export", "export_source"]

#: the MIME type of the data output an export step prints
MIME = "application/x-labkit-check-data"
#: largest export accepted from one check point [bytes of JSON]
MAX_EXPORT_BYTES = 32 * 2**20
#: modules whose classes may be rebuilt from data (dataclasses, enums, exceptions): labkit's and builtins
_NUMERIC_KINDS = "biufc"
_DEPTH = 40


class _Skip(Exception):
    """The value is not plain data."""


def _ours(module) -> bool:
    module = str(module)
    return module in ("builtins", "labkit") or module.startswith("labkit.")


def _qualified(cls) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


def _enc(value, depth):
    if depth > _DEPTH:
        raise _Skip
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, enum.Enum):
        if not _ours(type(value).__module__):
            raise _Skip
        return {"__enum__": _qualified(type(value)), "value": _enc(value.value, depth + 1)}
    if isinstance(value, int):
        return int(value)
    if isinstance(value, float):
        return float(value) if math.isfinite(value) else {"__float__": repr(float(value))}
    if isinstance(value, complex):
        return {"__complex__": [_enc(value.real, depth), _enc(value.imag, depth)]}
    if isinstance(value, (list, tuple)):
        items = [_enc(v, depth + 1) for v in value]
        return items if type(value) is list else {"__tuple__": items}
    if isinstance(value, dict):
        if not all(isinstance(k, str) for k in value):
            raise _Skip
        return {"__dict__": {k: _enc(v, depth + 1) for k, v in value.items()}}
    if isinstance(value, PurePath):
        return {"__path__": str(value)}
    kind = type(value).__module__.split(".")[0]
    if kind == "numpy":
        return _enc_numpy(value)
    if kind == "pandas":
        return _enc_pandas(value, depth)
    if isinstance(value, BaseException):
        if not _ours(type(value).__module__):
            raise _Skip
        return {"__exception__": _qualified(type(value)), "args": [_enc(a, depth + 1) for a in value.args]}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        cls = type(value)
        if cls.__module__.startswith("labkit.reports"):  # Checks and its rows: the checker has its own
            raise _Skip
        if not cls.__module__.startswith("labkit."):
            raise _Skip
        fields = {}
        for f in dataclasses.fields(value):
            if not f.init:
                continue
            try:
                fields[f.name] = _enc(getattr(value, f.name), depth + 1)
            except _Skip:  # behaviour (a callable field): left to its default, if it has one
                if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                    raise
        return {"__dataclass__": _qualified(cls), "fields": fields}
    raise _Skip


def _enc_numpy(value):
    import numpy as np

    if isinstance(value, np.generic):
        if value.dtype.kind not in _NUMERIC_KINDS:
            raise _Skip
        return {"__scalar__": value.dtype.str, "data": base64.b64encode(value.tobytes()).decode()}
    if not isinstance(value, np.ndarray) or value.dtype.kind not in _NUMERIC_KINDS:
        raise _Skip
    return {"__ndarray__": value.dtype.str, "shape": list(value.shape),
            "data": base64.b64encode(np.ascontiguousarray(value).tobytes()).decode()}


def _enc_pandas(value, depth):
    import pandas as pd

    if isinstance(value, pd.Series):
        return {"__series__": {"index": _enc(value.index.tolist(), depth + 1),
                               "values": _enc(value.tolist(), depth + 1), "name": _enc(value.name, depth + 1)}}
    if isinstance(value, pd.DataFrame):
        return {"__dataframe__": {"index": _enc(value.index.tolist(), depth + 1),
                                  "columns": _enc(value.columns.tolist(), depth + 1),
                                  "values": _enc([list(r) for r in value.itertuples(index=False)], depth + 1)}}
    raise _Skip


def encode(namespace) -> dict:
    """The plain-data part of a namespace: ``{name: JSON-ready value}`` (other values are left out).

    Parameters
    ----------
    namespace : dict
        Names and values (a kernel's ``globals()`` restricted to the names a check reads).

    Returns
    -------
    dict
        Only the names whose values are plain data (see the module docstring).
    """
    out = {}
    for name, value in namespace.items():
        try:
            out[name] = _enc(value, 0)
        except (_Skip, RecursionError, TypeError, ValueError, AttributeError):
            continue
    return out


def _class(qualified, base=None):
    module, _, qualname = str(qualified).partition(":")
    if not _ours(module) or not qualname:
        raise _Skip
    obj = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    if not isinstance(obj, type) or (base is not None and not issubclass(obj, base)):
        raise _Skip
    return obj


def _dec(doc, depth):
    if depth > _DEPTH:
        raise _Skip
    if doc is None or isinstance(doc, (bool, int, float, str)):
        return doc
    if isinstance(doc, list):
        return [_dec(v, depth + 1) for v in doc]
    if not isinstance(doc, dict) or len(doc) == 0:
        raise _Skip
    if "__tuple__" in doc:
        return tuple(_dec(v, depth + 1) for v in doc["__tuple__"])
    if "__dict__" in doc:
        return {str(k): _dec(v, depth + 1) for k, v in dict(doc["__dict__"]).items()}
    if "__float__" in doc:
        return float(str(doc["__float__"]))
    if "__complex__" in doc:
        re, im = doc["__complex__"]
        return complex(_dec(re, depth + 1), _dec(im, depth + 1))
    if "__path__" in doc:
        from pathlib import Path

        return Path(str(doc["__path__"]))
    if "__ndarray__" in doc or "__scalar__" in doc:
        import numpy as np

        dtype = np.dtype(str(doc.get("__ndarray__", doc.get("__scalar__"))))
        if dtype.kind not in _NUMERIC_KINDS:
            raise _Skip
        raw = base64.b64decode(str(doc["data"]))
        if "__scalar__" in doc:
            return np.frombuffer(raw, dtype=dtype, count=1)[0]
        shape = tuple(int(n) for n in doc["shape"])
        return np.frombuffer(raw, dtype=dtype).reshape(shape).copy()
    if "__series__" in doc:
        import pandas as pd

        d = doc["__series__"]
        return pd.Series(_dec(d["values"], depth + 1), index=_dec(d["index"], depth + 1), name=_dec(d["name"], depth))
    if "__dataframe__" in doc:
        import pandas as pd

        d = doc["__dataframe__"]
        return pd.DataFrame(_dec(d["values"], depth + 1), index=_dec(d["index"], depth + 1),
                            columns=_dec(d["columns"], depth + 1))
    if "__enum__" in doc:
        return _class(doc["__enum__"], enum.Enum)(_dec(doc["value"], depth + 1))
    if "__exception__" in doc:
        cls = _class(doc["__exception__"], BaseException)
        args = [_dec(a, depth + 1) for a in doc.get("args", [])]
        try:
            return cls(*args)
        except Exception:
            exc = cls.__new__(cls)
            exc.args = tuple(args)
            return exc
    if "__dataclass__" in doc:
        cls = _class(doc["__dataclass__"])
        if not dataclasses.is_dataclass(cls) or not cls.__module__.startswith("labkit."):
            raise _Skip
        fields = {f.name for f in dataclasses.fields(cls) if f.init}
        given = dict(doc.get("fields", {}))
        if not set(given) <= fields:
            raise _Skip
        return cls(**{k: _dec(v, depth + 1) for k, v in given.items()})
    raise _Skip


def decode(doc) -> dict:
    """Rebuild the values of :func:`encode`'s document; a value that does not rebuild is left out.

    Parameters
    ----------
    doc : dict
        ``{name: JSON value}`` as received (untrusted).

    Returns
    -------
    dict
        ``{name: value}``.
    """
    out = {}
    if not isinstance(doc, dict):
        return out
    for name, value in doc.items():
        if not isinstance(name, str) or not name.isidentifier():
            continue
        try:
            out[name] = _dec(value, 0)
        except Exception:  # untrusted data: whatever does not rebuild is simply absent
            continue
    return out


def dumps(doc) -> str:
    """JSON text of an encoded document.

    Parameters
    ----------
    doc : dict
        From :func:`encode` (or a wrapper holding it).

    Returns
    -------
    str
    """
    return json.dumps(doc, separators=(",", ":"), allow_nan=False)


def loads(text):
    """Parse an untrusted JSON document.

    Parameters
    ----------
    text : str
        At most :data:`MAX_EXPORT_BYTES` characters.

    Returns
    -------
    object or None
        The parsed document; None if it is not text, not JSON or too large.
    """
    if not isinstance(text, str) or len(text) > MAX_EXPORT_BYTES:
        return None
    try:
        return json.loads(text)
    except (ValueError, RecursionError):
        return None


def export(namespace, names, key):
    """Kernel side: display the plain-data values of ``names`` (one output of type :data:`MIME`).

    Parameters
    ----------
    namespace : dict
        The kernel's ``globals()``.
    names : sequence of str
        The names the check reads.
    key : str
        The check's cell id (echoed, for the record).
    """
    try:
        from IPython.display import publish_display_data

        values = {n: namespace[n] for n in names if n in namespace}
        text = dumps({"key": str(key), "values": encode(values)})
        if len(text) > MAX_EXPORT_BYTES:
            text = dumps({"key": str(key), "values": {}, "error": "export too large"})
        publish_display_data({MIME: text, "text/plain": f"[values for the check {key} handed to the grader]"})
    except Exception:  # never raise in the student's notebook
        pass


def export_source(names, key) -> str:
    """The code cell that replaces a check in the student's kernel.

    Parameters
    ----------
    names : sequence of str
        Names the check reads.
    key : str
        The check's cell id.

    Returns
    -------
    str
        Python source.
    """
    return (f"# labkit grade: the values this check reads go to the grader\n"
            f"__import__('labkit.course._wire', fromlist=['export']).export(globals(), {sorted(names)!r}, {key!r})")
