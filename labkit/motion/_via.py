"""Joint trajectories through via points: cubic segments with heuristic or given
via velocities, or a cubic spline with clamped or natural ends."""

from __future__ import annotations

from enum import Enum

import numpy as np
from scipy.interpolate import CubicHermiteSpline, CubicSpline, PPoly

from labkit.exceptions import OptionError, ShapeError, TrajectoryError
from labkit.validation import as_batch
from labkit.motion._timelaw import LawName, TimeLaw
from labkit.motion._laws import _law_name, minimum_duration
from labkit.motion._checks import _checked, _robot_bounds
from labkit.motion._trajectory import _robot_info, law_trajectory

__all__ = ["SplineEnds", "via_law", "via_trajectory", "heuristic_velocities"]



class SplineEnds(str, Enum):
    """End conditions of a via-point spline: ``"clamped"`` (given end
    velocities, zero by default) or ``"natural"`` (zero end accelerations)."""

    CLAMPED = "clamped"
    NATURAL = "natural"



def _floats(value, name):
    """``value`` as a float array, else :class:`ShapeError` saying what came."""
    return as_batch(value, (), name, finite=False)


def _end_velocity(value, n, name):
    """An end velocity: one finite number for every coordinate, or ``n`` of them."""
    v = as_batch(value, (), name)
    try:
        return np.broadcast_to(v, (n,))
    except ValueError:
        raise ShapeError(f"expected {name} as a number or with shape ({n},), got shape {v.shape}") from None


def heuristic_velocities(points, times, *, v0=0.0, vf=0.0):
    """Via-point velocities by the usual heuristic (Craig, ch. 7).

    At an interior via point the velocity is the mean of the two adjacent
    segment slopes, or zero where the slope changes sign (the joint turns
    back there); the end velocities are ``v0`` and ``vf``.

    Parameters
    ----------
    points : array_like, shape (m, n)
        Via points [rad, m], ``m >= 2``.
    times : array_like, shape (m,)
        Their times [s], increasing.
    v0, vf : float or array_like, shape (n,)
        Velocities at the first and last point [rad/s, m/s].

    Returns
    -------
    ndarray, shape (m, n)

    Examples
    --------
    >>> heuristic_velocities([[0.0], [1.0], [3.0], [2.0]], [0.0, 1.0, 2.0, 3.0])[:, 0]
    array([0. , 1.5, 0. , 0. ])
    """
    P = as_batch(points, (), "points")
    if P.ndim != 2 or P.shape[0] < 2:
        raise ShapeError(f"expected via points with shape (m, n), m >= 2, got {P.shape}")
    t = as_batch(times, (P.shape[0],), "times")
    if t.ndim != 1 or not np.all(np.diff(t) > 0):
        raise TrajectoryError(f"expected increasing times of shape ({P.shape[0]},), got {np.round(t, 6).tolist()}")
    v0, vf = _end_velocity(v0, P.shape[1], "v0"), _end_velocity(vf, P.shape[1], "vf")
    slopes = np.diff(P, axis=0) / np.diff(t)[:, None]
    V = np.zeros_like(P)
    if P.shape[0] > 2:
        left, right = slopes[:-1], slopes[1:]
        same = np.sign(left) * np.sign(right) > 0
        V[1:-1] = np.where(same, 0.5 * (left + right), 0.0)
    V[0] = v0
    V[-1] = vf
    return V


def _via_times(points, times, durations, robot):
    m = points.shape[0]
    if times is not None and durations is not None:
        raise TrajectoryError("give either times or durations, not both")
    if times is not None:
        t = _floats(times, "times").reshape(-1)
        if t.shape != (m,):
            raise ShapeError(f"expected times with shape ({m},), got {t.shape}")
    else:
        if durations is None:
            if robot is None:
                raise TrajectoryError("give times or durations, or a robot with speed limits")
            v, a = _robot_bounds(robot)
            d = np.array([minimum_duration(points[i + 1] - points[i], v_max=v, a_max=a, law="cubic")
                          for i in range(m - 1)])
            if np.any(d == 0) and np.any(np.diff(points, axis=0) != 0):
                raise TrajectoryError(f"{robot.name} gives no speed limits: give times or durations")
            d = np.maximum(d, 1e-3)
        else:
            d = np.broadcast_to(_floats(durations, "durations"), (m - 1,))
        t = np.concatenate([[0.0], np.cumsum(d)])
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise TrajectoryError(f"expected strictly increasing finite via times [s], got {t.tolist()}")
    return t


