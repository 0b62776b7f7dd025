"""Inverse kinematics machinery: closed-form families, their registry, the numeric solver.

The public functions (:func:`labkit.kinematics.ik`, ``ik_all``, ``ik_numeric``,
``solver_for`` ...) live in :mod:`labkit.kinematics`; this subpackage holds
what they run on:

* one module per closed-form family (``_planar_2r``, ``_planar_3r``,
  ``_yaw_pitch_pitch``, ``_yaw_pitch_pitch_pitch``, ``_yaw_pitch_pitch_pitch_roll``, ``_spherical_wrist``,
  ``_three_parallel``), each family's formulas written once against a small
  array namespace (:mod:`~labkit.kinematics.ik._xp`: numpy rows for a batch,
  Python floats for one target) following the protocol of
  :mod:`~labkit.kinematics.ik._family`;
* the one ordered registry of the families (:data:`FAMILIES`, :func:`detect`);
* the geometry they share once (:mod:`~labkit.kinematics.ik._geometry`: cosine
  law, Paden-Kahan subproblems);
* the one finishing step (flip, wrap, limits) and the driver
  (:func:`solve_closed_form`; :func:`solve_floats` and :func:`pick_floats`
  for a few targets on Python floats);
* target validation and task rows (:func:`validate_targets`, :func:`task_rows`);
* the batched Levenberg-Marquardt solver (:func:`solve_numeric`).
"""

from labkit.kinematics.ik._registry import FAMILIES, build, detect
from labkit.kinematics.ik._solve import pick_floats, solve as solve_closed_form, solve_floats
from labkit.kinematics.ik._numeric import LazyGenerator, solve as solve_numeric
from labkit.kinematics.ik._targets import (
    COMPONENTS, REDUCED, batch_index, describe_target, small_targets, target_words, task_rows, validate_targets,
)

__all__ = [
    "FAMILIES",
    "detect",
    "build",
    "solve_closed_form",
    "solve_floats",
    "pick_floats",
    "solve_numeric",
    "LazyGenerator",
    "validate_targets",
    "small_targets",
    "task_rows",
    "batch_index",
    "describe_target",
    "target_words",
    "COMPONENTS",
    "REDUCED",
]
