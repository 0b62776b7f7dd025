"""Statics and velocity kinematics on top of the geometric Jacobian (batched).

Conventions: a Jacobian ``J`` has shape ``(..., 6, n)`` with rows
``vx, vy, vz, wx, wy, wz`` (as returned by :func:`labkit.kinematics.jacobian`);
a wrench is ``[fx, fy, fz, nx, ny, nz]`` [N, N m]; a twist is
``[vx, vy, vz, wx, wy, wz]`` [m/s, rad/s]. Joint torques are [N m] for
revolute and [N] for prismatic joints. Functions that accept a ``part``
argument can restrict the analysis to the linear rows (a 3-DOF positioning
arm) or the angular rows.

Damped least squares
--------------------
:func:`joint_rates` solves ``J qd = v`` through the SVD ``J = U S V^T`` as
``qd = V diag(s_i / (s_i^2 + lambda_i^2)) U^T v``. The damping is switched on
only near a singularity, and only in the directions that are singular
(selective damping, after Nakamura & Hanafusa; Chiaverini):
``lambda_i^2 = 0`` while the singular value ``s_i >= epsilon`` and
``lambda_i^2 = (1 - (s_i / epsilon)^2) * max_damping^2`` below it. Away from
singularities this is the exact (pseudo-)inverse; near them the joint rates
stay bounded (``|qd| <= |v| / (2 lambda_i)`` in a damped direction) at the
price of a tracking error in that direction only: the well-conditioned
directions of ``v`` are still met exactly.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from labkit.rotations import skew
from labkit.validation import as_batch, as_number, as_option
from labkit.exceptions import OptionError, ShapeError

__all__ = ["joint_torques", "wrench_transform_matrix", "transform_wrench", "singular_values", "manipulability",
           "condition_number", "is_singular", "damping_factor", "joint_rates"]

Part = Literal["full", "linear", "angular"]
_PARTS = {"full": slice(0, 6), "linear": slice(0, 3), "angular": slice(3, 6)}


def _positive(value, name, *, zero=False):
    """A finite number > 0 (``zero``: >= 0), else :class:`OptionError` saying what came."""
    return as_number(value, name, positive=not zero, minimum=0.0 if zero else None, error=OptionError)


def _jac(J, rows=6):
    """``J`` (..., rows, n) as a float array (any number of rows for ``rows=None``), validated."""
    try:
        J = np.asarray(J, dtype=float)
    except (TypeError, ValueError):
        raise ShapeError(f"expected J as a matrix of numbers, got {J!r}") from None
    if J.ndim < 2 or rows is not None and J.shape[-2] != rows:
        raise ShapeError(f"expected J with shape (..., {rows or 'm'}, n), got {J.shape}")
    return as_batch(J, J.shape[-2:], "J")


def _select(J, part):
    return _jac(J)[..., _PARTS[as_option(part, _PARTS, "part")], :]


def joint_torques(J, wrench):
    """Joint torques/forces that balance a wrench at the end effector: ``tau = J^T F``.

    Parameters
    ----------
    J : array_like, shape (..., 6, n)
        Geometric Jacobian of the point where the wrench acts, in the frame
        the wrench is expressed in.
    wrench : array_like, shape (..., 6)
        ``[fx, fy, fz, nx, ny, nz]`` exerted by the robot on the environment
        [N, N m].

    Returns
    -------
    tau : ndarray, shape (..., n)
        Joint torques [N m] (revolute) and forces [N] (prismatic).

    Examples
    --------
    Seed 002 problem 3: the RPP arm at theta1 = 0, d2 = d3 = 1 m with
    F = [1, 2, 3, 0, 0, 0].

    >>> from labkit.robot import Robot
    >>> from labkit.kinematics import jacobian
    >>> J = jacobian(Robot.load("rpp_seed002"), [0.0, 1.0, 1.0])
    >>> joint_torques(J, [1, 2, 3, 0, 0, 0]).round(12) + 0.0
    array([2., 3., 1.])
    """
    J = _jac(J)
    F = as_batch(wrench, (6,), "wrench")
    return np.einsum("...in,...i->...n", J, F)


def wrench_transform_matrix(p, R=None):
    """6x6 matrix moving a wrench from point/frame C to point/frame B.

    ``[f_B; n_B] = [[R, 0], [[p]x R, R]] [f_C; n_C]``: the force is unchanged
    (rotated if the frames differ), the moment about B gains ``p x f``. With
    ``R = I`` this is the formula of seed 002 problem 4,
    ``[f; n_B] = [[I, 0], [[p]x, I]] [f; n_C]``.

    Parameters
    ----------
    p : array_like, shape (..., 3)
        Position of C relative to B (vector from B to C), expressed in B [m].
    R : array_like, shape (..., 3, 3), optional
        Orientation of frame C in frame B (``B_R_C``), used when the wrench is
        given in C's coordinates; default identity (both in the same frame).

    Returns
    -------
    X : ndarray, shape (..., 6, 6)

    Examples
    --------
    >>> X = wrench_transform_matrix([0.0, 0.0, 0.1])
    >>> X @ [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    array([1. , 0. , 0. , 0. , 0.1, 0. ])
    """
    S = skew(p)
    R = np.broadcast_to(np.eye(3), S.shape) if R is None else as_batch(R, (3, 3), "R")
    shape = np.broadcast_shapes(S.shape, R.shape)
    X = np.zeros(shape[:-2] + (6, 6))
    X[..., :3, :3] = R
    X[..., 3:, 3:] = R
    X[..., 3:, :3] = S @ R
    return X


def transform_wrench(wrench, p, R=None):
    """Move a wrench applied at point C to an equivalent wrench at point B.

    Parameters
    ----------
    wrench : array_like, shape (..., 6)
        ``[f; n_C]`` at C [N, N m] (in B's axes, or in C's axes if ``R`` given).
    p : array_like, shape (..., 3)
        Vector from B to C, in B's axes [m].
    R : array_like, shape (..., 3, 3), optional
        ``B_R_C`` when the wrench is given in C's axes.

    Returns
    -------
    wrench_B : ndarray, shape (..., 6)
        ``[f; n_C + p x f]`` in B's axes.

    Examples
    --------
    A 10 N force along -z applied 0.1 m along x from B gives a 1 N m moment
    about +y at B:

    >>> transform_wrench([0, 0, -10, 0, 0, 0], [0.1, 0, 0]).round(12) + 0.0
    array([  0.,   0., -10.,   0.,   1.,   0.])
    """
    w = as_batch(wrench, (6,), "wrench")
    return np.einsum("...ij,...j->...i", wrench_transform_matrix(p, R), w)


def singular_values(J, part: Part = "full"):
    """Singular values of the Jacobian (or its linear/angular rows), descending.

    Parameters
    ----------
    J : array_like, shape (..., 6, n)
        Geometric Jacobian(s).
    part : {"full", "linear", "angular"}
        All six rows, the three linear or the three angular ones.

    Returns
    -------
    s : ndarray, shape (..., min(m, n))
        With ``m`` = 6 or 3 rows.
    """
    return np.linalg.svd(_select(J, part), compute_uv=False)


def manipulability(J, part: Part = "full"):
    """Yoshikawa's manipulability measure.

    ``w = sqrt(det(J J^T))`` for a Jacobian with no more rows than columns;
    in general the product of the ``min(m, n)`` singular values (so that a
    6 x 3 Jacobian gives ``sqrt(det(J^T J))`` instead of 0). Use
    ``part="linear"`` for a positioning arm whose orientation is not
    controlled.

    Parameters
    ----------
    J : array_like, shape (..., 6, n)
        Geometric Jacobian(s) [m/rad or 1].
    part : {"full", "linear", "angular"}
        Which rows measure the volume (all, linear or angular).

    Returns
    -------
    w : ndarray, shape (...)
        Zero at a singularity [m^k for k linear rows].

    Examples
    --------
    A planar 2R arm with unit links: ``w = |sin(q2)|``.

    >>> from labkit.robot import Link, Robot
    >>> from labkit.kinematics import jacobian
    >>> arm = Robot("2r", (Link(a=1.0), Link(a=1.0)))
    >>> J = jacobian(arm, [0.3, np.pi / 6])
    >>> round(float(manipulability(J, "linear")), 6)
    0.5
    """
    return np.prod(singular_values(J, part), axis=-1)


def condition_number(J, part: Part = "full"):
    """Condition number ``s_max / s_min`` of the Jacobian (``inf`` at a singularity).

    Parameters
    ----------
    J : array_like, shape (..., 6, n)
    part : {"full", "linear", "angular"}

    Returns
    -------
    kappa : ndarray, shape (...)
        >= 1; ``inf`` where ``s_min == 0``.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> from labkit.kinematics import jacobian
    >>> J = jacobian(Robot.load("arduino_arm_3dof"), np.radians([30.0, 40.0, 90.0]))
    >>> bool(condition_number(J, "linear") < 10)
    True
    """
    s = singular_values(J, part)
    with np.errstate(divide="ignore", invalid="ignore"):
        k = s[..., 0] / s[..., -1]
    return np.where(s[..., -1] > 0, k, np.inf)


def is_singular(J, part: Part = "full", *, tol=1e-6):
    """Whether the Jacobian loses rank (``s_min <= tol * max(s_max, 1)``).

    Parameters
    ----------
    J : array_like, shape (..., 6, n)
    part : {"full", "linear", "angular"}
        Rows that must keep full rank ``min(m, n)``.
    tol : float
        Relative tolerance on the smallest singular value.

    Returns
    -------
    singular : ndarray of bool, shape (...)

    Examples
    --------
    The 3-DOF arduino arm stretched out (q3 = 0) is singular:

    >>> from labkit.robot import Robot
    >>> from labkit.kinematics import jacobian
    >>> arm = Robot.load("arduino_arm_3dof")
    >>> bool(is_singular(jacobian(arm, [0.3, 0.4, 0.0]), "linear"))
    True
    """
    tol = _positive(tol, "tol", zero=True)
    s = singular_values(J, part)
    return s[..., -1] <= tol * np.maximum(s[..., 0], 1.0)


def damping_factor(sigma_min, epsilon, max_damping):
    """Damping ``lambda`` used by :func:`joint_rates` (zero away from singularities).

    ``lambda^2 = (1 - (sigma_min / epsilon)^2) max_damping^2`` for
    ``sigma_min < epsilon``, else 0.

    Parameters
    ----------
    sigma_min : array_like, shape (...)
        Smallest singular value of the Jacobian.
    epsilon : float
        Size of the singular region (same units as ``sigma_min``).
    max_damping : float
        Damping at the singularity itself.

    Returns
    -------
    lam : ndarray, shape (...)

    Examples
    --------
    >>> damping_factor([1.0, 0.0], epsilon=0.05, max_damping=0.1)
    array([0. , 0.1])
    """
    s = as_batch(sigma_min, (), "sigma_min")
    epsilon, max_damping = _positive(epsilon, "epsilon"), _positive(max_damping, "max_damping", zero=True)
    ratio = np.clip(s / epsilon, 0.0, 1.0)
    return max_damping * np.sqrt(1.0 - ratio**2)


def joint_rates(J, twist, *, epsilon=1e-2, max_damping=5e-2):
    """Joint rates that produce a Cartesian velocity, damped near singularities.

    Solves ``J qd = twist`` in the least-squares sense (minimum norm when
    redundant) with the damped pseudo-inverse described in the module
    docstring: exact away from singularities (``s_min >= epsilon``), damped
    in the singular directions (``s_i < epsilon``) so that the rates stay
    finite while the other directions are met exactly. This is the
    one rule for rates from a twist: the Cartesian trajectories of
    :mod:`labkit.motion` solve their ``qd`` and ``qdd`` with it, on the rows
    :func:`labkit.kinematics.task_rows` gives.

    Parameters
    ----------
    J : array_like, shape (..., m, n)
        Jacobian rows matching ``twist``: the full ``(..., 6, n)`` Jacobian, or
        e.g. ``J[..., :3, :]`` for a positioning arm.
    twist : array_like, shape (..., m)
        Desired velocity [m/s, rad/s].
    epsilon : float
        Smallest singular value below which damping is applied.
    max_damping : float
        Damping at an exact singularity.

    Returns
    -------
    qd : ndarray, shape (..., n)
        Joint rates [rad/s, m/s]; always finite.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> from labkit.kinematics import jacobian
    >>> arm = Robot.load("arduino_arm_3dof")
    >>> q = np.radians([30.0, 40.0, 90.0])
    >>> Jv = jacobian(arm, q)[:3]
    >>> qd = joint_rates(Jv, [0.01, 0.0, 0.0])
    >>> np.allclose(Jv @ qd, [0.01, 0.0, 0.0])
    True
    """
    J = _jac(J, rows=None)
    v = as_batch(twist, (J.shape[-2],), "twist")
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    lam = damping_factor(s, epsilon, max_damping)  # per singular direction (zero where s_i >= epsilon); checks both
    denom = s**2 + lam**2
    with np.errstate(divide="ignore", invalid="ignore"):
        gain = np.where(denom > 0, s / denom, 0.0)
    Utv = np.einsum("...im,...i->...m", U, v)
    return np.einsum("...mn,...m->...n", Vt, gain * Utv)
