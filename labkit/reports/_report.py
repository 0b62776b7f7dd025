"""One report per lab: ``labkit report LAB_DIR``.

:func:`build_report` executes every notebook of a lab folder (or takes notebooks executed
already) and writes one document: a title page from the lab's ``lab.toml`` (course, lab
title, team, authors, date), the contents, one numbered chapter per notebook, numbered
figures, tables and equations with their captions (cell options ``#| label:``,
``#| fig-cap:``, ``#| tbl-cap:``; references ``@fig-...`` in markdown, see
:mod:`labkit.reports._numbering`), the checks of every notebook as a closing verification
table, and the code in an appendix (``show_code=True`` keeps it in the body).

The HTML is one offline file (MathJax inlined); the PDF is that HTML printed by headless
Chromium with a print stylesheet (A4, wrapped code, tables scaled to the text width, no
break inside a figure or table, embedded fonts); the DOCX is the same HTML converted by
pandoc (``pypandoc-binary``). See ``docs/reports.md``.

Example
-------
>>> from labkit.reports._report import LabInfo
>>> LabInfo(title="Planar 3R", course="ROBT403").course
'ROBT403'
"""

from __future__ import annotations

import base64
import datetime as _dt
import html as _html
import json
import os
import re
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from labkit.exceptions import LabkitError, OptionError
from labkit.reports._execute import execute_notebook, find_notebooks, lab_of, notebook_parameters
from labkit.reports._nbtools import CHECKS_MIME
from labkit.reports._numbering import cell_options, number_notebooks, resolve_references

__all__ = ["LAB_FILE", "LabInfo", "ReportResult", "lab_info", "write_lab_info", "build_report", "scrub_paths",
           "report_html", "FORMATS"]

#: the lab metadata file in a lab folder (title page)
LAB_FILE = "lab.toml"
#: output formats of :func:`build_report`
FORMATS = ("pdf", "html", "docx")
_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")
_H1 = re.compile(r"^#\s+(.+?)\s*$", re.MULTILINE)
_ANCHOR = re.compile(r'<a class="anchor-link" href="[^"]*">(?:&#182;|¶)</a>')
_TH = re.compile(r"(<th(?:\s[^>]*)?>)(.*?)(</th>)", re.DOTALL)


def _breakable(text):
    """A header that may wrap after ``_`` and ``/`` (``shoulder_pitch_dot``): text outside tags."""
    return re.sub(r"(?<=[_/])(?=[^<>\s])(?![^<]*>)", "<wbr>", text)


_CHECK_LINE = re.compile(r"^(?:PASS|FAIL|TYPO)  .*(?:\n|$)", re.MULTILINE)
_HEAD_ID = re.compile(r'(<h[1-6] )id="([^"]*)"')
_IMAGE_MIMES = ("image/png", "image/jpeg", "image/svg+xml")
_WIDGET = "application/vnd.jupyter.widget-view+json"
_JSHTML_FRAME = re.compile(r"data:image/(?:png|jpeg);base64,[A-Za-z0-9+/=\\\n]+")


@dataclass(frozen=True)
class LabInfo:
    """What the title page of a lab report shows (``lab.toml`` in the lab folder).

    Attributes
    ----------
    title : str
        Lab title.
    course : str
        Course code and name.
    team : str
        Team or group name ("" when none).
    authors : tuple of str
        Authors, in the order printed.
    date : str
        Date as printed ("" = the day the report is built).
    institution : str
        University / department ("" when none).
    reproduces : str
        The report this lab reproduces (a seed), "" when none.
    """

    title: str
    course: str = ""
    team: str = ""
    authors: tuple = ()
    date: str = ""
    institution: str = ""
    reproduces: str = ""


