"""labkit.reports (notebook execution, rendering, notebook tools): parameters, offline HTML, PDF, batch rendering."""

import re
from pathlib import Path

import numpy as np
import pytest

from conftest import require

REPO = Path(__file__).resolve().parents[2]
from labkit.exceptions import LabkitError

REMOTE = re.compile(
    r"""<(?:script|link|img|iframe|source)\b[^>]*\b(?:src|href)\s*=\s*["']?(?:https?:)?//"""
    r"""|@import\s+(?:url\()?\s*["']?(?:https?:)?//"""
    r"""|url\(\s*["']?(?:https?:)?//""",
    re.IGNORECASE,
)
ROOT = Path(__file__).resolve().parents[2]


def pdf_pages(path):
    """Number of pages of a PDF (Chromium writes uncompressed page objects)."""
    return len(re.findall(rb"/Type\s*/Page(?![a-zA-Z])", Path(path).read_bytes()))


def make_notebook(path, cells, params="output_dir = 'out'\nport = 'sim://'"):
    nbformat = require("nbformat")
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell("# Demo (seed none)\nMath: $\\tau = J^T F$")]
    nb.cells.append(nbformat.v4.new_code_cell(params, metadata={"tags": ["parameters"]}))
    nb.cells += [nbformat.v4.new_code_cell(c) for c in cells]
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    path.parent.mkdir(parents=True, exist_ok=True)
    nbformat.write(nb, str(path))
    return path


# ---------------------------------------------------------------- parameters, discovery

@pytest.mark.parametrize("text, value", [("3", 3), ("0.5", 0.5), ("True", True), ("None", None),
                                         ("[1, 2]", [1, 2]), ("sim://", "sim://"),
                                         ("/dev/ttyACM0", "/dev/ttyACM0"), ("'3'", "3")])
def test_parse_parameter(text, value):
    from labkit.reports import parse_parameter

    assert parse_parameter(text) == value


def test_find_notebooks_selection(tmp_path):
    from labkit.reports import find_notebooks, lab_of

    a = make_notebook(tmp_path / "lab_a" / "one.ipynb", ["x = 1"])
    b = make_notebook(tmp_path / "lab_b" / "two.ipynb", ["x = 2"])
    make_notebook(tmp_path / "lab_b" / ".ipynb_checkpoints" / "two-checkpoint.ipynb", ["x = 2"])
    assert find_notebooks(root=tmp_path) == [a.resolve(), b.resolve()]
    assert find_notebooks(["lab_b"], root=tmp_path) == [b.resolve()]
    assert find_notebooks([str(a)], root=tmp_path) == [a.resolve()]
    assert find_notebooks(["one"], root=tmp_path) == [a.resolve()]
    assert lab_of(b) == "lab_b"
    with pytest.raises(LabkitError, match="lab_a, lab_b"):
        find_notebooks(["nope"], root=tmp_path)


def test_unknown_parameter_is_rejected_with_the_valid_names(tmp_path):
    require("papermill")
    from labkit.reports import execute_notebook

    nb = make_notebook(tmp_path / "lab" / "p.ipynb", ["y = 1"])
    with pytest.raises(LabkitError, match="its parameters are: output_dir, port"):
        execute_notebook(nb, tmp_path / "out.ipynb", {"prot": "/dev/ttyACM0"})
    assert not (tmp_path / "out.ipynb").exists()


def test_parameter_overrides_must_fit_the_default_type(tmp_path, capsys):
    """Issue 13: ``labkit run -p beta_deg nan`` failed deep inside a cell; now it is refused up front."""
    from labkit.cli import main
    from labkit.exceptions import OptionError
    from labkit.reports import check_parameter_types, parse_parameter

    declared = {"beta_deg": "45.0", "n": "3", "port": '"sim://"', "show": "True", "q0": "[0, 0]",
                "opt": "None", "q": "np.radians([1, 2])"}
    ok = {"beta_deg": 30, "n": 4, "port": "/dev/ttyACM0", "show": False, "q0": (1, 2), "opt": "x", "q": "anything"}
    check_parameter_types("nb.ipynb", declared, ok)
    for key, text, kind in [("beta_deg", "nan", "a finite number like its default 45.0, got 'nan' \\(str\\)"),
                            ("beta_deg", "True", "a finite number"), ("n", "3.5", "an? int like its default 3"),
                            ("port", "5", "a str like its default"), ("show", "1", "a bool"), ("q0", "7", "a list")]:
        with pytest.raises(OptionError, match=f"nb.ipynb: parameter {key} expects {kind}"):
            check_parameter_types("nb.ipynb", declared, {key: parse_parameter(text)})
    nb = REPO / "notebooks" / "seed002_advanced_robotics" / "01_rotations.ipynb"
    assert main(["run", str(nb), "-p", "beta_deg", "nan", "-o", str(tmp_path / "out.ipynb")]) == 2
    assert "parameter beta_deg expects a finite number like its default 45.0, got 'nan'" in capsys.readouterr().err
    assert not (tmp_path / "out.ipynb").exists()


