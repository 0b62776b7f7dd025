"""Tables people read: :func:`report_table` turns a DataFrame into a report table.

One style for every table of a report: no pandas index unless it carries meaning, human
column names with their units (a mapping, ``{"shoulder_pitch_ddot": "shoulder accel
[deg/s^2]"}``), the same number of decimals down a column (chosen from the column's largest
magnitude for the significant digits asked), booleans as words, vectors as ``(x, y, z)``,
missing values as a dash, never ``NaN``; rows may form groups (a label printed once, a little
space between groups, a group never split across pages); a long table may break across pages
with its header repeated. :func:`error_report_table` lays out a measured-versus-calculated
error table (``labkit.measure.error_table``) the way a journal prints one. The result shows itself in a notebook (HTML; ``to_latex()`` gives booktabs,
``longtable`` when long); ``labkit report`` takes its HTML into the PDF and the DOCX.

Example
-------
>>> import pandas as pd
>>> t = report_table(pd.DataFrame({"q1": [0.0, 1.25, -0.5], "ok": [True, False, None]}),
...                  columns={"q1": "q1 [deg]", "ok": "reached"}, digits=2)
>>> t.header
('q1 [deg]', 'reached')
>>> t.rows
(('0.0', 'yes'), ('1.2', 'no'), ('-0.5', '–'))
"""

from __future__ import annotations

import html as _html
import math
import numbers
from dataclasses import dataclass

import numpy as np

from labkit.exceptions import OptionError, ShapeError

__all__ = ["ReportTable", "report_table", "error_report_table", "format_value", "LONG_TABLE_ROWS"]

#: a table with more rows than this may break across pages (its header repeated on each)
LONG_TABLE_ROWS = 15
_MINUS = "-"


@dataclass(frozen=True)
class ReportTable:
    """A table as a report prints it: header and cells as text, a caption.

    Attributes
    ----------
    header : tuple of str
        Column names as printed (with units).
    rows : tuple of tuple of str
        Cells as printed, one tuple per row.
    caption : str
        What the table shows ("" = none; a numbered table takes the ``#| tbl-cap`` of its cell).
    numeric : tuple of bool
        Per column: right-aligned numbers (else left-aligned text).
    groups : tuple of int
        Rows that start a group (ascending, the first is 0); empty: no groups.
    """

    header: tuple
    rows: tuple
    caption: str = ""
    numeric: tuple = ()
    groups: tuple = ()

    @property
    def long(self) -> bool:
        """True when the table may break across pages (more than :data:`LONG_TABLE_ROWS` rows)."""
        return len(self.rows) > LONG_TABLE_ROWS

    def to_html(self) -> str:
        """The table as HTML (``<table class="lk-report-table">``, a ``<thead>`` that repeats on each page).

        Returns
        -------
        str
        """
        align = [' class="lk-cell-num"' if n else ' class="lk-cell-text"' for n in self._numeric()]
        head = "".join(f"<th{a}>{_html.escape(h)}</th>" for a, h in zip(align, self.header))
        rows = ["<tr>" + "".join(f"<td{a}>{_html.escape(c)}</td>" for a, c in zip(align, row)) + "</tr>"
                for row in self.rows]
        body = "".join(f"<tbody>{''.join(rows[a:b])}</tbody>" for a, b in self._spans())
        cls = "lk-report-table" + (" lk-long" if self.long else "") + (" lk-grouped" if self.groups else "")
        cap = f"<caption>{_html.escape(self.caption)}</caption>" if self.caption else ""
        return f'<table class="{cls}">{cap}<thead><tr>{head}</tr></thead>{body}</table>'

    def _spans(self):
        """(first, end) row of each group (one span of every row without groups)."""
        starts = [s for s in self.groups if 0 < s < len(self.rows)]
        edges = [0, *starts, len(self.rows)]
        return list(zip(edges[:-1], edges[1:]))

    def to_latex(self) -> str:
        """The table as LaTeX: booktabs rules, ``longtable`` with the header repeated when long.

        Returns
        -------
        str
            A ``table``/``tabular`` (or a ``longtable``) environment; needs ``booktabs``
            (and ``longtable``).
        """
        spec = "".join("r" if n else "l" for n in self._numeric())
        head = " & ".join(_latex_escape(h) for h in self.header) + r" \\"
        starts = set(self.groups) - {0}
        body = "\n".join(("\\addlinespace\n" if k in starts else "") + " & ".join(_latex_escape(c) for c in row) + r" \\"
                         for k, row in enumerate(self.rows))
        cap = _latex_escape(self.caption)
        if self.long:
            first = (rf"\caption{{{cap}}}\\" + "\n") if cap else ""
            return (f"\\begin{{longtable}}{{{spec}}}\n{first}\\toprule\n{head}\n\\midrule\n\\endfirsthead\n"
                    f"\\toprule\n{head}\n\\midrule\n\\endhead\n{body}\n\\bottomrule\n\\end{{longtable}}")
        caption = f"\\caption{{{cap}}}\n" if cap else ""
        return (f"\\begin{{table}}\n\\centering\n{caption}\\begin{{tabular}}{{{spec}}}\n\\toprule\n{head}\n"
                f"\\midrule\n{body}\n\\bottomrule\n\\end{{tabular}}\n\\end{{table}}")

    def to_text(self) -> str:
        """The table as aligned plain text (what a terminal shows).

        Returns
        -------
        str
        """
        cols = list(zip(self.header, *self.rows)) if self.header else []
        widths = [max(len(c) for c in col) for col in cols]
        numeric = self._numeric()
        lines = [("  ".join(c.rjust(w) if n else c.ljust(w) for c, w, n in zip(row, widths, numeric))).rstrip()
                 for row in [self.header, *self.rows]]
        if self.caption:
            lines.insert(0, self.caption)
        return "\n".join(lines)

    def _numeric(self):
        return self.numeric or (False,) * len(self.header)

    def _repr_html_(self):
        return self.to_html()

    def __repr__(self):
        return self.to_text()


