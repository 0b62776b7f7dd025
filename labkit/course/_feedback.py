"""Feedback pages: one small, self-contained, escaped HTML page per student and an index per class.

A student's page (``<feedback>/<student>/index.html``) shows the total, and per notebook
the run status, what went wrong in the student's own cells (exception type, message,
cell, line), and every check with its points. Public checks list their rows with the
failing comparison or exception; **hidden checks show only their name, their rows'
names and pass/fail** (never their source, their values or their messages). Every
string is HTML-escaped (a student's ``<script>`` is text), nothing is fetched or
inlined from elsewhere, no sandbox or grader path appears, and the page is capped at
:data:`MAX_PAGE_BYTES`. The class index (``<feedback>/index.html``) lists every student
with status, points and a link to the page.

Example
-------
>>> from labkit.course._feedback import MAX_PAGE_BYTES
>>> MAX_PAGE_BYTES <= 2**20
True
"""

from __future__ import annotations

import hashlib
import html
from pathlib import Path
from urllib.parse import quote

from labkit.course._submission import clean_text

__all__ = ["MAX_PAGE_BYTES", "STUDENTS_FOLDER", "student_folder", "write_feedback", "write_class_index"]

#: the feedback folder's sub-folder holding one folder per student (the class index is beside it)
STUDENTS_FOLDER = "students"


def student_folder(student) -> str:
    """The folder of a student's page, relative to the feedback folder: never one of the grader's own files.

    Parameters
    ----------
    student : str
        The gradebook's name of the student (:func:`labkit.course._submission.student_label`).

    Returns
    -------
    str
        ``students/<name percent-encoded>`` (a leading dot encoded too; a very long name shortened
        with a hash of it): distinct names give distinct folders, and no name reaches ``index.html``.

    Examples
    --------
    >>> student_folder("index.html"), student_folder("../x y")
    ('students/index.html', 'students/%2E%2E%2Fx%20y')
    """
    name = quote(str(student), safe="")
    if name.startswith("."):
        name = "%2E" + name[1:].replace(".", "%2E", 1) if name.startswith("..") else "%2E" + name[1:]
    if len(name.encode()) > 200:
        name = name[:150] + "-" + hashlib.sha256(str(student).encode("utf-8", "backslashreplace")).hexdigest()[:16]
    return f"{STUDENTS_FOLDER}/{name}"

#: largest feedback page [bytes]
MAX_PAGE_BYTES = 256 * 2**10
_STYLE = ("body{font-family:sans-serif;max-width:60em;margin:2em auto;padding:0 1em;color:#222}"
          "table{border-collapse:collapse;margin:.5em 0 1.5em}td,th{border:1px solid #ccc;padding:.25em .6em;"
          "text-align:left;vertical-align:top}th{background:#f3f3f3}.pass{color:#1a7f37}.fail{color:#c62828}"
          ".free{color:#777}pre{white-space:pre-wrap;background:#f7f7f7;padding:.5em}")


def _e(text, limit=600) -> str:
    text = clean_text(text)
    if len(text) > limit:
        text = text[:limit] + " [...]"
    return html.escape(text, quote=True)


def _page(title, body) -> str:
    return (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{_e(title)}</title>"
            f"<style>{_STYLE}</style></head><body>\n{body}\n</body></html>\n")


def _result(passed, free) -> str:
    if free:
        return '<span class="free">free (worth 0)</span>'
    return '<span class="pass">pass</span>' if passed else '<span class="fail">FAIL</span>'


