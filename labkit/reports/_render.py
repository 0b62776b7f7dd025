"""Batch-rendered lab reports: ``labkit render`` and ``labkit run``.

:func:`render` executes notebooks in parallel worker processes and writes, for
each notebook ``notebooks/<lab>/<name>.ipynb``, into ``<output>/<lab>/``:

* ``<name>.ipynb`` - the executed notebook;
* ``<name>.html`` - a self-contained offline report: the package's nbconvert
  template ``labkit_report`` inlines MathJax 3 (SVG output, no font files) and the
  ipywidgets HTML manager (with the saved widget state) from ``labkit/reports/static``, so
  the page never loads anything from the network;
* ``<name>.pdf`` - that HTML printed by headless Chromium;

plus ``<output>/index.html`` linking every report with pass/fail. A notebook that
fails still gets its report (showing the failing cell and the traceback); the
batch goes on and :func:`render` reports the failures.

Example
-------
>>> from labkit.reports._render import chromium_command
>>> chromium_command("r.html", "r.pdf", "/tmp/profile")[:2]
['chromium', '--headless']
"""

from __future__ import annotations

import datetime as _dt
import html as _html
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from labkit.exceptions import LabkitError, needs_extra
from labkit.reports._document import _default_roots, number_notebook, scrub_paths
from labkit.reports._images import compact_notebook, externalize
from labkit.reports._portable import portable_text
from labkit.reports._typeset import static_page
from labkit.reports._assets import STATIC, _asset, _needs_math, _shared_asset, _shared_css  # noqa: F401 (STATIC)
from labkit.reports._execute import (
    CELL_TIMEOUT,
    chapter_of,
    execute_notebook,
    find_notebooks,
    lab_of,
    notebook_parameters,
)

__all__ = ["RenderResult", "find_chromium", "export_html", "print_pdf", "render", "render_one", "write_index"]

_HERE = Path(__file__).resolve().parent
TEMPLATES = _HERE / "templates"
TEMPLATE_NAME = "labkit_report"
#: Chromium's virtual time budget for MathJax and the widget manager before printing [ms]
VIRTUAL_TIME_BUDGET_MS = 20000
_HIDE_INPUT_TAG = "labkit-hide-input"
# matplotlib's jshtml animations link Font Awesome from a CDN; the template styles the buttons itself
_REMOTE_LINK = re.compile(r"<link[^>]*href=[\"']https?://[^>]*>", re.IGNORECASE)


@dataclass(frozen=True)
class RenderResult:
    """One notebook's report.

    Attributes
    ----------
    lab, name : str
        Lab folder and notebook name (without ``.ipynb``).
    ok : bool
        True when the notebook executed without error (its assertions passed).
    error : str
        First error ("Name: message") or "" when ok; also HTML/PDF export problems.
    notebook, html, pdf : Path or None
        Written files (``pdf`` is None with ``--no-pdf`` or when printing failed).
    seconds : float
        Execution wall time [s]; ``export_seconds`` HTML+PDF time [s].
    """

    lab: str
    name: str
    ok: bool
    error: str
    notebook: Path | None
    html: Path | None
    pdf: Path | None
    seconds: float
    export_seconds: float = 0.0


