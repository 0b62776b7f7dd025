"""Closed-form IK families ``spherical_rrp`` (RRP spherical arm) and ``stanford`` (RRP + spherical wrist) (private).

Joints 1 and 2 revolute, their axes perpendicular and meeting in the shoulder
``S``; joint 3 prismatic (the boom), its direction ``e`` perpendicular to
axis 2 (it turns with joint 2 in the plane perpendicular to axis 2). Either
DH convention, any signs. The point ``W`` placed (the tool point; the wrist
centre of ``stanford``) may lie off the boom: at ``q = 0``,
``W0 - S = off a2 + c_e e + c_n n`` with ``n = a2 x e`` (the Stanford arm's
``d2`` is ``off``, its ``a3`` is ``c_n``).

Joint 1 as ``yaw_pitch_pitch``: the two arm planes through ``W`` at the
lateral offset ``off`` (:class:`~labkit.kinematics._ik_solvers._yaw_pitch_pitch._Shoulder`),
``front`` then ``back``. In a plane, ``W`` lies ``rho`` from the shoulder's
line, ``rho^2 = (c_e + q3)^2 + c_n^2``: the boom ``out`` (``c_e + q3 > 0``,
``W`` on the boom's positive side) or ``in`` (run back through the
shoulder, rarely inside its limits); joint 2 then turns the in-plane vector
``(c_e + q3) e + c_n n`` onto ``W``'s (subproblem 1). Four branches
``{front|back}_{out|in}``; targets nearer the shoulder than
``sqrt(off^2 + c_n^2)`` (or nearer axis 1 than ``|off|``) are out of reach.
"front" is the side the boom points to at the middle of joint 2's range (its
radial part along ``a2 x a1``, as ``yaw_pitch_pitch``), ``+(a2 x a1)`` when it
points along axis 1 there.

``stanford``: six joints, joints 1-3 as above placing the wrist centre, axes
4-6 a spherical wrist (:class:`~labkit.kinematics._ik_solvers._spherical_wrist.SphericalWrist`):
eight branches ``{front|back}_{out|in}_{noflip|flip}``, targets poses.
"""

from __future__ import annotations

import numpy as np

from labkit.kinematics._ik_solvers._elementwise import arctan2, maximum, sqrt
from labkit.kinematics._ik_solvers._geometry import (
    REACH_TOL, TOL, NotThisFamily, _feet, _floats, _length_scale, _rotate, _unit,
)
from labkit.kinematics._ik_solvers._spherical_wrist import SphericalWrist
from labkit.kinematics._ik_solvers._yaw_pitch_pitch import _Shoulder, YawPitchPitch, _joint2_middle


class _SphericalArm(_Shoulder):
    """Geometry of joints 1-3 of a spherical (RRP) arm, yaw, pitch and boom, placing a point ``W`` (arguments
    and :class:`NotThisFamily` as :class:`~labkit.kinematics._ik_solvers._yaw_pitch_pitch._Arm`)."""

    def __init__(self, robot, z, o, W0):
        if not (robot.is_revolute[0] and robot.is_revolute[1]) or robot.is_revolute[2]:
            raise NotThisFamily("joints 1 and 2 must be revolute and joint 3 prismatic")
        a1, a2, e = (_unit(v) for v in z[:3])
        if abs(a1 @ a2) > TOL:
            raise NotThisFamily("axis 2 must be perpendicular to axis 1")
        S1, S2 = _feet(o[0], a1, o[1], a2)
        if np.linalg.norm(S2 - S1) > TOL * _length_scale(robot):
            raise NotThisFamily("axes 1 and 2 must meet (the shoulder)")
        if abs(e @ a2) > TOL:
            raise NotThisFamily("the boom (joint 3) must be perpendicular to axis 2")
        er, n = np.cross(a2, a1), np.cross(a2, e)
        Wd = W0 - S1
        self.off, self.c_e, self.c_n = float(Wd @ a2), float(Wd @ e), float(Wd @ n)
        self.S, self.a1, self.a2 = _floats(S1), _floats(a1), _floats(a2)
        self.planes_frame = (_floats(er), self.a2, self.a1)
        # in the plane perpendicular to a2, coordinates along (er, -a1), in which joint 2 turns positively
        self.e2, self.n2 = (float(e @ er), float(-(e @ a1))), (float(n @ er), float(-(n @ a1)))
        radial, = _rotate(self.a2, _joint2_middle(robot), _floats(e))
        radial = float(np.dot(radial, er))
        self.front = -1.0 if radial < -0.2 else 1.0

    def pitch(self, q2, q3):
        """The turn [rad] about axis 2 of the joints after joint 1: joint 2's (the boom ``q3`` [m] slides)."""
        return q2

    def solve(self, W):
        """``(q1, q2, q3)`` [rad, rad, m] placing ``W`` (3 components) [m] per branch (front out, front in, back
        out, back in), whether each reaches it, and how far ``W`` lies out of reach [m]."""
        sides, w, shoulder_ok, lateral = self.planes(W)
        c_n, (ex, ey), (nx, ny) = self.c_n, self.e2, self.n2
        u = sides[0][2]
        rho2 = u * u + w * w  # the same in both planes (u changes sign)
        ok = shoulder_ok & (rho2 >= c_n * c_n * (1.0 - 1e-12) - REACH_TOL)
        boom = sqrt(maximum(rho2 - c_n * c_n, 0.0))
        q, reach = [], []
        for _, q1, u in sides:
            for sign in (1.0, -1.0):
                b = sign * boom  # c_e + q3
                q2 = arctan2(-w, u) - arctan2(b * ey + c_n * ny, b * ex + c_n * nx)
                q.append((q1, q2, b - self.c_e))
                reach.append(ok)
        distance = maximum(lateral, maximum(abs(c_n) - sqrt(rho2), 0.0))
        return q, reach, distance


class SphericalRRP(YawPitchPitch):
    """Closed-form position IK of a spherical (RRP) arm: four branches."""

    name = "spherical_rrp"
    joints, prismatic = 3, 1
    branches = ("front_out", "front_in", "back_out", "back_in")
    aliases = {"front": "front_out", "back": "back_out"}
    arm_type = _SphericalArm


class Stanford(SphericalWrist):
    """Closed-form pose IK of a spherical arm with a spherical wrist (the Stanford arm): all 8 solutions."""

    name = "stanford"
    prismatic = 1
    arm_type, arm_branches = _SphericalArm, (("front", "back"), ("out", "in"))

