"""Cartesian paths: lines, arcs, circles and waypoints, timed and solved by IK.

A :class:`CartesianPath` is geometry only: a point ``p(s)`` for a path parameter
``s`` in ``[0, s_max]`` (1 for a line, arc or circle; the number of segments
for waypoints). A time law ``s(t)`` (cubic by default, any of
:mod:`labkit.motion`) gives the timing, so
``x(t) = p(s(t))``, ``xd = p'(s) s'``, ``xdd = p''(s) s'^2 + p'(s) s''``.
:func:`cartesian_trajectory` then solves inverse kinematics
(:func:`labkit.kinematics.ik`) at every sample on one consistent branch and returns a
:class:`labkit.motion.Trajectory` holding both joint and Cartesian
samples, raising on the first unreachable sample (time, point, by how much)
or joint-limit violation.

Orientation: planar arms take ``phi`` [rad] (held, or interpolated between
keys); 6-DOF arms take rotation matrices (held, or slerped with
:class:`scipy.spatial.transform.Slerp`); position-only arms (the 3-DOF
Arduino arm) ignore orientation.

The path geometry (:class:`CartesianPath`, :func:`line_path`,
:func:`arc_path`, :func:`circle_path`, :func:`waypoint_path`) is defined in
the private ``labkit.motion._paths``; import it from :mod:`labkit.motion`.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy.interpolate import PPoly
from scipy.spatial.transform import Rotation, Slerp

from labkit.motion._paths import CartesianPath, waypoint_path
from labkit.validation import as_batch, as_number, check_robot
from labkit.exceptions import JointLimitError, ShapeError, TrajectoryError, UnreachableError
from labkit.motion._timelaw import TimeLaw
from labkit.motion._laws import make_law, time_grid
from labkit.motion._trajectory import Trajectory
from labkit.motion._checks import check_joint_limits, check_speed
from labkit.motion._rates import joint_rates_and_accelerations
from labkit import kinematics

__all__ = ["path_law", "cartesian_trajectory", "cartesian_via_trajectory"]


def path_law(path, duration, law="cubic", *, t0=0.0, **options):
    """Time law ``s(t)`` for a path: rest to rest from 0 to ``path.s_max``.

    For waypoints, one rest-to-rest law per segment (the arm stops at each
    waypoint); ``duration`` is then the total (split in proportion to
    segment length) or one duration per segment.

    Parameters
    ----------
    path : CartesianPath
    duration : float or array_like, shape (m - 1,)
        [s].
    law : {"cubic", "quintic", "lspb", "linear"} or TimeLaw
        A ready-made scalar :class:`TimeLaw` from 0 to ``s_max`` is used as is.
    t0 : float
        Start time [s].
    **options
        Passed to :func:`labkit.motion.make_law` (e.g. ``v_max``, ``a_max``
        or ``blend_time`` of an LSPB).

    Returns
    -------
    TimeLaw
        Scalar law of ``s``.

    Examples
    --------
    >>> from labkit.motion import line_path
    >>> path_law(line_path([0, 0, 0], [1, 0, 0]), 2.0).coefficients[0]
    array([ 0.  ,  0.  ,  0.75, -0.25])
    """
    if not isinstance(path, CartesianPath):
        raise TrajectoryError(f"expected path as a CartesianPath (line_path, arc_path ...), got {path!r}")
    if isinstance(law, TimeLaw):
        if law.shape != () or abs(law.position(law.t0) - 0) > 1e-12 or abs(law.position(law.tf) - path.s_max) > 1e-9:
            raise TrajectoryError(f"expected a scalar time law from s = 0 to s = {path.s_max:g}, got {law!r}")
        return law
    m = int(round(path.s_max))
    if path.shape != "waypoints" or m == 1:
        return make_law(law, 0.0, path.s_max, float(np.sum(as_batch(duration, (), "duration"))), t0=t0, **options)
    d = as_batch(duration, (), "duration")
    if d.ndim == 0:
        seg = np.linalg.norm(np.diff(path.points, axis=0), axis=-1)
        d = float(d) * (seg / seg.sum() if seg.sum() > 0 else np.full(m, 1.0 / m))
    if d.shape != (m,):
        raise ShapeError(f"expected one duration or {m} segment durations, got shape {d.shape}")
    starts = t0 + np.concatenate([[0.0], np.cumsum(d)])
    laws = [make_law(law, float(k), float(k + 1), d[k], t0=starts[k], **options) for k in range(m)]
    kmax = max(lw.degree for lw in laws)
    cs = [np.concatenate([np.zeros((kmax - lw.degree,) + lw.ppoly.c.shape[1:]), lw.ppoly.c]) for lw in laws]
    x = np.concatenate([laws[0].breaks] + [lw.breaks[1:] for lw in laws[1:]])
    return TimeLaw(PPoly(np.concatenate(cs, axis=1), x), laws[0].name)


# -- orientation ----------------------------------------------------------------

def _planar_orientation(orientation, s, path):
    keys = np.atleast_1d(np.asarray(orientation, dtype=float))
    if keys.ndim != 1 or not np.all(np.isfinite(keys)):
        raise ShapeError(f"expected orientation phi [rad] as a float or a 1-D sequence, got {orientation!r}")
    if keys.size == 1:
        return np.full(s.shape, keys[0]), np.zeros(s.shape)
    ks = np.linspace(0.0, path.s_max, keys.size)
    seg = np.clip(np.searchsorted(ks, s, side="right") - 1, 0, keys.size - 2)
    slope = (keys[seg + 1] - keys[seg]) / (ks[seg + 1] - ks[seg])
    return keys[seg] + slope * (s - ks[seg]), slope


def _rotations(orientation):
    if isinstance(orientation, Rotation):
        return orientation if not orientation.single else Rotation.concatenate([orientation])
    R = np.asarray(orientation, dtype=float)
    if R.shape == (3, 3):
        R = R[None]
    R = as_batch(R, (3, 3), "orientation")
    return Rotation.from_matrix(R.reshape(-1, 3, 3))


def _pose_orientation(orientation, s, path):
    """Rotation at each s (slerp between evenly spaced keys) and dR/ds as omega per unit s."""
    rots = _rotations(orientation)
    if len(rots) == 1:
        return Rotation.concatenate([rots] * s.size) if s.size else rots, np.zeros((s.size, 3))
    ks = np.linspace(0.0, path.s_max, len(rots))
    R = Slerp(ks, rots)(np.clip(s, 0.0, path.s_max))
    seg = np.clip(np.searchsorted(ks, s, side="right") - 1, 0, len(rots) - 2)
    rel = (rots[1:] * rots[:-1].inv()).as_rotvec()  # world-frame rotation per segment
    omega_per_s = rel[seg] / (ks[1] - ks[0])
    return R, omega_per_s


# -- the trajectory --------------------------------------------------------------

def _target_kind(robot, q_start):
    """The robot's target kind and ``q_start`` (shape (n,) or None), both checked."""
    kind = kinematics.target_kind(check_robot(robot))
    if q_start is not None:
        q_start = as_batch(q_start, (robot.n,), "q_start")
        if q_start.shape != (robot.n,):
            raise ShapeError(f"expected q_start with shape ({robot.n},), got {q_start.shape}")
    return kind, q_start


