"""Measured-versus-calculated error tables and the published-table audit.

:func:`error_table` sets the readings of a measurement log (see
:mod:`labkit.measurement`) beside what the robot model says: forward kinematics
for commanded joints (quantities ``x``, ``y``, ``z``), inverse kinematics for
commanded Cartesian targets (quantities ``theta<i>``). For every (pose,
quantity) it reports the mean of the repeats, their spread (half range and
standard deviation), the absolute and relative error, and whether the
calculated value lies inside the measurement uncertainty

    U = sqrt(resolution**2 + half_range**2)   (``combine="quadrature"``)
    U = resolution + half_range               (``combine="sum"``)

i.e. the instrument's reading uncertainty combined with the repeatability
(half range) of the readings; ``inside = |mean - calculated| <= U``.

:func:`audit_published` (defined in :mod:`labkit.audit`, re-exported here)
recomputes a table of published "calculated" values from the robot file and
flags those that disagree beyond the precision they were stated at (half a
unit in the last stated digit).

Examples
--------
>>> from labkit.measurement import load_measurements
>>> df = load_measurements(seed_path("seed000_fk_tables1-3.csv"))
>>> table = error_table(df, "arduino_arm_3dof")
>>> row = table.table.query("pose_id == 't1_j1_5deg' and quantity == 'x'").iloc[0]
>>> round(float(row["calculated"]), 4), float(row["mean"]), float(row["half_range"])
(0.273, 0.28, 0.02)
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path

import numpy as np

from labkit.audit import AuditResult, _add_audit_cli, audit_published, load_published
from labkit.exceptions import MeasurementError, UnreachableError
from labkit.measurement import UNITS, load_measurements, quantity_dimension

__all__ = [
    "ErrorTable",
    "AuditResult",
    "error_table",
    "fk_error_table",
    "ik_error_table",
    "audit_published",
    "load_published",
    "decimals_for_resolution",
    "seed_path",
]

#: rules combining instrument resolution and half range into the uncertainty
_COMBINE = ("quadrature", "sum")
_MODES = ("auto", "fk", "ik")
DATA_DIR = Path(__file__).resolve().parent.parent / "data" / "measurements"


def seed_path(name):
    """Path of a bundled measurement file in ``data/measurements/``.

    Parameters
    ----------
    name : str
        File name, e.g. ``"seed000_published_calculated.csv"``.

    Returns
    -------
    pathlib.Path
        The path (not checked for existence).
    """
    return DATA_DIR / name


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
    resolution = float(resolution)
    if not math.isfinite(resolution) or resolution <= 0:
        raise MeasurementError(f"expected a positive finite resolution, got {resolution!r}")
    return max(0, -math.floor(math.log10(resolution) + 1e-12))


def _fixed(decimals):
    def fmt(v):
        return f"{round(float(v), decimals) + 0.0:.{decimals}f}"

    return fmt


def _err(message, line=None, column=None):
    where = []
    if line is not None:
        where.append(f"row {line}")
    if column is not None:
        where.append(f"column '{column}'")
    exc = MeasurementError(", ".join(where) + ": " + message if where else message)
    exc.row, exc.column = line, column
    return exc


def _frame(data, loader, required):
    """DataFrame from a path (via ``loader``) or a user-built frame, optional columns filled in."""
    import pandas as pd

    if not isinstance(data, pd.DataFrame):
        return loader(data)
    missing = [c for c in ("pose_id", "quantity", *required) if c not in data]
    if missing:
        raise MeasurementError(f"missing column(s) {missing}; found {list(data.columns)}")
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
    from labkit.dh import Robot

    if robot is None:
        names = sorted({r for r in df.get("robot", []) if isinstance(r, str) and r})
        if len(names) != 1:
            raise MeasurementError(f"expected one robot name in the measurements (or a robot argument), got {names}")
        robot = names[0]
    return Robot.load(robot)


def _joint_index(quantity, robot, line):
    i = int(quantity[5:] if quantity.startswith("theta") else quantity[1:]) - 1
    if i >= robot.n:
        raise _err(f"quantity {quantity!r} names joint {i + 1} but {robot.name} has {robot.n} joints",
                   line, "quantity")
    want_revolute = quantity.startswith("theta")
    if bool(robot.is_revolute[i]) != want_revolute:
        raise _err(f"joint {i + 1} of {robot.name} is {'revolute' if robot.is_revolute[i] else 'prismatic'}; "
                   f"use quantity {'theta' if robot.is_revolute[i] else 'd'}{i + 1}", line, "quantity")
    return i


def calculated_si(df, robot, *, mode="auto", branch="elbow_up"):
    """Model value [m, rad] of every row's quantity at its pose.

    Rows with ``commanded`` joints use forward kinematics (x, y, z from FK;
    theta<i>/d<i> are the commanded joint values); rows with only a
    ``target`` use inverse kinematics (theta<i>/d<i> from
    ``labkit.ik.ik(robot, target, branch=branch)``; x, y, z are the target).

    Returns
    -------
    ndarray, shape (len(df),)
    """
    from labkit.kinematics import fk_position

    if mode not in _MODES:
        raise MeasurementError(f"unknown mode {mode!r}; expected one of {_MODES}")
    lines = df["line"].tolist() if "line" in df else [i + 2 for i in range(len(df))]
    out = np.empty(len(df))
    cache = {}
    for k, (cmd, tgt, quantity, line) in enumerate(zip(df["commanded"], df["target"], df["quantity"], lines)):
        use_fk = cmd is not None and mode != "ik"
        if mode == "fk" and cmd is None:
            raise _err("expected commanded joint values for an FK table, got an empty cell", line, "commanded")
        if not use_fk and tgt is None:
            col = "target" if mode == "ik" else "commanded"
            raise _err("expected commanded joints or a target for this pose, got neither", line, col)
        key = ("fk", cmd) if use_fk else ("ik", tgt)
        if key not in cache:
            if use_fk:
                if len(cmd) != robot.n:
                    raise _err(f"expected {robot.n} commanded joint values, got {len(cmd)}", line, "commanded")
                q = np.asarray(cmd)
                cache[key] = (q, fk_position(robot, q))
            else:
                target, pos = _target_and_position(robot, tgt, line)
                cache[key] = (_ik_ignoring_limits(robot, target, branch, line), pos)
        q, pos = cache[key]
        if quantity in ("x", "y", "z"):
            if np.isnan(pos["xyz".index(quantity)]):
                raise _err(f"target {tgt} has no {quantity} component", line, "target")
            out[k] = pos["xyz".index(quantity)]
        else:
            out[k] = q[_joint_index(quantity, robot, line)]
    return out


def _target_and_position(robot, tgt, line):
    """IK target array and its (x, y, z) [m] (NaN where the target has no such component)."""
    from labkit.ik import target_kind

    kind = target_kind(robot)
    t = np.asarray(tgt, dtype=float)
    if kind == "pose":
        if t.size != 16:
            raise _err(f"expected a 4x4 pose target (16 numbers, row-major) for {robot.name}, got {t.size}",
                       line, "target")
        t = t.reshape(4, 4)
        return t, t[:3, 3]
    if t.size != 3:
        want = "(x, y, phi)" if kind == "planar" else "(x, y, z)"
        raise _err(f"expected a target {want} for {robot.name}, got {t.size} numbers", line, "target")
    return t, (np.array([t[0], t[1], np.nan]) if kind == "planar" else t)


def _ik_ignoring_limits(robot, target, branch, line):
    """``labkit.ik.ik`` of one target; a solution outside the joint limits is still returned.

    The model's calculated angle is compared with what was measured or
    published even where the servo could not go (a warning says so).
    """
    from labkit.exceptions import JointLimitError
    from labkit.ik import ik, ik_all

    try:
        return np.asarray(ik(robot, target, branch=branch), dtype=float)
    except JointLimitError as exc:
        sols = ik_all(robot, target)
        if branch not in sols.branches:
            raise _err(f"IK of target {tuple(float(v) for v in target.reshape(-1))} failed: {exc}", line, "target") from None
        k = sols.branches.index(branch)
        warnings.warn(f"row {line}: target {tuple(float(v) for v in target.reshape(-1))} is reachable only outside the joint limits ({exc})",
                      UserWarning, stacklevel=4)
        return np.asarray(sols.q[..., k, :], dtype=float)
    except (UnreachableError, ValueError) as exc:
        raise _err(f"IK of target {tuple(float(v) for v in target.reshape(-1))} failed: {exc}", line, "target") from None


def _wrap_deg_or_rad(x, unit):
    period = 360.0 if unit == "deg" else 2 * math.pi
    return (np.asarray(x) + period / 2) % period - period / 2


def _command_text(cmd, tgt):
    if cmd is not None:
        return "q = (" + ", ".join(f"{math.degrees(v):g}" for v in cmd) + ") deg"
    if tgt is not None:
        return "target = (" + ", ".join(f"{v:g}" for v in tgt) + ") m"
    return ""


@dataclasses.dataclass(frozen=True)
class ErrorTable:
    """Measured-versus-calculated table, one row per (pose, quantity).

    Attributes
    ----------
    table : pandas.DataFrame
        Columns ``pose_id, quantity, command, unit, calculated, mean, n,
        half_range, std, resolution, uncertainty, error, abs_error, rel_error,
        inside`` (values in ``unit``, the unit the readings were taken in;
        ``error = mean - calculated``, wrapped to (-180, 180] deg for angles;
        ``rel_error = abs_error / |calculated|``, NaN where ``|calculated|`` is
        below the resolution).
    summary : pandas.DataFrame
        Per quantity: ``unit, n_poses, rms_error, max_abs_error, mean_error,
        n_inside``.
    combine : str
        Rule that combined resolution and half range into ``uncertainty``.
    """

    table: object
    summary: object
    combine: str = "quadrature"

    def per_quantity(self):
        """Dict quantity -> DataFrame indexed by pose_id.

        Returns
        -------
        dict of str to pandas.DataFrame
            Rows of :attr:`table` for each quantity (in table order), without the
            ``quantity`` column.
        """
        return {q: g.set_index("pose_id").drop(columns="quantity")
                for q, g in self.table.groupby("quantity", sort=False)}

    def to_dataframe(self):
        """The long table (a copy).

        Returns
        -------
        pandas.DataFrame
            Copy of :attr:`table`.
        """
        return self.table.copy()

    def wide(self):
        """Report layout: one row per pose, per quantity calculated / measured / ± / error.

        Two summary rows ("RMS", "max abs. error") close the table.

        Returns
        -------
        pandas.DataFrame
            Two-level columns ``("pose", "command")`` then
            ``("<quantity> [<unit>]", "calculated" | "measured" | "±" | "error")``,
            in the units the readings were taken in.
        """
        import pandas as pd

        pieces = {}
        quantities = list(dict.fromkeys(self.table["quantity"]))
        for q in quantities:
            g = self.table[self.table["quantity"] == q].set_index("pose_id")
            unit = g["unit"].iloc[0]
            pieces[(f"{q} [{unit}]", "calculated")] = g["calculated"]
            pieces[(f"{q} [{unit}]", "measured")] = g["mean"]
            pieces[(f"{q} [{unit}]", "±")] = g["half_range"]
            pieces[(f"{q} [{unit}]", "error")] = g["error"]
        wide = pd.DataFrame(pieces)
        wide.columns = pd.MultiIndex.from_tuples(wide.columns)
        command = self.table.drop_duplicates("pose_id").set_index("pose_id")["command"]
        wide.insert(0, ("pose", "command"), command.reindex(wide.index))
        rms = {}
        mx = {}
        for q in quantities:
            s = self.summary.loc[q]
            key = (f"{q} [{s['unit']}]", "error")
            rms[key] = s["rms_error"]
            mx[key] = s["max_abs_error"]
        summary = pd.DataFrame([rms, mx], index=["RMS", "max abs. error"])
        summary.columns = pd.MultiIndex.from_tuples(summary.columns)
        return pd.concat([wide, summary.reindex(columns=wide.columns)])

    def style(self, *, tolerance=None, highlight="background-color: #f8c4c4", escape=None, caption=None):
        """A pandas Styler of :meth:`wide` for reports.

        Numbers are shown to the decimal place of the instrument resolution
        (:func:`decimals_for_resolution`); the measured and error cells of
        readings whose calculated value lies outside the measurement
        uncertainty (or, with ``tolerance``, whose ``|error|`` exceeds it) are
        highlighted.

        Parameters
        ----------
        tolerance : float or mapping, optional
            Maximum acceptable ``|error|`` in SI units (m, rad), one value or
            ``{quantity: value}``; default: the measurement uncertainty.
        highlight : str
            CSS of an out-of-tolerance cell.
        escape : {None, "html", "latex"}
            Escaping of text cells and labels (``to_latex`` uses "latex").
        caption : str, optional
            Table caption.

        Returns
        -------
        pandas.io.formats.style.Styler
        """
        import pandas as pd

        wide = self.wide()
        css = pd.DataFrame("", index=wide.index, columns=wide.columns)
        formatters = {}
        for q, g in self.table.groupby("quantity", sort=False):
            unit = g["unit"].iloc[0]
            top = f"{q} [{unit}]"
            dec = decimals_for_resolution(g["resolution"].min())
            for field in ("calculated", "measured", "±", "error"):
                formatters[(top, field)] = _fixed(dec)
            if tolerance is None:
                bad = ~g["inside"].to_numpy(bool)
            else:
                tol = tolerance.get(q, np.inf) if isinstance(tolerance, dict) else tolerance
                bad = g["abs_error"].to_numpy(float) * UNITS[unit][1] > float(tol)
            for pose in g["pose_id"][bad]:
                css.loc[pose, (top, "measured")] = highlight
                css.loc[pose, (top, "error")] = highlight
        styler = wide.style.set_caption(caption) if caption else wide.style
        return (styler.format(formatters, na_rep="", escape=escape)
                .format_index(escape=escape, axis=0)
                .format_index(escape=escape, axis=1)
                .apply(lambda _: css, axis=None))

    def to_html(self, path=None, **style_kwargs):
        """HTML of :meth:`style` (written to ``path`` if given).

        Parameters
        ----------
        path : str or os.PathLike, optional
            File to write; nothing is written if omitted.
        **style_kwargs
            Passed to :meth:`style` (``tolerance``, ``highlight``, ``caption``).

        Returns
        -------
        str
            The HTML table.
        """
        html = self.style(escape="html", **style_kwargs).to_html()
        if path is not None:
            Path(path).write_text(html)
        return html

    def to_latex(self, path=None, **style_kwargs):
        r"""LaTeX of :meth:`style` (``\cellcolor`` highlights need ``xcolor``/``colortbl``).

        Parameters
        ----------
        path : str or os.PathLike, optional
            File to write; nothing is written if omitted.
        **style_kwargs
            Passed to :meth:`style` (``tolerance``, ``highlight``, ``caption``).

        Returns
        -------
        str
            The LaTeX ``tabular`` (with ``\cellcolor`` for highlighted cells).
        """
        tex = self.style(escape="latex", **style_kwargs).to_latex(convert_css=True, hrules=True,
                                                 multicol_align="c")
        if path is not None:
            Path(path).write_text(tex)
        return tex


def error_table(measurements, robot=None, *, mode="auto", branch="elbow_up", combine="quadrature"):
    """Measured-versus-calculated error table.

    Parameters
    ----------
    measurements : pandas.DataFrame or str or os.PathLike
        Readings (:func:`labkit.measurement.load_measurements` or its path).
    robot : Robot or str, optional
        Robot model; default: the one named in the measurements.
    mode : {"auto", "fk", "ik"}
        "fk" needs commanded joints on every row, "ik" uses targets, "auto"
        uses commanded joints where present, else the target.
    branch : str
        IK branch for targets (default ``"elbow_up"``, as in seed 000).
    combine : {"quadrature", "sum"}
        How resolution and half range combine into the uncertainty.

    Returns
    -------
    ErrorTable

    Raises
    ------
    MeasurementError
        Naming the row and column of a reading that cannot be compared: no
        commanded joints/target, unreachable target, inconsistent pose,
        raw readings mixed with a summary row.
    """
    import pandas as pd

    if combine not in _COMBINE:
        raise MeasurementError(f"unknown combine rule {combine!r}; expected one of {_COMBINE}")
    df = _frame(measurements, load_measurements, ("value", "resolution", "unit"))
    if not len(df):
        raise MeasurementError("expected at least one reading, got an empty table")
    robot = _robot(robot, df)
    calc_si = calculated_si(df, robot, mode=mode, branch=branch)
    lines = df["line"].tolist() if "line" in df else [i + 2 for i in range(len(df))]
    rows = []
    for (pose, quantity), idx in df.groupby(["pose_id", "quantity"], sort=False).indices.items():
        g = df.iloc[idx]
        first = idx[0]
        unit = g["unit"].iloc[0]
        factor = UNITS[unit][1]
        for k in idx[1:]:
            if df["commanded"].iloc[k] != df["commanded"].iloc[first] or df["target"].iloc[k] != df["target"].iloc[first]:
                raise _err(f"pose {pose!r} was logged with different commanded joints/targets", lines[k], "commanded")
        values = np.array([v * UNITS[u][1] / factor for v, u in zip(g["value"], g["unit"])])
        res = np.array([v * UNITS[u][1] / factor for v, u in zip(g["resolution"], g["unit"])])
        half = np.array([v * UNITS[u][1] / factor for v, u in zip(g["half_range"], g["unit"])])
        summary_rows = ~np.isnan(half)
        if summary_rows.any():
            if len(g) > 1:
                k = idx[int(np.argmax(summary_rows))] if summary_rows.sum() == 1 else idx[1]
                raise _err(f"pose {pose!r}, quantity {quantity!r}: a summary row (half_range given) must be "
                           f"the only row of its pose and quantity, got {len(g)} rows", lines[k], "half_range")
            mean, hr, std, n = values[0], half[0], float("nan"), int(g["n_readings"].iloc[0])
        else:
            mean = values.mean()
            hr = (values.max() - values.min()) / 2
            std = values.std(ddof=1) if len(values) > 1 else float("nan")
            n = len(values)
        calc = calc_si[first] / factor
        error = mean - calc
        if quantity_dimension(quantity) == "angle":
            error = float(_wrap_deg_or_rad(error, unit))
        resolution = res.max()
        u = math.hypot(resolution, hr) if combine == "quadrature" else resolution + hr
        rel = abs(error) / abs(calc) if abs(calc) >= resolution else float("nan")
        rows.append(dict(
            pose_id=pose, quantity=quantity,
            command=_command_text(df["commanded"].iloc[first], df["target"].iloc[first]),
            unit=unit, calculated=calc, mean=mean, n=n, half_range=hr, std=std,
            resolution=resolution, uncertainty=u, error=error, abs_error=abs(error),
            rel_error=rel, inside=bool(abs(error) <= u * (1 + 1e-9)),
        ))
    table = pd.DataFrame(rows)
    summary = pd.DataFrame([
        dict(quantity=q, unit=g["unit"].iloc[0], n_poses=len(g),
             rms_error=float(np.sqrt(np.mean(g["error"] ** 2))),
             max_abs_error=float(g["abs_error"].max()), mean_error=float(g["error"].mean()),
             n_inside=int(g["inside"].sum()))
        for q, g in table.groupby("quantity", sort=False)
    ]).set_index("quantity")
    return ErrorTable(table=table, summary=summary, combine=combine)


def fk_error_table(measurements, robot=None, **kwargs):
    """:func:`error_table` for commanded joints (poses -> positions by FK).

    Parameters
    ----------
    measurements : pandas.DataFrame or str or os.PathLike
        Readings (:func:`labkit.measurement.load_measurements` or its path),
        with commanded joints on every row.
    robot : Robot or str, optional
        Robot model; default: the one named in the measurements.
    **kwargs
        Passed to :func:`error_table` (e.g. ``combine``).

    Returns
    -------
    ErrorTable

    Raises
    ------
    MeasurementError
        As for :func:`error_table` (e.g. a row without commanded joints).
    """
    return error_table(measurements, robot, mode="fk", **kwargs)


def ik_error_table(measurements, robot=None, *, branch="elbow_up", **kwargs):
    """:func:`error_table` for Cartesian targets (targets -> joint angles by IK).

    Parameters
    ----------
    measurements : pandas.DataFrame or str or os.PathLike
        Readings (:func:`labkit.measurement.load_measurements` or its path),
        with a target [m] on every row.
    robot : Robot or str, optional
        Robot model; default: the one named in the measurements.
    branch : str
        IK branch for the targets.
    **kwargs
        Passed to :func:`error_table` (e.g. ``combine``).

    Returns
    -------
    ErrorTable

    Raises
    ------
    MeasurementError
        As for :func:`error_table` (e.g. an unreachable target).
    """
    return error_table(measurements, robot, mode="ik", branch=branch, **kwargs)


# -- command line (plugin of labkit.cli) ---------------------------------------------
def _cmd_errors(args):
    import pandas as pd

    result = error_table(args.file, args.robot, branch=args.branch, combine=args.combine)
    with pd.option_context("display.width", 200, "display.max_columns", 50):
        print(result.wide().to_string(float_format=lambda v: f"{v:.4g}"))
    if args.html:
        result.to_html(args.html)
    if args.latex:
        result.to_latex(args.latex)
    return 0


def add_cli(subparsers):
    """Add ``labkit errors`` and ``labkit audit`` to the ``labkit`` command line."""
    sp = subparsers.add_parser("errors", help="measured-versus-calculated error table of a measurement CSV")
    sp.add_argument("file", help="measurement CSV (docs/measurements.md)")
    sp.add_argument("--robot", help="robot name or file (default: the file's robot column)")
    sp.add_argument("--branch", default="elbow_up", help="IK branch for target rows (default elbow_up)")
    sp.add_argument("--combine", default="quadrature", choices=_COMBINE, help="uncertainty rule")
    sp.add_argument("--html", help="also write the styled table as HTML")
    sp.add_argument("--latex", help="also write the styled table as LaTeX")
    sp.set_defaults(func=_cmd_errors)
    _add_audit_cli(subparsers)