def export_html(notebook, html_path, *, no_input=False, title=None, status="", error="", asset_dir=None,
                chapter=None, figures=None, typeset=False) -> Path:
    """Write the offline HTML report of an executed notebook.

    Parameters
    ----------
    notebook : str, Path or nbformat.NotebookNode
        The executed notebook.
    html_path : str or Path
        Where to write the HTML.
    no_input : bool
        Report mode: hide code cells' input and prompts, except the input of a
        cell that raised (so a failure shows what failed).
    title : str, optional
        Banner title (default: the file name).
    status, error : str
        Banner: ``"passed"``/``"failed"`` and the failure summary.
    asset_dir : str or Path, optional
        Folder for MathJax and the widget manager, written once and linked relatively
        (``labkit render`` shares ``<output>/_static`` between all reports); default: inlined
        into the page.
    chapter : int, optional
        The notebook's chapter in its lab report: figures and tables are numbered as there
        ("Figure 3.1"); default: "Figure 1".
    figures : str, optional
        Folder (relative to the HTML) where figures and animation frames are written once as
        files and linked (``labkit render``: ``<name>_assets``, shared with the executed
        notebook); default: inlined.
    typeset : bool
        Render the math (SVG) and the widgets (at their saved state) once with Chromium and
        write the page without MathJax and the widget manager (``labkit render``: 4 MB less
        in ``_static``); default: they run when the page is opened.

    Returns
    -------
    Path
        ``html_path``.

    Notes
    -----
    Figures and tables get their numbered captions (cell options ``#| fig-cap:``,
    ``#| tbl-cap:``, see :func:`number_notebook`), and absolute paths of this machine
    are written relative to the report's folder.
    """
    with needs_extra("reports"):
        import nbformat
        from nbconvert import HTMLExporter
        from nbconvert.preprocessors import TagRemovePreprocessor

    nb = notebook if not isinstance(notebook, (str, Path)) else nbformat.read(str(notebook), as_version=4)
    nb = nbformat.from_dict(json.loads(json.dumps(nb)))  # private copy: tags are added below
    html_path = Path(html_path)
    exporter = HTMLExporter(template_name=TEMPLATE_NAME, extra_template_basedirs=[str(TEMPLATES)])
    if no_input:
        for cell in nb.cells:
            failed = any(o.get("output_type") == "error" for o in cell.get("outputs", []))
            if cell.cell_type == "code" and not failed:
                cell.metadata.setdefault("tags", []).append(_HIDE_INPUT_TAG)
        exporter.exclude_input_prompt = True
        exporter.exclude_output_prompt = True
        exporter.register_preprocessor(TagRemovePreprocessor(remove_input_tags={_HIDE_INPUT_TAG}), enabled=True)
    for cell in nb.cells:  # drop remote stylesheet links from HTML outputs (jshtml animations)
        for out in cell.get("outputs", []):
            data = out.get("data", {})
            if "text/html" in data:
                text = data["text/html"] if isinstance(data["text/html"], str) else "".join(data["text/html"])
                data["text/html"] = _REMOTE_LINK.sub("", text)
    number_notebook(nb, chapter)  # numbered captions (as in the lab report), references, round-off as 0
    if figures:
        externalize(nb, html_path.resolve().parent, figures)
    has_widgets = "application/vnd.jupyter.widget-state+json" in nb.metadata.get("widgets", {})
    math, widgets = _needs_math(nb), has_widgets
    shared = asset_dir is not None
    inline = not shared or typeset  # scripts only Chromium runs are inlined into the page it renders
    html_dir = html_path.resolve().parent
    resources = {
        "metadata": {"name": html_path.stem},
        "labkit": {
            "mathjax": _asset("mathjax-tex-svg-full.js") if math and inline else "",
            "widgets": _asset("jupyter-widgets-embed.js") if widgets and inline else "",
            "mathjax_src": _shared_asset("mathjax-tex-svg-full.js", asset_dir, html_dir) if math and not inline else "",
            "widgets_src": _shared_asset("jupyter-widgets-embed.js", asset_dir, html_dir) if widgets and not inline else "",
            "css_src": _shared_css(asset_dir, html_dir) if shared else "",
            "status": status,
            "error": error,
            "title": title or html_path.stem,
            "generated": "generated by labkit render, " + _dt.datetime.now().strftime("%Y-%m-%d %H:%M"),
        },
    }
    body, _ = exporter.from_notebook_node(nb, resources=resources)
    body = scrub_paths(body, _default_roots(str(html_dir)))
    html_path.parent.mkdir(parents=True, exist_ok=True)
    html_path.write_text(body, encoding="utf-8")
    if typeset and (math or widgets):
        page = static_page(rendered_dom(html_path), html_path, math=math, widgets=widgets, css_dir=asset_dir)
        html_path.write_text(scrub_paths(page, _default_roots(str(html_dir))), encoding="utf-8")
    return html_path


