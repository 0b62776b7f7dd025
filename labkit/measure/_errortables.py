"""Measured-versus-calculated error tables (:class:`ErrorTable`, :func:`error_table`)."""

from __future__ import annotations

import dataclasses
import math
import numbers
from pathlib import Path

import numpy as np

from labkit.exceptions import MeasurementError, OptionError
from labkit.measure._schema import UNITS, quantity_dimension
from labkit.measure._csv import load_measurements
from labkit.measure._calculated import COMBINE_RULES, _command_text, _frame, _robot, _wrap_deg_or_rad, calculated_si
from labkit.tables import HIGHLIGHT, error_report_table

__all__ = ["ErrorTable", "error_table", "fk_error_table", "ik_error_table"]


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

    def flagged(self, tolerance=None):
        """Which rows are out of tolerance: the readings an error report highlights.

        Parameters
        ----------
        tolerance : float or dict of str to float, optional
            Largest acceptable ``|error|`` in SI units (m, rad), one value or
            ``{quantity: value}`` (a quantity not named is never flagged); default: the
            measurement uncertainty (a row is flagged when ``inside`` is false).

        Returns
        -------
        numpy.ndarray of bool, shape (n_rows,)
            One flag per row of :attr:`table`.

        Raises
        ------
        OptionError
            ``tolerance`` is not a non-negative number or a mapping of this table's
            quantities to such numbers.
        """
        if tolerance is None:
            return ~self.table["inside"].to_numpy(bool)
        quantities = list(dict.fromkeys(self.table["quantity"]))
        limits = dict(tolerance) if isinstance(tolerance, dict) else dict.fromkeys(quantities, tolerance)
        unknown = [q for q in limits if q not in quantities]
        if unknown:
            raise OptionError(f"tolerance names quantities {', '.join(map(repr, unknown))}, which the table does "
                              f"not have (it has {', '.join(quantities)})")
        for q, value in limits.items():
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or not value >= 0:
                raise OptionError(f"tolerance expects a non-negative number in m or rad (or {{quantity: number}}), "
                                  f"got {value!r} for {q!r}")
        si = self.table["abs_error"].to_numpy(float) * np.array([UNITS[u][1] for u in self.table["unit"]])
        limit = np.array([limits.get(q, np.inf) for q in self.table["quantity"]], dtype=float)
        return si > limit

    def report_table(self, *, tolerance=None, highlight=HIGHLIGHT, caption="", unit=None, scale=1.0, pose="command",
                     digits=None):
        """The table as a report prints it, the readings out of tolerance highlighted.

        :func:`labkit.tables.error_report_table` of this table (one row per pose and quantity:
        calculated, measured, ±, error with their unit, within U), the measured and error
        cells of the rows :meth:`flagged` marks highlighted. :meth:`to_html`, :meth:`to_latex`
        and :meth:`style` print this table, so a notebook shows what the report shows.

        Parameters
        ----------
        tolerance : float or dict of str to float, optional
            Largest acceptable ``|error|`` in SI units (m, rad), as :meth:`flagged`;
            default: the measurement uncertainty.
        highlight : str
            CSS of a highlighted cell.
        caption : str
            What the table shows (``None`` as "").
        unit, scale, pose, digits
            The layout of :func:`labkit.tables.error_report_table`: the unit the numbers
            print in and the factor to it (``unit="mm", scale=1e3``), what names a pose
            ("command" or "pose_id"), significant digits per column.

        Returns
        -------
        labkit.tables.ReportTable

        Raises
        ------
        OptionError
            A value the options do not accept (the message says what they expect).

        Examples
        --------
        >>> from labkit.data import measurement_file
        >>> errors = error_table("arduino_arm_3dof", measurement_file("seed000_ik_table4.csv"), branch="elbow_up")
        >>> t = errors.report_table(pose="pose_id")
        >>> t.header[2:6], t.rows[1][:6]
        (('calculated [deg]', 'measured [deg]', '± [deg]', 'error [deg]'), ('', 'theta2', '113.9', '115.0', '1.0', '1.1'))
        >>> sorted({r for r, _, _ in t.marks}) == sorted(np.flatnonzero(~errors.table["inside"]))
        True
        """
        return error_report_table(self, unit=unit, scale=scale, pose=pose, digits=digits, caption=caption or "",
                                  flagged=self.flagged(tolerance), highlight=highlight)

    @staticmethod
    def _options(options):
        """The options of :meth:`report_table` given by name to a method that passes them on."""
        unknown = sorted(set(options) - set(_REPORT_OPTIONS))
        if unknown:
            raise OptionError(f"expected options among {', '.join(_REPORT_OPTIONS)}, got {', '.join(unknown)}")
        return options

    def style(self, *, escape=None, **options):
        """A pandas Styler of :meth:`report_table`: the same cells, the same highlights.

        Numbers print as the lab report prints them (calculated and measured with the
        error's decimals, units in the headers, words for booleans, a dash for a missing
        value); the measured and error cells of readings whose calculated value lies outside
        the measurement uncertainty (or, with ``tolerance``, whose ``|error|`` exceeds it) are
        highlighted.

        Parameters
        ----------
        escape : {None, "html", "latex"}
            Escaping of the header and the cells.
        **options
            As :meth:`report_table`: ``tolerance`` (in m, rad; one value or
            ``{quantity: value}``), ``highlight`` (CSS), ``caption``, ``unit``, ``scale``,
            ``pose``, ``digits``.

        Returns
        -------
        pandas.io.formats.style.Styler

        Raises
        ------
        OptionError
            An option or value :meth:`report_table` does not accept, or a bad ``escape``.
        """
        return self.report_table(**self._options(options)).to_styler(escape=escape)

    def to_html(self, path=None, **options):
        """HTML of :meth:`report_table` (written to ``path`` if given): the report's table.

        Parameters
        ----------
        path : str or os.PathLike, optional
            File to write; nothing is written if omitted.
        **options
            As :meth:`report_table` (``tolerance``, ``highlight``, ``caption``, ``unit``,
            ``scale``, ``pose``, ``digits``).

        Returns
        -------
        str
            The HTML table (``<table class="lk-report-table">``; highlighted cells carry
            their CSS in a ``style`` attribute).
        """
        html = self.report_table(**self._options(options)).to_html()
        if path is not None:
            Path(path).write_text(html, encoding="utf-8")
        return html

    def to_latex(self, path=None, **options):
        r"""LaTeX of :meth:`report_table` (booktabs; ``\cellcolor`` highlights need ``xcolor`` with ``table``).

        Parameters
        ----------
        path : str or os.PathLike, optional
            File to write; nothing is written if omitted.
        **options
            As :meth:`report_table` (``tolerance``, ``highlight``, ``caption``, ``unit``,
            ``scale``, ``pose``, ``digits``).

        Returns
        -------
        str
            A ``table``/``tabular`` (a ``longtable`` when long), ``\cellcolor`` on
            highlighted cells.
        """
        tex = self.report_table(**self._options(options)).to_latex()
        if path is not None:
            Path(path).write_text(tex, encoding="utf-8")
        return tex


