"""Tables people read: :func:`report_table` turns a DataFrame into a :class:`ReportTable`.

One style for every table labkit prints, in a lab report and in a notebook alike: no pandas
index unless it carries meaning, human column names with their units (a mapping,
``{"shoulder_pitch_ddot": "shoulder accel [deg/s^2]"}``), the same number of decimals down a
column (chosen from the column's largest magnitude for the significant digits asked, the rule of
:mod:`labkit.tables._cells`), booleans as words, vectors as ``(x, y, z)``, missing values as a
dash, never ``NaN``; rows may form groups (a label printed once, a little space between groups,
a group never split across pages); a long table may break across pages with its header
repeated; cells may be marked (a highlight, :meth:`ReportTable.mark`). The result shows itself
in a notebook (HTML; ``to_latex()`` gives booktabs, ``longtable`` when long; ``to_styler()`` a
pandas Styler of the same cells); ``labkit report`` takes its HTML into the PDF and the DOCX.

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

import dataclasses
import html as _html
import numbers
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from labkit.exceptions import OptionError, ShapeError
from labkit.validation import as_count
from labkit.tables._cells import (BOOLEANS, MISSING, _cell_text, _column_style, css_to_latex, _is_missing,
                                  _is_number_text, latex_escape, _numbers_of)

__all__ = ["ReportTable", "report_table", "LONG_TABLE_ROWS", "HIGHLIGHT"]

#: a table with more rows than this may break across pages (its header repeated on each)
LONG_TABLE_ROWS = 15
#: CSS of a marked cell unless the caller says otherwise (a light red background)
HIGHLIGHT = "background-color: #f8c4c4"


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
    marks : tuple of (int, int, str)
        Marked cells: (row, column, CSS) by position (:meth:`mark`); HTML carries the CSS, LaTeX
        its colours and weight (:func:`labkit.tables.css_to_latex`), text shows no marks.
    """

    header: tuple
    rows: tuple
    caption: str = ""
    numeric: tuple = ()
    groups: tuple = ()
    marks: tuple = ()

    @property
    def long(self) -> bool:
        """True when the table may break across pages (more than :data:`LONG_TABLE_ROWS` rows)."""
        return len(self.rows) > LONG_TABLE_ROWS

    def mark(self, rows, columns=None, css=HIGHLIGHT) -> ReportTable:
        """The same table with some cells marked (highlighted).

        Parameters
        ----------
        rows : iterable of int or of bool
            Row positions, or one flag per row.
        columns : iterable of str or int, optional
            Printed column names (as in :attr:`header`) or positions; default: every column.
        css : str
            CSS of a marked cell (:data:`HIGHLIGHT`: a light red background).

        Returns
        -------
        ReportTable

        Raises
        ------
        OptionError
            A row or column the table does not have, or ``css`` not a string.

        Examples
        --------
        >>> import pandas as pd
        >>> t = report_table(pd.DataFrame({"x [m]": [0.1, 0.25]})).mark([False, True])
        >>> t.marks
        ((1, 0, 'background-color: #f8c4c4'),)
        """
        if not isinstance(css, str):
            raise OptionError(f"css expects a string ('background-color: #f8c4c4'), got {type(css).__name__}")
        css_to_latex(css)  # says what it expected of malformed CSS
        if isinstance(rows, str) or not isinstance(rows, Iterable):
            raise OptionError(f"rows expects row positions or one flag per row, got {rows!r}")
        rows = list(rows)
        if rows and all(isinstance(r, (bool, np.bool_)) for r in rows):
            if len(rows) != len(self.rows):
                raise OptionError(f"rows expects one flag per row ({len(self.rows)}), got {len(rows)}")
            rows = [k for k, flag in enumerate(rows) if flag]
        bad = [r for r in rows if isinstance(r, (bool, np.bool_)) or not isinstance(r, numbers.Integral)
               or not 0 <= r < len(self.rows)]
        if bad:
            raise OptionError(f"rows expects positions 0..{len(self.rows) - 1} (or one flag per row), got {bad[:5]!r}")
        if columns is not None and not isinstance(columns, (str, Iterable)):
            raise OptionError(f"columns expects printed column names or positions of this table, got {columns!r}")
        positions = []
        for c in range(len(self.header)) if columns is None else ([columns] if isinstance(columns, str) else columns):
            if isinstance(c, str) and c in self.header:
                positions.append(self.header.index(c))
            elif isinstance(c, numbers.Integral) and not isinstance(c, bool) and 0 <= c < len(self.header):
                positions.append(int(c))
            else:
                raise OptionError(f"columns expects printed column names or positions of this table "
                                  f"({', '.join(self.header)}), got {c!r}")
        return dataclasses.replace(self, marks=self.marks + tuple((int(r), c, css) for r in rows for c in positions))

    def _css(self):
        """{(row, column): CSS} of the marked cells (marks on one cell joined)."""
        out = {}
        for r, c, css in self.marks:
            out[(r, c)] = f"{out[(r, c)]}; {css}" if (r, c) in out else css
        return out

    def to_html(self) -> str:
        """The table as HTML (``<table class="lk-report-table">``, a ``<thead>`` that repeats on each page).

        Returns
        -------
        str
            Marked cells carry their CSS in a ``style`` attribute.
        """
        align = [' class="lk-cell-num"' if n else ' class="lk-cell-text"' for n in self._numeric()]
        marks = self._css()
        head = "".join(f"<th{a}>{_html.escape(h)}</th>" for a, h in zip(align, self.header))
        rows = ["<tr>" + "".join(f"<td{a}{self._style_attribute(marks, k, j)}>{_html.escape(c)}</td>"
                                 for j, (a, c) in enumerate(zip(align, row))) + "</tr>"
                for k, row in enumerate(self.rows)]
        body = "".join(f"<tbody>{''.join(rows[a:b])}</tbody>" for a, b in self._spans())
        cls = "lk-report-table" + (" lk-long" if self.long else "") + (" lk-grouped" if self.groups else "")
        cap = f"<caption>{_html.escape(self.caption)}</caption>" if self.caption else ""
        return f'<table class="{cls}">{cap}<thead><tr>{head}</tr></thead>{body}</table>'

    @staticmethod
    def _style_attribute(marks, row, column):
        css = marks.get((row, column))
        return f' style="{_html.escape(css, quote=True)}"' if css else ""

    def _spans(self):
        """(first, end) row of each group (one span of every row without groups)."""
        starts = [s for s in self.groups if 0 < s < len(self.rows)]
        edges = [0, *starts, len(self.rows)]
        return list(zip(edges[:-1], edges[1:]))

    def to_latex(self) -> str:
        r"""The table as LaTeX: booktabs rules, ``longtable`` with the header repeated when long.

        Returns
        -------
        str
            A ``table``/``tabular`` (or a ``longtable``) environment; needs ``booktabs``
            (and ``longtable``; marked cells ``\cellcolor``: ``xcolor`` with its ``table`` option).
        """
        spec = "".join("r" if n else "l" for n in self._numeric())
        marks = {cell: css_to_latex(css) for cell, css in self._css().items()}
        head = " & ".join(latex_escape(h) for h in self.header) + r" \\"
        starts = set(self.groups) - {0}
        body = "\n".join(("\\addlinespace\n" if k in starts else "")
                         + " & ".join(marks.get((k, j), "") + latex_escape(c) for j, c in enumerate(row)) + r" \\"
                         for k, row in enumerate(self.rows))
        cap = latex_escape(self.caption)
        if self.long:
            first = (rf"\caption{{{cap}}}\\" + "\n") if cap else ""
            return (f"\\begin{{longtable}}{{{spec}}}\n{first}\\toprule\n{head}\n\\midrule\n\\endfirsthead\n"
                    f"\\toprule\n{head}\n\\midrule\n\\endhead\n{body}\n\\bottomrule\n\\end{{longtable}}")
        caption = f"\\caption{{{cap}}}\n" if cap else ""
        return (f"\\begin{{table}}\n\\centering\n{caption}\\begin{{tabular}}{{{spec}}}\n\\toprule\n{head}\n"
                f"\\midrule\n{body}\n\\bottomrule\n\\end{{tabular}}\n\\end{{table}}")

    def to_styler(self, escape=None):
        """The same cells as a pandas Styler (no index; the marked cells styled with their CSS).

        Parameters
        ----------
        escape : {None, "html", "latex"}
            Escaping of the header and the cells, as :meth:`to_html` / :meth:`to_latex` escape
            them (``None``: the text as it is).

        Returns
        -------
        pandas.io.formats.style.Styler
            Its data are the printed cells (text), its columns the positions 0, 1, ...
            shown with the printed header.

        Raises
        ------
        OptionError
            ``escape`` is not None, "html" or "latex".
        """
        import pandas as pd

        escapes = {None: str, "html": _html.escape, "latex": latex_escape}
        if escape not in escapes:
            raise OptionError(f"escape expects None, 'html' or 'latex', got {escape!r}")
        text = escapes[escape]
        data = pd.DataFrame(list(self.rows), columns=range(len(self.header)), dtype=object)
        css = pd.DataFrame("", index=data.index, columns=data.columns)
        for (r, c), style in self._css().items():
            css.iloc[r, c] = style
        styler = data.style.hide(axis="index").format(text).format_index(lambda k: text(self.header[k]), axis=1)
        if self.caption:
            styler = styler.set_caption(text(self.caption))
        return styler.apply(lambda _: css, axis=None)

    def to_text(self) -> str:
        """The table as aligned plain text (what a terminal shows; marks are not shown).

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


def report_table(df, *, columns=None, digits=3, caption="", index=None, units=None, booleans=BOOLEANS,
                 missing=MISSING, zero=1e-9, group=None) -> ReportTable:
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
    if not isinstance(caption, str):
        raise OptionError(f"caption expects a string, got {caption!r}")
    if columns is not None and not isinstance(columns, Mapping):
        raise OptionError(f"columns expects a mapping {{column: printed name}}, got {columns!r}")
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
        as_count(value, "digits", minimum=1)
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
        decimals, scientific = _column_style(values, int(per_column.get(name, default)), zero)
        header.append(str(label))
        cells.append([_cell_text(v, decimals, scientific, booleans, missing, zero) for v in values])
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
