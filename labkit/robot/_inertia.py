"""Inertial data of a link: mass, centre of mass, inertia tensor, and the motor behind the joint.

Both are frozen leaf types held by :class:`~labkit.robot.Link` (fields ``inertial`` and
``motor``); :func:`lump` adds rigid bodies together (the parallel-axis theorem, written once),
used by URDF import and :meth:`~labkit.robot.Robot.with_payload`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from labkit.exceptions import RobotError
from labkit.validation import as_batch

__all__ = ["LinkInertia", "Motor", "lump"]

#: relative tolerance on the smallest eigenvalue of an inertia tensor (rounding in published tables)
_PSD_TOL = 1e-9


def _number(owner, field, value):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value):
        raise RobotError(f"{owner}: field '{field}': expected a finite number, got {value!r}", field)
    return float(value)


def _numbers(owner, field, value, k):
    try:
        items = list(value)
    except TypeError:
        raise RobotError(f"{owner}: field '{field}': expected a list of {k} numbers, got {value!r}", field) from None
    if len(items) != k:
        raise RobotError(f"{owner}: field '{field}': expected a list of {k} numbers, got {value!r}", field)
    return tuple(_number(owner, field, v) for v in items)


@dataclass(frozen=True)
class LinkInertia:
    """Mass, centre of mass and inertia tensor of the link that joint i moves, in frame i.

    Frame i is the DH frame that moves with joint i in the robot's convention (as
    roboticstoolbox's ``Link.r`` and ``Link.I``).

    Attributes
    ----------
    mass : float
        Mass [kg], >= 0.
    com : tuple of float, shape (3,)
        Centre of mass in frame i [m].
    inertia : tuple of float, shape (6,)
        ``(Ixx, Iyy, Izz, Ixy, Iyz, Ixz)`` about the centre of mass, axes of frame i
        [kg m^2]; the tensor must be positive semi-definite.

    Raises
    ------
    RobotError
        A negative mass, a non-finite number, or a tensor that is not positive semi-definite.

    Examples
    --------
    >>> LinkInertia(2.0, (0.1, 0, 0), (0.01, 0.02, 0.02, 0, 0, 0)).matrix.tolist()[0]
    [0.01, 0.0, 0.0]
    """

    mass: float
    com: tuple = (0.0, 0.0, 0.0)
    inertia: tuple = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    def __post_init__(self):
        owner = "LinkInertia"
        m = _number(owner, "mass", self.mass)
        if m < 0:
            raise RobotError(f"{owner}: field 'mass': expected a mass >= 0 kg, got {m:g}", "mass")
        object.__setattr__(self, "mass", m)
        object.__setattr__(self, "com", _numbers(owner, "com", self.com, 3))
        object.__setattr__(self, "inertia", _numbers(owner, "inertia", self.inertia, 6))
        eig = np.linalg.eigvalsh(self.matrix)
        if eig[0] < -_PSD_TOL * max(1.0, float(abs(eig).max())):
            raise RobotError(f"{owner}: field 'inertia': expected a positive semi-definite tensor "
                             f"[Ixx, Iyy, Izz, Ixy, Iyz, Ixz], got {list(self.inertia)} (eigenvalues "
                             f"{', '.join(f'{v:.3g}' for v in eig)})", "inertia")

    @property
    def matrix(self):
        """The inertia tensor about the centre of mass, shape (3, 3) [kg m^2]."""
        xx, yy, zz, xy, yz, xz = self.inertia
        return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])

    @classmethod
    def from_matrix(cls, mass, com, matrix):
        """Build from a (3, 3) tensor about the centre of mass (symmetrised).

        Parameters
        ----------
        mass : float
            Mass [kg].
        com : array_like, shape (3,)
            Centre of mass [m].
        matrix : array_like, shape (3, 3)
            Inertia tensor about the centre of mass [kg m^2].

        Returns
        -------
        LinkInertia
        """
        I = as_batch(matrix, (3, 3), "LinkInertia: field 'inertia' (a (3, 3) tensor)", finite=False)
        if I.shape != (3, 3):
            raise RobotError(f"LinkInertia: field 'inertia': expected a (3, 3) tensor, got shape {I.shape}", "inertia")
        I = 0.5 * (I + I.T)
        return cls(mass, _numbers("LinkInertia", "com", com, 3),
                   (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[1, 2], I[0, 2]))


def lump(bodies):
    """One rigid body equal to several rigidly joined ones (parallel-axis theorem).

    Parameters
    ----------
    bodies : iterable of (LinkInertia, ndarray (4, 4))
        Each body and the transform from the common frame to the frame its ``com`` and
        ``inertia`` are given in [m].

    Returns
    -------
    LinkInertia
        In the common frame (mass 0 at the origin if every mass is 0).

    Examples
    --------
    >>> two = lump([(LinkInertia(1.0, (1, 0, 0)), np.eye(4)), (LinkInertia(1.0, (-1, 0, 0)), np.eye(4))])
    >>> two.mass, two.com, two.inertia
    (2.0, (0.0, 0.0, 0.0), (0.0, 2.0, 2.0, 0.0, 0.0, 0.0))
    """
    parts = []
    for body, T in bodies:
        T = np.asarray(T, dtype=float)
        R = T[:3, :3]
        parts.append((body.mass, T[:3, 3] + R @ np.array(body.com), R @ body.matrix @ R.T))
    mass = sum(m for m, _, _ in parts)
    com = sum(m * c for m, c, _ in parts) / mass if mass > 0 else np.zeros(3)
    total = np.zeros((3, 3))
    for m, c, I in parts:
        r = c - com
        total += I + m * (float(r @ r) * np.eye(3) - np.outer(r, r))
    return LinkInertia.from_matrix(mass, com, total)


@dataclass(frozen=True)
class Motor:
    """The motor and gearbox driving a joint (roboticstoolbox's ``Jm``, ``G``, ``B``, ``Tc``).

    All values are at the motor side of the gear and reflected to the joint the way
    roboticstoolbox does it: armature ``G^2 Jm`` adds to the joint's inertia, friction at the
    joint is ``G^2 B qd + |G| Tc`` (``Tc`` = ``coulomb[0]`` when ``qd > 0``, ``coulomb[1]``
    when ``qd < 0``, none at rest).

    Attributes
    ----------
    inertia : float
        Rotor inertia ``Jm`` [kg m^2], >= 0.
    gear_ratio : float
        Motor turns per joint turn ``G`` (sign allowed, not 0).
    viscous : float
        Viscous friction ``B`` at the motor [N m s/rad], >= 0.
    coulomb : tuple of float
        Coulomb friction ``(plus, minus)`` at the motor [N m]: the friction torque when the
        joint moves forwards (>= 0) and backwards (<= 0).

    Examples
    --------
    >>> Motor(inertia=2e-4, gear_ratio=-62.6, viscous=1.5e-3, coulomb=(0.4, -0.43)).gear_ratio
    -62.6
    """

    inertia: float = 0.0
    gear_ratio: float = 1.0
    viscous: float = 0.0
    coulomb: tuple = (0.0, 0.0)

    def __post_init__(self):
        owner = "Motor"
        for field in ("inertia", "gear_ratio", "viscous"):
            object.__setattr__(self, field, _number(owner, field, getattr(self, field)))
        if self.inertia < 0 or self.viscous < 0:
            field = "inertia" if self.inertia < 0 else "viscous"
            raise RobotError(f"{owner}: field '{field}': expected a value >= 0, got {getattr(self, field):g}", field)
        if self.gear_ratio == 0:
            raise RobotError(f"{owner}: field 'gear_ratio': expected a non-zero ratio, got 0", "gear_ratio")
        plus, minus = _numbers(owner, "coulomb", self.coulomb, 2)
        if plus < 0 or minus > 0:
            raise RobotError(f"{owner}: field 'coulomb': expected [plus >= 0, minus <= 0] N m, got "
                             f"[{plus:g}, {minus:g}]", "coulomb")
        object.__setattr__(self, "coulomb", (plus, minus))
