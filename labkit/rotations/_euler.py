"""Euler and roll-pitch-yaw angles of rotation matrices (batched).

Angle sets (:class:`EulerConvention`)
-------------------------------------
* ``"xyz_fixed"`` (= roll-pitch-yaw): angles ``(gamma, beta, alpha)`` about the
  fixed x, y, z axes, ``R = Rz(alpha) Ry(beta) Rx(gamma)``;
* ``"zyx"`` Euler: angles ``(alpha, beta, gamma)`` about the moving z, y', x''
  axes, the same matrix ``Rz(alpha) Ry(beta) Rx(gamma)``;
* ``"zyz"`` Euler: angles ``(alpha, beta, gamma)``, ``R = Rz(alpha) Ry(beta) Rz(gamma)``.

:func:`euler_from_matrix` returns *both* angle triples of a matrix and flags
gimbal lock (where infinitely many triples exist).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from labkit.validation import as_batch
from labkit.exceptions import OptionError
from labkit.rotations._elementary import (
    compose_fixed_frame,
    compose_moving_frame,
    rotation_x,
    rotation_y,
    rotation_z,
    wrap_angle,
)

__all__ = [
    "EulerConvention",
    "EulerAngles",
    "matrix_from_euler",
    "euler_from_matrix",
    "matrix_from_rpy",
    "rpy_from_matrix",
]


class EulerConvention(str, Enum):
    """Angle sets understood by :func:`matrix_from_euler` / :func:`euler_from_matrix`.

    ``XYZ_FIXED`` (alias ``"rpy"``): ``(gamma, beta, alpha)`` = (roll, pitch,
    yaw) about the fixed x, y, z axes, ``R = Rz(alpha) Ry(beta) Rx(gamma)``.
    ``ZYX``: Euler ``(alpha, beta, gamma)`` about moving z, y', x'',
    ``R = Rz(alpha) Ry(beta) Rx(gamma)``.
    ``ZYZ``: Euler ``(alpha, beta, gamma)``, ``R = Rz(alpha) Ry(beta) Rz(gamma)``.
    """

    XYZ_FIXED = "xyz_fixed"
    ZYX = "zyx"
    ZYZ = "zyz"


def _convention(convention):
    if isinstance(convention, EulerConvention):
        return convention
    key = str(convention).lower()
    if key == "rpy":
        return EulerConvention.XYZ_FIXED
    try:
        return EulerConvention(key)
    except ValueError:
        valid = [c.value for c in EulerConvention] + ["rpy"]
        raise OptionError(f"expected an Euler convention in {valid}, got {convention!r}") from None


_FAMILY = {
    EulerConvention.XYZ_FIXED: (
        "gimbal lock at beta = +-pi/2: R depends only on gamma - alpha (beta = +pi/2) "
        "or gamma + alpha (beta = -pi/2); the representative has alpha (yaw) = 0"
    ),
    EulerConvention.ZYX: (
        "gimbal lock at beta = +-pi/2: R depends only on gamma - alpha (beta = +pi/2) "
        "or gamma + alpha (beta = -pi/2); the representative has alpha = 0"
    ),
    EulerConvention.ZYZ: (
        "gimbal lock at beta = 0 or pi: R depends only on alpha + gamma (beta = 0) "
        "or gamma - alpha (beta = pi); the representative has alpha = 0"
    ),
}


_COLUMNS = {
    EulerConvention.XYZ_FIXED: ("gamma (x)", "beta (y)", "alpha (z)"),
    EulerConvention.ZYX: ("alpha (z)", "beta (y')", "gamma (x'')"),
    EulerConvention.ZYZ: ("alpha (z)", "beta (y')", "gamma (z'')"),
}


@dataclass(frozen=True, eq=False)
class EulerAngles:
    """Both angle triples of a rotation matrix (result of :func:`euler_from_matrix`).

    Attributes
    ----------
    solutions : ndarray, shape (..., 2, 3)
        ``solutions[..., 0, :]`` and ``solutions[..., 1, :]``, the two angle
        triples [rad] in the order of the convention (``(gamma, beta, alpha)``
        for ``xyz_fixed``; ``(alpha, beta, gamma)`` for ``zyx`` and ``zyz``),
        each angle wrapped to ``(-pi, pi]``. The first solution has
        ``beta`` in ``[-pi/2, pi/2]`` (Tait-Bryan) or ``[0, pi]`` (ZYZ).
    gimbal_lock : ndarray of bool, shape (...)
        True where the matrix is at a singularity of the angle set. There
        infinitely many triples give the matrix (see :attr:`family`); both rows
        then hold the same representative.
    convention : EulerConvention
    """

    solutions: np.ndarray
    gimbal_lock: np.ndarray
    convention: EulerConvention

    @property
    def first(self):
        """First solution, shape (..., 3) [rad]."""
        return self.solutions[..., 0, :]

    @property
    def second(self):
        """Second solution, shape (..., 3) [rad] (equal to the first at gimbal lock)."""
        return self.solutions[..., 1, :]

    @property
    def family(self):
        """Text describing the one-parameter family of solutions at gimbal lock."""
        return _FAMILY[self.convention]

    def to_dataframe(self, degrees=True):
        """Table with one row per (matrix, solution): the three angles and the lock flag.

        Parameters
        ----------
        degrees : bool
            Angles in degrees (columns ``"<angle> [deg]"``), else radians.

        Returns
        -------
        pandas.DataFrame
            Indexed by ``(matrix, solution)`` (solution 1 or 2), one column per
            angle of the convention, then ``gimbal_lock``.

        Examples
        --------
        >>> from labkit.rotations import rotation_z
        >>> e = euler_from_matrix(rotation_z(np.pi / 6), "xyz_fixed")
        >>> e.to_dataframe().round(6).values.tolist()
        [[0.0, 0.0, 30.0, False], [180.0, 180.0, -150.0, False]]
        """
        import pandas as pd

        names = _COLUMNS[self.convention]
        unit = " [deg]" if degrees else " [rad]"
        sol = np.degrees(self.solutions) if degrees else self.solutions
        sol = sol.reshape(-1, 2, 3)
        lock = np.broadcast_to(self.gimbal_lock, self.solutions.shape[:-2]).reshape(-1)
        index = pd.MultiIndex.from_product([range(len(sol)), (1, 2)], names=["matrix", "solution"])
        data = {nm + unit: sol[:, :, k].reshape(-1) for k, nm in enumerate(names)}
        data["gimbal_lock"] = np.repeat(lock, 2)
        return pd.DataFrame(data, index=index)


def matrix_from_euler(angles, convention):
    """Rotation matrix from three angles of a given convention.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Angles [rad] in the order of the convention (see :class:`EulerConvention`).
    convention : {"xyz_fixed", "rpy", "zyx", "zyz"} or EulerConvention

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Examples
    --------
    Seed 002 problem 1(b): XYZ fixed angles (gamma, beta, alpha) = (pi/4, pi/6, 0).

    >>> np.round(matrix_from_euler([np.pi / 4, np.pi / 6, 0], "xyz_fixed"), 4)
    array([[ 0.866 ,  0.3536,  0.3536],
           [ 0.    ,  0.7071, -0.7071],
           [-0.5   ,  0.6124,  0.6124]])
    """
    conv = _convention(convention)
    angles = as_batch(angles, (3,), "angles")
    if conv is EulerConvention.XYZ_FIXED:
        return compose_fixed_frame("xyz", angles)
    return compose_moving_frame(conv.value, angles)


def _residual(alpha, beta, R):
    """``(Rz(alpha) Ry(beta))^T R``: what is left for the third rotation."""
    Q = rotation_z(alpha) @ rotation_y(beta)
    return np.swapaxes(Q, -1, -2) @ R


def _pair_of_solutions(alpha, beta, gamma, lock, second_beta):
    first = np.stack([alpha, beta, gamma], axis=-1)
    second = np.stack([alpha + np.pi, second_beta, gamma + np.pi], axis=-1)
    second = np.where(lock[..., None], first, second)
    return wrap_angle(np.stack([first, second], axis=-2))


def _tait_bryan_zyx(R, tol):
    """(alpha, beta, gamma) solutions of R = Rz(alpha) Ry(beta) Rx(gamma).

    alpha and beta come from the first column ``[c_a c_b, s_a c_b, -s_b]``; gamma from
    the residual rotation ``Rx(gamma) = (Rz(alpha) Ry(beta))^T R``, which keeps the
    reconstruction accurate to rounding even next to gimbal lock.
    """
    r11, r21, r31 = R[..., 0, 0], R[..., 1, 0], R[..., 2, 0]
    cb = np.hypot(r11, r21)
    lock = cb < tol
    beta = np.where(lock, np.where(-r31 > 0, np.pi / 2, -np.pi / 2), np.arctan2(-r31, cb))
    alpha = np.where(lock, 0.0, np.arctan2(r21, r11))  # representative alpha = 0 at gimbal lock
    M = _residual(alpha, beta, R)
    gamma = np.arctan2(M[..., 2, 1], M[..., 1, 1])
    return _pair_of_solutions(alpha, beta, gamma, lock, np.pi - beta), lock


def _proper_zyz(R, tol):
    """(alpha, beta, gamma) solutions of R = Rz(alpha) Ry(beta) Rz(gamma).

    alpha and beta come from the third column ``[c_a s_b, s_a s_b, c_b]``; gamma from
    the residual rotation ``Rz(gamma) = (Rz(alpha) Ry(beta))^T R``.
    """
    r13, r23, r33 = R[..., 0, 2], R[..., 1, 2], R[..., 2, 2]
    sb = np.hypot(r13, r23)
    lock = sb < tol
    beta = np.where(lock, np.where(r33 > 0, 0.0, np.pi), np.arctan2(sb, r33))
    alpha = np.where(lock, 0.0, np.arctan2(r23, r13))
    M = _residual(alpha, beta, R)
    gamma = np.arctan2(M[..., 1, 0], M[..., 0, 0])
    return _pair_of_solutions(alpha, beta, gamma, lock, -beta), lock


def euler_from_matrix(R, convention, *, tol=1e-9):
    """Both angle triples of a rotation matrix, with a gimbal-lock flag.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices (not checked; see :func:`check_rotation` and
        :func:`nearest_rotation` for measured or rounded matrices).
    convention : {"xyz_fixed", "rpy", "zyx", "zyz"} or EulerConvention
    tol : float
        Gimbal lock is declared where ``|cos(beta)|`` (Tait-Bryan) or
        ``|sin(beta)|`` (ZYZ) is below ``tol``.

    Returns
    -------
    EulerAngles
        ``solutions`` of shape (..., 2, 3) [rad] and the ``gimbal_lock`` flag.

    Examples
    --------
    Seed 002 problem 1(b): the matrix ``Rz(30 deg)`` (rounded to 3 decimals)
    has XYZ-fixed angles (0, 0, 30) deg and (180, 180, -150) deg; the seed
    prints the second as (-180, -180, -150) deg, the same angles.

    >>> R = [[0.866, -0.5, 0], [0.5, 0.866, 0], [0, 0, 1]]
    >>> e = euler_from_matrix(R, "xyz_fixed")
    >>> np.round(np.degrees(e.solutions), 2)
    array([[   0.,    0.,   30.],
           [ 180.,  180., -150.]])
    >>> bool(e.gimbal_lock)
    False
    """
    conv = _convention(convention)
    R = as_batch(R, (3, 3), "R")
    if conv is EulerConvention.ZYZ:
        sol, lock = _proper_zyz(R, tol)
    else:
        sol, lock = _tait_bryan_zyx(R, tol)
        if conv is EulerConvention.XYZ_FIXED:
            sol = sol[..., ::-1]
    return EulerAngles(solutions=sol, gimbal_lock=lock, convention=conv)


def matrix_from_rpy(rpy):
    """Rotation from roll-pitch-yaw = XYZ fixed angles, ``Rz(yaw) Ry(pitch) Rx(roll)``.

    Parameters
    ----------
    rpy : array_like, shape (..., 3)
        Roll (about fixed x), pitch (about fixed y), yaw (about fixed z) [rad].

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Examples
    --------
    >>> R = matrix_from_rpy([np.pi / 4, np.pi / 6, 0.0])
    >>> np.round(R[0], 4)
    array([0.866 , 0.3536, 0.3536])
    """
    rpy = np.asarray(rpy, dtype=float)
    return rotation_z(rpy[..., 2]) @ rotation_y(rpy[..., 1]) @ rotation_x(rpy[..., 0])


def rpy_from_matrix(R, *, tol=1e-9):
    """One roll-pitch-yaw (XYZ fixed) triple of a rotation matrix.

    The first solution of :func:`euler_from_matrix` with ``"xyz_fixed"``:
    pitch in ``[-pi/2, pi/2]``; at gimbal lock yaw = 0.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
    tol : float
        Gimbal lock is declared where ``|cos(pitch)|`` is below ``tol``.

    Returns
    -------
    rpy : ndarray, shape (..., 3)
        (roll, pitch, yaw) [rad].

    Examples
    --------
    >>> np.round(rpy_from_matrix(matrix_from_rpy([0.1, 0.2, 0.3])), 6)
    array([0.1, 0.2, 0.3])
    """
    return euler_from_matrix(R, EulerConvention.XYZ_FIXED, tol=tol).first
