"""Display units and measures of a robot for lab notebooks.

Lab parameters are in the units people read: joint values in degrees (revolute) or
millimetres (prismatic), positions in millimetres, angles in degrees. These helpers turn
them into SI and back, state IK targets in the form :func:`labkit.kinematics.ik_all` takes,
measure how far FK is from a target, and give the joint range the servos can reach.

Example
-------
>>> from labkit.reports import joints_from_display
>>> joints_from_display("rpp_seed002", [90, 500, 250]).round(4).tolist()
[1.5708, 0.5, 0.25]
"""

from __future__ import annotations

import math

import numpy as np

from labkit.exceptions import LabkitError
from labkit.kinematics import fk, target_kind
from labkit.robot import Robot

__all__ = ["joints_from_display", "joints_to_display", "target_from_display", "target_error", "servo_window",
           "robot_reach"]


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
    values = np.asarray(values, dtype=float)
    if values.shape[-1:] != (robot.n,):
        raise LabkitError(f"expected joint values with shape (..., {robot.n}) for {robot.name}, got {values.shape}")
    return values / _scale(robot)


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
    return np.asarray(q, dtype=float) * _scale(robot)


def target_from_display(robot, row):
    """One IK target in display units -> the target :func:`labkit.kinematics.ik_all` takes for ``robot``.

    Parameters
    ----------
    robot : Robot or str
    row : array_like
        ``x, y, z`` [mm] (position robots), ``x, y`` [mm] and ``phi`` [deg] (planar), or
        ``x, y, z`` [mm] and ``roll, pitch, yaw`` [deg] (6-DOF pose, fixed-axis RPY).

    Returns
    -------
    ndarray
        Shape (3,) [m] position, (3,) [m, m, rad] planar, or (4, 4) pose [m].
    """
    from labkit.rotations import matrix_from_rpy

    robot = Robot.load(robot)
    kind = target_kind(robot)
    row = np.asarray(row, dtype=float)
    sizes = {"position": 3, "planar": 3, "pose": 6}
    if row.shape != (sizes[kind],):
        raise LabkitError(f"expected a {kind} target of {sizes[kind]} numbers for {robot.name}, got shape {row.shape}")
    if kind == "position":
        return row / 1000.0
    if kind == "planar":
        return np.array([row[0] / 1000.0, row[1] / 1000.0, math.radians(row[2])])
    T = np.eye(4)
    T[:3, :3] = matrix_from_rpy(np.radians(row[3:]))
    T[:3, 3] = row[:3] / 1000.0
    return T


def _target_to_display(robot, T, kind):
    from labkit.rotations import rpy_from_matrix

    p = T[:3, 3] * 1000.0
    if kind == "position":
        return p
    if kind == "planar":
        return np.array([p[0], p[1], math.degrees(math.atan2(T[1, 0], T[0, 0]))])
    rpy = np.degrees(np.asarray(rpy_from_matrix(T[:3, :3]), dtype=float))
    return np.concatenate([p, rpy])


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
            ends = np.sort([lk.servo.joint_from_servo_angle(0.0), lk.servo.joint_from_servo_angle(math.pi)])
            out[j] = [max(out[j, 0], ends[0]), min(out[j, 1], ends[1])]
    return out


def target_error(robot, q, target):
    """How far FK(q) is from an IK target, in the target's own terms.

    Parameters
    ----------
    robot : Robot or str
    q : array_like, shape (n,)
        Joint values [rad | m].
    target : array_like
        Position (3,) [m], planar (x, y, phi) [m, m, rad], or pose (4, 4) [m].

    Returns
    -------
    float
        Largest absolute difference: position [m], planar x, y [m] and phi [rad] (wrapped),
        or any entry of the 4x4 pose.
    """
    from labkit.rotations import wrap_angle

    robot = Robot.load(robot)
    T = fk(robot, q)
    target = np.asarray(target, dtype=float)
    if target.shape == (4, 4):
        return float(np.abs(T - target).max())
    if target_kind(robot) == "planar":
        d = np.array([T[0, 3] - target[0], T[1, 3] - target[1],
                      wrap_angle(math.atan2(T[1, 0], T[0, 0]) - target[2])])
        return float(np.abs(d).max())
    return float(np.abs(T[:3, 3] - target).max())


def robot_reach(robot):
    """Sum of the link lengths and offsets, prismatic strokes and the tool offset [m] (a bound of the reach).

    Parameters
    ----------
    robot : Robot or str
        Robot or robot file.

    Returns
    -------
    float
        ``sum |a| + sum |d| + sum of the prismatic joints' largest |limit| + |tool translation|`` [m].
    """
    robot = Robot.load(robot)
    stroke = sum(max(abs(lo), abs(hi)) for (lo, hi), rev in zip(robot.joint_limits, robot.is_revolute) if not rev)
    return float(np.sum(np.abs(robot.a)) + np.sum(np.abs(robot.d)) + stroke + np.linalg.norm(robot.tool[:3, 3]))
