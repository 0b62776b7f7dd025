"""What the dynamics reads from a robot: its inertial data, joint axes and bodies in world coordinates.

The one place where a :class:`~labkit.robot.Robot` becomes the arrays of the recursive
Newton-Euler recursion (:mod:`labkit.dynamics._rne`): per joint the axis ``s`` (unit vector,
signed by ``flip``) and a point ``p`` on it, per link its centre of mass ``c`` and inertia
tensor about it, all in world coordinates (the frame :func:`~labkit.kinematics.fk` reports
in), from :func:`~labkit.kinematics.fk_frames`. The DH convention only decides which frame
carries joint i's axis: frame i - 1 (standard) or frame i (modified).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from labkit.exceptions import RobotError, ShapeError
from labkit.kinematics import fk_frames
from labkit.robot import Convention
from labkit.validation import as_batch, as_vector, check_robot

__all__ = ["STANDARD_GRAVITY", "CHUNK", "Body", "Geometry", "body", "geometry", "default_gravity", "joint_arrays",
           "cross", "by_chunks"]

#: standard acceleration of gravity [m/s^2] (the default magnitude along the robot's -up)
STANDARD_GRAVITY = 9.81
#: a batch is evaluated in chunks of this many states, whose temporaries stay in cache (2.5x at 100k)
CHUNK = 2048


@dataclass(frozen=True)
class Body:
    """The robot's inertial data as arrays (massless links and absent motors are zeros).

    Attributes
    ----------
    mass : ndarray, shape (n,)
        Link masses [kg].
    com : ndarray, shape (n, 3)
        Centres of mass in each link's frame i [m].
    inertia : ndarray, shape (n, 3, 3)
        Inertia tensors about the centres of mass, axes of frame i [kg m^2].
    armature : ndarray, shape (n,)
        Reflected rotor inertia ``G^2 Jm`` [kg m^2 or kg].
    viscous : ndarray, shape (n,)
        Reflected viscous friction ``G^2 B`` [N m s/rad or N s/m].
    coulomb : ndarray, shape (n, 2)
        Reflected Coulomb friction ``|G| Tc`` (moving forwards, backwards) [N m or N].
    """

    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    armature: np.ndarray
    viscous: np.ndarray
    coulomb: np.ndarray


def body(robot):
    """The inertial arrays of ``robot``; a robot without any inertial data is an error.

    Parameters
    ----------
    robot : Robot

    Returns
    -------
    Body

    Raises
    ------
    RobotError
        No link carries ``mass``/``com``/``inertia`` (the dynamics of such a robot is zero).
    """
    check_robot(robot)
    if all(lk.inertial is None for lk in robot.links):
        raise RobotError(f"robot {robot.name!r} has no inertial parameters: expected mass, com and inertia on its "
                         f"[[joint]] tables (docs/robot-files.md), got none", "inertial")
    n = robot.n
    mass, com, inertia = np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3, 3))
    armature, viscous, coulomb = np.zeros(n), np.zeros(n), np.zeros((n, 2))
    for i, lk in enumerate(robot.links):
        if lk.inertial is not None:
            mass[i], com[i], inertia[i] = lk.inertial.mass, lk.inertial.com, lk.inertial.matrix
        if lk.motor is not None:
            G = lk.motor.gear_ratio
            armature[i] = G * G * lk.motor.inertia
            viscous[i] = G * G * lk.motor.viscous
            coulomb[i] = abs(G) * np.array(lk.motor.coulomb)
    return Body(mass, com, inertia, armature, viscous, coulomb)


@dataclass(frozen=True)
class Geometry:
    """Joint axes and link inertias of a batch of configurations, as spatial vectors in world coordinates.

    Spatial vectors are taken at the world origin, angular part first (Featherstone's
    Plucker coordinates): a motion ``(w, v_O)``, ``v_O`` the velocity of the body point at
    the origin; a force ``(n_O, f)``, ``n_O`` the moment about the origin.

    Attributes
    ----------
    axis : ndarray, shape (..., n, 6)
        Each joint's unit motion: ``(s, p x s)`` for a revolute joint turning about the unit
        vector ``s`` (negated for a flipped joint) through the point ``p``, ``(0, s)`` for a
        prismatic one.
    inertia : ndarray, shape (..., n, 6, 6)
        Each link's spatial inertia at the world origin [kg m^2, kg m, kg].
    com : ndarray, shape (..., n, 3)
        Each link's centre of mass [m].
    """

    axis: np.ndarray
    inertia: np.ndarray
    com: np.ndarray


def cross(a, b):
    """Cross product over the last axis of broadcastable arrays (cheaper than ``np.cross`` on small ones).

    Parameters
    ----------
    a, b : ndarray, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3)
    """
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _skew(v):
    """``[v]x`` for (..., 3) vectors: (..., 3, 3)."""
    z = np.zeros(v.shape[:-1])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([np.stack([z, -w, y], -1), np.stack([w, z, -x], -1), np.stack([-y, x, z], -1)], -2)


def geometry(robot, q, parts):
    """Spatial joint axes, spatial inertias and centres of mass of ``robot`` at ``q`` (world coordinates).

    Parameters
    ----------
    robot : Robot
    q : ndarray, shape (..., n)
        Joint values [rad, m] (checked).
    parts : Body
        The robot's inertial arrays (:func:`body`).

    Returns
    -------
    Geometry
    """
    T = fk_frames(robot, q)
    n = robot.n
    first = 0 if robot.convention is Convention.STANDARD else 1
    carrier = T[..., first:first + n, :3, :]  # the frame whose z is joint i's axis
    s = carrier[..., :, 2] * np.where(robot.flip, -1.0, 1.0)[:, None]
    revolute = robot.is_revolute[:, None]
    axis = np.concatenate([np.where(revolute, s, 0.0), np.where(revolute, cross(carrier[..., :, 3], s), s)], -1)
    R = T[..., 1:n + 1, :3, :3]
    com = np.einsum("...ij,...j->...i", R, parts.com) + T[..., 1:n + 1, :3, 3]
    C = _skew(com)
    m = parts.mass[:, None, None]
    top = np.concatenate([R @ parts.inertia @ np.swapaxes(R, -1, -2) - m * C @ C, m * C], -1)
    bottom = np.concatenate([-m * C, np.broadcast_to(m * np.eye(3), C.shape)], -1)
    return Geometry(axis, np.concatenate([top, bottom], -2), com)


def default_gravity(robot, gravity):
    """The gravity vector in world coordinates [m/s^2]: ``gravity`` checked, or 9.81 along ``-robot.up``.

    Parameters
    ----------
    robot : Robot
    gravity : array_like, shape (3,), or None

    Returns
    -------
    ndarray, shape (3,)
    """
    if gravity is None:
        return -STANDARD_GRAVITY * np.asarray(robot.up, dtype=float)
    g = as_batch(gravity, (3,), "gravity (a vector in world coordinates, m/s^2)")
    if g.ndim != 1:
        raise ShapeError(f"expected gravity with shape (3,) (one vector in world coordinates, m/s^2), got {g.shape}")
    return g


def by_chunks(func, arrays, tail):
    """``func`` over a batch in chunks of :data:`CHUNK` states (one call for a small batch).

    Parameters
    ----------
    func : callable
        ``func(*chunk)`` with arrays of shape (m, n) returns shape (m, *tail).
    arrays : sequence of ndarray, shape (..., n)
        Joint arrays of one batch shape.
    tail : tuple of int
        Trailing shape of ``func``'s result.

    Returns
    -------
    ndarray, shape (..., *tail)
    """
    lead = arrays[0].shape[:-1]
    flat = [a.reshape(-1, a.shape[-1]) for a in arrays]
    total = flat[0].shape[0]
    if total <= CHUNK:
        return func(*flat).reshape(lead + tuple(tail))
    out = np.empty((total,) + tuple(tail))
    for start in range(0, total, CHUNK):
        out[start:start + CHUNK] = func(*(a[start:start + CHUNK] for a in flat))
    return out.reshape(lead + tuple(tail))


def joint_arrays(robot, **arrays):
    """Check joint arrays ``(..., n)`` and broadcast them to one batch shape.

    Parameters
    ----------
    robot : Robot
    **arrays : array_like, shape (..., n)
        Named joint arrays (``q``, ``qd``, ``qdd``, ``tau``).

    Returns
    -------
    list of ndarray, shape (..., n)
        In the order given, broadcast against each other.

    Raises
    ------
    ShapeError
        An array does not end in ``n``, holds a non-finite value, or the batch shapes differ.
    """
    check_robot(robot)
    checked = {name: as_vector(value, robot.n, name) for name, value in arrays.items()}
    try:
        shape = np.broadcast_shapes(*(a.shape for a in checked.values()))
    except ValueError:
        shapes = ", ".join(f"{k} {a.shape}" for k, a in checked.items())
        raise ShapeError(f"expected joint arrays with one batch shape (..., {robot.n}), got {shapes}") from None
    return [np.broadcast_to(a, shape) for a in checked.values()]
