"""Elementwise functions the closed-form families write their formulas with (private).

A family's formulas run on ``(N,)`` numpy rows for a batch and on Python
floats for one target (:func:`labkit.kinematics._ik_solvers._solve.solve`):
on a float numpy returns a numpy scalar, costs 0.2-2 us a call and slows every
later operation, so each function here is the numpy function of the same name
but returns what :mod:`math` returns on Python floats (bools for :func:`where`).
The results agree with numpy's to a unit or two in the last place; where numpy
would give ``nan`` or ``inf`` the float path raises ``ValueError`` or
``ArithmeticError`` and the caller runs the target again on numpy scalars.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["sqrt", "sin", "cos", "arctan2", "where", "maximum", "minimum", "clip"]


def _unary(name):
    """``np.<name>``, or ``math.<name>`` on a Python float (a public function of this module)."""
    on_arrays, on_floats = getattr(np, name), getattr(math, name)

    def f(x):
        return on_floats(x) if type(x) is float else on_arrays(x)

    f.__name__ = f.__qualname__ = name
    f.__doc__ = f"""``np.{name}(x)``; a float for a float.

    Parameters
    ----------
    x : ndarray or float

    Returns
    -------
    ndarray or float
    """
    return f


sqrt, sin, cos = _unary("sqrt"), _unary("sin"), _unary("cos")


def arctan2(y, x):
    """``np.arctan2(y, x)`` [rad]; a float for two floats.

    Parameters
    ----------
    y, x : ndarray or float

    Returns
    -------
    ndarray or float
    """
    return math.atan2(y, x) if type(y) is float and type(x) is float else np.arctan2(y, x)


def where(condition, a, b):
    """``np.where(condition, a, b)``; ``a`` or ``b`` itself for a Python bool ``condition``.

    Parameters
    ----------
    condition : ndarray of bool or bool
    a, b : ndarray or float

    Returns
    -------
    ndarray or float
    """
    return (a if condition else b) if type(condition) is bool else np.where(condition, a, b)


def maximum(a, b):
    """``np.maximum(a, b)`` (a nan in either is the result); a float for two floats.

    Parameters
    ----------
    a, b : ndarray or float

    Returns
    -------
    ndarray or float
    """
    if type(a) is float and type(b) is float:
        return a if a >= b or a != a else b
    return np.maximum(a, b)


def minimum(a, b):
    """``np.minimum(a, b)`` (a nan in either is the result); a float for two floats.

    Parameters
    ----------
    a, b : ndarray or float

    Returns
    -------
    ndarray or float
    """
    if type(a) is float and type(b) is float:
        return a if a <= b or a != a else b
    return np.minimum(a, b)


def clip(x, lo, hi):
    """``np.clip(x, lo, hi)`` for constant bounds ``lo <= hi``; a float for a float.

    Parameters
    ----------
    x : ndarray or float
    lo, hi : float

    Returns
    -------
    ndarray or float
    """
    if type(x) is float:
        return lo if x < lo else hi if x > hi else x
    return np.clip(x, lo, hi)