def _choose_branch(robot, target0, q_start):
    sols = kinematics.ik_all(robot, target0)
    valid = np.asarray(sols.valid).reshape(-1)
    if not np.any(valid):
        return None  # let ik() raise the precise error for sample 0
    q = np.asarray(sols.q).reshape(valid.size, robot.n)
    if q_start is None:
        idx = int(np.argmax(valid))
    else:
        dist = np.linalg.norm(q - np.asarray(q_start, dtype=float), axis=-1)
        dist[~valid] = np.inf
        idx = int(np.argmin(dist))
    return sols.branches[idx]


def _fmt_point(p, kind):
    if kind == "planar":
        return f"(x, y, phi) = ({p[0] * 1e3:.1f} mm, {p[1] * 1e3:.1f} mm, {math.degrees(p[2]):.1f} deg)"
    return "(" + ", ".join(f"{v * 1e3:.1f}" for v in p[:3]) + ") mm"


def _first_index(exc):
    idx = exc.index
    if idx is None:
        return None
    if isinstance(idx, (tuple, list, np.ndarray)):
        idx = np.ravel(idx)
        return int(idx[0]) if idx.size else None
    return int(idx)


def _solve_chained(robot, targets, q_start, offset, block=8):
    """Numeric IK along the path: each block of samples starts from the last solution."""
    out = np.empty((len(targets), robot.n))
    q_prev = None if q_start is None else np.asarray(q_start, dtype=float)
    for s in range(0, len(targets), block):
        offset[0] = s
        qb = kinematics.ik(robot, targets[s:s + block], q_near=q_prev)
        out[s:s + block] = qb
        q_prev = qb[-1]
    return out


