"""Closed-form IK family ``planar_2r`` (private).

Two revolute joints with parallel axes (either direction, any orientation in
the world) and a tool point off axis 2. Target: tool position ``(x, y, z)``;
the point must lie in the arm's plane (its height along axis 1 is fixed),
otherwise it is unreachable by the height difference. Branches ``elbow_up``
(relative elbow angle negative about axis 1, as ``planar_3r``) and
``elbow_down``.
"""

from __future__ import annotations

import numpy as np

from labkit.kinematics._ik_solvers._family import ELBOW_ALIASES, ELBOWS, Family, _documented
from labkit.kinematics._ik_solvers._geometry import (
    TOL, _CosineLaw, _dot, _floats, _length_scale, _need_parallel, _perpendicular, _unit,
)


class Planar2R(Family):
    """Closed-form position IK of a planar 2R arm: both elbow branches."""

    name = "planar_2r"
    kind = "position"
    joints = 2
    branches = ELBOWS
    aliases = ELBOW_ALIASES

    def __init__(self, robot, z, o, tool):
        a1, a2 = _unit(z[0]), _unit(z[1])
        _need_parallel(a1, a2, "axes 1 and 2 must be parallel")
        scale = _length_scale(robot)
        u = _perpendicular(a1)
        v = np.cross(a1, u)
        self.n, self.u, self.v, self.O = _floats(a1), _floats(u), _floats(v), _floats(o[0])
        self.s2 = 1.0 if a1 @ a2 > 0 else -1.0
        self.h = float(a1 @ (tool[:3, 3] - o[0]))  # height of the tool point along axis 1 (constant)
        e, f = o[1] - o[0], tool[:3, 3] - o[1]
        self.law = _CosineLaw((e @ u, e @ v), (f @ u, f @ v), TOL * scale,
                              "axis 2 must be away from axis 1 and the tool point away from axis 2")
        self.height_tol = 1e-9 * scale

    @_documented
    def solve(self, t):
        d = tuple(t[k] - self.O[k] for k in range(3))
        dz = _dot(self.n, d) - self.h
        ok, in_plane, q = self.law.branches(_dot(self.u, d), _dot(self.v, d))
        off_plane = np.abs(dz) > self.height_tol
        distance = np.hypot(in_plane, np.where(off_plane, dz, 0.0))
        ok = ok & np.logical_not(off_plane)
        return [(q1, self.s2 * q2) for q1, q2 in q], [ok, ok], distance
