"""Batches of gradings and renders on a local process pool or a dask.distributed cluster.

A task carries its inputs as file contents (relative path -> bytes) and sends its
outputs back the same way, so workers on other machines need labkit installed but
share no folder with the driver; only the driver writes files. (A grading task on the
local pool gets its submission's folder and reads it itself, under the same caps: the
driver never holds a class's submissions at once.) The default
engine is a local pool of worker processes; ``scheduler="tcp://host:port"`` runs
the same tasks on a dask.distributed cluster, where a task whose worker is lost is
rerun on another worker (each task has one result slot, so nothing is lost or
counted twice). One progress bar (tqdm) counts the whole batch.

Example
-------
>>> import tempfile, pathlib
>>> from labkit.course import pack_dir, unpack_dir
>>> with tempfile.TemporaryDirectory() as a, tempfile.TemporaryDirectory() as b:
...     _ = (pathlib.Path(a) / "x" ).mkdir()
...     _ = (pathlib.Path(a) / "x" / "f.txt").write_text("hi")
...     _ = unpack_dir(pack_dir(a), b)
...     (pathlib.Path(b) / "x" / "f.txt").read_text()
'hi'
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from labkit.exceptions import LabkitError, needs_extra
from labkit.course._grade import grade_submission
from labkit.course._feedback import student_folder
from labkit.course._leftovers import remove_leftovers, temporary_folder
from labkit.course._safefs import read_tree, remove_tree, write_tree
from labkit.course._submission import MAX_DEPTH, MAX_ENTRIES, MAX_SUBMISSION_BYTES, clean_text, student_label
from labkit.course._sandbox import Limits, check_sandbox
from labkit.reports import find_chromium, find_notebooks, lab_of, render_one, write_index

__all__ = ["pack_dir", "unpack_dir", "run_tasks", "grade", "gradebook_frame", "write_gradebook", "render_batch"]

def pack_dir(path, *, limit=None, max_depth=64, max_entries=100_000) -> dict:
    """The regular files under a folder as ``{relative posix path: bytes}`` (links and special files skipped).

    The walk is :func:`labkit.course._safefs.read_tree`'s: iterative, under folder descriptors,
    with caps.

    Parameters
    ----------
    path : str or os.PathLike
        The folder.
    limit : int, optional
        Largest total size accepted [bytes].
    max_depth, max_entries : int
        Deepest folder level and most entries accepted.

    Returns
    -------
    dict of str to bytes

    Raises
    ------
    LabkitError
        If the folder is over a cap (the message says which) or is not a folder.
    """
    return read_tree(path, max_depth=max_depth, max_entries=max_entries, max_bytes=limit)


def unpack_dir(files, dest) -> Path:
    """Write ``{relative path: bytes}`` under ``dest`` (paths escaping ``dest`` are rejected; no link followed).

    Parameters
    ----------
    files : dict of str to bytes
        As returned by :func:`pack_dir`.
    dest : str or os.PathLike
        Target folder (created).

    Returns
    -------
    Path
        ``dest``.

    Raises
    ------
    LabkitError
        For an absolute path or one with ``..``.
    """
    return write_tree(files, dest, replace=True)


def run_tasks(fn, argsets, *, scheduler=None, jobs=2, desc="tasks", progress=True, on_result=None,
              on_lost=None) -> list:
    """Run ``fn(*args)`` for every args tuple; results in input order.

    Parameters
    ----------
    fn : callable
        A module-level function (it is pickled to the workers).
    argsets : sequence of tuple
        Arguments of each task.
    scheduler : str, optional
        ``"tcp://host:port"`` of a dask.distributed scheduler; default a local pool.
    jobs : int
        Worker processes of the local pool.
    desc : str
        Progress-bar label.
    progress : bool
        Show one tqdm progress bar for the batch (on stderr).
    on_result : callable, optional
        Called as ``on_result(index, result)`` in the driver as each task finishes.
    on_lost : callable, optional
        ``on_lost(index, reason)`` gives the result of a task whose worker process died under it
        (killed, out of memory, a crash in C), or that failed on every try on dask; default: such a
        task stops the batch with a LabkitError. On the local pool the tasks a dying worker took down
        with it (every task of a broken pool) are run again, one at a time in a pool of their own:
        the task that kills that pool too is the one lost; the others finish.

    Returns
    -------
    list
        ``fn``'s results, in the order of ``argsets``.

    Raises
    ------
    LabkitError
        If ``jobs < 1``, the scheduler cannot be reached, or (without ``on_lost``) a task's worker died or a
        task failed on every try.
    """
    from tqdm.auto import tqdm

    argsets = list(argsets)
    results = [None] * len(argsets)
    bar = tqdm(total=len(argsets), desc=desc, unit="task", disable=not progress)

    def done(i, value):
        results[i] = value
        bar.update(1)
        if on_result is not None:
            on_result(i, value)

    def lost(i, why):
        if on_lost is None:
            raise LabkitError(f"task {i} of {desc!r} ({fn.__name__}) was lost: {why}")
        done(i, on_lost(i, why))

    try:
        if scheduler is None:
            if jobs < 1:
                raise LabkitError(f"expected jobs >= 1, got {jobs}")
            broken = _local_pool(fn, argsets, range(len(argsets)), jobs, done)
            for i in broken:  # each alone: a pool that breaks now broke for this task
                for j in _local_pool(fn, argsets, [i], 1, done):
                    lost(j, "its worker process died (killed, out of memory, or a crash)")
        else:
            with needs_extra("course"):
                from distributed import Client, as_completed

            try:
                client = Client(scheduler, timeout=30)
            except OSError as exc:
                raise LabkitError(f"cannot reach the dask scheduler at {scheduler!r}: {exc}") from exc
            try:
                token = f"{desc}-{time.time_ns()}"
                futures = [client.submit(fn, *args, key=f"{token}-{i}", pure=False, retries=2)
                           for i, args in enumerate(argsets)]
                index = {f.key: i for i, f in enumerate(futures)}
                for fut in as_completed(futures):
                    try:
                        value = fut.result()
                    except Exception as exc:
                        lost(index[fut.key], f"it failed on every try: {type(exc).__name__}: {exc}")
                        continue
                    done(index[fut.key], value)
            finally:
                client.close()
    finally:
        bar.close()
    return results


def _local_pool(fn, argsets, indices, jobs, done) -> list:
    """Run the tasks ``indices`` on a new pool of ``jobs`` spawned processes; the indices lost to a broken pool."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from concurrent.futures.process import BrokenProcessPool

    indices, broken = list(indices), []
    if not indices:
        return broken
    with ProcessPoolExecutor(max_workers=max(1, min(jobs, len(indices))), initializer=_on_the_drivers_machine,
                             mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = {}
        for k, i in enumerate(indices):
            try:
                futures[pool.submit(fn, *argsets[i])] = i
            except BrokenProcessPool:  # broken before every task was handed in
                broken += indices[k:]
                break
        for fut in as_completed(futures):
            try:
                value = fut.result()
            except BrokenProcessPool:
                broken.append(futures[fut])
                continue
            done(futures[fut], value)
    if broken:  # its workers are gone (one died, the pool stopped the rest): their folders go now, their cgroups
        remove_leftovers()  # beside the next run's (labkit.course.memory_cgroup)
    return sorted(broken)


#: set once this process has checked that bubblewrap starts here (a dask worker; a pool worker from the start)
_WORKER_CHECKED = []
#: set once this process has removed what dead graders left on its machine (a dask worker; a pool worker from the
#: start)
_WORKER_SWEPT = []


def _on_the_drivers_machine():
    """A local pool worker's start: its machine is the driver's, which the driver has checked (bubblewrap starts)
    and swept (:func:`remove_leftovers`) before the batch, and sweeps again if a worker dies."""
    _WORKER_CHECKED.append(True)
    _WORKER_SWEPT.append(True)


def _sweep_once():
    """On a worker's first task: remove the temporary folders of dead graders and workers on its machine (a dask
    worker on another machine, whose killed predecessor's folders the driver cannot reach)."""
    if not _WORKER_SWEPT:
        _WORKER_SWEPT.append(True)
        remove_leftovers()


def _grade_task(student, submission_files, lab_files, limits, html, free):
    """Worker side of :func:`grade`: unpack (or read the folder, given its path), grade, pack the feedback into
    ``result.files``.

    Whatever goes wrong becomes this student's row (status ``"crash"``), never the batch's failure.
    """
    from dataclasses import replace

    t0 = time.perf_counter()
    _sweep_once()
    if isinstance(submission_files, str):  # the folder itself (a worker of the local pool): read it here
        try:
            submission_files = _pack_submission(submission_files)
        except Exception as exc:  # noqa: BLE001 - whatever the folder holds, it is this student's row
            return _failed(student, lab_files, free, "invalid", f"{type(exc).__name__}: {exc}", t0)
    try:
        if limits.sandbox and not _WORKER_CHECKED:  # a worker on another machine: its bubblewrap, once
            check_sandbox()
            _WORKER_CHECKED.append(True)
        with temporary_folder("task") as tmp:
            sub = unpack_dir(submission_files, tmp / "submissions" / "submission")  # a name of ours
            lab = unpack_dir(lab_files, tmp / "lab")
            out = tmp / "feedback"
            result = grade_submission(sub, lab, out, limits=limits, html=html, free=free, student=student)
            page = out / student_folder(student)
            files = pack_dir(page) if page.is_dir() else {}
            return replace(result, files=files)
    except Exception as exc:  # noqa: BLE001 - one student's row, never the class's crash
        return _failed(student, lab_files, free, "crash", f"grading failed: {type(exc).__name__}: {exc}", t0)


def _pack_submission(path) -> dict:
    """A submission folder's files under the caps of a submission (depth, entries, bytes)."""
    return pack_dir(path, limit=MAX_SUBMISSION_BYTES, max_depth=MAX_DEPTH, max_entries=MAX_ENTRIES)


def _failed(student, lab_files, free, status, why, t0=None):
    """A row for a student whose submission could not be graded: every check 0."""
    with needs_extra("course"):
        import nbformat

    from labkit.course._assign import graded_cells
    from labkit.course._grade import SubmissionResult
    from labkit.course._points import unscored

    sources = {}
    for rel in sorted(lab_files):
        if "/" not in rel and rel.endswith(".ipynb") and not rel.startswith("_"):
            try:
                nb = nbformat.reads(lab_files[rel].decode("utf-8"), as_version=4)
            except Exception:  # noqa: BLE001 - the instructor's notebook was graded elsewhere
                continue
            if graded_cells(nb, rel):
                sources[rel] = nb
    seconds = 0.0 if t0 is None else time.perf_counter() - t0
    why = clean_text(why)
    return SubmissionResult(student, status, why[:500], unscored(sources, free, why[:200]), seconds)


def grade(submissions_dir, lab_dir, output_dir, *, limits=None, scheduler=None, jobs=2, html=True, progress=True,
          count_free=False):
    """Grade every submission under ``submissions_dir``; feedback goes to ``output_dir/<student>/``.

    First the lab's untouched student version is graded once (:func:`labkit.course.baseline`):
    the rows it passes are free and worth nothing in every submission.

    Parameters
    ----------
    submissions_dir : str or os.PathLike
        One folder per student holding their notebooks; every other entry (a file, a
        symlink) gets an ``"invalid"`` row.
    lab_dir : str or os.PathLike
        The instructor's lab folder.
    output_dir : str or os.PathLike
        Feedback folder (created): ``students/<student>/index.html`` (:func:`labkit.course._feedback.student_folder`)
        and the class's ``index.html``.
    limits : Limits, optional
        Per-notebook limits.
    scheduler : str, optional
        dask.distributed scheduler address; default the local pool.
    jobs : int
        Local pool size.
    html : bool
        Write the feedback pages.
    progress : bool
        Show the progress bar.
    count_free : bool
        Count the free rows too (their points as the lab declares them).

    Returns
    -------
    list of SubmissionResult
        Exactly one per entry of ``submissions_dir`` (a hidden ``.name`` aside), whatever it holds, sorted by
        name (``files`` emptied once written). Names are carried as they are, bytes that are not UTF-8 and
        control characters escaped visibly (:func:`labkit.course._submission.student_label`).

    Raises
    ------
    LabkitError
        If there is no entry in ``submissions_dir`` or the lab folder is not one.
    """
    from dataclasses import replace

    from labkit.course._feedback import write_class_index
    from labkit.course._grade import baseline

    subs, lab = Path(submissions_dir).resolve(), Path(lab_dir).resolve()
    if not lab.is_dir():
        raise LabkitError(f"expected the lab folder, got {lab}")
    try:
        with os.scandir(subs) as it:
            entries = sorted((e for e in it if not e.name.startswith(".")), key=lambda e: os.fsencode(e.name))
    except OSError:
        entries = []
    if not entries:
        raise LabkitError(f"expected one folder per student in {subs}, found none")
    out = Path(output_dir).resolve()
    limits = limits or Limits()
    if limits.sandbox and scheduler is None:  # here, before anything runs (dask workers check their own)
        check_sandbox()
    remove_leftovers()  # what graders and workers killed outright left here (their folders are named after them)
    lab_files = pack_dir(lab)
    free = {} if count_free else baseline(lab, limits=limits).free
    argsets, early, seen = [], {}, set()
    for entry in entries:
        student = student_label(entry.name)
        while student in seen:  # two raw names shown alike: both keep a row
            student += "~"
        seen.add(student)
        try:
            if entry.is_symlink() or not entry.is_dir(follow_symlinks=False):
                early[student] = _failed(student, lab_files, free, "invalid", "not a folder (a file or a symlink)")
                continue
            # the local pool's workers read the folder themselves: the driver never holds a class's files at once
            files = entry.path if scheduler is None else _pack_submission(entry.path)
        except Exception as exc:  # noqa: BLE001 - whatever the entry holds, it is this student's row
            early[student] = _failed(student, lab_files, free, "invalid", f"{type(exc).__name__}: {exc}")
            continue
        argsets.append((student, files, lab_files, limits, html, free))

    def write(i, result):
        page = out / student_folder(result.student)
        if page.exists():
            remove_tree(page)
        unpack_dir(result.files, page)

    def lost(i, why):  # the grading process died under this submission: its row, never the class's stop
        return _failed(argsets[i][0], lab_files, free, "crash", f"grading failed: {why}")

    results = run_tasks(_grade_task, argsets, scheduler=scheduler, jobs=jobs, desc="grading", progress=progress,
                        on_result=write, on_lost=lost) if argsets else []
    results = sorted([replace(r, files={}) for r in results] + list(early.values()), key=lambda r: r.student)
    if html:
        write_class_index(results, out, title=f"Gradebook: {lab.name}")
    return results


def gradebook_frame(results):
    """The gradebook as a pandas table: one row per student, one column per check.

    Parameters
    ----------
    results : sequence of SubmissionResult

    Returns
    -------
    pandas.DataFrame
        Index ``student``; columns ``status``, ``points``, ``max_points``, then
        ``"<notebook>: <check>"`` (points earned, hidden checks marked ``(hidden)``; none for a
        check worth 0, whose rows are all free, such as a notebook without student work),
        ``seconds``, ``memory_limit`` (how memory was limited: ``cgroup v2``, ``cgroup v1``
        or ``watchdog``) and ``detail``.
    """
    import pandas as pd

    rows = []
    worth = {(s.notebook, s.cell_id) for r in results for s in r.scores if s.max_points > 0}
    for r in results:
        row = {"student": r.student, "status": r.status, "points": r.points, "max_points": r.max_points}
        for s in r.scores:
            if (s.notebook, s.cell_id) in worth:  # a check all of whose rows are free is worth 0: no column
                row[clean_text(f"{s.notebook}: {s.name}" + (" (hidden)" if s.hidden else ""))] = s.points
        row.update(seconds=round(r.seconds, 2), memory_limit=r.memory_limit, detail=clean_text(r.detail))
        rows.append(row)
    return pd.DataFrame(rows).set_index("student")


#: what a spreadsheet reads as the start of a formula (OWASP's list for CSV injection)
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def _inert(value):
    """A cell value a spreadsheet shows as text: control characters gone, a formula's first character quoted."""
    if not isinstance(value, str):
        return value
    text = clean_text(value) if not value.startswith(("\t", "\r")) else "'" + clean_text(value)
    return "'" + text if text.startswith(_FORMULA_START) else text


def _inert_frame(frame):
    """``frame`` with every text cell, the index and the column names made :func:`_inert`."""
    import pandas as pd

    frame = frame.copy()
    for column in frame.columns:  # text columns are "str" (pandas 3) or object: every column that is not numbers
        if not pd.api.types.is_numeric_dtype(frame[column]) or frame[column].dtype == object:
            frame[column] = frame[column].map(_inert)
    frame.index = frame.index.map(_inert)
    frame.index.name = _inert(frame.index.name)
    frame.columns = [_inert(c) for c in frame.columns]
    return frame


def write_gradebook(frame, path) -> list:
    """Write the gradebook as CSV or Excel (by suffix); a ``.csv`` also gets its ``.xlsx`` twin.

    Every text cell is made inert for a spreadsheet: control characters removed, and a cell that
    starts with ``=``, ``+``, ``-``, ``@``, a tab or a CR gets a leading ``'`` (it is text, never a
    formula), in the CSV and in the Excel file alike.

    Parameters
    ----------
    frame : pandas.DataFrame
        From :func:`gradebook_frame`.
    path : str or os.PathLike
        ``*.csv`` or ``*.xlsx``.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    LabkitError
        For another suffix.
    """
    path = Path(path)
    if path.suffix not in (".csv", ".xlsx"):
        raise LabkitError(f"expected a gradebook path ending .csv or .xlsx, got {path.name!r}")
    path.parent.mkdir(parents=True, exist_ok=True)
    frame = _inert_frame(frame)
    written = []
    if path.suffix == ".csv":
        frame.to_csv(path)
        written.append(path)
    xlsx = path.with_suffix(".xlsx")
    frame.to_excel(xlsx, sheet_name="gradebook", engine="openpyxl")
    return written + [xlsx]


def _render_task(lab, name, lab_files, no_input, pdf, parameters, timeout):
    """Worker side of :func:`render_batch`: render one notebook, send back its report files."""
    _sweep_once()
    with temporary_folder("render") as tmp:
        nb = unpack_dir(lab_files, tmp / "notebooks" / lab) / f"{name}.ipynb"
        out = tmp / "reports"
        r = render_one(nb, out, no_input=no_input, pdf=pdf, parameters=parameters, timeout=timeout)
        files = {rel: data for rel, data in pack_dir(out / lab).items() if rel.split("/")[0].startswith(name)}
        return r, files


def render_batch(notebooks=None, output_dir="reports", *, scheduler=None, jobs=2, no_input=False, pdf=True,
                 parameters=None, timeout=None, progress=True):
    """Render notebooks as portable tasks (local pool or dask cluster); reports written by the driver.

    Parameters
    ----------
    notebooks : sequence of str or Path, optional
        Notebooks, lab folders or lab names (see :func:`labkit.reports.find_notebooks`).
    output_dir : str or Path
        Reports folder; ``<output_dir>/<lab>/`` receives each notebook's files, plus the index.
    scheduler : str, optional
        dask.distributed scheduler address; default a local pool of ``jobs`` processes.
    jobs : int
        Local pool size.
    no_input, pdf : bool
        Report mode; print PDFs (on the workers: they need Chromium).
    parameters : dict, optional
        Overrides for every notebook that declares them.
    timeout : float, optional
        Seconds one cell may run.
    progress : bool
        Show the progress bar.

    Returns
    -------
    (list of RenderResult, float)
        Results (paths in ``output_dir``) in notebook order, and the wall time [s].

    Raises
    ------
    LabkitError
        If no notebook matches.
    """
    from dataclasses import replace

    paths = find_notebooks(notebooks)
    if not paths:
        raise LabkitError("no notebooks to render")
    if pdf and scheduler is None:
        find_chromium()
    remove_leftovers()  # what renders and gradings killed outright left here
    out = Path(output_dir).resolve()
    labs = {}
    for p in paths:
        labs.setdefault(lab_of(p), pack_dir(p.parent))
    argsets = [(lab_of(p), p.stem, labs[lab_of(p)], no_input, pdf, parameters, timeout) for p in paths]
    t0 = time.perf_counter()
    pairs = run_tasks(_render_task, argsets, scheduler=scheduler, jobs=jobs, desc="rendering", progress=progress,
                      on_result=lambda i, pair: unpack_dir(pair[1], out / argsets[i][0]))
    results = []
    for (lab, name, *_), (r, _files) in zip(argsets, pairs):
        moved = {k: (out / lab / Path(getattr(r, k)).name) if getattr(r, k) else None
                 for k in ("notebook", "html", "pdf")}
        results.append(replace(r, **moved))
    wall = time.perf_counter() - t0
    write_index(results, out, wall_seconds=wall)
    return results, wall