def _solve(robot, kind, targets, t, branch, path, q_start=None):
    offset = [0]
    try:
        if kinematics.solver_for(robot).value == "numeric":
            return _solve_chained(robot, targets, q_start, offset)
        return kinematics.ik(robot, targets, branch=branch)
    except UnreachableError as exc:
        i = _first_index(exc)
        if i is None:
            raise
        i += offset[0]
        xi = targets[i][:3, 3] if np.ndim(targets[i]) == 2 else targets[i]
        raise UnreachableError(
            f"{robot.name}: {path.shape} sample {i} at t = {t[i]:.4g} s, point {_fmt_point(xi, kind)}, "
            f"is unreachable: {exc.distance * 1e3:.3g} mm outside the workspace ({exc})",
            distance=exc.distance,
            index=i,
        ) from exc
    except JointLimitError as exc:
        i = _first_index(exc)
        if i is None:
            raise
        i += offset[0]
        xi = targets[i][:3, 3] if np.ndim(targets[i]) == 2 else targets[i]
        raise JointLimitError(
            f"{robot.name}: {path.shape} sample {i} at t = {t[i]:.4g} s, point {_fmt_point(xi, kind)}: {exc}",
            joint=exc.joint,
            index=i,
        ) from exc


def cartesian_trajectory(robot, path, duration=None, *, law="cubic", dt=0.01, t=None,
                         orientation=None, branch=None, q_start=None, check_limits=True,
                         check_speed_limits=False, max_joint_step=math.pi / 2, **law_options):
    """Time a Cartesian path and solve IK at every sample on one branch.

    Parameters
    ----------
    robot : Robot
        Any robot :func:`labkit.kinematics.ik` solves: position targets (3-DOF arm),
        planar (x, y, phi) targets (planar 3R) or poses (6R).
    path : CartesianPath
        From :func:`line_path`, :func:`arc_path`, :func:`circle_path` or :func:`waypoint_path`.
    duration : float or array_like
        [s] (per segment for waypoints); ignored when ``law`` is a TimeLaw.
    law : {"cubic", "quintic", "lspb", "linear"} or TimeLaw
        Timing of the path parameter (see :func:`path_law`).
    dt : float
        Sample step [s]; or give the sample times ``t``.
    t : array_like, shape (N,), optional
        Sample times [s] (instead of ``dt``).
    orientation : float, sequence, (3, 3) or (k, 3, 3) array, Rotation
        Planar arms: ``phi`` [rad] held, or keys interpolated linearly over
        ``s``. 6-DOF arms: a rotation held, or keys slerped. Ignored for
        position-only arms. Default: the orientation of ``q_start``.
    branch : str, optional
        IK branch (e.g. ``"elbow_up"``); default the branch of the first valid
        solution at the first sample (nearest ``q_start`` if given), kept for
        the whole path.
    q_start : array_like, shape (n,), optional
        Current configuration: picks the branch and the default orientation.
    check_limits, check_speed_limits : bool
        Joint-limit check (the IK already rejects out-of-limit solutions) and
        speed/acceleration check (raises with the minimum duration).
    max_joint_step : float
        Largest joint change between consecutive samples [rad] before the
        path is declared discontinuous (a branch flip through a singularity).
    **law_options
        Passed to :func:`path_law` (e.g. ``t0`` [s], ``blend_time`` [s]).

    Returns
    -------
    Trajectory
        ``q, qd, qdd`` (``qd = J^-1 xd``, ``qdd = J^-1 (xdd - Jdot qd)``),
        and ``x, xd`` (x, y, z; x, y, phi; or x, y, z, roll, pitch, yaw).

    Raises
    ------
    UnreachableError
        Naming the first unreachable sample: index, time, point and distance.
    JointLimitError
        First sample whose solution on the branch violates a joint limit.
    TrajectoryError
        Over-speed (with minimum duration) or a discontinuous branch.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> from labkit.motion import line_path
    >>> arm = Robot.load("arduino_arm_3dof")
    >>> traj = cartesian_trajectory(arm, line_path([0, 0.18, -0.094], [0.1, 0.15, -0.2]), 5.0,
    ...                             dt=0.1, branch="elbow_up")
    >>> traj.q.shape, round(float(np.linalg.norm(traj.xd, axis=1).max()), 4)
    ((51, 3), 0.0446)
    """
    kind, q_start = _target_kind(robot, q_start)
    max_joint_step = as_number(max_joint_step, "max_joint_step", unit="rad", positive=True, error=TrajectoryError)
    s_law = path_law(path, duration, law, **law_options)
    t = time_grid(s_law.t0, s_law.tf, dt) if t is None else as_batch(t, (), "times t").reshape(-1)
    s, sd, sdd = s_law.position(t), s_law.velocity(t), s_law.acceleration(t)
    p, dp, ddp = path.evaluate(s)
    pd = dp * sd[:, None]
    pdd = ddp * sd[:, None] ** 2 + dp * sdd[:, None]
    if orientation is None and kind != "position":
        if q_start is None:
            raise TrajectoryError(f"{robot.name} needs an orientation (or q_start to hold its orientation)")
        T0 = robot.fk(q_start)
        orientation = math.atan2(T0[1, 0], T0[0, 0]) if kind == "planar" else T0[:3, :3]
    if kind == "position":
        targets, x, xd, xdd = p, p, pd, pdd
        axis_names = ("x", "y", "z")
    elif kind == "planar":
        phi, dphi = _planar_orientation(orientation, s, path)
        targets = np.column_stack([p[:, :2], phi])
        x = targets
        xd = np.column_stack([pd[:, :2], dphi * sd])
        xdd = np.column_stack([pdd[:, :2], dphi * sdd])
        axis_names = ("x", "y", "phi")
    else:
        R, omega_s = _pose_orientation(orientation, s, path)
        targets = np.tile(np.eye(4), (t.size, 1, 1))
        targets[:, :3, :3] = R.as_matrix()
        targets[:, :3, 3] = p
        rpy = np.unwrap(R.as_euler("xyz"), axis=0)
        x = np.column_stack([p, rpy])
        xd = np.column_stack([pd, omega_s * sd[:, None]])
        xdd = np.column_stack([pdd, omega_s * sdd[:, None]])
        axis_names = ("x", "y", "z", "roll", "pitch", "yaw")
    if branch is None and kinematics.solver_for(robot).value != "numeric":
        branch = _choose_branch(robot, targets[0], q_start)
    q = np.asarray(_solve(robot, kind, targets, t, branch, path, q_start), dtype=float)
    rev = robot.is_revolute
    if q.shape[0] > 1:
        step = np.diff(q, axis=0)
        np.abs(step, out=step)
        if not (step if rev.all() else step[:, rev]).max(initial=0.0) < math.pi:  # else unwrap changes nothing
            q[:, rev] = np.unwrap(q[:, rev], axis=0)
            step = np.abs(np.diff(q, axis=0))
        if np.any(step > max_joint_step):
            i, j = np.argwhere(step > max_joint_step)[0]
            raise TrajectoryError(
                f"{robot.name}: joint {j + 1} ({robot.joint_names[j]}) jumps by "
                f"{math.degrees(step[i, j]):.1f} deg between t = {t[i]:.4g} s and {t[i + 1]:.4g} s "
                f"(IK branch {branch!r} flips near a singularity); try another branch or path"
            )
    qd, qdd = joint_rates_and_accelerations(robot, kind, q, xd, xdd)
    resampler = functools.partial(_resample, robot, path, s_law, orientation, branch, q_start)
    traj = Trajectory(t, q, qd, qdd, x, xd, xdd=xdd, joint_names=robot.joint_names,
                      axis_names=axis_names, revolute=tuple(bool(r) for r in rev), resampler=resampler)
    if check_limits:
        check_joint_limits(robot, traj)
    if check_speed_limits:
        check_speed(robot, traj)
    return traj


