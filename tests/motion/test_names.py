"""labkit.motion's naming scheme: a constructor's name ends with what it returns."""

import numpy as np

import labkit.motion as m
from labkit.motion import CartesianPath, TimeLaw, Trajectory

PATHS = {"line_path", "arc_path", "circle_path", "waypoint_path"}
POINT_LAWS = {"cubic_law", "quintic_law", "lspb_law", "linear_law"}


def test_old_names_are_gone():
    for old in ("Path", "line", "arc", "circle", "waypoints", "cubic", "quintic", "lspb", "linear"):
        assert not hasattr(m, old), old
        assert old not in m.__all__


def test_path_constructors_end_in_path_and_return_a_cartesian_path():
    assert {n for n in m.__all__ if n.endswith("_path")} == PATHS
    made = [m.line_path([0, 0, 0], [1, 0, 0]), m.arc_path([0, 0], 1.0, 0.0, 1.0),
            m.circle_path([0, 0, 0], 0.1), m.waypoint_path([[0, 0], [1, 0], [1, 1]])]
    assert all(isinstance(p, CartesianPath) for p in made)
    assert [p.shape for p in made] == ["line", "arc", "circle", "waypoints"]


def test_law_constructors_end_in_law_and_return_a_time_law():
    assert POINT_LAWS | {"make_law", "via_law", "blended_law", "path_law"} == {n for n in m.__all__ if n.endswith("_law")}
    for name in POINT_LAWS:
        law = getattr(m, name)(0.0, 1.0, 2.0)
        assert isinstance(law, TimeLaw) and law.name.value == name.removesuffix("_law")
        np.testing.assert_allclose(law.position(2.0), 1.0)
    line = m.line_path([0, 0, 0], [1, 0, 0])
    assert isinstance(m.path_law(line, 2.0), TimeLaw)
    assert isinstance(m.via_law(None, np.array([[0.0], [1.0], [0.5]]), durations=1.0), TimeLaw)
    assert isinstance(m.blended_law(None, np.array([[0.0], [1.0], [0.5]]), durations=[1.0, 1.0], blend_time=0.2), TimeLaw)


def test_trajectory_constructors_end_in_trajectory():
    traj = [n for n in m.__all__ if n.endswith("_trajectory")]
    assert {"joint_trajectory", "via_trajectory", "cartesian_trajectory", "blended_trajectory", "law_trajectory"} <= set(traj)
    assert isinstance(m.joint_trajectory(None, [0.0], [1.0], 1.0, dt=0.1), Trajectory)
    assert isinstance(m.law_trajectory(m.cubic_law([0.0], [1.0], 1.0), dt=0.1), Trajectory)
    assert not hasattr(m, "from_law")
