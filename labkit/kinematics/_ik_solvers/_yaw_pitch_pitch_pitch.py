"""Closed-form IK family ``yaw_pitch_pitch_pitch`` (OpenMANIPULATOR-X, MeArm, uArm, Dobot type 4-DOF arms) (private).

Four revolute joints: joints 1-3 as ``yaw_pitch_pitch`` (shoulder on or offset
from axis 1; the upper arm may leave the shoulder at any angle, such as
OpenMANIPULATOR-X's 128 mm up / 24 mm forward link) and axis 4 parallel to
axes 2 and 3 (a wrist pitch). Such an arm reaches a tool point and one angle
of its tool: targets ``(x, y, z, pitch)`` [m, rad].

The approach direction
    The tool ``x`` axis, or the tool ``z`` axis (the approach vector of the n-o-a
    convention) when only that one lies in the arm's plane (perpendicular to axis 2).
Pitch
    The elevation of the approach direction above the plane perpendicular to
    axis 1, measured in the arm's plane, positive upwards (towards the side of
    axis 1 that the robot's ``up`` points to; ``+axis 1`` if axis 1 is
    horizontal), with pitch 0 pointing horizontally away from axis 1 towards
    the target. ``-pi/2`` points the tool straight down (a grasp from above);
    beyond ``+-pi/2`` the tool points back over axis 1.

Branches: for each side of the base (``q1`` facing the target, and turned by
half a turn: the arm reaches over its back, with the arm-relative elevation
``pi - pitch``) both elbows, named as ``yaw_pitch_pitch``: ``elbow_up``,
``elbow_down``, ``back_elbow_up``, ``back_elbow_down``. Which of them lie in the
joint limits is the finishing step's ``valid``.

The solution, per side: ``q1`` from the target point (as ``yaw_pitch_pitch``),
the total rotation ``theta = q2 + q3 + q4`` (signs of parallel axes included)
from the pitch, the wrist point on axis 4 from the tool point and ``theta``,
joints 2-3 from the cosine law, ``q4`` from ``theta``, on numpy rows.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.kinematics._ik_solvers._family import Family, _documented
from labkit.kinematics._ik_solvers._geometry import (
    TOL, NotThisFamily, _angle_about, _need_parallel, _pose_matrices, _rotation_matrices, _unit,
)
from labkit.kinematics._ik_solvers._yaw_pitch_pitch import _Arm, YawPitchPitch
from labkit.rotations import wrap_angle


class YawPitchPitchPitch(Family):
    """Closed-form IK of a 4-DOF yaw-pitch-pitch-pitch arm for targets (x, y, z, pitch): four branches."""

    name = "yaw_pitch_pitch_pitch"
    kind = "position_pitch"
    joints = 4
    branches = YawPitchPitch.branches
    aliases = {"up": "elbow_up", "down": "elbow_down"}

    def __init__(self, robot, z, o, tool):
        a2, a4 = _unit(z[1]), _unit(z[3])
        _need_parallel(a2, a4, "axis 4 must be parallel to axes 2 and 3")
        pt = tool[:3, 3]
        W0 = o[3] + a4 * ((pt - o[3]) @ a4)  # the wrist point: the tool point's foot on axis 4
        self.arm = arm = _Arm(robot, z, o, W0)
        self.s4 = 1.0 if a4 @ a2 > 0 else -1.0
        x0 = self._approach(robot, z, o, tool)
        if abs(x0 @ a2) > TOL:
            raise NotThisFamily("the approach direction (tool x or z axis) must lie in the arm's plane (perpendicular "
                                "to axis 2)")
        er, a1 = np.array(arm.er), np.array(arm.a1)
        self.psi0 = math.atan2(float(x0 @ a1), float(x0 @ er))  # elevation of the approach at q = 0
        # pitch is positive upwards: towards +axis 1 (sign +1) or -axis 1 (-1, an axis 1 pointing down)
        self.sign = -1.0 if float(np.dot(robot.up, a1)) < -TOL else 1.0
        d0 = pt - W0  # the tool point seen from the wrist point at q = 0, in the arm's plane
        self.dr0, self.dv0 = float(d0 @ er), float(d0 @ a1)
        self.R0 = tool[:3, :3].copy()
        self.approach_tool = self.R0.T @ x0  # the approach direction in tool coordinates

    def _approach(self, robot, z, o, tool):
        """The approach direction at ``q = 0`` (world): the tool x axis, else its z axis if only that lies in the plane."""
        x, a, a2 = _unit(tool[:3, 0]), _unit(tool[:3, 2]), _unit(z[1])
        return a if abs(x @ a2) > TOL and abs(a @ a2) <= TOL else x

    def _arm_joints(self, x, y, z, pitch):
        """Per branch ``(q1, q2, q3, q4)``, reachable, the side's sign, and the distance out of reach."""
        arm = self.arm
        sides, w, shoulder_ok, lateral = arm.planes((x, y, z))
        pitch = self.sign * pitch  # the elevation towards +axis 1
        q, reach, signs, distance = [], [], [], None
        for side, q1, u in sides:
            # the arm-relative elevation: the target lies along +er' (side > 0) or -er' of this plane
            theta = self.psi0 - (pitch if side > 0 else math.pi - pitch)
            c, s = np.cos(theta), np.sin(theta)
            wr = u - (self.dr0 * c + self.dv0 * s)  # the wrist point in this plane
            wv = w - (self.dv0 * c - self.dr0 * s)
            ok, dist, pairs = arm.elbows(side, wr - arm.Sr, wv)
            ok = shoulder_ok & ok
            dist = np.maximum(dist, lateral)
            distance = dist if distance is None else np.minimum(distance, dist)
            for q2, q3 in pairs:
                q.append((q1, q2, q3, self.s4 * (theta - q2 - arm.s3 * q3)))
                reach.append(ok)
                signs.append(side)
        return q, reach, signs, distance

    @_documented
    def solve(self, t):
        q, reach, _, distance = self._arm_joints(t[0], t[1], t[2], t[3])
        return q, reach, distance

    # -- poses <-> targets (numpy; for display, target errors and pose targets) --------------------

    def _rest(self, target, back=False):
        """The orientation after joints 1-4 (before any roll) on the front or back side:
        ``Rot(a1, q1) Rot(a2, theta)``, (N, 3, 3)."""
        sides, _, _, _ = self.arm.planes(tuple(target[:, :3].T))
        q1 = next(q1 for side, q1, _ in sides if (side < 0) == back)
        pitch = self.sign * target[:, 3]
        return _rotation_matrices(self.arm.a1, q1) @ _rotation_matrices(
            self.arm.a2, self.psi0 - (math.pi - pitch if back else pitch))

    def pose(self, target, back=False):
        """Tool poses [m] of targets ``(x, y, z, pitch[, roll])`` [m, rad], facing them or over the back.

        Parameters
        ----------
        target : ndarray, shape (N, k)
        back : bool
            The pose of the branches reaching over the back (base turned by half a turn).

        Returns
        -------
        ndarray, shape (N, 4, 4)
        """
        return _pose_matrices(self._rest(target, back) @ self.R0, target[:, :3])

    def poses(self, target):
        """Every tool pose [m] that reaches targets [m, rad]: facing them, then over the back.

        Parameters
        ----------
        target : ndarray, shape (N, k)

        Returns
        -------
        ndarray, shape (N, 2, 4, 4)
        """
        return np.stack([self.pose(target), self.pose(target, back=True)], axis=1)

    def target_of(self, T):
        """The targets [m, rad] (angles in (-pi, pi]) that tool poses [m] reach: :meth:`pose` inverted.

        Parameters
        ----------
        T : ndarray, shape (N, 4, 4)

        Returns
        -------
        ndarray, shape (N, k)
        """
        p = T[:, :3, 3]
        app = T[:, :3, :3] @ self.approach_tool
        sides, _, _, _ = self.arm.planes(tuple(p.T))
        (s_a, q1_a, _), (_, q1_b, _) = sides
        normals = [_rotation_matrices(self.arm.a1, q1) @ np.array(self.arm.a2) for q1 in (q1_a, q1_b)]
        first = np.abs((app * normals[0]).sum(-1)) <= np.abs((app * normals[1]).sum(-1)) + 1e-12
        q1 = np.where(first, q1_a, q1_b)
        ahead = first == (s_a > 0)  # the target lies along +er of the chosen plane
        er = _rotation_matrices(self.arm.a1, q1) @ np.array(self.arm.er)
        psi = np.arctan2(app @ np.array(self.arm.a1), (app * er).sum(-1))
        pitch = wrap_angle(self.sign * np.where(ahead, psi, math.pi - psi))
        out = [p, pitch[:, None]]
        roll = self._roll_of(T, app, q1, psi, ahead)
        if roll is not None:
            out.append(roll[:, None])
        return np.concatenate(out, axis=1)

    def _roll_of(self, T, app, q1, psi, ahead):
        """The roll of poses (None: this family has no roll)."""
        return None


def _roll_about(app, reference, actual):
    """The angle [rad] about the unit approach directions ``app`` (N, 3) turning ``reference`` onto ``actual``."""
    return _angle_about(tuple(app.T), tuple(reference.T), tuple(actual.T))