def _latex_escape(text) -> str:
    out = str(text)
    for a, b in (("\\", r"\textbackslash{}"), ("&", r"\&"), ("%", r"\%"), ("$", r"\$"), ("#", r"\#"),
                 ("_", r"\_"), ("{", r"\{"), ("}", r"\}"), ("~", r"\textasciitilde{}"), ("^", r"\^{}"),
                 ("–", "--"), ("±", r"$\pm$"), ("°", r"$^\circ$")):
        out = out.replace(a, b)
    return out


def _is_missing(v) -> bool:
    if v is None:
        return True
    try:
        import pandas as pd

        if v is pd.NA or v is pd.NaT:
            return True
    except ImportError:  # pragma: no cover - pandas is a dependency of the table's callers
        pass
    return isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isnan(float(v))


def _is_vector(v) -> bool:
    return isinstance(v, (tuple, list, np.ndarray)) and not isinstance(v, str)


def _is_number_text(text) -> bool:
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


def _numbers_of(values, zero=0.0):
    """Every finite real number in a column (vectors flattened), as floats; round-off (``<= zero``) as 0."""
    out = []
    for v in values:
        items = np.asarray(v, dtype=object).ravel() if _is_vector(v) else [v]
        for x in items:
            if isinstance(x, (bool, np.bool_)) or _is_missing(x) or not isinstance(x, numbers.Real):
                continue
            if math.isfinite(float(x)):
                out.append(0.0 if abs(float(x)) <= zero else float(x))
    return out


def _style(values, digits, zero):
    """(decimals, scientific) for a column: ``digits`` significant digits on its largest magnitude."""
    nums = _numbers_of(values, zero)
    if all(float(x).is_integer() for x in nums) and all(
            isinstance(x, (numbers.Integral, np.integer)) for v in values if not _is_missing(v)
            for x in (np.asarray(v, dtype=object).ravel() if _is_vector(v) else [v])
            if isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_))):
        return 0, False
    big = max((abs(x) for x in nums), default=0.0)
    if big == 0.0:
        return 0, False  # a column of zeros (round-off) prints 0
    if big >= 1e6 or big < 1e-3:
        return digits - 1, True
    exponent = math.floor(math.log10(big))
    return max(digits - 1 - exponent, 0), False


def _number(x, decimals, scientific, zero) -> str:
    x = 0.0 if abs(float(x)) <= zero else float(x)
    if math.isinf(x):
        return "∞" if x > 0 else "-∞"
    if scientific:
        if x == 0.0:
            return "0"
        mant, exp = f"{x:.{decimals}e}".split("e")
        return f"{mant}e{int(exp)}"
    text = f"{x:.{decimals}f}"
    if text.startswith("-") and float(text) == 0.0:
        text = text[1:]  # -0.00 is round-off
    return text


def _cell(v, decimals, scientific, words, missing, zero) -> str:
    if _is_missing(v):
        return missing
    if isinstance(v, (bool, np.bool_)):
        return words[0] if v else words[1]
    if _is_vector(v):
        items = np.asarray(v, dtype=object).ravel()
        return "(" + ", ".join(_cell(x, decimals, scientific, words, missing, zero) for x in items) + ")"
    if isinstance(v, (numbers.Integral, np.integer)):
        return str(int(v)) if decimals == 0 and not scientific else _number(v, decimals, scientific, zero)
    if isinstance(v, numbers.Real):
        return _number(v, decimals, scientific, zero)
    return str(v)


