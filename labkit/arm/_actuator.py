"""Ideal actuators: the joints of a robot file without a servo (no ``servo`` and no ``[bus]`` table).

The virtual arm drives such a joint as an ideal position actuator (a joint with its own drive: a
stepper or a servo motor with its own controller): it follows its commands within the robot file's
own limits, at most at the joint's ``max_velocity`` and ``max_acceleration`` (or the defaults
below), and reports its position as the 10-bit count of an absolute encoder spread over those
limits, on the joint's feedback input. No 180-degree hobby-servo window is assumed. The host (the
feedback counts it reads) and the virtual board (the counts it sends) take the mapping from here.

Examples
--------
>>> from labkit.robot import Robot
>>> arm = Robot.load("rpp_seed002")
>>> [is_ideal(lk) for lk in arm.links]
[True, True, True]
>>> round(float(joint_sensor(arm, 1).joint_from_adc(1023.0)), 6)   # the top count: the stroke's end [m]
2.0
"""

from __future__ import annotations

import math

from labkit.exceptions import RobotError, ShapeError
from labkit.robot import Link, Robot, ServoCalibration
from labkit.validation import as_count

__all__ = ["is_ideal", "joint_sensor", "ideal_speed_limits", "IDEAL_VELOCITY", "IDEAL_ACCELERATION"]

#: an ideal actuator's speed where the robot file states none: revolute [rad/s] (90 deg/s), prismatic [m/s]
IDEAL_VELOCITY = {True: math.radians(90.0), False: 0.1}
#: an ideal actuator's acceleration where the robot file states none: revolute [rad/s^2], prismatic [m/s^2]
IDEAL_ACCELERATION = {True: math.radians(360.0), False: 0.5}
#: the encoder's counts at the two ends of the joint limits (the board's 10-bit feedback input)
ENCODER_COUNTS = (0.0, 1023.0)


def is_ideal(link):
    """Whether ``link``'s joint is an ideal actuator (neither a hobby servo nor a bus servo drives it).

    Parameters
    ----------
    link : labkit.robot.Link

    Returns
    -------
    bool

    Raises
    ------
    ShapeError
        ``link`` is not a :class:`labkit.robot.Link`.
    """
    if not isinstance(link, Link):
        raise ShapeError(f"expected a labkit.robot.Link (robot.links[j]), got {type(link).__name__}")
    return link.servo is None and link.bus is None


def joint_sensor(robot, j):
    """The map between joint ``j`` and its feedback counts: its servo's pot, or an ideal actuator's encoder.

    Parameters
    ----------
    robot : labkit.robot.Robot
    j : int
        Joint index (also the encoder's channel).

    Returns
    -------
    ServoCalibration
        The servo's calibration, or for an ideal actuator a calibration whose feedback counts
        0..1023 span the joint limits (``joint_from_adc``, ``adc_from_joint``).

    Raises
    ------
    RobotError
        An ideal actuator with an infinite limit (its encoder needs a finite range).
    """
    lk = robot.links[j]
    if lk.servo is not None:
        return lk.servo
    lo, hi = lk.limits
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise RobotError(f"{robot.name}: joint {robot.joint_names[j]!r}: expected finite limits for a joint without a "
                         f"servo (an ideal actuator moves within them), got [{lo}, {hi}]", "limits")
    return ServoCalibration(channel=min(j, 5), zero=-lo, direction=1, angle_range=(0.0, hi - lo),
                            feedback_adc=ENCODER_COUNTS)


def ideal_speed_limits(robot, j):
    """Joint ``j``'s speed and acceleration limits as an ideal actuator: the robot file's, else the defaults.

    Parameters
    ----------
    robot : labkit.robot.Robot
    j : int

    Returns
    -------
    tuple of float
        ``(max_velocity, max_acceleration)`` [rad/s, rad/s^2 | m/s, m/s^2].

    Raises
    ------
    ShapeError
        ``robot`` is not a :class:`labkit.robot.Robot`, or ``j`` not a joint index 0..n-1.
    """
    if not isinstance(robot, Robot):
        raise ShapeError(f"expected a labkit.robot.Robot, got {type(robot).__name__}")
    j = as_count(j, "j (a joint index)", maximum=robot.n - 1, error=ShapeError)
    lk = robot.links[j]
    rev = bool(robot.is_revolute[j])
    return (IDEAL_VELOCITY[rev] if lk.max_velocity is None else float(lk.max_velocity),
            IDEAL_ACCELERATION[rev] if lk.max_acceleration is None else float(lk.max_acceleration))
