"""A numba-jitted standard-DH chain: the compiled reference of ``bench_kinematics.py``.

Benchmark-only (numba is in the ``bench`` extra, never imported by labkit).
Revolute joints, standard DH, identity base and tool (the PUMA 560 file);
one configuration per loop iteration, the rotation and origin kept in
registers, each joint's sine and cosine computed once (LLVM fuses them into
one ``sincos``), the Jacobian from the same walk.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=False)
def fk(q, a, ca, sa, d, theta, out):
    """Poses (N, 4, 4) of configurations q (N, n) [rad, m]: rotation and origin kept in registers."""
    n = q.shape[1]
    for k in range(q.shape[0]):
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
        p0 = p1 = p2 = 0.0
        for i in range(n):
            ang = q[k, i] + theta[i]
            ct, st = math.cos(ang), math.sin(ang)
            n00, n10, n20 = r00 * ct + r01 * st, r10 * ct + r11 * st, r20 * ct + r21 * st
            n01, n11, n21 = r01 * ct - r00 * st, r11 * ct - r10 * st, r21 * ct - r20 * st
            p0 += d[i] * r02 + a[i] * n00
            p1 += d[i] * r12 + a[i] * n10
            p2 += d[i] * r22 + a[i] * n20
            r00, r10, r20 = n00, n10, n20
            r01, r02 = ca[i] * n01 + sa[i] * r02, ca[i] * r02 - sa[i] * n01
            r11, r12 = ca[i] * n11 + sa[i] * r12, ca[i] * r12 - sa[i] * n11
            r21, r22 = ca[i] * n21 + sa[i] * r22, ca[i] * r22 - sa[i] * n21
        T = out[k]
        T[0, 0], T[0, 1], T[0, 2], T[0, 3] = r00, r01, r02, p0
        T[1, 0], T[1, 1], T[1, 2], T[1, 3] = r10, r11, r12, p1
        T[2, 0], T[2, 1], T[2, 2], T[2, 3] = r20, r21, r22, p2
        T[3, 0], T[3, 1], T[3, 2], T[3, 3] = 0.0, 0.0, 0.0, 1.0
    return out


@njit(cache=False)
def jacobian(q, a, ca, sa, d, theta, out):
    """Geometric Jacobians (N, 6, n) of configurations q (N, n) [m/rad, 1]."""
    n = q.shape[1]
    zo = np.empty((n, 6))  # axis z_i and origin o_i of each joint
    for k in range(q.shape[0]):
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
        p0 = p1 = p2 = 0.0
        for i in range(n):
            zo[i, 0], zo[i, 1], zo[i, 2], zo[i, 3], zo[i, 4], zo[i, 5] = r02, r12, r22, p0, p1, p2
            ang = q[k, i] + theta[i]
            ct, st = math.cos(ang), math.sin(ang)
            n00, n10, n20 = r00 * ct + r01 * st, r10 * ct + r11 * st, r20 * ct + r21 * st
            n01, n11, n21 = r01 * ct - r00 * st, r11 * ct - r10 * st, r21 * ct - r20 * st
            p0 += d[i] * r02 + a[i] * n00
            p1 += d[i] * r12 + a[i] * n10
            p2 += d[i] * r22 + a[i] * n20
            r00, r10, r20 = n00, n10, n20
            r01, r02 = ca[i] * n01 + sa[i] * r02, ca[i] * r02 - sa[i] * n01
            r11, r12 = ca[i] * n11 + sa[i] * r12, ca[i] * r12 - sa[i] * n11
            r21, r22 = ca[i] * n21 + sa[i] * r22, ca[i] * r22 - sa[i] * n21
        J = out[k]
        for i in range(n):
            z0, z1, z2 = zo[i, 0], zo[i, 1], zo[i, 2]
            e0, e1, e2 = p0 - zo[i, 3], p1 - zo[i, 4], p2 - zo[i, 5]
            J[0, i] = z1 * e2 - z2 * e1
            J[1, i] = z2 * e0 - z0 * e2
            J[2, i] = z0 * e1 - z1 * e0
            J[3, i], J[4, i], J[5, i] = z0, z1, z2
    return out


def constants(robot):
    """The DH arrays of a standard-DH revolute robot with identity base and tool."""
    if robot.convention.value != "standard" or not all(robot.is_revolute):
        raise ValueError("the numba reference chain handles standard DH with revolute joints only")
    if not (np.array_equal(robot.base, np.eye(4)) and np.array_equal(robot.tool, np.eye(4))):
        raise ValueError("the numba reference chain assumes identity base and tool")
    return (np.array(robot.a, float), np.cos(robot.alpha), np.sin(robot.alpha),
            np.array(robot.d, float), np.array(robot.theta, float))
