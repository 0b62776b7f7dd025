"""Figures for lab reports: the arm, its workspace, trajectories, paths and
animations. matplotlib is imported inside the functions.
"""

from labkit.plotting._figures import (
    is_planar,
    plot_arm,
    plot_workspace,
    plot_time_series,
    plot_trajectory,
    plot_path_3d,
    START_COLOR,
    END_COLOR,
)
from labkit.plotting._animation import animate_arm, save_animation

__all__ = [
    "is_planar",
    "plot_arm",
    "plot_workspace",
    "plot_time_series",
    "plot_trajectory",
    "plot_path_3d",
    "START_COLOR",
    "END_COLOR",
    "animate_arm",
    "save_animation",
]