def _resample(robot, path, s_law, orientation, branch, q_start, t):
    return cartesian_trajectory(robot, path, law=s_law, t=t, orientation=orientation, branch=branch,
                                q_start=q_start, check_limits=False)


def _cartesian_view(robot, kind, traj):
    """The trajectory with x, xd from FK and the Jacobian (joint-space via points)."""
    from labkit.motion._trajectory import law_trajectory

    T, J = kinematics.fk_jacobian(robot, traj.q)
    w = np.einsum("nij,nj->ni", J, traj.qd)
    if kind == "position":
        x, xd, axes = T[:, :3, 3], w[:, :3], ("x", "y", "z")
    elif kind == "planar":
        phi = np.unwrap(np.arctan2(T[:, 1, 0], T[:, 0, 0]))
        x, xd, axes = np.column_stack([T[:, :2, 3], phi]), w[:, [0, 1, 5]], ("x", "y", "phi")
    else:
        rpy = np.unwrap(Rotation.from_matrix(T[:, :3, :3]).as_euler("xyz"), axis=0)
        x, xd, axes = np.column_stack([T[:, :3, 3], rpy]), w, ("x", "y", "z", "roll", "pitch", "yaw")

    def resampler(t):
        return _cartesian_view(robot, kind, law_trajectory(traj.law, t, joint_names=traj.joint_names,
                                                     revolute=traj.revolute))

    return Trajectory(traj.t, traj.q, traj.qd, traj.qdd, x, xd, joint_names=traj.joint_names,
                      axis_names=axes, revolute=traj.revolute, law=traj.law, resampler=resampler)


