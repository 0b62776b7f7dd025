"""Rotations: elementary rotations, composition in moving and fixed frames, Euler
and roll-pitch-yaw angle sets, and rotation-matrix checks.
"""

from labkit.rotations._elementary import (
    rotation_x,
    rotation_y,
    rotation_z,
    rotation_about,
    compose_moving_frame,
    compose_fixed_frame,
    wrap_angle,
)
from labkit.rotations._euler import (
    EulerConvention,
    EulerAngles,
    matrix_from_euler,
    euler_from_matrix,
    matrix_from_rpy,
    rpy_from_matrix,
)
from labkit.rotations._matrix import is_rotation, check_rotation, nearest_rotation

__all__ = [
    "rotation_x",
    "rotation_y",
    "rotation_z",
    "rotation_about",
    "compose_moving_frame",
    "compose_fixed_frame",
    "wrap_angle",
    "EulerConvention",
    "EulerAngles",
    "matrix_from_euler",
    "euler_from_matrix",
    "matrix_from_rpy",
    "rpy_from_matrix",
    "is_rotation",
    "check_rotation",
    "nearest_rotation",
]
