"""The HTML of reports: chapters from executed notebooks, captions, numbers, paths.

Shared by the one-document lab report (:mod:`labkit.reports._report`) and the per-notebook
reports (:func:`number_notebook`, used by ``export_html``): notebook outputs become figures
and tables with their numbered captions, round-off in tables prints as 0, absolute paths of
the machine are written relative. The print stylesheet and the table-fitting script are
``static/report.css`` and ``static/report-fit.js``.

Example
-------
>>> from labkit.reports._document import tidy_numbers
>>> tidy_numbers("<td>-0.00</td>")
'<td>0.00</td>'
"""

from __future__ import annotations

import datetime as _dt
import html as _html
import re
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from labkit.exceptions import needs_extra
from labkit.reports._nbtools import CHECKS_MIME
from labkit.reports._numbering import cell_options, number_notebooks, resolve_references

__all__ = ["scrub_paths", "tidy_numbers", "number_notebook", "report_html", "fill_toc_pages", "STATIC"]

#: the package's static assets (MathJax, the widget manager, the report stylesheet and script)
STATIC = Path(__file__).resolve().parent / "static"
_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")
_H1 = re.compile(r"^#\s+(.+?)\s*$", re.MULTILINE)
_ANCHOR = re.compile(r'<a class="anchor-link" href="[^"]*">(?:&#182;|¶)</a>')
_TH = re.compile(r"(<th(?:\s[^>]*)?>)(.*?)(</th>)", re.DOTALL)


_NEG_ZERO = re.compile(r"(<td[^>]*>\s*)-(0(?:\.0+)?)(\s*</td>)")
_TINY = re.compile(r"(<td[^>]*>\s*)-?\d(?:\.\d+)?e-(?:1[2-9]|[2-9]\d|\d{3})(\s*</td>)")


def tidy_numbers(html: str) -> str:
    """Table cells that are round-off print as ``0``: ``-0.0000`` loses its sign, ``6.1e-17`` is ``0``.

    Parameters
    ----------
    html : str
        HTML holding tables.

    Returns
    -------
    str

    Examples
    --------
    >>> tidy_numbers("<td>-0.000</td><td>6.084e-17</td><td>-0.5</td>")
    '<td>0.000</td><td>0</td><td>-0.5</td>'
    """
    return _TINY.sub(r"\g<1>0\2", _NEG_ZERO.sub(r"\1\2\3", html))


def _breakable(text):
    """A header that may wrap after ``_`` and ``/`` (``shoulder_pitch_dot``): text outside tags."""
    return re.sub(r"(?<=[_/])(?=[^<>\s])(?![^<]*>)", "<wbr>", text)


#: a parameter that says where the build writes (``output_dir = "../../reports/..."``): not in the code listing
_BUILD_PARAMETER = re.compile(r"^\s*output_dir\s*=")
_CHECK_LINE = re.compile(r"^(?:PASS|FAIL|TYPO)  .*(?:\n|$)", re.MULTILINE)
_HEAD_ID = re.compile(r'(<h[1-6] )id="([^"]*)"')
_IMAGE_MIMES = ("image/png", "image/jpeg", "image/svg+xml")
_WIDGET = "application/vnd.jupyter.widget-view+json"
_JSHTML_FRAME = re.compile(r"data:image/(?:png|jpeg);base64,[A-Za-z0-9+/=\\\n]+")


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
    >>> scrub_paths("/usr/lib and iVBOR/usr/x data:image/png;base64,A/usr", [("/usr", "<python>")])
    '<python>/lib and iVBOR/usr/x data:image/png;base64,A/usr'
    """
    pairs = sorted(((str(r), rep) for r, rep in roots if r and len(str(r)) > 1), key=lambda p: -len(p[0]))
    if not pairs:
        return text
    # a root is a whole path name (no letter, digit or [_+.-] before it or, unless it ends with "/", after it), and
    # base64 data (data: URIs, figures) is left alone: "/usr" (Debian's Python) also occurs inside a PNG's base64
    names = dict(reversed(pairs))
    edge = "[A-Za-z0-9_+.-]"
    alternatives = "|".join(re.escape(r) + ("" if r.endswith("/") else f"(?!{edge})") for r, _ in pairs)
    pattern = re.compile(rf"(data:[\w/+.-]+;base64,[A-Za-z0-9+/=\\\n]+)|(?<!{edge})({alternatives})")
    return pattern.sub(lambda m: m.group(1) or names[m.group(2)], text)


def _default_roots(*folders):
    import site

    roots = [(f, ".") for f in folders if f]
    repo = Path(__file__).resolve().parents[2]
    roots += [(str(repo), "."), (str(Path.cwd()), ".")]
    for p in {sys.prefix, sys.base_prefix, *site.getsitepackages(), site.getusersitepackages()}:
        roots.append((str(p), "&lt;python&gt;"))  # the texts are HTML
    roots += [(str(Path.home()), "~"), (tempfile.gettempdir().rstrip("/") + "/", "&lt;tmp&gt;/")]
    return roots


def _md(text: str) -> str:
    with needs_extra("reports"):
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
            parts.append(f'<figure class="lk-figure" id="{item.anchor}">{"".join(pending_images)}'
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
                html = tidy_numbers(_TH.sub(lambda m: m.group(1) + _breakable(m.group(2)) + m.group(3), html))
                long = " lk-long" if re.search(r'class="lk-report-table[^"]*\blk-long\b', html) else ""
                if tbls:
                    item = tbls.pop(0)
                    parts.append(f'<figure class="lk-table{long}" id="{item.anchor}"><figcaption>{_caption_html(item)}'
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
    labels = {**numbering["labels"], **numbering["local"][k]}  # the chapter's own labels first
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
        if "parameters" in tags or "injected-parameters" in tags:  # where files go is the build's, not the lab's
            listing = "\n".join(line for line in listing.splitlines() if not _BUILD_PARAMETER.match(line))
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
    def entry(anchor, number, title):  # the page number is filled in by a second print (build_report)
        return (f'<li><a href="#{anchor}"><span class="lk-tocnum">{number}</span><span class="lk-toctitle">{title}'
                f'</span><span class="lk-tocpage" data-for="{anchor}"></span></a></li>')

    toc = [entry(f"chapter-{c.number}", c.number, _md_inline(c.title)) for c in chapters]
    toc.append(entry("sec-verification", n_ver, "Verification"))
    if not show_code:
        toc.append(entry("appendix-code", "A", "Code"))
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
<style>{(STATIC / "report.css").read_text("utf-8")}</style>
{script}
<script>{(STATIC / "report-fit.js").read_text("utf-8")}</script>
</head><body>
{_title_page(info, lab, generated, parameters)}
<nav class="lk-toc" id="contents"><h1>Contents</h1><ol>{"".join(toc)}</ol></nav>
{"".join(body)}
</body></html>
"""


