"""Closed-form IK of a planar 2R arm (private; the public API is :mod:`labkit.kinematics`).

``planar_2r``
    two revolute joints with parallel axes (either direction, any orientation in
    the world) and a tool point off axis 2. Target: tool position ``(x, y, z)``;
    the point must lie in the arm's plane (its height along axis 1 is fixed),
    otherwise it is unreachable by the height difference. Branches ``elbow_up``
    (relative elbow angle negative about axis 1, as ``planar_3r``) and
    ``elbow_down``.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.kinematics._ik_analytic import _REACH_TOL, _TOL, _NotThisStructure, _axes, _scale, _unit


class Planar2R:
    """Closed-form position IK of a planar 2R arm: both elbow branches."""

    name = "planar_2r"
    kind = "position"
    branches = ("elbow_up", "elbow_down")
    aliases = {"elbow_minus": "elbow_up", "elbow_plus": "elbow_down", "up": "elbow_up", "down": "elbow_down"}

    def __init__(self, robot):
        if robot.n != 2 or not np.all(robot.is_revolute):
            raise _NotThisStructure("needs exactly 2 revolute joints")
        z, o, tool = _axes(robot)
        a1, a2 = _unit(z[0]), _unit(z[1])
        if np.linalg.norm(np.cross(a1, a2)) > _TOL:
            raise _NotThisStructure("axes 1 and 2 must be parallel")
        scale = _scale(robot)
        self.n = a1
        self.s2 = 1.0 if a1 @ a2 > 0 else -1.0
        t = np.eye(3)[int(np.argmin(np.abs(a1)))]
        self.u = _unit(t - a1 * (t @ a1))
        self.v = np.cross(a1, self.u)
        self.O = o[0]
        P = tool[:3, 3]
        self.h = float(a1 @ (P - self.O))  # height of the tool point along axis 1 (constant)
        e = o[1] - self.O
        f = P - o[1]
        ex, ey, fx, fy = e @ self.u, e @ self.v, f @ self.u, f @ self.v
        self.L1, self.L2 = math.hypot(ex, ey), math.hypot(fx, fy)
        if self.L1 < _TOL * scale or self.L2 < _TOL * scale:
            raise _NotThisStructure("axis 2 must be away from axis 1 and the tool point away from axis 2")
        self.g1, self.g2 = math.atan2(ey, ex), math.atan2(fy, fx)
        self.height_tol = 1e-9 * scale

    def solve(self, target):
        """Both elbow branches of position targets.

        Parameters
        ----------
        target : ndarray, shape (N, 3)
            Tool-point positions [m].

        Returns
        -------
        q : ndarray, shape (N, 2, 2)
            Joint angles per branch [rad].
        reachable : ndarray of bool, shape (N, 2)
        distance : ndarray, shape (N,)
            How far outside the workspace each target lies [m] (0 inside).
        """
        d = target - self.O
        dz = d @ self.n - self.h
        wx, wy = d @ self.u, d @ self.v
        L1, L2 = self.L1, self.L2
        r2 = wx * wx + wy * wy
        r = np.sqrt(r2)
        cb = (r2 - L1 * L1 - L2 * L2) / (2 * L1 * L2)
        in_plane = np.maximum(np.maximum(r - (L1 + L2), abs(L1 - L2) - r), 0.0)
        distance = np.hypot(in_plane, np.where(np.abs(dz) > self.height_tol, dz, 0.0))
        ok = (np.abs(cb) <= 1.0 + _REACH_TOL) & (np.abs(dz) <= self.height_tol)
        cb = np.clip(cb, -1.0, 1.0)
        sb = np.sqrt(1.0 - cb * cb)
        aw = np.arctan2(wy, wx)
        q = np.empty((target.shape[0], 2, 2))
        for k, sign in enumerate((-1.0, 1.0)):  # elbow up: relative angle < 0
            tb = sign * np.arctan2(sb, cb)
            ta = aw - np.arctan2(sign * L2 * sb, L1 + L2 * cb)
            q[:, k, 0] = ta - self.g1
            q[:, k, 1] = self.s2 * (tb - (self.g2 - self.g1))
        return q, np.repeat(ok[:, None], 2, axis=1), distance
