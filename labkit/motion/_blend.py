"""Blended multi-segment paths: straight segments between via points joined by parabolic blends.

The joint-space (or Cartesian) analogue of roboticstoolbox's ``mstraj`` and of Craig's
"linear function with parabolic blends for a path with via points" (ch. 7): the
coordinates move at constant velocity ``v_k = (P_{k+1} - P_k) / d_k`` between via
points, and around each via point a blend of duration ``tau`` (constant acceleration
``(v_k - v_{k-1}) / tau``, centred on the via time) turns from one velocity to the
next. The motion starts at the first point and stops at the last one exactly (from and
to rest) but passes *near* the interior via points: at via time the blend misses the
corner by ``|v_k - v_{k-1}| tau / 8``. Through-the-points trajectories are
:func:`labkit.motion.via_trajectory`.

Timing, if not given: every segment takes the time of its slowest coordinate at
``v_max`` (at least ``tau``), and ``tau`` is the shortest blend whose acceleration stays
within ``a_max`` at every via point; both are iterated to a fixed point.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import PPoly

from labkit.exceptions import ShapeError, TrajectoryError
from labkit.validation import as_batch, as_number
from labkit.motion._timelaw import LawName, TimeLaw
from labkit.motion._checks import _checked, _robot_bounds
from labkit.motion._trajectory import Trajectory, _robot_info, law_trajectory
from labkit.motion._paths import waypoint_path
from labkit.motion._cartesian import _choose_branch, _solve, _target_kind
from labkit.motion._rates import joint_rates_and_accelerations
from labkit.motion._laws import _bounds, time_grid
from labkit import kinematics

__all__ = ["blended_law", "blended_trajectory", "cartesian_blended_trajectory"]


def _points(points):
    P = as_batch(points, (), "points", finite=False)
    if P.ndim == 1:
        P = P[:, None]
    if P.ndim != 2 or P.shape[0] < 2:
        raise ShapeError(f"expected via points with shape (m, n), m >= 2, got {np.shape(points)}")
    if not np.all(np.isfinite(P)):
        raise ShapeError("expected finite via points")
    return P


def _velocities(P, d):
    """Segment velocities with rest before and after: shape (m + 1, n)."""
    v = np.diff(P, axis=0) / d[:, None]
    zero = np.zeros((1, P.shape[1]))
    return np.concatenate([zero, v, zero])


def _timing(P, v_max, a_max, durations, blend_time):
    m, n = P.shape
    dP = np.abs(np.diff(P, axis=0))
    if durations is not None:
        d = as_batch(durations, (), "durations", finite=False)
        if d.shape not in ((), (m - 1,)):
            raise ShapeError(f"expected one duration or {m - 1} segment durations, got shape {d.shape}")
        d = np.broadcast_to(d, (m - 1,)).copy()
        if not np.all(np.isfinite(d)) or np.any(d <= 0):
            raise TrajectoryError(f"expected positive segment durations [s], got {d.tolist()}")
    else:
        if not np.all(np.isfinite(v_max)):
            raise TrajectoryError("expected durations, or a finite v_max (or a robot with max_velocity) for every "
                                  f"coordinate, got v_max = {np.asarray(v_max).tolist()}")
        d = np.max(dP / v_max, axis=1)
        d = np.where(d > 0, d, 1e-3)
    if blend_time is not None:
        tau = as_number(blend_time, "blend_time", unit="s", positive=True, error=TrajectoryError)
        if durations is None:
            d = np.maximum(d, tau)
        return d, tau
    if not np.all(np.isfinite(a_max)):
        raise TrajectoryError("expected blend_time, or a finite a_max (or a robot with max_acceleration) for every "
                              f"coordinate, got a_max = {np.asarray(a_max).tolist()}")
    tau = 0.0
    for _ in range(50):  # tau needs the velocities, which need the durations (>= tau): fixed point
        dv = np.abs(np.diff(_velocities(P, d), axis=0))
        new_tau = float(np.max(dv / a_max))
        if durations is None:
            d = np.maximum(d, new_tau)
        if abs(new_tau - tau) <= 1e-12 * max(1.0, new_tau):
            break
        tau = new_tau
    return d, max(new_tau, 1e-9)


def blended_law(robot, points, *, durations=None, v_max=None, a_max=None, blend_time=None):
    """Straight segments between via points with parabolic blends around them (``mstraj``).

    Parameters
    ----------
    robot : Robot or None
        Supplies the bounds of joint-space points; ``None`` for other
        coordinates (Cartesian, or joints with the bounds given here).
    points : array_like, shape (m, n)
        Via points [rad, m or any unit], ``m >= 2``; the first and last are reached at rest.
    durations : float or array_like, shape (m - 1,), optional
        Time between consecutive via times [s]; default from ``v_max`` (slowest coordinate).
    v_max, a_max : float or array_like, shape (n,), optional
        Speed [unit/s] and acceleration [unit/s^2] bounds; default the robot's
        ``max_velocity`` / ``max_acceleration`` (``None`` with no robot: unbounded).
    blend_time : float, optional
        Blend duration ``tau`` [s]; default the shortest within ``a_max``.

    Returns
    -------
    TimeLaw
        Piecewise quadratic (law ``"blended"``) from 0 to ``sum(durations) + tau``;
        via point ``k`` is passed (nearest) at ``t = tau / 2 + sum(durations[:k])``.

    Raises
    ------
    TrajectoryError
        Missing or non-positive timing, blends that overlap (``tau`` longer than a
        segment) or, with given timing, a blend or segment over ``a_max`` / ``v_max``.

    Examples
    --------
    >>> law = blended_law(None, [[0.0], [1.0], [1.0]], durations=1.0, blend_time=0.5)
    >>> float(law.duration), law.degree
    (2.5, 2)
    >>> float(law.position(0.25 + 1.0)[0])  # misses the corner at 1.0 by |dv| tau / 8
    0.9375
    """
    P = _points(points)
    m, n = P.shape
    if robot is not None and robot.n == n:
        rv, ra = _robot_bounds(robot)
        v_max = rv if v_max is None else v_max
        a_max = ra if a_max is None else a_max
    vb, ab = _bounds(v_max, "v_max", (n,)), _bounds(a_max, "a_max", (n,))
    d, tau = _timing(P, vb, ab, durations, blend_time)
    if np.any(d < tau * (1 - 1e-12)):
        k = int(np.argmin(d))
        raise TrajectoryError(
            f"blends of {tau:.4g} s overlap: segment {k + 1} lasts {d[k]:.4g} s; expected every segment "
            f">= blend_time (lengthen the segments or shorten the blends)"
        )
    v = _velocities(P, d)  # v[k] enters via point k, v[k + 1] leaves it
    acc = np.diff(v, axis=0) / tau
    over_v = np.abs(v) > vb * (1 + 1e-9)
    over_a = np.abs(acc) > ab * (1 + 1e-9)
    if np.any(over_v):
        k, j = np.argwhere(over_v)[0]
        raise TrajectoryError(f"segment {k} coordinate {j + 1} needs {abs(v[k, j]):.4g}/s > v_max {vb[j]:.4g}/s")
    if np.any(over_a):
        k, j = np.argwhere(over_a)[0]
        raise TrajectoryError(
            f"blend at via point {k + 1} coordinate {j + 1} needs {abs(acc[k, j]):.4g}/s^2 > a_max {ab[j]:.4g}/s^2 "
            f"(lengthen blend_time or the segments)"
        )
    T = tau / 2 + np.concatenate([[0.0], np.cumsum(d)])  # via times
    breaks, coeffs = [0.0], []
    for k in range(m):
        # blend around via point k: from the incoming line, constant acceleration
        start = P[k] - v[k] * tau / 2
        coeffs.append(np.stack([0.5 * acc[k], v[k], start]))
        breaks.append(T[k] + tau / 2)
        if k < m - 1 and d[k] - tau > 1e-12 * max(1.0, d[k]):
            coeffs.append(np.stack([np.zeros(n), v[k + 1], P[k] + v[k + 1] * tau / 2]))
            breaks.append(T[k + 1] - tau / 2)
    c = np.stack(coeffs, axis=1)  # (3, pieces, n)
    return TimeLaw(PPoly(c, np.array(breaks)), LawName.BLENDED)


def blended_trajectory(robot, points, *, durations=None, v_max=None, a_max=None, blend_time=None,
                       dt=0.01, t=None, check_limits=True, check_speed_limits=False):
    """A joint trajectory passing near via points with parabolic blends, sampled.

    Parameters
    ----------
    robot : Robot or None
        Joint names, limits and speed bounds; ``None`` for bare joint values
        (nothing checked).
    points : array_like, shape (m, n)
        Via configurations [rad, m]; the first and last are reached at rest.
    durations, v_max, a_max, blend_time
        As :func:`blended_law` (bounds default to the robot's).
    dt : float
        Sample step [s].
    t : array_like, shape (N,), optional
        Explicit sample times [s].
    check_limits, check_speed_limits : bool
        As :func:`labkit.motion.via_trajectory`.

    Returns
    -------
    Trajectory
        With ``law`` (named ``"blended"``).

    Examples
    --------
    >>> traj = blended_trajectory(None, [[0.0, 0.0], [0.5, 1.0], [1.0, 0.0]], v_max=1.0, a_max=4.0, dt=0.05)
    >>> bool(np.abs(traj.qd).max() <= 1.0 + 1e-12), bool(np.abs(traj.qdd).max() <= 4.0 + 1e-12)
    (True, True)
    """
    law = blended_law(robot, points, durations=durations, v_max=v_max, a_max=a_max, blend_time=blend_time)
    names, rev = _robot_info(robot, law.shape[0])
    traj = law_trajectory(law, t, dt=dt, joint_names=names, revolute=rev)
    return _checked(traj, robot, check_limits, check_speed_limits)


def cartesian_blended_trajectory(robot, points, *, durations=None, v_max=None, a_max=None, blend_time=None,
                                 branch=None, q_start=None, dt=0.01, t=None, check_limits=True,
                                 check_speed_limits=False):
    """A Cartesian trajectory along straight lines between via points with parabolic blends, solved by IK.

    The tool point (and, for planar arms, ``phi``) follows :func:`blended_law` in
    Cartesian coordinates: straight lines at constant speed, blends near the interior
    via points; every sample is solved on one IK branch.

    Parameters
    ----------
    robot : Robot
        A robot with position targets ``(x, y, z)`` or planar ``(x, y, phi)`` targets.
    points : array_like, shape (m, 3)
        Via targets [m, or m, m, rad].
    durations, blend_time : optional
        As :func:`blended_law`.
    v_max, a_max : float or array_like, shape (3,)
        Cartesian bounds [m/s, m/s^2 (rad/s, rad/s^2 for phi)]; needed unless
        durations and blend_time are given.
    branch, q_start
        IK branch, or chosen at the first point (nearest ``q_start``).
    dt, t, check_limits, check_speed_limits
        As :func:`labkit.motion.via_trajectory`.

    Returns
    -------
    Trajectory
        Joint samples and ``x``, ``xd``, ``xdd`` (the blended Cartesian law).

    Raises
    ------
    ShapeError
        For a robot whose IK targets are poses.
    UnreachableError, JointLimitError
        At the first sample that cannot be solved (time, point).

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> arm = Robot.load("arduino_arm_3dof")
    >>> P = [[0.15, 0.02, -0.10], [0.20, 0.10, -0.05], [0.10, 0.18, -0.10]]
    >>> traj = cartesian_blended_trajectory(arm, P, v_max=0.1, a_max=0.5, branch="elbow_up", dt=0.05)
    >>> bool(np.allclose(traj.x[0], P[0])), bool(np.allclose(traj.x[-1], P[-1]))
    (True, True)
    """
    kind, q_start = _target_kind(robot, q_start)
    if kind == "pose":
        raise ShapeError(f"{robot.name}: blended Cartesian paths take position or planar targets, not poses")
    law = blended_law(None, points, durations=durations, v_max=v_max, a_max=a_max, blend_time=blend_time)
    if law.shape != (3,):
        raise ShapeError(f"expected via targets with shape (m, 3), got {np.shape(points)}")
    ts = time_grid(law.t0, law.tf, dt) if t is None else as_batch(t, (), "times t")
    x = np.asarray(law.position(ts))
    xd = np.asarray(law.velocity(ts))
    xdd = np.asarray(law.evaluate(ts, 2))
    P = _points(points)
    where = waypoint_path(P if kind == "position" else np.column_stack([P[:, :2], np.zeros(len(P))]))
    if branch is None and kinematics.solver_for(robot).value != "numeric":
        branch = _choose_branch(robot, x[0], q_start)
    q = np.asarray(_solve(robot, kind, x, ts, branch, where, q_start), dtype=float)
    rev = robot.is_revolute
    q[:, rev] = np.unwrap(q[:, rev], axis=0)
    qd, qdd = joint_rates_and_accelerations(robot, kind, q, xd, xdd)
    axes = ("x", "y", "z") if kind == "position" else ("x", "y", "phi")
    traj = Trajectory(ts, q, qd, qdd, x, xd, xdd=xdd, joint_names=robot.joint_names, axis_names=axes,
                      revolute=tuple(bool(r) for r in rev))
    return _checked(traj, robot, check_limits, check_speed_limits)
