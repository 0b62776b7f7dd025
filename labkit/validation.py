"""Input checks shared by the public entry points (private)."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from labkit.exceptions import OptionError, RobotError, ShapeError, TrajectoryError


def as_batch(x, last, name, *, finite=True, batch=True, bools=False):
    """Return ``x`` as a float array of shape ``(..., *last)`` (``batch=False``: exactly ``last``).

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
    batch : bool
        Accept leading batch dimensions.
    bools : bool
        Accept booleans (as 0 and 1: a mask).

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
        arr = np.asarray(x)
        why = ("booleans are not numbers" if arr.dtype.kind == "b" and not bools else
               "None is not a number" if arr.dtype.kind == "O" and any(v is None for v in arr.flat) else None)
        if why is None:
            arr = arr.astype(float, copy=False)
    except (TypeError, ValueError) as exc:
        why = str(exc)
    if why is not None:
        raise ShapeError(f"expected {name} as numbers, got {_received(x)} ({why})")
    last = tuple(last)
    k = len(last)
    if arr.ndim < k or arr.shape[arr.ndim - k:] != last or (not batch and arr.ndim != k):
        want = "(" + "..., " * batch + ", ".join(map(str, last)) + "," * (k == 1 and not batch) + ")"
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


def as_number(x, name, *, unit="", positive=False, minimum=None, error=ShapeError):
    """Return ``x`` as one finite float (``True`` and ``False`` are not numbers).

    Parameters
    ----------
    x : float
        Input.
    name : str
        Argument name used in the error message.
    unit : str
        Its unit, shown in the message ("s").
    positive : bool
        Also reject zero and negative values.
    minimum : float or None
        Also reject values below it.
    error : type
        The :class:`~labkit.exceptions.LabkitError` subclass to raise.

    Returns
    -------
    float

    Raises
    ------
    ShapeError (or ``error``)
        With what was expected and what was received.
    """
    what = (f"{name} as a {'positive ' if positive else ''}finite number" + (f" >= {minimum}" if minimum is not None
            else "") + (f" [{unit}]" if unit else ""))
    try:
        out = math.nan if isinstance(x, (bool, np.bool_, str, bytes)) else float(x)
    except (TypeError, ValueError):
        out = math.nan
    if not math.isfinite(out) or (positive and out <= 0.0) or (minimum is not None and out < minimum):
        raise error(f"expected {what}, got {x!r}")
    return out


def _received(x):
    """``repr(x)`` for a message, or its type (and shape) where the repr is long."""
    text = repr(x)
    if len(text) <= 80:
        return text
    shape = getattr(x, "shape", None)
    return f"a {type(x).__name__}" + (f" of shape {tuple(shape)}" if shape is not None else "")


def as_count(x, name, *, minimum=0, maximum=None, error=OptionError):
    """Return ``x`` as an int within ``minimum..maximum`` (``True`` and ``2.5`` are not counts).

    Parameters
    ----------
    x : int
        Input.
    name : str
        Argument name used in the error message.
    minimum, maximum : int or None
        Bounds (inclusive); ``None``: unbounded.
    error : type
        The :class:`~labkit.exceptions.LabkitError` subclass to raise.

    Returns
    -------
    int

    Raises
    ------
    OptionError (or ``error``)
        With what was expected and what was received.
    """
    ok = isinstance(x, (int, np.integer)) and not isinstance(x, (bool, np.bool_))
    if not ok or (minimum is not None and x < minimum) or (maximum is not None and x > maximum):
        span = f"{minimum}..{maximum}" if maximum is not None else f">= {minimum}" if minimum is not None else ""
        raise error(f"expected {name} as an integer {span}".rstrip() + f", got {x!r}")
    return int(x)


def as_seed(seed, name="seed"):
    """Return ``seed`` if numpy's ``default_rng`` takes it: ``None`` (fresh entropy), an int >= 0 or a Generator.

    Parameters
    ----------
    seed : int, numpy.random.Generator or None
        Input.
    name : str
        Argument name used in the error message.

    Returns
    -------
    int, numpy.random.Generator or None

    Raises
    ------
    OptionError
        With what was expected and what was received.
    """
    if seed is None or (not isinstance(seed, (int, np.integer)) and isinstance(seed, np.random.Generator)):
        return seed  # (an int never touches np.random: importing it costs a first ik_numeric 8 ms)
    return as_count(seed, name)


def as_option(x, options, name, *, error=OptionError):
    """Return ``x`` if it is one of the strings ``options``, else an OptionError that lists them.

    Parameters
    ----------
    x : str
        Input.
    options : iterable of str
        The valid values (a mapping: its keys).
    name : str
        Argument name used in the error message.
    error : type
        The :class:`~labkit.exceptions.LabkitError` subclass to raise.

    Returns
    -------
    str

    Raises
    ------
    OptionError (or ``error``)
        With the valid values and what was received.
    """
    if not (isinstance(x, str) and x in options):
        raise error(f"expected {name} as one of {', '.join(map(repr, options))}, got {_received(x)}")
    return x


def as_path(x, name, *, error=OptionError):
    """Return ``x`` as a :class:`pathlib.Path` if it is a ``str`` or ``os.PathLike`` (bytes and numbers are not paths).

    Parameters
    ----------
    x : str or os.PathLike
        Input.
    name : str
        What the path is of, for the message ("the camera file").
    error : type
        The :class:`~labkit.exceptions.LabkitError` subclass to raise.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    OptionError (or ``error``)
        With what was expected and what was received.
    """
    if isinstance(x, str) and x or isinstance(x, os.PathLike) and isinstance(os.fspath(x), str):
        return Path(x)
    raise error(f"expected {name} as a path (str or os.PathLike), got {_received(x)}")


def check_robot(robot, name="robot", *, optional=False):
    """Return ``robot`` if it is a labkit ``Robot`` (``None`` too where ``optional``), else a RobotError.

    Duck-typed on what every robot has (``links``, ``n``, ``joint_limits``), so that this layer
    needs nothing of :mod:`labkit.robot`.

    Parameters
    ----------
    robot : Robot or None
        Input.
    name : str
        Argument name used in the error message.
    optional : bool
        Accept ``None`` ("no robot").

    Returns
    -------
    Robot or None

    Raises
    ------
    RobotError
        With what was expected and what was received.
    """
    if robot is None and optional:
        return None
    if not all(hasattr(robot, attr) for attr in ("links", "n", "joint_limits")):
        hint = " (Robot.load(name) loads a bundled robot or a robot file)" if isinstance(robot, str) else ""
        raise RobotError(f"expected {name} as a labkit Robot{' or None' if optional else ''}{hint}, "
                         f"got {_received(robot)}")
    return robot


def check_trajectory(traj, name="traj", *, error=TrajectoryError):
    """Return ``traj`` if it is a joint trajectory (samples ``t``, ``q``, ``qd``, ``qdd``), else a TrajectoryError.

    Duck-typed, like :func:`check_robot`, so that plotting (below motion) can check one too.

    Parameters
    ----------
    traj : labkit.motion.Trajectory
        Input.
    name : str
        Argument name used in the error message.
    error : type
        The :class:`~labkit.exceptions.LabkitError` subclass to raise.

    Returns
    -------
    Trajectory

    Raises
    ------
    TrajectoryError (or ``error``)
        With what was expected and what was received.
    """
    if not all(hasattr(traj, attr) for attr in ("t", "q", "qd", "qdd", "law")):
        raise error(f"expected {name} as a Trajectory (joint_trajectory, via_trajectory ...), got {_received(traj)}")
    return traj


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
