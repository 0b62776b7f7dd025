"""Kinematics of serial arms: forward kinematics and geometric Jacobians, inverse
kinematics (closed-form families with named branches, batched numeric IK),
statics and velocity kinematics, workspace sampling. Symbolic DH algebra lives in
:mod:`labkit.kinematics.symbolic` (imports sympy when used).
"""

from labkit.kinematics import _display, _forward, _ik, _statics, _workspace
from labkit.kinematics._forward import fk, fk_position, fk_position_with, fk_frames, fk_frames_with, jacobian, fk_jacobian
from labkit.kinematics._ik import (
    Solver,
    IKSolutions,
    IKResult,
    target_kind,
    solver_for,
    ik,
    ik_all,
    ik_numeric,
    pose_from_position_pitch,
)
from labkit.kinematics._ik_solvers import REDUCED as REDUCED_KINDS, target_components, task_rows
from labkit.kinematics._statics import (
    joint_torques,
    wrench_transform_matrix,
    transform_wrench,
    singular_values,
    manipulability,
    condition_number,
    is_singular,
    damping_factor,
    joint_rates,
)
from labkit.kinematics._display import target_from_display, target_to_display, target_error, target_from_pose
from labkit.kinematics._workspace import Workspace, workspace_points, PlanarRegion, planar_region

__all__ = [
    *_forward.__all__,
    *_ik.__all__,
    "task_rows",
    "target_components",
    "REDUCED_KINDS",
    *_statics.__all__,
    *_display.__all__,
    *_workspace.__all__,
]
