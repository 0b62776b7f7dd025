"""Closed-form IK family ``cartesian_yaw``: a gantry with a wrist turn (PPPR, PPRP, PRPP, RPPP) (private).

Three prismatic joints and one revolute joint anywhere in the chain, either
DH convention, any signs. The prismatic joints never turn the tool, so it
turns only about the revolute axis ``k`` (on the side of the robot's
``up``, :func:`~labkit.kinematics._ik_solvers._scara._up_axis`): the targets are
``(x, y, z, yaw)`` [m, rad] with the SCARA's yaw
(:class:`~labkit.kinematics._ik_solvers._scara._YawTarget`: the turn about
``k`` of the tool ``x`` axis, or ``y`` where ``x`` lies along ``k``).

The yaw gives the revolute joint, ``theta = s (yaw - yaw0)`` (``s`` the sign
of its axis along ``k``). Then the tool point is affine in the prismatic
values: with ``R = Rot(k, s theta)``, ``O`` a point on the revolute axis and
``p0`` the tool point at ``q = 0``,

    ``p = O + R (p0 - O) + sum_before e_i q_i + R sum_after e_i q_i``

(``e_i`` the prismatic directions at ``q = 0``, before or after the revolute
joint in the chain), a 3 x 3 linear system ``E(theta) q = p - O - R (p0 - O)``.
Its determinant is ``alpha + beta cos(theta) + gamma sin(theta)`` (only the
directions after the revolute joint turn, and about one axis): the family fits
when ``|alpha| > sqrt(beta^2 + gamma^2)``, i.e. the system is regular at every
turn (always when the revolute joint is first or last, or its axis is
parallel to the prismatic directions it turns). One branch, ``unique``.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.kinematics._ik_solvers._family import Family, _documented
from labkit.kinematics._ik_solvers._geometry import (
    NotThisFamily, _floats, _in_chain_order, _rotation_matrices, _unit,
)
from labkit.kinematics._ik_solvers._scara import _YawTarget, _up_axis


class CartesianYaw(_YawTarget, Family):
    """Closed-form IK of three prismatic joints and a wrist turn (targets x y z yaw): one branch."""

    name = "cartesian_yaw"
    kind = "position_yaw"
    joints, prismatic = 4, 3
    branches = ("unique",)

    def __init__(self, robot, z, o, tool):
        self.rev = rev = int(np.flatnonzero(robot.is_revolute)[0])
        self.slides = tuple(int(j) for j in np.flatnonzero(~robot.is_revolute))
        k, u, v = _up_axis(robot, z[rev:])
        self.k, self.u, self.v, self.O = _floats(k), _floats(u), _floats(v), o[rev].copy()
        self.s = 1.0 if z[rev] @ k > 0 else -1.0
        self.E0 = np.column_stack([_unit(z[j]) for j in self.slides])
        self.after = np.array([j > rev for j in self.slides])
        self.arm0 = tool[:3, 3] - self.O  # the tool point from the revolute axis at q = 0
        d0, d1, d2 = (np.linalg.det(self._directions(np.array([a]))[0]) for a in (0.0, math.pi, 0.5 * math.pi))
        alpha, beta, gamma = 0.5 * (d0 + d1), 0.5 * (d0 - d1), d2 - 0.5 * (d0 + d1)
        if abs(alpha) - math.hypot(beta, gamma) < 1e-6 * max(1.0, abs(alpha)):
            raise NotThisFamily("the three prismatic axes must stay linearly independent at every turn of the "
                                "revolute joint")
        self.yaw_reference(tool)

    def _directions(self, turn):
        """The prismatic directions (N, 3, 3) (columns, in the chain's order) at turns (N,) about ``k`` [rad]."""
        R = _rotation_matrices(self.k, turn)
        return np.where(self.after, R @ self.E0, self.E0)

    @_documented
    def solve(self, t):
        t = np.array(t, dtype=float).reshape(4, -1)
        turn = t[3] - self.yaw0  # the tool's turn about k, the revolute joint's in the chain's sense times s
        R = _rotation_matrices(self.k, turn)
        rhs = t[:3].T - self.O - R @ self.arm0
        slide = np.linalg.solve(self._directions(turn), rhs[..., None])[..., 0]
        q = _in_chain_order((self.rev, *self.slides), (self.s * turn, *slide.T))
        return [q], [np.full(turn.shape, True)], np.zeros(turn.shape)
