"""Resolved-rate Cartesian control: joint rates from the tool's velocity error, run on any arm.

The tool point follows a Cartesian path ``x_d(t)`` (a :class:`labkit.motion.CartesianPath` timed by
:func:`labkit.motion.path_law`) with the rate law (Whitney 1969; roboticstoolbox's ``p_servo``)

``qd = joint_rates(J_v(q), xd_d + gain (x_d - x(q)))``,  ``q <- q + qd dt``,

``J_v`` the position rows of the geometric Jacobian and :func:`labkit.kinematics.joint_rates` the
library's one damped rule (exact away from singularities, damped near them). The loop closes on the
**commanded** joints (kinematic feedback: integration drift is corrected, the servos' lag is not fed
back), so the set-points are computed ahead and streamed to the board as protocol segments
(:meth:`labkit.arm.Arm.run_trajectory`), which every arm labkit drives runs the same way, real or
virtual. While they run, :func:`track_on_arm` reads the sensed joints after each queued segment and
reports where the tool really went: the distance from the path and the lag behind ``x_d(t)``.
Orientation is left free (position rows only).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from labkit.exceptions import OptionError
from labkit.validation import as_number, as_vector, check_robot, readonly

__all__ = ["resolved_rate_trajectory", "PathTracking", "track_on_arm"]


def resolved_rate_trajectory(robot, path, duration, q0, *, law="quintic", gain=20.0, dt=0.02):
    """Joint set-points of resolved-rate control along a Cartesian path (module notes).

    Parameters
    ----------
    robot : Robot
    path : labkit.motion.CartesianPath
        Tool-point path [m].
    duration : float
        Time to run the path [s].
    q0 : array_like, shape (n,)
        Start joints [rad, m] (the tool need not be on the path: the gain pulls it there).
    law : str or TimeLaw
        Time law of the path parameter (:func:`labkit.motion.path_law`).
    gain : float
        Position-error gain [1/s], >= 0 (0: pure feedforward, integration drift uncorrected).
    dt : float
        Control step [s].

    Returns
    -------
    labkit.motion.Trajectory
        ``q``, ``qd``, ``qdd`` (finite differences of ``qd``) at ``t``, and ``x`` = the desired tool
        points, ``xd`` their velocity [m/s].

    Raises
    ------
    OptionError
        ``gain`` negative or ``dt``/``duration`` not > 0.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> from labkit.motion import line_path
    >>> from labkit.kinematics import fk_position
    >>> arm = Robot.load("arduino_arm_3dof")
    >>> q0 = np.radians([90.0, 60.0, 100.0])
    >>> p0 = fk_position(arm, q0)
    >>> traj = resolved_rate_trajectory(arm, line_path(p0, p0 + [0.0, 0.05, 0.0]), 2.0, q0)
    >>> bool(np.max(np.linalg.norm(fk_position(arm, traj.q) - traj.x, axis=-1)) < 1e-3)
    True
    """
    from labkit.kinematics import fk_position, jacobian, joint_rates
    from labkit.motion import Trajectory, path_law, time_grid

    duration, dt = (as_number(v, name, unit="s", positive=True, error=OptionError)
                    for name, v in (("duration", duration), ("dt", dt)))
    gain = as_number(gain, "gain", unit="1/s", error=OptionError)
    if gain < 0:
        raise OptionError(f"expected gain >= 0 [1/s], got {gain!r}")
    check_robot(robot)
    q = as_vector(q0, robot.n, "q0 (start joints, rad)").copy()
    s_law = path_law(path, float(duration), law)
    t = time_grid(0.0, float(duration), float(dt))
    p, dp, _ = path.evaluate(s_law.position(t))
    x_d, xd_d = p, dp * np.asarray(s_law.velocity(t)).reshape(-1, 1)
    Q, Qd = np.empty((t.size, robot.n)), np.empty((t.size, robot.n))
    for k in range(t.size):
        Q[k] = q
        twist = xd_d[k] + gain * (x_d[k] - fk_position(robot, q))
        Qd[k] = joint_rates(jacobian(robot, q)[:3], twist)
        if k + 1 < t.size:
            q = q + Qd[k] * (t[k + 1] - t[k])
    Qd[-1] = 0.0  # the path law ends at rest
    Qdd = np.gradient(Qd, t, axis=0) if t.size > 1 else np.zeros_like(Qd)
    return Trajectory(t=t, q=Q, qd=Qd, qdd=Qdd, x=x_d, xd=xd_d, joint_names=tuple(robot.joint_names),
                      axis_names=("x", "y", "z"), revolute=tuple(bool(r) for r in robot.is_revolute))


@dataclass(frozen=True)
class PathTracking:
    """Where the tool went while an arm ran a Cartesian trajectory (:func:`track_on_arm`).

    Attributes
    ----------
    t : ndarray, shape (m,)
        Times of the reads [s from the trajectory's start, board time].
    q_sensed : ndarray, shape (m, n)
        Sensed joints [rad, m].
    x_measured : ndarray, shape (m, 3)
        Tool point of the sensed joints [m].
    x_desired : ndarray, shape (m, 3)
        The path point due at that time [m].
    path_error : ndarray, shape (m,)
        Distance of the measured point from the path [m] (off the line).
    lag : ndarray, shape (m,)
        Distance of the measured point from the point due [m] (off the line or behind on it).
    """

    t: np.ndarray
    q_sensed: np.ndarray
    x_measured: np.ndarray
    x_desired: np.ndarray
    path_error: np.ndarray
    lag: np.ndarray

    def to_dataframe(self):
        """Summary table: largest and RMS path error and lag [mm].

        Returns
        -------
        pandas.DataFrame
            Rows ``path error`` and ``lag``, columns ``max [mm]`` and ``rms [mm]``.
        """
        import pandas as pd

        rows = [(name, 1e3 * float(np.max(v)), 1e3 * float(np.sqrt(np.mean(v ** 2))))
                for name, v in (("path error", self.path_error), ("lag", self.lag))]
        return pd.DataFrame(rows, columns=["measure", "max [mm]", "rms [mm]"])


def track_on_arm(arm, trajectory, path, *, settle=0.3):
    """Run a Cartesian trajectory on the arm, reading the sensed joints while it runs.

    The arm first moves (``MOVE``, waiting) to the trajectory's first joints, then the trajectory
    is streamed as segments (:meth:`labkit.arm.Arm.run_trajectory`); after each queued segment, and
    for ``settle`` s after the last, the board time and the sensed joints are read.

    Parameters
    ----------
    arm : labkit.arm.Arm
        The open arm (any board or bus).
    trajectory : labkit.motion.Trajectory
        Joint set-points with the desired tool points ``x`` (:func:`resolved_rate_trajectory`).
    path : labkit.motion.CartesianPath
        The path the tool point should stay on.
    settle : float
        Reading time after the trajectory ends [s].

    Returns
    -------
    PathTracking

    Raises
    ------
    OptionError
        The trajectory has no Cartesian points ``x`` of shape (N, 3).
    JointLimitError, TrajectoryError, DeviceError
        As :meth:`labkit.arm.Arm.run_trajectory` (nothing moves on the first two).
    """
    from labkit.kinematics import fk_position

    if trajectory.x is None or np.shape(trajectory.x)[1] != 3:
        raise OptionError("expected a trajectory with desired tool points x of shape (N, 3) "
                          "(resolved_rate_trajectory), got none")
    arm.move_joints(trajectory.q[0], wait=True)
    reads = []

    def read(*_):
        reads.append((arm.status().t, arm.read_joints()))

    read()
    t0 = reads[0][0]
    arm.run_trajectory(trajectory, progress=read, wait=True)
    end = arm.status().t + settle
    while reads[-1][0] < end:
        arm.sleep(0.05)
        read()
    t = np.array([r[0] for r in reads]) - t0
    q = np.array([r[1] for r in reads])
    x = fk_position(arm.robot, q)
    tt = np.asarray(trajectory.t)
    x_d = np.column_stack([np.interp(t, tt, np.asarray(trajectory.x)[:, i]) for i in range(3)])
    return PathTracking(readonly(t), readonly(q), readonly(x), readonly(x_d), readonly(path.distance_from(x)),
                        readonly(np.linalg.norm(x - x_d, axis=-1)))
