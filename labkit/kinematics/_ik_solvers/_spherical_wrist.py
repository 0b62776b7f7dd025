"""Closed-form IK family ``spherical_wrist`` (private).

Six revolute joints; joints 1-3 as ``yaw_pitch_pitch`` (with or without a
shoulder offset: PUMA 560/600, IRB140, KR5) and axes 4, 5, 6 meeting in one
point (the wrist centre), 4 not parallel to 5 and 5 not parallel to 6.
Target: tool pose. Joints 1-3 place the wrist centre
(:class:`~labkit.kinematics._ik_solvers._yaw_pitch_pitch._Arm`), joints 4-6 are a
Paden-Kahan subproblem 2 and a subproblem 1. Eight branches
``{right|left}_{up|down}_{noflip|flip}`` ("no flip" as roboticstoolbox-python:
``sign(q5) = -sign(alpha_4)``).
"""

from __future__ import annotations

import math

import numpy as np

from labkit.kinematics._ik_solvers._elementwise import sin, where
from labkit.kinematics._ik_solvers._family import Family, _documented
from labkit.kinematics._ik_solvers._geometry import (
    TOL, NotThisFamily, _Subproblem2, _angle_between, _cross, _floats, _length_scale, _matvec, _perpendicular,
    _reject, _per_branch, _rotate, _unit, _wrist_branches,
)
from labkit.kinematics._ik_solvers._yaw_pitch_pitch import _Arm
from labkit.robot.types import Convention


class SphericalWrist(Family):
    """Closed-form pose IK of a 6R arm with a spherical wrist: all 8 solutions."""

    name = "spherical_wrist"
    kind = "pose"
    joints = 6
    #: the arm placing the wrist centre (joints 1-3), and the names of its shoulder and elbow branches
    arm_type, arm_branches = _Arm, (("right", "left"), ("up", "down"))

    def __init__(self, robot, z, o, tool):
        a4, a5, a6 = (_unit(v) for v in z[3:])
        if np.linalg.norm(np.cross(a4, a5)) < 1e-6 or np.linalg.norm(np.cross(a5, a6)) < 1e-6:
            raise NotThisFamily("wrist axes 4-5 and 5-6 must not be parallel")
        # wrist centre: least-squares intersection of axes 4, 5, 6
        A, b = np.zeros((3, 3)), np.zeros(3)
        for d, p in zip((a4, a5, a6), o[3:]):
            P = np.eye(3) - np.outer(d, d)
            A += P
            b += P @ p
        C = np.linalg.solve(A, b)
        scale = _length_scale(robot)
        for d, p in zip((a4, a5, a6), o[3:]):
            if np.linalg.norm(np.cross(C - p, d)) > TOL * scale:
                raise NotThisFamily("wrist axes 4, 5, 6 do not meet in one point")
        self.arm = self.arm_type(robot, z, o, C)
        self.a4, self.a5, self.a6 = _floats(a4), _floats(a5), _floats(a6)
        self.R0 = [_floats(row) for row in tool[:3, :3]]  # tool orientation at q = 0
        self.w_tool = _floats(tool[:3, :3].T @ (C - tool[:3, 3]))  # wrist centre in tool coordinates
        self.x6 = _floats(_perpendicular(a6))  # perpendicular to axis 6, to recover q6
        self.x6p = _reject(self.a6, self.x6)  # its part perpendicular to a6, as angle_about takes it,
        self.n6 = _cross(self.a6, self.x6p)  # and a6 x that
        self.wrist = _Subproblem2(a4, a5, a6)
        # "no flip" as roboticstoolbox-python: sign(q5) = -sign(alpha_4) (alpha between axes 4 and 5)
        alpha4 = robot.links[4].alpha if robot.convention is Convention.MODIFIED else robot.links[3].alpha
        self.noflip_sign = -1.0 if math.sin(alpha4) > 0 else 1.0
        self.branches, self.aliases = _wrist_branches(*self.arm_branches)

    @_documented
    def solve(self, t):
        R = (t[0][:3], t[1][:3], t[2][:3])
        Rw = _matvec(R, self.w_tool)
        arm_q, arm_ok, distance = self.arm.solve((t[0][3] + Rw[0], t[1][3] + Rw[1], t[2][3] + Rw[2]))
        # M = R123^T R R0^T; the wrist only needs its action on a6 and on x6 (perpendicular to a6)
        RR0t = (_matvec(self.R0, R[0]), _matvec(self.R0, R[1]), _matvec(self.R0, R[2]))
        m, mx = _matvec(RR0t, self.a6), _matvec(RR0t, self.x6)
        a2, a4, a5, a6, x6p, n6 = self.arm.a2, self.a4, self.a5, self.a6, self.x6p, self.n6
        subproblem2 = self.wrist.solve

        def wrist(q23, m0, m1, m2, x0, x1, x2):
            """Joints 4-6 (noflip, then flip) for one arm branch, joint 1 undone on ``m`` and ``mx``."""
            m6, MX = _rotate(a2, -q23, (m0, m1, m2), (x0, x1, x2))  # undo joints 2 and 3 (the arm's pitch)
            (t4, t5), (u4, u5) = subproblem2(m6)
            Y, = _rotate(a5, -t5, *_rotate(a4, -t4, MX))
            Z, = _rotate(a5, -u5, *_rotate(a4, -u4, MX))
            t6, u6 = _angle_between(n6, x6p, _reject(a6, Y)), _angle_between(n6, x6p, _reject(a6, Z))
            swap = (sin(t5) * self.noflip_sign) < 0  # noflip first
            return (where(swap, u4, t4), where(swap, u5, t5), where(swap, u6, t6),
                    where(swap, t4, u4), where(swap, t5, u5), where(swap, t6, u6))

        # joint 1 undone once per side (arm branches 0-1 are the front side, 2-3 the back side), then
        # the four arm branches at once (one call on numpy rows four times as long)
        undone = [_rotate(self.arm.a1, -arm_q[b][0], m, mx) for b in (0, 2)]
        wrists = _per_branch(wrist, [(self.arm.pitch(q2, q3), *undone[b // 2][0], *undone[b // 2][1])
                                       for b, (_, q2, q3) in enumerate(arm_q)], ())
        q, reach = [], []
        for (q1, q2, q3), (t4, t5, t6, u4, u5, u6), ok in zip(arm_q, wrists, arm_ok):
            q += [(q1, q2, q3, t4, t5, t6), (q1, q2, q3, u4, u5, u6)]
            reach += [ok, ok]
        return q, reach, distance
