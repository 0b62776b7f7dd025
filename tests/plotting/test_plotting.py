"""Plots on the Agg backend: count what is drawn, check colours, labels and animations."""

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.colors import to_rgba

from conftest import require
from labkit.motion import arc_path, cartesian_trajectory, line_path
from labkit.robot import Robot
from labkit.exceptions import LabkitError
from labkit.plotting import (
    END_COLOR,
    START_COLOR,
    is_planar,
    plot_arm,
    plot_path_3d,
    plot_time_series,
    plot_trajectory,
    plot_workspace,
)
from labkit.plotting import animate_arm, save_animation
from labkit.motion import joint_trajectory


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def planar003():
    return Robot.load("planar3r_seed003")


@pytest.fixture(scope="module")
def arduino():
    return Robot.load("arduino_arm_3dof")


def _gid(artists, gid):
    return [a for a in artists if a.get_gid() == gid]


def test_planar_detection(planar003, arduino):
    assert is_planar(planar003) and is_planar(Robot.load("planar3r_seed004"))
    assert not is_planar(arduino) and not is_planar(Robot.load("puma560"))


def test_plot_arm_2d_start_red_end_green(planar003):
    Q = np.radians([[0, 30, 30], [20, 40, -30], [30, 50, -45], [45, 60, -60]])
    ax = plot_arm(planar003, Q)
    assert ax.name != "3d"
    links = _gid(ax.lines, "arm-links")
    assert len(links) == 4
    assert to_rgba(links[0].get_color()) == to_rgba(START_COLOR)
    assert to_rgba(links[-1].get_color()) == to_rgba(END_COLOR)
    # base, joints 2 and 3, tool point: 4 vertices per configuration (frame 1 coincides with the base)
    assert all(len(ln.get_xdata()) == 4 for ln in links)
    tip = planar003.fk(Q[-1])[:2, 3] * 1e3
    np.testing.assert_allclose([links[-1].get_xdata()[-1], links[-1].get_ydata()[-1]], tip, atol=1e-9)
    assert len(_gid(ax.lines, "arm-joints")) == 4 and len(_gid(ax.lines, "arm-tool")) == 4
    assert len(_gid(ax.texts, "arm-orientation")) == 4  # one arrow per configuration
    assert ax.get_xlabel() == "x [mm]" and ax.get_ylabel() == "y [mm]"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["start", "end"]


def test_plot_arm_frames_and_units(planar003):
    ax = plot_arm(planar003, [0.0, 0.0, 0.0], frames=True, units="m", orientation_arrow=False)
    # 2-D triads: x and y axis of base, frames 1..3 and tool = 5 frames x 2 lines
    assert len(_gid(ax.lines, "arm-frame")) == 2 * (planar003.n + 2)
    assert len(_gid(ax.texts, "arm-orientation")) == 0
    np.testing.assert_allclose(_gid(ax.lines, "arm-tool")[0].get_xydata(), [[0.335, 0.0]])


def test_plot_arm_3d(arduino):
    ax = plot_arm(arduino, np.radians([[90, 90, 90], [45, 60, 100]]), frames=True)
    assert ax.name == "3d"
    assert len(_gid(ax.lines, "arm-links")) == 2
    assert len(_gid(ax.lines, "arm-frame")) == 2 * 3 * (arduino.n + 2)
    assert len(_gid(ax.collections, "arm-orientation")) == 2
    assert ax.get_zlabel() == "z [mm]"
    tool = _gid(ax.lines, "arm-tool")[0]
    xs, ys, zs = tool.get_data_3d()
    np.testing.assert_allclose([xs[0], ys[0], zs[0]], [0.0, 180.0, -94.0], atol=1e-9)  # seed 000 home
    with pytest.raises(ValueError, match="3-D axes"):
        plot_arm(arduino, [1.0, 1.0, 1.0], ax=plt.figure().add_subplot())


def test_workspace_scatter_and_filled(planar003):
    wide = plot_workspace(planar003, np.radians([[-90, 90]] * 3), n=4000, seed=1)
    pts90 = wide.collections[0].get_offsets()
    assert pts90.shape == (4000, 2) and wide.collections[0].get_gid() == "workspace"
    narrow = plot_workspace(planar003, np.radians([[-45, 45]] * 3), n=4000, seed=1)
    pts45 = narrow.collections[0].get_offsets()
    assert np.linalg.norm(pts45, axis=1).min() > np.linalg.norm(pts90, axis=1).min()  # +-45 deg: no folding back
    assert np.linalg.norm(pts90, axis=1).max() <= 335.0 + 1e-9
    filled = plot_workspace(planar003, np.radians([[-45, 45]] * 3), n=20000, style="filled")
    mesh = _gid(filled.collections, "workspace")
    assert len(mesh) == 1 and isinstance(mesh[0], matplotlib.collections.QuadMesh)
    ax3 = plot_workspace(Robot.load("arduino_arm_3dof"), n=1000)
    assert ax3.name == "3d" and len(_gid(ax3.collections, "workspace")) == 1
    with pytest.raises(ValueError, match="'scatter', 'filled'"):
        plot_workspace(planar003, style="hexbin")


