"""Reports: executing lab notebooks, rendering HTML/PDF reports, the helpers
notebooks use (:class:`Checks`, tables, LaTeX), and a course's loop: student
versions (:func:`assign`), sandboxed autograding (:func:`grade`) and batches on a
local pool or a dask.distributed cluster.
"""

from labkit.reports._execute import (
    CELL_TIMEOUT,
    ExecutionResult,
    notebooks_root,
    find_notebooks,
    lab_of,
    parse_parameter,
    check_parameter_types,
    notebook_parameters,
    execute_notebook,
)
from labkit.reports._render import RenderResult, export_html, print_pdf, render, render_one, write_index
from labkit.reports._nbtools import CheckRow, Checks, check, show_latex, matrix_latex, show_table
from labkit.reports._assign import (
    CODE_STUB,
    HIDDEN_TESTS_TAG,
    PARAMETERS_TAG,
    SOLUTION_TAG,
    TESTS_TAG,
    AssignResult,
    Check,
    assign,
    cell_role,
    lab_checks,
    student_notebook,
)
from labkit.reports._sandbox import Limits, run_untrusted
from labkit.reports._grade import CheckScore, SubmissionResult, grade_submission, graded_notebook
from labkit.reports._batch import (
    grade,
    gradebook_frame,
    pack_dir,
    render_batch,
    run_tasks,
    unpack_dir,
    write_gradebook,
)
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
    "check_parameter_types",
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
    "CODE_STUB",
    "HIDDEN_TESTS_TAG",
    "PARAMETERS_TAG",
    "SOLUTION_TAG",
    "TESTS_TAG",
    "AssignResult",
    "Check",
    "assign",
    "cell_role",
    "lab_checks",
    "student_notebook",
    "Limits",
    "run_untrusted",
    "CheckScore",
    "SubmissionResult",
    "grade_submission",
    "graded_notebook",
    "grade",
    "gradebook_frame",
    "pack_dir",
    "render_batch",
    "run_tasks",
    "unpack_dir",
    "write_gradebook",
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
