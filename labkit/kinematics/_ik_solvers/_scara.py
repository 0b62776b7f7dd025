"""Closed-form IK families ``scara`` (RRPR, RRRP, PRRR ... SCARA arms) and ``scara_rrp`` (no wrist) (private).

Four joints, three revolute and one prismatic, every axis parallel (either
direction, any orientation in the world, either DH convention; the quill may
point up or down and sit anywhere in the chain). Joints 1 and 2 of the
revolute ones are the shoulder and the elbow, the third the wrist. The arm
reaches a tool point and a turn of its tool about the axes: targets ``(x, y,
z, yaw)`` [m, rad].

Up
    ``k``, the axis direction on the side of the robot's ``up`` (axis 1 itself
    when it is horizontal).
Yaw
    The angle about ``k`` from the reference ``u`` (world ``x`` when ``k`` is
    world ``z``; in general :func:`~labkit.kinematics._ik_solvers._geometry._perpendicular`
    of ``k``) to the tool ``x`` axis projected on the plane perpendicular to
    ``k`` (the tool ``y`` axis where ``x`` lies along ``k``).

Branches ``elbow_left`` and ``elbow_right`` (aliases ``lefty``/``righty``):
looking down ``k``, the elbow lies to the left or right of the line from the
shoulder axis to the wrist axis (right: the elbow turns counterclockwise, the
"righty" arm of SCARA makers).

The prismatic joint moves every later frame along ``k`` and commutes with the
rotations about axes parallel to it, so it takes the height and the three
revolute joints solve the planar problem of ``planar_3r``: the total turn from
the yaw, the wrist axis from the tool point and that turn, the elbow from
the cosine law. ``scara_rrp``: the same with two revolute joints and no wrist,
for targets ``(x, y, z)`` (the tool point's offset from the elbow axis is
link 2).
"""

from __future__ import annotations

import math

import numpy as np

from labkit.kinematics._ik_solvers._family import Family, _documented
from labkit.kinematics._ik_solvers._geometry import (
    TOL, _CosineLaw, _dot, _floats, _in_chain_order, _length_scale, _need_parallel, _perpendicular, _pose_matrices,
    _rotation_matrices, _unit,
)


def _up_axis(robot, z):
    """The unit axis ``k`` along ``z[0]`` on the side of the robot's ``up``, ``u`` normal to it, ``v = k x u``."""
    k = _unit(z[0])
    k = -k if float(np.dot(robot.up, k)) < -TOL else k
    u = _perpendicular(k)
    return k, u, np.cross(k, u)


class _YawTarget:
    """Targets ``(x, y, z, yaw)`` of an arm whose tool turns only about the constant axis ``k`` (a mixin).

    Set by :meth:`yaw_reference` from the family's ``k``, ``u``, ``v`` (:func:`_up_axis`)
    and the tool frame at ``q = 0``; the yaw is the module docstring's.
    """

    def yaw_reference(self, tool):
        """Read the yaw's reference axis and its yaw at ``q = 0`` from ``world_from_tool`` (4, 4) there."""
        k, u, v = (np.array(a) for a in (self.k, self.u, self.v))
        R0 = tool[:3, :3]
        self.ref = R0[:, 1] if abs(R0[:, 0] @ k) > 1.0 - 1e-9 else R0[:, 0]
        self.ref_tool = R0.T @ self.ref  # the yaw's reference axis in tool coordinates
        self.yaw0 = math.atan2(float(self.ref @ v), float(self.ref @ u))
        self.R0 = R0.copy()

    def pose(self, target):
        """Tool poses ``world_from_tool`` (N, 4, 4) [m] of targets ``(x, y, z, yaw)`` (N, 4) [m, rad]."""
        return _pose_matrices(_rotation_matrices(self.k, target[:, 3] - self.yaw0) @ self.R0, target[:, :3])

    def target_of(self, T):
        """The targets ``(x, y, z, yaw)`` (N, 4) [m, rad] of tool poses (N, 4, 4) [m]; yaw in (-pi, pi]."""
        ref = T[:, :3, :3] @ self.ref_tool
        yaw = np.arctan2(ref @ np.array(self.v), ref @ np.array(self.u))
        return np.concatenate([T[:, :3, 3], yaw[:, None]], axis=1)

    def poses(self, target):
        """Every tool pose (N, 1, 4, 4) [m] reaching targets (N, 4) [m, rad]: the yaw fixes the orientation."""
        return self.pose(target)[:, None]


class Scara(_YawTarget, Family):
    """Closed-form IK of a SCARA arm (three revolute and one prismatic joint, axes parallel): two elbows."""

    name = "scara"
    kind = "position_yaw"
    joints, prismatic = 4, 1
    branches = ("elbow_left", "elbow_right")
    aliases = {"left": "elbow_left", "right": "elbow_right", "lefty": "elbow_left", "righty": "elbow_right"}

    def __init__(self, robot, z, o, tool):
        k, u, v = _up_axis(robot, z)
        for j in range(1, robot.n):
            _need_parallel(k, _unit(z[j]), "all joint axes must be parallel")
        rev = np.flatnonzero(robot.is_revolute)
        self.order = (*rev, int(np.flatnonzero(~robot.is_revolute)[0]))  # shoulder, elbow, [wrist,] quill
        self.signs = tuple(1.0 if z[j] @ k > 0 else -1.0 for j in self.order)
        self.k, self.u, self.v, self.O = _floats(k), _floats(u), _floats(v), _floats(o[rev[0]])
        P = [(float((o[j] - o[rev[0]]) @ u), float((o[j] - o[rev[0]]) @ v)) for j in rev]
        pt = tool[:3, 3] - o[rev[0]]
        P.append((float(pt @ u), float(pt @ v)))  # the tool point: the wrist of an arm without one
        self.law = _CosineLaw(np.subtract(P[1], P[0]), np.subtract(P[2], P[1]), TOL * _length_scale(robot),
                              "the elbow axis must be away from the shoulder axis and the wrist axis from "
                              "the elbow")
        self.t0 = (P[3][0] - P[2][0], P[3][1] - P[2][1]) if len(rev) == 3 else (0.0, 0.0)  # tool from the wrist
        self.h0 = float(pt @ k)  # its height along k at q = 0
        self.yaw_reference(tool)

    @_documented
    def solve(self, t):
        d = tuple(t[i] - self.O[i] for i in range(3))
        rot = t[3] - self.yaw0 if len(t) == 4 else 0.0  # the total turn of the revolute joints about k
        c, s = np.cos(rot), np.sin(rot)
        t0x, t0y = self.t0
        x, y = _dot(self.u, d), _dot(self.v, d)
        # elbow left: the relative angle of link 2 is negative about k
        ok, distance, arm = self.law.branches(x - (c * t0x - s * t0y), y - (s * t0x + c * t0y))
        quill = self.signs[-1] * (_dot(self.k, d) - self.h0)
        q = []
        for q1, q2 in arm:
            turns = (q1, q2, rot - q1 - q2)[:len(self.order) - 1]  # shoulder, elbow, [wrist]
            q.append(_in_chain_order(self.order, (*(sj * v for sj, v in zip(self.signs, turns)), quill)))
        return q, [ok, ok], distance


class ScaraRRP(Scara):
    """Closed-form position IK of a SCARA without a wrist (two revolute joints and a quill, axes parallel)."""

    name = "scara_rrp"
    kind = "position"
    joints = 3