def find_chromium() -> str:
    """Path of the Chromium executable (``$LABKIT_CHROMIUM``, chromium, chromium-browser).

    Returns
    -------
    str
        Full path of the first of ``$LABKIT_CHROMIUM``, ``chromium``,
        ``chromium-browser``, ``google-chrome`` found on ``PATH``.

    Raises
    ------
    LabkitError
        None of them is installed.
    """
    for name in (os.environ.get("LABKIT_CHROMIUM"), "chromium", "chromium-browser", "google-chrome"):
        if name and shutil.which(name):
            return shutil.which(name)
    raise LabkitError("Chromium not found (Debian: apt-get install chromium); use --no-pdf to skip PDFs")


def chromium_command(html, out, profile, *, mode="pdf", chromium="chromium", budget_ms=VIRTUAL_TIME_BUDGET_MS,
                     window="1200,1600"):
    """The headless-Chromium command line that prints ``html`` to a PDF (or a PNG screenshot).

    ``mode`` is ``"pdf"``, ``"screenshot"`` or ``"dom"`` (the rendered DOM on stdout; ``out`` unused).
    Host names do not resolve, so the page cannot fetch anything from the network. The browser runs with a fresh profile
    ``profile``, no sandbox, no GPU, and no background networking, component updates or
    sync, and waits ``budget_ms`` of virtual time for scripts (MathJax, widgets).

    Parameters
    ----------
    html : str or path-like
        The HTML report to load.
    out : str or path-like
        The PDF or PNG to write (unused for ``mode="dom"``).
    profile : str or path-like
        Directory for the fresh browser profile.
    mode : {"pdf", "screenshot", "dom"}
        What to produce.
    chromium : str
        The Chromium executable (see :func:`find_chromium`).
    budget_ms : int
        Virtual time [ms] given to the page's scripts.
    window : str
        Window size ``"width,height"`` [px] of a screenshot.

    Returns
    -------
    list of str
        The command line (program and arguments).

    Raises
    ------
    LabkitError
        ``mode`` is none of the three.
    """
    if mode not in ("pdf", "screenshot", "dom"):
        raise LabkitError(f"mode must be 'pdf', 'screenshot' or 'dom', got {mode!r}")
    cmd = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           "--disable-default-apps", "--mute-audio", "--hide-scrollbars",
           "--host-resolver-rules=MAP * ~NOTFOUND",  # offline: a report never fetches anything
           f"--user-data-dir={profile}", f"--virtual-time-budget={int(budget_ms)}"]
    if mode == "dom":
        return cmd + ["--dump-dom", Path(html).resolve().as_uri()]
    if mode == "pdf":
        # untagged: the structure tree of a tagged PDF doubles its size (a report's 0.9 MB -> 0.5 MB)
        cmd += ["--no-pdf-header-footer", "--disable-pdf-tagging", f"--print-to-pdf={out}"]
    else:
        cmd += [f"--window-size={window}", f"--screenshot={out}"]
    return cmd + [Path(html).resolve().as_uri()]


def rendered_dom(html, *, budget_ms=30000, timeout=300) -> str:
    """The DOM of ``html`` after its scripts ran (MathJax, widgets), from headless Chromium.

    Parameters
    ----------
    html : str or os.PathLike
        The page.
    budget_ms : int
        Chromium's virtual time budget for the scripts [ms].
    timeout : float
        Seconds Chromium may take [s].

    Returns
    -------
    str
        ``chromium --dump-dom``'s output.

    Raises
    ------
    LabkitError
        When Chromium is missing or does not finish in ``timeout``.
    """
    with tempfile.TemporaryDirectory(prefix="labkit-chromium-") as profile:
        cmd = chromium_command(Path(html).resolve(), None, profile, mode="dom", chromium=find_chromium(),
                               budget_ms=budget_ms)
        try:
            return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout).stdout
        except subprocess.TimeoutExpired as exc:
            raise LabkitError(f"Chromium did not render {Path(html).name} in {timeout} s") from exc