def via_law(robot, points, times=None, *, durations=None, law="via_cubic", velocities=None,
            ends="clamped", v0=0.0, vf=0.0):
    """A piecewise-cubic law through via points.

    Parameters
    ----------
    robot : Robot or None
        Speed bounds for automatic durations; ``None`` when times or
        durations are given.
    points : array_like, shape (m, n)
        Configurations to pass through [rad, m], ``m >= 2``.
    times : array_like, shape (m,), optional
        Absolute times of the points [s].
    durations : float or array_like, shape (m - 1,), optional
        Segment durations [s] (times start at 0). With neither times nor
        durations, each segment gets the shortest rest-to-rest cubic duration
        allowed by the robot's speed/acceleration bounds.
    law : {"via_cubic", "spline"} or LawName
        ``"via_cubic"``: cubic segments (``CubicHermiteSpline``) with
        continuous velocity; via velocities given or heuristic. ``"spline"``:
        a cubic spline (``CubicSpline``) with continuous acceleration.
    velocities : array_like, shape (m, n), optional
        Via velocities for ``"via_cubic"`` [rad/s, m/s].
    ends : {"clamped", "natural"}
        Spline end conditions (``"spline"`` only).
    v0, vf : float or array_like, shape (n,)
        End velocities ("via_cubic" heuristic and clamped spline).

    Returns
    -------
    TimeLaw
        ``m - 1`` cubic segments; ``law.coefficients`` gives a0..a3 per segment.

    Examples
    --------
    >>> law = via_law(None, [[0.0], [1.0], [0.5]], durations=1.0, law="spline", ends="natural")
    >>> law.n_segments, law.degree
    (2, 3)
    """
    P = _floats(points, "points")
    if P.ndim == 1:
        P = P[:, None]
    if P.ndim != 2 or P.shape[0] < 2:
        raise ShapeError(f"expected via points with shape (m, n), m >= 2, got {np.shape(points)}")
    if not np.all(np.isfinite(P)):
        raise ShapeError("expected finite via points")
    name = _law_name(law, (LawName.VIA_CUBIC, LawName.SPLINE))
    try:
        end = SplineEnds(ends)
    except ValueError:
        raise OptionError(f"expected ends in {{'clamped', 'natural'}}, got {ends!r}") from None
    t = _via_times(P, times, durations, robot)
    n = P.shape[1]
    v0, vf = _end_velocity(v0, n, "v0"), _end_velocity(vf, n, "vf")
    if name is LawName.VIA_CUBIC:
        if velocities is None:
            V = heuristic_velocities(P, t, v0=v0, vf=vf)
        else:
            V = as_batch(velocities, (), "velocities")
            if V.shape != P.shape:
                raise ShapeError(f"expected velocities with shape {P.shape}, got {V.shape}")
        spl = CubicHermiteSpline(t, P, V, axis=0)
    else:
        bc = ((1, v0), (1, vf)) if end is SplineEnds.CLAMPED else "natural"
        spl = CubicSpline(t, P, axis=0, bc_type=bc)
    return TimeLaw(PPoly(spl.c, spl.x), name)


def via_trajectory(robot, points, times=None, *, durations=None, law="via_cubic", velocities=None,
                   ends="clamped", v0=0.0, vf=0.0, dt=0.01, t=None,
                   check_limits=True, check_speed_limits=False):
    """A joint trajectory through via points, sampled.

    Parameters
    ----------
    robot : Robot or None
        Joint names, limits and speed bounds; ``None`` for bare joint values
        (times or durations needed, nothing checked).
    points : array_like, shape (m, n)
        Configurations to pass through [rad, m], ``m >= 2``.
    times : array_like, shape (m,), optional
        Absolute times of the points [s].
    durations : float or array_like, shape (m - 1,), optional
        Segment durations [s] (times start at 0). With neither times nor
        durations, each segment gets the shortest rest-to-rest cubic duration
        allowed by the robot's speed/acceleration bounds.
    law : {"via_cubic", "spline"} or LawName
        Cubic segments with continuous velocity, or a cubic spline with
        continuous acceleration (see :func:`via_law`).
    velocities : array_like, shape (m, n), optional
        Via velocities for ``"via_cubic"`` [rad/s, m/s]; default heuristic.
    ends : {"clamped", "natural"}
        Spline end conditions (``"spline"`` only).
    v0, vf : float or array_like, shape (n,)
        End velocities [rad/s, m/s] ("via_cubic" heuristic and clamped spline).
    dt : float
        Sample step [s].
    t : array_like, shape (N,), optional
        Explicit sample times [s] instead of ``dt``.
    check_limits : bool
        With a robot, raise :class:`JointLimitError` at the first sample
        outside the joint limits.
    check_speed_limits : bool
        With a robot, raise :class:`TrajectoryError` if a joint exceeds its
        speed/acceleration bound (the message gives the minimum duration).

    Returns
    -------
    Trajectory

    Raises
    ------
    JointLimitError
        A sample outside the joint limits (``check_limits``).
    TrajectoryError
        A joint over its speed/acceleration bound (``check_speed_limits``).

    Examples
    --------
    >>> P = np.radians([[0, 0, 0], [20, 30, -10], [40, 45, -30], [30, 60, -45], [10, 70, -60]])
    >>> traj = via_trajectory(None, P, durations=1.0, law="spline", dt=0.1)
    >>> traj.t[-1], traj.law.n_segments
    (np.float64(4.0), 4)
    """
    tl = via_law(robot, points, times, durations=durations, law=law, velocities=velocities,
                 ends=ends, v0=v0, vf=vf)
    names, rev = _robot_info(robot, tl.shape[0])
    traj = law_trajectory(tl, t, dt=dt, joint_names=names, revolute=rev)
    return _checked(traj, robot, check_limits, check_speed_limits)


