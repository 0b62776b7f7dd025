"""The one ordered registry of closed-form IK families (private).

A robot's family is the first of :data:`FAMILIES` that fits its geometry (joint
axes at ``q = 0``), cached by the robot's content (``Robot`` stays
plain frozen data). Adding a family: one module with a
:class:`~labkit.kinematics._ik_solvers._family.Family` subclass and one line here; the
``Solver`` enum of :mod:`labkit.kinematics` is built from this tuple.
"""

from __future__ import annotations

from labkit.kinematics._chain import _by_content
from labkit.kinematics._ik_solvers._cartesian_yaw import CartesianYaw
from labkit.kinematics._ik_solvers._planar_2r import Planar2R
from labkit.kinematics._ik_solvers._planar_3r import Planar3R
from labkit.kinematics._ik_solvers._prismatic import Cartesian, Cylindrical
from labkit.kinematics._ik_solvers._scara import Scara, ScaraRRP
from labkit.kinematics._ik_solvers._spherical_arm import SphericalRRP, Stanford
from labkit.kinematics._ik_solvers._spherical_wrist import SphericalWrist
from labkit.kinematics._ik_solvers._three_parallel import ThreeParallel
from labkit.kinematics._ik_solvers._yaw_pitch_pitch import YawPitchPitch
from labkit.kinematics._ik_solvers._yaw_pitch_pitch_pitch import YawPitchPitchPitch
from labkit.kinematics._ik_solvers._yaw_pitch_pitch_pitch_roll import YawPitchPitchPitchRoll

#: the families, in the order they are tried
FAMILIES = (Planar2R, Planar3R, YawPitchPitch, YawPitchPitchPitch, YawPitchPitchPitchRoll, SphericalWrist,
            ThreeParallel, Scara, ScaraRRP, Cylindrical, Cartesian, CartesianYaw, SphericalRRP, Stanford)

_BY_NAME = {f.name: f for f in FAMILIES}


@_by_content
def detect(robot):
    """The first family that fits ``robot``, built on it (or None), cached by content.

    Parameters
    ----------
    robot : Robot

    Returns
    -------
    solver, reasons : Family or None, dict
        The family, and why each family tried before does not fit.
    """
    reasons, found = {}, None
    for family in FAMILIES:
        found, why = family.fits(robot)
        if found is not None:
            break
        reasons[family.name] = why
    return found, reasons


def build(robot, name):
    """The family ``name`` on ``robot``, or why it does not fit (:meth:`Family.fits`).

    Parameters
    ----------
    robot : Robot
    name : str

    Returns
    -------
    solver, reason : Family or None, str
    """
    return _BY_NAME[name].fits(robot)