def print_pdf(html, pdf, *, mode="pdf", timeout=120, budget_ms=VIRTUAL_TIME_BUDGET_MS, window="1200,1600") -> Path:
    """Print ``html`` to ``pdf`` with headless Chromium (``mode="screenshot"``: a PNG instead).

    Parameters
    ----------
    html : str or os.PathLike
        The HTML report to print (opened as a ``file://`` URL, offline).
    pdf : str or os.PathLike
        Output file (replaced if it exists; parent folders are created).
    mode : {"pdf", "screenshot"}
        Print to PDF, or save a PNG screenshot of the window.
    timeout : float
        Wall-clock limit for Chromium [s].
    budget_ms : int
        Chromium's virtual time budget for scripts (MathJax, widgets) [ms].
    window : str
        Window size ``"width,height"`` [px] of a screenshot.

    Returns
    -------
    pathlib.Path
        The written file (absolute).

    Raises
    ------
    LabkitError
        If Chromium is missing, fails, times out or writes nothing, or ``mode``
        is unknown.
    """
    chromium = find_chromium()
    pdf = Path(pdf).resolve()
    pdf.parent.mkdir(parents=True, exist_ok=True)
    if pdf.exists():
        pdf.unlink()
    with tempfile.TemporaryDirectory(prefix="labkit-chromium-") as profile:
        cmd = chromium_command(html, pdf, profile, mode=mode, chromium=chromium, budget_ms=budget_ms, window=window)
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired as exc:
            raise LabkitError(f"Chromium did not finish printing {html} in {timeout} s") from exc
    if not pdf.is_file() or pdf.stat().st_size == 0:
        tail = "\n".join((proc.stderr or "").strip().splitlines()[-5:])
        raise LabkitError(f"Chromium wrote no {mode} for {html} (exit {proc.returncode}): {tail}")
    return pdf


def render_one(notebook, output_dir, *, no_input=False, pdf=True, parameters=None, timeout=None) -> RenderResult:
    """Execute one notebook and write its executed copy, HTML and (optionally) PDF report.

    Parameters
    ----------
    notebook : str or Path
        Source notebook ``.../<lab>/<name>.ipynb``.
    output_dir : str or Path
        Reports folder; files go to ``output_dir/<lab>/``.
    no_input : bool
        Report mode (hide code).
    pdf : bool
        Also print the PDF.
    parameters : dict, optional
        Parameter overrides. ``output_dir`` is set to ``output_dir/<lab>/<name>_files``
        when the notebook declares it and it is not overridden.
    timeout : float, optional
        Seconds one cell may run (default :data:`labkit.reports.CELL_TIMEOUT`).

    Returns
    -------
    RenderResult
        Never raises for a failing notebook: the failure is in ``error``.
    """
    notebook = Path(notebook).resolve()
    lab, name = lab_of(notebook), notebook.stem
    folder = Path(output_dir).resolve() / lab
    folder.mkdir(parents=True, exist_ok=True)
    params = dict(parameters or {})
    try:
        declared = notebook_parameters(notebook)
    except LabkitError:
        declared = {}
    if "output_dir" in declared and "output_dir" not in params:
        # absolute for the kernel; the executed notebook reads ./<name>_files (labkit.reports._portable)
        params["output_dir"] = str(folder / f"{name}_files")
    params = {k: v for k, v in params.items() if k in declared}
    with _stderr_to(folder / f"{name}.log"):  # kernel start-up chatter goes to the log, not the terminal
        result = execute_notebook(notebook, folder / f"{name}.ipynb", params, check_names=False,
                                  timeout=timeout or CELL_TIMEOUT)
    portable_text(folder / f"{name}.log", folder, notebook.parent)
    t0 = time.perf_counter()
    errors = [] if result.ok else [result.error]
    html_path = pdf_path = None
    try:
        import nbformat

        # figures and animation frames re-encoded once (small), then written once as files that the
        # HTML and the executed notebook both link (<name>_assets/)
        executed = nbformat.read(str(result.output), as_version=4)
        compact_notebook(executed)
        figures = f"{name}_assets"
        shutil.rmtree(folder / figures, ignore_errors=True)  # no stale figures of an earlier render
        html_path = export_html(executed, folder / f"{name}.html", no_input=no_input, title=f"{lab} / {name}",
                                status="passed" if result.ok else "failed", error="" if result.ok else errors[0],
                                asset_dir=Path(output_dir).resolve() / "_static", chapter=chapter_of(notebook),
                                figures=figures, typeset=True)
        externalize(executed, folder, figures)
        nbformat.write(executed, str(result.output))
        if pdf:
            pdf_path = print_pdf(html_path, folder / f"{name}.pdf")
    except Exception as exc:  # an export problem must not stop the batch
        errors.append(f"report export failed: {type(exc).__name__}: {exc}")
    return RenderResult(lab, name, result.ok and len(errors) == 0, "; ".join(errors), result.output, html_path,
                        pdf_path, result.seconds, time.perf_counter() - t0)


