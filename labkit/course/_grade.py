"""Grading one submission: run it in the sandbox, hand out the checks' data, score in a clean process.

A submission is a folder holding the student's copies of the lab's notebooks (same file
names as the instructor's lab folder) and any files they need. :func:`grade_submission`

1. copies the folder's regular files (never a symlink, never a file over the size limit)
   into a fresh working copy, plus the lab's data files the student did not bring;
2. rebuilds each notebook from the student's cells and the instructor's checks
   (:func:`graded_notebook`), then replaces every check by an **export step** that hands
   out, as plain data, the values the check reads (:mod:`labkit.course._wire`): the
   instructor's check code never enters the student's kernel;
3. runs it against ``sim://`` in the sandbox of :func:`labkit.course.run_untrusted`;
4. runs the instructor's checks on the handed-out data in a separate clean process
   (:mod:`labkit.course._checker`), one score per row;
5. scores (:mod:`labkit.course._points`): a check's points are shared by its rows, except
   **free** rows (rows that pass on the untouched student version, see :func:`baseline`, and
   check no value a row needing work reads), which are worth 0; a row that rests on a value
   of the lab's earns only while the rows proving that value pass;
6. writes a small feedback page (:mod:`labkit.course._feedback`).

Nothing the student's code patches, hooks or prints reaches the verdict: at most it
changes the data handed out, which it could change by assigning the variables.

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
import time
from dataclasses import dataclass, field
from pathlib import Path

from labkit.exceptions import LabkitError, needs_extra
from labkit.course._assign import (HIDDEN_TESTS_TAG, PARAMETERS_TAG, REFERENCE_TAG, SOLUTION_TAG, TESTS_TAG, cell_role,
                                   graded_cells, student_notebook)
from labkit.course._checker import run_checker
from labkit.course._leftovers import new_folder, temporary_folder
from labkit.course._plan import plan_check, prelude_source, python_source
from labkit.course._points import score_notebook, unscored
from labkit.course._sandbox import SANDBOX_HOME, Limits, check_sandbox, run_untrusted, sandbox_args
from labkit.course._safefs import read_tree, remove_tree, write_tree
from labkit.course._submission import clean_text, copy_regular_files, error_detail, read_student_notebook, student_label
from labkit.course._wire import MIME, export_source
from labkit.reports import notebook_parameters

__all__ = ["SubmissionResult", "Baseline", "graded_notebook", "grade_submission", "baseline"]

#: the port every graded notebook runs against (the virtual arm)
GRADING_PORT = "sim://"


@dataclass(frozen=True)
class SubmissionResult:
    """One student's grading.

    Attributes
    ----------
    student : str
        Submission folder name.
    status : str
        Worst outcome over the notebooks: ``"ok"``, ``"error"`` (a cell raised; the other
        checks still ran), ``"missing"``, ``"invalid"`` (not a notebook, malformed, or not a
        folder), ``"memory"``, ``"cpu-time"``, ``"timeout"``, ``"crash"``.
    detail : str
        What happened: per notebook the run's problems (exception type, message, cell, line)
        and the failing rows.
    scores : tuple of CellScore
        Every check of the lab, in order.
    seconds : float
        Wall time of the grading [s].
    files : dict
        Relative path -> bytes of the feedback written; filled only by batch tasks.
    memory_limit : str
        How the memory limit was enforced: ``"cgroup v2"``, ``"cgroup v1"`` (a memory cgroup per
        run, exact) or ``"watchdog"`` (sampling); ``""`` if no notebook ran.
    """

    student: str
    status: str
    detail: str
    scores: tuple
    seconds: float
    files: dict = field(default_factory=dict, repr=False, compare=False)
    memory_limit: str = ""

    @property
    def points(self) -> float:
        """Total points earned [points]."""
        return round(sum(s.points for s in self.scores), 9)

    @property
    def max_points(self) -> float:
        """Total points possible [points]."""
        return round(sum(s.max_points for s in self.scores), 9)


_SEVERITY = ("ok", "error", "missing", "invalid", "memory", "cpu-time", "timeout", "crash")


def graded_notebook(source, student):
    """The notebook to grade: the student's cells with the instructor's checks put back.

    Every ``tests`` / ``hidden-tests`` cell of ``source`` appears with the instructor's text:
    a student cell with the same id is replaced (edits to a check do not count), a missing one
    is inserted after the nearest preceding cell the student still has. Student cells
    claiming a test tag that the instructor does not have lose the tag.

    Parameters
    ----------
    source, student : nbformat.NotebookNode
        The instructor's notebook and the submission (not modified).

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
    nb.metadata["kernelspec"] = source.metadata.get("kernelspec", {"name": "python3", "language": "python"})
    return nb