#: what :meth:`ErrorTable.report_table` accepts
_REPORT_OPTIONS = ("tolerance", "highlight", "caption", "unit", "scale", "pose", "digits")


def error_table(robot, measurements, *, mode="auto", branch=None, combine="quadrature"):
    """Measured-versus-calculated error table.

    Parameters
    ----------
    robot : Robot or str or None
        Robot model (or its name or file); ``None``: the one named in the
        measurements' ``robot`` column.
    measurements : pandas.DataFrame or str or os.PathLike
        Readings (:func:`labkit.measure.load_measurements` or its path).
    mode : {"auto", "fk", "ik"}
        "fk" needs commanded joints on every row, "ik" uses targets, "auto"
        uses commanded joints where present, else the target.
    branch : str, optional
        IK branch for target rows (e.g. ``"elbow_up"``, as in seed 000);
        default the first branch that reaches each target, as
        :func:`labkit.kinematics.ik` picks it.
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

    if combine not in COMBINE_RULES:
        raise MeasurementError(f"unknown combine rule {combine!r}; expected one of {COMBINE_RULES}")
    df = _frame(measurements, load_measurements, ("value", "resolution", "unit"))
    if not len(df):
        raise MeasurementError("expected at least one reading, got an empty table")
    robot = _robot(robot, df)
    calc_si = calculated_si(df, robot, mode=mode, branch=branch)
    lines = df["line"].tolist() if "line" in df else [i + 2 for i in range(len(df))]
    rows = []
    col = {name: df[name].tolist() for name in ("unit", "value", "resolution", "half_range", "n_readings",
                                                 "commanded", "target")}  # (lists: no pandas call per reading)
    groups = {}  # (pose, quantity) -> row positions, in order of first appearance (rows without either skipped)
    for k, key in enumerate(zip(df["pose_id"].tolist(), df["quantity"].tolist())):
        if not (pd.isna(key[0]) or pd.isna(key[1])):
            groups.setdefault(key, []).append(k)
    for (pose, quantity), idx in groups.items():
        first = idx[0]
        unit = col["unit"][first]
        factor = UNITS[unit][1]
        for k in idx[1:]:
            if col["commanded"][k] != col["commanded"][first] or col["target"][k] != col["target"][first]:
                raise MeasurementError(f"pose {pose!r} was logged with different commanded joints/targets", line=lines[k], column="commanded")
        values, res, half = (np.array([col[name][k] * UNITS[col["unit"][k]][1] / factor for k in idx])
                             for name in ("value", "resolution", "half_range"))
        summary_rows = ~np.isnan(half)
        if summary_rows.any():
            if len(idx) > 1:
                k = idx[int(np.argmax(summary_rows))] if summary_rows.sum() == 1 else idx[1]
                raise MeasurementError(f"pose {pose!r}, quantity {quantity!r}: a summary row (half_range given) must be "
                           f"the only row of its pose and quantity, got {len(idx)} rows", line=lines[k], column="half_range")
            mean, hr, std, n = values[0], half[0], float("nan"), int(col["n_readings"][first])
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
            command=_command_text(col["commanded"][first], col["target"][first], robot),
            unit=unit, calculated=calc, mean=mean, n=n, half_range=hr, std=std,
            resolution=resolution, uncertainty=u, error=error, abs_error=abs(error),
            rel_error=rel, inside=bool(abs(error) <= u * (1 + 1e-9)),
        ))
    table = pd.DataFrame(rows)
    per_quantity = {}
    for row in rows:
        per_quantity.setdefault(row["quantity"], []).append(row)
    summary = pd.DataFrame([
        dict(quantity=q, unit=g[0]["unit"], n_poses=len(g), **_error_statistics([row["error"] for row in g]),
             n_inside=sum(row["inside"] for row in g))
        for q, g in per_quantity.items()
    ]).set_index("quantity")
    return ErrorTable(table=table, summary=summary, combine=combine)


def _error_statistics(errors):
    """RMS, largest magnitude and mean of a quantity's errors, NaN entries left out (all NaN: NaN)."""
    e = np.array(errors, dtype=float)
    e = e[~np.isnan(e)]
    if not e.size:
        return dict(rms_error=math.nan, max_abs_error=math.nan, mean_error=math.nan)
    return dict(rms_error=float(np.sqrt(np.mean(e ** 2))), max_abs_error=float(np.abs(e).max()),
                mean_error=float(e.mean()))


def fk_error_table(robot, measurements, **kwargs):
    """:func:`error_table` for commanded joints (poses -> positions by FK).

    Parameters
    ----------
    robot : Robot or str or None
        Robot model (or its name or file); ``None``: the one named in the
        measurements' ``robot`` column.
    measurements : pandas.DataFrame or str or os.PathLike
        Readings (:func:`labkit.measure.load_measurements` or its path),
        with commanded joints on every row.
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
    return error_table(robot, measurements, mode="fk", **kwargs)


def ik_error_table(robot, measurements, *, branch=None, **kwargs):
    """:func:`error_table` for Cartesian targets (targets -> joint angles by IK).

    Parameters
    ----------
    robot : Robot or str or None
        Robot model (or its name or file); ``None``: the one named in the
        measurements' ``robot`` column.
    measurements : pandas.DataFrame or str or os.PathLike
        Readings (:func:`labkit.measure.load_measurements` or its path),
        with a target [m] on every row.
    branch : str, optional
        IK branch for the targets; default as :func:`error_table`.
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
    return error_table(robot, measurements, mode="ik", branch=branch, **kwargs)
