"""Inverse dynamics by the recursive Newton-Euler algorithm, and what is built from it.

One recursion, written once (:func:`newton_euler`), in spatial vectors at the world origin
(:class:`~labkit.dynamics._model.Geometry`): there each joint's motion axis and each link's
spatial inertia are plain arrays, so the outward pass (velocities and accelerations, the base
accelerating at ``-gravity``) and the inward pass (forces) are running sums over the joints.
The mass matrix comes from the composite rigid bodies (the same spatial inertias summed from
the tip), the Coriolis matrix from the recursion's bilinear form in the velocity
(polarization), the gravity torques from the recursion at rest. Batched over leading
dimensions like :func:`~labkit.kinematics.fk`.
"""

from __future__ import annotations

import numpy as np

from labkit.dynamics._model import body, by_chunks, cross, default_gravity, geometry, joint_arrays

__all__ = ["inverse_dynamics", "mass_matrix", "coriolis_matrix", "gravity_torques", "friction_torques",
           "kinetic_energy", "potential_energy"]


def _motion_cross(v, m):
    """Spatial cross product of motions ``v x m`` (Featherstone's ``crm(v) m``), (..., 6)."""
    w, vo = v[..., :3], v[..., 3:]
    return np.concatenate([cross(w, m[..., :3]), cross(vo, m[..., :3]) + cross(w, m[..., 3:])], -1)


def _force_cross(v, f):
    """Spatial cross product of a motion and a force ``v x* f`` (``crf(v) f``), (..., 6)."""
    w, vo = v[..., :3], v[..., 3:]
    return np.concatenate([cross(w, f[..., :3]) + cross(vo, f[..., 3:]), cross(w, f[..., 3:])], -1)


def _apply(I, v):
    """``I @ v`` for (..., 6, 6) and (..., 6)."""
    return np.einsum("...ij,...j->...i", I, v)


def newton_euler(axis, inertia, qd, qdd, base_acceleration):
    """Joint forces of the rigid links (no motor, no friction) by the Newton-Euler recursion.

    Parameters
    ----------
    axis : ndarray, shape (..., n, 6)
        Spatial joint axes at the world origin (:class:`~labkit.dynamics._model.Geometry`).
    inertia : ndarray, shape (..., n, 6, 6)
        Spatial link inertias at the world origin.
    qd, qdd : ndarray, shape (..., n)
        Joint velocities [rad/s, m/s] and accelerations [rad/s^2, m/s^2], broadcastable
        against the batch shape of ``axis``.
    base_acceleration : ndarray, shape (..., 3)
        The base's linear acceleration in world coordinates (``-gravity``) [m/s^2].

    Returns
    -------
    ndarray, shape (..., n)
        Joint torques [N m] and forces [N].
    """
    joint_velocity = axis * qd[..., None]
    v = np.cumsum(joint_velocity, axis=-2)  # link i's spatial velocity: the joints' motions up to i
    a0 = np.concatenate([np.zeros_like(base_acceleration), base_acceleration], -1)[..., None, :]
    a = a0 + np.cumsum(axis * qdd[..., None] + _motion_cross(v, joint_velocity), axis=-2)
    f = _apply(inertia, a) + _force_cross(v, _apply(inertia, v))  # net force on each link
    carried = np.flip(np.cumsum(np.flip(f, -2), axis=-2), -2)  # joint i carries links i..n
    return np.einsum("...i,...i->...", axis, carried)


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
    gravity : array_like, shape (3,), optional
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
    n = robot.n
    return by_chunks(lambda q, qd, qdd: inverse(parts, geometry(robot, q, parts), qd, qdd, g, friction),
                     (q, qd, qdd), (n,))


def inverse(parts, geo, qd, qdd, gravity, friction):
    """:func:`inverse_dynamics` on the robot's arrays (shared with the forward dynamics).

    Parameters
    ----------
    parts : Body
        The robot's inertial arrays.
    geo : Geometry
        Its spatial axes and inertias at ``q``, batch shape (...).
    qd, qdd : ndarray, shape (..., n)
        Joint velocities and accelerations [rad/s, rad/s^2, m/s, m/s^2].
    gravity : ndarray, shape (3,)
        Gravity in world coordinates [m/s^2].
    friction : bool
        Add the motors' friction.

    Returns
    -------
    ndarray, shape (..., n)
        Joint torques [N m] and forces [N].
    """
    tau = newton_euler(geo.axis, geo.inertia, qd, qdd, -gravity) + parts.armature * qdd
    return tau + _friction(parts, qd) if friction else tau


def gravity_torques(robot, q, *, gravity=None):
    """Joint torques that hold the arm still against gravity, ``g(q)``.

    Parameters
    ----------
    robot : Robot
        With inertial parameters.
    q : array_like, shape (..., n)
        Joint values [rad, m].
    gravity : array_like, shape (3,), optional
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
    zero, g = np.zeros(robot.n), default_gravity(robot, gravity)

    def held(q):
        geo = geometry(robot, q, parts)
        return newton_euler(geo.axis, geo.inertia, zero, zero, -g)

    return by_chunks(held, (q,), (robot.n,))


def mass_matrix(robot, q):
    """The joint-space mass (inertia) matrix ``M(q)``, motors' reflected rotor inertia included.

    By the composite rigid bodies: ``M[i, j] = S_i . (I_j + ... + I_n) S_j`` for ``i <= j``,
    with the spatial joint axes ``S`` and link inertias ``I`` of the Newton-Euler recursion.

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
    return by_chunks(lambda q: composite_mass(parts, geometry(robot, q, parts)), (q,), (robot.n, robot.n))


def composite_mass(parts, geo):
    """:func:`mass_matrix` on the robot's arrays (shared with the forward dynamics).

    Parameters
    ----------
    parts : Body
        The robot's inertial arrays.
    geo : Geometry
        Its spatial axes and inertias at ``q``, batch shape (...).

    Returns
    -------
    ndarray, shape (..., n, n)
        The mass matrix, rotor inertia on the diagonal.
    """
    composite = np.flip(np.cumsum(np.flip(geo.inertia, -3), axis=-3), -3)  # links j..n as one body
    A = np.einsum("...ik,...jkl,...jl->...ij", geo.axis, composite, geo.axis)  # S_i . Ic_j S_j
    n = parts.mass.size
    M = np.where(np.triu(np.ones((n, n), dtype=bool)), A, np.swapaxes(A, -1, -2))
    return M + np.diag(parts.armature)


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

    def christoffel(q, qd):
        scale = np.maximum(np.abs(qd).max(axis=-1, keepdims=True), 1.0)[..., None]  # (m, 1, 1)
        step = scale * np.eye(n)
        velocities = np.concatenate([qd[..., None, :] + step, qd[..., None, :] - step], axis=-2)  # (m, 2n, n)
        geo = geometry(robot, q, parts)
        h = newton_euler(geo.axis[..., None, :, :], geo.inertia[..., None, :, :, :], velocities, np.zeros(n),
                         np.zeros(3))
        return np.swapaxes((h[..., :n, :] - h[..., n:, :]) / (4.0 * scale), -1, -2)  # column j: C[:, j]

    return by_chunks(christoffel, (q, qd), (n, n))


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
    gravity : array_like, shape (3,), optional
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
    return -np.einsum("i,...i->...", parts.mass, np.einsum("...ij,...j->...i", geo.com, g))
