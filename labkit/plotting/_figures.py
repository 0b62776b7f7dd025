"""Plots for lab reports: the arm, its workspace, trajectories and paths.

Every function takes ``ax=None`` (a new figure and axes are made) and returns
the axes it drew on; nothing here touches global ``rcParams``. Inputs are in
SI units and radians; the plots show millimetres and degrees (the edges of
labkit, where a report wants them) unless told otherwise. Animations are in
:mod:`labkit.plotting` (:func:`animate_arm`, :func:`save_animation`).

Artists carry a ``gid`` so that tests and notebooks can find them:
``"arm-links"`` (one line per configuration), ``"arm-joints"``,
``"arm-tool"``, ``"arm-frame"`` (one per axis of each triad),
``"arm-orientation"``, ``"workspace"``, ``"path"``, ``"path-start"``,
``"path-end"``.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.validation import as_batch, as_count, as_number, check_robot, check_trajectory
from labkit.exceptions import OptionError, ShapeError

__all__ = [
    "is_planar",
    "plot_arm",
    "plot_workspace",
    "plot_time_series",
    "plot_trajectory",
    "plot_path_3d",
    "START_COLOR",
    "END_COLOR",
]

#: colours of the start and end configurations (seed 003: start red, end green)
START_COLOR = "tab:red"
END_COLOR = "tab:green"

_UNITS = {"mm": 1e3, "m": 1.0}
_FRAME_COLORS = ("tab:red", "tab:green", "tab:blue")  # x, y, z axes of a triad


def _scale(units):
    try:
        return _UNITS[units]
    except (KeyError, TypeError):
        raise OptionError(f"expected units in {{'mm', 'm'}}, got {units!r}") from None


def _is3d(ax):
    return getattr(ax, "name", "") == "3d"


def _new_axes(ax, three_d, figsize=None):
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=figsize or ((6.4, 5.6) if three_d else (6.0, 5.0)))
    return fig.add_subplot(projection="3d" if three_d else None)


def is_planar(robot, q=None):
    """Whether the arm moves in the world x-y plane (so a 2-D plot shows it all).

    True when every joint axis is parallel to world z and every frame origin
    has the same z, at ``q`` (default the zero configuration).

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (n,) or (N, n), optional
        Joint values [rad, m] to test at (the first row of a batch); default
        zeros.

    Returns
    -------
    bool
    """
    from labkit.kinematics import fk_frames

    check_robot(robot)
    q = np.zeros(robot.n) if q is None else as_batch(q, (robot.n,), "q").reshape(-1, robot.n)[0]
    F = fk_frames(robot, q)
    z_axes = F[:-1, :3, 2]
    return bool(np.allclose(np.abs(z_axes[:, 2]), 1.0, atol=1e-9)
                and np.ptp(F[:, 2, 3]) < 1e-9)


def _dims(robot, q, dims):
    if dims == "auto":
        return 2 if is_planar(robot, q) else 3
    if dims not in (2, 3):
        raise OptionError(f"expected dims in {{'auto', 2, 3}}, got {dims!r}")
    return dims


def _configs(robot, q):
    return as_batch(q, (check_robot(robot).n,), "q").reshape(-1, robot.n)


def _unique_chain(origins):
    """Drop consecutive coincident frame origins (modified DH stacks frames)."""
    keep = [0]
    for i in range(1, len(origins)):
        if np.linalg.norm(origins[i] - origins[keep[-1]]) > 1e-12:
            keep.append(i)
    return origins[keep]


def plot_arm(robot, q, ax=None, *, dims="auto", frames=False, frame_length=None,
             orientation_arrow=True, color="tab:blue", start_end=True, units="mm",
             label=None, alpha=None):
    """Draw the arm at one or several configurations.

    Links are straight lines between successive frame origins (base, joints,
    tool point), joints are circles and the tool point a square. With
    several configurations the first is drawn in red and the last in green
    (as seed 003 does) and those in between fade in.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (n,) or (k, n)
        Configuration(s) [rad, m].
    ax : matplotlib Axes, optional
        2-D axes, or 3-D axes (``projection="3d"``); new ones if omitted.
    dims : {"auto", 2, 3}
        2-D (x-y plane) or 3-D drawing; ``"auto"``: 2-D for planar arms.
    frames : bool
        Draw the x/y/z triads (red/green/blue) of every frame and the tool.
    frame_length : float, optional
        Triad length [m] (default 15 % of the arm's reach).
    orientation_arrow : bool
        An arrow along the tool x axis (end-effector orientation).
    color : color
        Colour of single or intermediate configurations.
    start_end : bool
        Colour the first/last of several configurations red/green.
    units : {"mm", "m"}
        Axis units.
    label : str, optional
        Legend label of the (last) configuration.
    alpha : float, optional
        Opacity of intermediate configurations (default fades from 0.25 to 0.6).

    Returns
    -------
    matplotlib Axes

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> ax = plot_arm(Robot.load("planar3r_seed003"), [[0, 0, 0], [0.5, 0.5, 0.5]])
    >>> len([ln for ln in ax.lines if ln.get_gid() == "arm-links"])
    2
    """
    from labkit.kinematics import fk_frames

    Q = _configs(robot, q)
    if alpha is not None and not 0.0 <= as_number(alpha, "alpha", error=OptionError) <= 1.0:
        raise OptionError(f"expected alpha from 0 to 1, got {alpha!r}")
    d = _dims(robot, Q[0], dims)
    s = _scale(units)
    ax = _new_axes(ax, d == 3)
    if (d == 3) != _is3d(ax):
        raise OptionError(f"expected {'3-D' if d == 3 else '2-D'} axes for dims={d}")
    F = fk_frames(robot, Q)  # (k, n + 2, 4, 4)
    reach = float(np.sum(np.abs(robot.a)) + np.sum(np.abs(robot.d)) + np.linalg.norm(robot.tool[:3, 3])) or 1.0
    L = (as_number(frame_length, "frame_length", unit="m", positive=True) if frame_length is not None
         else 0.15 * reach) * s
    k = len(Q)
    for c in range(k):
        if k > 1 and start_end and c == 0:
            col, a, lab = START_COLOR, 1.0, "start"
        elif k > 1 and start_end and c == k - 1:
            col, a, lab = END_COLOR, 1.0, label or "end"
        else:
            col = color
            a = 1.0 if k == 1 else (alpha if alpha is not None else 0.25 + 0.35 * c / max(k - 1, 1))
            lab = label if c == k - 1 else None
        chain = _unique_chain(F[c, :, :3, 3]) * s
        tool = F[c, -1]
        coords = (chain[:, 0], chain[:, 1]) if d == 2 else (chain[:, 0], chain[:, 1], chain[:, 2])
        ax.plot(*coords, "-", color=col, lw=3 if k == 1 or a == 1.0 else 2, alpha=a,
                solid_capstyle="round", gid="arm-links", label=lab, zorder=2)
        jc = tuple(x[:-1] for x in coords)
        ax.plot(*jc, "o", ms=7, mfc="white", mec=col, mew=1.6, alpha=a, gid="arm-joints",
                linestyle="none", zorder=3)
        tc = tuple(x[-1:] for x in coords)
        ax.plot(*tc, "s", ms=6, color=col, alpha=a, gid="arm-tool", linestyle="none", zorder=3)
        if orientation_arrow:
            p, xdir = tool[:3, 3] * s, tool[:3, 0]
            if d == 2:
                ax.annotate("", xy=(p[0] + L * xdir[0], p[1] + L * xdir[1]), xytext=(p[0], p[1]),
                            arrowprops=dict(arrowstyle="->", color=col, lw=1.6, alpha=a),
                            gid="arm-orientation", zorder=4)
            else:
                ax.quiver(*p, *(L * xdir), color=col, alpha=a, arrow_length_ratio=0.25,
                          gid="arm-orientation")
        if frames:
            for T in F[c, :]:
                o = T[:3, 3] * s
                for axis in range(3 if d == 3 else 2):
                    e = T[:3, axis] * L * 0.6
                    if d == 2:
                        ax.plot([o[0], o[0] + e[0]], [o[1], o[1] + e[1]], color=_FRAME_COLORS[axis],
                                lw=1, alpha=a, gid="arm-frame", zorder=1)
                    else:
                        ax.plot([o[0], o[0] + e[0]], [o[1], o[1] + e[1]], [o[2], o[2] + e[2]],
                                color=_FRAME_COLORS[axis], lw=1, alpha=a, gid="arm-frame")
    _label_space_axes(ax, d, units)
    if d == 2:
        ax.set_aspect("equal", adjustable="datalim")
    else:
        _equal_3d(ax, F[:, :, :3, 3].reshape(-1, 3) * s)
    if k > 1 and start_end or label:
        ax.legend(loc="best", fontsize="small")
    return ax


def _label_space_axes(ax, d, units):
    ax.set_xlabel(f"x [{units}]")
    ax.set_ylabel(f"y [{units}]")
    if d == 3:
        ax.set_zlabel(f"z [{units}]")
    ax.grid(True, alpha=0.3)


def _equal_3d(ax, pts):
    """Equal scaling of a 3-D axes around points (N, 3), merged with what is shown."""
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    if ax.has_data() and getattr(ax, "_labkit_box", None) is not None:
        lo = np.minimum(lo, ax._labkit_box[0])
        hi = np.maximum(hi, ax._labkit_box[1])
    ax._labkit_box = (lo, hi)
    c = 0.5 * (lo + hi)
    r = 0.5 * float(max(hi - lo)) or 1.0
    r *= 1.1
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(c[2] - r, c[2] + r)
    ax.set_box_aspect((1, 1, 1))


def _workspace_samples(robot, joint_ranges, n, seed):
    try:
        from labkit.kinematics import workspace_points
    except ImportError:  # before labkit.kinematics lands: sample here
        from labkit.kinematics import fk_position

        r = robot.joint_limits if joint_ranges is None else np.asarray(joint_ranges, dtype=float)
        rng = np.random.default_rng(seed)
        q = r[:, 0] + rng.random((n, robot.n)) * (r[:, 1] - r[:, 0])
        return fk_position(robot, q)
    return workspace_points(robot, joint_ranges, n=n, seed=seed).points


def _filled_region(pts2, bins):
    """Occupancy grid (edges, occupied) of 2-D points."""
    try:
        from labkit.kinematics import planar_region
    except ImportError:
        planar_region = None
    if planar_region is not None:
        reg = planar_region(pts2, bins=bins)
        return reg.x_edges, reg.y_edges, reg.occupied
    lo, hi = pts2.min(axis=0), pts2.max(axis=0)
    span = float(max(hi - lo)) or 1e-3
    nb = int(bins or np.clip(0.5 * np.sqrt(len(pts2)), 20, 400))
    xe = np.linspace(lo[0], lo[0] + span, nb + 1)
    ye = np.linspace(lo[1], lo[1] + span, nb + 1)
    H, _, _ = np.histogram2d(pts2[:, 0], pts2[:, 1], bins=[xe, ye])
    return xe, ye, H.T > 0


def plot_workspace(robot, joint_ranges=None, ax=None, *, n=30_000, style="scatter", dims="auto",
                   color="tab:gray", seed=0, units="mm", bins=None, label=None, plane="xy"):
    """The reachable workspace for given joint ranges, as points or a filled region.

    Parameters
    ----------
    robot : Robot
    joint_ranges : array_like, shape (n, 2), optional
        ``[lower, upper]`` per joint [rad, m]; default the joint limits (seed
        003 plots +-90 deg and +-45 deg: ``np.radians([[-90, 90]] * 3)``).
    ax : matplotlib Axes, optional
    n : int
        Number of random joint samples (:func:`labkit.kinematics.workspace_points`).
    style : {"scatter", "filled"}
        Dots, or the occupied region as a filled area (2-D only) with its outline.
    dims : {"auto", 2, 3}
        ``"auto"``: 2-D for planar arms.
    plane : {"xy", "xz", "yz"}
        Projection plane of a 2-D plot of a spatial arm.
    color : matplotlib color
        Colour of the dots or region.
    seed : int
        Seed of the random joint samples (same picture every run).
    units : {"mm", "m"}
        Axis units (the robot itself is in m).
    bins : int, optional
        Grid cells along the longer side for ``style="filled"`` (see
        :func:`labkit.kinematics.planar_region`).
    label : str, optional
        Legend label (default ``"workspace"``).

    Returns
    -------
    matplotlib Axes

    Raises
    ------
    ValueError
        An unknown ``style`` or ``plane``, or ``style="filled"`` in 3-D.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> ax = plot_workspace(Robot.load("planar3r_seed003"), np.radians([[-45, 45]] * 3), n=2000)
    >>> ax.collections[0].get_offsets().shape
    (2000, 2)
    """
    if style not in ("scatter", "filled"):
        raise OptionError(f"expected style in {{'scatter', 'filled'}}, got {style!r}")
    planes = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}
    check_robot(robot)
    n = as_count(n, "n (the number of samples)", minimum=1)
    if joint_ranges is not None:
        joint_ranges = as_batch(joint_ranges, (2,), "joint_ranges ((lower, upper) per joint)")
        if joint_ranges.shape != (robot.n, 2):
            raise ShapeError(f"expected joint_ranges with shape ({robot.n}, 2), got {joint_ranges.shape}")
    if not isinstance(plane, str) or plane not in planes:
        raise OptionError(f"expected plane in {sorted(planes)}, got {plane!r}")
    d = _dims(robot, None, dims)
    if style == "filled" and d == 3:
        raise OptionError("style='filled' draws a 2-D region: use dims=2 (a projection) or style='scatter'")
    s = _scale(units)
    pts = _workspace_samples(robot, joint_ranges, int(n), seed) * s
    ax = _new_axes(ax, d == 3)
    if d == 3:
        ax.scatter(pts[:, 0], pts[:, 1], pts[:, 2], s=1, color=color, alpha=0.3, depthshade=False,
                   gid="workspace", label=label or "workspace", rasterized=True)
        _label_space_axes(ax, 3, units)
        _equal_3d(ax, pts)
        return ax
    i, j = planes[plane]
    p2 = pts[:, [i, j]]
    if style == "scatter":
        ax.scatter(p2[:, 0], p2[:, 1], s=1, color=color, alpha=0.35, linewidths=0, gid="workspace",
                   label=label or "workspace", rasterized=True)
    else:
        xe, ye, occ = _filled_region(p2 / s, bins)
        masked = np.ma.masked_where(~occ, np.ones(occ.shape))
        from matplotlib.colors import ListedColormap

        ax.pcolormesh(xe * s, ye * s, masked, cmap=ListedColormap([color]), alpha=0.35,
                      shading="flat", gid="workspace", rasterized=True)
        ax.plot([], [], "s", color=color, alpha=0.35, label=label or "workspace")
    names = "xyz"
    ax.set_xlabel(f"{names[i]} [{units}]")
    ax.set_ylabel(f"{names[j]} [{units}]")
    ax.grid(True, alpha=0.3)
    ax.set_aspect("equal", adjustable="datalim")
    return ax


_QUANTITIES = {
    "q": ("q", 0, "position"),
    "qd": ("qd", 1, "velocity"),
    "qdd": ("qdd", 2, "acceleration"),
    "x": ("x", 0, "position"),
    "xd": ("xd", 1, "velocity"),
    "xdd": ("xdd", 2, "acceleration"),
    "speed": ("xd", 1, "speed"),
    "acceleration_norm": ("xdd", 2, "acceleration"),
}
_SUFFIX = ("", "/s", "/s²")


def plot_time_series(traj, quantity="q", ax=None, *, degrees=True, units="mm", names=None):
    """One quantity of a trajectory against time, one line per joint or axis.

    Parameters
    ----------
    traj : Trajectory
    quantity : {"q", "qd", "qdd", "x", "xd", "xdd", "speed", "acceleration_norm"}
        Joint position/velocity/acceleration, Cartesian position/velocity/
        acceleration, or the magnitude of the linear velocity/acceleration
        (seed 000 figures 8.3 and 8.4).
    ax : matplotlib Axes, optional
    degrees : bool
        Revolute joints and angle axes in degrees.
    units : {"mm", "m"}
        Length unit.
    names : sequence of str, optional
        Legend labels (default the trajectory's joint/axis names).

    Returns
    -------
    matplotlib Axes

    Examples
    --------
    >>> from labkit.motion import joint_trajectory
    >>> ax = plot_time_series(joint_trajectory(None, [0, 0, 1.57], [-0.8, 0.8, 0.8], 5.0), "qd")
    >>> len(ax.lines), ax.get_ylabel()
    (3, 'joint velocity [deg/s]')
    """
    try:
        attr, order, word = _QUANTITIES[quantity]
    except (KeyError, TypeError):
        raise OptionError(f"expected quantity in {sorted(_QUANTITIES)}, got {quantity!r}") from None
    data = getattr(check_trajectory(traj), attr)
    if data is None:
        raise OptionError(f"this trajectory has no {attr!r} (Cartesian quantities need a Cartesian trajectory)")
    ax = _new_axes(ax, False, figsize=(6.4, 3.6))
    ls = _scale(units)
    ang = 180.0 / math.pi if degrees else 1.0
    aunit = "deg" if degrees else "rad"
    if quantity in ("speed", "acceleration_norm"):
        ax.plot(traj.t, np.linalg.norm(data[:, :3], axis=1) * ls, color="tab:blue", label=f"|{word}|")
        ax.set_ylabel(f"end-effector {word} [{units}{_SUFFIX[order]}]")
    elif attr.startswith("q"):
        labels = list(names or traj.joint_names)
        units_used = set()
        for j in range(traj.n):
            sc, u = (ang, aunit) if traj.revolute[j] else (ls, units)
            units_used.add(u)
            ax.plot(traj.t, data[:, j] * sc, label=labels[j])
        ax.set_ylabel(f"joint {word} [{' or '.join(sorted(units_used))}{_SUFFIX[order]}]")
    else:
        labels = list(names or traj.axis_names)
        angle_axes = {"phi", "roll", "pitch", "yaw"}
        units_used = set()
        for k in range(data.shape[1]):
            is_ang = traj.axis_names[k] in angle_axes
            sc, u = (ang, aunit) if is_ang else (ls, units)
            units_used.add(u)
            ax.plot(traj.t, data[:, k] * sc, label=labels[k], linestyle="--" if is_ang else "-")
        ax.set_ylabel(f"end-effector {word} [{' or '.join(sorted(units_used))}{_SUFFIX[order]}]")
    ax.set_xlabel("t [s]")
    ax.grid(True, alpha=0.3)
    if len(ax.lines) > 1:
        ax.legend(loc="best", fontsize="small")
    return ax


def plot_trajectory(traj, ax=None, *, space="joint", degrees=True, units="mm", title=None):
    """Position, velocity and acceleration against time, stacked.

    Parameters
    ----------
    traj : Trajectory
    ax : sequence of 3 matplotlib Axes, optional
        Where to draw (top to bottom); a new figure if omitted.
    space : {"joint", "cartesian"}
    degrees, units
        As :func:`plot_time_series`.
    title : str, optional
        Figure title when the figure is made here; with ``ax`` given, the
        title of the top axes (so that side-by-side columns keep their own).

    Returns
    -------
    ndarray of 3 Axes

    Examples
    --------
    >>> from labkit.motion import joint_trajectory
    >>> axes = plot_trajectory(joint_trajectory(None, [0.0], [1.0], 2.0))
    >>> [len(a.lines) for a in axes]
    [1, 1, 1]
    """
    if space not in ("joint", "cartesian"):
        raise OptionError(f"expected space in {{'joint', 'cartesian'}}, got {space!r}")
    check_trajectory(traj)
    own = ax is None
    if own:
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(3, 1, sharex=True, figsize=(6.4, 7.2), layout="constrained")
    axes = np.asarray(ax).reshape(-1)
    if axes.size != 3:
        raise ShapeError(f"expected 3 axes, got {axes.size}")
    qs = ("q", "qd", "qdd") if space == "joint" else ("x", "xd", "xdd")
    for a, qn in zip(axes, qs):
        if space == "cartesian" and qn == "xdd" and traj.xdd is None:
            a.set_visible(False)
            continue
        plot_time_series(traj, qn, a, degrees=degrees, units=units)
        if a is not axes[-1]:
            a.set_xlabel("")
    if title and own:
        axes[0].figure.suptitle(title)
    elif title:
        axes[0].set_title(title)
    return axes


def plot_path_3d(path, ax=None, *, units="mm", start_end=True, color="tab:blue", label=None):
    """The end-effector path in 3-D, start red and end green.

    Parameters
    ----------
    path : Trajectory or array_like, shape (N, 3)
        A Cartesian trajectory (its ``x[:, :3]``) or points [m].
    ax : 3-D matplotlib Axes, optional
    units : {"mm", "m"}
        Axis units.
    start_end : bool
        Mark the start (red) and end (green) points.
    color : matplotlib color
        Colour of the path.
    label : str, optional
        Legend label (default ``"path"``).

    Returns
    -------
    matplotlib Axes (3-D)

    Raises
    ------
    ValueError
        No points (shape (N, 2) or (N, 3)), or 2-D axes given.

    Examples
    --------
    >>> ax = plot_path_3d(np.linspace([0, 0.18, -0.094], [0.1, 0.15, -0.2], 51))
    >>> [ln.get_gid() for ln in ax.lines]
    ['path', 'path-start', 'path-end']
    """
    pts = getattr(path, "x", path)
    if pts is None:
        raise ShapeError("expected a Cartesian trajectory (with x) or points (N, 3)")
    pts = as_batch(pts, (), "points")
    if pts.ndim != 2 or pts.shape[1] < 2:
        raise ShapeError(f"expected points with shape (N, 3), got {pts.shape}")
    if pts.shape[1] == 2 or getattr(path, "axis_names", ())[2:3] == ("phi",):
        pts = np.column_stack([pts[:, :2], np.zeros(len(pts))])
    s = _scale(units)
    p = pts[:, :3] * s
    ax = _new_axes(ax, True)
    if not _is3d(ax):
        raise OptionError("expected 3-D axes (projection='3d')")
    ax.plot(p[:, 0], p[:, 1], p[:, 2], color=color, lw=2, gid="path", label=label or "path")
    if start_end:
        shown = {h.get_label() for h in ax.get_legend_handles_labels()[0]}
        ax.plot(*p[0, :, None], "o", color=START_COLOR, ms=7, gid="path-start",
                label="_start" if "start" in shown else "start")
        ax.plot(*p[-1, :, None], "o", color=END_COLOR, ms=7, gid="path-end",
                label="_end" if "end" in shown else "end")
    _label_space_axes(ax, 3, units)
    _equal_3d(ax, p)
    ax.legend(loc="best", fontsize="small")
    return ax
