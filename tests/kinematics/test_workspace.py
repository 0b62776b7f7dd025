"""Tests of labkit.kinematics workspaces (sampling and planar regions)."""

import numpy as np
import pytest

from labkit.robot import Robot
from labkit.exceptions import ShapeError
from labkit.kinematics import fk_position
from labkit.kinematics import PlanarRegion, Workspace, planar_region, workspace_points


def test_random_samples_inside_limits_and_match_fk():
    arm = Robot.load("arduino_arm_3dof")
    ws = workspace_points(arm, n=5000, seed=3)
    assert isinstance(ws, Workspace) and len(ws) == 5000
    assert ws.q.shape == (5000, 3) and ws.points.shape == (5000, 3)
    assert np.all(arm.within_limits(ws.q))
    assert np.allclose(ws.points, fk_position(arm, ws.q))
    # reach: every point within L1 + L2 of the shoulder (at the origin)
    assert np.linalg.norm(ws.points, axis=1).max() <= 0.274 + 1e-12
    # samples actually cover the range (not all at one end)
    assert np.all(ws.q.min(axis=0) < np.radians(2)) and np.all(ws.q.max(axis=0) > np.radians(178))


def test_seeded_reproducible_and_frozen():
    arm = Robot.load("planar3r_seed004")
    a = workspace_points(arm, n=100, seed=7)
    b = workspace_points(arm, n=100, seed=7)
    c = workspace_points(arm, n=100, seed=8)
    assert np.array_equal(a.q, b.q) and not np.array_equal(a.q, c.q)
    with pytest.raises(AttributeError):
        a.q = None
    g = workspace_points(arm, n=100, seed=np.random.default_rng(1))
    assert g.q.shape == (100, 3)


def test_grid_sampling_includes_range_ends():
    arm = Robot.load("planar3r_seed003")
    ranges = np.radians([[-45, 45], [-45, 45], [-45, 45]])
    ws = workspace_points(arm, ranges, n=1000, grid=True)
    assert ws.q.shape == (1000, 3)  # 10 values per joint
    for j in range(3):
        assert np.allclose(np.unique(ws.q[:, j]), np.linspace(ranges[j, 0], ranges[j, 1], 10))
    assert workspace_points(arm, ranges, n=3, grid=True).q.shape == (8, 3)


def test_custom_ranges_and_prismatic_joint():
    rpp = Robot.load("rpp_seed002")
    ranges = [[0, np.pi / 2], [0.2, 0.4], [0.5, 1.0]]
    ws = workspace_points(rpp, ranges, n=2000)
    assert np.all((ws.q >= np.array(ranges)[:, 0]) & (ws.q <= np.array(ranges)[:, 1]))
    assert np.allclose(ws.points, fk_position(rpp, ws.q))
    df = ws.to_dataframe(rpp.joint_names)
    assert list(df.columns) == ["theta1", "d2", "d3", "x", "y", "z"] and len(df) == 2000


def test_tool_point_option():
    arm = Robot.load("planar3r_seed004")
    ws = workspace_points(arm, n=50, point=[-0.12, 0, 0])  # the wrist point
    assert np.allclose(ws.points, fk_position(arm, ws.q, point=[-0.12, 0, 0]))
    assert np.linalg.norm(ws.points, axis=1).max() <= 0.35 + 1e-12


def test_bad_ranges_raise_clear_errors():
    arm = Robot.load("planar3r_seed004")
    with pytest.raises(ShapeError, match=r"joint_ranges with shape \(3, 2\).*got \(2, 2\)"):
        workspace_points(arm, [[0, 1], [0, 1]])
    with pytest.raises(ValueError, match=r"joint_ranges\[1\] as \[lower, upper\].*\[1.0, 0.0\]"):
        workspace_points(arm, [[0, 1], [1, 0], [0, 1]])
    with pytest.raises(ShapeError, match="finite"):
        workspace_points(arm, [[0, 1], [0, np.nan], [0, 1]])
    with pytest.raises(ValueError, match="expected n as an integer >= 1, got 0"):
        workspace_points(arm, n=0)


def test_planar_region_of_full_disc():
    arm = Robot.load("planar3r_seed004")  # L = 0.2 + 0.15 + 0.12, joints +-180 deg: a disc
    region = planar_region(workspace_points(arm, n=300_000, seed=0))
    assert isinstance(region, PlanarRegion)
    R = 0.47
    assert region.area == pytest.approx(np.pi * R**2, rel=0.03)
    outer = max(region.boundaries, key=len)
    assert np.allclose(outer[0], outer[-1])  # closed loop
    r = np.linalg.norm(outer, axis=1)
    assert np.all(np.abs(r - R) < 4 * np.sqrt(region.cell_area))
    inside = region.contains([[0.0, 0.0], [0.3, -0.2], [0.46, 0.0], [0.5, 0.0], [np.nan, 0.0]])
    assert inside.tolist() == [True, True, True, False, False]
    ny, nx = region.occupied.shape
    assert region.x_edges.shape == (nx + 1,) and region.y_edges.shape == (ny + 1,)


def test_seed003_limited_workspace_is_smaller_and_inside():
    arm = Robot.load("planar3r_seed003")
    wide = planar_region(workspace_points(arm, n=200_000))
    narrow_ws = workspace_points(arm, np.radians([[-45, 45]] * 3), n=200_000)
    narrow = planar_region(narrow_ws)
    assert narrow.area < 0.5 * wide.area
    assert wide.contains(narrow_ws.points[:, :2]).mean() > 0.999
    assert len(wide.boundaries) == 1


def test_planar_region_projection_and_input_checks():
    arm = Robot.load("arduino_arm_3dof")
    ws = workspace_points(arm, n=50_000)
    side = planar_region(ws, plane="xz")
    assert side.plane == "xz" and side.area > 0
    assert planar_region(ws.points[:, :2]).area > 0
    with pytest.raises(ValueError, match=r"expected plane as one of 'xy', 'xz', 'yz', got 'ab'"):
        planar_region(ws, plane="ab")
    with pytest.raises(ShapeError, match=r"\(N, 3\) or \(N, 2\)"):
        planar_region(np.zeros((10, 4)))
    with pytest.raises(ShapeError, match="contains|xy"):
        side.contains([1.0, 2.0, 3.0])
