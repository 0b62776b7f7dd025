"""IK targets in display units (mm, deg) and how far FK is from a target, for lab notebooks.

A target row reads the target's lengths [mm], then its angles [deg] (a 6-DOF pose's
as fixed-axis roll, pitch, yaw); :func:`target_from_display` turns it into the target
:func:`labkit.kinematics.ik_all` takes, :func:`target_to_display` goes back. :func:`target_from_pose` is the target a
tool pose reaches (the target of FK), in SI units.

Example
-------
>>> from labkit.kinematics import target_from_display
>>> from labkit.robot import Robot
>>> target_from_display(Robot.load("planar3r_seed003"), [100, 50, 90]).round(4).tolist()
[0.1, 0.05, 1.5708]
"""

from __future__ import annotations

import numpy as np

from labkit.kinematics._forward import fk
from labkit.kinematics._ik import target_kind
from labkit.kinematics._ik_solvers import COMPONENTS, REDUCED, detect, target_components
from labkit.validation import as_batch

__all__ = ["target_from_display", "target_to_display", "target_error", "target_from_pose"]


def target_from_pose(robot, T):
    """The IK target of ``robot`` that tool poses ``T`` reach (the target of FK).

    Parameters
    ----------
    robot : Robot
    T : array_like, shape (..., 4, 4)
        Tool poses [m].

    Returns
    -------
    ndarray
        ``(..., 3)`` position [m], ``(..., 3)`` planar ``(x, y, phi)`` [m, rad],
        ``(..., 4)`` ``(x, y, z, pitch)`` / ``(..., 5)`` ``(x, y, z, pitch, roll)``
        [m, rad] (angles in (-pi, pi]), or the poses themselves (6-DOF).

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> arm = Robot.load("openmanipulator_x")
    >>> np.round(target_from_pose(arm, arm.fk([0.0, 0.0, 0.0, np.pi / 2])), 4).tolist()
    [0.16, 0.0, 0.0615, -1.5708]
    """
    kind = target_kind(robot)
    T = as_batch(T, (4, 4), "T")
    if kind == "position":
        return T[..., :3, 3].copy()
    if kind == "planar":
        return np.concatenate([T[..., :2, 3], np.arctan2(T[..., 1, 0], T[..., 0, 0])[..., None]], axis=-1)
    if kind in REDUCED:
        found, _ = detect(robot)
        lead = T.shape[:-2]
        return found.target_of(T.reshape(-1, 4, 4)).reshape(lead + (len(COMPONENTS[kind]),))
    return T.copy()


def target_from_display(robot, row):
    """One IK target in display units -> the target :func:`labkit.kinematics.ik_all` takes for ``robot``.

    Parameters
    ----------
    robot : Robot
    row : array_like
        ``x, y, z`` [mm] (position robots), ``x, y`` [mm] and ``phi`` [deg] (planar),
        ``x, y, z`` [mm] and ``pitch`` [deg] (4-DOF) or ``pitch, roll`` [deg] (5-DOF), or
        ``x, y, z`` [mm] and ``roll, pitch, yaw`` [deg] (6-DOF pose, fixed-axis RPY).

    Returns
    -------
    ndarray
        Shape (3,) [m] position, (3,) [m, m, rad] planar, (4,) / (5,) [m, rad], or (4, 4) pose [m].
    """
    from labkit.rotations import matrix_from_rpy

    kind = target_kind(robot)
    names = target_components(kind)
    row = as_batch(row, (len(names),), f"row ({' '.join(names)} for {robot.name})", batch=False)
    if kind != "pose":  # lengths, then angles
        n = 2 if kind == "planar" else 3
        return np.concatenate([row[:n] / 1000.0, np.radians(row[n:])])
    T = np.eye(4)
    T[:3, :3] = matrix_from_rpy(np.radians(row[3:]))
    T[:3, 3] = row[:3] / 1000.0
    return T


def target_to_display(robot, T):
    """A pose -> the IK target row of ``robot`` in display units (inverse of :func:`target_from_display`).

    Parameters
    ----------
    robot : Robot
    T : array_like, shape (4, 4)
        Tool pose [m].

    Returns
    -------
    ndarray
        ``x, y, z`` [mm] (position), ``x, y`` [mm] and ``phi`` [deg] (planar),
        ``x, y, z`` [mm] and ``pitch`` [, ``roll``] [deg] (4-, 5-DOF), or
        ``x, y, z`` [mm] and ``roll, pitch, yaw`` [deg] (pose).
    """
    from labkit.rotations import rpy_from_matrix

    kind = target_kind(robot)
    T = as_batch(T, (4, 4), "T", batch=False)
    if kind != "pose":  # lengths, then angles
        t, n = target_from_pose(robot, T), 2 if kind == "planar" else 3
        return np.concatenate([t[:n] * 1000.0, np.degrees(t[n:])])
    rpy = np.degrees(np.asarray(rpy_from_matrix(T[:3, :3]), dtype=float))
    return np.concatenate([T[:3, 3] * 1000.0, rpy])


def target_error(robot, q, target):
    """How far FK(q) is from an IK target, in the target's own terms.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (n,)
        Joint values [rad | m].
    target : array_like
        Position (3,) [m], planar (x, y, phi) [m, m, rad], (x, y, z, pitch[, roll]) [m, rad],
        or pose (4, 4) [m].

    Returns
    -------
    float
        Largest absolute difference: position [m], planar x, y [m] and phi [rad] (wrapped),
        x, y, z [m] and pitch, roll [rad] (wrapped), or any entry of the 4x4 pose.
    """
    from labkit.rotations import wrap_angle

    T, kind, target = fk(robot, q), target_kind(robot), as_batch(target, (), "target")
    if target.shape == (4, 4):
        return float(np.abs(T - target).max())
    target = as_batch(target, (len(COMPONENTS.get(kind, "xyz")),), "target", batch=False)  # (a pose: its point)
    d = (T[:3, 3] if kind == "pose" else target_from_pose(robot, T)) - target
    angles = slice(2 if kind == "planar" else 3, None)
    d[angles] = wrap_angle(d[angles])
    return float(np.abs(d).max())