def test_chromium_command_flags():
    from labkit.reports._render import chromium_command

    cmd = chromium_command("r.html", "/tmp/r.pdf", "/tmp/prof", budget_ms=5000)
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--user-data-dir=/tmp/prof",
                 "--virtual-time-budget=5000", "--print-to-pdf=/tmp/r.pdf"):
        assert flag in cmd
    assert cmd[-1].startswith("file://") and cmd[-1].endswith("/r.html")
    assert "--host-resolver-rules=MAP * ~NOTFOUND" in cmd  # offline
    with pytest.raises(LabkitError, match="'pdf', 'screenshot' or 'dom'"):
        chromium_command("r.html", "x", "p", mode="png")


# ---------------------------------------------------------------- HTML export (no kernel)

def executed_notebook(with_error=False):
    nbformat = require("nbformat")
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell("Rotation $R_x(\\theta)$"),
                nbformat.v4.new_code_cell("secret_input_line = 1", execution_count=1)]
    html_out = ('<link rel="stylesheet" href="https://maxcdn.bootstrapcdn.com/font-awesome/4.4.0/css/fa.css">'
                '<div class="anim">frames</div>')
    nb.cells[1].outputs = [nbformat.v4.new_output("display_data", {"text/html": html_out, "text/plain": "anim"})]
    if with_error:
        bad = nbformat.v4.new_code_cell("failing_input_line = 1/0", execution_count=2)
        bad.outputs = [nbformat.v4.new_output("error", ename="ZeroDivisionError", evalue="division by zero",
                                              traceback=["ZeroDivisionError: division by zero"])]
        nb.cells.append(bad)
    return nb


def test_export_html_is_offline_and_inlines_mathjax(tmp_path):
    require("nbconvert")
    from labkit.reports import export_html

    html = export_html(executed_notebook(), tmp_path / "r.html", status="passed").read_text()
    assert REMOTE.search(html) is None, REMOTE.search(html)
    assert "window.MathJax" in html and "MathJax" in html and len(html) > 1_000_000  # MathJax inlined
    assert "_jupyter_widget_embedder" not in html  # no widget state: the widget manager is not inlined
    assert "secret_input_line" in html and "passed" in html


def test_export_html_without_math_or_widgets_stays_small(tmp_path):
    nbformat = require("nbformat")
    from labkit.reports import export_html

    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell("No math here, just 5 dollars"), nbformat.v4.new_code_cell("x = 1")]
    html = export_html(nb, tmp_path / "r.html").read_text()
    assert "window.MathJax" not in html and len(html) < 1_000_000


def test_no_input_hides_code_but_not_the_failing_cell(tmp_path):
    require("nbconvert")
    from labkit.reports import export_html

    html = export_html(executed_notebook(with_error=True), tmp_path / "r.html", no_input=True, status="failed",
                       error="ZeroDivisionError: division by zero").read_text()
    assert "secret_input_line" not in html
    assert "failing_input_line" in html and "ZeroDivisionError" in html
    assert 'labkit-banner failed' in html


def test_remote_pattern_catches_remote_references():
    for bad in ('<script src="https://cdn.x/y.js">', "<link href='http://a/b.css' rel=stylesheet>",
                "@import url('https://fonts.googleapis.com/css');", "src: url(https://x/f.woff2)",
                '<script src="//cdn.x/y.js">'):
        assert REMOTE.search(bad), bad
    for ok in ('<a href="https://www.mathjax.org">', '<script src="data:text/javascript,1">', "xmlns='http://www.w3.org'"):
        assert REMOTE.search(ok) is None, ok


# ---------------------------------------------------------------- nbtools

