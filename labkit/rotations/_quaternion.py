"""Quaternions, axis-angle, rotation vectors, exp/log and slerp (batched).

A thin labkit-shaped layer over :class:`scipy.spatial.transform.Rotation`:
rotation matrices ``(..., 3, 3)`` are labkit's currency, every function takes and
returns arrays with leading batch dimensions, angles are in radians, and bad
input raises a :class:`~labkit.exceptions.LabkitError` saying what was expected.
scipy is imported inside the functions (``import labkit.rotations`` stays light).

Quaternions are **scalar first**, ``(w, x, y, z)`` (as pytransform3d and most
textbooks; scipy's default is scalar last), unit norm, returned with ``w >= 0``.
"""

from __future__ import annotations

import numpy as np

from labkit.validation import as_batch, as_number
from labkit.exceptions import RotationMatrixError, ShapeError
from labkit.rotations._matrix import check_rotation

__all__ = [
    "quaternion_from_matrix",
    "matrix_from_quaternion",
    "axis_angle_from_matrix",
    "matrix_from_axis_angle",
    "rotation_vector_from_matrix",
    "matrix_from_rotation_vector",
    "skew",
    "matrix_exp",
    "matrix_log",
    "slerp",
]


def _rotation():
    from scipy.spatial.transform import Rotation  # heavy: only when used

    return Rotation


def _matrices(R, tol):
    """Checked rotations as (N, 3, 3) and their leading shape."""
    R = check_rotation(as_batch(R, (3, 3), "R"), tol=tol)
    return R.reshape(-1, 3, 3), R.shape[:-2]


def quaternion_from_matrix(R, *, tol=1e-6):
    """Unit quaternions ``(w, x, y, z)`` of rotation matrices, ``w >= 0``.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices (orthonormal within ``tol``, det +1).
    tol : float
        Accepted orthonormality error (see :func:`check_rotation`).

    Returns
    -------
    q : ndarray, shape (..., 4)
        Scalar-first unit quaternions with non-negative scalar part.

    Raises
    ------
    RotationMatrixError
        A matrix is not a rotation.

    Examples
    --------
    >>> from labkit.rotations import rotation_z
    >>> np.round(quaternion_from_matrix(rotation_z(np.pi / 2)), 6)
    array([0.707107, 0.      , 0.      , 0.707107])
    """
    R, lead = _matrices(R, tol)
    xyzw = _rotation().from_matrix(R).as_quat()
    q = np.concatenate([xyzw[:, 3:], xyzw[:, :3]], axis=1)
    q = np.where(q[:, :1] < 0, -q, q)
    return q.reshape(lead + (4,))


def matrix_from_quaternion(q, *, normalize=False, tol=1e-6):
    """Rotation matrices of quaternions ``(w, x, y, z)``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Scalar-first quaternions.
    normalize : bool
        Divide by the norm first; otherwise the norm must be 1 within ``tol``.
    tol : float
        Accepted deviation of the norm from 1 when ``normalize`` is False.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Raises
    ------
    ShapeError
        Wrong shape, non-finite values, a zero quaternion, or (without
        ``normalize``) a quaternion that is not unit.

    Examples
    --------
    >>> np.round(matrix_from_quaternion([np.cos(0.25), 0.0, 0.0, np.sin(0.25)])[0], 4)
    array([ 0.8776, -0.4794,  0.    ])
    """
    q = as_batch(q, (4,), "quaternion (w, x, y, z)")
    tol = as_number(tol, "tol", positive=True)
    lead = q.shape[:-1]
    q = q.reshape(-1, 4)
    norm = np.sqrt((q * q).sum(axis=1))
    if np.any(norm == 0.0):
        raise ShapeError("expected a non-zero quaternion (w, x, y, z), got (0, 0, 0, 0)")
    if not normalize and np.any(np.abs(norm - 1.0) > tol):
        i = int(np.argmax(np.abs(norm - 1.0)))
        raise ShapeError(
            f"expected unit quaternions (w, x, y, z) (|q| = 1 within {tol:g}; pass normalize=True to "
            f"scale them), got |q| = {norm[i]:.6g}"
        )
    R = _rotation().from_quat(np.concatenate([q[:, 1:], q[:, :1]], axis=1)).as_matrix()
    return R.reshape(lead + (3, 3))


