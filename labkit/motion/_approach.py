"""Approach points "above" an object, in world terms (the robot's ``up`` direction).

Private module: the names are re-exported by :mod:`labkit.motion`, import
them from there.

"Above" is not ``+z`` of the base frame on every arm: the seed 000 Arduino arm's
frame 0 has z pointing down, so ``pick + (0, 0, 0.05)`` lies 5 cm *below* the
object there. The robot file says which way is up (key ``up``, the
:attr:`~labkit.robot.Robot.up` attribute); these helpers build and test
heights along it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from labkit.exceptions import OptionError, ShapeError
from labkit.validation import as_batch, readonly

__all__ = ["height_above", "approach_point", "PickPlaceLeg", "pick_and_place_legs"]


def _up(robot):
    up = getattr(robot, "up", None)
    if up is None:
        raise OptionError(f"expected a Robot with an 'up' direction, got {robot!r}")
    return np.asarray(up, dtype=float)


def height_above(robot, points, reference=None):
    """Height of ``points`` along the robot's world up direction [m].

    Parameters
    ----------
    robot : Robot
        Supplies ``robot.up`` (unit vector, world coordinates).
    points : array_like, shape (..., 3)
        Positions in world coordinates (as :func:`labkit.kinematics.fk_position`
        returns them) [m].
    reference : array_like, shape (..., 3), optional
        Positions the height is measured from [m] (default the world origin).

    Returns
    -------
    ndarray, shape (...)
        ``(points - reference) . up`` [m]: positive above the reference.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> arm = Robot.load("arduino_arm_3dof")          # frame 0: z points down
    >>> round(float(height_above(arm, [0.1, 0.15, -0.25], reference=[0.1, 0.15, -0.20])), 6)
    0.05
    """
    p = as_batch(points, (3,), "points")
    if reference is not None:
        p = p - as_batch(reference, (3,), "reference")
    return p @ _up(robot)


def approach_point(robot, target, height):
    """The point ``height`` above ``target`` in world terms: ``target + height * robot.up`` [m].

    Parameters
    ----------
    robot : Robot
        Supplies ``robot.up`` (unit vector, world coordinates).
    target : array_like, shape (..., 3)
        Object positions in world coordinates [m].
    height : float or array_like, shape (...)
        Clearance above each target [m], positive.

    Returns
    -------
    ndarray, shape (..., 3)
        Approach points [m].

    Raises
    ------
    OptionError
        A height that is not a positive finite number.
    ShapeError
        ``height`` does not broadcast against the targets.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> arm = Robot.load("arduino_arm_3dof")
    >>> approach_point(arm, [0.10, 0.15, -0.20], 0.05)   # up is -z0 on this arm
    array([ 0.1 ,  0.15, -0.25])
    """
    p = as_batch(target, (3,), "target")
    h = as_batch(height, (), "height", finite=False)
    if not (np.all(np.isfinite(h)) and np.all(h > 0)):
        raise OptionError(f"expected a positive approach height [m], got {np.asarray(height).tolist()!r}")
    try:
        np.broadcast_shapes(h.shape, p.shape[:-1])
    except ValueError:
        raise ShapeError(f"expected height with shape () or {p.shape[:-1]}, got {h.shape}") from None
    return p + h[..., None] * _up(robot)


@dataclass(frozen=True, eq=False)
class PickPlaceLeg:
    """One straight leg of a two-stage pick and place.

    Attributes
    ----------
    label : str
        What the leg does (``"down to the object"`` ...).
    start, end : ndarray, shape (3,)
        Leg end points in world coordinates [m].
    gripper : {None, "close", "open"}
        Gripper action once the leg has arrived.
    """

    label: str
    start: np.ndarray
    end: np.ndarray
    gripper: Literal["close", "open"] | None = None


def pick_and_place_legs(robot, home, pick, place, height):
    """The seven straight legs of a two-stage pick and place, approaching from above.

    home -> above the object -> down to it (close) -> lift -> above the place ->
    down to it (open) -> lift -> home; "above" is ``height`` along ``robot.up``
    (:func:`approach_point`), so the legs that end at the object or the place descend.

    Parameters
    ----------
    robot : Robot
        Supplies ``robot.up``.
    home, pick, place : array_like, shape (3,)
        Start/end point, object and drop positions in world coordinates [m].
    height : float
        Clearance of the approach points above ``pick`` and ``place`` [m], positive.

    Returns
    -------
    list of PickPlaceLeg
        Seven legs, each starting where the previous one ended.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> arm = Robot.load("arduino_arm_3dof")
    >>> legs = pick_and_place_legs(arm, [0, 0.18, -0.094], [0.1, 0.15, -0.2], [-0.12, 0.14, -0.16], 0.05)
    >>> [leg.label for leg in legs][:3], legs[1].gripper
    (['home -> above the object', 'down to the object', 'lift'], 'close')
    >>> bool(height_above(arm, legs[1].start, legs[1].end) > 0)   # the down leg descends
    True
    """
    home, pick, place = (as_batch(p, (3,), name).reshape(3) for p, name in
                         ((home, "home"), (pick, "pick"), (place, "place")))
    above_pick, above_place = approach_point(robot, pick, height), approach_point(robot, place, height)
    points = [("home -> above the object", home, above_pick, None),
              ("down to the object", above_pick, pick, "close"),
              ("lift", pick, above_pick, None),
              ("above the place", above_pick, above_place, None),
              ("down to the place", above_place, place, "open"),
              ("lift", place, above_place, None),
              ("home", above_place, home, None)]
    return [PickPlaceLeg(label, readonly(a), readonly(b), grip) for label, a, b, grip in points]