def test_checks_pass_fail_and_typos():
    from labkit.reports import Checks, check

    c = Checks(display=False)
    assert c.check("T", [[1.0, 2.0]], [[1.00004, 2.0]], tol=5e-5).passed
    assert not c.check("x", 1.0, 1.1, tol=0.05, note="sec. 4.3").passed
    c.typo("M", [0.16976], [0.0816], note="double counted")
    df = c.to_dataframe()
    assert list(df["result"]) == ["pass", "FAIL", "published typo"]
    with pytest.raises(AssertionError, match=r"x: max \|diff\| 0.100 > tol 0.050"):
        c.assert_all()
    with pytest.raises(AssertionError, match="differs from published"):
        check("pi", 3.0, np.pi, tol=1e-3)
    with pytest.raises(ValueError, match=r"published shape \(3,\)"):
        c.check("shape", [1, 2], [1, 2, 3], tol=1)
    assert c.check("rel", 101.0, 100.0, tol=0.011, relative=True).passed


def test_matrix_latex():
    from labkit.reports import matrix_latex

    tex = matrix_latex(np.array([[0.86603, -0.00001], [0.5, 1]]), decimals=4)
    assert tex == "\\begin{bmatrix} 0.8660 & 0.0000 \\\\ 0.5000 & 1.0000 \\end{bmatrix}"
    with pytest.raises(ValueError, match=r"got \(2, 2, 2\)"):
        matrix_latex(np.zeros((2, 2, 2)))


# ---------------------------------------------------------------- batch render (kernel + Chromium)

def _assert_no_machine_path(out, tmp_path):
    """No file under ``out`` (executed notebooks as JSON, HTML, logs, index, PDF text) names the
    output folder, the repository or the home folder by its absolute path."""
    import os

    pypdf = require("pypdf")
    forbidden = [str(tmp_path), str(out), str(REPO), os.path.expanduser("~") + "/"]
    files = [p for p in out.rglob("*") if p.is_file()]
    assert any(p.suffix == ".pdf" for p in files) and any(p.suffix == ".ipynb" for p in files)
    for path in files:
        if path.suffix == ".pdf":
            text = "\n".join(page.extract_text() or "" for page in pypdf.PdfReader(str(path)).pages)
        elif path.suffix in (".png", ".jpg", ".jpeg", ".gif"):
            continue
        else:
            text = path.read_text("utf-8", errors="replace")
        for root in forbidden:
            assert root not in text, f"{path.relative_to(out)} names {root}"


@pytest.mark.slow
def test_render_batch_html_pdf_index_and_failure(tmp_path, capsys):
    require("papermill")
    from labkit.cli import main

    good = make_notebook(tmp_path / "nb" / "demo" / "good.ipynb", [
        "import matplotlib.pyplot as plt\nfig, ax = plt.subplots(figsize=(3, 2))\nax.plot([0, 1], [1, 0])\nplt.show()",
        "import ipywidgets as w\nw.IntSlider(value=7, description='q1')",
        "from labkit.reports import Checks\nc = Checks()\nc.check('tau', [2, 3, 1], [2, 3, 1], tol=1e-9)\nc.assert_all()",
        # absolute paths of the machine printed by the code: the output folder, the kernel's folder, $HOME, the repo
        "import os, sys, labkit\nos.makedirs(output_dir, exist_ok=True)\n"
        "print('saved', os.path.abspath(os.path.join(output_dir, 'x.csv')), 'in', os.getcwd())\n"
        "print('home', os.path.expanduser('~'), 'labkit', labkit.__file__, 'python', sys.prefix)",
    ])
    bad = make_notebook(tmp_path / "nb" / "demo" / "bad.ipynb", ["raise RuntimeError('servo 2 stalled')"])
    out = tmp_path / "reports"
    rc = main(["render", str(good), str(bad), "--jobs", "2", "--no-input", "-o", str(out)])
    printed = capsys.readouterr()
    assert rc == 1
    assert "FAILED (1): demo/bad" in printed.err
    assert re.search(r"2 notebooks rendered in \d+\.\d s", printed.out)
    assert "[ 1/2]" in printed.out and "[ 2/2]" in printed.out
    for name in ("good", "bad"):
        for ext in ("ipynb", "html", "pdf"):
            assert (out / "demo" / f"{name}.{ext}").stat().st_size > 0, (name, ext)
        html = (out / "demo" / f"{name}.html").read_text()
        assert REMOTE.search(html) is None
        assert pdf_pages(out / "demo" / f"{name}.pdf") >= 1
    good_html = (out / "demo" / "good.html").read_text()
    # math typeset and widgets rendered once by Chromium: SVG math and the slider, no MathJax or widget manager
    assert "<mjx-container" in good_html and "<svg" in good_html and "q1" in good_html
    assert "widget-slider" in good_html and "application/vnd.jupyter.widget-state+json" not in good_html
    assert "window.MathJax" not in good_html and "embed.js" not in good_html and len(good_html) < 300_000
    static = sorted(p.name for p in (out / "_static").iterdir())
    assert static[0] == "jupyterlab.css" and all(n.startswith("rendered-") for n in static[1:]), static
    assert f'href="../_static/{static[1]}"' in good_html  # the widgets' stylesheet, written once
    assert "_jupyter_widget_embedder" not in good_html
    _assert_no_machine_path(out, tmp_path)
    executed = (out / "demo" / "good.ipynb").read_text()
    assert '"input_path": "demo/good.ipynb"' in executed and '"output_path": "good.ipynb"' in executed
    assert 'output_dir = \\"./good_files\\"' in executed and "../" not in executed  # relative to the notebook
    assert "saved ./good_files/x.csv in ." in re.sub(r"<[^>]+>", "", good_html)
    bad_html = (out / "demo" / "bad.html").read_text()
    text = re.sub(r"<[^>]+>", "", bad_html)
    assert "servo 2 stalled" in text and "raise RuntimeError(" in text  # the failing cell is shown
    index = (out / "index.html").read_text()
    assert 'href="demo/good.html"' in index and 'href="demo/bad.pdf"' in index
    assert index.count("<td>pass</td>") == 1 and index.count("<td>FAIL</td>") == 1
    # re-rendering one notebook keeps the other listed (index.json)
    from labkit.reports import write_index, RenderResult

    write_index([RenderResult("demo", "bad", True, "", None, out / "demo" / "bad.html", None, 1.0)], out)
    index = (out / "index.html").read_text()
    assert index.count("<td>pass</td>") == 2 and 'href="demo/good.html"' in index


