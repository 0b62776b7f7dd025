"""Measured-versus-calculated error tables and the published-table audit.

:func:`error_table` sets the readings of a measurement log (see
:mod:`labkit.measure`) beside what the robot model says: forward kinematics
for commanded joints (quantities ``x``, ``y``, ``z``), inverse kinematics for
commanded Cartesian targets (quantities ``theta<i>``). For every (pose,
quantity) it reports the mean of the repeats, their spread (half range and
standard deviation), the absolute and relative error, and whether the
calculated value lies inside the measurement uncertainty

    U = sqrt(resolution**2 + half_range**2)   (``combine="quadrature"``)
    U = resolution + half_range               (``combine="sum"``)

i.e. the instrument's reading uncertainty combined with the repeatability
(half range) of the readings; ``inside = |mean - calculated| <= U``.

:func:`audit_published` (defined in :mod:`labkit.measure`, re-exported here)
recomputes a table of published "calculated" values from the robot file and
flags those that disagree beyond the precision they were stated at (half a
unit in the last stated digit).

Examples
--------
>>> from labkit.data import measurement_file
>>> from labkit.measure import error_table, load_measurements
>>> df = load_measurements(measurement_file("seed000_fk_tables1-3.csv"))
>>> table = error_table("arduino_arm_3dof", df)
>>> row = table.table.query("pose_id == 't1_j1_5deg' and quantity == 'x'").iloc[0]
>>> round(float(row["calculated"]), 4), float(row["mean"]), float(row["half_range"])
(0.273, 0.28, 0.02)
"""

from __future__ import annotations

import math
import os
import warnings

import numpy as np

from labkit.rotations import wrap_angle
from labkit.exceptions import MeasurementError, UnreachableError
from labkit.validation import as_number

__all__ = ["COMBINE_RULES", "decimals_for_resolution"]

#: rules combining instrument resolution and half range into the uncertainty
COMBINE_RULES = ("quadrature", "sum")
_MODES = ("auto", "fk", "ik")


def decimals_for_resolution(resolution):
    """Decimal places that show a value down to the instrument resolution.

    The last shown digit is the place of the resolution's leading digit
    (0.0005 m -> 4, 0.5 deg -> 1, 1 mm -> 0).

    Parameters
    ----------
    resolution : float
        Instrument resolution, positive, in any unit (the same as the values).

    Returns
    -------
    int
        Number of decimals, at least 0.

    Raises
    ------
    MeasurementError
        ``resolution`` is not a positive finite number.

    Examples
    --------
    >>> decimals_for_resolution(0.0005), decimals_for_resolution(0.5), decimals_for_resolution(2.0)
    (4, 1, 0)
    """
    resolution = as_number(resolution, "resolution", positive=True, error=MeasurementError)
    return max(0, -math.floor(math.log10(resolution) + 1e-12))


def _frame(data, loader, required):
    """DataFrame from a path (via ``loader``) or a user-built frame, optional columns filled in."""
    import pandas as pd

    if not isinstance(data, pd.DataFrame):
        if not isinstance(data, (str, os.PathLike)):
            raise MeasurementError(f"expected measurements as a DataFrame or the path of a CSV file, got "
                                   f"{type(data).__name__} (the robot comes first: f(robot, measurements))")
        return loader(data)
    missing = [c for c in ("pose_id", "quantity", *required) if c not in data]
    if missing:
        raise MeasurementError(f"expected the column(s) {missing}; found {list(data.columns)}")
    df = data.reset_index(drop=True).copy()
    defaults = {"line": np.arange(len(df)) + 2, "half_range": np.nan, "n_readings": 1,
                "commanded": None, "target": None, "precision": "", "table": "", "robot": ""}
    for col, value in defaults.items():
        if col not in df:
            df[col] = pd.Series([value] * len(df), dtype=object) if value is None or col == "line" else value
    for col in ("commanded", "target"):
        df[col] = pd.Series([_as_tuple(v) for v in df[col]], dtype=object, index=df.index)
    return df


def _as_tuple(v):
    if v is None or (np.ndim(v) == 0 and isinstance(v, float) and math.isnan(v)):
        return None
    return tuple(float(x) for x in np.asarray(v, dtype=float).reshape(-1))


def _robot(robot, df):
    from labkit.robot import Robot

    if robot is None:
        names = sorted({r for r in df.get("robot", []) if isinstance(r, str) and r})
        if len(names) != 1:
            raise MeasurementError(f"expected one robot name in the measurements (or a robot argument), got {names}")
        robot = names[0]
    return Robot.load(robot)


def _joint_index(quantity, robot, line):
    i = int(quantity[5:] if quantity.startswith("theta") else quantity[1:]) - 1
    if i >= robot.n:
        raise MeasurementError(f"quantity {quantity!r} names joint {i + 1} but {robot.name} has {robot.n} joints", line=line, column="quantity")
    want_revolute = quantity.startswith("theta")
    if bool(robot.is_revolute[i]) != want_revolute:
        raise MeasurementError(f"joint {i + 1} of {robot.name} is {'revolute' if robot.is_revolute[i] else 'prismatic'}; "
                   f"use quantity {'theta' if robot.is_revolute[i] else 'd'}{i + 1}", line=line, column="quantity")
    return i


