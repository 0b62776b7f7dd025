"""Grading one submission: hidden tests put back, sandboxed execution, scores, feedback report.

A submission is a folder holding the student's copies of the lab's notebooks
(same file names as the instructor's lab folder) and any files they need.
:func:`grade_submission` copies only that folder into a fresh temporary working
directory, rebuilds each notebook from the student's cells and the instructor's
checks (see :func:`graded_notebook`), runs it against ``sim://`` in the sandbox of
:func:`labkit.course.run_untrusted`, scores every check, and writes the
executed notebook and an offline HTML feedback report (the template of
``labkit render``) into ``output_dir/<student>/``.

Example
-------
>>> import nbformat
>>> from labkit.course import graded_notebook
>>> cell = nbformat.v4.new_code_cell
>>> source = nbformat.v4.new_notebook(cells=[cell("x = 1", id="work", metadata={"tags": ["solution"]}),
...                                          cell("assert x == 1", id="t1", metadata={"tags": ["tests"]}),
...                                          cell("assert x > 0", id="h1", metadata={"tags": ["hidden-tests"]})])
>>> student = nbformat.v4.new_notebook(cells=[cell("x = 2", id="work"),
...                                           cell("pass  # edited", id="t1", metadata={"tags": ["tests"]})])
>>> [c.source for c in graded_notebook(source, student).cells]
['x = 2', 'assert x == 1', 'assert x > 0']
"""

from __future__ import annotations

import copy
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from labkit.exceptions import LabkitError
from labkit.course._assign import HIDDEN_TESTS_TAG, TESTS_TAG, cell_role, graded_cells
from labkit.course._sandbox import Limits, run_untrusted
from labkit.reports import notebook_parameters

__all__ = ["CellScore", "SubmissionResult", "graded_notebook", "grade_submission"]

#: the port every graded notebook runs against (the virtual arm)
GRADING_PORT = "sim://"


@dataclass(frozen=True)
class CellScore:
    """The score of one check of one submission.

    Attributes
    ----------
    notebook, name : str
        Notebook file name and check name.
    points, max_points : float
        Points earned and possible [points].
    hidden : bool
        True for a hidden check.
    passed : bool
        True when the check cell ran without an error.
    """

    notebook: str
    name: str
    points: float
    max_points: float
    hidden: bool
    passed: bool


@dataclass(frozen=True)
class SubmissionResult:
    """One student's grading.

    Attributes
    ----------
    student : str
        Submission folder name.
    status : str
        Worst outcome over the notebooks: ``"ok"``, ``"error"`` (a cell raised; the other checks
        still ran), ``"timeout"``, ``"cpu-time"``, ``"memory"``, ``"crash"``, ``"missing"``.
    detail : str
        What happened, per notebook that did not end ``"ok"``.
    scores : tuple of CellScore
        Every check of the lab, in order.
    seconds : float
        Wall time of the grading [s].
    files : dict
        Relative path -> bytes of the feedback written (executed notebooks, HTML reports);
        filled only by batch tasks that send the files back to the driver.
    """

    student: str
    status: str
    detail: str
    scores: tuple
    seconds: float
    files: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def points(self) -> float:
        """Total points earned [points]."""
        return sum(s.points for s in self.scores)

    @property
    def max_points(self) -> float:
        """Total points possible [points]."""
        return sum(s.max_points for s in self.scores)


_SEVERITY = ("ok", "error", "missing", "memory", "cpu-time", "timeout", "crash")


