"""Rotation matrices: elementary rotations, compositions, Euler/RPY angles (batched).

All angles are in radians and matrices have shape ``(..., 3, 3)``; every
function broadcasts over leading batch dimensions.

Two readings of a sequence of elementary rotations
---------------------------------------------------
* **moving (current) frame** - each rotation is about an axis of the frame
  produced by the previous rotations: the matrices are *post*-multiplied,
  ``R = R_1 R_2 ... R_k`` (:func:`compose_moving_frame`);
* **fixed frame** - each rotation is about an axis of the fixed (reference)
  frame: the matrices are *pre*-multiplied, ``R = R_k ... R_2 R_1``
  (:func:`compose_fixed_frame`).

Rotating about ``x`` then ``y`` in the moving frame gives the same matrix as
rotating about ``y`` then ``x`` in the fixed frame.

Angle sets (:class:`EulerConvention`)
-------------------------------------
* ``"xyz_fixed"`` (= roll-pitch-yaw): angles ``(gamma, beta, alpha)`` about the
  fixed x, y, z axes, ``R = Rz(alpha) Ry(beta) Rx(gamma)``;
* ``"zyx"`` Euler: angles ``(alpha, beta, gamma)`` about the moving z, y', x''
  axes, the same matrix ``Rz(alpha) Ry(beta) Rx(gamma)``;
* ``"zyz"`` Euler: angles ``(alpha, beta, gamma)``, ``R = Rz(alpha) Ry(beta) Rz(gamma)``.

:func:`euler_from_matrix` returns *both* angle triples of a matrix and flags
gimbal lock (where infinitely many triples exist). The angle-set functions are
defined in the private ``labkit._euler`` and re-exported here by name.
"""

from __future__ import annotations

import numpy as np

from labkit._euler import (
    EulerAngles,
    EulerConvention,
    euler_from_matrix,
    matrix_from_euler,
    matrix_from_rpy,
    rpy_from_matrix,
)
from labkit._validation import as_batch
from labkit.exceptions import RotationMatrixError

__all__ = [
    "rotation_x",
    "rotation_y",
    "rotation_z",
    "rotation_about",
    "compose_moving_frame",
    "compose_fixed_frame",
    "EulerConvention",
    "EulerAngles",
    "matrix_from_euler",
    "euler_from_matrix",
    "matrix_from_rpy",
    "rpy_from_matrix",
    "wrap_angle",
    "is_rotation",
    "check_rotation",
    "nearest_rotation",
    "RotationMatrixError",
]

_AXES = {"x": 0, "y": 1, "z": 2}


def _elementary(angle, axis):
    angle = np.asarray(angle, dtype=float)
    c, s = np.cos(angle), np.sin(angle)
    R = np.zeros(angle.shape + (3, 3))
    i, j = {0: (1, 2), 1: (2, 0), 2: (0, 1)}[axis]
    R[..., axis, axis] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


def rotation_x(angle):
    """Rotation about the x axis.

    Parameters
    ----------
    angle : array_like, shape (...)
        Rotation angle [rad].

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Examples
    --------
    >>> import numpy as np
    >>> np.round(rotation_x(np.pi / 2), 6)[1:, 1:]
    array([[ 0., -1.],
           [ 1.,  0.]])
    """
    return _elementary(angle, 0)


def rotation_y(angle):
    """Rotation about the y axis.

    Parameters
    ----------
    angle : array_like, shape (...)
        Rotation angle [rad].

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Examples
    --------
    >>> float(rotation_y(0.3)[0, 2]) == float(np.sin(0.3))
    True
    """
    return _elementary(angle, 1)


def rotation_z(angle):
    """Rotation about the z axis.

    Parameters
    ----------
    angle : array_like, shape (...)
        Rotation angle [rad].

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Examples
    --------
    >>> float(rotation_z(0.3)[1, 0]) == float(np.sin(0.3))
    True
    """
    return _elementary(angle, 2)