def calculated_si(df, robot, *, mode="auto", branch=None):
    """Model value [m, rad] of every row's quantity at its pose.

    Rows with ``commanded`` joints use forward kinematics (x, y, z from FK;
    theta<i>/d<i> are the commanded joint values); rows with only a
    ``target`` use inverse kinematics (theta<i>/d<i> from
    ``labkit.kinematics.ik(robot, target, branch=branch)``; x, y, z are the target).

    Parameters
    ----------
    df : pandas.DataFrame
        Measurement rows (``quantity``, ``commanded``, ``target`` columns, as
        loaded by :func:`labkit.measure.load_measurements`).
    robot : Robot
        The model.
    mode : {"auto", "fk", "ik"}
        ``"auto"``: FK where a row has commanded joints, else IK; ``"fk"``
        requires commanded joints; ``"ik"`` uses the targets.
    branch : str, optional
        IK branch for target rows; default the first branch that reaches
        the target (:func:`labkit.kinematics.ik`).

    Returns
    -------
    ndarray, shape (len(df),)
    """
    from labkit.kinematics import fk_position

    if not isinstance(mode, str) or mode not in _MODES:
        raise MeasurementError(f"unknown mode {mode!r}; expected one of {_MODES}")
    if branch is not None and not isinstance(branch, str):
        raise MeasurementError(f"expected branch as an IK branch name (or None: the first that reaches), got {branch!r}")
    lines = df["line"].tolist() if "line" in df else [i + 2 for i in range(len(df))]
    out = np.empty(len(df))
    cache = {}
    for k, (cmd, tgt, quantity, line) in enumerate(zip(df["commanded"], df["target"], df["quantity"], lines)):
        use_fk = cmd is not None and mode != "ik"
        if mode == "fk" and cmd is None:
            raise MeasurementError("expected commanded joint values for an FK table, got an empty cell", line=line, column="commanded")
        if not use_fk and tgt is None:
            col = "target" if mode == "ik" else "commanded"
            raise MeasurementError("expected commanded joints or a target for this pose, got neither", line=line, column=col)
        key = ("fk", cmd) if use_fk else ("ik", tgt)
        if key not in cache:
            if use_fk:
                if len(cmd) != robot.n:
                    raise MeasurementError(f"expected {robot.n} commanded joint values, got {len(cmd)}", line=line, column="commanded")
                q = np.asarray(cmd)
                cache[key] = (q, fk_position(robot, q))
            else:
                target, pos = _target_and_position(robot, tgt, line)
                cache[key] = (_ik_ignoring_limits(robot, target, branch, line), pos)
        q, pos = cache[key]
        if quantity in ("x", "y", "z"):
            if np.isnan(pos["xyz".index(quantity)]):
                raise MeasurementError(f"target {tgt} has no {quantity} component", line=line, column="target")
            out[k] = pos["xyz".index(quantity)]
        else:
            out[k] = q[_joint_index(quantity, robot, line)]
    return out


def _target_and_position(robot, tgt, line):
    """IK target array and its (x, y, z) [m] (NaN where the target has no such component)."""
    from labkit.kinematics import target_kind

    kind = target_kind(robot)
    t = np.asarray(tgt, dtype=float)
    if kind == "pose":
        if t.size != 16:
            raise MeasurementError(f"expected a 4x4 pose target (16 numbers, row-major) for {robot.name}, got {t.size}", line=line, column="target")
        t = t.reshape(4, 4)
        return t, t[:3, 3]
    if t.size != 3:
        want = "(x, y, phi)" if kind == "planar" else "(x, y, z)"
        raise MeasurementError(f"expected a target {want} for {robot.name}, got {t.size} numbers", line=line, column="target")
    return t, (np.array([t[0], t[1], np.nan]) if kind == "planar" else t)


def _ik_ignoring_limits(robot, target, branch, line):
    """``labkit.kinematics.ik`` of one target; a solution outside the joint limits is still returned.

    The model's calculated angle is compared with what was measured or
    published even where the servo could not go (a warning says so).
    """
    from labkit.exceptions import JointLimitError
    from labkit.kinematics import ik, ik_all

    try:
        return np.asarray(ik(robot, target, branch=branch), dtype=float)
    except JointLimitError as exc:
        sols = ik_all(robot, target)
        if branch is None:  # the first branch that reaches the target, limits ignored
            reaching = [b for b, ok in zip(sols.branches, np.asarray(sols.reachable).reshape(-1)) if ok]
            branch = reaching[0] if reaching else None
        if branch not in sols.branches:
            raise MeasurementError(f"IK of target {tuple(float(v) for v in target.reshape(-1))} failed: {exc}", line=line, column="target") from None
        k = sols.branches.index(branch)
        warnings.warn(f"row {line}: target {tuple(float(v) for v in target.reshape(-1))} is reachable only outside the joint limits ({exc})",
                      UserWarning, stacklevel=4)
        return np.asarray(sols.q[..., k, :], dtype=float)
    except (UnreachableError, ValueError) as exc:
        raise MeasurementError(f"IK of target {tuple(float(v) for v in target.reshape(-1))} failed: {exc}", line=line, column="target") from None


def _wrap_deg_or_rad(x, unit):
    """Wrap angles given in ``unit`` ("deg" or "rad") to half a turn either side of zero."""
    if unit == "deg":
        return np.degrees(wrap_angle(np.radians(x)))
    return wrap_angle(x)


def _command_text(cmd, tgt, robot=None):
    if cmd is not None and robot is not None and not all(robot.is_revolute) and len(cmd) == robot.n:
        # a prismatic joint in mm, not its metres read as radians
        return "q = (" + ", ".join(f"{math.degrees(v) if rev else v * 1000.0:g} {'deg' if rev else 'mm'}"
                                   for v, rev in zip(cmd, robot.is_revolute)) + ")"
    if cmd is not None:
        return "q = (" + ", ".join(f"{math.degrees(v):g}" for v in cmd) + ") deg"
    if tgt is not None:
        return "target = (" + ", ".join(f"{v:g}" for v in tgt) + ") m"
    return ""
