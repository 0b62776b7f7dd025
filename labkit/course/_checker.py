"""The verdict: the instructor's checks run on the handed-out data, in a clean process of their own.

After a submission has run in the sandbox, :func:`run_checker` starts
``python -m labkit.course._checker JOB RESULT`` (sandboxed too when the grading is: no
network, the Python installation and labkit read-only, the submission's files read-only
at the same place the kernel saw them). For every notebook it runs the instructor's
prelude (imports, definitions, ``Checks`` objects, see :mod:`labkit.course._plan`); for
every check cell a fresh namespace gets the decoded values of that check point
(:func:`labkit.course._wire.decode`, plain data only, never a name the prelude defines),
then the cell's statements run one by one and each row is scored on its own: it passes
when it raises nothing and adds no failing ``Checks`` row. No code of the student's runs
here.

Example
-------
>>> from labkit.course._checker import check_cell
>>> from labkit.course._plan import plan_check
>>> plan = plan_check("assert x == 1\\nassert y == 2", "c", "demo")
>>> [r["passed"] for r in check_cell(plan, {"x": 1, "y": 3}, {})]
[True, False]
"""

from __future__ import annotations

import copy
import json
import os
import subprocess
import sys
import traceback
from pathlib import Path

__all__ = ["check_cell", "run_checker", "main"]

#: largest result document read back from the checker [bytes]
_MAX_RESULT_BYTES = 64 * 2**20
_NO_DATA = "the notebook stopped before this check (no values were handed out)"


def _checks_objects(ns):
    return [v for v in ns.values() if type(v).__name__ == "Checks" and type(v).__module__.startswith("labkit.")]


def _line_of(exc, first_line):
    tb = traceback.extract_tb(exc.__traceback__)
    for frame in reversed(tb):
        if frame.filename == "<check>":
            return first_line + frame.lineno - 1
    return first_line


def _run(source, first_line, ns):
    code = compile(source, "<check>", "exec")
    exec(code, ns)  # noqa: S102 - the instructor's code on decoded data


def check_cell(plan, values, base) -> list:
    """Run one check cell on decoded values; one result per row.

    Parameters
    ----------
    plan : CheckPlan
        The cell (see :func:`labkit.course._plan.plan_check`).
    values : dict or None
        The decoded values of this check point (None: the kernel never got there).
    base : dict
        The prelude's namespace (names there are never taken from ``values``).

    Returns
    -------
    list of dict
        ``{"passed": bool, "error": str, "line": int}`` per row.
    """
    rows = {row.statement: row for row in plan.rows}
    if values is None or plan.error:
        why = plan.error or _NO_DATA
        return [{"passed": False, "error": why, "line": row.line} for row in plan.rows]
    ns = {"__name__": "__main__", "__builtins__": __builtins__}
    wanted = set(plan.free_names)  # only what the check reads (never a builtin's name), never a trusted name
    ns.update({k: v for k, v in values.items() if k in wanted and k not in base})
    for name, value in base.items():
        if type(value).__name__ == "Checks":  # a fresh, silent one for every cell
            value = type(value)(title=value.title, display=False)
        ns[name] = value
    results, setup_error = {}, ""
    for i, (source, line, kind) in enumerate(plan.statements):
        if kind == "skip":
            continue
        before = [(c, len(c.rows)) for c in _checks_objects(ns)]
        try:
            _run(source, line, ns)
            failed = [r for c, n in before for r in c.rows[n:] if not r.passed]
            failed += [r for c in _checks_objects(ns) if all(c is not b for b, _ in before) for r in c.rows
                       if not r.passed]
            error = "; ".join(r.shortfall() for r in failed)
            where = line
        except Exception as exc:
            error = f"{type(exc).__name__}: {exc}" if str(exc) else f"{type(exc).__name__} (no message)"
            where = _line_of(exc, line)
        if kind == "setup":
            if error and not setup_error:
                setup_error = f"{error} (line {where})"
            continue
        if error and setup_error and "NameError" in error:
            error += f"; earlier in the check: {setup_error}"
        if error:
            error += _values_read(source, ns, values, base)
        results[i] = {"passed": not error, "error": error[:500], "line": where}
    return [results.get(row.statement, {"passed": False, "error": "not run", "line": row.line})
            for row in rows.values()]


def _shown(value) -> str:
    """A short text of a value for a failing row (numbers to 4 significant digits)."""
    try:
        import numpy as np

        if isinstance(value, (list, tuple, np.ndarray)) and np.asarray(value).dtype.kind in "biuf":
            text = np.array2string(np.asarray(value), precision=4, threshold=8)
        elif isinstance(value, float):
            text = f"{value:.4g}"
        else:
            text = repr(value)
    except Exception:  # noqa: BLE001 - a value that cannot be shown is named only
        text = f"<{type(value).__name__}>"
    text = " ".join(text.split())
    return text if len(text) <= 60 else text[:57] + "..."


def _values_read(source, ns, values, base) -> str:
    """``" (t3 = 1.234, q = [0 0 0])"``: the submission's values a failing row reads, so the row names them."""
    import ast

    try:
        names = [n.id for n in ast.walk(ast.parse(source)) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load)]
    except SyntaxError:
        return ""
    mine = list(dict.fromkeys(n for n in names if n in values and n not in base and n in ns))
    if not mine:
        return ""
    return " (" + ", ".join(f"{n} = {_shown(ns[n])}" for n in mine[:4]) + (", ..." if len(mine) > 4 else "") + ")"


