"""Elementwise functions the closed-form families write their formulas with (private).

A family's formulas run on the components of its targets: ``(N,)`` numpy rows
for a batch, Python floats for one target
(:func:`labkit.kinematics._ik_solvers._solve.solve`). NumPy's functions take
both, but on a float they return a numpy scalar and cost 0.2-2 us a call
(``np.clip`` 5 us), and every later operation on that scalar costs several
times a float operation: one target's solution then costs far more than its
arithmetic. Each function here is the numpy function of the same name, except
that on Python floats (bools for :func:`where`) it returns what :mod:`math`
(or a conditional expression) returns, a Python float, so one target stays on
floats from its components to its joint values. The formulas stay written
once; only which library evaluates an elementwise function depends on the
argument's type.

On floats the functions agree with numpy's to the last unit or two (the
platform's ``libm`` against numpy's own SIMD loops); a value numpy would turn
into ``nan`` or ``inf`` with a warning (``sqrt`` of a negative number, ``sin``
of infinity) raises ``ValueError`` or ``ArithmeticError`` on floats, and the
caller then runs the target again on numpy scalars
(:func:`labkit.kinematics._ik_solvers._solve.solve`).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["sqrt", "sin", "cos", "arctan2", "where", "maximum", "minimum", "clip"]


def sqrt(x):
    """``np.sqrt(x)``; a float for a float.

    Parameters
    ----------
    x : ndarray or float
        Non-negative values.

    Returns
    -------
    ndarray or float
    """
    return math.sqrt(x) if type(x) is float else np.sqrt(x)


def sin(x):
    """``np.sin(x)``; a float for a float.

    Parameters
    ----------
    x : ndarray or float
        Angles [rad].

    Returns
    -------
    ndarray or float
    """
    return math.sin(x) if type(x) is float else np.sin(x)


def cos(x):
    """``np.cos(x)``; a float for a float.

    Parameters
    ----------
    x : ndarray or float
        Angles [rad].

    Returns
    -------
    ndarray or float
    """
    return math.cos(x) if type(x) is float else np.cos(x)


def arctan2(y, x):
    """``np.arctan2(y, x)``; a float for two floats.

    Parameters
    ----------
    y, x : ndarray or float
        Coordinates.

    Returns
    -------
    ndarray or float
        The angle of ``(x, y)`` [rad] in [-pi, pi].
    """
    return math.atan2(y, x) if type(y) is float and type(x) is float else np.arctan2(y, x)


def where(condition, a, b):
    """``np.where(condition, a, b)``; for a Python bool ``condition``, ``a`` or ``b`` itself.

    Parameters
    ----------
    condition : ndarray of bool or bool
        Where to take ``a``.
    a, b : ndarray or float
        The values taken where ``condition`` holds, and elsewhere.

    Returns
    -------
    ndarray or float
    """
    return (a if condition else b) if type(condition) is bool else np.where(condition, a, b)


def maximum(a, b):
    """``np.maximum(a, b)`` (a nan in either argument is the result); a float for two floats.

    Parameters
    ----------
    a, b : ndarray or float
        The values compared.

    Returns
    -------
    ndarray or float
    """
    if type(a) is float and type(b) is float:
        return a if a >= b or a != a else b
    return np.maximum(a, b)


def minimum(a, b):
    """``np.minimum(a, b)`` (a nan in either argument is the result); a float for two floats.

    Parameters
    ----------
    a, b : ndarray or float
        The values compared.

    Returns
    -------
    ndarray or float
    """
    if type(a) is float and type(b) is float:
        return a if a <= b or a != a else b
    return np.minimum(a, b)


def clip(x, lo, hi):
    """``np.clip(x, lo, hi)``; a float for a float.

    Parameters
    ----------
    x : ndarray or float
        The values clipped.
    lo, hi : float
        Constant bounds, ``lo <= hi``.

    Returns
    -------
    ndarray or float
    """
    if type(x) is float:
        return lo if x < lo else hi if x > hi else x
    return np.clip(x, lo, hi)
