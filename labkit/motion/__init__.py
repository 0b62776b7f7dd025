"""Motion: time laws (cubic, quintic, LSPB, linear), joint trajectories, via
points (through them, or passed near with parabolic blends), Cartesian paths
(lines, arcs, circles) and their trajectories.
"""

from labkit.motion._timelaw import LawKind, TimeLaw
from labkit.motion._laws import cubic, quintic, lspb, linear, make_law, minimum_duration, time_grid
from labkit.motion._trajectory import Trajectory, joint_trajectory, from_law
from labkit.motion._via import SplineEnds, via_law, via_trajectory, heuristic_velocities
from labkit.motion._checks import check_joint_limits, check_speed, speed_scale
from labkit.motion._paths import Path, line, arc, circle, waypoints
from labkit.motion._cartesian import path_law, cartesian_trajectory, cartesian_via_trajectory
from labkit.motion._approach import height_above, approach_point, PickPlaceLeg, pick_and_place_legs
from labkit.motion._blend import blended_law, blended_trajectory, cartesian_blended_trajectory

__all__ = [
    "LawKind",
    "TimeLaw",
    "cubic",
    "quintic",
    "lspb",
    "linear",
    "make_law",
    "minimum_duration",
    "time_grid",
    "Trajectory",
    "joint_trajectory",
    "from_law",
    "SplineEnds",
    "via_law",
    "via_trajectory",
    "heuristic_velocities",
    "check_joint_limits",
    "check_speed",
    "speed_scale",
    "Path",
    "line",
    "arc",
    "circle",
    "waypoints",
    "path_law",
    "cartesian_trajectory",
    "cartesian_via_trajectory",
    "height_above",
    "approach_point",
    "PickPlaceLeg",
    "pick_and_place_legs",
    "blended_law",
    "blended_trajectory",
    "cartesian_blended_trajectory",
]
