"""Display units and measures of a robot for lab notebooks.

Lab parameters are in the units people read: joint values in degrees (revolute) or
millimetres (prismatic). These helpers turn them into SI and back, give the joint range
the servos can reach and a bound of the robot's reach. (IK targets in display units are
:func:`labkit.kinematics.target_from_display` and its inverse.)

Example
-------
>>> from labkit.robot import joints_from_display
>>> joints_from_display("rpp_seed002", [90, 500, 250]).round(4).tolist()
[1.5708, 0.5, 0.25]
"""

from __future__ import annotations

import math

import numpy as np

from labkit.exceptions import RobotError
from labkit.robot._model import Robot
from labkit.robot.types import JointType, Link
from labkit.validation import as_batch

__all__ = ["joints_from_display", "joints_to_display", "servo_travel", "servo_window", "robot_reach"]


def _scale(robot):
    """Per-joint display factor: degrees per radian (revolute) or millimetres per metre (prismatic)."""
    return np.where(np.asarray(robot.is_revolute, bool), 180.0 / math.pi, 1000.0)


def joints_from_display(robot, values):
    """Joint values in display units (deg revolute, mm prismatic) -> SI (rad, m).

    Parameters
    ----------
    robot : Robot or str
    values : array_like, shape (..., n)
        Joint values [deg | mm].

    Returns
    -------
    ndarray, shape (..., n)
        Joint values [rad | m].
    """
    robot = Robot.load(robot)
    return as_batch(values, (robot.n,), f"joint values of {robot.name}") / _scale(robot)


def joints_to_display(robot, q):
    """Joint values in SI (rad, m) -> display units (deg revolute, mm prismatic).

    Parameters
    ----------
    robot : Robot or str
    q : array_like, shape (..., n)
        Joint values [rad | m].

    Returns
    -------
    ndarray, shape (..., n)
        Joint values [deg | mm].
    """
    robot = Robot.load(robot)
    return as_batch(q, (robot.n,), f"q of {robot.name}") * _scale(robot)


def servo_travel(link):
    """The servo positions a joint's servo reaches, the span the board's pulse range covers.

    A hobby servo turns 0..180 deg (the board's 18000 cdeg: its ``pulse_us`` are extended to
    those angles); an RC linear servo (a prismatic joint's servo) travels its stroke, the servo
    table's ``range`` (the rod's positions at the two ends of ``pulse_us``).

    Parameters
    ----------
    link : labkit.robot.Link
        A joint with a servo calibration.

    Returns
    -------
    tuple of float
        ``(lower, upper)`` servo positions [rad | m].

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> servo_travel(Robot.load("arduino_arm_3dof").links[0])
    (0.0, 3.141592653589793)
    """
    if not isinstance(link, Link):
        raise RobotError(f"expected a Link, got {link!r}")
    if link.joint_type is JointType.REVOLUTE:
        return 0.0, math.pi
    return tuple(link.servo.angle_range)


def servo_window(robot):
    """The joint range the servos can reach, inside the joint limits, per joint.

    A joint without a servo calibration counts as reaching its whole limits.

    Parameters
    ----------
    robot : Robot or str

    Returns
    -------
    ndarray, shape (n, 2)
        Lower and upper joint values [rad | m].
    """
    robot = Robot.load(robot)
    out = np.array(robot.joint_limits, dtype=float)
    for j, lk in enumerate(robot.links):
        if lk.servo is not None:
            ends = np.sort(lk.servo.joint_from_servo_angle(servo_travel(lk)))
            out[j] = [max(out[j, 0], ends[0]), min(out[j, 1], ends[1])]
    return out


def robot_reach(robot):
    """Sum of the link lengths and offsets, prismatic strokes and the tool offset [m] (a bound of the reach).

    Parameters
    ----------
    robot : Robot or str
        Robot or robot file.

    Returns
    -------
    float
        ``sum |a| + sum |d| + sum of the prismatic joints' largest finite |limit| + |tool translation|`` [m]
        (:attr:`Robot.reach`).
    """
    return Robot.load(robot).reach

