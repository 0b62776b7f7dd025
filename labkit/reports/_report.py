"""One report per lab: ``labkit report LAB_DIR``.

:func:`build_report` executes every notebook of a lab folder (or takes notebooks executed
already) and writes one document: a title page from the lab's ``lab.toml`` (course, lab
title, team, authors, date), the contents, one numbered chapter per notebook, numbered
figures, tables and equations with their captions (cell options ``#| label:``,
``#| fig-cap:``, ``#| tbl-cap:``; references ``[Figure](#fig-...)`` or ``@fig-...`` in markdown, see
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

import json
import os
import re
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from labkit.exceptions import LabkitError, OptionError, needs_extra
from labkit.reports._execute import execute_notebook, find_notebooks, notebook_parameters
from labkit.reports._document import _chapter, _default_roots, fill_toc_pages, report_html, scrub_paths
from labkit.reports._images import compact_notebook, compact_notebook_file, internalize
from labkit.reports._numbering import number_notebooks

__all__ = ["LAB_FILE", "LabInfo", "ReportResult", "lab_info", "write_lab_info", "build_report", "FORMATS"]

#: the lab metadata file in a lab folder (title page)
LAB_FILE = "lab.toml"
#: output formats of :func:`build_report`
FORMATS = ("pdf", "html", "docx")
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
        params["output_dir"] = str(Path(folder).resolve() / f"{notebook.stem}_files")  # ./<name>_files once written
    out = Path(folder) / notebook.name
    with _stderr_to(Path(folder) / f"{notebook.stem}.log"):
        kwargs = {"timeout": timeout} if timeout else {}
        result = execute_notebook(notebook, out, params, **kwargs)
    from labkit.reports._portable import portable_text

    portable_text(Path(folder) / f"{notebook.stem}.log", folder, notebook.parent)
    try:  # small figures and animation frames (see labkit.reports._images)
        compact_notebook_file(result.output)
    except Exception:  # noqa: BLE001 - the notebook keeps its outputs; build_report compacts them in memory
        pass
    return result


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
    with needs_extra("reports"):
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
        internalize(nb, path.parent)  # labkit render's notebooks link their figures (<name>_assets/)
        compact_notebook(nb)  # executed elsewhere (--executed): its figures may still be large
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
    from labkit.reports._assets import _asset, _needs_math

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

        files["pdf"], passes = _print_paged(html_path, base.with_suffix(".pdf"), html_text)
        html_path.write_text(html_text, encoding="utf-8")
        progress(f"  PDF  {files['pdf'].name} ({files['pdf'].stat().st_size / 1e6:.1f} MB, {passes} passes)")
    if "docx" in to:
        files["docx"] = _docx(html_path, base.with_suffix(".docx"), info)
        progress(f"  DOCX {files['docx'].name}")
    if "html" in to:
        if needs_math:  # typeset once: the hand-in HTML carries SVG math, not 2 MB of MathJax
            html_path.write_text(_typeset(html_path), encoding="utf-8")
        files["html"] = html_path
    else:
        html_path.unlink()
    if (base.parent / "index.json").is_file():  # a labkit render folder: its index links this report too
        from labkit.reports._render import write_index

        write_index([], base.parent)
    warnings = tuple(unresolved)
    for w in warnings:
        progress(f"  warning: {w}")
    errs = tuple(e for e in errors if e)
    return ReportResult(lab, not errs and not warnings, files, tuple(c.title for c in chapters), errs, warnings,
                        time.perf_counter() - t0)


#: most prints of a lab report to settle the contents' page numbers
MAX_PRINTS = 4


def anchor_pages(pdf) -> dict:
    """The printed page of every link target of a PDF printed by Chromium (its named destinations).

    Parameters
    ----------
    pdf : str or os.PathLike
        A PDF printed by :func:`labkit.reports.print_pdf`.

    Returns
    -------
    dict of str to int
        HTML id (``chapter-1``, ``sec-verification``, ...) -> page number, 1 = the first page.
    """
    with needs_extra("reports"):
        import pypdf

    reader = pypdf.PdfReader(str(pdf))
    return {str(name).lstrip("/"): reader.get_destination_page_number(dest) + 1
            for name, dest in reader.named_destinations.items()}


def _print_paged(html_path, pdf_path, html_text):
    """Print the report until the contents' page numbers are those of the printed chapters.

    The first print has the page numbers empty (their space reserved); each next one has the
    numbers read back from the previous PDF, until a print confirms them (two prints unless
    filling in the numbers moved a chapter).
    """
    from labkit.reports._render import print_pdf

    pages = {}
    for passes in range(1, MAX_PRINTS + 1):
        Path(html_path).write_text(fill_toc_pages(html_text, pages), encoding="utf-8")
        pdf = print_pdf(html_path, pdf_path, budget_ms=30000, timeout=300)
        found = anchor_pages(pdf)
        found = {k: v for k, v in found.items() if f'data-for="{k}"' in html_text}
        if passes > 1 and found == pages:
            return pdf, passes
        pages = found
    raise LabkitError(f"the contents' page numbers of {Path(pdf_path).name} did not settle in {MAX_PRINTS} prints")


def _typeset(html_path) -> str:
    """The page as Chromium rendered it (MathJax done, tables fitted), without its scripts."""
    from labkit.reports._render import rendered_dom
    from labkit.reports._typeset import static_page

    return static_page(rendered_dom(html_path), html_path, math=True, strip_all=True)


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
