"""Inverse kinematics machinery: closed-form families, their registry, the numeric solver.

The public functions (:func:`labkit.kinematics.ik`, ``ik_all``, ``ik_numeric``,
``solver_for`` ...) live in :mod:`labkit.kinematics`; this subpackage holds
what they run on, every part on numpy rows (one target is a batch of one):

* one module per closed-form family, following the protocol of
  :mod:`~labkit.kinematics._ik_solvers._family`, and their one ordered
  registry (:data:`FAMILIES`, :func:`detect`);
* the geometry they share once (:mod:`~labkit.kinematics._ik_solvers._geometry`:
  cosine law, Paden-Kahan subproblems);
* the one finishing step (flip, wrap) and branch pick (:func:`solve_closed_form`,
  :func:`nearest`);
* target validation and task rows (:func:`validate_targets`, :func:`task_rows`);
* the batched Levenberg-Marquardt solver (:func:`solve_numeric`), its
  arithmetic (:mod:`~labkit.kinematics._ik_solvers._lm`) and its starts
  (:mod:`~labkit.kinematics._ik_solvers._starts`).
"""

from labkit.kinematics._ik_solvers._registry import FAMILIES, build, detect
from labkit.kinematics._ik_solvers._solve import nearest, solve as solve_closed_form
from labkit.kinematics._ik_solvers._numeric import LazyGenerator, _first_success, solve as solve_numeric
from labkit.kinematics._ik_solvers._targets import (
    COMPONENTS, REDUCED, _batch_index, _describe_target, target_components, _target_words, task_rows,
    validate_targets,
)

__all__ = [
    "FAMILIES", "detect", "build", "solve_closed_form", "nearest", "solve_numeric", "LazyGenerator",
    "validate_targets", "task_rows", "target_components", "COMPONENTS", "REDUCED",
]
