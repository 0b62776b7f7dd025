"""Euler and roll-pitch-yaw angles of rotation matrices (batched): all 24 conventions.

Angle sets (:class:`EulerConvention`)
-------------------------------------
Every sequence of three axes with no axis repeated twice in a row (12:
six Tait-Bryan ``xyz, xzy, yxz, yzx, zxy, zyx`` and six proper Euler
``xyx, xzx, yxy, yzy, zxz, zyz``), read two ways. The names are exactly
those of ``scipy.spatial.transform.Rotation.from_euler`` / ``as_euler``:
**upper case = intrinsic (moving axes), lower case = extrinsic (fixed axes)**.

* **intrinsic** (moving axes): ``"XYZ"``... or ``"xyz_moving"``...: angles
  ``(alpha, beta, gamma)`` about the moving axes, ``R = R_1(alpha) R_2(beta)
  R_3(gamma)`` (:func:`~labkit.rotations.compose_moving_frame`);
* **extrinsic** (fixed axes): ``"xyz"``... or ``"xyz_fixed"``...: angles
  ``(gamma, beta, alpha)`` about the fixed axes in the order applied,
  ``R = R_3(alpha) R_2(beta) R_1(gamma)``
  (:func:`~labkit.rotations.compose_fixed_frame`). Extrinsic ``abc`` is intrinsic
  ``CBA`` with the angles reversed.

So ``"zyx"`` is the *extrinsic* (fixed-axis) set, as in scipy; the intrinsic
ZYX (yaw-pitch-roll about moving axes) is ``"ZYX"`` = ``"zyx_moving"``, and the
intrinsic ZYZ Euler angles are ``"ZYZ"`` = ``"zyz_moving"``. The one other name
is ``"rpy"`` = ``"xyz"`` = ``"xyz_fixed"`` (roll, pitch, yaw about the fixed x,
y, z axes). Any other name raises :class:`~labkit.exceptions.OptionError`
listing the valid ones.

:func:`euler_from_matrix` returns *both* angle triples of a matrix and flags
gimbal lock (where infinitely many triples exist), from one algorithm for all
conventions: the middle angle and the first one come from column ``k`` (Tait-Bryan)
or ``i`` (proper) of ``R``, the third from the residual rotation
``(R_1(alpha) R_2(beta))^T R``, which keeps the reconstruction accurate to
rounding even next to gimbal lock. The first solution is scipy's ``as_euler``
(same ranges; at gimbal lock the same representative, third angle of the
triple = 0). The two differ only just next to gimbal lock: scipy declares lock
when the middle angle is within 1e-7 rad of it and then returns a triple that
rebuilds ``R`` only to about that distance, while labkit declares it where
``|cos(beta)|`` (Tait-Bryan) or ``|sin(beta)|`` (proper) is below ``tol``
(1e-9) and returns the exact pair in between.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from labkit.validation import as_batch, as_number
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

_SEQUENCES = ("xyz", "xzy", "yxz", "yzx", "zxy", "zyx", "xyx", "xzx", "yxy", "yzy", "zxz", "zyz")


class EulerConvention(str, Enum):
    """The 24 angle sets of :func:`matrix_from_euler` / :func:`euler_from_matrix`.

    Member ``ABC`` (value ``"ABC"``, alias ``ABC_MOVING``) is the intrinsic set about
    moving axes a, b', c'': angles ``(alpha, beta, gamma)``, ``R = R_a(alpha) R_b(beta)
    R_c(gamma)``. Member ``ABC_FIXED`` (value ``"abc_fixed"``) is the extrinsic set about
    fixed axes a, b, c: angles ``(gamma, beta, alpha)`` in the order applied,
    ``R = R_c(alpha) R_b(beta) R_a(gamma)``. ``XYZ_FIXED`` is roll-pitch-yaw.
    :attr:`scipy_name` gives the name ``scipy.spatial.transform.Rotation`` uses.

    Every accepted name looks up its member, following scipy (upper case =
    intrinsic, lower case = extrinsic)::

        EulerConvention("ZYX") is EulerConvention("zyx_moving") is EulerConvention.ZYX
        EulerConvention("zyx") is EulerConvention("zyx_fixed") is EulerConvention.ZYX_FIXED
        EulerConvention("rpy") is EulerConvention.XYZ_FIXED

    Any other name raises :class:`~labkit.exceptions.OptionError` listing the valid ones.
    """

    XYZ = "XYZ"
    XZY = "XZY"
    YXZ = "YXZ"
    YZX = "YZX"
    ZXY = "ZXY"
    ZYX = "ZYX"
    XYX = "XYX"
    XZX = "XZX"
    YXY = "YXY"
    YZY = "YZY"
    ZXZ = "ZXZ"
    ZYZ = "ZYZ"
    XYZ_FIXED = "xyz_fixed"
    XZY_FIXED = "xzy_fixed"
    YXZ_FIXED = "yxz_fixed"
    YZX_FIXED = "yzx_fixed"
    ZXY_FIXED = "zxy_fixed"
    ZYX_FIXED = "zyx_fixed"
    XYX_FIXED = "xyx_fixed"
    XZX_FIXED = "xzx_fixed"
    YXY_FIXED = "yxy_fixed"
    YZY_FIXED = "yzy_fixed"
    ZXZ_FIXED = "zxz_fixed"
    ZYZ_FIXED = "zyz_fixed"
    # aliases: the explicit intrinsic spelling
    XYZ_MOVING = "XYZ"
    XZY_MOVING = "XZY"
    YXZ_MOVING = "YXZ"
    YZX_MOVING = "YZX"
    ZXY_MOVING = "ZXY"
    ZYX_MOVING = "ZYX"
    XYX_MOVING = "XYX"
    XZX_MOVING = "XZX"
    YXY_MOVING = "YXY"
    YZY_MOVING = "YZY"
    ZXZ_MOVING = "ZXZ"
    ZYZ_MOVING = "ZYZ"

    @property
    def extrinsic(self):
        """True for fixed-axis (extrinsic) sets [bool]."""
        return self.value.endswith("_fixed")

    @property
    def axes(self):
        """The three axes in the order the rotations are applied, e.g. ``"xyz"`` [str]."""
        return self.value[:3].lower()

    @property
    def scipy_name(self):
        """The sequence name of ``scipy.spatial.transform.Rotation`` (``"XYZ"`` / ``"xyz"``) [str]."""
        return self.axes if self.extrinsic else self.axes.upper()

    @classmethod
    def _missing_(cls, value):
        # scipy's lower-case names, "<axes>_moving" and "rpy" (the values are "ABC" and "abc_fixed")
        key = value if isinstance(value, str) else None
        if key == "rpy":
            return cls.XYZ_FIXED
        if key is not None and key[:3] in _SEQUENCES and key[3:] in ("", "_fixed", "_moving"):
            return cls(key[:3].upper()) if key[3:] == "_moving" else cls(key[:3] + "_fixed")
        raise OptionError(_valid_names_message(value))


def _valid_names_message(got):
    intrinsic = ", ".join(repr(q.upper()) for q in _SEQUENCES)
    extrinsic = ", ".join(repr(q) for q in _SEQUENCES)
    return (
        "expected an Euler convention by scipy's names: intrinsic (moving axes, upper case) "
        + intrinsic + "; extrinsic (fixed axes, lower case) " + extrinsic
        + "; or '<axes>_moving' (= upper case) / '<axes>_fixed' (= lower case) for the same 12 lower-case "
        "axes, e.g. 'zyx_moving' = 'ZYX', 'zyx_fixed' = 'zyx'; or 'rpy' (= 'xyz', roll-pitch-yaw about "
        "fixed axes); got " + repr(got)
    )


def _convention(convention):
    return EulerConvention(convention)


def _intrinsic(conv):
    """Axis indices (i, j, k) of the equivalent intrinsic sequence (extrinsic abc = intrinsic CBA)."""
    axes = [{"x": 0, "y": 1, "z": 2}[a] for a in conv.axes]
    return tuple(axes[::-1]) if conv.extrinsic else tuple(axes)


def _names(conv):
    """Angle names in the order of the convention's angle triple."""
    a = conv.axes
    if conv.extrinsic:
        return (f"gamma ({a[0]})", f"beta ({a[1]})", f"alpha ({a[2]})")
    return (f"alpha ({a[0]})", f"beta ({a[1]}')", f"gamma ({a[2]}'')")


