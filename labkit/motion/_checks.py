"""Checks of a sampled trajectory against a robot: joint limits, speed and
acceleration limits, and the time scale that would respect them."""

from __future__ import annotations

import math

import numpy as np

from labkit.exceptions import JointLimitError, ShapeError, TrajectoryError
from labkit.validation import as_number, check_robot, check_trajectory

__all__ = ["check_joint_limits", "check_speed", "speed_scale"]



def _robot_bounds(robot):
    """Per-joint ``max_velocity`` and ``max_acceleration`` as arrays, ``inf`` where a joint has none."""
    check_robot(robot)
    v = np.array([math.inf if lk.max_velocity is None else lk.max_velocity for lk in robot.links], dtype=float)
    a = np.array([math.inf if lk.max_acceleration is None else lk.max_acceleration for lk in robot.links], dtype=float)
    return v, a


# -- checks ---------------------------------------------------------------------

def _checked(traj, robot, limits, speed):
    """``traj`` after the requested joint-limit and speed checks against ``robot``."""
    if robot is not None:
        if limits:
            check_joint_limits(robot, traj)
        if speed:
            check_speed(robot, traj)
    return traj


def check_joint_limits(robot, traj):
    """Raise at the first sample outside the robot's joint limits.

    Parameters
    ----------
    robot : Robot
        Gives the joint limits.
    traj : Trajectory
        Samples ``q`` of shape (N, n) [rad, m].

    Raises
    ------
    JointLimitError
        Naming the time, sample index and joint; ``.joint`` and ``.index`` set.
    """
    check_robot(robot)
    ok = robot.within_limits(check_trajectory(traj).q)
    if np.all(ok):
        return
    i = int(np.argmin(ok))
    try:
        robot.check_limits(traj.q[i])
    except JointLimitError as exc:
        raise JointLimitError(
            f"at t = {traj.t[i]:.4g} s (sample {i}): {exc}", joint=exc.joint, index=i
        ) from None


def speed_scale(robot, traj):
    """Factor by which the trajectory must be slowed to respect speed bounds.

    Uniform time scaling by ``k`` divides velocities by ``k`` and
    accelerations by ``k**2``; this returns the smallest such ``k`` (1 or
    less when the bounds already hold) and the joint that sets it.

    Parameters
    ----------
    robot : Robot
        Gives ``max_velocity`` / ``max_acceleration`` per joint.
    traj : Trajectory
        Samples ``qd``/``qdd`` [rad/s, m/s; rad/s^2, m/s^2]; the peaks of its
        law when it has one.

    Returns
    -------
    k : float
    joint : int
        Index of the limiting joint.
    what : str
        ``"velocity"`` or ``"acceleration"``.

    Raises
    ------
    ShapeError
        The trajectory and the robot differ in the number of joints.
    """
    v, a = _robot_bounds(robot)
    if check_trajectory(traj).n != robot.n:
        raise ShapeError(f"{robot.name} has {robot.n} joints; trajectory has {traj.n}")
    if traj.law is not None and traj.law.shape == (robot.n,):
        vpk, apk = traj.law.peak(1), traj.law.peak(2)
    else:
        vpk, apk = np.max(np.abs(traj.qd), axis=0), np.max(np.abs(traj.qdd), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        rv = np.where(np.isfinite(v), vpk / v, 0.0)
        ra = np.sqrt(np.where(np.isfinite(a), apk / a, 0.0))
    jv, ja = int(np.argmax(rv)), int(np.argmax(ra))
    if rv[jv] >= ra[ja]:
        return float(rv[jv]), jv, "velocity"
    return float(ra[ja]), ja, "acceleration"


def check_speed(robot, traj, *, tol=1e-9):
    """Raise if a joint exceeds its ``max_velocity`` or ``max_acceleration``.

    Parameters
    ----------
    robot : Robot
        Gives the speed bounds (unbounded joints are skipped).
    traj : Trajectory
        Samples ``qd``/``qdd`` [rad/s, m/s; rad/s^2, m/s^2] (or its law).
    tol : float
        Accepted excess of the slow-down factor over 1 [-].

    Raises
    ------
    TrajectoryError
        Naming the joint, the peak, the bound, the time it happens and the
        minimum duration at which the same path would respect every bound
        (uniform time scaling); the exception carries ``minimum_duration``
        [s] and ``joint``.
    ShapeError
        The trajectory and the robot differ in the number of joints.
    """
    tol = as_number(tol, "tol", error=TrajectoryError)
    if tol < 0:
        raise TrajectoryError(f"expected tol >= 0, got {tol!r}")
    k, j, what = speed_scale(robot, traj)
    if k <= 1.0 + tol:
        return
    rev = robot.links[j].is_revolute
    s, unit = (180.0 / math.pi, "deg") if rev else (1.0, "m")
    if what == "velocity":
        arr, bound, u = traj.qd[:, j], robot.links[j].max_velocity, unit + "/s"
    else:
        arr, bound, u = traj.qdd[:, j], robot.links[j].max_acceleration, unit + "/s^2"
    i = int(np.argmax(np.abs(arr)))
    Tmin = traj.duration * k
    exc = TrajectoryError(
        f"{robot.name}: joint {j + 1} ({robot.joint_names[j]}) {what} reaches "
        f"{abs(arr[i]) * s:.4g} {u} at t = {traj.t[i]:.4g} s, above its max_{what} "
        f"{bound * s:.4g} {u}; slow down by {k:.3g}x: minimum duration {Tmin:.4g} s "
        f"(now {traj.duration:.4g} s)"
    )
    exc.minimum_duration = Tmin
    exc.joint = j
    raise exc
