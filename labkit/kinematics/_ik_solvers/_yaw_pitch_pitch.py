"""Closed-form IK family ``yaw_pitch_pitch`` and the arm geometry it shares (private).

Three revolute joints: axis 1, axis 2 perpendicular to axis 1 and either
intersecting it or offset from it along their common normal (a *shoulder
offset*, ``a_1`` of IRB140 / KR5 arms), axis 3 parallel to axis 2; the tool
point may lie off the arm plane by a constant lateral offset. Target: tool
position. :class:`_Arm` (joints 1-3 placing a point) is also the first half of
``yaw_pitch_pitch_pitch`` and ``spherical_wrist``.

Branch naming (geometric, so it does not depend on sign conventions):
*elbow up* is the branch whose elbow lies on the "up" side of the line from
the shoulder to the wrist centre (tool point). "Up" is the side of the
shoulder's horizontal plane (perpendicular to axis 1) that the elbow points to
at the middle of joint 2's range (the side the arm works on); if that is
ambiguous (elbow within 0.2 L1 of the plane) it is ``+axis 1``. For the
Arduino arm of seed 000 (frame 0 ``z`` points down, servos 0-180 deg) this is
``-z0`` and reproduces the seed's elbow-up formula; for the PUMAs it is
``+z0``. With a shoulder offset the front and back arm solutions reach
differently far: ``reachable`` is per branch.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.kinematics._ik_solvers._elementwise import arctan2, maximum, minimum, sqrt, where
from labkit.kinematics._ik_solvers._family import Family, _documented
from labkit.kinematics._ik_solvers._geometry import (
    REACH_TOL, TOL, _CosineLaw, NotThisFamily, _feet, _matvec, _floats, _length_scale, _need_parallel, _unit,
)


def _joint2_middle(robot):
    """The middle of joint 2's range in the chain's sense (0 for an unbounded range) [rad]."""
    lim = robot.joint_limits[1]
    mid = 0.5 * (lim[0] + lim[1]) if np.all(np.isfinite(lim)) else 0.0
    return -mid if robot.links[1].flip else mid  # the limits are on q, the geometry on the chain's theta


class _Shoulder:
    """Joint 1 of an arm whose axis 2 is perpendicular to axis 1: the two arm planes through a point.

    Attributes read: ``S`` (the shoulder's foot on axis 1), ``planes_frame``
    (rows: the radial direction ``a2 x a1``, ``a2`` and ``a1`` at ``q = 0``),
    ``off`` (the point's lateral offset along axis 2) and ``front`` (the sign of
    the radial coordinate on the front side).
    """

    def planes(self, P):
        """The two arm planes through the point ``P`` (3 components) [m], front side then back side:
        ``sides`` ``[(side, q1, u), ...]`` (``side`` the sign of ``u``, the radial coordinate of ``P`` in
        that plane from axis 1 [m]; ``q1`` [rad]), ``w`` the height of ``P`` along axis 1 from the
        shoulder [m], ``shoulder_ok`` (``P`` at least the lateral offset from axis 1) and ``lateral``
        (how far inside it [m])."""
        S = self.S
        d = (P[0] - S[0], P[1] - S[1], P[2] - S[2])
        hr, hn, w = _matvec(self.planes_frame, d)
        off = self.off
        rho2 = hr * hr + hn * hn
        u0 = sqrt(maximum(rho2 - off * off, 0.0))
        shoulder_ok = rho2 >= off * off * (1.0 - 1e-12) - REACH_TOL
        lateral = maximum(abs(off) - sqrt(rho2), 0.0)
        az = arctan2(hn, hr)
        sides = []
        for side in (self.front, -self.front):
            u = side * u0
            sides.append((side, az - arctan2(off, u), u))
        return sides, w, shoulder_ok, lateral

    def pitch(self, q2, q3):
        """The turn [rad] about axis 2 of the joints after joint 1, from joints 2 and 3 in the chain's sense."""
        return q2 + self.s3 * q3


class _Arm(_Shoulder):
    """Geometry of joints 1-3: base yaw, two parallel pitch axes, the point ``W`` (3,) they place (tool point,
    wrist centre; ``W0`` at ``q = 0`` [m]), from the joint axes ``z`` and points ``o`` on them (n, 3) at
    ``q = 0``; raises :class:`NotThisFamily` unless axes 1-3 are yaw-pitch-pitch."""

    def __init__(self, robot, z, o, W0):
        a1, a2, a3 = (_unit(v) for v in z[:3])
        if abs(a1 @ a2) > TOL:
            raise NotThisFamily("axis 2 must be perpendicular to axis 1")
        _need_parallel(a2, a3, "axis 3 must be parallel to axis 2")
        scale = _length_scale(robot)
        er = np.cross(a2, a1)
        # the shoulder: foot of the common normal of axes 1 and 2 on axis 2, at the radial
        # distance Sr from axis 1 (the shoulder offset a_1 of IRB140 / KR5 arms; 0 for a PUMA)
        S1, S2 = _feet(o[0], a1, o[1], a2)
        self.S = _floats(S1)
        self.Sr = float((S2 - S1) @ er)
        self.s3 = 1.0 if a3 @ a2 > 0 else -1.0
        E = o[2] - S2
        Er, Ev = E @ er, E @ a1
        Wd = W0 - S1
        Wr, Wv = Wd @ er, Wd @ a1
        self.off = float(Wd @ a2)
        self.law = law = _CosineLaw((Er, Ev), (Wr - self.Sr - Er, Wv - Ev), TOL * scale,
                                    "the elbow must be away from the shoulder and the wrist")
        # which sign of u is the "front" (q1 as atan2 of the target) and which side is "up"
        self.front = -1.0 if Wr < -TOL * scale else 1.0
        self.up = -1.0 if law.L1 * math.sin(law.g1 - _joint2_middle(robot)) < -0.2 * law.L1 else 1.0
        self.up_positive = self.up > 0
        self.a1, self.a2, self.er = _floats(a1), _floats(a2), _floats(er)
        self.planes_frame = (self.er, self.a2, self.a1)  # rows: radial, lateral and height of a point

    def elbows(self, side, ur, w):
        """Joints 2-3 [rad] placing ``W`` at ``(ur, w)`` [m] from the shoulder in the arm plane of ``side``:
        ``ok``, ``distance`` out of reach [m] and ``[(q2, q3) elbow up, (q2, q3) elbow down]``."""
        ok, dist, elbow, shoulder, direction = self.law.solve(ur, w)
        # the shoulder -> W line points along +er' where ur > 0 (side when there is no offset)
        forward = where(abs(ur) > 1e-12, ur > 0, side > 0)
        # elbow above the shoulder->W line  <=>  (theta_b < 0) == (ur > 0), with up = +axis 1
        sign = where(forward == self.up_positive, -1.0, 1.0)  # the elbow below has -sign
        ss, se = sign * shoulder, sign * elbow
        g1, g21, s3 = self.law.g1, self.law.g21, self.s3
        return ok, dist, [(g1 - (direction - ss), s3 * (g21 - se)), (g1 - (direction + ss), s3 * (g21 + se))]

    def solve(self, W):
        """``(q1, q2, q3)`` [rad] placing ``W`` (3 components) [m] per branch (front elbow up, front down,
        back up, back down), whether each reaches it, and how far ``W`` lies out of reach [m]."""
        sides, w, shoulder_ok, lateral = self.planes(W)
        q, reach, distance = [], [], None
        for side, q1, u in sides:
            ok, dist, pairs = self.elbows(side, u - self.Sr, w)
            ok = shoulder_ok & ok
            dist = maximum(dist, lateral)
            distance = dist if distance is None else minimum(distance, dist)
            for q2, q3 in pairs:
                q.append((q1, q2, q3))
                reach.append(ok)
        return q, reach, distance


class YawPitchPitch(Family):
    """Closed-form position IK of a 3R yaw-pitch-pitch arm (seed 000's Arduino arm); the tool point placed
    by ``arm_type`` (also the base of ``spherical_rrp``)."""

    name = "yaw_pitch_pitch"
    kind = "position"
    joints = 3
    branches = ("elbow_up", "elbow_down", "back_elbow_up", "back_elbow_down")
    aliases = {"up": "elbow_up", "down": "elbow_down"}
    arm_type = _Arm

    def __init__(self, robot, z, o, tool):
        self.arm = self.arm_type(robot, z, o, tool[:3, 3])

    @_documented
    def solve(self, t):
        return self.arm.solve(t)