@contextmanager
def _stderr_to(path):
    """Redirect file descriptor 2 (this process and its children) to ``path``."""
    sys.stderr.flush()
    saved = os.dup(2)
    with open(path, "ab") as log:
        os.dup2(log.fileno(), 2)
        try:
            yield
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)


def _rel(path, start):
    return os.path.relpath(path, start).replace(os.sep, "/") if path else None


def _merge_previous(results, out):
    """Current results plus those of earlier renders (``index.json``) whose reports still exist."""
    state = out / "index.json"
    current = {(r.lab, r.name) for r in results}
    merged = list(results)
    try:
        previous = json.loads(state.read_text("utf-8"))
    except (OSError, ValueError):
        previous = []
    for row in previous:
        try:
            if (row["lab"], row["name"]) in current or not (out / row["html"]).is_file():
                continue
            paths = {k: (out / row[k]) if row.get(k) else None for k in ("notebook", "html", "pdf")}
            merged.append(RenderResult(row["lab"], row["name"], bool(row["ok"]), row["error"], paths["notebook"],
                                       paths["html"], paths["pdf"], float(row["seconds"])))
        except (KeyError, TypeError, ValueError):
            continue
    state.write_text(json.dumps([{"lab": r.lab, "name": r.name, "ok": r.ok, "error": r.error, "seconds": r.seconds,
                                  **{k: _rel(getattr(r, k), out) for k in ("notebook", "html", "pdf")}}
                                 for r in merged], indent=1), encoding="utf-8")
    return merged


