"""Closed-form IK family ``yaw_pitch_pitch_pitch`` (MeArm / uArm / Dobot type 4-DOF arms) (private).

Four revolute joints: joints 1-3 as ``yaw_pitch_pitch`` (shoulder on or offset
from axis 1) and axis 4 parallel to axes 2 and 3 (a wrist pitch). Such an arm
reaches a position and one pitch angle of its tool: its pose targets are the
poses ``Rot(a1, q1) Rot(a2, theta) M`` at a point, built from
``(x, y, z, pitch)`` by :meth:`YawPitchPitchPitch.pose`. ``q1`` follows from
the orientation, joints 2-3 place the wrist point on axis 4 (cosine law) and
``q4`` completes the pitch. Branches ``elbow_up`` and ``elbow_down``
(geometric, as ``yaw_pitch_pitch``). A pose whose orientation no such arm can
take is unreachable (``distance`` inf). Runs on numpy batches only.
"""

from __future__ import annotations

import numpy as np

from labkit.exceptions import ShapeError
from labkit.kinematics.ik._family import ELBOWS, Family, documented
from labkit.kinematics.ik._geometry import (
    angle_about, floats, need_parallel, perpendicular, rotation_matrices, unit,
)
from labkit.kinematics.ik._xp import NUMPY
from labkit.kinematics.ik._yaw_pitch_pitch import Arm
from labkit.rotations import wrap_angle


class YawPitchPitchPitch(Family):
    """Closed-form pose IK of a 4-DOF arm with three parallel pitch axes: both elbow branches."""

    name = "yaw_pitch_pitch_pitch"
    kind = "pose"
    joints = 4
    branches = ELBOWS
    aliases = {"up": "elbow_up", "down": "elbow_down"}
    scalar = False

    def __init__(self, robot, z, o, tool):
        a2, a4 = unit(z[1]), unit(z[3])
        need_parallel(a2, a4, "axis 4 must be parallel to axes 2 and 3")
        self.arm = Arm(robot, z, o, o[3])  # joints 1-3 place a point on axis 4
        self.s4 = 1.0 if a4 @ a2 > 0 else -1.0
        self.M = tool.copy()
        self.w_tool = np.linalg.inv(tool)[:3] @ np.r_[o[3], 1.0]  # that point in tool coordinates
        self.R0 = tool[:3, :3].copy()
        self.u = floats(perpendicular(a2))

    def pose(self, target):
        """Tool poses of ``(x, y, z, pitch)`` targets (see :func:`labkit.kinematics.pose_from_position_pitch`).

        Parameters
        ----------
        target : ndarray, shape (N, 4)
            Tool point [m] and pitch [rad]: the elevation of the tool x axis above the
            plane perpendicular to axis 1, positive towards +axis 1, 0 pointing away
            from axis 1 in the arm's plane.

        Returns
        -------
        ndarray, shape (N, 4, 4)

        Raises
        ------
        ShapeError
            The robot's tool x axis is not in the arm's plane.
        """
        arm = self.arm
        er, en, ev = (np.array(v) for v in (arm.er, arm.a2, arm.a1))
        x0 = self.R0[:, 0]
        if abs(x0 @ en) > 1e-9:
            raise ShapeError("the tool x axis of this robot is not in the arm's plane: pitch is undefined")
        d = target[:, :3] - np.array(arm.S)
        hr, hn = d @ er, d @ en
        off = float((self.M[:3, 3] - np.array(arm.S)) @ en)  # lateral offset of the tool point (constant)
        u = np.sqrt(np.maximum(hr * hr + hn * hn - off * off, 0.0))
        q1 = np.arctan2(hn, hr) - np.arctan2(off, u)
        psi0 = np.arctan2(x0 @ ev, x0 @ er)
        theta = psi0 - target[:, 3]  # rotating about axis 2 by theta lowers the pitch by theta
        T = np.zeros((target.shape[0], 4, 4))
        T[:, :3, :3] = rotation_matrices(arm.a1, q1) @ rotation_matrices(arm.a2, theta) @ self.R0
        T[:, :3, 3] = target[:, :3]
        T[:, 3, 3] = 1.0
        return T

    @documented
    def solve(self, xp, t):
        arm = self.arm
        T = np.moveaxis(np.asarray(t), -1, 0)
        N = T.shape[0]
        Mrot = T[:, :3, :3] @ self.R0.T  # = Rot(a1, q1) Rot(a2, theta)
        a1, a2 = arm.a1, arm.a2
        q1 = angle_about(NUMPY, a1, a2, tuple((Mrot @ np.array(a2)).T))
        rest = rotation_matrices(a1, -q1) @ Mrot
        theta = angle_about(NUMPY, a2, self.u, tuple((rest @ np.array(self.u)).T))
        err = np.abs(rotation_matrices(a1, q1) @ rotation_matrices(a2, theta) - Mrot).max(axis=(1, 2))
        oriented = err < 1e-9
        W = (T[:, :3, :3] @ self.w_tool + T[:, :3, 3]).T
        sols, ok, distance = arm.solve(NUMPY, W)
        front = np.abs(wrap_angle(sols[0][0] - q1)) < 1e-6  # the front pair has the orientation's q1
        q1_ok = front | (np.abs(wrap_angle(sols[2][0] - q1)) < 1e-6)
        q, reach = [], []
        for k in range(2):
            _, q2, q3 = (np.where(front, f, b) for f, b in zip(sols[k], sols[2 + k]))
            q.append((q1, q2, q3, self.s4 * (theta - q2 - arm.s3 * q3)))
            reach.append(np.where(front, ok[k], ok[2 + k]) & oriented & q1_ok)
        return q, reach, np.where(oriented, distance, np.inf) + np.zeros(N)