def _axis_index(axis):
    key = str(axis).lower()
    if key not in _AXES:
        raise ValueError(f"expected an axis 'x', 'y' or 'z', got {axis!r}")
    return _AXES[key]


def rotation_about(axis, angle):
    """Elementary rotation about a named axis.

    Parameters
    ----------
    axis : {"x", "y", "z"}
        Rotation axis.
    angle : array_like, shape (...)
        Rotation angle [rad].

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Examples
    --------
    >>> np.allclose(rotation_about("y", 0.2), rotation_y(0.2))
    True
    """
    return _elementary(angle, _axis_index(axis))


def _sequence(sequence, angles):
    axes = [_axis_index(a) for a in sequence]
    if not axes:
        raise ValueError("expected a non-empty sequence of axes such as 'zyx', got an empty one")
    angles = as_batch(angles, (len(axes),), "angles")
    return axes, angles


def compose_moving_frame(sequence, angles):
    """Compose elementary rotations about the axes of the *moving* (current) frame.

    Each rotation is about an axis of the frame obtained after the previous
    ones, so the matrices are post-multiplied:
    ``R = R_{s1}(angles[0]) @ R_{s2}(angles[1]) @ ...``.

    Parameters
    ----------
    sequence : str or sequence of {"x", "y", "z"}
        Axes in the order the rotations are performed, e.g. ``"zyz"`` or
        ``("y", "x", "z")``.
    angles : array_like, shape (..., k)
        One angle per axis [rad], ``k = len(sequence)``.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Raises
    ------
    ValueError
        For an unknown axis name; :class:`~labkit.exceptions.ShapeError` if
        ``angles`` does not end in ``k``.

    Examples
    --------
    Seed 002 problem 1(a): pi/4 about x, then pi/6 about the new y axis.

    >>> np.round(compose_moving_frame("xy", [np.pi / 4, np.pi / 6]), 4)
    array([[ 0.866 ,  0.    ,  0.5   ],
           [ 0.3536,  0.7071, -0.6124],
           [-0.3536,  0.7071,  0.6124]])
    """
    axes, angles = _sequence(sequence, angles)
    R = _elementary(angles[..., 0], axes[0])
    for k in range(1, len(axes)):
        R = R @ _elementary(angles[..., k], axes[k])
    return R


def compose_fixed_frame(sequence, angles):
    """Compose elementary rotations about the axes of the *fixed* (reference) frame.

    Each rotation is about an axis of the fixed frame, so the matrices are
    pre-multiplied: ``R = ... @ R_{s2}(angles[1]) @ R_{s1}(angles[0])``.

    Parameters
    ----------
    sequence : str or sequence of {"x", "y", "z"}
        Axes in the order the rotations are performed.
    angles : array_like, shape (..., k)
        One angle per axis [rad].

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Examples
    --------
    Seed 002 problem 1(a) read in the fixed frame: pi/6 about y, then pi/4
    about the fixed x axis (the same matrix as ``compose_moving_frame("xy", ...)``).

    >>> R = compose_fixed_frame("yx", [np.pi / 6, np.pi / 4])
    >>> np.allclose(R, compose_moving_frame("xy", [np.pi / 4, np.pi / 6]))
    True
    """
    axes, angles = _sequence(sequence, angles)
    R = _elementary(angles[..., 0], axes[0])
    for k in range(1, len(axes)):
        R = _elementary(angles[..., k], axes[k]) @ R
    return R


def wrap_angle(angle):
    """Wrap angles to ``(-pi, pi]``.

    Parameters
    ----------
    angle : array_like, shape (...)
        Angles [rad].

    Returns
    -------
    wrapped : ndarray, shape (...)

    Examples
    --------
    >>> float(wrap_angle(-np.pi)) == float(np.pi)
    True
    """
    a = np.asarray(angle, dtype=float)
    w = np.mod(a + np.pi, 2 * np.pi) - np.pi
    return np.where(w <= -np.pi, w + 2 * np.pi, w)