def graded_notebook(source, student):
    """The notebook to grade: the student's cells with the instructor's checks put back.

    Every ``tests`` / ``hidden-tests`` cell of ``source`` appears with the instructor's text:
    a student cell with the same id is replaced (edits to a check do not count), a missing one
    is inserted after the nearest preceding cell the student still has. Student cells
    claiming a test tag that the instructor does not have lose the tag.

    Parameters
    ----------
    source, student : nbformat.NotebookNode
        The instructor's notebook and the student's submission (not modified).

    Returns
    -------
    nbformat.NotebookNode
        A new notebook (the student's metadata; outputs cleared).
    """
    tests = {str(c.get("id")): c for c in source.cells if cell_role(c) in (TESTS_TAG, HIDDEN_TESTS_TAG)}
    nb = copy.deepcopy(student)
    cells = []
    for cell in nb.cells:
        cid = str(cell.get("id"))
        if cid in tests:
            cells.append(copy.deepcopy(tests[cid]))
            continue
        tags = cell.get("metadata", {}).get("tags", [])
        if TESTS_TAG in tags or HIDDEN_TESTS_TAG in tags:
            cell.metadata["tags"] = [t for t in tags if t not in (TESTS_TAG, HIDDEN_TESTS_TAG)]
        cells.append(cell)
    present = {str(c.get("id")) for c in cells}
    for i, cell in enumerate(source.cells):
        cid = str(cell.get("id"))
        if cid not in tests or cid in present:
            continue
        anchor = next((str(c.get("id")) for c in reversed(source.cells[:i]) if str(c.get("id")) in present), None)
        at = 0 if anchor is None else 1 + next(k for k, c in enumerate(cells) if str(c.get("id")) == anchor)
        cells.insert(at, copy.deepcopy(cell))
        present.add(cid)
    for cell in cells:
        if cell.cell_type == "code":
            cell.outputs, cell.execution_count = [], None
    nb.cells = cells
    nb.metadata.setdefault("kernelspec", source.metadata.get("kernelspec",
                                                             {"name": "python3", "language": "python"}))
    return nb


def _inject_parameters(nb, params):
    """Insert papermill's ``injected-parameters`` cell after the ``parameters`` cell (else first)."""
    import nbformat

    text = "# Parameters (injected by labkit grade)\n" + "\n".join(f"{k} = {v!r}" for k, v in params.items())
    injected = nbformat.v4.new_code_cell(text, metadata={"tags": ["injected-parameters"]})
    at = next((i + 1 for i, c in enumerate(nb.cells) if "parameters" in c.get("metadata", {}).get("tags", [])), 0)
    nb.cells.insert(at, injected)
    return nb


def _passed(cell) -> bool:
    return cell.get("execution_count") is not None and not any(
        o.get("output_type") == "error" for o in cell.get("outputs", []))


def _score_cell(scores, nb_name, status):
    """A markdown cell summarising the scores, for the top of the feedback report."""
    import nbformat

    rows = "\n".join(f"| {s.name} | {'hidden' if s.hidden else 'public'} | {'pass' if s.passed else 'FAIL'} "
                     f"| {s.points:g} / {s.max_points:g} |" for s in scores)
    total, most = sum(s.points for s in scores), sum(s.max_points for s in scores)
    return nbformat.v4.new_markdown_cell(
        f"## Feedback: {nb_name}\n\nScore **{total:g} / {most:g}**; run status: `{status}`.\n\n"
        f"| check | kind | result | points |\n|---|---|---|---|\n{rows}\n")


