"""A course's loop: student versions of the labs (:func:`assign`), sandboxed
autograding of submissions (:func:`grade_submission`, :func:`run_untrusted`), and
batches of gradings or renders on a local process pool or a dask.distributed cluster
(:func:`grade`, :func:`render_batch`, the gradebook).
"""

from labkit.course._assign import CODE_STUB, HIDDEN_TESTS_TAG, PARAMETERS_TAG, SOLUTION_TAG, TESTS_TAG, AssignResult, GradedCell, assign, cell_role, graded_cells, student_notebook
from labkit.course._sandbox import Limits, run_untrusted
from labkit.course._grade import CellScore, SubmissionResult, grade_submission, graded_notebook
from labkit.course._batch import grade, gradebook_frame, pack_dir, render_batch, run_tasks, unpack_dir, write_gradebook

__all__ = [
    "CODE_STUB",
    "HIDDEN_TESTS_TAG",
    "PARAMETERS_TAG",
    "SOLUTION_TAG",
    "TESTS_TAG",
    "AssignResult",
    "GradedCell",
    "assign",
    "cell_role",
    "graded_cells",
    "student_notebook",
    "Limits",
    "run_untrusted",
    "CellScore",
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
]