def report_table(df, *, columns=None, digits=3, caption="", index=None, units=None, booleans=("yes", "no"),
                 missing="–", zero=1e-9, group=None) -> ReportTable:
    """A DataFrame as a report table: human names with units, digits per column, words for booleans.

    Parameters
    ----------
    df : pandas.DataFrame or pandas.Series
        The data (numbers in the units the header states; a Series is one column).
    columns : dict of str to str, optional
        Column name -> printed name with its unit (``{"q1_dot": "q1 rate [deg/s]"}``); a
        column not named keeps its name (the levels of a two-level name joined by ", "). A
        name mapped to ``None`` is left out.
    digits : int or dict of str to int
        Significant digits of a column's largest magnitude; every number of the column gets
        the same decimals (a column of integers prints as integers). Per column by the
        DataFrame's names, with ``"*"`` for the rest.
    caption : str
        What the table shows (a subsample says which rows). A table numbered by ``#| tbl-cap``
        in a report takes that caption instead.
    index : bool, optional
        Print the index as the first column; default: only when it carries meaning (it has a
        name or holds labels), not row numbers (0, 1, 2, ... or those of a subsample).
    units : dict of str to str, optional
        Column name -> unit, added to the printed name as ``[unit]`` unless it already holds
        one; default: ``df.attrs["units"]`` (what ``Trajectory.to_dataframe`` records).
    booleans : (str, str)
        Words for true and false ("yes", "no"; marks such as "✓", "✗" work too).
    missing : str
        What a missing value (``None``, ``NaN``) prints as.
    zero : float
        Round-off: a magnitude at most this prints as 0 (``5.6e-17`` is 0, never ``5.6e-17``).
    group : str or list of str, optional
        A column (or columns) whose runs of equal values form groups of rows: the values
        printed on a group's first row only, a little space between groups, a group kept on
        one page.

    Returns
    -------
    ReportTable
        Shows itself as HTML in a notebook; ``to_latex()`` / ``to_text()`` for other outputs.

    Raises
    ------
    OptionError
        ``digits`` is not a positive integer, or ``columns`` / ``digits`` / ``group`` name a
        column the table does not have (or, for ``group``, does not print).
    ShapeError
        ``df`` is not a DataFrame or Series.

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"t": [0.0, 0.5], "shoulder_pitch_ddot": [0.012, -0.0016],
    ...                    "target": [(0.1, 0.1, -0.1), (0.1, -0.1, -0.16)]})
    >>> print(report_table(df, columns={"t": "time [s]", "shoulder_pitch_ddot": "shoulder accel [deg/s^2]",
    ...                                 "target": "target [m]"}, digits={"t": 2, "*": 2}).to_text())
    time [s]  shoulder accel [deg/s^2]            target [m]
        0.00                     0.012   (0.10, 0.10, -0.10)
        0.50                    -0.002  (0.10, -0.10, -0.16)
    """
    import pandas as pd

    if isinstance(df, pd.Series):
        df = df.to_frame()
    if not isinstance(df, pd.DataFrame):
        raise ShapeError(f"expected a pandas DataFrame or Series, got {type(df).__name__}")
    if len(booleans) != 2 or not all(isinstance(b, str) for b in booleans):
        raise OptionError(f"booleans expects two words (true, false), got {booleans!r}")
    columns = dict(columns or {})
    unknown = [k for k in columns if k not in df.columns and k not in df.index.names]
    if unknown:
        raise OptionError(f"columns names {', '.join(map(str, unknown))}, which the table does not have "
                          f"(it has {', '.join(map(str, df.columns))})")
    if index is None:  # row numbers (a default or a subsample's index) carry no meaning; labels and names do
        index = any(n is not None for n in df.index.names) or not pd.api.types.is_integer_dtype(df.index.dtype)
    if index:
        names = [n if n is not None else "" for n in df.index.names]
        levels = [df.index.get_level_values(k) for k in range(df.index.nlevels)]
        df = df.copy()
        df.columns = [c for c in df.columns]  # one level: a two-level name is a tuple
        for k in reversed(range(len(levels))):
            key = names[k] if names[k] not in df.columns else f"{names[k]} "
            df.insert(0, key, list(levels[k]))
    units = dict(df.attrs.get("units", {}) if units is None else units)
    per_column = digits if isinstance(digits, dict) else {"*": digits}
    unknown = [k for k in per_column if k != "*" and k not in df.columns]
    if unknown:
        raise OptionError(f"digits names {', '.join(map(str, unknown))}, which the table does not have")
    default = per_column.get("*", 3)
    for value in [default, *per_column.values()]:
        if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
            raise OptionError(f"digits expects positive integers, got {value!r}")
    group = [] if group is None else [group] if isinstance(group, str) else list(group)
    for name in group:
        if name not in df.columns or columns.get(name, name) is None:
            raise OptionError(f"group expects columns the table prints, got {name!r} "
                              f"(it prints {', '.join(str(c) for c in df.columns if columns.get(c, c) is not None)})")
    header, cells, numeric, grouped = [], [], [], []
    for name in df.columns:
        label = columns.get(name, ", ".join(map(str, name)) if isinstance(name, tuple) else name)
        if label is None:
            continue
        if name in group:
            grouped.append(len(header))
        if units.get(name) and "[" not in str(label):
            label = f"{label} [{units[name]}]"
        values = list(df[name])
        decimals, scientific = _style(values, int(per_column.get(name, default)), zero)
        header.append(str(label))
        cells.append([_cell(v, decimals, scientific, booleans, missing, zero) for v in values])
        present = [v for v in values if not _is_missing(v)]  # numbers kept as printed ("0.024") align as numbers
        numeric.append(bool(present) and all(_is_number_text(v) if isinstance(v, str) else bool(_numbers_of([v]))
                                             for v in present))
    starts = ()
    if grouped:
        labels = list(zip(*(cells[g] for g in grouped)))
        starts = tuple(k for k in range(len(labels)) if k == 0 or labels[k] != labels[k - 1])
        for g in grouped:
            cells[g] = [c if k in starts else "" for k, c in enumerate(cells[g])]
    rows = tuple(zip(*cells)) if cells else tuple(() for _ in range(len(df)))
    return ReportTable(tuple(header), tuple(tuple(r) for r in rows), str(caption or ""), tuple(numeric), starts)


