"""Rotation matrices: elementary rotations (batched).

All angles in radians; matrices have shape ``(..., 3, 3)``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["rotation_x", "rotation_y", "rotation_z", "matrix_from_rpy"]


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