@pytest.mark.slow
def test_rendered_html_screenshot_is_not_blank(tmp_path):
    require("papermill")
    import matplotlib.image as mpimg
    from labkit.reports import render, print_pdf

    nb = make_notebook(tmp_path / "nb" / "shot" / "shot.ipynb", [
        "import matplotlib.pyplot as plt\nfig, ax = plt.subplots(figsize=(4, 3))\n"
        "ax.fill_between([0, 1], [0, 1], color='tab:blue')\nplt.show()",
        "from IPython.display import Math\nMath(r'\\tau = J^T F')",
    ])
    results, wall = render([nb], tmp_path / "reports", jobs=1, pdf=False, progress=None)
    assert results[0].ok, results[0].error
    png = print_pdf(results[0].html, tmp_path / "shot.png", mode="screenshot", window="900,900")
    img = mpimg.imread(png)[..., :3]
    non_white = np.mean(np.any(img < 0.9, axis=-1))
    blue = np.mean((img[..., 2] > 0.6) & (img[..., 0] < 0.4))
    assert non_white > 0.05, f"screenshot looks blank ({non_white:.3f} non-white)"
    assert blue > 0.01, "the matplotlib figure is not visible in the screenshot"
    # MathJax (inlined) typeset the formula offline: the rendered DOM holds an SVG math container
    import subprocess

    from labkit.reports._render import chromium_command, find_chromium

    dom = subprocess.run(chromium_command(results[0].html, None, tmp_path / "profile", mode="dom",
                                          chromium=find_chromium()), capture_output=True, text=True, timeout=120).stdout
    assert 'data-mathjax="done"' in dom and "<mjx-container" in dom


@pytest.mark.slow
def test_labkit_run_overrides_parameters_and_reports_failures(tmp_path, capsys):
    require("papermill")
    nbformat = require("nbformat")
    from labkit.cli import main

    nb = make_notebook(tmp_path / "lab" / "run.ipynb", [
        "assert port == '/dev/fake', port\nprint('PORT', port)",
    ])
    out = tmp_path / "executed.ipynb"
    assert main(["run", str(nb), "-p", "port", "/dev/fake", "-o", str(out), "--html"]) == 0
    executed = nbformat.read(str(out), as_version=4)
    injected = [c for c in executed.cells if "injected-parameters" in c.metadata.get("tags", [])]
    assert injected and "/dev/fake" in injected[0].source
    assert out.with_suffix(".html").is_file()
    assert main(["run", str(nb), "-o", str(tmp_path / "default.ipynb")]) == 1  # default port: the assert fails
    assert "AssertionError: sim://" in capsys.readouterr().err


