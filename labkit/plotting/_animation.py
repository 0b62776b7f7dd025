"""Animation of the arm along a trajectory (matplotlib ``FuncAnimation``).

The animation embeds in a notebook and in a static HTML report through
``anim.to_jshtml()`` (frames inlined as PNG, no server needed), and
:func:`save_animation` writes a GIF (Pillow) or an MP4 (ffmpeg) when the
writer is installed.
"""

from __future__ import annotations

import numpy as np

from labkit.exceptions import LabkitError, OptionError, ShapeError
from labkit.validation import as_batch, as_count, as_number
from labkit.plotting._figures import (
    END_COLOR,
    START_COLOR,
    _configs,
    _dims,
    _equal_3d,
    _is3d,
    _label_space_axes,
    _new_axes,
    _scale,
    _unique_chain,
)

__all__ = ["animate_arm", "save_animation"]


def animate_arm(robot, traj, ax=None, *, t=None, max_frames=80, interval=None, dims="auto",
                trail=True, ghosts=True, units="mm", color="tab:blue"):
    """Animate the arm along a trajectory.

    Parameters
    ----------
    robot : Robot
    traj : Trajectory or array_like, shape (N, n)
        Joint samples [rad, m] (a :class:`~labkit.motion.Trajectory`
        brings its own times).
    ax : matplotlib Axes, optional
        2-D or 3-D axes; new ones if omitted.
    t : array_like, shape (N,), optional
        Sample times [s] for a plain array (default 0.1 s apart, as seed 000).
    max_frames : int
        At most this many frames (samples are thinned evenly, the last kept),
        so that ``to_jshtml()`` stays small.
    interval : float, optional
        Delay between frames [ms]; default real time.
    dims : {"auto", 2, 3}
    trail : bool
        Draw the tool path up to the current frame.
    ghosts : bool
        Show the start (red) and end (green) configurations faintly.
    units : {"mm", "m"}
    color : matplotlib color
        Colour of the moving arm.

    Returns
    -------
    matplotlib.animation.FuncAnimation
        ``anim.to_jshtml()`` for notebooks/HTML; :func:`save_animation` for files.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> from labkit.motion import joint_trajectory
    >>> arm = Robot.load("planar3r_seed003")
    >>> anim = animate_arm(arm, joint_trajectory(None, [0, 0, 0], [0.8, -0.5, 0.3], 2.0, dt=0.1), max_frames=3)
    >>> anim._labkit_frames
    3
    >>> "<img" in anim.to_jshtml()
    True
    """
    from matplotlib.animation import FuncAnimation

    from labkit.kinematics import fk_frames

    Q = getattr(traj, "q", traj)
    Q = _configs(robot, Q)
    max_frames = as_count(max_frames, "max_frames", minimum=1)
    if interval is not None:
        interval = as_number(interval, "interval", unit="ms", positive=True)
    T = getattr(traj, "t", None)
    if T is None:
        T = np.arange(len(Q)) * 0.1 if t is None else as_batch(t, (), "t (sample times, s)")
    if len(T) != len(Q):
        raise ShapeError(f"expected {len(Q)} sample times, got {len(T)}")
    idx = np.unique(np.linspace(0, len(Q) - 1, min(int(max_frames), len(Q))).round().astype(int))
    d = _dims(robot, Q[0], dims)
    s = _scale(units)
    ax = _new_axes(ax, d == 3)
    if (d == 3) != _is3d(ax):
        raise OptionError(f"expected {'3-D' if d == 3 else '2-D'} axes for dims={d}")
    F = fk_frames(robot, Q[idx]) * 1.0
    F[..., :3, 3] *= s
    chains = [_unique_chain(Fk[:, :3, 3]) for Fk in F]
    tool = F[:, -1, :3, 3]
    dim = slice(0, d)
    if ghosts:
        for c, col in ((chains[0], START_COLOR), (chains[-1], END_COLOR)):
            ax.plot(*c[:, dim].T, "-o", color=col, alpha=0.3, lw=2, ms=4, gid="anim-ghost")
    (arm_line,) = ax.plot(*chains[0][:, dim].T, "-o", color=color, lw=3, ms=7, mfc="white",
                          mew=1.6, gid="anim-arm")
    (trail_line,) = ax.plot(*tool[:1, dim].T, "-", color="tab:orange", lw=1.5, gid="anim-trail")
    stamp = ax.text2D(0.02, 0.95, "", transform=ax.transAxes) if d == 3 else \
        ax.text(0.02, 0.95, "", transform=ax.transAxes)
    allpts = np.concatenate(chains)
    if d == 2:
        lo, hi = allpts[:, :2].min(axis=0), allpts[:, :2].max(axis=0)
        pad = 0.1 * float(max(hi - lo)) or 1.0
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal")
    else:
        _equal_3d(ax, allpts)
    _label_space_axes(ax, d, units)

    def _set(line, pts):
        if d == 2:
            line.set_data(pts[:, 0], pts[:, 1])
        else:
            line.set_data_3d(pts[:, 0], pts[:, 1], pts[:, 2])

    def update(frame):
        _set(arm_line, chains[frame])
        if trail:
            _set(trail_line, tool[: frame + 1])
        stamp.set_text(f"t = {T[idx[frame]]:.2f} s")
        return arm_line, trail_line, stamp

    if interval is None:
        step = np.diff(T[idx]).mean() if len(idx) > 1 else 0.1
        interval = max(20.0, 1000.0 * float(step))
    anim = FuncAnimation(ax.figure, update, frames=len(idx), interval=interval, blit=False)
    anim._labkit_frames = len(idx)
    return anim


def save_animation(anim, path, *, fps=None, dpi=100):
    """Save an animation as GIF (Pillow) or MP4 (ffmpeg), chosen by suffix.

    Parameters
    ----------
    anim : matplotlib.animation.Animation
    path : str or os.PathLike
        ``.gif`` or ``.mp4``.
    fps : float, optional
        Frames per second (default from the animation's interval).
    dpi : float
        Resolution [dots per inch].

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    ValueError
        For another suffix.
    LabkitError
        If the writer is not installed (the message lists the available ones);
        use ``anim.to_jshtml()`` instead.
    """
    from pathlib import Path

    from matplotlib import animation

    p = Path(path)
    writers = {".gif": "pillow", ".mp4": "ffmpeg"}
    name = writers.get(p.suffix.lower())
    if name is None:
        raise OptionError(f"expected a .gif or .mp4 file name, got {str(path)!r}")
    if not animation.writers.is_available(name):
        raise LabkitError(
            f"the {name} animation writer is not installed (available: {animation.writers.list()}); "
            f"install {'Pillow' if name == 'pillow' else 'ffmpeg'} or use anim.to_jshtml()"
        )
    if fps is None:
        fps = max(1.0, 1000.0 / float(getattr(anim, "_interval", 100)))
    anim.save(str(p), writer=name, fps=fps, dpi=dpi)
    return p
