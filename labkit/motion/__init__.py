"""Motion: time laws (cubic, quintic, LSPB, linear), joint trajectories, via
points (through them, or passed near with parabolic blends), Cartesian paths
(lines, arcs, circles, waypoints) and their trajectories.

Naming: a constructor's name ends with what it returns.

* ``*_law`` -> :class:`TimeLaw` (a value against time): the point-to-point
  laws :func:`cubic_law`, :func:`quintic_law`, :func:`lspb_law`,
  :func:`linear_law` (and :func:`make_law` choosing one by name), and the
  composite ones :func:`via_law`, :func:`blended_law` and :func:`path_law`
  (the law ``s(t)`` of a path's parameter).
* ``*_path`` -> :class:`CartesianPath` (geometry only, no timing):
  :func:`line_path`, :func:`arc_path`, :func:`circle_path`,
  :func:`waypoint_path`.
* ``*_trajectory`` -> :class:`Trajectory` (sampled joint and Cartesian
  values): :func:`joint_trajectory`, :func:`via_trajectory`,
  :func:`cartesian_trajectory`, ..., and :func:`law_trajectory` (samples a
  ready joint law).

The law names given as strings (``law="cubic"``, :class:`LawName`) stay the
bare names: ``"cubic"``, ``"quintic"``, ``"lspb"``, ``"linear"``.
"""

from labkit.motion._timelaw import LawName, TimeLaw
from labkit.motion._laws import cubic_law, quintic_law, lspb_law, linear_law, make_law, minimum_duration, time_grid
from labkit.motion._trajectory import Trajectory, joint_trajectory, law_trajectory
from labkit.motion._via import SplineEnds, via_law, via_trajectory, heuristic_velocities
from labkit.motion._checks import check_joint_limits, check_speed, speed_scale
from labkit.motion._paths import CartesianPath, line_path, arc_path, circle_path, waypoint_path
from labkit.motion._cartesian import path_law, cartesian_trajectory, cartesian_via_trajectory
from labkit.motion._approach import height_above, approach_point, PickPlaceLeg, pick_and_place_legs
from labkit.motion._blend import blended_law, blended_trajectory, cartesian_blended_trajectory

__all__ = [
    "LawName",
    "TimeLaw",
    "cubic_law",
    "quintic_law",
    "lspb_law",
    "linear_law",
    "make_law",
    "minimum_duration",
    "time_grid",
    "Trajectory",
    "joint_trajectory",
    "law_trajectory",
    "SplineEnds",
    "via_law",
    "via_trajectory",
    "heuristic_velocities",
    "check_joint_limits",
    "check_speed",
    "speed_scale",
    "CartesianPath",
    "line_path",
    "arc_path",
    "circle_path",
    "waypoint_path",
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