@pytest.mark.slow
def test_widget_cells_do_not_wait_for_the_cell_timeout(tmp_path):
    """Regression (nbclient #312): with ipywidgets the client missed the reply until the timeout."""
    require("papermill")
    from labkit.reports import execute_notebook

    nb = make_notebook(tmp_path / "lab" / "w.ipynb", [
        "import ipywidgets as w\nw.interact(lambda x: print(x), x=w.FloatSlider(value=1.0));",
        "w.interact(lambda y: print(y), y=(0.0, 1.0));",
    ])
    for k in range(4):
        result = execute_notebook(nb, tmp_path / f"out{k}.ipynb", timeout=30)
        assert result.ok, result.error
        assert result.seconds < 25, f"run {k} took {result.seconds:.1f} s: a reply was read only at the timeout"


def _kernel_that_dies_at_start(tmp_path, monkeypatch, deaths):
    """A kernelspec ``dying`` whose first ``deaths`` kernels exit before replying to kernel_info; then ipykernel."""
    import json
    import sys

    count = tmp_path / "starts"
    script = tmp_path / "dying_kernel.py"
    script.write_text(
        "import sys\nfrom pathlib import Path\n"
        f"count = Path({str(count)!r})\n"
        "n = int(count.read_text()) + 1 if count.exists() else 1\ncount.write_text(str(n))\n"
        f"if n <= {deaths}:\n    sys.exit(1)  # dies while starting: no cell has run\n"
        "from ipykernel import kernelapp\nkernelapp.launch_new_instance()\n")
    spec = tmp_path / "jupyter" / "kernels" / "dying"
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, str(script), "-f", "{connection_file}"], "display_name": "dying", "language": "python"}))
    monkeypatch.setenv("JUPYTER_PATH", str(tmp_path / "jupyter"))
    return count


@pytest.mark.slow
def test_a_kernel_that_dies_while_starting_is_started_again(tmp_path, monkeypatch):
    """A kernel that dies before its first reply (seen once in a CI-sized run: several kernels starting at
    once on a loaded machine) has run no cell: the notebook runs from the start in a new kernel."""
    require("papermill")
    from labkit.reports import execute_notebook

    count = _kernel_that_dies_at_start(tmp_path, monkeypatch, deaths=1)
    nb = make_notebook(tmp_path / "lab" / "k.ipynb", ["x = 6 * 7", "assert x == 42"])
    result = execute_notebook(nb, tmp_path / "out.ipynb", kernel_name="dying", timeout=60)
    assert result.ok, result.error
    assert count.read_text() == "2"  # one death, one kernel that ran the notebook


@pytest.mark.slow
def test_a_kernel_that_never_starts_is_reported_after_a_few_starts(tmp_path, monkeypatch):
    """Kernels that keep dying at start: a few tries (labkit.reports._execute.KERNEL_STARTS), then the
    notebook is reported as failed with jupyter_client's reason, the batch goes on."""
    require("papermill")
    from labkit.reports import execute_notebook
    from labkit.reports._execute import KERNEL_STARTS

    count = _kernel_that_dies_at_start(tmp_path, monkeypatch, deaths=99)
    nb = make_notebook(tmp_path / "lab" / "k.ipynb", ["x = 1"])
    result = execute_notebook(nb, tmp_path / "out.ipynb", kernel_name="dying", timeout=60)
    assert not result.ok and "Kernel died before replying to kernel_info" in result.error
    assert count.read_text() == str(KERNEL_STARTS)
    assert (tmp_path / "out.ipynb").is_file()


def test_index_links_each_labs_hand_in_report(tmp_path):
    """reports/index.html links <lab>.pdf and <lab>.html (labkit report's hand-in) beside the notebooks' reports."""
    from labkit.reports import RenderResult, write_index

    out = tmp_path / "reports"
    (out / "demo").mkdir(parents=True)
    (out / "demo" / "a.html").write_text("<p>a</p>")
    (out / "other").mkdir()
    (out / "other" / "b.html").write_text("<p>b</p>")
    results = [RenderResult("demo", "a", True, "", None, out / "demo" / "a.html", None, 1.0),
               RenderResult("other", "b", True, "", None, out / "other" / "b.html", None, 1.0)]
    write_index(results, out)
    index = (out / "index.html").read_text()
    assert 'href="demo.pdf"' not in index and "not written yet: <code>labkit report demo</code>" in index
    (out / "demo.pdf").write_bytes(b"%PDF-1.4")
    (out / "demo.html").write_text("<p>report</p>")
    write_index([], out)  # what labkit report does after writing into a render folder
    index = (out / "index.html").read_text()
    assert 'href="demo.pdf">PDF</a> <a href="demo.html">HTML</a>' in index
    assert "not written yet: <code>labkit report other</code>" in index and 'href="demo/a.html"' in index
