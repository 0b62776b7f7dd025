"""Checks of the host link's arguments (private; used by :class:`labkit.arm.Arm`).

Bad input never reaches the board: a joint vector outside the limits or a servo's range,
a NaN pulse width or timeout, a negative recording time are refused with an error that
says what was expected and what was received.

Examples
--------
>>> finite("seconds", 0.5, lo=0.0)
0.5
>>> finite("us", float("nan"))
Traceback (most recent call last):
...
labkit.exceptions.OptionError: expected us as a finite number, got nan
"""

from __future__ import annotations

import math
import numbers

from labkit.exceptions import JointLimitError, OptionError
from labkit.robot import JointType
from labkit.validation import as_vector
from labkit.arm._protocol import AMAX_MAX, VMAX_MAX, wire_speed_limits

__all__ = []


def finite(name, value, *, lo=None, hi=None, unit=""):
    """``value`` as a float if it is a finite real number within ``lo..hi``.

    Parameters
    ----------
    name : str
        Argument name for the message.
    value : object
        What the caller passed.
    lo, hi : float, optional
        Inclusive bounds.
    unit : str
        Unit shown in the message (``"s"``, ``"us"``).

    Returns
    -------
    float

    Raises
    ------
    OptionError
        Not a real number, not finite, or out of bounds (a ``ValueError``).
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise OptionError(f"expected {name} as a number{' [' + unit + ']' if unit else ''}, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise OptionError(f"expected {name} as a finite number, got {v}")
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        shown = f"{'' if lo is None else f'{lo:g}'}..{'' if hi is None else f'{hi:g}'}"
        raise OptionError(f"expected {name} in {shown}{' ' + unit if unit else ''}, got {v:g}")
    return v


def whole(name, value, *, lo, hi, unit=""):
    """``value`` as an int if it is a whole number within ``lo..hi``.

    Parameters
    ----------
    name : str
        Argument name for the message.
    value : object
        What the caller passed.
    lo, hi : int
        Inclusive bounds.
    unit : str
        Unit shown in the message (``"Hz"``).

    Returns
    -------
    int

    Raises
    ------
    OptionError
        Not a finite number (a bool is not one), not whole, or out of bounds (a ``ValueError``).
    """
    v = finite(name, value, lo=lo, hi=hi, unit=unit)
    if v != int(v):
        raise OptionError(f"expected {name} as a whole number, got {v:g}")
    return int(v)


def joint_vector(robot, q):
    """One configuration ``q`` checked against the robot's joint limits and every servo's range.

    Parameters
    ----------
    robot : labkit.Robot
        Joint limits and servo calibrations.
    q : array_like, shape (n,)
        Joint values [rad, m].

    Returns
    -------
    ndarray, shape (n,)

    Raises
    ------
    JointLimitError
        Wrong shape, a joint outside its limits, or outside its servo's range.
    """
    q = as_vector(q, robot.n, "q")
    if q.ndim != 1:
        raise JointLimitError(f"expected one configuration q with shape ({robot.n},), got {q.shape}")
    robot.check_limits(q)
    for j, lk in enumerate(robot.links):
        if lk.servo is not None:
            try:
                lk.servo.pulse_us(q[j])
            except JointLimitError as exc:
                if lk.joint_type is JointType.REVOLUTE:
                    raise JointLimitError(f"{robot.name}: joint {j + 1}: {exc}", joint=j) from None
                s = lk.servo  # an RC linear servo: say it in millimetres and microseconds
                (r0, r1), (p0, p1) = s.angle_range, s.pulse_range
                raise JointLimitError(
                    f"{robot.name}: joint {j + 1} ({lk.name!r}): {q[j] * 1000:g} mm needs a pulse of "
                    f"{float(s.pulse_from_servo_angle(s.servo_angle(q[j]))):.1f} us, outside its servo's pulse_us "
                    f"{p0:g}..{p1:g} us (range {r0 * 1000:g}..{r1 * 1000:g} mm); nothing was sent", joint=j) from None
    return q


def reply_timeout(value):
    """A reply timeout [s] as :class:`labkit.arm.Arm` takes it, in its constructor and its setter alike.

    Parameters
    ----------
    value : object

    Returns
    -------
    float
        ``value`` [s], finite, 1e-4..60.

    Raises
    ------
    OptionError
    """
    return finite("timeout", value, lo=1e-4, hi=60.0, unit="s")


def retry_count(value):
    """A retry count as :class:`labkit.arm.Arm` takes it, in its constructor and its setter alike.

    Parameters
    ----------
    value : object

    Returns
    -------
    int
        ``value``, a whole number 0..1000.

    Raises
    ------
    OptionError
    """
    return whole("retries", value, lo=0, hi=1000)


def speed_limit_lists(robot, speed_limits):
    """The per-joint ``LIMITS`` to send or check: the robot file's, or ``speed_limits`` checked.

    Parameters
    ----------
    robot : labkit.Robot
    speed_limits : tuple of two sequences of int, or None
        ``(vmax, amax)``: per joint [cdeg/s] and [cdeg/s^2] (0: unchecked), as :meth:`labkit.arm.Arm.speed_limits`
        returns them; ``None``: the robot file's (:func:`labkit.arm._protocol.wire_speed_limits`).

    Returns
    -------
    vmax, amax : list of int

    Raises
    ------
    OptionError
        Not two sequences of ``robot.n`` whole numbers within 0..1e6 cdeg/s and 0..1e8 cdeg/s^2 (nothing is sent).

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> speed_limit_lists(Robot.load("arduino_arm_3dof"), ([0, 0, 0], [0, 0, 0]))
    ([0, 0, 0], [0, 0, 0])
    """
    if speed_limits is None:
        return wire_speed_limits(robot)
    n = robot.n
    if isinstance(speed_limits, (str, bytes)) or not hasattr(speed_limits, "__len__") or len(speed_limits) != 2 \
            or any(isinstance(v, (str, bytes)) or not hasattr(v, "__len__") or len(v) != n for v in speed_limits):
        raise OptionError(f"expected speed_limits as (vmax, amax), {n} values each [cdeg/s, cdeg/s^2] as "
                          f"Arm.speed_limits() returns them, got {speed_limits!r}")
    vmax, amax = speed_limits
    return ([whole("vmax", v, lo=0, hi=VMAX_MAX, unit="cdeg/s") for v in vmax],
            [whole("amax", a, lo=0, hi=AMAX_MAX, unit="cdeg/s^2") for a in amax])
