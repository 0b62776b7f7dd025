"""A course's loop: student versions of the labs (:func:`assign`), sandboxed
autograding of submissions (:func:`grade_submission`: the submission runs in an allow-list
sandbox, :func:`run_untrusted`, in a memory cgroup of its own, :func:`memory_cgroup`, and hands
out the values its checks read as plain data; the instructor's checks run afterwards in a clean
process; :func:`baseline` finds the checks that pass without student work), and
batches of gradings or renders on a local process pool or a dask.distributed cluster
(:func:`grade`, :func:`render_batch`, the gradebook).
"""

from labkit.course._assign import CODE_STUB, HIDDEN_TESTS_TAG, PARAMETERS_TAG, SOLUTION_TAG, TESTS_TAG, AssignResult, GradedCell, assign, cell_role, graded_cells, student_notebook
from labkit.course._cgroup import MemoryCgroup, memory_cgroup, memory_mechanism
from labkit.course._sandbox import SANDBOX_HOME, Limits, RunResult, check_sandbox, run_untrusted, sandbox_args
from labkit.course._points import CellScore, RowScore
from labkit.course._grade import Baseline, SubmissionResult, baseline, grade_submission, graded_notebook
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
    "MemoryCgroup",
    "memory_cgroup",
    "memory_mechanism",
    "SANDBOX_HOME",
    "Limits",
    "RunResult",
    "check_sandbox",
    "run_untrusted",
    "sandbox_args",
    "Baseline",
    "CellScore",
    "RowScore",
    "baseline",
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