def rotation_vector_from_matrix(R, *, tol=1e-6):
    """Rotation vectors ``angle * axis`` of rotation matrices, angle in ``[0, pi]``.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices.
    tol : float
        Accepted orthonormality error.

    Returns
    -------
    v : ndarray, shape (..., 3)
        Rotation vectors [rad].

    Examples
    --------
    >>> from labkit.rotations import rotation_x
    >>> np.round(rotation_vector_from_matrix(rotation_x(0.5)), 6)
    array([0.5, 0. , 0. ])
    """
    R, lead = _matrices(R, tol)
    return _rotation().from_matrix(R).as_rotvec().reshape(lead + (3,))


def matrix_from_rotation_vector(v):
    """Rotation matrices of rotation vectors (Rodrigues: ``exp([v]x)``).

    Parameters
    ----------
    v : array_like, shape (..., 3)
        Rotation vectors ``angle * axis`` [rad].

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Examples
    --------
    >>> np.round(matrix_from_rotation_vector([0.0, 0.0, np.pi / 2]), 6)
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  1.]])
    """
    v = as_batch(v, (3,), "rotation vector")
    return _rotation().from_rotvec(v.reshape(-1, 3)).as_matrix().reshape(v.shape[:-1] + (3, 3))


def axis_angle_from_matrix(R, *, tol=1e-6):
    """Unit axis and angle in ``[0, pi]`` of rotation matrices.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices.
    tol : float
        Accepted orthonormality error.

    Returns
    -------
    axis : ndarray, shape (..., 3)
        Unit rotation axes (``[1, 0, 0]`` for the identity, where any axis fits).
    angle : ndarray, shape (...)
        Rotation angles [rad].

    Examples
    --------
    >>> from labkit.rotations import rotation_y
    >>> axis, angle = axis_angle_from_matrix(rotation_y(-0.3))
    >>> np.round(axis, 6) + 0.0, round(float(angle), 6)
    (array([ 0., -1.,  0.]), 0.3)
    """
    v = rotation_vector_from_matrix(R, tol=tol)
    angle = np.sqrt((v * v).sum(axis=-1))
    safe = np.where(angle > 0, angle, 1.0)[..., None]
    axis = np.where(angle[..., None] > 0, v / safe, [1.0, 0.0, 0.0])
    return axis, angle


def matrix_from_axis_angle(axis, angle):
    """Rotation matrices about (not necessarily unit) axes by angles.

    Parameters
    ----------
    axis : array_like, shape (..., 3)
        Rotation axes (normalised here; must be non-zero).
    angle : array_like, shape (...)
        Angles [rad], broadcast against the axes' leading shape.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Raises
    ------
    ShapeError
        A zero axis, wrong shapes or non-finite values.

    Examples
    --------
    >>> from labkit.rotations import rotation_z
    >>> bool(np.allclose(matrix_from_axis_angle([0, 0, 2.0], 0.4), rotation_z(0.4)))
    True
    """
    axis = as_batch(axis, (3,), "axis")
    angle = as_batch(angle, (), "angle")
    norm = np.sqrt((axis * axis).sum(axis=-1))
    if np.any(norm == 0.0):
        raise ShapeError("expected a non-zero rotation axis, got (0, 0, 0)")
    try:
        v = axis / norm[..., None] * angle[..., None]
    except ValueError:
        raise ShapeError(f"expected angle broadcastable to {axis.shape[:-1]}, got {angle.shape}") from None
    return matrix_from_rotation_vector(v)


