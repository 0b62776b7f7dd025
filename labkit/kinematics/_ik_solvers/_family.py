"""What a closed-form IK family is (private): the protocol every family module follows.

A family is a class with

``name``
    its :class:`labkit.kinematics.Solver` value (``"planar_3r"`` ...);
``kind``
    the target it takes: ``"position"``, ``"planar"``, ``"position_pitch"``,
    ``"position_pitch_roll"``, ``"position_yaw"`` or ``"pose"`` (:data:`labkit.kinematics._ik_solvers._targets.COMPONENTS`);
``branches``, ``aliases``
    the names of its solutions, in order, and accepted other names;
``joints``, ``prismatic``
    how many joints it needs, and how many of them are prismatic (the others revolute);
``__init__(robot, z, o, tool)``
    reads the robot's geometry (joint axes ``z``, points ``o`` on them and the
    tool frame at ``q = 0``: :func:`~labkit.kinematics._ik_solvers._geometry.joint_axes`),
    raising :class:`~labkit.kinematics._ik_solvers._geometry.NotThisFamily` with
    the reason when the robot lacks the structure (:meth:`Family.fits` answers);
``solve(t)``
    every branch of the targets ``t``, in the chain's sense (flipped joints not
    yet negated, angles not yet wrapped: :func:`~labkit.kinematics._ik_solvers._solve.finish`
    does that for every family).

A new family is one module with such a class and one line in
:data:`labkit.kinematics._ik_solvers._registry.FAMILIES`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

from labkit.kinematics._ik_solvers._geometry import NotThisFamily, joint_axes, _need_joints


#: the two branches of a planar elbow, and the names seeds 003/004 and roboticstoolbox use for them
ELBOWS = ("elbow_up", "elbow_down")
ELBOW_ALIASES = {"elbow_minus": "elbow_up", "elbow_plus": "elbow_down", "up": "elbow_up", "down": "elbow_down"}


class Family(ABC):
    """Base of the closed-form families (see the module docstring for the protocol)."""

    name = ""
    kind = ""
    branches = ()
    aliases = {}
    joints = 0
    prismatic = 0

    @classmethod
    def fits(cls, robot):
        """The family built on ``robot``'s geometry, or None and what the robot lacks.

        Parameters
        ----------
        robot : Robot

        Returns
        -------
        solver, reason : Family or None, str
            The family, or None and the reason.
        """
        try:
            _need_joints(robot, cls.joints, cls.prismatic)
            return cls(robot, *joint_axes(robot)), ""
        except NotThisFamily as exc:
            return None, str(exc)

    @abstractmethod
    def solve(self, t):
        """Every branch of targets ``t``: their components as ``(N,)`` rows (``t[i]``, a pose's ``t[i][j]``).

        Parameters
        ----------
        t : sequence

        Returns
        -------
        q, reachable, distance : list of tuple, list, ndarray (N,)
            Per branch the ``n`` joint values [rad, m] in the chain's sense and whether it reaches the
            target; how far the target lies out of reach [m].
        """


def _documented(method):
    """Give a family's method the docstring of the protocol's method of that name (a decorator)."""
    method.__doc__ = getattr(Family, method.__name__).__doc__
    return method
