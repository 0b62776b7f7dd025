"""Rotation-matrix checks: is a 3x3 matrix a proper rotation, and the nearest one that is."""

from __future__ import annotations

import numpy as np

from labkit.validation import as_batch, as_number
from labkit.exceptions import RotationMatrixError

__all__ = ["is_rotation", "check_rotation", "nearest_rotation"]




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
    >>> from labkit.rotations import rotation_z
    >>> bool(is_rotation(rotation_z(0.4))), bool(is_rotation(np.diag([1.0, 1.0, -1.0])))
    (True, False)
    """
    R = as_batch(R, (3, 3), "R", finite=False)
    tol = as_number(tol, "tol", positive=True)
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
    tol = as_number(tol, "tol", positive=True)
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