#: the columns of a measured-versus-calculated error table (``labkit.measure.ErrorTable.table``) a reader needs
_ERROR_COLUMNS = {"calculated": "calculated", "mean": "measured", "half_range": "±", "error": "error"}


def error_report_table(errors, *, unit=None, scale=1.0, pose="command", digits=None, caption="") -> ReportTable:
    """A measured-versus-calculated error table as a journal prints it: one row per pose and quantity.

    Columns: the pose, the quantity, calculated, measured (mean of the readings), ± (half
    their range), error (measured - calculated), each with its unit, and "within U" (yes/no:
    the error inside the measurement uncertainty). The rows of one pose form a group. The
    other columns of the error table (counts, spread, resolution, relative error) stay in
    its CSV; its summary (RMS, largest error) is a table of its own.

    Parameters
    ----------
    errors : labkit.measure.ErrorTable or pandas.DataFrame
        The error table (or its long ``table``: columns ``pose_id, quantity, command, unit,
        calculated, mean, half_range, error, inside``).
    unit : str, optional
        The unit the numbers print in after ``scale`` ("mm"); default: the readings' unit.
    scale : float
        Factor from the readings' unit to ``unit`` (1e3 for m -> mm).
    pose : {"command", "pose_id"}
        What names a pose: the commanded joints or target ("q = (5, 0, 0) deg") or its id.
    digits : int or dict of str to int, optional
        Significant digits of each column's largest magnitude; per column by the names
        "calculated", "measured", "±", "error", with ``"*"`` for the rest. Default: 2 for
        ±, 3 for the error, and calculated and measured with the error's decimals (so that
        the printed error is the printed measured minus calculated).
    caption : str
        What the table shows.

    Returns
    -------
    ReportTable

    Raises
    ------
    OptionError
        ``pose`` is not "command" or "pose_id"; ``scale`` is not a positive number; the
        readings are in several units and ``unit`` / ``scale`` would print them as one.
    ShapeError
        ``errors`` lacks a column the layout needs.

    Examples
    --------
    >>> import pandas as pd
    >>> long = pd.DataFrame({"pose_id": ["p1", "p1"], "quantity": ["x", "y"], "command": ["q = (5, 0) deg"] * 2,
    ...                      "unit": ["m", "m"], "calculated": [0.2733, 0.0239], "mean": [0.26, 0.065],
    ...                      "half_range": [0.02, 0.05], "error": [-0.0133, 0.0411], "inside": [True, True]})
    >>> print(error_report_table(long, unit="mm", scale=1e3).to_text())
    pose            quantity  calculated [mm]  measured [mm]  ± [mm]  error [mm]  within U
    q = (5, 0) deg  x                   273.3          260.0      20       -13.3  yes
                    y                    23.9           65.0      50        41.1  yes
    """
    import pandas as pd

    if pose not in ("command", "pose_id"):
        raise OptionError(f"pose expects 'command' or 'pose_id', got {pose!r}")
    if isinstance(scale, bool) or not isinstance(scale, numbers.Real) or not scale > 0:
        raise OptionError(f"scale expects a positive number, got {scale!r}")
    table = getattr(errors, "table", errors)
    if not isinstance(table, pd.DataFrame):
        raise ShapeError(f"expected an ErrorTable or its DataFrame, got {type(errors).__name__}")
    needed = [pose, "quantity", "unit", *_ERROR_COLUMNS, "inside"]
    lacking = [c for c in needed if c not in table.columns]
    if lacking:
        raise ShapeError(f"expected an error table with columns {', '.join(needed)}; it lacks {', '.join(lacking)}")
    units = list(dict.fromkeys(table["unit"]))
    if len(units) > 1 and (unit is not None or scale != 1.0):
        raise OptionError(f"unit and scale convert readings of one unit; these are in {', '.join(units)}")
    shown = unit if unit is not None else (units[0] if len(units) == 1 else "")
    suffix = f" [{shown}]" if shown else ""
    frame = pd.DataFrame({"pose": table[pose].to_numpy(), "quantity": table["quantity"].to_numpy(),
                          **{f"{name}{suffix}": table[column].to_numpy(float) * float(scale)
                             for column, name in _ERROR_COLUMNS.items()},
                          "within U": table["inside"].to_numpy(bool)})
    if digits is None:  # error = measured - calculated: the three print with the error's decimals (3 digits)
        digits = {"±": 2, "*": 3}
        err = np.abs(frame[f"error{suffix}"].to_numpy(float))
        if np.isfinite(err).any() and np.nanmax(err) > 0:
            decimals = 2 - math.floor(math.log10(np.nanmax(err)))
            for name in ("calculated", "measured"):
                big = np.nanmax(np.abs(frame[f"{name}{suffix}"].to_numpy(float)), initial=0.0)
                digits[name] = max(1, decimals + 1 + math.floor(math.log10(big))) if big > 0 else 3
    if isinstance(digits, dict):
        digits = {(f"{k}{suffix}" if k in _ERROR_COLUMNS.values() else k): v for k, v in digits.items()}
    return report_table(frame, digits=digits, caption=caption, group="pose")