def skew(v):
    """Skew-symmetric matrices ``[v]x`` with ``[v]x u = v x u``.

    Parameters
    ----------
    v : array_like, shape (..., 3)
        Vectors (e.g. angular velocities [rad/s] or rotation vectors [rad]).

    Returns
    -------
    S : ndarray, shape (..., 3, 3)

    Examples
    --------
    >>> skew([1.0, 2.0, 3.0])
    array([[ 0., -3.,  2.],
           [ 3.,  0., -1.],
           [-2.,  1.,  0.]])
    """
    v = as_batch(v, (3,), "v")
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def matrix_exp(S, *, tol=1e-9):
    """Matrix exponential of skew-symmetric matrices: the rotation ``exp(S)`` (modern_robotics' MatrixExp3).

    Parameters
    ----------
    S : array_like, shape (..., 3, 3)
        Skew-symmetric matrices ``[omega theta]x`` [rad].
    tol : float
        Accepted asymmetry ``max |S + S^T|``.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Raises
    ------
    ShapeError
        A matrix is not skew-symmetric.

    Examples
    --------
    >>> from labkit.rotations import rotation_z
    >>> bool(np.allclose(matrix_exp(skew([0, 0, 0.7])), rotation_z(0.7)))
    True
    """
    S = as_batch(S, (3, 3), "S")
    tol = as_number(tol, "tol", positive=True)
    asym = np.abs(S + np.swapaxes(S, -1, -2)).max(initial=0.0)
    if asym > tol:
        raise ShapeError(f"expected skew-symmetric matrices (max |S + S^T| <= {tol:g}), got {asym:.3g}")
    return matrix_from_rotation_vector(np.stack([S[..., 2, 1], S[..., 0, 2], S[..., 1, 0]], axis=-1))


def matrix_log(R, *, tol=1e-6):
    """Matrix logarithm of rotations: the skew-symmetric ``[omega theta]x`` with angle in ``[0, pi]`` (MatrixLog3).

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices.
    tol : float
        Accepted orthonormality error.

    Returns
    -------
    S : ndarray, shape (..., 3, 3)
        Skew-symmetric matrices with ``matrix_exp(S) = R``.

    Examples
    --------
    >>> from labkit.rotations import rotation_x
    >>> np.round(matrix_log(rotation_x(0.5))[2, 1], 6)
    np.float64(0.5)
    """
    return skew(rotation_vector_from_matrix(R, tol=tol))


def slerp(R_start, R_end, s, *, tol=1e-6):
    """Spherical linear interpolation between rotations (constant angular velocity, shortest arc).

    ``R(s) = R_start exp(s log(R_start^T R_end))``, computed with
    :class:`scipy.spatial.transform.Slerp`.

    Parameters
    ----------
    R_start, R_end : array_like, shape (3, 3)
        Rotations at ``s = 0`` and ``s = 1``.
    s : array_like, shape (...)
        Path parameters in ``[0, 1]``.
    tol : float
        Accepted orthonormality error of the two rotations.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Raises
    ------
    ShapeError
        ``s`` outside ``[0, 1]`` or non-finite; rotations of the wrong shape.
    RotationMatrixError
        ``R_start`` or ``R_end`` is not a rotation.

    Examples
    --------
    >>> from labkit.rotations import rotation_z
    >>> bool(np.allclose(slerp(np.eye(3), rotation_z(1.0), 0.25), rotation_z(0.25)))
    True
    """
    from scipy.spatial.transform import Slerp

    ends = []
    for name, R in (("R_start", R_start), ("R_end", R_end)):
        R = as_batch(R, (3, 3), name)
        if R.shape != (3, 3):
            raise ShapeError(f"expected {name} with shape (3, 3), got {R.shape}")
        try:
            ends.append(check_rotation(R, tol=tol))
        except RotationMatrixError as exc:
            raise RotationMatrixError(f"{name}: {exc}") from None
    s = as_batch(s, (), "s", finite=False)
    if not np.all(np.isfinite(s)) or np.any((s < 0) | (s > 1)):
        raise ShapeError(f"expected s in [0, 1], got values from {s.min():.4g} to {s.max():.4g}")
    interp = Slerp([0.0, 1.0], _rotation().from_matrix(np.stack(ends)))
    return interp(s.reshape(-1)).as_matrix().reshape(s.shape + (3, 3))