def cartesian_via_trajectory(robot, points, times=None, *, durations=None, law="spline",
                             ends="clamped", branch=None, q_start=None, dt=0.01, t=None,
                             check_limits=True, check_speed_limits=False):
    """A joint-space trajectory through Cartesian via points (seed 003, task 5).

    Solves IK for each via point on one branch, then plans in joint space
    with :func:`labkit.motion.via_trajectory` (the end effector passes
    through every via point but not along straight lines between them).

    Parameters
    ----------
    robot : Robot
    points : array_like, shape (m, 3) or (m, 4, 4)
        Via targets as :func:`labkit.kinematics.ik` takes them: positions [m],
        planar ``(x, y, phi)`` [m, rad], or poses.
    times, durations, law, ends
        As :func:`labkit.motion.via_law` (``durations`` may be omitted
        when the robot has speed limits).
    branch, q_start
        IK branch, or chosen at the first via point (nearest ``q_start``).
    dt, t, check_limits, check_speed_limits
        As :func:`labkit.motion.via_trajectory`.

    Returns
    -------
    Trajectory
        Joint samples with ``law``, plus ``x``, ``xd`` from forward kinematics.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> arm = Robot.load("planar3r_seed003")
    >>> P = [[0.30, 0.0, 0.0], [0.28, 0.08, 0.3], [0.24, 0.15, 0.5], [0.18, 0.2, 0.8], [0.1, 0.24, 1.0]]
    >>> traj = cartesian_via_trajectory(arm, P, durations=1.0, branch="elbow_down", dt=0.5)
    >>> np.allclose(traj.x[::2], P)
    True
    """
    from labkit.motion._via import via_trajectory

    kind, q_start = _target_kind(robot, q_start)
    targets = as_batch(points, (), "points")
    m = targets.shape[0] if targets.ndim else 0
    if m < 2:
        raise ShapeError(f"expected at least 2 via points, got shape {targets.shape}")
    where = waypoint_path(targets[:, :3, 3] if targets.ndim == 3 else
                      (np.column_stack([targets[:, :2], np.zeros(m)]) if kind == "planar" else targets[:, :3]))
    if times is not None:
        tv = as_batch(times, (), "times")
    elif durations is not None:
        d = as_batch(durations, (), "durations")
        if d.shape not in ((), (m - 1,)):
            raise ShapeError(f"expected one duration or {m - 1} segment durations, got shape {d.shape}")
        tv = np.concatenate([[0.0], np.cumsum(np.broadcast_to(d, (m - 1,)))])
    else:
        tv = np.full(m, np.nan)
    if branch is None and kinematics.solver_for(robot).value != "numeric":
        branch = _choose_branch(robot, targets[0], q_start)
    q = np.asarray(_solve(robot, kind, targets, tv, branch, where, q_start), dtype=float)
    rev = robot.is_revolute
    q[:, rev] = np.unwrap(q[:, rev], axis=0)
    traj = via_trajectory(robot, q, times, durations=durations, law=law, ends=ends, dt=dt, t=t,
                          check_limits=check_limits, check_speed_limits=check_speed_limits)
    return _cartesian_view(robot, kind, traj)