def format_value(value, *, digits=4, decimals=None, unit="", zero=1e-9) -> str:
    """A number or a vector as prose prints it, the way :func:`report_table` prints a cell.

    Parameters
    ----------
    value : float or array_like
        A number, or numbers (printed as ``(a, b, c)``; a matrix row by row).
    digits : int
        Significant digits of the largest magnitude; every number gets the same decimals.
    decimals : int, optional
        Fixed decimals instead of ``digits``.
    unit : str
        Appended after a space ("mm", "deg").
    zero : float
        Round-off: a magnitude at most this prints as 0.

    Returns
    -------
    str

    Raises
    ------
    OptionError
        ``digits`` or ``decimals`` is not a non-negative integer (``digits`` positive).

    Examples
    --------
    >>> format_value([0.523599, 0.149718, -5.6e-17], decimals=4, unit="rad")
    '(0.5236, 0.1497, 0.0000) rad'
    >>> format_value(1.1e-13, unit="mm")
    '0 mm'
    """
    if isinstance(digits, bool) or not isinstance(digits, numbers.Integral) or digits < 1:
        raise OptionError(f"digits expects a positive integer, got {digits!r}")
    if decimals is not None and (isinstance(decimals, bool) or not isinstance(decimals, numbers.Integral) or decimals < 0):
        raise OptionError(f"decimals expects a non-negative integer, got {decimals!r}")
    arr = np.asarray(value, dtype=object)
    flat = list(arr.ravel()) if arr.ndim else [value]
    if decimals is None:
        dec, scientific = _style(flat, int(digits), zero)
    else:
        dec, scientific = int(decimals), False
    if arr.ndim == 0:
        text = _cell(value, dec, scientific, ("yes", "no"), "–", zero)
    elif arr.ndim == 1:
        text = _cell(list(arr), dec, scientific, ("yes", "no"), "–", zero)
    else:
        text = "(" + ", ".join(_cell(list(row), dec, scientific, ("yes", "no"), "–", zero)
                               for row in arr.reshape(-1, arr.shape[-1])) + ")"
    return f"{text} {unit}" if unit else text
