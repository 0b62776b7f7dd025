"""Closed-form IK of 4-DOF yaw-pitch-pitch-pitch arms (MeArm / uArm / Dobot type) (private).

``yaw_pitch_pitch_pitch``
    four revolute joints: joints 1-3 as ``yaw_pitch_pitch`` (shoulder on or offset
    from axis 1) and axis 4 parallel to axes 2 and 3 (a wrist pitch). Such an arm
    reaches a position and one pitch angle of its tool: its pose targets are the
    poses ``Rot(a1, q1) Rot(a2, theta) M`` at a point, built from
    ``(x, y, z, pitch)`` by :func:`labkit.kinematics.pose_from_position_pitch`.
    ``q1`` follows from the orientation, joints 2-3 place the wrist point on
    axis 4 (cosine law) and ``q4`` completes the pitch. Branches ``elbow_up`` and
    ``elbow_down`` (geometric, as ``yaw_pitch_pitch``). A pose whose orientation
    no such arm can take is unreachable (``distance`` inf).
"""

from __future__ import annotations

import numpy as np

from labkit.exceptions import ShapeError
from labkit.kinematics._ik_analytic import _TOL, _Arm, _NotThisStructure, _axes, _rot_batch, _unit
from labkit.validation import as_batch
from labkit.rotations import wrap_angle


def _angle_about(axis, v, w):
    """Angle rotating v onto w about ``axis`` (v (3,), w (N, 3)), both projected perpendicular to it."""
    vp = v - axis * (v @ axis)
    wp = w - np.outer(w @ axis, axis)
    return np.arctan2((np.cross(vp, wp) @ axis), wp @ vp)


class YawPitchPitchPitch:
    """Closed-form pose IK of a 4-DOF arm with three parallel pitch axes: both elbow branches."""

    name = "yaw_pitch_pitch_pitch"
    kind = "pose"
    branches = ("elbow_up", "elbow_down")
    aliases = {"up": "elbow_up", "down": "elbow_down"}

    def __init__(self, robot):
        if robot.n != 4 or not np.all(robot.is_revolute):
            raise _NotThisStructure("needs exactly 4 revolute joints")
        z, o, tool = _axes(robot)
        a2, a4 = _unit(z[1]), _unit(z[3])
        if np.linalg.norm(np.cross(a2, a4)) > _TOL:
            raise _NotThisStructure("axis 4 must be parallel to axes 2 and 3")
        self.arm = _Arm(robot, z, o, o[3])  # joints 1-3 place a point on axis 4
        self.s4 = 1.0 if a4 @ a2 > 0 else -1.0
        self.M = tool.copy()
        self.w_tool = np.linalg.inv(tool)[:3] @ np.r_[o[3], 1.0]  # that point in tool coordinates
        self.R0 = tool[:3, :3].copy()
        t = np.eye(3)[int(np.argmin(np.abs(a2)))]
        self.u = _unit(t - a2 * (t @ a2))

    def pose(self, target):
        """Tool poses of ``(x, y, z, pitch)`` targets (see :func:`pose_from_position_pitch`).

        Parameters
        ----------
        target : ndarray, shape (N, 4)
            Tool point [m] and pitch [rad]: the elevation of the tool x axis above the
            plane perpendicular to axis 1, positive towards +axis 1, 0 pointing away
            from axis 1 in the arm's plane.

        Returns
        -------
        ndarray, shape (N, 4, 4)
        """
        arm = self.arm
        x0 = self.R0[:, 0]
        if abs(x0 @ arm.en) > 1e-9:
            raise ShapeError("the tool x axis of this robot is not in the arm's plane: pitch is undefined")
        d = target[:, :3] - arm.S
        hr, hn = d @ arm.er, d @ arm.en
        P0 = self.M[:3, 3] - arm.S
        off = float(P0 @ arm.en)  # lateral offset of the tool point from the arm plane (constant)
        u = np.sqrt(np.maximum(hr * hr + hn * hn - off * off, 0.0))
        q1 = np.arctan2(hn, hr) - np.arctan2(off, u)
        psi0 = np.arctan2(x0 @ arm.ev, x0 @ arm.er)
        theta = psi0 - target[:, 3]  # rotating about axis 2 by theta lowers the pitch by theta
        R = _rot_batch(arm.a[0], q1) @ _rot_batch(arm.en, theta) @ self.R0
        T = np.zeros((target.shape[0], 4, 4))
        T[:, :3, :3] = R
        T[:, :3, 3] = target[:, :3]
        T[:, 3, 3] = 1.0
        return T

    def solve(self, T):
        """Both elbow branches of pose targets.

        Parameters
        ----------
        T : ndarray, shape (N, 4, 4)
            Target poses ``world_from_tool`` [m].

        Returns
        -------
        q : ndarray, shape (N, 2, 4)
            Joint angles per branch [rad].
        reachable : ndarray of bool, shape (N, 2)
        distance : ndarray, shape (N,)
            How far outside the workspace the wrist point lies [m]; inf where no
            4-DOF pose has the target's orientation.
        """
        arm = self.arm
        N = T.shape[0]
        Mrot = T[:, :3, :3] @ self.R0.T  # = Rot(a1, q1) Rot(a2, theta)
        a1, a2 = arm.a[0], arm.en
        q1 = _angle_about(a1, a2, Mrot @ a2)
        rest = _rot_batch(a1, -q1) @ Mrot
        theta = _angle_about(a2, self.u, rest @ self.u)
        err = np.abs(_rot_batch(a1, q1) @ _rot_batch(a2, theta) - Mrot).max(axis=(1, 2))
        oriented = err < 1e-9
        W = (T[:, :3, :3] @ self.w_tool + T[:, :3, 3]).T
        sols, ok, distance = arm.solve(W)
        q = np.empty((N, 2, 4))
        reach = np.empty((N, 2), dtype=bool)
        front = np.abs(wrap_angle(sols[0][0] - q1)) < 1e-6  # the front pair has the orientation's q1
        for k in range(2):
            pick = [np.where(front, f, b) for f, b in zip(sols[k], sols[2 + k])]
            q[:, k, 0], q[:, k, 1], q[:, k, 2] = q1, pick[1], pick[2]
            q[:, k, 3] = self.s4 * (theta - pick[1] - arm.s3 * pick[2])
            side_ok = np.where(front, ok[:, k], ok[:, 2 + k])
            q1_ok = front | (np.abs(wrap_angle(sols[2][0] - q1)) < 1e-6)
            reach[:, k] = side_ok & oriented & q1_ok
        distance = np.where(oriented, distance, np.inf)
        return q, reach, distance


def position_pitch_pose(solver, target):
    """Validated ``(x, y, z, pitch)`` targets -> poses, for :func:`labkit.kinematics.pose_from_position_pitch`.

    Parameters
    ----------
    solver : YawPitchPitchPitch
        The detected solver of the robot.
    target : array_like, shape (..., 4)
        ``(x, y, z)`` [m] and pitch [rad].

    Returns
    -------
    ndarray, shape (..., 4, 4)
    """
    t = as_batch(target, (4,), "target (x, y, z, pitch)")
    return solver.pose(t.reshape(-1, 4)).reshape(t.shape[:-1] + (4, 4))