def _family(conv):
    i, j, k = _intrinsic(conv)
    # the representative zeroes the third angle of the triple, as scipy's as_euler does
    zero = "alpha = 0" if conv.extrinsic else "gamma = 0"
    if i == k:
        return ("gimbal lock at beta = 0 or pi: R depends only on alpha + gamma (beta = 0) or "
                f"alpha - gamma (beta = pi); the representative has {zero} (the third angle, as scipy)")
    s = "+" if (i, j, k) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else "-"
    t = "-" if s == "+" else "+"
    return (f"gimbal lock at beta = +-pi/2: R depends only on alpha {s} gamma (beta = +pi/2) or "
            f"alpha {t} gamma (beta = -pi/2); the representative has {zero} (the third angle, as scipy)")


@dataclass(frozen=True, eq=False)
class EulerAngles:
    """Both angle triples of a rotation matrix (result of :func:`euler_from_matrix`).

    Attributes
    ----------
    solutions : ndarray, shape (..., 2, 3)
        ``solutions[..., 0, :]`` and ``solutions[..., 1, :]``, the two angle
        triples [rad] in the order of the convention (``(alpha, beta, gamma)``
        for intrinsic sets, ``(gamma, beta, alpha)`` for extrinsic ones such as
        ``xyz_fixed``), each angle wrapped to ``(-pi, pi]``. The first solution
        has ``beta`` in ``[-pi/2, pi/2]`` (Tait-Bryan) or ``[0, pi]`` (proper Euler).
    gimbal_lock : ndarray of bool, shape (...)
        True where the matrix is at a singularity of the angle set. There
        infinitely many triples give the matrix (see :attr:`family`); both rows
        then hold the same representative, the one scipy's ``as_euler`` returns:
        the third angle of the triple is 0 (``gamma`` for intrinsic sets,
        ``alpha`` for extrinsic ones such as ``"xyz"``).
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
        return _family(self.convention)

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

        names = _names(self.convention)
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
    convention : str or EulerConvention
        scipy's names: ``"XYZ"`` ... = ``"xyz_moving"`` ... (intrinsic, moving axes),
        ``"xyz"`` ... = ``"xyz_fixed"`` ... (extrinsic, fixed axes), or ``"rpy"`` (= ``"xyz"``).

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Raises
    ------
    OptionError
        For an unknown convention (the message lists the valid names).

    Examples
    --------
    Seed 002 problem 1(b): XYZ fixed angles (gamma, beta, alpha) = (pi/4, pi/6, 0).

    >>> np.round(matrix_from_euler([np.pi / 4, np.pi / 6, 0], "xyz_fixed"), 4)
    array([[ 0.866 ,  0.3536,  0.3536],
           [ 0.    ,  0.7071, -0.7071],
           [-0.5   ,  0.6124,  0.6124]])
    >>> bool(np.allclose(matrix_from_euler([0.1, 0.2, 0.3], "xyz"),
    ...                  matrix_from_euler([0.3, 0.2, 0.1], "ZYX")))
    True
    """
    conv = _convention(convention)
    angles = as_batch(angles, (3,), "angles")
    if conv.extrinsic:
        return compose_fixed_frame(conv.axes, angles)
    return compose_moving_frame(conv.axes, angles)


