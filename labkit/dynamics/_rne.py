"""Inverse dynamics by the recursive Newton-Euler algorithm, and what is built from it.

One recursion, written once (:func:`newton_euler`), in world coordinates: outwards it carries
each link's angular velocity and acceleration and the acceleration of a point on the next
joint's axis, with the base accelerating at ``-gravity``; inwards the force and moment each
link receives from the one before. The mass matrix is its columns at unit accelerations (no
velocity, no gravity), the Coriolis matrix its bilinear form in the velocity (polarization),
the gravity torques its value at rest. Batched over leading dimensions like
:func:`~labkit.kinematics.fk`.
"""

from __future__ import annotations

import numpy as np

from labkit.dynamics._model import body, default_gravity, geometry, joint_arrays

__all__ = ["inverse_dynamics", "mass_matrix", "coriolis_matrix", "gravity_torques", "friction_torques",
           "kinetic_energy", "potential_energy"]


def _cross(a, b):
    """Cross product over the last axis of broadcastable (..., 3) arrays."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _dot(a, b):
    return np.einsum("...i,...i->...", a, b)


def _apply(I, v):
    """``I @ v`` for (..., 3, 3) and (..., 3)."""
    return np.einsum("...ij,...j->...i", I, v)


def newton_euler(geo, qd, qdd, base_acceleration):
    """Joint forces of the rigid links (no motor, no friction) by the Newton-Euler recursion.

    Parameters
    ----------
    geo : Geometry
        Axes, axis points, centres of mass and inertias, shape (..., n, ...) (:func:`geometry`).
    qd, qdd : ndarray, shape (..., n)
        Joint velocities [rad/s, m/s] and accelerations [rad/s^2, m/s^2], broadcastable
        against ``geo``'s batch shape.
    base_acceleration : ndarray, shape (..., 3)
        The base's acceleration in world coordinates (``-gravity``) [m/s^2].

    Returns
    -------
    ndarray, shape (..., n)
        Joint torques [N m] and forces [N].
    """
    n = len(geo.revolute)
    lead = np.broadcast_shapes(geo.axis.shape[:-2], qd.shape[:-1], qdd.shape[:-1], base_acceleration.shape[:-1])
    zero = np.zeros(lead + (3,))
    w, dw, acc, p_prev = zero, zero, zero + base_acceleration, None
    force, moment = [None] * n, [None] * n
    for i in range(n):
        s, p = geo.axis[..., i, :], geo.point[..., i, :]
        if p_prev is not None:  # the point on joint i's axis, moving with link i - 1
            r = p - p_prev
            acc = acc + _cross(dw, r) + _cross(w, _cross(w, r))
        v_joint = s * qd[..., i, None]
        a_joint = s * qdd[..., i, None]
        if geo.revolute[i]:
            dw = dw + a_joint + _cross(w, v_joint)
            w = w + v_joint
        else:
            acc = acc + a_joint + 2.0 * _cross(w, v_joint)
        rc = geo.com[..., i, :] - p
        a_com = acc + _cross(dw, rc) + _cross(w, _cross(w, rc))
        I = geo.inertia[..., i, :, :]
        force[i] = geo.mass[i] * a_com
        moment[i] = _apply(I, dw) + _cross(w, _apply(I, w)) + _cross(rc, force[i])  # about p
        p_prev = p
    tau = np.empty(lead + (n,))
    f, m = zero, zero  # from link i + 1, moment about its axis point
    for i in range(n - 1, -1, -1):
        p = geo.point[..., i, :]
        if i < n - 1:
            m = m + _cross(geo.point[..., i + 1, :] - p, f)
        f = f + force[i]
        m = m + moment[i]
        tau[..., i] = _dot(m if geo.revolute[i] else f, geo.axis[..., i, :])
    return tau


def _one_more_axis(geo):
    """``geo`` with a batch axis before the joint axis, to broadcast against several joint arrays per state."""
    return type(geo)(geo.axis[..., None, :, :], geo.point[..., None, :, :], geo.com[..., None, :, :],
                     geo.inertia[..., None, :, :, :], geo.revolute, geo.mass)


def _friction(parts, qd):
    """Viscous plus Coulomb friction torques opposing the motion, reflected through the gears."""
    coulomb = np.where(qd > 0, parts.coulomb[:, 0], np.where(qd < 0, parts.coulomb[:, 1], 0.0))
    return parts.viscous * qd + coulomb


def inverse_dynamics(robot, q, qd, qdd, *, gravity=None, friction=True):
    """Joint torques that give accelerations ``qdd`` at ``q, qd`` (recursive Newton-Euler).

    ``tau = M(q) qdd + C(q, qd) qd + g(q) + friction(qd)``, with the motors' reflected rotor
    inertia in ``M`` (roboticstoolbox's ``rne``).

    Parameters
    ----------
    robot : Robot
        With inertial parameters (robot-file keys ``mass``, ``com``, ``inertia``, ``motor``).
    q : array_like, shape (..., n)
        Joint values [rad, m].
    qd : array_like, shape (..., n)
        Joint velocities [rad/s, m/s].
    qdd : array_like, shape (..., n)
        Joint accelerations [rad/s^2, m/s^2].
    gravity : array_like, shape (3,) or (..., 3), optional
        Gravity in world coordinates [m/s^2]; default 9.81 along ``-robot.up``.
    friction : bool
        Add the motors' viscous and Coulomb friction.

    Returns
    -------
    tau : ndarray, shape (..., n)
        Joint torques [N m] and forces [N].

    Raises
    ------
    ShapeError
        Joint arrays not ending in ``n``, non-finite, or of different batch shapes.
    RobotError
        The robot carries no inertial parameters.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> puma = Robot.load("puma560")
    >>> np.round(inverse_dynamics(puma, np.zeros(6), np.zeros(6), np.zeros(6)), 3) + 0.0
    array([ 0.   , 37.484,  0.249,  0.   ,  0.   ,  0.   ])
    """
    parts = body(robot)
    q, qd, qdd = joint_arrays(robot, q=q, qd=qd, qdd=qdd)
    g = default_gravity(robot, gravity)
    tau = newton_euler(geometry(robot, q, parts), qd, qdd, -g) + parts.armature * qdd
    return tau + _friction(parts, qd) if friction else tau


def gravity_torques(robot, q, *, gravity=None):
    """Joint torques that hold the arm still against gravity, ``g(q)``.

    Parameters
    ----------
    robot : Robot
        With inertial parameters.
    q : array_like, shape (..., n)
        Joint values [rad, m].
    gravity : array_like, shape (3,) or (..., 3), optional
        Gravity in world coordinates [m/s^2]; default 9.81 along ``-robot.up``.

    Returns
    -------
    ndarray, shape (..., n)
        Joint torques [N m] and forces [N].

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> [round(float(t), 2) for t in gravity_torques(Robot.load("puma560"), [0, 0.5, 0, 0, 0, 0])[1:3]]
    [28.2, -3.99]
    """
    parts = body(robot)
    (q,) = joint_arrays(robot, q=q)
    zero = np.zeros(robot.n)
    return newton_euler(geometry(robot, q, parts), zero, zero, -default_gravity(robot, gravity))


def mass_matrix(robot, q):
    """The joint-space mass (inertia) matrix ``M(q)``, motors' reflected rotor inertia included.

    Column j is the inverse dynamics at unit acceleration of joint j, without velocity and
    gravity.

    Parameters
    ----------
    robot : Robot
        With inertial parameters.
    q : array_like, shape (..., n)
        Joint values [rad, m].

    Returns
    -------
    M : ndarray, shape (..., n, n)
        Symmetric, positive definite where every joint moves some mass [kg m^2, kg m, kg].

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> M = mass_matrix(Robot.load("puma560"), np.zeros(6))
    >>> bool(np.allclose(M, M.T)), round(float(M[0, 0]), 3)
    (True, 3.961)
    """
    parts = body(robot)
    (q,) = joint_arrays(robot, q=q)
    unit = np.eye(robot.n)
    columns = newton_euler(_one_more_axis(geometry(robot, q, parts)), np.zeros(robot.n), unit, np.zeros(3))  # (..., j, i) = M[i, j]
    M = np.swapaxes(columns, -1, -2) + np.diag(parts.armature)
    return 0.5 * (M + np.swapaxes(M, -1, -2))


def coriolis_matrix(robot, q, qd):
    """The Coriolis and centripetal matrix ``C(q, qd)`` (Christoffel symbols of ``M``).

    ``C @ qd`` is the velocity product of :func:`inverse_dynamics` and ``dM/dt - 2 C`` is
    skew-symmetric. Column j is the Newton-Euler velocity term's bilinear form in ``qd`` and
    the unit velocity of joint j (by polarization: two velocity-only recursions).

    Parameters
    ----------
    robot : Robot
        With inertial parameters.
    q : array_like, shape (..., n)
        Joint values [rad, m].
    qd : array_like, shape (..., n)
        Joint velocities [rad/s, m/s].

    Returns
    -------
    C : ndarray, shape (..., n, n)
        [kg m^2/s and the like], friction excluded.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> puma, q, qd = Robot.load("puma560"), np.zeros(6), np.full(6, 0.5)
    >>> C = coriolis_matrix(puma, q, qd)
    >>> h = inverse_dynamics(puma, q, qd, np.zeros(6), gravity=[0, 0, 0], friction=False)
    >>> bool(np.allclose(C @ qd, h))
    True
    """
    parts = body(robot)
    q, qd = joint_arrays(robot, q=q, qd=qd)
    n = robot.n
    scale = np.maximum(np.abs(qd).max(axis=-1, keepdims=True), 1.0)[..., None]  # (..., 1, 1)
    step = scale * np.eye(n)
    velocities = np.concatenate([qd[..., None, :] + step, qd[..., None, :] - step], axis=-2)  # (..., 2n, n)
    h = newton_euler(_one_more_axis(geometry(robot, q, parts)), velocities, np.zeros(n), np.zeros(3))
    columns = (h[..., :n, :] - h[..., n:, :]) / (4.0 * scale)  # (..., j, i) = C[i, j]
    return np.swapaxes(columns, -1, -2)


def friction_torques(robot, qd):
    """The motors' friction at the joints: ``G^2 B qd + |G| Tc`` (signed as the torque to overcome it).

    Parameters
    ----------
    robot : Robot
    qd : array_like, shape (..., n)
        Joint velocities [rad/s, m/s].

    Returns
    -------
    ndarray, shape (..., n)
        Torques [N m] and forces [N] the drives supply against friction (0 at rest).

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> np.round(friction_torques(Robot.load("puma560"), [1, 0, 0, 0, 0, -1]), 3)
    array([30.533,  0.   ,  0.   ,  0.   ,  0.   , -1.021])
    """
    (qd,) = joint_arrays(robot, qd=qd)
    return _friction(body(robot), qd)


def kinetic_energy(robot, q, qd):
    """Kinetic energy ``qd^T M(q) qd / 2`` (rotors' reflected inertia included).

    Parameters
    ----------
    robot : Robot
        With inertial parameters.
    q, qd : array_like, shape (..., n)
        Joint values [rad, m] and velocities [rad/s, m/s].

    Returns
    -------
    ndarray, shape (...)
        [J].

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> round(float(kinetic_energy(Robot.load("puma560"), np.zeros(6), [1, 0, 0, 0, 0, 0])), 3)
    1.981
    """
    q, qd = joint_arrays(robot, q=q, qd=qd)
    return 0.5 * np.einsum("...i,...ij,...j->...", qd, mass_matrix(robot, q), qd)


def potential_energy(robot, q, *, gravity=None):
    """Potential energy of the links in gravity, ``-sum m_i gravity . c_i`` (zero at the world origin).

    Parameters
    ----------
    robot : Robot
        With inertial parameters.
    q : array_like, shape (..., n)
        Joint values [rad, m].
    gravity : array_like, shape (3,) or (..., 3), optional
        Gravity in world coordinates [m/s^2]; default 9.81 along ``-robot.up``.

    Returns
    -------
    ndarray, shape (...)
        [J].

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> round(float(potential_energy(Robot.load("puma560"), np.zeros(6))), 2)
    164.35
    """
    parts = body(robot)
    (q,) = joint_arrays(robot, q=q)
    geo = geometry(robot, q, parts)
    g = default_gravity(robot, gravity)
    return -np.einsum("i,...i->...", parts.mass, _dot(geo.com, g[..., None, :]))