def test_workspace_overlay_with_arm(planar003):
    ax = plot_workspace(planar003, np.radians([[-90, 90]] * 3), n=500)
    plot_arm(planar003, np.radians([[0, 0, 0], [45, 45, 0]]), ax=ax)
    assert len(ax.collections) >= 1 and len(_gid(ax.lines, "arm-links")) == 2


def test_time_series_joint_units():
    traj = joint_trajectory(None, [0.0, 0.0, 1.57], [-0.8, 0.8, 0.8], 5.0, dt=0.1)
    ax = plot_time_series(traj, "q")
    assert len(ax.lines) == 3
    assert ax.get_ylabel() == "joint position [deg]" and ax.get_xlabel() == "t [s]"
    np.testing.assert_allclose(ax.lines[2].get_ydata()[0], np.degrees(1.57))
    rad = plot_time_series(traj, "qdd", degrees=False)
    assert rad.get_ylabel() == "joint acceleration [rad/s²]"
    axes = plot_trajectory(traj, title="seed 003 task 2")
    assert len(axes) == 3 and [len(a.lines) for a in axes] == [3, 3, 3]
    assert axes[0].figure.get_suptitle() == "seed 003 task 2"
    # side by side in the caller's figure: each column keeps its own title (not one shared suptitle)
    import matplotlib.pyplot as plt

    fig, grid = plt.subplots(3, 2)
    plot_trajectory(traj, grid[:, 0], title="cubic")
    plot_trajectory(traj, grid[:, 1], title="quintic")
    assert [grid[0, 0].get_title(), grid[0, 1].get_title(), fig.get_suptitle()] == ["cubic", "quintic", ""]
    plt.close(fig)
    assert [a.get_ylabel() for a in traj.plot()] == [a.get_ylabel() for a in axes]  # the delegate
    with pytest.raises(ValueError, match="expected quantity"):
        plot_time_series(traj, "jerk")
    with pytest.raises(ValueError, match="Cartesian"):
        plot_time_series(traj, "x")


def test_cartesian_plots_seed000(arduino):
    traj = cartesian_trajectory(arduino, line_path([0, 0.18, -0.094], [0.1, 0.15, -0.2]), 5.0, dt=0.1, branch="elbow_up")
    ax = plot_time_series(traj, "speed")
    assert ax.get_ylabel() == "end-effector speed [mm/s]"
    assert ax.lines[0].get_ydata().max() == pytest.approx(44.63, abs=0.01)  # not the seed's 45
    axes = plot_trajectory(traj, space="cartesian")
    assert [len(a.lines) for a in axes] == [3, 3, 3]
    ax3 = plot_path_3d(traj)
    assert [ln.get_gid() for ln in ax3.lines] == ["path", "path-start", "path-end"]
    assert to_rgba(ax3.lines[1].get_color()) == to_rgba(START_COLOR)


def test_no_global_state_changes(planar003):
    before = dict(matplotlib.rcParams)
    plot_arm(planar003, [0.1, 0.2, 0.3], frames=True)
    plot_workspace(planar003, n=200, style="filled")
    after = dict(matplotlib.rcParams)
    assert before == after


def test_animation_jshtml_gif_mp4(tmp_path):
    planar004 = Robot.load("planar3r_seed004")
    path = arc_path([0.1, 0.25], 0.25, -np.pi / 2, np.pi / 2)  # seed 004 part D
    traj = cartesian_trajectory(planar004, path, 2.0, dt=0.1, orientation=[-np.pi / 2, 0.0], branch="elbow_minus")
    anim = animate_arm(planar004, traj, max_frames=4)
    assert anim._labkit_frames == 4
    html = anim.to_jshtml()
    assert "<img" in html and html.count("data:image/png;base64") == 4
    arm_line = _gid(anim._fig.axes[0].lines, "anim-arm")[0]
    tool = arm_line.get_xydata()[-1]
    p_end = path.point([1.0])[0, :2] * 1e3
    np.testing.assert_allclose(tool, p_end, atol=1e-6)  # last frame drawn by to_jshtml
    require("PIL")
    gif = save_animation(animate_arm(planar004, traj, max_frames=3), tmp_path / "arc.gif", dpi=40)
    assert gif.stat().st_size > 1000 and gif.read_bytes()[:6] in (b"GIF87a", b"GIF89a")
    from matplotlib import animation

    mp4 = tmp_path / "arc.mp4"
    if animation.writers.is_available("ffmpeg"):
        save_animation(animate_arm(planar004, traj, max_frames=3), mp4, dpi=40)
        assert mp4.stat().st_size > 1000 and mp4.read_bytes()[4:8] == b"ftyp"
    else:
        with pytest.raises(LabkitError, match="ffmpeg"):
            save_animation(animate_arm(planar004, traj, max_frames=5), mp4)
    with pytest.raises(ValueError, match=".gif or .mp4"):
        save_animation(anim, tmp_path / "arc.avi")


def test_animation_3d(arduino):
    traj = joint_trajectory(None, np.radians([90, 90, 90]), np.radians([45, 60, 100]), 1.0, dt=0.1)
    anim = animate_arm(arduino, traj, max_frames=3)
    assert anim._labkit_frames == 3
    assert anim._fig.axes[0].name == "3d"
    assert anim.to_jshtml().count("data:image/png;base64") == 3