def grade_submission(submission, lab_dir, output_dir, *, limits=None, hide=(), html=True) -> SubmissionResult:
    """Grade one submission folder against the instructor's lab folder.

    Parameters
    ----------
    submission : str or os.PathLike
        The student's folder (its name is the student's name in the gradebook).
    lab_dir : str or os.PathLike
        The instructor's lab folder (tagged notebooks with solutions and hidden tests).
    output_dir : str or os.PathLike
        Feedback goes to ``output_dir/<student>/<notebook>.ipynb`` and ``.html``.
    limits : Limits, optional
        Per-notebook CPU, memory and wall-clock limits.
    hide : sequence of path-like
        Further folders the student's code must not see (the submission's own parent
        folder, ``lab_dir`` and ``output_dir`` are always hidden).
    html : bool
        Write the HTML feedback reports.

    Returns
    -------
    SubmissionResult
        Never raises for anything the student's code does.

    Raises
    ------
    LabkitError
        If ``submission`` or ``lab_dir`` is not a folder, or the sandbox cannot start.
    """
    import nbformat
    from labkit.reports import export_html

    t0 = time.perf_counter()
    submission, lab, out = Path(submission).resolve(), Path(lab_dir).resolve(), Path(output_dir).resolve()
    for what, path in (("submission", submission), ("lab", lab)):
        if not path.is_dir():
            raise LabkitError(f"expected a {what} folder, got {path}")
    notebooks = sorted(p for p in lab.glob("*.ipynb") if not p.name.startswith("_"))
    if not notebooks:
        raise LabkitError(f"expected lab notebooks (*.ipynb) in {lab}, found none")
    student = submission.name
    feedback = out / student
    feedback.mkdir(parents=True, exist_ok=True)
    hide = [submission.parent, lab, out, *hide]
    limits = limits or Limits()
    scores, statuses, details = [], [], []
    root = Path(tempfile.mkdtemp(prefix="labkit-grade-"))
    try:
        work = root / "work"
        shutil.copytree(submission, work, symlinks=True)  # this submission only; links are not followed
        for p in lab.rglob("*"):  # the lab's data files the student did not bring
            rel = p.relative_to(lab)
            if p.is_file() and p.suffix != ".ipynb" and not (work / rel).exists():
                (work / rel).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(p, work / rel)
        for source_path in notebooks:
            source = nbformat.read(str(source_path), as_version=4)
            checks = graded_cells(source, source_path.name)
            mine = work / source_path.name
            try:
                theirs = nbformat.read(str(mine), as_version=4)
            except Exception as exc:  # missing or not a notebook: every check fails
                statuses.append("missing")
                details.append(f"{source_path.name}: cannot read the submission ({type(exc).__name__})")
                scores += [CellScore(c.notebook, c.name, 0.0, c.points, c.hidden, False) for c in checks]
                continue
            nb = graded_notebook(source, theirs)
            declared = notebook_parameters(source_path)
            params = {"port": GRADING_PORT, "output_dir": str(work / f"{source_path.stem}_files")}
            params = {k: v for k, v in params.items() if k in declared}
            if params:
                nb = _inject_parameters(nb, params)
            status, detail = run_untrusted(nb, work, limits=limits, hide=hide)
            check_ids = {c.cell_id for c in checks}
            if status == "error":  # a failing check is a score, not a run error; an error elsewhere is
                errors = [o for c in nb.cells if str(c.get("id")) not in check_ids
                          for o in c.get("outputs", []) if o.get("output_type") == "error"]
                status, detail = ("error", f"{errors[0].get('ename')}: {errors[0].get('evalue', '')}"[:300]) \
                    if errors else ("ok", "")
            statuses.append(status)
            if status != "ok":
                details.append(f"{source_path.name}: {status}: {detail}")
            by_id = {str(c.get("id")): c for c in nb.cells}
            nb_scores = [CellScore(c.notebook, c.name, c.points if _passed(by_id[c.cell_id]) else 0.0, c.points,
                                    c.hidden, _passed(by_id[c.cell_id])) for c in checks]
            scores += nb_scores
            nb.cells.insert(0, _score_cell(nb_scores, source_path.name, status))
            nbformat.write(nb, str(feedback / source_path.name))
            if html:
                total = sum(s.points for s in nb_scores)
                export_html(nb, feedback / f"{source_path.stem}.html", title=f"{student} / {source_path.stem}",
                            status="passed" if all(s.passed for s in nb_scores) else "failed",
                            error=f"score {total:g} / {sum(c.points for c in checks):g}; run status {status}"
                            + (f": {detail}" if detail else ""))
    finally:
        shutil.rmtree(root, ignore_errors=True)
    worst = max(statuses, key=_SEVERITY.index) if statuses else "missing"
    return SubmissionResult(student, worst, "; ".join(details), tuple(scores), time.perf_counter() - t0)
