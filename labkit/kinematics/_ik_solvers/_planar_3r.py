"""Closed-form IK family ``planar_3r`` (private).

Three revolute joints whose axes are all parallel to the world ``+z`` axis,
with a tool frame whose ``z`` is ``+z`` too (seeds 003 and 004). Target
``(x, y, phi)``, ``phi`` the angle of the tool ``x`` axis from world ``x``.
Elbow up means the elbow lies to the left of the line joint 1 -> joint 3
(above it for a target in front, ``x > 0``): the relative elbow angle is
negative (seed 004's "elbow minus").
"""

from __future__ import annotations

import math

import numpy as np

from labkit.kinematics._ik_solvers._family import ELBOW_ALIASES, ELBOWS, Family, _documented
from labkit.kinematics._ik_solvers._geometry import TOL, _CosineLaw, NotThisFamily


class Planar3R(Family):
    """Closed-form IK of a planar 3R arm for targets (x, y, phi)."""

    name = "planar_3r"
    kind = "planar"
    branches, aliases = ELBOWS, ELBOW_ALIASES
    joints = 3

    def __init__(self, robot, z, o, tool):
        if np.any(np.abs(z[:, 2] - 1.0) > TOL):
            raise NotThisFamily("all joint axes must be parallel to world +z")
        if abs(tool[2, 2] - 1.0) > TOL:
            raise NotThisFamily("the tool z axis must be world +z")
        P = o[:, :2]
        self.base = (float(P[0, 0]), float(P[0, 1]))
        self.law = _CosineLaw(P[1] - P[0], P[2] - P[1], TOL, "links 1 and 2 must have non-zero length")
        self.psi0 = math.atan2(tool[1, 0], tool[0, 0])
        t0 = tool[:2, 3] - P[2]  # tool point relative to axis 3 at q = 0
        self.t0 = (float(t0[0]), float(t0[1]))

    @_documented
    def solve(self, t):
        x, y, phi = t[0], t[1], t[2]
        rot = phi - self.psi0  # q1 + q2 + q3
        c, s = np.cos(rot), np.sin(rot)
        t0x, t0y = self.t0
        ok, distance, q = self.law.branches(x - (c * t0x - s * t0y) - self.base[0],
                                            y - (s * t0x + c * t0y) - self.base[1])
        return [(q1, q2, rot - q1 - q2) for q1, q2 in q], [ok, ok], distance
