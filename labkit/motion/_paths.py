"""Cartesian path geometry: lines, arcs, circles and waypoints.

Private module: the names are re-exported by :mod:`labkit.motion`, import
them from there.

A :class:`CartesianPath` is geometry only: a point ``p(s)`` for a path parameter
``s`` in ``[0, s_max]`` (1 for a line, arc or circle; the number of segments
for waypoints), with its derivatives ``dp/ds``, ``d2p/ds2``
(:meth:`CartesianPath.evaluate`) and the distance of points from it
(:meth:`CartesianPath.distance_from`). The timing ``s(t)`` and the inverse kinematics
along the path are in :mod:`labkit.motion`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from labkit.validation import as_batch, as_number
from labkit.exceptions import ShapeError

__all__ = ["CartesianPath", "line_path", "arc_path", "circle_path", "waypoint_path"]


def _point3(p, name):
    p = as_batch(p, (), name, finite=False)
    if p.shape == (2,):
        p = np.append(p, 0.0)  # planar: the x-y plane
    return as_batch(p, (3,), name).reshape(3)


@dataclass(frozen=True, eq=False)
class CartesianPath:
    """Geometry of a Cartesian path, parameterised by ``s`` in ``[0, s_max]``.

    Attributes
    ----------
    shape : str
        ``"line"``, ``"arc"``, ``"circle"`` or ``"waypoints"``.
    points : ndarray, shape (m, 3)
        Line ends or waypoints [m]; for arcs, the start and end points.
    center : ndarray, shape (3,) or None
        Arc centre [m].
    radius : float
        Arc radius [m] (0 for lines).
    plane_axes : ndarray, shape (2, 3) or None
        Orthonormal in-plane axes ``u, v`` of an arc;
        ``p = c + r (cos(theta) u + sin(theta) v)``.
    start_angle, sweep : float
        Arc angles [rad]: ``theta = start_angle + s sweep``.
    """

    shape: str
    points: np.ndarray
    center: np.ndarray | None = None
    radius: float = 0.0
    plane_axes: np.ndarray | None = None
    start_angle: float = 0.0
    sweep: float = 0.0

    @property
    def s_max(self):
        """End value of the path parameter (1, or the number of segments)."""
        return float(self.points.shape[0] - 1) if self.shape == "waypoints" else 1.0

    @property
    def length(self):
        """Path length [m]."""
        if self.shape in ("arc", "circle"):
            return abs(self.sweep) * self.radius
        return float(np.sum(np.linalg.norm(np.diff(self.points, axis=0), axis=-1)))

    @property
    def normal(self):
        """Unit normal of an arc's plane (``u x v``; sweep > 0 turns about it)."""
        if self.plane_axes is None:
            return None
        return np.cross(self.plane_axes[0], self.plane_axes[1])

    def evaluate(self, s):
        """Point and its first two derivatives with respect to ``s``.

        Parameters
        ----------
        s : array_like, shape (N,)

        Returns
        -------
        p, dp, ddp : ndarray, shape (N, 3)
            ``p(s)`` [m], ``dp/ds`` and ``d2p/ds2`` [m].
        """
        s = as_batch(s, (), "s").reshape(-1)
        if self.shape in ("arc", "circle"):
            u, v = self.plane_axes
            th = self.start_angle + s * self.sweep
            c, sn = np.cos(th)[:, None], np.sin(th)[:, None]
            radial = c * u + sn * v
            p = self.center + self.radius * radial
            dp = self.radius * self.sweep * (-sn * u + c * v)
            ddp = -self.radius * self.sweep**2 * radial
            return p, dp, ddp
        P = self.points
        if P.shape[0] == 2:  # a line: segment 0 everywhere (the same values without the gathers)
            d = np.empty((s.size, 3))
            d[...] = P[1] - P[0]
            p = np.multiply(s[:, None], d)
            p += P[0]
            return p, d, np.zeros_like(d)
        seg = np.clip(np.floor(s).astype(int), 0, P.shape[0] - 2)
        frac = (s - seg)[:, None]
        d = P[seg + 1] - P[seg]
        return P[seg] + frac * d, d, np.zeros_like(d)

    def point(self, s):
        """``p(s)``, shape (N, 3) [m].

        Parameters
        ----------
        s : array_like, shape (N,)
            Path parameter [-], from 0 to ``s_max``.

        Returns
        -------
        ndarray, shape (N, 3)
            Points on the path [m].
        """
        return self.evaluate(s)[0]

    def distance_from(self, x):
        """Distance of points ``x`` (N, 3) from the path [m] (checks, tests).

        Parameters
        ----------
        x : array_like, shape (N, 3) or (3,)
            Points [m].

        Returns
        -------
        ndarray, shape (N,)
            Shortest distance of each point from the path [m].
        """
        x = as_batch(x, (3,), "x").reshape(-1, 3)
        if self.shape in ("arc", "circle"):
            rel = x - self.center
            n = self.normal
            off = rel @ n
            inplane = rel - off[:, None] * n
            return np.hypot(off, np.linalg.norm(inplane, axis=-1) - self.radius)
        best = np.full(x.shape[0], np.inf)
        for a, b in zip(self.points[:-1], self.points[1:]):
            d = b - a
            L2 = float(d @ d)
            f = np.clip(((x - a) @ d) / L2, 0.0, 1.0) if L2 > 0 else np.zeros(x.shape[0])
            best = np.minimum(best, np.linalg.norm(x - (a + f[:, None] * d), axis=-1))
        return best


