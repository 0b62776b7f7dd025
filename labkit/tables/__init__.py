"""Tables people read: the one rule for how a number, a word and a table print.

:func:`report_table` turns a DataFrame into a :class:`ReportTable` (units in headers, the same
decimals down a column, words for booleans, ``(x, y, z)`` for vectors, a dash for missing
values, no pandas index, marked cells); :func:`error_report_table` lays out a
measured-versus-calculated error table; :func:`format_value` prints a value in prose the way a
cell prints it. Lab reports (:mod:`labkit.reports`, which re-exports these names) and the
measurement tables (``labkit.measure.ErrorTable``, ``AuditResult``) print through them, so a
table looks the same in a notebook and in the report.
"""

from labkit.tables._cells import css_to_latex, format_value, latex_escape
from labkit.tables._table import HIGHLIGHT, LONG_TABLE_ROWS, ReportTable, report_table
from labkit.tables._errors import error_report_table

__all__ = [
    "HIGHLIGHT",
    "LONG_TABLE_ROWS",
    "ReportTable",
    "report_table",
    "error_report_table",
    "format_value",
    "latex_escape",
    "css_to_latex",
]