def _as_matrices(R):
    return as_batch(R, (3, 3), "R")


def _orthonormality_error(R):
    RtR = np.swapaxes(R, -1, -2) @ R
    return np.max(np.abs(RtR - np.eye(3)), axis=(-2, -1))


def is_rotation(R, tol=1e-6):
    """Whether matrices are proper rotations (orthonormal, determinant +1).

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
    tol : float
        Allowed ``max |R^T R - I|`` and ``|det R - 1|``.

    Returns
    -------
    ok : ndarray of bool, shape (...)
        False also for non-finite entries.

    Examples
    --------
    >>> bool(is_rotation(rotation_z(0.4))), bool(is_rotation(np.diag([1.0, 1.0, -1.0])))
    (True, False)
    """
    R = as_batch(R, (3, 3), "R", finite=False)
    finite = np.all(np.isfinite(R), axis=(-2, -1))
    Rf = np.where(finite[..., None, None], R, 0.0)
    return finite & (_orthonormality_error(Rf) <= tol) & (np.abs(np.linalg.det(Rf) - 1.0) <= tol)


def check_rotation(R, tol=1e-6):
    """Return ``R`` as an array, or raise saying why it is not a rotation.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
    tol : float
        Allowed ``max |R^T R - I|`` and ``|det R - 1|``.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Raises
    ------
    ShapeError
        Wrong shape or non-finite entries.
    RotationMatrixError
        Not orthonormal (columns not unit length / not perpendicular), or a
        reflection (det = -1); the message gives the size of the defect, the
        batch index and suggests :func:`nearest_rotation`.

    Examples
    --------
    >>> check_rotation([[0.866, -0.5, 0], [0.5, 0.866, 0], [0, 0, 1]], tol=1e-3).shape
    (3, 3)
    """
    R = _as_matrices(R)
    err = _orthonormality_error(R)
    det = np.linalg.det(R)
    bad = err > tol
    if np.any(bad):
        idx = tuple(int(i) for i in np.argwhere(bad)[0]) if R.ndim > 2 else ()
        where = f" at batch index {idx}" if idx else ""
        Ri = R[idx]
        norms = np.linalg.norm(Ri, axis=0)
        raise RotationMatrixError(
            f"expected an orthonormal matrix (max |R^T R - I| <= {tol:g}), got "
            f"max |R^T R - I| = {float(err[idx]):.3g}{where} (column norms "
            f"{np.array2string(norms, precision=4)}); use nearest_rotation() to re-orthonormalise "
            "a measured or rounded matrix"
        )
    refl = np.abs(det - 1.0) > tol
    if np.any(refl):
        idx = tuple(int(i) for i in np.argwhere(refl)[0]) if R.ndim > 2 else ()
        where = f" at batch index {idx}" if idx else ""
        raise RotationMatrixError(
            f"expected det R = +1, got det R = {float(det[idx]):.4g}{where}: "
            "the matrix is a reflection (a left-handed frame), not a rotation"
        )
    return R


def nearest_rotation(R):
    """Nearest proper rotation (in the Frobenius norm) to each matrix.

    Re-orthonormalises measured or rounded matrices by the polar
    decomposition computed with an SVD: ``M = U S V^T`` gives
    ``R = U diag(1, 1, det(U V^T)) V^T``.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Approximately orthonormal matrices.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
        Proper rotations (det = +1).

    Examples
    --------
    >>> R = nearest_rotation([[0.866, -0.5, 0], [0.5, 0.866, 0], [0, 0, 1]])
    >>> bool(is_rotation(R, tol=1e-12))
    True
    >>> round(float(np.degrees(np.arctan2(R[1, 0], R[0, 0]))), 2)
    30.0
    """
    M = _as_matrices(R)
    U, _, Vt = np.linalg.svd(M)
    d = np.sign(np.linalg.det(U @ Vt))
    d = np.where(d == 0, 1.0, d)
    U = U.copy()
    U[..., :, 2] *= d[..., None]
    return U @ Vt
