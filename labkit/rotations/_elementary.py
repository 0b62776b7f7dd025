"""Elementary rotations, their composition in moving and fixed frames, angle wrapping (batched).

All angles are in radians and matrices have shape ``(..., 3, 3)``; every
function broadcasts over leading batch dimensions.

Two readings of a sequence of elementary rotations
---------------------------------------------------
* **moving (current) frame** - each rotation is about an axis of the frame
  produced by the previous rotations: the matrices are *post*-multiplied,
  ``R = R_1 R_2 ... R_k`` (:func:`compose_moving_frame`);
* **fixed frame** - each rotation is about an axis of the fixed (reference)
  frame: the matrices are *pre*-multiplied, ``R = R_k ... R_2 R_1``
  (:func:`compose_fixed_frame`).

Rotating about ``x`` then ``y`` in the moving frame gives the same matrix as
rotating about ``y`` then ``x`` in the fixed frame.

Euler and roll-pitch-yaw angle sets are in ``_euler.py``, matrix checks in
``_matrix.py``; :mod:`labkit.rotations` re-exports all of them.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.validation import as_batch
from labkit.exceptions import OptionError, ShapeError

__all__ = [
    "rotation_x",
    "rotation_y",
    "rotation_z",
    "rotation_about",
    "compose_moving_frame",
    "compose_fixed_frame",
    "wrap_angle",
]

_AXES = {"x": 0, "y": 1, "z": 2}


def _elementary(angle, axis):
    angle = as_batch(angle, (), "angle")
    c, s = np.cos(angle), np.sin(angle)
    R = np.zeros(angle.shape + (3, 3))
    i, j = {0: (1, 2), 1: (2, 0), 2: (0, 1)}[axis]
    R[..., axis, axis] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


def rotation_x(angle):
    """Rotation about the x axis.

    Parameters
    ----------
    angle : array_like, shape (...)
        Rotation angle [rad].

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Examples
    --------
    >>> import numpy as np
    >>> np.round(rotation_x(np.pi / 2), 6)[1:, 1:]
    array([[ 0., -1.],
           [ 1.,  0.]])
    """
    return _elementary(angle, 0)


def rotation_y(angle):
    """Rotation about the y axis.

    Parameters
    ----------
    angle : array_like, shape (...)
        Rotation angle [rad].

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Examples
    --------
    >>> float(rotation_y(0.3)[0, 2]) == float(np.sin(0.3))
    True
    """
    return _elementary(angle, 1)


def rotation_z(angle):
    """Rotation about the z axis.

    Parameters
    ----------
    angle : array_like, shape (...)
        Rotation angle [rad].

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Examples
    --------
    >>> float(rotation_z(0.3)[1, 0]) == float(np.sin(0.3))
    True
    """
    return _elementary(angle, 2)


def _axis_index(axis):
    key = str(axis).lower()
    if key not in _AXES:
        raise OptionError(f"expected an axis 'x', 'y' or 'z', got {axis!r}")
    return _AXES[key]


def rotation_about(axis, angle):
    """Elementary rotation about a named axis.

    Parameters
    ----------
    axis : {"x", "y", "z"}
        Rotation axis.
    angle : array_like, shape (...)
        Rotation angle [rad].

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Examples
    --------
    >>> np.allclose(rotation_about("y", 0.2), rotation_y(0.2))
    True
    """
    return _elementary(angle, _axis_index(axis))


def _sequence(sequence, angles):
    if not isinstance(sequence, (str, list, tuple)):
        raise OptionError(f"expected a sequence of axes such as 'zyx' or ('z', 'y', 'x'), got {sequence!r}")
    axes = [_axis_index(a) for a in sequence]
    if not axes:
        raise ShapeError("expected a non-empty sequence of axes such as 'zyx', got an empty one")
    angles = as_batch(angles, (len(axes),), "angles")
    return axes, angles


def compose_moving_frame(sequence, angles):
    """Compose elementary rotations about the axes of the *moving* (current) frame.

    Each rotation is about an axis of the frame obtained after the previous
    ones, so the matrices are post-multiplied:
    ``R = R_{s1}(angles[0]) @ R_{s2}(angles[1]) @ ...``.

    Parameters
    ----------
    sequence : str or sequence of {"x", "y", "z"}
        Axes in the order the rotations are performed, e.g. ``"zyz"`` or
        ``("y", "x", "z")``.
    angles : array_like, shape (..., k)
        One angle per axis [rad], ``k = len(sequence)``.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Raises
    ------
    ValueError
        For an unknown axis name; :class:`~labkit.exceptions.ShapeError` if
        ``angles`` does not end in ``k``.

    Examples
    --------
    Seed 002 problem 1(a): pi/4 about x, then pi/6 about the new y axis.

    >>> np.round(compose_moving_frame("xy", [np.pi / 4, np.pi / 6]), 4)
    array([[ 0.866 ,  0.    ,  0.5   ],
           [ 0.3536,  0.7071, -0.6124],
           [-0.3536,  0.7071,  0.6124]])
    """
    axes, angles = _sequence(sequence, angles)
    R = _elementary(angles[..., 0], axes[0])
    for k in range(1, len(axes)):
        R = R @ _elementary(angles[..., k], axes[k])
    return R


def compose_fixed_frame(sequence, angles):
    """Compose elementary rotations about the axes of the *fixed* (reference) frame.

    Each rotation is about an axis of the fixed frame, so the matrices are
    pre-multiplied: ``R = ... @ R_{s2}(angles[1]) @ R_{s1}(angles[0])``.

    Parameters
    ----------
    sequence : str or sequence of {"x", "y", "z"}
        Axes in the order the rotations are performed.
    angles : array_like, shape (..., k)
        One angle per axis [rad].

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Examples
    --------
    Seed 002 problem 1(a) read in the fixed frame: pi/6 about y, then pi/4
    about the fixed x axis (the same matrix as ``compose_moving_frame("xy", ...)``).

    >>> R = compose_fixed_frame("yx", [np.pi / 6, np.pi / 4])
    >>> np.allclose(R, compose_moving_frame("xy", [np.pi / 4, np.pi / 6]))
    True
    """
    axes, angles = _sequence(sequence, angles)
    R = _elementary(angles[..., 0], axes[0])
    for k in range(1, len(axes)):
        R = _elementary(angles[..., k], axes[k]) @ R
    return R


_TWO_PI = 2 * math.pi
_INV_TWO_PI = 1.0 / (2 * math.pi)
_PI = math.pi
#: floats in (_INSIDE, pi] are already wrapped: the formula of :func:`_wrap` takes no turn off them and
#: returns them unchanged, bit for bit (its ceil is 0 there with a margin; near -pi it decides)
_INSIDE = -3.14


def wrap_angle(angle):
    """Wrap angles to ``(-pi, pi]``.

    Parameters
    ----------
    angle : array_like, shape (...)
        Angles [rad].

    Returns
    -------
    wrapped : ndarray, shape (...), or float
        A float for a float ``angle``.

    Examples
    --------
    >>> float(wrap_angle(-np.pi)) == float(np.pi)
    True
    """
    if isinstance(angle, float):  # one angle: the same formula on a float (no array round trip)
        if _INSIDE < angle <= _PI:  # (most angles: returned as the formula would, without computing it)
            return angle
        return _wrap(angle, math.ceil)
    return _wrap(as_batch(angle, (), "angle", finite=False), np.ceil)


def _wrap(a, ceil):
    """``a`` less its whole turns above (-pi, pi] (``ceil``: math.ceil for a float, np.ceil for arrays).

    The turns are ``ceil((a - pi) / 2 pi)``. Where rounding made that one too few or one too many (a float
    just above -pi came out just above pi; one next to a far odd multiple of pi, at or below -pi), one turn
    is added or taken back: from ``a`` (so an angle already inside stays bit for bit), or, where that rounds
    outside again, from the first result (``w -+ 2 pi``, exact there: it lies between pi and 2 pi).
    """
    if ceil is math.ceil:
        k = ceil((a - _PI) * _INV_TWO_PI)
        w = a - _TWO_PI * k
        if -_PI < w <= _PI:
            return w
        v = a - _TWO_PI * (k + 1 if w > _PI else k - 1)
        return v if -_PI < v <= _PI else (w - _TWO_PI if w > _PI else w + _TWO_PI)
    w = a - _TWO_PI * ceil((a - _PI) * _INV_TWO_PI)
    if w.size == 0 or (w.max() <= _PI and w.min() > -_PI):  # (the usual case: two reductions, no temporaries)
        return w
    k = ceil((a - _PI) * _INV_TWO_PI)
    over, under = w > _PI, w <= -_PI
    v = a - _TWO_PI * (k + over - under)
    v = np.where((v > -_PI) & (v <= _PI), v, np.where(over, w - _TWO_PI, w + _TWO_PI))
    return np.where(over | under, v, w)
