"""Input checks shared by the public entry points (private)."""

from __future__ import annotations

import numpy as np

from labkit.exceptions import ShapeError


def as_batch(x, last, name, *, finite=True):
    """Return ``x`` as a float array of shape ``(..., *last)``.

    Parameters
    ----------
    x : array_like
        Input.
    last : tuple of int
        Required trailing shape.
    name : str
        Argument name used in the error message.
    finite : bool
        Reject NaN/inf values.

    Returns
    -------
    ndarray, shape (..., *last)
        ``x`` as floats (``np.asarray``: no copy when it already is one).

    Raises
    ------
    ShapeError
        With the expected and the received shape.
    """
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ShapeError(f"expected {name} as numbers, got {x!r} ({exc})") from None
    last = tuple(last)
    k = len(last)
    if arr.ndim < k or arr.shape[arr.ndim - k:] != last:
        want = "(..., " + ", ".join(str(v) for v in last) + ")"
        raise ShapeError(f"expected {name} with shape {want}, got {arr.shape}")
    if finite and not np.isfinite(arr).all():
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ShapeError(
            f"expected finite {name}, got a non-finite value at index {tuple(int(i) for i in bad)}"
        )
    return arr


def as_vector(x, n, name, *, finite=True):
    """Return ``x`` as a float array of shape ``(..., n)``.

    Parameters
    ----------
    x : array_like
        Input.
    n : int
        Required length of the last axis.
    name : str
        Argument name used in the error message.
    finite : bool
        Reject NaN/inf values.

    Returns
    -------
    ndarray, shape (..., n)
        ``x`` as floats.

    Raises
    ------
    ShapeError
        With the expected and the received shape.
    """
    return as_batch(x, (n,), name, finite=finite)


def readonly(a):
    """A float copy of ``a`` that cannot be written to (``None`` stays ``None``).

    Frozen dataclasses holding arrays store them through this, so that
    ``result.q[0] = 1`` raises instead of silently mutating a "frozen" result.

    Parameters
    ----------
    a : array_like or None
        Values to copy.

    Returns
    -------
    ndarray or None
        A read-only float copy of ``a``; ``None`` when ``a`` is ``None``.
    """
    if a is None:
        return None
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a
