"""Field checks shared by the robot description's dataclasses, worded like the robot-file loader (private)."""

from __future__ import annotations

import math

import numpy as np

from labkit.exceptions import RobotError


def _finite(owner, field, value):
    """``value`` as a float, or :class:`RobotError` worded like the robot-file loader."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value):
        raise RobotError(f"{owner}: field '{field}': expected a finite number, got {value!r}", field)
    return float(value)


def _limit_pair(owner, field, value):
    """``(lower, upper)`` with ``lower < upper`` (infinite bounds allowed), as floats."""
    try:
        lo, hi = value
        lo, hi = float(lo), float(hi)
    except (TypeError, ValueError):
        raise RobotError(f"{owner}: field '{field}': expected [lower, upper], got {value!r}", field) from None
    if math.isnan(lo) or math.isnan(hi) or not lo < hi:
        raise RobotError(f"{owner}: field '{field}': expected lower < upper, got {value!r}", field)
    return lo, hi


def _check_integer(owner, field, value, low, high, unit=""):
    """An integer in ``low..high`` (not a bool, not a float; message as the robot-file loader's)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
        raise RobotError(f"{owner}: field '{field}': expected an integer {low}-{high}{unit}, got {value!r}", field)


def _check_channel(owner, field, channel):
    """A servo channel: an integer 0-5."""
    _check_integer(owner, field, channel, 0, 5)


def _check_direction(owner, direction):
    """A servo direction: the integer 1 or -1 (``1.0`` and ``True`` are refused)."""
    if isinstance(direction, (bool, np.bool_)) or not isinstance(direction, (int, np.integer)) or direction not in (1, -1):
        raise RobotError(f"{owner}: field 'direction': expected 1 or -1, got {direction!r}", "direction")


def _check_stall_torque(owner, servo):
    """A servo's ``stall_torque``: None or a positive finite number [N m] (stored as a float)."""
    if servo.stall_torque is not None:
        v = _finite(owner, "stall_torque", servo.stall_torque)
        if not v > 0:
            raise RobotError(f"{owner}: field 'stall_torque': expected a torque > 0 N m, got {v:g}", "stall_torque")
        object.__setattr__(servo, "stall_torque", v)
