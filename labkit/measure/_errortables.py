"""Measured-versus-calculated error tables (:class:`ErrorTable`, :func:`error_table`)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from labkit.exceptions import MeasurementError
from labkit.measure._schema import UNITS, quantity_dimension
from labkit.measure._csv import load_measurements
from labkit.measure._calculated import COMBINE_RULES, _command_text, _fixed, _frame, _robot, _wrap_deg_or_rad, calculated_si, decimals_for_resolution

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