_ROT = (rotation_x, rotation_y, rotation_z)


def _solve_intrinsic(R, i, j, k, tol, zero_gamma):
    """(alpha, beta, gamma) pairs of ``R = R_i(alpha) R_j(beta) R_k(gamma)`` and the lock flag.

    Tait-Bryan (i, j, k distinct; s = +1 for a cyclic sequence, else -1):
    column k is ``R e_k = cos(b) (cos(a) e_k - s sin(a) e_j) + s sin(b) e_i``.
    Proper Euler (k = i, l the third axis, s the parity of (i, j, l)):
    column i is ``R e_i = cos(b) e_i + sin(b) sin(a) e_j - s sin(b) cos(a) e_l``.
    The second solution is ``(a + pi, pi - b, c + pi)`` (Tait-Bryan) or
    ``(a + pi, -b, c + pi)`` (proper). At gimbal lock the representative has
    ``gamma = 0`` (``zero_gamma``; alpha then from ``R R_j(beta)^T = R_i(alpha)``)
    or ``alpha = 0`` (gamma from the residual).
    """
    proper = i == k
    third = 3 - i - j
    s = 1.0 if (i, j, third if proper else k) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
    if proper:
        rii, rji, rli = R[..., i, i], R[..., j, i], R[..., third, i]
        sb = np.hypot(rji, rli)
        lock = sb < tol
        beta = np.where(lock, np.where(rii > 0, 0.0, np.pi), np.arctan2(sb, rii))
        alpha = np.arctan2(rji, -s * rli)
        second_beta = -beta
    else:
        rik, rjk, rkk = R[..., i, k], R[..., j, k], R[..., k, k]
        cb = np.hypot(rjk, rkk)
        lock = cb < tol
        beta = np.where(lock, np.where(s * rik > 0, np.pi / 2, -np.pi / 2), np.arctan2(s * rik, cb))
        alpha = np.arctan2(-s * rjk, rkk)
        second_beta = np.pi - beta
    Rj = _ROT[j](beta)
    if zero_gamma:
        N = R @ np.swapaxes(Rj, -1, -2)  # = R_i(alpha) at gimbal lock with gamma = 0
        p, r = (i + 1) % 3, (i + 2) % 3
        alpha = np.where(lock, np.arctan2(N[..., r, p], N[..., p, p]), alpha)
    else:
        alpha = np.where(lock, 0.0, alpha)
    M = np.swapaxes(_ROT[i](alpha) @ Rj, -1, -2) @ R  # = R_k(gamma) up to rounding
    p, r = (k + 1) % 3, (k + 2) % 3
    gamma = np.arctan2(M[..., r, p], M[..., p, p])
    if zero_gamma:
        gamma = np.where(lock, 0.0, gamma)
    first = np.stack([alpha, beta, gamma], axis=-1)
    second = np.stack([alpha + np.pi, second_beta, gamma + np.pi], axis=-1)
    second = np.where(lock[..., None], first, second)
    return wrap_angle(np.stack([first, second], axis=-2)), lock


