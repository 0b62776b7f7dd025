"""Calibration parameters: their names and groups, nominal values, and a robot with them set (private).

The names (``offset[j]``, ``a[i]``, ``d[i]``, ``tool_x`` ... ``base_z``,
``sag[j]``) and groups are described in :mod:`labkit.measure._calibration`,
which fits them.
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np

from labkit.exceptions import MeasurementError
from labkit.robot import Robot
from labkit.validation import as_batch

GROUPS = ("joint_offsets", "link_lengths", "base_offset", "gravity_sag")
_NAME = re.compile(r"^(offset|a|d|sag)\[(\d+)\]$|^(tool|base)_([xyz])$")


def parameter_names(robot, params=("joint_offsets", "link_lengths")):
    """Expand groups into parameter names (order kept, duplicates dropped).

    Parameters
    ----------
    robot : Robot
        The nominal robot (decides which lengths are non-zero and which joints
        can sag).
    params : str or sequence of str
        Groups from ``GROUPS`` (``"joint_offsets"``, ``"link_lengths"``,
        ``"base_offset"``, ``"gravity_sag"``) and/or single names such as
        ``"offset[2]"``, ``"a[3]"``, ``"d[1]"``, ``"sag[2]"``, ``"tool_x"``,
        ``"base_z"`` (indices 1-based).

    Returns
    -------
    tuple of str
        Parameter names, e.g. ``('offset[1]', 'a[3]', 'tool_x')``.

    Raises
    ------
    MeasurementError
        An unknown group or name, or a joint index outside ``1..n``.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> parameter_names(Robot.load("arduino_arm_3dof"), ("joint_offsets", "link_lengths", "gravity_sag"))
    ('offset[1]', 'offset[2]', 'offset[3]', 'a[3]', 'tool_x', 'sag[2]', 'sag[3]')
    """
    robot = Robot.load(robot)
    if isinstance(params, str):
        params = (params,)
    if not isinstance(params, (list, tuple)):
        raise MeasurementError(f"expected params as a group name or a sequence of groups and names "
                               f"({', '.join(GROUPS)}, 'offset[1]' ...), got {params!r}")
    names = []
    for p in params:
        if p == "joint_offsets":
            names += [f"offset[{j + 1}]" for j in range(robot.n)]
        elif p == "link_lengths":
            for i, lk in enumerate(robot.links):
                if lk.a != 0:
                    names.append(f"a[{i + 1}]")
                if lk.is_revolute and lk.d != 0:
                    names.append(f"d[{i + 1}]")
            names += [f"tool_{ax}" for k, ax in enumerate("xyz") if robot.tool[k, 3] != 0]
        elif p == "base_offset":
            names += ["base_x", "base_y", "base_z"]
        elif p == "gravity_sag":
            z0 = _horizontal_axes(robot)
            names += [f"sag[{j + 1}]" for j in range(robot.n) if z0[j]]
        else:
            m = _NAME.match(str(p))
            if not m:
                raise MeasurementError(
                    f"unknown calibration parameter {p!r}; expected a group {GROUPS} or a name like "
                    "'offset[2]', 'a[3]', 'd[1]', 'sag[2]', 'tool_x', 'base_z'"
                )
            if m.group(1):
                idx = int(m.group(2))
                if not 1 <= idx <= robot.n:
                    raise MeasurementError(f"parameter {p!r}: expected an index 1..{robot.n}, got {idx}")
            names.append(str(p))
    return tuple(dict.fromkeys(names))


def _horizontal_axes(robot):
    from labkit.kinematics import fk_frames

    T = fk_frames(robot, np.zeros(robot.n))
    shift = 1 if robot.convention.value == "modified" else 0
    return [bool(robot.is_revolute[j]) and abs(T[j + shift, 2, 2]) < 0.5 for j in range(robot.n)]


def _slot(robot, name):
    """Where parameter ``name`` sits: (key of :func:`_numbers`, index), or None (a sag)."""
    m = _NAME.match(name) if isinstance(name, str) else None
    if m is None:
        raise MeasurementError(f"expected a parameter name such as 'offset[1]', 'a[2]', 'tool_x' or 'sag[2]', "
                               f"got {name!r}")
    if m.group(1) in ("offset", "a", "d"):
        i = int(m.group(2)) - 1
        if not 0 <= i < robot.n:
            raise MeasurementError(f"expected a joint index 1..{robot.n} in {name!r}, got {i + 1}")
        return ("theta" if robot.links[i].is_revolute else "d") if m.group(1) == "offset" else m.group(1), i
    return (f"{m.group(3)}_position", "xyz".index(m.group(4))) if m.group(3) else None


def _nominal(robot, name):
    slot = _slot(robot, name)
    if slot is None:
        return 0.0
    key, i = slot
    return getattr(robot.links[i], key) if key in ("theta", "a", "d") else float(getattr(robot, key[:4])[i, 3])


def apply_parameters(robot, names, values):
    """Copy of ``robot`` with the named parameters set (``sag`` entries ignored).

    Parameters
    ----------
    robot : Robot
        Robot to start from (not modified).
    names : sequence of str
        Parameter names as returned by :func:`parameter_names`.
    values : array_like, shape (len(names),)
        Parameter values in SI units: joint offsets [rad] (revolute) or [m]
        (prismatic), lengths and tool/base offsets [m].

    Returns
    -------
    Robot
    """
    robot = Robot.load(robot)
    if isinstance(names, str) or not isinstance(names, (list, tuple)):
        raise MeasurementError(f"expected names as a sequence of parameter names (parameter_names), got {names!r}")
    values = as_batch(values, (len(names),), "values (one per name)")
    if values.shape != (len(names),):
        raise MeasurementError(f"expected values with shape ({len(names)},), got {values.shape}")
    numbers = _numbers(robot, names, values)
    links = tuple(lk if (lk.theta, lk.a, lk.d) == row else dataclasses.replace(lk, theta=row[0], a=row[1], d=row[2])
                  for lk, row in zip(robot.links, zip(numbers["theta"], numbers["a"], numbers["d"])))
    frames = {}  # the tool and base transforms that change (the others stay the robot's, not checked again)
    for frame in ("base", "tool"):
        if numbers[f"{frame}_position"] is not None:
            T = frames[frame] = np.array(getattr(robot, frame))
            T[:3, 3] = numbers[f"{frame}_position"]
    return robot.replace(links=links, **frames)


def _numbers(robot, names, values):
    """The DH columns and base and tool translations with the named parameters set (``sag`` entries ignored).

    Returns
    -------
    dict
        ``theta``, ``a``, ``d`` (lists of n floats [rad, m]) and ``base_position``, ``tool_position``
        (3 floats [m], or None where no parameter names them): the keyword arguments of
        :func:`labkit.kinematics.fk_position_with`.
    """
    numbers = {field: [getattr(lk, field) for lk in robot.links] for field in ("theta", "a", "d")}
    numbers.update(base_position=None, tool_position=None)
    for name, v in zip(names, values):
        slot = _slot(robot, name)
        if slot is not None:
            key, i = slot
            if numbers[key] is None:
                numbers[key] = getattr(robot, key[:4])[:3, 3].tolist()
            numbers[key][i] = float(v)
    return numbers


def _position_derivatives(robot, names, values, q):
    """Tool positions and their derivatives with respect to the named parameters (``sag`` entries excluded).

    Read from the frames of the robot with the parameters set
    (:func:`labkit.kinematics.fk_frames_with`): a joint offset (DH theta) turns the
    distal chain about the joint axis ``z`` through its origin ``o``, so the tool
    point moves by ``z x (p - o)``; a DH ``d`` slides it along ``z``; a DH ``a``
    slides it along the ``x`` axis of the frame it is measured in (frame i in the
    standard convention, frame i-1 in the modified one); a tool translation along
    frame n's axes; a base translation along the world axes.

    Parameters
    ----------
    robot : Robot
    names : sequence of str
        Parameter names (:func:`parameter_names`), none of them a ``sag``.
    values : array_like, shape (len(names),)
        Parameter values in SI units.
    q : array_like, shape (P, n)
        Commanded joint values [rad, m].

    Returns
    -------
    positions : ndarray, shape (P, 3)
        Tool positions in the world frame [m].
    derivatives : ndarray, shape (P, 3, len(names))
        ``d position / d parameter`` [m/rad or 1].
    """
    from labkit.kinematics import fk_frames_with

    n = robot.n
    shift = 1 if robot.convention.value == "modified" else 0
    frame, axis, turn, base = [], [], [], []  # the direction of each column: an axis of a frame (of F below)
    for name in names:
        key, i = _slot(robot, name)
        turn.append(key == "theta")
        base.append(key == "base_position")
        frame.append(n if key == "tool_position" else (i + 1 - shift if key == "a" else i + shift))
        axis.append(i if key.endswith("position") else (0 if key == "a" else 2))
    # (P, n + 2, 4, 3): the columns (axes x, y, z and the origin) of every frame
    columns = fk_frames_with(robot, q, **_numbers(robot, names, values))[..., :3, :].swapaxes(-1, -2)
    direction = columns[:, frame, axis]  # (P, p, 3)
    tip = columns[:, n + 1, 3]
    if any(turn):  # z x (p - o), the cross product written out (np.cross costs more for a few vectors)
        z, lever = direction[:, turn], tip[:, None] - columns[:, np.array(frame)[turn], 3]
        direction[:, turn] = z[..., [1, 2, 0]] * lever[..., [2, 0, 1]] - z[..., [2, 0, 1]] * lever[..., [1, 2, 0]]
    if any(base):
        direction[:, base] = np.eye(3)[[i for b, i in zip(base, axis) if b]]
    return tip, direction.transpose(0, 2, 1)
