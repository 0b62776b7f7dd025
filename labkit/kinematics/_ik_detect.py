"""Which closed-form IK family a robot belongs to (private; see :func:`labkit.kinematics.solver_for`).

Every family is tried on the robot's geometry (joint axes at ``q = 0``, read from
its DH table through forward kinematics); the first that fits is used. The result
is cached per robot object in a keyed cache (``Robot`` stays plain frozen data).
"""

from __future__ import annotations

import weakref

from labkit.exceptions import OptionError
from labkit.kinematics._ik_4dof import YawPitchPitchPitch, position_pitch_pose
from labkit.kinematics._ik_analytic import Planar3R, SphericalWrist, YawPitchPitch, _NotThisStructure
from labkit.kinematics._ik_planar import Planar2R
from labkit.kinematics._ik_ur import ThreeParallel

#: analytic solver (or None) and reasons per robot object; entries die with the robot
_DETECTED = weakref.WeakKeyDictionary()

SOLVERS = {cls.name: cls for cls in (Planar2R, Planar3R, YawPitchPitch, YawPitchPitchPitch, SphericalWrist,
                                     ThreeParallel)}
#: the order in which families are tried
ORDER = ("planar_2r", "planar_3r", "yaw_pitch_pitch", "yaw_pitch_pitch_pitch", "spherical_wrist", "three_parallel")

__all__ = ["pose_from_position_pitch"]


def detect(robot):
    """The analytic solver instance for ``robot`` or None (cached per robot object).

    Parameters
    ----------
    robot : Robot
        The arm whose DH table is inspected.

    Returns
    -------
    solver or None, dict
        The solver and, for every solver tried, why it does not apply.
    """
    cached = _DETECTED.get(robot)
    if cached is not None:
        return cached
    reasons = {}
    found = None
    for name in ORDER:
        try:
            found = SOLVERS[name](robot)
            break
        except _NotThisStructure as exc:
            reasons[name] = str(exc)
    result = (found, reasons)
    _DETECTED[robot] = result
    return result


def build(robot, name):
    """Force the analytic solver ``name`` on ``robot``.

    Parameters
    ----------
    robot : Robot
        The arm.
    name : str
        A key of :data:`SOLVERS` (``"planar_2r"``, ``"planar_3r"``, ``"yaw_pitch_pitch"``,
        ``"yaw_pitch_pitch_pitch"``, ``"spherical_wrist"``, ``"three_parallel"``).

    Returns
    -------
    solver
        The solver instance.

    Raises
    ------
    _NotThisStructure
        With the reason the robot does not have that structure.
    """
    return SOLVERS[name](robot)


def pose_from_position_pitch(robot, target):
    """Tool poses of ``(x, y, z, pitch)`` targets of a 4-DOF yaw-pitch-pitch-pitch arm.

    A MeArm / uArm / Dobot type arm reaches a tool point and one pitch angle; its
    IK targets are poses (``target_kind`` is ``"pose"``), built here.

    Parameters
    ----------
    robot : Robot
        An arm whose closed-form family is ``yaw_pitch_pitch_pitch``.
    target : array_like, shape (..., 4)
        Tool point ``(x, y, z)`` [m] and pitch [rad]: the elevation of the tool x
        axis above the plane perpendicular to axis 1 (positive towards +axis 1;
        0 = pointing away from axis 1 in the arm's plane).

    Returns
    -------
    T : ndarray, shape (..., 4, 4)
        ``world_from_tool`` poses to pass to :func:`ik` / :func:`ik_all`.

    Raises
    ------
    OptionError
        The robot is not of that family.
    ShapeError
        Bad target shape or values.
    """
    found, reasons = detect(robot)
    if not isinstance(found, YawPitchPitchPitch):
        raise OptionError(
            f"{robot.name}: (x, y, z, pitch) targets need a 4-DOF yaw-pitch-pitch-pitch arm "
            f"({reasons.get('yaw_pitch_pitch_pitch', 'its solver is ' + repr(getattr(found, 'name', None)))})"
        )
    return position_pitch_pose(found, target)