def _prelude(statements):
    ns = {"__name__": "__main__", "__builtins__": __builtins__}
    errors = []
    for source in statements:
        try:
            exec(compile(source, "<prelude>", "exec"), ns)  # noqa: S102 - the instructor's imports and definitions
        except Exception as exc:
            errors.append(f"{type(exc).__name__}: {exc}"[:300])
    for value in ns.values():
        if type(value).__name__ == "Checks":
            value.display = False
    ns.pop("__builtins__", None)
    ns.pop("__name__", None)
    return ns, errors


def _run_job(job) -> dict:
    from labkit.course._plan import CheckPlan, Row
    from labkit.course._wire import decode, loads

    out = []
    for notebook in job["notebooks"]:
        base, errors = _prelude(notebook["prelude"])
        cells = []
        for cell in notebook["cells"]:
            plan = CheckPlan(cell["cell_id"], cell["name"], tuple(cell["free_names"]),
                             tuple(tuple(s) for s in cell["statements"]), tuple(Row(*r) for r in cell["rows"]),
                             cell.get("error", ""))
            doc = loads(cell["data"]) if cell.get("data") is not None else None
            values = decode(doc.get("values", {})) if isinstance(doc, dict) else None
            try:
                rows = check_cell(plan, values, dict(copy.copy(base)))
            except BaseException as exc:  # noqa: BLE001 - one cell's failure is its rows' failure
                rows = [{"passed": False, "error": f"{type(exc).__name__}: {exc}"[:300], "line": r.line}
                        for r in plan.rows]
            cells.append({"cell_id": plan.cell_id, "rows": rows})
        out.append({"name": notebook["name"], "cells": cells, "prelude_errors": errors})
    return {"notebooks": out}


def main(argv=None) -> int:
    """Entry point of the checker process: ``python -m labkit.course._checker JOB RESULT``.

    Parameters
    ----------
    argv : list of str, optional
        ``[JOB, RESULT]``: the job file to read and the result file to write (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 (the results, failures included, are in the result file).
    """
    argv = sys.argv[1:] if argv is None else argv
    job_path, result_path = argv
    os.environ.setdefault("MPLBACKEND", "Agg")
    job = json.loads(Path(job_path).read_text(encoding="utf-8"))
    result = _run_job(job)
    Path(result_path).write_text(json.dumps(result), encoding="utf-8")
    return 0


def _no_data(job) -> dict:
    """The result document of a job whose check points all went unreached (what the checker would say)."""
    return {"notebooks": [{"name": nb["name"], "prelude_errors": [], "cells": [
        {"cell_id": cell["cell_id"], "rows": [{"passed": False, "error": cell.get("error") or _NO_DATA, "line": row[3]}
                                              for row in cell["rows"]]} for cell in nb["cells"]]}
        for nb in job["notebooks"]]}


def run_checker(job, private, *, limits, sandbox_args=None) -> dict:
    """Run the checker process on a job; the per-row results, or an ``"error"`` entry.

    Parameters
    ----------
    job : dict
        ``{"notebooks": [{"name", "prelude", "cells": [...]}]}`` (see :func:`_run_job`).
    private : pathlib.Path
        A folder of the grader's for the job and result files (the checker's working folder).
    limits : Limits
        Wall-clock and memory limits (the checker gets the wall limit and the memory limit).
    sandbox_args : list of str, optional
        The bubblewrap prefix to run it under (None: a plain process).

    Returns
    -------
    dict
        The result document, or ``{"error": "..."}`` if the checker failed.
    """
    if all(cell.get("data") is None for nb in job["notebooks"] for cell in nb["cells"]):
        return _no_data(job)  # the kernel reached no check: nothing to run, no process to start
    job_path, result_path = private / "check-job.json", private / "check-result.json"
    job_path.write_text(json.dumps(job), encoding="utf-8")
    flags = ["-P"] if sys.version_info >= (3, 11) else []
    cmd = [sys.executable, *flags, "-s", "-m", "labkit.course._checker", str(job_path), str(result_path)]
    from labkit.course._watchdog import dies_with_this_process

    prefix = [*dies_with_this_process(), "prlimit", f"--as={int(max(limits.memory_bytes, 2 * 2**30))}", "--"]
    env = None
    if sandbox_args:
        cmd = [*prefix, *sandbox_args, *cmd]
    else:
        cmd = [*prefix, *cmd]
        env = {k: v for k, v in os.environ.items() if k in ("PATH", "PYTHONPATH", "LANG", "HOME")}
        env.update(MPLBACKEND="Agg", MPLCONFIGDIR=str(private / "mpl"), OPENBLAS_NUM_THREADS="1")
    try:
        proc = subprocess.run(cmd, cwd=private, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                              timeout=max(60.0, limits.wall_seconds))
    except subprocess.TimeoutExpired:
        return {"error": f"the checks ran over {max(60.0, limits.wall_seconds):g} s"}
    from labkit.course._safefs import read_file

    try:  # the checker's folder is writable in its sandbox: read it as any such file
        return json.loads(read_file(private, result_path.name, max_bytes=_MAX_RESULT_BYTES).decode("utf-8"))
    except (OSError, ValueError):
        tail = proc.stderr.decode(errors="replace").strip().splitlines()[-3:]
        return {"error": f"the checker failed (exit status {proc.returncode}): {' '.join(tail)}"[:500]}


if __name__ == "__main__":
    sys.exit(main())