_TOC_PAGE = re.compile(r'(<span class="lk-tocpage" data-for="([^"]+)">)[^<]*(</span>)')


def fill_toc_pages(html: str, pages: dict) -> str:
    """Write the page number of each contents entry (``pages``: anchor -> printed page number).

    Parameters
    ----------
    html : str
        A lab report's HTML (:func:`report_html`).
    pages : dict of str to int
        Page of each anchor in the printed PDF (1 = the title page); a missing anchor prints nothing.

    Returns
    -------
    str

    Examples
    --------
    >>> fill_toc_pages('<span class="lk-tocpage" data-for="chapter-1"></span>', {"chapter-1": 3})
    '<span class="lk-tocpage" data-for="chapter-1">3</span>'
    """
    return _TOC_PAGE.sub(lambda m: f"{m.group(1)}{pages.get(m.group(2), '')}{m.group(3)}", html)


def _caption_output(item):
    return {"output_type": "display_data", "metadata": {},
            "data": {"text/html": f'<div class="lk-caption lk-{item.kind}" id="{item.anchor}">{_caption_html(item)}</div>'}}


def number_notebook(nb, chapter=None):
    """Number the figures, tables and equations of one notebook and write its captions and references.

    Code cells lose their ``#|`` option lines, round-off in tables prints as ``0``
    (:func:`labkit.reports._report.tidy_numbers`); a captioned cell gets its caption as an
    output ("Figure 1: ...", after the figure; "Table 1: ...", before the table);
    ``[Figure](#fig-...)`` and ``@fig-...`` references in markdown become "Figure 1" links.

    Parameters
    ----------
    nb : nbformat.NotebookNode
        An executed notebook (changed in place).
    chapter : int, optional
        The notebook's chapter in its lab report (its place among the lab's notebooks,
        from 1): numbers print as in the lab report, "Figure 3.1"; None: "Figure 1".

    Returns
    -------
    list of str
        The labels referred to but not defined.
    """

    numbering = number_notebooks([nb], chapters=chapter is not None, first_chapter=chapter or 1)
    unresolved = []
    for i, cell in enumerate(nb.cells):
        if cell.cell_type == "markdown":
            cell.source = resolve_references(cell.source, numbering["local"][0], unresolved=unresolved)
            continue
        if cell.cell_type != "code":
            continue
        for out in cell.get("outputs", []):  # round-off in tables prints as 0
            html = out.get("data", {}).get("text/html")
            if html and "<table" in (html if isinstance(html, str) else "".join(html)):
                out["data"]["text/html"] = tidy_numbers(html if isinstance(html, str) else "".join(html))
        opts, source = cell_options(cell.source)
        if not opts:
            continue
        cell.source = source.lstrip("\n")
        entry = numbering["cells"].get((0, i), {})
        figs, tbls = list(entry.get("fig", [])), list(entry.get("tbl", []))
        def is_image(out):
            data = out.get("data", {})
            html = data.get("text/html", "")
            html = html if isinstance(html, str) else "".join(html)
            return (any(m in data for m in ("image/png", "image/jpeg", "image/svg+xml"))
                    or ("<table" not in html and "data:image/" in html))

        images = [k for k, out in enumerate(cell.get("outputs", [])) if is_image(out)]
        after = {k: None for k in images}
        if len(figs) == 1 and images:  # one caption for all the cell's figures, after the last
            after = {images[-1]: figs[0]}
        else:
            after = dict(zip(images, figs))
        outputs = []
        for k, out in enumerate(cell.get("outputs", [])):
            html = out.get("data", {}).get("text/html", "")
            html = html if isinstance(html, str) else "".join(html)
            if tbls and "<table" in html:
                outputs.append(_caption_output(tbls.pop(0)))
                out["data"]["text/html"] = re.sub(r"<caption>.*?</caption>", "", html, flags=re.DOTALL)
            outputs.append(out)
            if after.get(k) is not None:
                outputs.append(_caption_output(after[k]))
        cell["outputs"] = outputs
    return unresolved