def _inject_parameters(nb, params):
    """Insert papermill's ``injected-parameters`` cell after the ``parameters`` cell (else first)."""
    with needs_extra("course"):
        import nbformat

    text = "# Parameters (injected by labkit grade)\n" + "\n".join(f"{k} = {v!r}" for k, v in params.items())
    injected = nbformat.v4.new_code_cell(text, metadata={"tags": ["injected-parameters"]})
    at = next((i + 1 for i, c in enumerate(nb.cells) if "parameters" in c.get("metadata", {}).get("tags", [])), 0)
    nb.cells.insert(at, injected)
    return nb


def _run_one(source, theirs, name, work, limits, hide, private, declared):
    """Run one notebook; (status, detail, checks, plans, data by cell id, run notebook, memory mechanism)."""
    checks = {c.cell_id: c for c in graded_cells(source, name)}
    plans = {cid: plan_check(next(c.source for c in source.cells if str(c.get("id")) == cid), cid, chk.name)
             for cid, chk in checks.items()}
    nb = graded_notebook(source, theirs)
    for cell in nb.cells:
        cid = str(cell.get("id"))
        if cid in plans:
            cell.source = export_source(plans[cid].free_names, cid)
            cell.metadata = {"labkit": {"export": cid}}
    params = _grading_parameters(work, limits, name, declared)
    if params:
        nb = _inject_parameters(nb, params)
    status, detail, mechanism = run_untrusted(nb, work, limits=limits, hide=hide, private=private)
    data = {}
    for cell in nb.cells:
        cid = cell.get("metadata", {}).get("labkit", {}).get("export")
        if cid in plans:
            texts = [o["data"][MIME] for o in cell.get("outputs", [])
                     if o.get("output_type") == "display_data" and isinstance(o.get("data", {}).get(MIME), str)]
            data[cid] = texts[-1] if texts else None
    errors = [(i, c) for i, c in enumerate(nb.cells) if c.cell_type == "code" and c.get("metadata", {}).get(
        "labkit", {}).get("export") is None and any(o.get("output_type") == "error" for o in c.get("outputs", []))]
    if status == "error":
        mine = {str(c.get("id")): i for i, c in enumerate(theirs.cells)}  # cell numbers as the student sees them
        first = errors[0] if errors else None
        status, detail = ("error", error_detail(first[1], mine.get(str(first[1].get("id")), first[0]))) if first \
            else ("ok", "")
    return status, detail, checks, plans, data, nb, mechanism


def _grading_parameters(work, limits, name, declared) -> dict:
    """The parameters grading injects (``port``, ``output_dir``), those the notebook declares."""
    home = SANDBOX_HOME if limits.sandbox else str(work)
    params = {"port": GRADING_PORT, "output_dir": f"{home}/{Path(name).stem}_files"}
    return {k: v for k, v in params.items() if k in declared}


def trusted_sources(source, params) -> list:
    """The instructor's cells the checker runs whole, after the prelude: trusted parameters and references.

    The ``parameters`` cell (then the values grading injects) and every ``reference`` cell, in
    order. They run in the checker's process only (a ``reference`` cell is not in the student
    version and never runs in the student's kernel), so the names they assign (the target, the
    robot, a reference solution) are the instructor's, never the values the student's kernel hands out.

    Parameters
    ----------
    source : nbformat.NotebookNode
        The instructor's notebook.
    params : dict
        The injected parameters.

    Returns
    -------
    list of str
    """
    out = []
    for cell in source.cells:
        role = cell_role(cell)
        if role == PARAMETERS_TAG:
            out.append(python_source(cell.source))
            if params:
                out.append("\n".join(f"{k} = {v!r}" for k, v in params.items()))
        elif role == REFERENCE_TAG:
            out.append(python_source(cell.source))
    return out


