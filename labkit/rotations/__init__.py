"""Rotations: elementary rotations, composition in moving and fixed frames, Euler
and roll-pitch-yaw angle sets (all 24 conventions), rotation-matrix checks, and
quaternions / axis-angle / rotation vectors / exp-log / slerp (over scipy,
imported only when those are called).
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
from labkit.rotations._quaternion import (
    quaternion_from_matrix,
    matrix_from_quaternion,
    axis_angle_from_matrix,
    matrix_from_axis_angle,
    rotation_vector_from_matrix,
    matrix_from_rotation_vector,
    skew,
    matrix_exp,
    matrix_log,
    slerp,
)

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
