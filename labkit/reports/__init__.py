"""Reports: executing lab notebooks (papermill on the virtual arm), rendering them to
self-contained HTML and PDF, and the helpers notebooks use to close a section
(:class:`Checks`, :func:`check`, LaTeX, and :func:`report_table`, the one table style).

The course loop (student versions, grading) is :mod:`labkit.course`; making and
opening labs is :mod:`labkit.labs`.
"""

from labkit.reports._execute import CELL_TIMEOUT, ExecutionResult, notebooks_root, find_notebooks, lab_of, parse_parameter, check_parameter_types, notebook_parameters, kernel_manager_class, execute_notebook
from labkit.reports._render import RenderResult, find_chromium, export_html, print_pdf, render, render_one, write_index
from labkit.reports._nbtools import Comparison, Checks, check, show_latex, matrix_latex
from labkit.tables import LONG_TABLE_ROWS, ReportTable, error_report_table, format_value, report_table
from labkit.reports._report import LabInfo, ReportResult, lab_info, write_lab_info, build_report

__all__ = [
    "CELL_TIMEOUT",
    "ExecutionResult",
    "notebooks_root",
    "find_notebooks",
    "lab_of",
    "parse_parameter",
    "check_parameter_types",
    "notebook_parameters",
    "kernel_manager_class",
    "execute_notebook",
    "RenderResult",
    "find_chromium",
    "export_html",
    "print_pdf",
    "render",
    "render_one",
    "write_index",
    "Comparison",
    "Checks",
    "check",
    "show_latex",
    "matrix_latex",
    "LONG_TABLE_ROWS",
    "ReportTable",
    "report_table",
    "error_report_table",
    "format_value",
    "LabInfo",
    "ReportResult",
    "lab_info",
    "write_lab_info",
    "build_report",
]