def _scrub(text, *paths) -> str:
    for p in paths:
        if p:
            text = text.replace(str(p), "~")
    return text


def grade_submission(submission, lab_dir, output_dir, *, limits=None, hide=(), html=True, free=None, student=None) \
        -> SubmissionResult:
    """Grade one submission folder against the instructor's lab folder.

    Parameters
    ----------
    submission : str or os.PathLike
        The student's folder (its name is the student's name in the gradebook).
    lab_dir : str or os.PathLike
        The instructor's lab folder (tagged notebooks with solutions and hidden tests).
    output_dir : str or os.PathLike
        Feedback goes to ``output_dir/students/<student, percent-encoded>/index.html``
        (:func:`labkit.course._feedback.student_folder`).
    limits : Limits, optional
        Per-notebook CPU, memory and wall-clock limits.
    hide : sequence of path-like
        Further folders the student's code must not see (the sandbox shows nothing of the
        host's but the Python installation and labkit; these are emptied even there).
    html : bool
        Write the feedback page.
    free : dict, optional
        ``{(notebook, cell id): set of row indices}`` that pass untouched (:func:`baseline`);
        default: computed now (one more run of the lab's student version).
    student : str, optional
        The student's name in the gradebook (default the folder's name, its undecodable bytes
        and control characters escaped: :func:`labkit.course._submission.student_label`).

    Returns
    -------
    SubmissionResult
        Never raises for anything in the submission (a malformed one is ``"invalid"``).

    Raises
    ------
    LabkitError
        If ``lab_dir`` holds no notebook, or the sandbox cannot start.
    """
    with needs_extra("course"):
        import nbformat

    from labkit.course._feedback import student_folder, write_feedback

    t0 = time.perf_counter()
    submission, lab, out = Path(submission), Path(lab_dir).resolve(), Path(output_dir).resolve()
    notebooks = sorted(p for p in lab.glob("*.ipynb") if not p.name.startswith("_"))
    if not notebooks:
        raise LabkitError(f"expected lab notebooks (*.ipynb) in {lab}, found none")
    sources = {p.name: nbformat.read(str(p), as_version=4) for p in notebooks}
    sources = {name: nb for name, nb in sources.items() if graded_cells(nb, name)}  # nothing to score elsewhere
    if not sources:
        raise LabkitError(f"expected a notebook with checks (cells tagged tests or hidden-tests) in {lab}, found none")
    limits = limits or Limits()
    if free is None:
        free = baseline(lab, limits=limits).free
    student = student_label(submission.name) if student is None else clean_text(student)
    if submission.is_symlink() or not submission.is_dir():
        return _invalid(student, sources, free, "the submission is not a folder (a symlink or a file)", t0)
    hide = [submission.resolve().parent, lab, out, *hide]
    root = new_folder("grade")  # named after this process: a later batch removes it if this one is killed
    statuses, details, scores, pages, mechanisms = [], [], [], [], []
    try:
        work = root / "home"
        work.mkdir()
        try:
            copy_regular_files(submission, work)
        except (LabkitError, OSError) as exc:
            return _invalid(student, sources, free, str(exc), t0)
        lab_data = {rel: data for rel, data in read_tree(lab).items() if not rel.endswith(".ipynb")}
        write_tree(lab_data, work)  # the lab's data files the student did not bring
        theirs_all = {}
        for name in sources:  # every notebook read before any kernel runs on the working copy
            try:
                theirs_all[name] = read_student_notebook(work, name)
            except FileNotFoundError:
                theirs_all[name] = ("missing", f"{name} is not in the submission")
            except Exception as exc:  # noqa: BLE001 - whatever is wrong with the student's file
                first = str(exc).splitlines()[0][:200] if str(exc) else ""
                theirs_all[name] = ("invalid", f"{name} is not a valid notebook: {type(exc).__name__}: {first}")
        runs, job = [], {"notebooks": []}
        for name, source in sources.items():
            theirs = theirs_all[name]
            if isinstance(theirs, tuple):
                runs.append((name, *theirs, None))
                continue
            status, detail, checks, plans, data, _, mechanism = _run_one(source, theirs, name, work, limits, hide,
                                                                        root, notebook_parameters(lab / name))
            mechanisms.append(mechanism)
            runs.append((name, status, detail, (checks, plans)))
            roles = [(c.source, cell_role(c) == SOLUTION_TAG) for c in source.cells if c.cell_type == "code"]
            trusted = list(prelude_source(roles)) + trusted_sources(source, _grading_parameters(work, limits, name,
                                                                                              notebook_parameters(lab / name)))
            job["notebooks"].append({"name": name, "prelude": trusted, "cells": [
                {"cell_id": p.cell_id, "name": p.name, "free_names": list(p.free_names),
                 "statements": [list(s) for s in p.statements], "rows": [list(_row_list(r)) for r in p.rows],
                 "error": p.error, "data": data.get(cid)} for cid, p in plans.items()]})
        checker = root / "checker"
        checker.mkdir()
        verdict = {"notebooks": []}
        if job["notebooks"]:
            args = sandbox_args(work, checker, hide, limits=limits, writable_home=False) if limits.sandbox else None
            verdict = run_checker(job, checker, limits=limits, sandbox_args=args)
        by_nb = {n["name"]: n for n in verdict.get("notebooks", [])}
        for name, status, detail, planned in runs:
            cells = {c["cell_id"]: c["rows"] for c in by_nb.get(name, {}).get("cells", [])}
            if planned is not None and "error" in verdict:
                status, detail = "crash", f"{detail + '; ' if detail else ''}{verdict['error']}"
            nb_scores = score_notebook(sources[name], name, cells, free, planned[1] if planned else None)
            scores += nb_scores
            statuses.append(status)
            failing = [f"{r.name if r.name.startswith(s.name) else s.name + ' / ' + r.name}: {r.error} (line {r.line})"
                       for s in nb_scores for r in s.rows
                       if not r.passed and not r.free and r.error]
            if status != "ok" or failing or detail:
                parts = [f"{status}: {detail}"] if status != "ok" or detail else []
                details.append(f"{name}: " + "; ".join(parts + failing[:4] + (["..."] if len(failing) > 4 else [])))
            pages.append((name, status, _scrub(detail, work, root), nb_scores))
    finally:
        remove_tree(root)
    worst = max(statuses, key=_SEVERITY.index) if statuses else "missing"
    result = SubmissionResult(student, worst, clean_text(" | ".join(details), 2000), tuple(scores),
                              time.perf_counter() - t0, memory_limit=", ".join(sorted(set(mechanisms))))
    if html:
        write_feedback(result, pages, out / student_folder(student))
    return result


