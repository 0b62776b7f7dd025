"""Workspace sampling: reachable point clouds and planar workspace regions.

:func:`workspace_points` samples joint space (uniformly at random or on a
grid) inside given joint ranges and maps every sample through batched forward
kinematics. :func:`planar_region` turns a point cloud of a planar robot (or a
projection of a spatial one) into a filled occupancy grid and its boundary
curves, ready to draw (``pcolormesh`` of ``occupied``, ``plot`` of each
boundary loop) without any plotting code here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from labkit.exceptions import OptionError, ShapeError
from labkit.kinematics._forward import fk_position
from labkit.validation import as_batch, as_count, as_option, as_seed, as_vector, check_robot

__all__ = ["Workspace", "workspace_points", "PlanarRegion", "planar_region"]


@dataclass(frozen=True, eq=False)
class Workspace:
    """Joint samples and the points they reach.

    Attributes
    ----------
    q : ndarray, shape (N, n)
        Joint samples [rad, m].
    points : ndarray, shape (N, 3)
        Tool-point positions in the world frame [m].
    """

    q: np.ndarray
    points: np.ndarray

    def __len__(self):
        return len(self.points)

    def to_dataframe(self, joint_names=None):
        """Table with one row per sample: joint columns then ``x, y, z`` [m].

        Parameters
        ----------
        joint_names : sequence of str, optional
            Names of the joint columns; default ``q1 .. qn``.

        Returns
        -------
        pandas.DataFrame
            Joint values [rad, m] and tool positions ``x, y, z`` [m].
        """
        import pandas as pd

        names = list(joint_names) if joint_names is not None else [f"q{i + 1}" for i in range(self.q.shape[1])]
        data = {nm: self.q[:, i] for i, nm in enumerate(names)}
        data.update(x=self.points[:, 0], y=self.points[:, 1], z=self.points[:, 2])
        return pd.DataFrame(data)


def _ranges(robot, joint_ranges):
    if joint_ranges is None:
        return robot.joint_limits
    r = as_batch(joint_ranges, (robot.n, 2), "joint_ranges", batch=False)
    bad = np.flatnonzero(r[:, 0] > r[:, 1])
    if bad.size:
        j = int(bad[0])
        raise OptionError(f"expected joint_ranges[{j}] as [lower, upper] with lower <= upper, got {r[j].tolist()}")
    return r


def workspace_points(robot, joint_ranges=None, *, n=100_000, grid=False, seed=0, point=None):
    """Sample the reachable workspace of a robot.

    Parameters
    ----------
    robot : Robot
    joint_ranges : array_like, shape (n_joints, 2), optional
        ``[lower, upper]`` per joint [rad, m]; default the robot's joint limits.
    n : int
        Number of samples. With ``grid=True`` each joint gets
        ``k = max(2, round(n ** (1 / n_joints)))`` evenly spaced values and
        ``N = k ** n_joints`` samples are returned.
    grid : bool
        Regular grid (including the range ends) instead of uniform random samples.
    seed : int >= 0, numpy.random.Generator or None
        Seed of the random samples (None: fresh entropy; ignored with ``grid=True``).
    point : array_like, shape (3,), optional
        Point in tool coordinates [m] (default the tool-frame origin).

    Returns
    -------
    Workspace
        ``q`` (N, n_joints) and ``points`` (N, 3) [m].

    Raises
    ------
    ShapeError, OptionError
        For malformed ``joint_ranges``, ``n < 1`` or a bad ``seed``.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> ws = workspace_points(Robot.load("planar3r_seed004"), n=1000)
    >>> ws.q.shape, ws.points.shape
    ((1000, 3), (1000, 3))
    >>> bool(np.all(np.linalg.norm(ws.points, axis=1) <= 0.47 + 1e-12))
    True
    """
    r, n = _ranges(check_robot(robot), joint_ranges), as_count(n, "n", minimum=1)
    dof = robot.n
    if grid:
        k = max(2, int(round(n ** (1.0 / dof))))
        axes = [np.linspace(lo, hi, k) for lo, hi in r]
        q = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, dof)
    else:
        rng = np.random.default_rng(as_seed(seed))  # a Generator is returned as it is
        q = r[:, 0] + rng.random((n, dof)) * (r[:, 1] - r[:, 0])
    return Workspace(q=q, points=fk_position(robot, q, point=point))


_PLANES = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}


@dataclass(frozen=True, eq=False)
class PlanarRegion:
    """A 2-D workspace region as an occupancy grid and its boundary curves.

    Attributes
    ----------
    x_edges : ndarray, shape (nx + 1,)
        Cell edges along the first plane axis [m].
    y_edges : ndarray, shape (ny + 1,)
        Cell edges along the second plane axis [m].
    occupied : ndarray of bool, shape (ny, nx)
        ``occupied[j, i]`` for the cell ``[x_edges[i], x_edges[i+1]] x
        [y_edges[j], y_edges[j+1]]`` (``pcolormesh(x_edges, y_edges, occupied)``).
    boundaries : tuple of ndarray, each shape (k, 2)
        Closed boundary loops (first point repeated at the end) [m]: the
        outer boundary and those of holes.
    plane : str
        The projection plane, ``"xy"``, ``"xz"`` or ``"yz"``.
    """

    x_edges: np.ndarray
    y_edges: np.ndarray
    occupied: np.ndarray
    boundaries: tuple
    plane: str = "xy"

    @property
    def cell_area(self):
        """Area of one grid cell [m^2]."""
        return float((self.x_edges[1] - self.x_edges[0]) * (self.y_edges[1] - self.y_edges[0]))

    @property
    def area(self):
        """Area of the occupied cells [m^2] (accurate to about one cell row along the boundary)."""
        return float(self.occupied.sum()) * self.cell_area

    def contains(self, xy):
        """Whether points fall in an occupied cell.

        Parameters
        ----------
        xy : array_like, shape (..., 2)
            Points in the plane [m].

        Returns
        -------
        inside : ndarray of bool, shape (...)
        """
        xy = as_vector(xy, 2, "xy", finite=False)  # a non-finite point is in no cell
        i = np.searchsorted(self.x_edges, xy[..., 0], side="right") - 1
        j = np.searchsorted(self.y_edges, xy[..., 1], side="right") - 1
        ny, nx = self.occupied.shape
        ok = (i >= 0) & (i < nx) & (j >= 0) & (j < ny) & np.isfinite(xy).all(axis=-1)
        out = np.zeros(xy.shape[:-1], dtype=bool)
        out[ok] = self.occupied[j[ok], i[ok]]
        return out


def planar_region(
    workspace,
    *,
    bins=None,
    plane: Literal["xy", "xz", "yz"] = "xy",
    close_gaps=2,
):
    """Occupancy grid and boundary of a planar workspace (or a projection).

    The sampled points are binned on a square-celled grid; cells hit by at
    least one sample are occupied. ``close_gaps`` rounds of a binary closing
    fill isolated empty cells left by sparse sampling (use denser sampling or
    ``close_gaps=0`` to keep small real holes). The boundary is the 0.5 level
    line of the occupancy (marching squares, via ``contourpy``).

    Parameters
    ----------
    workspace : Workspace or array_like, shape (N, 3) or (N, 2)
        Sampled points [m].
    bins : int, optional
        Number of cells along the longer side of the bounding box; default
        ``clip(sqrt(N) / 2, 20, 400)`` for ``N`` points (a few samples per
        occupied cell).
    plane : {"xy", "xz", "yz"}
        Plane the 3-D points are projected on (ignored for (N, 2) input).
    close_gaps : int
        Iterations of the binary closing (0 to disable).

    Returns
    -------
    PlanarRegion

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> ws = workspace_points(Robot.load("planar3r_seed004"), n=200_000)
    >>> region = planar_region(ws, bins=100)
    >>> round(region.area / (np.pi * 0.47**2), 1)  # a full disc of radius 0.47 m
    1.0
    >>> bool(region.contains([0.3, 0.1])), bool(region.contains([0.5, 0.0]))
    (True, False)
    """
    import contourpy
    from scipy import ndimage

    pts = as_batch(workspace.points if isinstance(workspace, Workspace) else workspace, (), "workspace points")
    if pts.ndim != 2 or pts.shape[1] not in (2, 3) or len(pts) == 0:
        raise ShapeError(f"expected points with shape (N, 3) or (N, 2), N >= 1, got {pts.shape}")
    plane = as_option(plane, _PLANES, "plane")
    xy = pts if pts.shape[1] == 2 else pts[:, _PLANES[plane]]
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    span = float(max(hi - lo)) or 1e-3
    bins = int(np.clip(0.5 * np.sqrt(len(xy)), 20, 400)) if bins is None else as_count(bins, "bins", minimum=1)
    close_gaps = as_count(close_gaps, "close_gaps")
    cell = span / bins
    pad = (close_gaps + 2) * cell
    edges = []
    for k in range(2):
        m = int(np.ceil((hi[k] - lo[k] + 2 * pad) / cell))
        edges.append(0.5 * (lo[k] + hi[k]) - 0.5 * m * cell + cell * np.arange(m + 1))
    H, _, _ = np.histogram2d(xy[:, 0], xy[:, 1], bins=edges)
    occ = H.T > 0
    if close_gaps:
        occ = ndimage.binary_closing(occ, structure=np.ones((3, 3), bool), iterations=close_gaps)
    xc = 0.5 * (edges[0][1:] + edges[0][:-1])
    yc = 0.5 * (edges[1][1:] + edges[1][:-1])
    gen = contourpy.contour_generator(xc, yc, occ.astype(float), line_type="Separate")
    loops = tuple(np.asarray(line, dtype=float) for line in gen.lines(0.5))
    return PlanarRegion(x_edges=edges[0], y_edges=edges[1], occupied=occ, boundaries=loops, plane=plane)