def student_page(result, pages) -> str:
    """The HTML text of one student's feedback page.

    Parameters
    ----------
    result : SubmissionResult
    pages : sequence of (str, str, str, list of CellScore)
        Per notebook: name, run status, run detail (already free of sandbox paths), scores.

    Returns
    -------
    str
    """
    parts = [f"<h1>Feedback: {_e(result.student)}</h1>",
             f"<p>Score <b>{result.points:g} / {result.max_points:g}</b> points; status <code>{_e(result.status)}"
             "</code>.</p>"]
    for name, status, detail, scores in pages:
        parts.append(f"<h2>{_e(name)}</h2><p>Run status: <code>{_e(status)}</code></p>")
        if detail:
            parts.append(f"<pre>{_e(detail, 1500)}</pre>")
        parts.append("<table><tr><th>check</th><th>kind</th><th>row</th><th>result</th><th>points</th>"
                     "<th>what failed</th></tr>")
        hidden_count = 0
        for s in scores:
            kind = "hidden" if s.hidden else "public"
            rows = s.rows or ()
            shown = s.name
            if s.hidden:  # an unnamed hidden check is named after its cell id: never show the id
                hidden_count += 1
                shown = f"hidden check {hidden_count}" if s.name == s.cell_id else s.name
            parts.append(f"<tr><td rowspan=\"{max(1, len(rows)) + 1}\">{_e(shown)}</td>"
                         f"<td rowspan=\"{max(1, len(rows)) + 1}\">{kind}</td><td><i>total</i></td>"
                         f"<td>{_result(s.passed, s.free)}</td><td>{s.points:.3g} / {s.max_points:.3g}</td><td></td></tr>")
            for r in rows:
                why = "" if s.hidden or r.passed else _e(r.error, 400)
                row_name = r.name.replace(s.cell_id, shown) if s.hidden and s.cell_id else r.name
                parts.append(f"<tr><td>{_e(row_name, 200)}</td><td>{_result(r.passed, r.free)}</td>"
                             f"<td>{r.points:.3g} / {r.max_points:.3g}</td><td>{why}</td></tr>")
            if not rows:
                parts.append("<tr><td colspan=\"4\">not graded</td></tr>")
        parts.append("</table>")
    parts.append("<p><small>Free rows pass on the untouched student version and are worth nothing. "
                 "Hidden checks show only their names and results.</small></p>")
    text = _page(f"Feedback: {result.student}", "\n".join(parts))
    if len(text.encode()) > MAX_PAGE_BYTES:  # cannot happen with the caps above; a last guard
        text = _page(f"Feedback: {result.student}", "\n".join(parts[:2]) + "<p>(details too long)</p>")
    return text


def write_feedback(result, pages, folder) -> Path:
    """Write ``folder/index.html`` for one student.

    Parameters
    ----------
    result : SubmissionResult
    pages : sequence
        As for :func:`student_page`.
    folder : str or os.PathLike
        The student's feedback folder (created; emptied of earlier files).

    Returns
    -------
    pathlib.Path
        The page.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.iterdir():
        if old.is_file():
            old.unlink()
    path = folder / "index.html"
    path.write_text(student_page(result, pages), encoding="utf-8")
    return path


def write_class_index(results, folder, *, title="Gradebook") -> Path:
    """Write ``folder/index.html``: one row per student with status, points and a link.

    Parameters
    ----------
    results : sequence of SubmissionResult
    folder : str or os.PathLike
        The feedback folder.
    title : str
        Page title.

    Returns
    -------
    pathlib.Path
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rows = []
    for r in results:
        where = student_folder(r.student)
        link = f"<a href=\"{_e(quote(where))}/index.html\">{_e(r.student)}</a>" \
            if (folder / where / "index.html").is_file() else _e(r.student)
        rows.append(f"<tr><td>{link}</td><td>{_e(r.status)}</td><td>{r.points:g} / {r.max_points:g}</td>"
                    f"<td>{_e(r.detail, 300)}</td></tr>")
    mean = sum(r.points for r in results) / len(results) if results else 0.0
    body = (f"<h1>{_e(title)}</h1><p>{len(results)} submissions; mean {mean:.2f} points.</p>"
            "<table><tr><th>student</th><th>status</th><th>points</th><th>detail</th></tr>"
            + "\n".join(rows) + "</table>")
    path = folder / "index.html"
    path.write_text(_page(title, body), encoding="utf-8")
    return path
