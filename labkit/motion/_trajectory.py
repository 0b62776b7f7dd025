"""Joint-space trajectories: point-to-point moves, via points, limit checks.

A trajectory is sampled data, the frozen :class:`Trajectory` (``t``, ``q``,
``qd``, ``qdd`` and, for Cartesian paths, ``x`` and ``xd``), built from a
:class:`labkit.motion.TimeLaw`:

* :func:`joint_trajectory` -- one move between two configurations (cubic,
  quintic, LSPB), its duration given or chosen from the robot's
  ``max_velocity`` / ``max_acceleration``;
* :func:`via_trajectory` -- through via points, either cubic segments with
  continuous velocity (heuristic or given via velocities) or a cubic spline
  with continuous acceleration (clamped or natural ends);
* :func:`check_joint_limits` and :func:`check_speed` -- the first sample
  outside the joint limits, and speed/acceleration limits with the minimum
  duration that would respect them.

Cartesian paths (lines, arcs, circles) live in :mod:`labkit.motion`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.interpolate import CubicHermiteSpline

from labkit.validation import as_batch, check_robot, readonly
from labkit.exceptions import ShapeError, TrajectoryError
from labkit.motion._timelaw import TimeLaw
from labkit.motion._laws import _number, make_law, minimum_duration, time_grid
from labkit.motion._checks import _checked, _robot_bounds

__all__ = ["Trajectory", "joint_trajectory", "law_trajectory"]

_ANGLE_AXES = {"phi", "roll", "pitch", "yaw", "rx", "ry", "rz"}


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A sampled trajectory (joint space, and Cartesian where planned so).

    Attributes
    ----------
    t : ndarray, shape (N,)
        Sample times [s], increasing.
    q, qd, qdd : ndarray, shape (N, n)
        Joint positions [rad, m], velocities [rad/s, m/s] and accelerations
        [rad/s^2, m/s^2].
    x, xd : ndarray, shape (N, k), optional
        Cartesian coordinates and rates of the end effector for Cartesian
        trajectories: ``k = 3`` (x, y, z [m]) for position targets, (x, y [m],
        phi [rad]) for planar arms, or 6 (x, y, z [m], roll, pitch, yaw [rad],
        XYZ fixed angles) for poses; ``xd`` holds the linear velocity [m/s]
        and, for 6, the angular velocity [rad/s] (not the angle rates).
    xdd : ndarray, shape (N, k), optional
        Cartesian acceleration [m/s^2, rad/s^2] (where known).
    joint_names, axis_names : tuple of str
        Column names of ``q`` and ``x``.
    revolute : tuple of bool
        Which joints are revolute (converted by ``to_dataframe(degrees=True)``).
    law : TimeLaw, optional
        The joint-space law the samples came from (exact resampling).

    Examples
    --------
    >>> traj = joint_trajectory(None, [0.0, 0.0], [1.0, -1.0], 2.0, dt=0.5)
    >>> traj.q.shape
    (5, 2)
    >>> traj.resample(0.25).t.size
    9
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    x: np.ndarray | None = None
    xd: np.ndarray | None = None
    xdd: np.ndarray | None = None
    joint_names: tuple = ()
    axis_names: tuple = ()
    revolute: tuple = ()
    law: TimeLaw | None = field(default=None, repr=False)
    resampler: Callable | None = field(default=None, repr=False)

    def __post_init__(self):
        t = np.asarray(self.t, dtype=float)
        if t.ndim != 1 or t.size == 0:
            raise ShapeError(f"expected t with shape (N,), N >= 1, got {t.shape}")
        if np.any(np.diff(t) <= 0):
            raise ShapeError("expected strictly increasing sample times t")
        N = t.size
        q = np.asarray(self.q, dtype=float)
        if q.ndim != 2 or q.shape[0] != N:
            raise ShapeError(f"expected q with shape ({N}, n), got {q.shape}")
        for name in ("qd", "qdd"):
            a = np.asarray(getattr(self, name), dtype=float)
            if a.shape != q.shape:
                raise ShapeError(f"expected {name} with shape {q.shape}, got {a.shape}")
        if (self.x is None) != (self.xd is None):
            raise ShapeError("expected both x and xd, or neither")
        if self.x is not None:
            x, xd = np.asarray(self.x, float), np.asarray(self.xd, float)
            if x.ndim != 2 or x.shape[0] != N or xd.shape != x.shape:
                raise ShapeError(f"expected x and xd with shape ({N}, k), got {x.shape} and {xd.shape}")
            if self.xdd is not None and np.shape(self.xdd) != x.shape:
                raise ShapeError(f"expected xdd with shape {x.shape}, got {np.shape(self.xdd)}")
        elif self.xdd is not None:
            raise ShapeError("xdd given without x and xd")
        for name in ("t", "q", "qd", "qdd", "x", "xd", "xdd"):
            object.__setattr__(self, name, readonly(getattr(self, name)))
        n = q.shape[1]
        names = tuple(self.joint_names) or tuple(f"q{i + 1}" for i in range(n))
        if len(names) != n:
            raise ShapeError(f"expected {n} joint names, got {len(names)}")
        object.__setattr__(self, "joint_names", names)
        rev = tuple(bool(r) for r in self.revolute) or (True,) * n
        object.__setattr__(self, "revolute", rev)
        if self.x is not None:
            k = self.x.shape[1]
            axes = tuple(self.axis_names) or {3: ("x", "y", "z"), 6: ("x", "y", "z", "roll", "pitch", "yaw")}.get(
                k, tuple(f"x{i + 1}" for i in range(k))
            )
            if len(axes) != k:
                raise ShapeError(f"expected {k} axis names, got {len(axes)}")
            object.__setattr__(self, "axis_names", tuple(axes))

    # -- views ----------------------------------------------------------------
    @property
    def n(self):
        """Number of joints."""
        return self.q.shape[1]

    @property
    def duration(self):
        """``t[-1] - t[0]`` [s]."""
        return float(self.t[-1] - self.t[0])

    def __len__(self):
        return self.t.size

    def to_dataframe(self, *, degrees=False, millimetres=False):
        """The samples as a pandas DataFrame indexed by time.

        Columns ``<joint>``, ``<joint>_dot``, ``<joint>_ddot`` per joint, then
        ``<axis>``, ``<axis>_dot`` (and ``<axis>_ddot``) per Cartesian axis.

        Parameters
        ----------
        degrees : bool
            Revolute joints and angle axes in degrees (deg/s, deg/s^2)
            instead of radians: for tables in a report.
        millimetres : bool
            Lengths in mm instead of m.

        Returns
        -------
        pandas.DataFrame
            Index ``t`` [s]; ``df.attrs["units"]`` maps columns to units.
        """
        import pandas as pd

        ang = 180.0 / math.pi if degrees else 1.0
        lin = 1e3 if millimetres else 1.0
        aunit = "deg" if degrees else "rad"
        lunit = "mm" if millimetres else "m"
        cols, units = {}, {}
        for j, name in enumerate(self.joint_names):
            s, u = (ang, aunit) if self.revolute[j] else (lin, lunit)
            for suffix, arr, tu in (("", self.q, ""), ("_dot", self.qd, "/s"), ("_ddot", self.qdd, "/s^2")):
                cols[name + suffix] = arr[:, j] * s
                units[name + suffix] = u + tu
        if self.x is not None:
            for k, name in enumerate(self.axis_names):
                is_angle = name in _ANGLE_AXES
                s, u = (ang, aunit) if is_angle else (lin, lunit)
                cols[name] = self.x[:, k] * s
                units[name] = u
                # the angular part of a 6-D xd is an angular velocity, same unit scaling
                cols[name + "_dot"] = self.xd[:, k] * s
                units[name + "_dot"] = u + "/s"
                if self.xdd is not None:
                    cols[name + "_ddot"] = self.xdd[:, k] * s
                    units[name + "_ddot"] = u + "/s^2"
        df = pd.DataFrame(cols, index=pd.Index(self.t, name="t"))
        df.attrs["units"] = units
        return df

    def resample(self, dt, *, t0=None, tf=None):
        """The trajectory at a fixed time step.

        Exact when the trajectory knows how it was made (a joint law or a
        Cartesian path); otherwise piecewise-cubic Hermite interpolation of
        ``q`` with ``qd`` (and of ``qd`` with ``qdd``).

        Parameters
        ----------
        dt : float
            Step [s] (seed 000 uses 0.1 s).
        t0, tf : float, optional
            Span (default the trajectory's own).

        Returns
        -------
        Trajectory
        """
        t0 = self.t[0] if t0 is None else t0
        tf = self.t[-1] if tf is None else tf
        t = time_grid(t0, tf, dt)
        if self.resampler is not None:
            return self.resampler(t)
        if self.law is not None:
            return law_trajectory(self.law, t, joint_names=self.joint_names, revolute=self.revolute)
        if self.t.size < 2:
            raise TrajectoryError("cannot resample a trajectory with a single sample")
        tc = np.clip(t, self.t[0], self.t[-1])
        q = CubicHermiteSpline(self.t, self.q, self.qd, axis=0)(tc)
        qd = CubicHermiteSpline(self.t, self.qd, self.qdd, axis=0)(tc)
        qdd = np.stack([np.interp(tc, self.t, self.qdd[:, j]) for j in range(self.n)], axis=-1)
        x = xd = xdd = None
        if self.x is not None:
            k = self.x.shape[1]
            x = CubicHermiteSpline(self.t, self.x, self.xd, axis=0)(tc)
            if self.xdd is not None:
                xd = CubicHermiteSpline(self.t, self.xd, self.xdd, axis=0)(tc)
                xdd = np.stack([np.interp(tc, self.t, self.xdd[:, i]) for i in range(k)], axis=-1)
            else:
                xd = np.stack([np.interp(tc, self.t, self.xd[:, i]) for i in range(k)], axis=-1)
        return Trajectory(t, q, qd, qdd, x, xd, xdd, joint_names=self.joint_names,
                          axis_names=self.axis_names, revolute=self.revolute)

    def plot(self, ax=None, **kwargs):
        """Position, velocity and acceleration against time (:func:`labkit.plotting.plot_trajectory`).

        Parameters
        ----------
        ax : sequence of 3 matplotlib Axes, optional
            Where to draw; a new figure if omitted.
        **kwargs
            Passed to :func:`labkit.plotting.plot_trajectory` (``space``,
            ``degrees``, ``units``, ``title``).

        Returns
        -------
        ndarray of 3 Axes
        """
        from labkit.plotting import plot_trajectory

        return plot_trajectory(self, ax, **kwargs)

    def __repr__(self):
        extra = f", axes={self.axis_names}" if self.x is not None else ""
        return (
            f"Trajectory(N={len(self)}, t=[{self.t[0]:g}, {self.t[-1]:g}] s, "
            f"joints={self.joint_names}{extra})"
        )


def law_trajectory(law, t=None, *, dt=0.01, joint_names=(), revolute=()):
    """Sample a joint-space :class:`TimeLaw` into a :class:`Trajectory`.

    Parameters
    ----------
    law : TimeLaw
        Law with values of shape (n,).
    t : array_like, shape (N,), optional
        Sample times [s]; default ``time_grid(law.t0, law.tf, dt)``.
    dt : float
        Step [s] when ``t`` is not given.
    joint_names : sequence of str, optional
        Name per joint (for tables and plots).
    revolute : sequence of bool, optional
        Whether each joint is revolute (units in tables and plots).

    Returns
    -------
    Trajectory

    Raises
    ------
    ShapeError
        The law's values are not of shape (n,).
    """
    if not isinstance(law, TimeLaw):
        raise TrajectoryError(f"expected law as a TimeLaw (cubic_law, via_law ...), got {law!r}")
    if len(law.shape) != 1:
        raise ShapeError(f"expected a law with values of shape (n,), got {law.shape}")
    t = time_grid(law.t0, law.tf, dt) if t is None else as_batch(t, (), "times t")
    return Trajectory(
        t,
        law.position(t),
        law.velocity(t),
        law.acceleration(t),
        joint_names=joint_names,
        revolute=revolute,
        law=law,
    )


def _robot_info(robot, n):
    if check_robot(robot, optional=True) is None:
        return (), ()
    if robot.n != n:
        raise ShapeError(f"{robot.name} has {robot.n} joints; expected q with shape (..., {robot.n}), got (..., {n})")
    return robot.joint_names, tuple(bool(r) for r in robot.is_revolute)


def _round_up(T, dt):
    """Round a duration up to a whole number of steps (to 1e-9)."""
    k = math.ceil(T / dt - 1e-9)
    return max(k, 1) * dt


def joint_trajectory(robot, q0, qf, duration=None, *, law="cubic", dt=0.01, t=None,
                     check_limits=True, check_speed_limits=False, **law_options):
    """A point-to-point joint move.

    Parameters
    ----------
    robot : Robot or None
        Gives joint names, limits and speed bounds; ``None`` for bare joint
        values (no names, nothing checked).
    q0, qf : array_like, shape (n,)
        Start and end configurations [rad, m].
    duration : float, optional
        Move time [s]. If omitted, the shortest duration that respects the
        robot's ``max_velocity`` / ``max_acceleration`` for this law, rounded
        up to a whole number of steps ``dt``.
    law : {"cubic", "quintic", "lspb", "linear"} or LawName
        Time law (rest to rest unless ``v0``/``vf``... are passed in
        ``law_options``).
    dt : float
        Sample step [s].
    t : array_like, shape (N,), optional
        Explicit sample times instead of ``dt``.
    check_limits : bool
        With a robot, raise :class:`JointLimitError` at the first sample
        outside the joint limits.
    check_speed_limits : bool
        With a robot, raise :class:`TrajectoryError` if a joint exceeds its
        speed/acceleration bound (the message gives the minimum duration).
    **law_options
        Passed to the law (``v0``, ``vf``, ``a0``, ``af``, ``v_max``, ...).

    Returns
    -------
    Trajectory
        With ``law`` set (exact :meth:`Trajectory.resample`).

    Examples
    --------
    >>> traj = joint_trajectory(None, [0.0, 0.0, 1.57], [-0.8, 0.8, 0.8], 5.0, dt=0.1)
    >>> traj.law.coefficients[0, :, 2]  # a0..a3 of joint 3 (seed 003, task 2)
    array([ 1.57   ,  0.     , -0.0924 ,  0.01232])
    """
    q0 = np.atleast_1d(as_batch(q0, (), "q0"))
    n = q0.shape[-1]
    if q0.ndim != 1:
        raise ShapeError(f"expected q0 with shape (n,), got {q0.shape}")
    qf = as_batch(qf, (n,), "qf")
    names, rev = _robot_info(robot, n)
    if t is None:
        dt = _number(dt, "a time step dt")
        if dt <= 0:
            raise TrajectoryError(f"expected a positive time step dt [s], got {dt!r}")
    if duration is not None and t is None:
        d = float(duration) if isinstance(duration, (int, float)) and not isinstance(duration, bool) else math.nan
        if not (math.isfinite(d) and d >= dt):
            raise TrajectoryError(f"expected a finite duration of at least one step dt = {dt:g} s (else the "
                                  f"trajectory never leaves q0), got {duration!r}")
    if duration is None:
        if robot is None:
            raise TrajectoryError("give a duration, or a robot whose joints have max_velocity/max_acceleration: expected one of them, got neither")
        v, a = _robot_bounds(robot)
        T = minimum_duration(qf - q0, v_max=v, a_max=a, law=law)
        if T == 0.0 and np.any(qf != q0):
            raise TrajectoryError(
                f"{robot.name} gives no max_velocity/max_acceleration: cannot choose a duration, give one"
            )
        duration = _round_up(T, dt) if T > 0 else dt
    tl = make_law(law, q0, qf, duration, **law_options)
    traj = law_trajectory(tl, t, dt=dt, joint_names=names, revolute=rev)
    return _checked(traj, robot, check_limits, check_speed_limits)