def euler_from_matrix(R, convention, *, tol=1e-9):
    """Both angle triples of a rotation matrix, with a gimbal-lock flag (any of the 24 conventions).

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices (not checked; see :func:`check_rotation` and
        :func:`nearest_rotation` for measured or rounded matrices).
    convention : str or EulerConvention
        scipy's names: ``"XYZ"`` ... = ``"xyz_moving"`` ... (intrinsic, moving axes),
        ``"xyz"`` ... = ``"xyz_fixed"`` ... (extrinsic, fixed axes), or ``"rpy"`` (= ``"xyz"``).
    tol : float
        Gimbal lock is declared where ``|cos(beta)|`` (Tait-Bryan) or
        ``|sin(beta)|`` (proper Euler) is below ``tol``.

    Returns
    -------
    EulerAngles
        ``solutions`` of shape (..., 2, 3) [rad] and the ``gimbal_lock`` flag.

    Raises
    ------
    OptionError
        For an unknown convention (the message lists the valid names).

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
    tol = as_number(tol, "tol", positive=True)
    # the representative at gimbal lock zeroes the third angle of the triple (as scipy)
    sol, lock = _solve_intrinsic(R, *_intrinsic(conv), tol, zero_gamma=not conv.extrinsic)
    if conv.extrinsic:
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
    rpy = as_batch(rpy, (3,), "rpy")
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