def write_index(results, output_dir, *, wall_seconds=None) -> Path:
    """Write ``output_dir/index.html``: each lab's hand-in report, every notebook's report with pass/fail.

    Reports rendered earlier into the same folder (recorded in ``index.json``) stay listed
    when only some notebooks are re-rendered.

    Parameters
    ----------
    results : sequence of RenderResult
        Reports rendered now.
    output_dir : str or os.PathLike
        Reports folder (created if missing).
    wall_seconds : float, optional
        Wall time of this render [s], shown in the summary line.

    Returns
    -------
    pathlib.Path
        The ``index.html`` written.
    """
    out = Path(output_dir).resolve()
    out.mkdir(parents=True, exist_ok=True)
    results = _merge_previous(results, out)
    rows = []
    for r in sorted(results, key=lambda r: (r.lab, r.name)):
        links = " ".join(f'<a href="{_html.escape(_rel(p, out))}">{kind}</a>'
                         for kind, p in (("HTML", r.html), ("PDF", r.pdf), ("notebook", r.notebook)) if p)
        status = "pass" if r.ok else "FAIL"
        rows.append(f'<tr class="{status.lower()}"><td>{_html.escape(r.lab)}</td><td>{_html.escape(r.name)}</td>'
                    f"<td>{status}</td><td>{links}</td><td>{r.seconds:.1f}</td>"
                    f"<td><pre>{_html.escape(r.error)}</pre></td></tr>")
    hand_in = []  # the one report per lab a student hands in (labkit report writes <lab>.pdf, .html, .docx here)
    for lab in sorted({r.lab for r in results}):
        links = " ".join(f'<a href="{_html.escape(lab)}.{ext}">{ext.upper()}</a>' for ext in ("pdf", "html", "docx")
                         if (out / f"{lab}.{ext}").is_file()) or f"not written yet: <code>labkit report {lab}</code>"
        hand_in.append(f"<tr><td>{_html.escape(lab)}</td><td>{links}</td></tr>")
    n_fail = sum(not r.ok for r in results)
    summary = f"{len(results)} notebooks, {len(results) - n_fail} passed, {n_fail} failed"
    if wall_seconds is not None:
        summary += f", last render took {wall_seconds:.1f} s"
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>labkit reports</title>
<style>
body {{ font-family: sans-serif; margin: 2em; }}
table {{ border-collapse: collapse; }}
td, th {{ border: 1px solid #ccc; padding: 4px 10px; text-align: left; vertical-align: top; }}
tr.pass td:nth-child(3) {{ color: #1e7d32; font-weight: bold; }}
tr.fail td:nth-child(3) {{ color: #b71c1c; font-weight: bold; }}
pre {{ margin: 0; white-space: pre-wrap; max-width: 50em; }}
</style></head><body>
<h1>labkit lab reports</h1>
<p>{_html.escape(summary)}. Generated {_dt.datetime.now().strftime("%Y-%m-%d %H:%M")}.</p>
<h2>Hand-in reports, one per lab</h2>
<table><thead><tr><th>lab</th><th>report</th></tr></thead><tbody>
{chr(10).join(hand_in)}
</tbody></table>
<h2>Notebooks</h2>
<table><thead><tr><th>lab</th><th>notebook</th><th>status</th><th>report</th><th>run [s]</th><th>error</th></tr></thead>
<tbody>
{chr(10).join(rows)}
</tbody></table></body></html>
"""
    out.mkdir(parents=True, exist_ok=True)
    index = out / "index.html"
    index.write_text(scrub_paths(page, _default_roots(str(out))), encoding="utf-8")
    portable_text(out / "index.json", out)
    return index


def render(notebooks=None, output_dir="reports", *, jobs=2, no_input=False, pdf=True, parameters=None,
           progress=print, timeout=None):
    """Execute notebooks in ``jobs`` worker processes and write all reports plus the index.

    Parameters
    ----------
    notebooks : sequence of str or Path, optional
        Notebooks, lab folders or lab names (see :func:`labkit.reports.find_notebooks`);
        default: all.
    output_dir : str or Path
        Reports folder.
    jobs : int
        Number of worker processes (each runs its own kernel and Chromium).
    no_input, pdf : bool
        Report mode; print PDFs.
    parameters : dict, optional
        Overrides for every notebook (only those a notebook declares are applied).
    progress : callable or None
        Called with one line of text per finished notebook.
    timeout : float, optional
        Seconds one cell may run.

    Returns
    -------
    (list of RenderResult, float)
        Results in finishing order and the total wall time [s].
    """
    if jobs < 1:
        raise LabkitError(f"--jobs must be >= 1, got {jobs}")
    paths = find_notebooks(notebooks)
    if not paths:
        raise LabkitError("no notebooks to render")
    with needs_extra("reports"):  # fail early, not once per notebook in the workers
        import nbconvert, papermill  # noqa: F401, E401
    if pdf:
        find_chromium()  # fail early, before executing anything
    progress = progress or (lambda line: None)
    out = Path(output_dir).resolve()
    paths = sorted(paths, key=lambda p: -_previous_seconds(out, p))  # longest first: shorter tail
    t0 = time.perf_counter()
    results = []
    progress(f"rendering {len(paths)} notebooks with {jobs} worker(s) into {out}")
    import multiprocessing

    with ProcessPoolExecutor(max_workers=min(jobs, len(paths)),
                             mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = {pool.submit(render_one, p, out, no_input=no_input, pdf=pdf, parameters=parameters,
                               timeout=timeout): p for p in paths}
        for fut in as_completed(futures):
            p = futures[fut]
            try:
                r = fut.result()
            except Exception as exc:  # a crashed worker: report it, keep going
                r = RenderResult(lab_of(p), p.stem, False, f"{type(exc).__name__}: {exc}", None, None, None, 0.0)
            results.append(r)
            status = "ok  " if r.ok else "FAIL"
            line = (f"[{len(results):>2}/{len(paths)}] {status} {r.lab}/{r.name}  "
                    f"run {r.seconds:5.1f} s, report {r.export_seconds:4.1f} s")
            progress(line + ("" if r.ok else f"\n        {r.error}"))
    wall = time.perf_counter() - t0
    write_index(results, out, wall_seconds=wall)
    return results, wall


def _previous_seconds(output_dir, notebook) -> float:
    """Run time of the notebook's previous render (papermill metadata), +inf when unknown."""
    executed = Path(output_dir) / lab_of(notebook) / f"{Path(notebook).stem}.ipynb"
    try:
        return float(json.loads(executed.read_text("utf-8"))["metadata"]["papermill"]["duration"])
    except (OSError, ValueError, KeyError, TypeError):
        return float("inf")