def _row_list(row):
    """A :class:`~labkit.course._plan.Row` as a list (for the checker's JSON job)."""
    return [row.index, row.name, row.statement, row.line]


def _invalid(student, sources, free, why, t0, status="invalid") -> SubmissionResult:
    why = clean_text(why)
    return SubmissionResult(student, status, why[:500], unscored(sources, free, why[:200]), time.perf_counter() - t0)


@dataclass(frozen=True)
class Baseline:
    """What the untouched student version of a lab scores.

    Attributes
    ----------
    free : dict
        ``{(notebook, cell id): set of row indices}`` that pass without any student work: the free
        rows and the derivation rows, which the grading tells apart (:mod:`labkit.course._points`).
    result : SubmissionResult
        The untouched version's grading (every row counted).
    reasons : tuple of str
        One line per free row: which check, and why it passes untouched.
    max_points : float
        The most a submission can earn [points]: every check's points, shared by its rows that
        are not free (a check whose rows are all free is worth 0). The one maximum ``labkit
        assign`` reports and ``labkit grade``, the gradebook and the feedback pages use.
    derivations : tuple of str
        One line per derivation row: it passes untouched but checks values that rows needing
        work read, so it counts (:mod:`labkit.course._points`).
    """

    free: dict
    result: SubmissionResult
    reasons: tuple
    max_points: float = 0.0
    derivations: tuple = ()

    @property
    def free_points(self) -> float:
        """Points the untouched version would earn if free rows counted [points]."""
        return round(sum(r.points for s in self.result.scores for r in s.rows if r.passed), 9)


