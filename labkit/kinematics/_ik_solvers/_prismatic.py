"""Closed-form IK families with prismatic axes: ``cylindrical`` (RPP) and ``cartesian`` (PPP) (private).

Both take tool positions ``(x, y, z)`` [m].

``cylindrical``
    One revolute joint (axis ``k``, either direction) and two prismatic ones:
    a lift parallel to ``k`` (anywhere in the chain) and a radial axis
    perpendicular to ``k`` after the revolute joint (it may pass beside the
    axis, at the offset ``b``). The lift takes the height; in the plane
    perpendicular to ``k`` the tool point lies ``c + q`` along the radial
    direction and ``b`` beside it, so ``c + q = +-sqrt(r^2 - b^2)`` for a
    target at distance ``r`` from the axis: branches ``front`` (``+``, the
    tool on the radial axis's positive side) and ``back`` (``-``: the arm
    turned by half a turn, the radial joint run back through the axis; rarely
    inside its limits). Targets nearer the axis than ``|b|`` are out of reach.
``cartesian``
    Three prismatic joints whose directions are linearly independent (a
    gantry; not necessarily at right angles): the tool point moves by
    ``E q``, ``E`` the matrix of the directions, so ``q = E^-1 (p - p0)``. One
    branch, ``unique``.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.kinematics._ik_solvers._family import Family, _documented
from labkit.kinematics._ik_solvers._geometry import (
    TOL, NotThisFamily, _dot, _floats, _in_chain_order, _need_parallel, _unit,
)
from labkit.kinematics._ik_solvers._scara import _up_axis


class Cylindrical(Family):
    """Closed-form position IK of a cylindrical (RPP) arm: two branches."""

    name = "cylindrical"
    kind = "position"
    joints, prismatic = 3, 2
    branches = ("front", "back")

    def __init__(self, robot, z, o, tool):
        rev = int(np.flatnonzero(robot.is_revolute)[0])
        k, u, v = _up_axis(robot, z[rev:])
        lift, radial = (int(j) for j in np.flatnonzero(~robot.is_revolute))
        if abs(_unit(z[lift]) @ k) < 1.0 - TOL:
            lift, radial = radial, lift
        _need_parallel(k, _unit(z[lift]), "one prismatic axis must be parallel to the revolute one")
        e = _unit(z[radial])
        if abs(e @ k) > TOL or radial < rev:
            raise NotThisFamily("the other prismatic axis must be perpendicular to the revolute one and after it")
        self.order = (rev, lift, radial)
        self.s_rev, self.s_lift = (1.0 if z[j] @ k > 0 else -1.0 for j in (rev, lift))
        self.k, self.u, self.v, self.O = _floats(k), _floats(u), _floats(v), _floats(o[rev])
        p0 = tool[:3, 3] - o[rev]
        f = np.cross(k, e)
        self.c, self.b, self.h0 = float(p0 @ e), float(p0 @ f), float(p0 @ k)
        self.E, self.F = (float(e @ u), float(e @ v)), (float(f @ u), float(f @ v))

    @_documented
    def solve(self, t):
        d = tuple(t[i] - self.O[i] for i in range(3))
        x, y = _dot(self.u, d), _dot(self.v, d)
        r2 = x * x + y * y
        b = self.b
        ok = r2 >= b * b
        rho = np.sqrt(np.maximum(r2 - b * b, 0.0))
        distance = np.maximum(abs(b) - np.sqrt(r2), 0.0)
        lift = self.s_lift * (_dot(self.k, d) - self.h0)
        (eu, ev), (fu, fv) = self.E, self.F
        q = []
        for sign in (1.0, -1.0):
            along = sign * rho  # c + q: the tool point's distance along the radial direction
            turn = np.arctan2(y, x) - np.arctan2(along * ev + b * fv, along * eu + b * fu)
            q.append(_in_chain_order(self.order, (self.s_rev * turn, lift, along - self.c)))
        return q, [ok, ok], distance


class Cartesian(Family):
    """Closed-form position IK of a Cartesian (PPP) gantry: one branch."""

    name = "cartesian"
    kind = "position"
    joints, prismatic = 3, 3
    branches = ("unique",)

    def __init__(self, robot, z, o, tool):
        E = np.column_stack([_unit(a) for a in z])
        if abs(np.linalg.det(E)) < math.sqrt(TOL):
            raise NotThisFamily("the three prismatic axes must be linearly independent")
        self.inverse = tuple(_floats(row) for row in np.linalg.inv(E))
        self.p0 = _floats(tool[:3, 3])

    @_documented
    def solve(self, t):
        d = tuple(t[i] - self.p0[i] for i in range(3))
        ok = np.full(np.shape(t[0]), True)
        return [tuple(_dot(row, d) for row in self.inverse)], [ok], np.zeros(np.shape(t[0]))
