"""Closed-form IK family ``yaw_pitch_pitch_pitch_roll`` (SO-100 / SO-101, Lynxmotion AL5D type 5-DOF arms) (private).

Five revolute joints: joints 1-4 as ``yaw_pitch_pitch_pitch`` and axis 5 (a
wrist roll) perpendicular to axis 4, in the arm's plane, with the tool point
on it. Targets ``(x, y, z, pitch, roll)`` [m, rad].

The approach direction
    Axis 5 (the roll axis), pointing from the wrist towards the tool point (or
    ``+axis 5`` when the tool point is at the wrist); a positive roll turns
    the tool right-handed about it (``q5 = -roll`` where axis 5 points the
    other way).
Pitch
    As ``yaw_pitch_pitch_pitch``, of this approach direction: its elevation
    above the plane perpendicular to axis 1, positive towards ``+axis 1``, 0
    pointing horizontally away from axis 1 towards the target.
Roll
    The angle about the approach direction (right-handed) from the tool's
    reference orientation: the orientation the arm has with ``q5 = 0`` when it
    reaches the target with the target *ahead*: on the side of axis 1 that
    ``axis 2 x axis 1`` points to (at ``q1 = 0``; where the arm points at
    ``q = 0`` in the bundled OpenMANIPULATOR-X, SO-101 and AL5D files). An arm reaching over its back
    (base turned by half a turn) takes the same orientation with ``q5`` turned
    by half a turn: the roll, like the pitch, is a property of the tool pose,
    not of the branch.

Branches as ``yaw_pitch_pitch_pitch`` (both elbows on each side of the base);
``q5`` follows from the roll and the side.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.kinematics._ik_solvers._family import _documented
from labkit.kinematics._ik_solvers._geometry import TOL, NotThisFamily, _length_scale, _rotation_matrices, _unit
from labkit.kinematics._ik_solvers._yaw_pitch_pitch_pitch import YawPitchPitchPitch, _roll_about
from labkit.rotations import wrap_angle


class YawPitchPitchPitchRoll(YawPitchPitchPitch):
    """Closed-form IK of a 5-DOF yaw-pitch-pitch-pitch-roll arm for targets (x, y, z, pitch, roll): four branches."""

    name = "yaw_pitch_pitch_pitch_roll"
    kind = "position_pitch_roll"
    joints = 5

    def _approach(self, robot, z, o, tool):
        """The approach direction at ``q = 0`` (world): ``+axis 5``, which must carry the tool point."""
        a5 = _unit(z[4])
        ahead = tool[:3, 3] - o[4]
        if np.linalg.norm(np.cross(ahead, a5)) > TOL * _length_scale(robot):
            raise NotThisFamily("the tool point must lie on axis 5 (the roll axis)")
        W0 = o[3] + _unit(z[3]) * ((tool[:3, 3] - o[3]) @ _unit(z[3]))
        self.s5 = -1.0 if (tool[:3, 3] - W0) @ a5 < -TOL * _length_scale(robot) else 1.0
        self.a5 = self.s5 * a5
        return self.a5

    @_documented
    def solve(self, t):
        q, reach, signs, distance = self._arm_joints(t[0], t[1], t[2], t[3])
        roll = self.s5 * t[4]  # q5 about +axis 5
        back = roll + math.pi  # the same tool orientation reached over the back
        return [(*qb, roll if side > 0 else back) for qb, side in zip(q, signs)], reach, distance

    def _rest(self, target, back=False):
        """``Rot(a1, q1) Rot(a2, theta) Rot(a5, q5)`` of targets (N, 5) on one side, (N, 3, 3)."""
        roll = target[:, 4] + (math.pi if back else 0.0)
        return super()._rest(target, back) @ _rotation_matrices(tuple(self.a5), roll)

    def _roll_of(self, T, app, q1, psi, ahead):
        """Roll of poses: from the reference orientation (``q5 = 0``, the target ahead) about the approach."""
        reference = _rotation_matrices(self.arm.a1, q1) @ np.array(self.arm.a2)  # a2 after joints 1-4
        actual = T[:, :3, :3] @ (self.R0.T @ np.array(self.arm.a2))
        chain = _roll_about(app, reference, actual)  # = q5 (chain sense) on this side
        return wrap_angle(np.where(ahead, chain, chain - math.pi))