def baseline(lab_dir, *, limits=None) -> Baseline:
    """Grade the lab's untouched student version: which rows pass without student work, and why.

    Parameters
    ----------
    lab_dir : str or os.PathLike
        The instructor's lab folder.
    limits : Limits, optional

    Returns
    -------
    Baseline

    Raises
    ------
    LabkitError
        If the untouched version does not run to its end (a limit, a crash): then it cannot
        tell which rows are free; or if the sandbox cannot start here (:func:`check_sandbox`).
    """
    with needs_extra("course"):
        import nbformat

    from labkit.course._plan import python_source

    lab = Path(lab_dir).resolve()
    if (limits or Limits()).sandbox:
        check_sandbox()  # a refused user namespace is the machine's, not the lab's: say so before grading
    with temporary_folder("baseline") as tmp:
        sub = tmp / "untouched"
        sub.mkdir()
        solved, sources = {}, {}
        for p in sorted(lab.glob("*.ipynb")):
            if p.name.startswith("_"):
                continue
            nb = sources[p.name] = nbformat.read(str(p), as_version=4)
            nbformat.write(student_notebook(nb), str(sub / p.name))
            solved[p.name] = {n for c in nb.cells if cell_role(c) == SOLUTION_TAG
                              for n in _assigned(python_source(c.source))}
        result = grade_submission(sub, lab, tmp / "feedback", limits=limits, html=False, free={})
    if result.status not in ("ok", "error"):
        raise LabkitError(f"expected the untouched student version of {lab.name} to run to its end (its checks tell "
                          f"which rows are free), got status {result.status!r}: {result.detail[:300]}; "
                          "raise the limits (--cpu, --memory, --wall) or fix the lab")
    free = {}
    for s in result.scores:
        for index, r in enumerate(s.rows):
            if r.passed:
                free.setdefault((s.notebook, s.cell_id), set()).add(index)
    scored = unscored(sources, free)  # the grading's own scoring of the rows: free and derivation rows
    reasons, derivations = [], []
    for s, counted in zip(result.scores, scored):
        source = next((c.source for c in sources[s.notebook].cells if str(c.get("id")) == s.cell_id), "")
        plan = plan_check(source, s.cell_id, s.name)
        for index, (r, rule) in enumerate(zip(s.rows, counted.rows)):
            if not r.passed:
                continue
            reads = _loaded(python_source(plan.statements[plan.rows[index].statement][0])) if index < len(plan.rows) \
                else set()
            if not rule.free:
                derivations.append(f"{s.notebook}: {s.name} / {r.name}: passes untouched, but checks values that rows "
                                   "needing work read: it counts, and earns only with them")
                continue
            mine = sorted(reads & solved.get(s.notebook, set()))
            why = (f"the stub's values of {', '.join(mine)} already pass it" if mine else
                   "it reads no value a solution cell assigns" + (f" (only {', '.join(sorted(reads))})" if reads else ""))
            reasons.append(f"{s.notebook}: {s.name} / {r.name}: passes untouched: {why}")
    earnable = sum(s.max_points for s in scored)
    return Baseline(free, result, tuple(reasons), round(earnable, 9), tuple(derivations))


def _assigned(text) -> set:
    import ast

    try:
        tree = ast.parse(text)
    except SyntaxError:
        return set()
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store)}


def _loaded(text) -> set:
    import ast

    try:
        tree = ast.parse(text)
    except SyntaxError:
        return set()
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load)}
