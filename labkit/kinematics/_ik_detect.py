"""Which closed-form IK family a robot belongs to (private; see :func:`labkit.kinematics.solver_for`).

Every family is tried on the robot's geometry (joint axes at ``q = 0``, read from
its DH table through forward kinematics); the first that fits is used. The result
is cached per robot object in a keyed cache (``Robot`` stays plain frozen data).
"""

from __future__ import annotations

import weakref

from labkit.kinematics._ik_analytic import Planar3R, SphericalWrist, YawPitchPitch, _NotThisStructure
from labkit.kinematics._ik_planar import Planar2R
from labkit.kinematics._ik_ur import ThreeParallel

#: analytic solver (or None) and reasons per robot object; entries die with the robot
_DETECTED = weakref.WeakKeyDictionary()

SOLVERS = {cls.name: cls for cls in (Planar2R, Planar3R, YawPitchPitch, SphericalWrist, ThreeParallel)}
#: the order in which families are tried
ORDER = ("planar_2r", "planar_3r", "yaw_pitch_pitch", "spherical_wrist", "three_parallel")


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
        ``"spherical_wrist"``, ``"three_parallel"``).

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
