"""Closed-form IK family ``three_parallel``: UR-type 6R arms, up to 8 solutions (private).

Six revolute joints; axes 2, 3, 4 parallel (direction ``n`` at ``q = 0``),
axis 1 and axis 5 perpendicular to them, axis 6 meeting axis 5 in a point and
not parallel to ``n`` at every ``q5`` (Universal Robots UR3/UR5/UR10 and their
e-series). Target: tool pose. Solved in the world frame on the joint screws at
``q = 0`` (product of exponentials ``T = e^[S1] q1 ... e^[S6] q6 M``):

1. joints 2-4 keep the ``n``-height of every point: the point ``P56`` where axes
   5 and 6 meet (fixed in the tool) gives ``A cos q1 + B sin q1 = h``: two
   shoulder solutions;
2. they keep ``n``-components of directions: ``n(q1) . z6 = a cos q5 + b sin q5``:
   two wrist solutions;
3. ``q6`` is Paden-Kahan subproblem 1 on ``R^T n(q1)``; at the wrist
   singularity (axis 6 parallel to ``n``) only ``q4 + q6`` is determined and the
   representative has ``q6 = 0``;
4. ``e^[S2] q2 e^[S3] q3 e^[S4] q4`` is then known: a planar 2R problem for a
   point on axis 4 (two elbow solutions, cosine law) and ``q4`` from the total angle.

Branch names ``{shoulder}_{elbow}_{wrist}``: ``left``/``right`` is the sign
(+/-) of the arccos term of step 1, ``up``/``down`` the elbow (relative angle
of link 3 to link 2 about ``n`` negative / positive, as ``planar_3r``), and
``noflip``/``flip`` the sign (+/-) of the arccos term of step 2. Runs on numpy
batches only.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.kinematics._ik_solvers._family import Family, _documented
from labkit.kinematics._ik_solvers._geometry import (
    REACH_TOL, TOL, _CosineLaw, NotThisFamily, _angle_about, _feet, _floats, _length_scale, _need_parallel,
    _perpendicular, _pose_matrices, _rotation_matrices, _unit, _wrist_branches,
)


def _screw(axis, point, angle):
    """Homogeneous transforms ``e^[S] angle`` of a rotation about a line, (N,) -> (N, 4, 4)."""
    R = _rotation_matrices(axis, angle)
    return _pose_matrices(R, point - R @ point)


def _inverse(E):
    Rt = np.swapaxes(E[..., :3, :3], -1, -2)
    return _pose_matrices(Rt, -(Rt @ E[..., :3, 3, None])[..., 0])


class ThreeParallel(Family):
    """Closed-form pose IK of a UR-type 6R arm (axes 2, 3, 4 parallel): all 8 solutions."""

    name = "three_parallel"
    kind = "pose"
    joints = 6

    def __init__(self, robot, z, o, tool):
        w = [_unit(v) for v in z]
        n = w[1]
        for k in (2, 3):
            _need_parallel(n, w[k], "axes 2, 3 and 4 must be parallel")
        if abs(w[0] @ n) > TOL or abs(w[4] @ n) > TOL:
            raise NotThisFamily("axes 1 and 5 must be perpendicular to axes 2-4")
        if np.linalg.norm(np.cross(w[4], w[5])) < 1e-6:
            raise NotThisFamily("axis 6 must not be parallel to axis 5")
        scale = _length_scale(robot)
        f5, f6 = _feet(o[4], w[4], o[5], w[5])
        if np.linalg.norm(f5 - f6) > TOL * scale:
            raise NotThisFamily("axes 5 and 6 must meet in a point")
        self.w, self.o, self.n = w, o, n
        self.s = [1.0 if w[i] @ n > 0 else -1.0 for i in range(1, 4)]  # signs of axes 2-4 along n
        self.Minv = np.linalg.inv(tool)
        self.p56_tool = (self.Minv @ np.r_[f6, 1.0])[:3]  # the meeting point in tool coordinates
        self.n_cross = np.cross(w[0], n)  # n(q1) = cos(q1) n + sin(q1) (w1 x n)
        self.h = float(n @ (f6 - o[0]))
        self.z6_tool = self.Minv[:3, :3] @ w[5]
        self.a5 = float(n @ w[5])  # n . Rot(w5, q5) w6 = a5 cos q5 + b5 sin q5
        self.b5 = float(n @ np.cross(w[4], w[5]))
        if math.hypot(self.a5, self.b5) < 1e-6:
            raise NotThisFamily("axis 6 must not stay perpendicular to axes 2-4")
        # planar 2R of a point on axis 4 about axes 2, 3 (in the plane perpendicular to n)
        self.u = _perpendicular(n)
        self.v = np.cross(n, self.u)
        e, f = o[2] - o[1], o[3] - o[2]
        self.law = _CosineLaw((e @ self.u, e @ self.v), (f @ self.u, f @ self.v), TOL * scale,
                              "axes 2, 3 and 4 must be apart (non-zero upper arm and forearm)")
        self.branches, self.aliases = _wrist_branches(("left", "right"))

    @_documented
    def solve(self, t):
        T = np.moveaxis(np.atleast_3d(t), -1, 0)  # (one target's components are scalars)
        N = T.shape[0]
        w, o, n = self.w, self.o, self.n
        w6, nf, uf = _floats(w[5]), _floats(n), _floats(self.u)
        X = T @ self.Minv  # = e^[S1] q1 ... e^[S6] q6
        P = T[:, :3, :3] @ self.p56_tool + T[:, :3, 3]
        z6 = T[:, :3, :3] @ self.z6_tool
        d = P - o[0]
        A, B = d @ n, d @ self.n_cross
        rho = np.hypot(A, B)
        c1 = self.h / np.where(rho > 0, rho, 1.0)
        ok1 = np.abs(c1) <= 1.0 + REACH_TOL
        dist1 = np.maximum(abs(self.h) - rho, 0.0)
        acos1 = np.arccos(np.clip(c1, -1.0, 1.0))
        base1 = np.arctan2(B, A)
        q, reach = [], []
        distance = np.full(N, np.inf)
        rho5 = math.hypot(self.a5, self.b5)
        base5 = math.atan2(self.b5, self.a5)
        for sign1 in (1.0, -1.0):
            q1 = base1 + sign1 * acos1
            nq = np.cos(q1)[:, None] * n + np.sin(q1)[:, None] * self.n_cross
            c5 = (nq * z6).sum(axis=1) / rho5
            ok5 = np.abs(c5) <= 1.0 + 1e-9
            acos5 = np.arccos(np.clip(c5, -1.0, 1.0))
            E1inv = _inverse(_screw(w[0], o[0], q1))
            wrists = []
            for sign5 in (1.0, -1.0):
                q5 = base5 + sign5 * acos5
                # q6: Rot(w6, q6) v = Rot(w5, -q5) n with v = R^T n(q1)
                v = (np.swapaxes(X[:, :3, :3], -1, -2) @ nq[:, :, None])[:, :, 0]
                m = _rotation_matrices(w[4], -q5) @ n
                q6 = _angle_about(w6, tuple(v.T), tuple(m.T))
                vp = v - np.outer(v @ w[5], w[5])
                q6 = np.where(np.sqrt((vp * vp).sum(axis=1)) < 1e-12, 0.0, q6)  # wrist singularity
                G = E1inv @ X @ _inverse(_screw(w[5], o[5], q6)) @ _inverse(_screw(w[4], o[4], q5))
                # G = e^[S2] q2 e^[S3] q3 e^[S4] q4: rotation about n by phi, and a point of axis 4
                phi = _angle_about(nf, uf, tuple((G[:, :3, :3] @ self.u).T))
                p4 = (G[:, :3, :3] @ o[3]) + G[:, :3, 3] - o[1]
                ok, dist, elbows = self.law.branches(p4 @ self.u, p4 @ self.v)  # rotations about n
                distance = np.minimum(distance, np.maximum(dist1, dist))
                wrists.append((q5, q6, phi, ok1 & ok5 & ok, elbows))
            for elbow in range(2):  # elbow up, then down; noflip, then flip for each
                for q5, q6, phi, ok, elbows in wrists:
                    r2, r3 = elbows[elbow]
                    q.append((q1, self.s[0] * r2, self.s[1] * r3, self.s[2] * (phi - r2 - r3), q5, q6))
                    reach.append(ok)
        return q, reach, distance