def lab_info(lab_dir) -> LabInfo:
    """Read ``LAB_DIR/lab.toml`` (the title page); without it, a title from the folder.

    Parameters
    ----------
    lab_dir : str or os.PathLike
        The lab folder.

    Returns
    -------
    LabInfo

    Raises
    ------
    LabkitError
        ``lab.toml`` is not valid TOML or its ``authors`` is not a list of strings.
    """
    import tomllib

    lab_dir = Path(lab_dir)
    path = lab_dir / LAB_FILE
    if not path.is_file():
        return LabInfo(title=lab_dir.resolve().name.replace("_", " "))
    try:
        data = tomllib.loads(path.read_text("utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise LabkitError(f"{path.name} of {lab_dir.name}: expected TOML, got an error: {exc}") from exc
    lab = data.get("lab", data)
    authors = lab.get("authors", [])
    if isinstance(authors, str):
        authors = [authors]
    if not all(isinstance(a, str) for a in authors):
        raise LabkitError(f"{path.name}: authors must be a list of strings, got {authors!r}")
    return LabInfo(title=str(lab.get("title") or lab_dir.resolve().name), course=str(lab.get("course", "")),
                   team=str(lab.get("team", "")), authors=tuple(authors), date=str(lab.get("date", "")),
                   institution=str(lab.get("institution", "")), reproduces=str(lab.get("reproduces", "")))


def _toml_str(text) -> str:
    return json.dumps(str(text), ensure_ascii=False)


def write_lab_info(lab_dir, info: LabInfo) -> Path:
    """Write ``LAB_DIR/lab.toml`` for ``info`` (what ``labkit new`` does).

    Parameters
    ----------
    lab_dir : str or os.PathLike
        The lab folder.
    info : LabInfo
        Title page contents.

    Returns
    -------
    pathlib.Path
        The file written.
    """
    lines = ["# title page of `labkit report` (edit: course, team, authors, date)", "[lab]",
             f"title = {_toml_str(info.title)}", f"course = {_toml_str(info.course)}",
             f"team = {_toml_str(info.team)}",
             "authors = [" + ", ".join(_toml_str(a) for a in info.authors) + "]",
             f"date = {_toml_str(info.date)}  # \"\" = the day the report is built"]
    if info.institution:
        lines.append(f"institution = {_toml_str(info.institution)}")
    if info.reproduces:
        lines.append(f"reproduces = {_toml_str(info.reproduces)}")
    path = Path(lab_dir) / LAB_FILE
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


@dataclass(frozen=True)
class ReportResult:
    """A lab report.

    Attributes
    ----------
    lab : str
        Lab folder name.
    ok : bool
        Every notebook ran without an error and every reference resolved.
    files : dict
        Format (``"pdf"``, ``"html"``, ``"docx"``) -> file written.
    chapters : tuple of str
        Chapter titles in order.
    errors : tuple of str
        Notebook failures (``"<notebook>, cell n, line k: Error: message"``).
    warnings : tuple of str
        Unresolved references and other problems of the document.
    seconds : float
        Wall time [s].
    """

    lab: str
    ok: bool
    files: dict = field(default_factory=dict)
    chapters: tuple = ()
    errors: tuple = ()
    warnings: tuple = ()
    seconds: float = 0.0


def scrub_paths(text: str, roots) -> str:
    """Replace absolute machine paths in ``text``: each root (longest first) by a short name.

    Parameters
    ----------
    text : str
        Any text of a report.
    roots : sequence of (str or Path, str)
        (absolute folder, replacement) pairs, e.g. ``(output_dir, ".")``.

    Returns
    -------
    str

    Examples
    --------
    >>> scrub_paths("saved /tmp/x/reports/a.csv", [("/tmp/x/reports", ".")])
    'saved ./a.csv'
    """
    pairs = sorted(((str(r), rep) for r, rep in roots if r and len(str(r)) > 1), key=lambda p: -len(p[0]))
    for root, rep in pairs:
        text = text.replace(root, rep)
    return text


def _default_roots(*folders):
    import site

    roots = [(f, ".") for f in folders if f]
    repo = Path(__file__).resolve().parents[2]
    roots += [(str(repo), "."), (str(Path.cwd()), ".")]
    for p in {sys.prefix, sys.base_prefix, *site.getsitepackages(), site.getusersitepackages()}:
        roots.append((str(p), "<python>"))
    roots += [(str(Path.home()), "~"), (tempfile.gettempdir().rstrip("/") + "/", "<tmp>/")]
    return roots


def _md(text: str) -> str:
    from nbconvert.filters.markdown_mistune import markdown2html_mistune

    return markdown2html_mistune(text)


def _md_inline(text: str) -> str:
    html = _md(text).strip()
    if html.startswith("<p>") and html.endswith("</p>") and html.count("<p>") == 1:
        html = html[3:-4]
    return html


def _joined(value) -> str:
    return value if isinstance(value, str) else "".join(value)


def _first_frame(html: str):
    m = _JSHTML_FRAME.search(html)
    return m.group(0).replace("\\n", "").replace("\n", "").replace("\\", "") if m else None


def _image_html(data, mime) -> str:
    if mime == "image/svg+xml":
        return f'<div class="lk-svg">{_joined(data[mime])}</div>'
    payload = _joined(data[mime]).replace("\n", "")
    return f'<img src="data:{mime};base64,{payload}" alt="">'


def _caption_html(item) -> str:
    cap = _md_inline(item.caption) if item.caption else ""
    sep = ": " if cap else ""
    return f'<span class="lk-num">{item.text}</span>{sep}{cap}'


@dataclass
class _Chapter:
    number: int
    title: str
    name: str
    body: list
    code: list
    checks: list
    ok: bool
    error: str


def _split_title(nb, fallback):
    for i, cell in enumerate(nb.cells):
        if cell.cell_type == "markdown":
            m = _H1.search(cell.source)
            if m:
                title = re.sub(r"\s*\{#sec-[\w-]+\}\s*$", "", m.group(1))
                return title, i, m
            break
    return nb.metadata.get("title") or fallback, None, None


def _outputs(cell, entry, show_code_first=None):
    """HTML of one code cell's outputs, figures and tables wrapped with their captions."""
    figs = list(entry.get("fig", [])) if entry else []
    tbls = list(entry.get("tbl", [])) if entry else []
    parts, checks = [], []
    pending_images = []

    def flush_images():
        if not pending_images:
            return
        if figs:
            item = figs.pop(0)
            parts.append(f'<figure class="lk-figure" id="{item.label}">{"".join(pending_images)}'
                         f"<figcaption>{_caption_html(item)}</figcaption></figure>")
        else:
            parts.append(f'<figure class="lk-figure lk-unnumbered">{"".join(pending_images)}</figure>')
        pending_images.clear()

    outputs = cell.get("outputs", [])
    n_images = sum(1 for o in outputs if any(m in o.get("data", {}) for m in _IMAGE_MIMES)
                   or _first_frame(_joined(o.get("data", {}).get("text/html", ""))))
    one_figure = len(figs) == 1 and n_images > 1  # one caption for all the cell's images
    for out in outputs:
        kind = out.get("output_type")
        if kind == "stream":
            text = _ANSI.sub("", _joined(out.get("text", ""))) if out.get("name") == "stdout" else ""
            text = _CHECK_LINE.sub("", text)  # the check rows are in the verification table
            if text.strip():
                if not one_figure:
                    flush_images()
                parts.append(f'<pre class="lk-output">{_html.escape(text)}</pre>')
            continue
        if kind == "error":
            flush_images()
            trace = _ANSI.sub("", "\n".join(out.get("traceback", [])))
            parts.append(f'<pre class="lk-error">{_html.escape(trace)}</pre>')
            continue
        data = out.get("data", {})
        if CHECKS_MIME in data:
            checks.append(data[CHECKS_MIME])
            continue
        image = next((m for m in _IMAGE_MIMES if m in data), None)
        if image:
            pending_images.append(_image_html(data, image))
            if not one_figure:
                flush_images()
            continue
        if "text/html" in data:
            html = _joined(data["text/html"])
            frame = _first_frame(html) if ("Animation" in html or "anim" in html) and "<table" not in html else None
            if frame:
                pending_images.append(f'<img src="{frame}" alt="">'
                                      '<p class="lk-note">(animation: first frame; the notebook plays it)</p>')
                if not one_figure:
                    flush_images()
                continue
            if "<table" in html:
                html = re.sub(r"<caption>.*?</caption>", "", html, flags=re.DOTALL) if tbls else html
                html = _TH.sub(lambda m: m.group(1) + _breakable(m.group(2)) + m.group(3), html)
                if tbls:
                    item = tbls.pop(0)
                    parts.append(f'<figure class="lk-table" id="{item.label}"><figcaption>{_caption_html(item)}'
                                 f'</figcaption><div class="lk-fit">{html}</div></figure>')
                else:
                    parts.append(f'<div class="lk-fit lk-unnumbered">{html}</div>')
                continue
            if "<script" in html.lower():
                continue  # interactive output: not part of a printed report
            parts.append(f'<div class="lk-html">{html}</div>')
            continue
        if "text/latex" in data:
            parts.append(f'<div class="lk-math">{_html.escape(_joined(data["text/latex"]))}</div>')
            continue
        if "text/markdown" in data:
            parts.append(f'<div class="lk-md">{_md(_joined(data["text/markdown"]))}</div>')
            continue
        if _WIDGET in data:
            parts.append('<p class="lk-note">(interactive control: open the notebook to use it)</p>')
            continue
        if "text/plain" in data:
            parts.append(f'<pre class="lk-output">{_html.escape(_joined(data["text/plain"]))}</pre>')
    flush_images()
    return parts, checks


def _chapter(k, nb, name, numbering, *, show_code, unresolved, error=""):
    title, title_cell, match = _split_title(nb, name)
    body, code, checks = [], [], []
    labels = numbering["labels"]
    for i, cell in enumerate(nb.cells):
        tags = cell.get("metadata", {}).get("tags", [])
        if cell.cell_type == "markdown":
            src = cell.source
            if i == title_cell and match is not None:
                src = src[:match.start()] + src[match.end():]
            found = []
            src = resolve_references(src, labels, unresolved=found)
            unresolved += [f"{name}.ipynb, cell {i + 1}: unresolved reference @{lab}" for lab in found]
            if src.strip():
                html = _ANCHOR.sub("", _md(src))
                html = _HEAD_ID.sub(lambda m: f'{m.group(1)}id="c{k + 1}-{m.group(2)}"', html)  # unique per chapter
                body.append(f'<div class="lk-md">{html}</div>')
            continue
        if cell.cell_type != "code":
            continue
        opts, source = cell_options(cell.source)
        listing = source.strip("\n")
        if "injected-parameters" in tags:
            listing = "# parameters of this run (labkit report)\n" + "\n".join(
                line for line in listing.splitlines() if not line.startswith("# Parameters"))
        if listing.strip():
            code.append(listing)
        if show_code and listing.strip() and "parameters" not in tags:
            body.append(f'<pre class="lk-code">{_html.escape(listing)}</pre>')
        if opts.get("echo") is False and not show_code:
            pass
        parts, found_checks = _outputs(cell, numbering["cells"].get((k, i)))
        checks += found_checks
        body += parts
    return _Chapter(k + 1, title, name, body, code, checks, not error, error)


_CSS = """
@page { size: A4; margin: 20mm 18mm 20mm 18mm;
        @bottom-center { content: counter(page); font: 9pt "DejaVu Sans", sans-serif; color: #555; } }
@page :first { @bottom-center { content: none; } }
html { font-family: "DejaVu Serif", Georgia, serif; font-size: 10.5pt; line-height: 1.4; color: #111; }
body { margin: 0 auto; width: 174mm; }
@media print { body { margin: 0; } }
h1, h2, h3, h4, .lk-title, .lk-toc, figcaption, table { font-family: "DejaVu Sans", Arial, sans-serif; }
h1.lk-chapter { font-size: 18pt; margin: 0 0 10pt 0; break-before: page; }
h1.lk-chapter .lk-chnum { display: inline-block; min-width: 1.6em; }
h2 { font-size: 13pt; margin: 14pt 0 6pt 0; break-after: avoid; }
h3 { font-size: 11pt; break-after: avoid; }
.lk-titlepage { height: 240mm; display: flex; flex-direction: column; justify-content: center; text-align: center; }
.lk-titlepage .lk-course { font-size: 14pt; margin-bottom: 24pt; }
.lk-titlepage .lk-title { font-size: 24pt; font-weight: bold; margin-bottom: 18pt; }
.lk-titlepage .lk-team { font-size: 14pt; margin-bottom: 6pt; }
.lk-titlepage .lk-authors { font-size: 12pt; margin-bottom: 24pt; }
.lk-titlepage .lk-small { font-size: 9.5pt; color: #444; }
.lk-toc { break-before: page; }
.lk-toc ol { list-style: none; padding-left: 0; font-size: 11pt; }
.lk-toc li { margin: 4pt 0; display: flex; }
.lk-toc li a { color: #111; text-decoration: none; flex: 1; }
.lk-toc .lk-tocnum { display: inline-block; min-width: 2.2em; }
pre { white-space: pre-wrap; overflow-wrap: anywhere; word-break: break-word; font-size: 8.5pt;
      font-family: "DejaVu Sans Mono", monospace; margin: 4pt 0; }
pre.lk-output { background: #f7f7f7; padding: 4pt 6pt; border-left: 2pt solid #ccc; }
pre.lk-error { background: #fdecea; padding: 4pt 6pt; border-left: 2pt solid #b71c1c; }
pre.lk-code { background: #f3f6fa; padding: 4pt 6pt; border-left: 2pt solid #7a9cc6; }
figure { margin: 8pt 0; break-inside: avoid; page-break-inside: avoid; }
figure img, .lk-svg svg, .lk-html img { max-width: 100%; height: auto; display: block; margin: 0 auto; }
figure.lk-figure img { max-height: 190mm; object-fit: contain; }
figcaption { font-size: 9.5pt; margin: 4pt 0; text-align: center; }
figure.lk-table figcaption { text-align: left; }
.lk-num { font-weight: bold; }
.lk-fit { width: 100%; overflow: hidden; break-inside: avoid; }
@page landscape { size: A4 landscape; margin: 18mm;
        @bottom-center { content: counter(page); font: 9pt "DejaVu Sans", sans-serif; color: #555; } }
.lk-landscape { page: landscape; width: 261mm; break-before: page; break-after: page; }
table.lk-nowrap td { white-space: nowrap; }
th { overflow-wrap: normal; word-break: normal; }
table.lk-breakall th, table.lk-breakall td { white-space: normal; overflow-wrap: anywhere; }
table { border-collapse: collapse; font-size: 8.5pt; margin: 2pt 0; break-inside: avoid; }
th, td { border-bottom: 0.5pt solid #bbb; padding: 2pt 5pt; text-align: right; vertical-align: top; }
th { border-bottom: 1pt solid #555; font-weight: bold; }
thead th { text-align: center; }
caption { font-size: 9pt; text-align: left; }
.lk-note { font-size: 9pt; color: #555; font-style: italic; }
.lk-math { margin: 6pt 0; overflow: hidden; }
mjx-container[display="true"] { overflow: hidden; max-width: 100%; }
table.lk-verify td { text-align: left; }
table.lk-verify td.lk-n { text-align: right; white-space: nowrap; }
table.lk-verify .lk-rownote { color: #555; font-size: 7.5pt; }
td.lk-pass { color: #1e7d32; font-weight: bold; }
td.lk-fail { color: #b71c1c; font-weight: bold; }
td.lk-typo { color: #8a5a00; font-weight: bold; }
.lk-appendix h2 { break-after: avoid; }
.lk-appendix pre.lk-code { break-inside: auto; }
.lk-failed { background: #fdecea; border: 1px solid #e59b95; padding: 4pt 8pt; }
a { color: #1a4f8a; }
"""

# scale every table (and wide display math) down to the text width; runs before printing
_FIT_JS = """
function lkFitTable(box) {
  var t = box.querySelector('table'); if (!t) return;
  var w = box.getBoundingClientRect().width;
  t.style.zoom = 1;
  t.classList.add('lk-nowrap');          /* natural width: cells unwrapped, headers wrapped at spaces */
  var natural = t.getBoundingClientRect().width;
  t.classList.remove('lk-nowrap');
  var fig = box.closest('figure') || box;
  if (natural * 0.6 > w) {             /* unreadable when shrunk to portrait: turn the page */
    fig.classList.add('lk-landscape');
    w = box.getBoundingClientRect().width;
  }
  if (natural > w) { t.style.zoom = Math.max(0.5, (w - 4) / natural); }
  if (t.getBoundingClientRect().width > w + 1) { t.classList.add('lk-breakall'); }  /* last resort */
}
function lkFit() {
  document.querySelectorAll('.lk-fit').forEach(lkFitTable);
  document.querySelectorAll('mjx-container[display="true"]').forEach(function (m) {
    var w = m.parentElement.getBoundingClientRect().width, mw = m.getBoundingClientRect().width;
    if (mw > w) { m.style.zoom = Math.max(0.4, (w - 2) / mw); }
  });
  document.body.setAttribute('data-fitted', 'yes');
}
window.addEventListener('load', function () {
  if (window.MathJax && MathJax.startup && MathJax.startup.promise) {
    MathJax.startup.promise.then(lkFit);
  } else { lkFit(); }
});
"""


def _verification(chapters, number):
    rows = []
    for ch in chapters:
        for block in ch.checks:
            for r in block.get("rows", []):
                result = str(r.get("result", ""))
                css = "lk-pass" if result == "pass" else "lk-fail" if result == "FAIL" else "lk-typo"
                note = f'<div class="lk-rownote">{_html.escape(str(r.get("note") or ""))}</div>' if r.get("note") else ""
                rows.append(f'<tr><td class="lk-n">{ch.number}</td><td>{_html.escape(str(r["quantity"]))}{note}</td>'
                            f'<td class="lk-n">{_html.escape(str(r["reproduced"]))}</td>'
                            f'<td class="lk-n">{_html.escape(str(r["published / expected"]))}</td>'
                            f'<td class="lk-n">{_html.escape(str(r["max |diff|"]))}</td>'
                            f'<td class="lk-n">{_html.escape(str(r["tolerance"]))}</td>'
                            f'<td class="{css}">{_html.escape(result)}</td></tr>')
        if not ch.ok:
            rows.append(f'<tr><td class="lk-n">{ch.number}</td><td colspan="5">{_html.escape(ch.error)}</td>'
                        f'<td class="lk-fail">FAIL</td></tr>')
    n_pass = sum("lk-pass" in r for r in rows)
    n_fail = sum('class="lk-fail"' in r for r in rows)
    n_typo = sum("lk-typo" in r for r in rows)
    head = ("<thead><tr><th>Ch.</th><th>quantity</th><th>reproduced</th><th>published / expected</th>"
            "<th>max |diff|</th><th>tolerance</th><th>result</th></tr></thead>")
    table = (f'<figure class="lk-table" id="tbl-verification"><figcaption><span class="lk-num">Table {number}.1</span>: '
             f"every reproduced number against the published (or expected) one, with its tolerance; "
             f"{n_pass} pass, {n_fail} fail, {n_typo} published typos</figcaption>"
             f'<div class="lk-fit"><table class="lk-verify">{head}<tbody>{"".join(rows)}</tbody></table></div></figure>')
    return (f'<section class="lk-verification" id="sec-verification"><h1 class="lk-chapter">'
            f'<span class="lk-chnum">{number}</span> Verification</h1>'
            "<p>The closing checks of every chapter: a check passes when the largest absolute (or relative) "
            "difference is within the tolerance, which is documented in its note; a published typo is a "
            "published number shown to be wrong, with the corrected value.</p>" + table + "</section>")


def _title_page(info, lab, generated, parameters):
    authors = ", ".join(info.authors)
    lines = [f'<div class="lk-course">{_html.escape(info.course)}</div>' if info.course else "",
             f'<div class="lk-institution">{_html.escape(info.institution)}</div>' if info.institution else "",
             f'<div class="lk-title">{_html.escape(info.title)}</div>',
             f'<div class="lk-team">{_html.escape(info.team)}</div>' if info.team else "",
             f'<div class="lk-authors">{_html.escape(authors)}</div>' if authors else "",
             f'<div class="lk-date">{_html.escape(info.date or generated)}</div>',
             "<p></p>",
             f'<div class="lk-small">Reproduces: {_html.escape(info.reproduces)}</div>' if info.reproduces else "",
             f'<div class="lk-small">Lab folder <code>{_html.escape(lab)}</code>; built by <code>labkit report</code> on '
             f"{_html.escape(generated)}{_html.escape(parameters)}</div>"]
    return '<section class="lk-titlepage">' + "".join(lines) + "</section>"


def report_html(chapters, info, *, lab, show_code=False, mathjax="", generated=None, parameters=""):
    """The HTML text of a lab report from its chapters (see :func:`build_report`).

    Parameters
    ----------
    chapters : sequence of _Chapter
        Built by :func:`build_report`.
    info : LabInfo
        Title page.
    lab : str
        Lab folder name.
    show_code : bool
        Code in the body (else in an appendix).
    mathjax : str
        MathJax source to inline ("" = no math).
    generated : str, optional
        Date printed when ``info.date`` is empty.
    parameters : str
        Note on the run's parameters for the title page.

    Returns
    -------
    str
    """
    generated = generated or _dt.date.today().isoformat()
    n_ver = len(chapters) + 1
    toc = [f'<li><a href="#chapter-{c.number}"><span class="lk-tocnum">{c.number}</span>{_md_inline(c.title)}</a></li>'
           for c in chapters]
    toc.append(f'<li><a href="#sec-verification"><span class="lk-tocnum">{n_ver}</span>Verification</a></li>')
    if not show_code:
        toc.append('<li><a href="#appendix-code"><span class="lk-tocnum">A</span>Code</a></li>')
    body = []
    for c in chapters:
        banner = (f'<p class="lk-failed">This notebook failed: {_html.escape(c.error)}</p>' if not c.ok else "")
        body.append(f'<section class="lk-chapter-body" id="chapter-{c.number}"><h1 class="lk-chapter">'
                    f'<span class="lk-chnum">{c.number}</span> {_md_inline(c.title)}</h1>{banner}'
                    + "".join(c.body) + "</section>")
    body.append(_verification(chapters, n_ver))
    if not show_code:
        app = ['<section class="lk-appendix" id="appendix-code"><h1 class="lk-chapter"><span class="lk-chnum">A</span>'
               " Code</h1><p>The code of every chapter, cell by cell, in the order it ran.</p>"]
        for c in chapters:
            app.append(f"<h2>A.{c.number} {_md_inline(c.title)} <small>({_html.escape(c.name)}.ipynb)</small></h2>")
            app += [f'<pre class="lk-code">{_html.escape(src)}</pre>' for src in c.code]
        app.append("</section>")
        body += app
    script = ""
    if mathjax:
        script = ("<script>window.MathJax = {tex: {inlineMath: [['$', '$'], ['\\\\(', '\\\\)']], "
                  "displayMath: [['$$', '$$'], ['\\\\[', '\\\\]']], processEscapes: true, tags: 'none'}, "
                  "svg: {fontCache: 'global'}, options: {enableMenu: false, ignoreHtmlClass: 'lk-code|lk-output'}};"
                  f"</script>\n<script>{mathjax}</script>")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>{_html.escape(info.title)}</title>
<style>{_CSS}</style>
{script}
<script>{_FIT_JS}</script>
</head><body>
{_title_page(info, lab, generated, parameters)}
<nav class="lk-toc" id="contents"><h1>Contents</h1><ol>{"".join(toc)}</ol></nav>
{"".join(body)}
</body></html>
"""


def _execute_one(notebook, folder, parameters, timeout):
    """Worker: execute one notebook into ``folder`` (kernel stderr into its .log)."""
    from labkit.reports._render import _stderr_to

    notebook = Path(notebook)
    params = dict(parameters or {})
    try:
        declared = notebook_parameters(notebook)
    except LabkitError:
        declared = {}
    params = {k: v for k, v in params.items() if k in declared}
    if "output_dir" in declared and "output_dir" not in params:
        params["output_dir"] = str(Path(folder) / f"{notebook.stem}_files")
    out = Path(folder) / notebook.name
    with _stderr_to(Path(folder) / f"{notebook.stem}.log"):
        kwargs = {"timeout": timeout} if timeout else {}
        return execute_notebook(notebook, out, params, **kwargs)


def build_report(lab_dir, output=None, *, to=("pdf", "html"), show_code=False, executed=None, jobs=2,
                 parameters=None, timeout=None, progress=print) -> ReportResult:
    """Execute a lab's notebooks and write its one report (PDF, HTML, DOCX).

    Parameters
    ----------
    lab_dir : str or os.PathLike
        The lab folder (``notebooks/<lab>`` or a ``labkit new`` folder).
    output : str or os.PathLike, optional
        Report file without suffix, or a folder (then ``<folder>/<lab>``); default
        ``reports/<lab>`` (files ``reports/<lab>.pdf``, ``.html``, ``.docx``).
    to : sequence of str
        Formats among ``"pdf"``, ``"html"``, ``"docx"``.
    show_code : bool
        Keep the code in the body instead of the appendix.
    executed : str or os.PathLike, optional
        A folder holding the lab's executed notebooks (``<name>.ipynb``, e.g. from
        ``labkit render``): use them instead of executing again. Otherwise the executed
        notebooks go where ``labkit render`` puts them: ``<output folder>/<lab>/``.
    jobs : int
        Parallel kernels.
    parameters : dict, optional
        Overrides applied to every notebook that declares them.
    timeout : float, optional
        Seconds one cell may run.
    progress : callable or None
        Called with a line per step.

    Returns
    -------
    ReportResult

    Raises
    ------
    OptionError
        An unknown format or ``jobs < 1``.
    LabkitError
        The folder has no notebooks, a label is defined twice, or a tool is missing.
    """
    import nbformat

    t0 = time.perf_counter()
    progress = progress or (lambda line: None)
    to = tuple(dict.fromkeys(f.strip().lower() for f in to if f.strip()))
    bad = [f for f in to if f not in FORMATS]
    if bad or not to:
        raise OptionError(f"--to expects some of {', '.join(FORMATS)}, got {', '.join(to) or '(nothing)'}")
    if jobs < 1:
        raise OptionError(f"jobs must be >= 1, got {jobs}")
    lab_dir = Path(lab_dir)
    if not lab_dir.is_dir():
        raise LabkitError(f"expected a lab folder with notebooks, got {lab_dir} (not a folder)")
    notebooks = find_notebooks([lab_dir])
    lab = lab_dir.resolve().name
    if output is None:
        base = Path("reports") / lab
    else:
        base = Path(output)
        if base.is_dir() or not base.suffix and str(output).endswith(("/", os.sep)):
            base = base / lab
        elif base.suffix in {f".{f}" for f in FORMATS}:
            base = base.with_suffix("")
    base = base.resolve()
    base.parent.mkdir(parents=True, exist_ok=True)
    if "pdf" in to:
        from labkit.reports._render import find_chromium

        find_chromium()
    info = lab_info(lab_dir)
    run_dir = Path(executed).resolve() if executed else base.parent / lab  # labkit render's layout
    results = {}
    if executed is None:
        run_dir.mkdir(parents=True, exist_ok=True)
        progress(f"executing {len(notebooks)} notebooks of {lab} with {jobs} kernel(s)")
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(max_workers=min(jobs, len(notebooks)),
                                 mp_context=multiprocessing.get_context("spawn")) as pool:
            futures = {p: pool.submit(_execute_one, p, run_dir, parameters, timeout) for p in notebooks}
            for p, fut in futures.items():
                res = fut.result()
                results[p] = res
                progress(f"  {'ok  ' if res.ok else 'FAIL'} {p.name} ({res.seconds:.1f} s)"
                         + ("" if res.ok else f": {res.error}"))
    nbs, errors = [], []
    for p in notebooks:
        path = run_dir / p.name
        if not path.is_file():
            raise LabkitError(f"no executed notebook {path.name} in {run_dir.name}; run `labkit render {lab}` "
                              f"first or leave out --executed")
        nb = nbformat.read(str(path), as_version=4)
        nbs.append(nb)
        from labkit.reports._execute import _first_error

        _, err = _first_error(nb, p.name)
        if p in results and not results[p].ok and not err:
            err = results[p].error
        errors.append(err)
    numbering = number_notebooks(nbs)
    unresolved = []
    chapters = [_chapter(k, nb, p.stem, numbering, show_code=show_code, unresolved=unresolved, error=errors[k])
                for k, (p, nb) in enumerate(zip(notebooks, nbs))]
    from labkit.reports._render import _asset, _needs_math

    needs_math = any(_needs_math(nb) for nb in nbs)
    overrides = {k: v for k, v in (parameters or {}).items()}
    param_note = ("; parameters " + ", ".join(f"{k} = {v!r}" for k, v in overrides.items())) if overrides else \
        "; notebooks' default parameters (the simulated arm)"
    html_text = report_html(chapters, info, lab=lab, show_code=show_code,
                            mathjax=_asset("mathjax-tex-svg-full.js") if needs_math else "",
                            parameters=param_note)
    html_text = scrub_paths(html_text, _default_roots(str(run_dir), str(base.parent), str(lab_dir.resolve())))
    files = {}
    html_path = base.with_suffix(".html")
    html_path.write_text(html_text, encoding="utf-8")
    if "pdf" in to:
        from labkit.reports._render import print_pdf

        files["pdf"] = print_pdf(html_path, base.with_suffix(".pdf"), budget_ms=30000, timeout=300)
        progress(f"  PDF  {files['pdf'].name} ({files['pdf'].stat().st_size / 1e6:.1f} MB)")
    if "docx" in to:
        files["docx"] = _docx(html_path, base.with_suffix(".docx"), info)
        progress(f"  DOCX {files['docx'].name}")
    if "html" in to:
        files["html"] = html_path
    else:
        html_path.unlink()
    warnings = tuple(unresolved)
    for w in warnings:
        progress(f"  warning: {w}")
    errs = tuple(e for e in errors if e)
    return ReportResult(lab, not errs and not warnings, files, tuple(c.title for c in chapters), errs, warnings,
                        time.perf_counter() - t0)


def _docx(html_path, docx_path, info) -> Path:
    """DOCX through pandoc (``pypandoc-binary``): math as Word equations, images embedded."""
    try:
        import pypandoc
    except ImportError as exc:
        raise LabkitError("DOCX needs pandoc: pip install pypandoc-binary (or labkit[reports])") from exc
    text = Path(html_path).read_text("utf-8")
    text = re.sub(r"<script.*?</script>", "", text, flags=re.DOTALL)
    text = re.sub(r'<section class="lk-titlepage">.*?</section>', "", text, flags=re.DOTALL)
    text = re.sub(r'<nav class="lk-toc".*?</nav>', "", text, flags=re.DOTALL)
    text = _tex_spans(text)
    with tempfile.TemporaryDirectory(prefix="labkit-docx-") as tmp:
        src = Path(tmp) / "report.html"
        src.write_text(text, encoding="utf-8")
        meta = [f"--metadata=title:{info.title}"]
        if info.authors or info.team:
            meta.append(f"--metadata=author:{', '.join(info.authors) or info.team}")
        if info.date:
            meta.append(f"--metadata=date:{info.date}")
        if info.course:
            meta.append(f"--metadata=subtitle:{info.course}")
        pypandoc.convert_file(str(src), "docx", format="html+tex_math_dollars", outputfile=str(docx_path),
                              extra_args=["--toc", "--toc-depth=1", "--resource-path", tmp, *meta])
    return Path(docx_path)


_DISPLAY_TEX = re.compile(r"\$\$(.+?)\$\$", re.DOTALL)
_INLINE_TEX = re.compile(r"(?<![\\$])\$(?!\s)([^$<>]+?)(?<!\s)\$(?!\d)")


def _tex_spans(html: str) -> str:
    """``$...$`` / ``$$...$$`` (outside code) as pandoc's math spans."""
    parts = re.split(r"(<pre.*?</pre>|<code.*?</code>)", html, flags=re.DOTALL)
    for i in range(0, len(parts), 2):
        seg = _DISPLAY_TEX.sub(lambda m: f'<span class="math display">\\[{m.group(1)}\\]</span>', parts[i])
        parts[i] = _INLINE_TEX.sub(lambda m: f'<span class="math inline">\\({m.group(1)}\\)</span>', seg)
    return "".join(parts)