def line_path(start, end):
    """Straight line from ``start`` to ``end``.

    Parameters
    ----------
    start, end : array_like, shape (3,) or (2,)
        Points [m]; 2-D points lie in the x-y plane (planar arms).

    Returns
    -------
    CartesianPath

    Examples
    --------
    >>> round(line_path([0, 0.18, -0.094], [0.1, 0.15, -0.2]).length, 4)
    0.1488
    """
    return CartesianPath("line", np.stack([_point3(start, "start"), _point3(end, "end")]))


def _plane_axes(normal, plane_axes):
    if plane_axes is not None:
        if normal is not None:
            raise ShapeError("give the arc plane by normal or by plane_axes, not both")
        A = as_batch(plane_axes, (), "plane_axes", finite=False)
        if A.shape == (2, 2):
            A = np.concatenate([A, np.zeros((2, 1))], axis=1)
        A = as_batch(A, (2, 3), "plane_axes")
        u = A[0] / np.linalg.norm(A[0])
        v = A[1] - (A[1] @ u) * u  # Gram-Schmidt: v orthogonal to u
        nv = np.linalg.norm(v)
        if nv < 1e-12:
            raise ShapeError("expected two non-parallel in-plane axes, got parallel vectors")
        return np.stack([u, v / nv])
    n = np.array([0.0, 0.0, 1.0]) if normal is None else as_batch(normal, (3,), "normal").reshape(3)
    nn = np.linalg.norm(n)
    if nn < 1e-12:
        raise ShapeError("expected a non-zero plane normal")
    n = n / nn
    ref = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = ref - (ref @ n) * n
    u /= np.linalg.norm(u)
    return np.stack([u, np.cross(n, u)])


def arc_path(center, radius, start_angle, sweep, *, normal=None, plane_axes=None):
    """Circular arc.

    ``p(s) = center + radius (cos(theta) u + sin(theta) v)`` with
    ``theta = start_angle + s * sweep``, ``s`` in [0, 1].

    Parameters
    ----------
    center : array_like, shape (3,) or (2,)
        Centre [m] (2-D: in the x-y plane).
    radius : float
        [m], positive.
    start_angle, sweep : float
        [rad]; a positive sweep turns counter-clockwise about the normal.
    normal : array_like, shape (3,), optional
        Plane normal (default +z: the x-y plane, ``u = x``, ``v = y``). The
        in-plane axis ``u`` is the world x axis projected on the plane (y if
        the normal is close to x), and ``v = normal x u``.
    plane_axes : array_like, shape (2, 3), optional
        In-plane axes ``u, v`` instead of a normal (``v`` is orthogonalised).

    Returns
    -------
    CartesianPath

    Examples
    --------
    >>> a = arc_path([0.1, 0.25], 0.25, -np.pi / 2, np.pi / 2)  # seed 004, part D
    >>> a.point([0.0, 1.0]).round(3)
    array([[0.1 , 0.  , 0.  ],
           [0.35, 0.25, 0.  ]])
    """
    c = _point3(center, "center")
    r = as_number(radius, "radius", unit="m", positive=True)
    th0, sw = as_number(start_angle, "start_angle", unit="rad"), as_number(sweep, "sweep", unit="rad")
    if sw == 0:
        raise ShapeError(f"expected finite angles and a non-zero sweep [rad], got {start_angle!r}, {sweep!r}")
    A = _plane_axes(normal, plane_axes)
    shape = "circle" if abs(abs(sw) - 2 * math.pi) < 1e-12 else "arc"
    ends = c + r * np.stack([math.cos(t) * A[0] + math.sin(t) * A[1] for t in (th0, th0 + sw)])
    return CartesianPath(shape, ends, c, r, A, th0, sw)


def circle_path(center, radius, *, start_angle=0.0, normal=None, plane_axes=None, clockwise=False):
    """Full circle (an arc sweeping 2 pi) starting at ``start_angle``.

    Parameters
    ----------
    center : array_like, shape (3,) or (2,)
        Centre [m] (2-D: in the x-y plane).
    radius : float
        [m], positive.
    start_angle : float
        Angle of the start point in the plane [rad], measured from ``u``.
    normal : array_like, shape (3,), optional
        Plane normal (default +z), as for :func:`arc_path`.
    plane_axes : array_like, shape (2, 3), optional
        In-plane axes ``u, v`` instead of a normal, as for :func:`arc_path`.
    clockwise : bool
        Sweep ``-2 pi`` (clockwise about the normal) instead of ``+2 pi``.

    Returns
    -------
    CartesianPath

    Raises
    ------
    ShapeError
        A non-positive radius or a malformed centre, normal or plane_axes.

    Examples
    --------
    >>> round(circle_path([0, 0, 0.5], 0.1).length, 6)
    0.628319
    """
    return arc_path(center, radius, start_angle, -2 * math.pi if clockwise else 2 * math.pi,
               normal=normal, plane_axes=plane_axes)


def waypoint_path(points):
    """Straight segments through a sequence of points (stopping at each).

    Parameters
    ----------
    points : array_like, shape (m, 3) or (m, 2)
        ``m >= 2`` waypoints [m].

    Returns
    -------
    CartesianPath
        ``s`` runs from 0 to ``m - 1``; waypoint ``k`` is at ``s = k``.

    Examples
    --------
    >>> waypoint_path([[0, 0.2, 0.1], [0.1, 0.2, 0.1], [0.1, 0.2, 0.0]]).s_max
    2.0
    """
    P = as_batch(points, (), "points", finite=False)
    if P.ndim == 2 and P.shape[1] == 2:
        P = np.concatenate([P, np.zeros((P.shape[0], 1))], axis=1)
    P = as_batch(P, (3,), "points")
    if P.ndim != 2 or P.shape[0] < 2:
        raise ShapeError(f"expected waypoints with shape (m, 3), m >= 2, got {np.shape(points)}")
    return CartesianPath("waypoints", P)
