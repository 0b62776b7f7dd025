"""Student versions of lab notebooks: ``labkit assign``, built on nbgrader's preprocessors.

labkit's lab notebooks mark cells with tags (the team's fixed scheme):

``solution``
    Student work. The student version replaces it with a stub that raises
    ``NotImplementedError``. Leading comment lines (``# Hint: ...``) stay as the hint;
    with nbgrader's ``### BEGIN SOLUTION`` / ``### END SOLUTION`` delimiters only the
    delimited region is replaced and the rest of the cell (scaffolding) stays.
``tests``
    Public checks: kept (and locked against editing in JupyterLab). A region between
    ``### BEGIN HIDDEN TESTS`` / ``### END HIDDEN TESTS`` inside it is removed.
``hidden-tests``
    Removed from the student version; put back only when the submission is graded.
``parameters``
    papermill's parameters cell: left intact.

A ``tests`` or ``hidden-tests`` cell is one check: it passes when it runs without an
error. Its name is ``metadata["labkit"]["check"]`` (default: the cell id) and its
weight ``metadata["labkit"]["points"]`` (default 1).

:func:`assign` translates the tags into nbgrader's cell metadata (``solution``,
``grade``, ``locked``, ``grade_id``, ``points``) and runs nbgrader's own
``ClearSolutions``, ``ClearHiddenTests``, ``LockCells`` and ``ClearOutput``
preprocessors; cell ids are kept, so a submission's cells can be matched to the
instructor's at grading time.

Example
-------
>>> import nbformat
>>> from labkit.course import student_notebook
>>> nb = nbformat.v4.new_notebook(cells=[
...     nbformat.v4.new_code_cell("# Hint: the cosine law\\nc2 = 0.5", metadata={"tags": ["solution"]}),
...     nbformat.v4.new_code_cell("assert c2 == 0.5", metadata={"tags": ["hidden-tests"]})])
>>> student = student_notebook(nb)
>>> [c.source for c in student.cells]
['# Hint: the cosine law\\n# YOUR CODE HERE\\nraise NotImplementedError()']
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path

from labkit.exceptions import LabkitError, needs_extra
from labkit.course._safefs import read_tree, write_tree

__all__ = ["SOLUTION_TAG", "TESTS_TAG", "HIDDEN_TESTS_TAG", "PARAMETERS_TAG", "REFERENCE_TAG", "CODE_STUB",
           "GradedCell", "AssignResult", "cell_role", "graded_cells", "student_notebook", "assign"]

SOLUTION_TAG = "solution"
TESTS_TAG = "tests"
HIDDEN_TESTS_TAG = "hidden-tests"
PARAMETERS_TAG = "parameters"
#: the instructor's trusted references: removed from the student version, run only by the checker (never in the
#: student's kernel), before the checks; the names they assign are never taken from the student's values
REFERENCE_TAG = "reference"
_ROLES = (SOLUTION_TAG, TESTS_TAG, HIDDEN_TESTS_TAG, PARAMETERS_TAG, REFERENCE_TAG)
#: what replaces a solution (nbgrader's stub; the cell's leading comments stay above it as the hint)
CODE_STUB = "# YOUR CODE HERE\nraise NotImplementedError()"
_BEGIN_SOLUTION, _END_SOLUTION = "### BEGIN SOLUTION", "### END SOLUTION"
_BEGIN_HIDDEN = "### BEGIN HIDDEN TESTS"


@dataclass(frozen=True)
class GradedCell:
    """One graded check: a ``tests`` or ``hidden-tests`` cell.

    Attributes
    ----------
    notebook : str
        Notebook file name (``01_ik.ipynb``).
    cell_id : str
        The cell's id (stable across the student version).
    name : str
        Check name (``metadata["labkit"]["check"]``, default the cell id).
    points : float
        Weight of the check [points].
    hidden : bool
        True for a ``hidden-tests`` cell (absent from the student version).
    """

    notebook: str
    cell_id: str
    name: str
    points: float
    hidden: bool


@dataclass(frozen=True)
class AssignResult:
    """What :func:`assign` wrote.

    Attributes
    ----------
    notebooks : tuple of Path
        The student notebooks.
    other_files : tuple of Path
        Non-notebook files copied with them (data, images).
    checks : tuple of GradedCell
        Every check of the lab (public and hidden).
    """

    notebooks: tuple
    other_files: tuple
    checks: tuple


def cell_role(cell) -> str | None:
    """The authoring role of a cell: one of the five tags, or None for an ordinary cell.

    Parameters
    ----------
    cell : nbformat.NotebookNode
        A notebook cell.

    Returns
    -------
    str or None
        ``"solution"``, ``"tests"``, ``"hidden-tests"``, ``"parameters"``, ``"reference"`` or None.

    Raises
    ------
    LabkitError
        If the cell carries two roles, or a test/parameters tag sits on a non-code cell.
    """
    tags = set(cell.get("metadata", {}).get("tags", []))
    roles = [r for r in _ROLES if r in tags]
    if len(roles) > 1:
        raise LabkitError(f"cell {cell.get('id')!r} has tags {roles}; expected at most one of {list(_ROLES)}")
    if not roles:
        return None
    if roles[0] != SOLUTION_TAG and cell.cell_type != "code":
        raise LabkitError(f"cell {cell.get('id')!r} is tagged {roles[0]!r} but is a {cell.cell_type} cell; "
                          "expected a code cell")
    return roles[0]


def _check_of(notebook_name, cell, role) -> GradedCell:
    meta = cell.get("metadata", {}).get("labkit", {})
    points = meta.get("points", 1)
    if not isinstance(points, (int, float)) or isinstance(points, bool) or points < 0:
        raise LabkitError(f"{notebook_name} cell {cell.get('id')!r}: expected labkit.points >= 0, got {points!r}")
    return GradedCell(notebook_name, str(cell.get("id")), str(meta.get("check", cell.get("id"))), float(points),
                 role == HIDDEN_TESTS_TAG)


def graded_cells(notebook, name=None) -> list[GradedCell]:
    """The checks (``tests`` and ``hidden-tests`` cells) of an instructor notebook, in cell order.

    Parameters
    ----------
    notebook : nbformat.NotebookNode or str or os.PathLike
        The notebook or its file.
    name : str, optional
        Notebook file name recorded in the checks (default: the file's name).

    Returns
    -------
    list of GradedCell
    """
    nb, name = _read(notebook, name)
    return [_check_of(name, c, role) for c in nb.cells if (role := cell_role(c)) in (TESTS_TAG, HIDDEN_TESTS_TAG)]


def _read(notebook, name=None):
    with needs_extra("course"):
        import nbformat

    if isinstance(notebook, (str, Path)):
        path = Path(notebook)
        if not path.is_file():
            raise LabkitError(f"notebook not found: {path}")
        return nbformat.read(str(path), as_version=4), name or path.name
    return notebook, name or "notebook.ipynb"


def _to_nbgrader(nb):
    """A copy of ``nb`` with the labkit tags translated into nbgrader cell metadata."""
    nb = copy.deepcopy(nb)
    for cell in nb.cells:
        role = cell_role(cell)
        cell_id = str(cell.get("id"))
        if role == SOLUTION_TAG:
            if _BEGIN_SOLUTION not in cell.source:  # the whole cell but its leading comment lines (the hint)
                lines = cell.source.split("\n")
                n_hint = 0
                while n_hint < len(lines) and lines[n_hint].lstrip().startswith("#"):
                    n_hint += 1
                cell.source = "\n".join(lines[:n_hint] + [_BEGIN_SOLUTION] + lines[n_hint:] + [_END_SOLUTION])
            cell.metadata["nbgrader"] = {"solution": True, "grade": False, "locked": False,
                                         "grade_id": cell_id, "schema_version": 3}
        elif role in (TESTS_TAG, HIDDEN_TESTS_TAG):
            if role == HIDDEN_TESTS_TAG:  # the whole cell is hidden
                cell.source = f"{_BEGIN_HIDDEN}\n{cell.source}\n### END HIDDEN TESTS"
            cell.metadata["nbgrader"] = {"solution": False, "grade": True, "locked": True, "grade_id": cell_id,
                                         "points": _check_of("", cell, role).points, "schema_version": 3}
        elif _BEGIN_SOLUTION in cell.source or _BEGIN_HIDDEN in cell.source:
            raise LabkitError(f"cell {cell_id!r} has nbgrader delimiters but no 'solution' or 'tests' tag")
    return nb


def student_notebook(nb):
    """The student version of an instructor notebook (a new notebook; ``nb`` is not changed).

    Parameters
    ----------
    nb : nbformat.NotebookNode
        Instructor notebook with tagged cells.

    Returns
    -------
    nbformat.NotebookNode
        Solutions replaced by :data:`CODE_STUB` (hint comments kept), ``hidden-tests``
        cells removed, hidden regions of ``tests`` cells removed, test cells locked,
        outputs cleared; every other cell (the ``parameters`` cell included) unchanged.

    Raises
    ------
    LabkitError
        For conflicting tags or misplaced nbgrader delimiters.
    """
    with needs_extra("course"):
        from nbgrader.preprocessors import ClearHiddenTests, ClearOutput, ClearSolutions, LockCells

    nb = _to_nbgrader(nb)
    resources = {}
    try:
        nb, resources = ClearSolutions(code_stub={"python": CODE_STUB}).preprocess(nb, resources)
        nb, resources = ClearHiddenTests().preprocess(nb, resources)
    except RuntimeError as exc:  # nbgrader's message for unbalanced delimiters
        raise LabkitError(f"cannot make the student version: {exc}") from exc
    nb.cells = [c for c in nb.cells if cell_role(c) not in (HIDDEN_TESTS_TAG, REFERENCE_TAG)]
    nb, resources = LockCells(lock_grade_cells=True, lock_solution_cells=True).preprocess(nb, resources)
    nb, resources = ClearOutput().preprocess(nb, resources)
    return nb


def assign(lab_dir, out_dir) -> AssignResult:
    """Write the student version of every notebook of a lab folder.

    Parameters
    ----------
    lab_dir : str or os.PathLike
        Instructor lab folder (``*.ipynb`` with tagged cells, plus any data files).
    out_dir : str or os.PathLike
        Where the student versions go (created); other files of the lab folder
        (not ``.ipynb_checkpoints``) are copied alongside.

    Returns
    -------
    AssignResult

    Raises
    ------
    LabkitError
        If ``lab_dir`` holds no notebook, ``out_dir`` is inside ``lab_dir``, or a notebook's tags
        are inconsistent (nothing is written for a lab with a bad notebook).
    """
    with needs_extra("course"):
        import nbformat

    lab, out = Path(lab_dir).resolve(), Path(out_dir).resolve()
    notebooks = sorted(p for p in lab.glob("*.ipynb") if not p.name.startswith("_"))
    if not notebooks:
        raise LabkitError(f"expected lab notebooks (*.ipynb) in {lab}, found none")
    if out == lab or lab in out.parents:
        raise LabkitError(f"expected an output folder outside the lab folder {lab}, got {out}")
    students = {p.name: student_notebook(nbformat.read(str(p), as_version=4)) for p in notebooks}
    checks = tuple(c for p in notebooks for c in graded_cells(p))
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name, nb in students.items():
        nbformat.write(nb, str(out / name))
        written.append(out / name)
    data = {rel: content for rel, content in read_tree(lab).items() if not rel.endswith(".ipynb")}
    write_tree(data, out, replace=True)
    others = [out / rel for rel in data]
    return AssignResult(tuple(written), tuple(others), checks)
