"""Reports: executing lab notebooks, rendering HTML/PDF reports, and the helpers
notebooks use (:class:`Checks`, tables, LaTeX).
"""

from labkit.reports._execute import (
    CELL_TIMEOUT,
    ExecutionResult,
    notebooks_root,
    find_notebooks,
    lab_of,
    parse_parameter,
    notebook_parameters,
    execute_notebook,
)
from labkit.reports._render import RenderResult, export_html, print_pdf, render, render_one, write_index
from labkit.reports._nbtools import CheckRow, Checks, check, show_latex, matrix_latex, show_table
from labkit.reports._lab import lab_command, serve_lab
from labkit.reports._labunits import (
    joints_from_display,
    joints_to_display,
    target_from_display,
    target_error,
    servo_window,
    robot_reach,
)
from labkit.reports._scaffold import LabDefaults, NewLab, lab_defaults, new_lab

__all__ = [
    "CELL_TIMEOUT",
    "ExecutionResult",
    "notebooks_root",
    "find_notebooks",
    "lab_of",
    "parse_parameter",
    "notebook_parameters",
    "execute_notebook",
    "RenderResult",
    "export_html",
    "print_pdf",
    "render",
    "render_one",
    "write_index",
    "CheckRow",
    "Checks",
    "check",
    "show_latex",
    "matrix_latex",
    "show_table",
    "lab_command",
    "serve_lab",
    "LabDefaults",
    "NewLab",
    "lab_defaults",
    "servo_window",
    "joints_from_display",
    "joints_to_display",
    "target_from_display",
    "target_error",
    "robot_reach",
    "new_lab",
]
