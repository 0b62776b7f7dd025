"""labkit report: one document per lab, read back from the PDF (pdfplumber, pypdf), HTML and DOCX.

The small lab built here has what breaks a printed report: a table wider than the page, a
long code line, a figure, an equation, cross-references between chapters, a failing-free
closing check with round-off and a published typo, and an absolute path printed by the code.
"""

import ast
import html as _html
import logging
import re
import zipfile
from pathlib import Path

import numpy as np
import pytest

from conftest import require
from labkit.exceptions import LabkitError

REPO = Path(__file__).resolve().parents[2]
MACHINE_PATH = re.compile(r"(?<![\w.])/(?:tmp|home|root|work|usr|opt|var)/[\w./-]+")


# ---------------------------------------------------------------- numbering and references

def _nb(cells):
    nbformat = require("nbformat")
    nb = nbformat.v4.new_notebook()
    for kind, src, *outputs in cells:
        cell = nbformat.v4.new_markdown_cell(src) if kind == "md" else nbformat.v4.new_code_cell(src)
        if kind == "code":
            cell.outputs = [nbformat.from_dict(o) for o in (outputs[0] if outputs else [])]
        nb.cells.append(cell)
    return nb


PNG = {"output_type": "display_data", "metadata": {},
       "data": {"image/png": "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mP8z8BQDwAEhQGAhKmMIQAAAABJRU5ErkJggg==",
                "text/plain": "<Figure>"}}
TABLE = {"output_type": "execute_result", "metadata": {}, "execution_count": 1,
         "data": {"text/html": "<table><thead><tr><th>x [mm]</th></tr></thead><tbody><tr><td>1</td></tr></tbody></table>",
                  "text/plain": "x"}}


def test_cell_options_and_numbering_per_chapter():
    from labkit.reports._numbering import cell_options, number_notebooks

    opts, rest = cell_options('#| label: fig-a\n#| fig-cap: "The arm: $q$"\nplot()\n#| not an option')
    assert opts == {"label": "fig-a", "fig-cap": "The arm: $q$"} and rest.startswith("plot()")
    one = _nb([("md", "# One"), ("code", "#| label: fig-a\n#| fig-cap: A"), ("code", "#| tbl-cap: [T1, T2]"),
               ("code", "#| label: fig-b\n#| fig-cap: B")])
    two = _nb([("md", "# Two\n\n$$ x = 1 $$ {#eq-x}"), ("code", "#| label: tbl-c\n#| tbl-cap: C")])
    labels = number_notebooks([one, two])["labels"]
    assert labels["fig-a"].text == "Figure 1.1" and labels["fig-b"].text == "Figure 1.2"
    assert [lab.text for lab in labels.values() if lab.kind == "tbl"] == ["Table 1.1", "Table 1.2", "Table 2.1"]
    assert labels["eq-x"].text == "Equation (2.1)"
    assert number_notebooks([one], chapters=False)["labels"]["fig-b"].text == "Figure 2"
    # every notebook of a lab may have its own fig-a (a reference resolves in its own chapter first)
    both = number_notebooks([one, one])
    assert "fig-a" not in both["labels"] and both["local"][1]["fig-a"].text == "Figure 2.1"
    assert both["local"][1]["fig-a"].anchor == "fig-a-2"
    with pytest.raises(LabkitError, match="fig-a is defined twice in notebook 1"):
        number_notebooks([_nb([("code", "#| label: fig-a\n#| fig-cap: A"), ("code", "#| label: fig-a\n#| fig-cap: B")])])


def test_references_are_resolved_and_unknown_ones_reported():
    from labkit.reports._numbering import number_notebooks, resolve_references

    nb = _nb([("code", "#| label: fig-arm\n#| fig-cap: The arm"), ("md", "$$ a $$ {#eq-a}")])
    labels = number_notebooks([nb], chapters=False)["labels"]
    missing = []
    text = resolve_references("See @fig-arm and @eq-a, not a@fig-arm, and @fig-nope.", labels, unresolved=missing)
    assert "[Figure 1](#fig-arm)" in text and "[Equation (1)](#eq-a)" in text and "a@fig-arm" in text
    assert missing == ["fig-nope"] and "?@fig-nope" in text
    assert "\\tag{1}" in resolve_references("$$ a $$ {#eq-a}", labels)


def test_an_equation_labelled_by_a_hidden_anchor_is_numbered_and_referenced():
    """``$$ ... $$ <a id="eq-x"></a>``: a live notebook shows nothing of the label (Quarto's ``{#eq-x}`` it shows
    as text); the report numbers it as Quarto's form and leaves no anchor text behind."""
    from labkit.reports._numbering import number_notebooks, resolve_references

    nb = _nb([("md", "# One"), ("md", '$$ u = a t $$ {#eq-a}\n\n$$ v = b t $$ <a id="eq-b"></a>\n\nSee [Equation](#eq-b).')])
    labels = number_notebooks([nb], chapters=False)["labels"]
    assert (labels["eq-a"].text, labels["eq-b"].text) == ("Equation (1)", "Equation (2)")
    text = resolve_references(nb.cells[1].source, labels)
    assert "\\tag{2}" in text and "<a id=" not in text and "[Equation (2)](#eq-b)" in text


def test_per_notebook_html_numbers_captions_and_references(tmp_path):
    require("nbconvert")
    from labkit.reports import export_html

    nb = _nb([("md", "# Demo\n\nAs @fig-arm and @tbl-xyz show."),
              ("code", "#| label: fig-arm\n#| fig-cap: \"The arm (the seed's Figure 8.2)\"\nplot()", [PNG]),
              ("code", "#| label: tbl-xyz\n#| tbl-cap: Positions\ntable", [TABLE])])
    html = export_html(nb, tmp_path / "r.html").read_text()
    text = re.sub(r"<[^>]+>", "", html)
    assert "Figure 1: The arm (the seed's Figure 8.2)" in text and "Table 1: Positions" in text
    assert 'href="#fig-arm"' in html and 'id="fig-arm"' in html and "#| label" not in html  # one notebook: the label
    assert text.index("Table 1: Positions") < text.index("x [mm]")  # a table's caption is above it


def test_per_notebook_reports_number_as_the_lab_report(tmp_path):
    """labkit render's HTML of a lab's second notebook says "Figure 2.1", captions as in the lab report."""
    nbformat = require("nbformat")
    from labkit.reports import export_html
    from labkit.reports._document import _chapter
    from labkit.reports._numbering import number_notebooks
    from labkit.reports._execute import chapter_of

    lab = tmp_path / "lab"
    lab.mkdir()
    first = _nb([("md", "# One\n\nSee @fig-a."), ("code", "#| label: fig-a\n#| fig-cap: First figure\nplot()", [PNG])])
    second = _nb([("md", "# Two\n\n@fig-arm and @tbl-xyz; $$ x = 1 $$ {#eq-x} and @eq-x."),
                  ("code", "#| label: tbl-xyz\n#| tbl-cap: Positions\ntable", [TABLE]),
                  ("code", "#| label: fig-arm\n#| fig-cap: \"The arm (the seed's Figure 8.2)\"\nplot()", [PNG])])
    for name, nb in (("01_one.ipynb", first), ("02_two.ipynb", second)):
        nbformat.write(nb, str(lab / name))
    assert [chapter_of(lab / "01_one.ipynb"), chapter_of(lab / "02_two.ipynb")] == [1, 2]
    numbering = number_notebooks([first, second])
    captions = {}
    for k, (nb, path) in enumerate(((first, lab / "01_one.ipynb"), (second, lab / "02_two.ipynb"))):
        chapter = _chapter(k, nb, path.stem, numbering, show_code=False, unresolved=[])
        in_lab = re.findall(r"((?:Figure|Table) \d+\.\d+)</span>: ([^<]*)", "".join(chapter.body))
        html = export_html(nb, tmp_path / f"{path.stem}.html", chapter=chapter_of(path)).read_text()
        alone = re.findall(r"((?:Figure|Table) \d+\.\d+)</span>: ([^<]*)", html)
        assert in_lab and alone == in_lab, (alone, in_lab)
        captions[path.stem] = alone
        text = re.sub(r"<[^>]+>", "", html)
    assert [(n, _html.unescape(c)) for n, c in captions["02_two"]] == [
        ("Table 2.1", "Positions"), ("Figure 2.1", "The arm (the seed's Figure 8.2)")]
    assert "Figure 2.1 and Table 2.1" in text and "Equation (2.1)" in text  # references as in the lab report


# ---------------------------------------------------------------- numbers, messages

def test_check_table_digits_roundoff_and_typo():
    from labkit.reports import Checks

    c = Checks(display=False)
    c.check("T [m]", [0.1234567891, -2.77556e-17], [0.1234567891, 0.0], tol=1e-9)
    c.check("L1 [mm]", 94.00012, 94, tol=0.5)
    c.typo("T06 (sec. 2.2)", [1.0, 2.0], [1.0, 2.0, 3.0], "published with a missing row")
    df = c.to_dataframe()
    # 6 significant digits, the same decimals across a vector and beside the published value; round-off is 0
    assert list(df["reproduced"])[:2] == ["(0.123457, 0.000000)", "94.0001"]
    assert list(df["published / expected"])[:2] == ["(0.123457, 0.000000)", "94.0000"]
    assert list(df["tolerance"]) == ["1.0e-9", "0.50", "typo"] and list(df["max |diff|"])[:2] == ["0", "1.20e-4"]
    assert "nan" not in df.to_string().lower() and "e-17" not in df.to_string()


def test_check_cells_are_printed_by_the_tables_rule():
    """One rule for printed numbers: a check row's cells are labkit.tables.format_value's, not a rule of their own."""
    from labkit.reports import Checks
    from labkit.tables import format_value

    c = Checks(display=False)
    c.check("x [mm]", [0.01200, -0.0016, 0.0], [0.012, -0.0016, 0.0], tol=1e-6)  # not 0.012, -0.0016, 0
    c.check("flag", 1.0, 1.0, tol=0)  # whole numbers (a flag, a count) print as integers
    c.check("count", [3.0, 4.0], [3, 5], tol=0)
    c.check("long", np.arange(10.0) + 0.5, np.arange(10.0) + 0.5, tol=1e-9)
    c.check("missing", float("nan"), 2.0, tol=1.0)
    rows = c.to_dataframe().to_dict(orient="records")
    assert rows[0]["reproduced"] == format_value([0.012, -0.0016, 0.0], digits=6) == "(0.0120000, -0.0016000, 0.0000000)"
    assert (rows[1]["reproduced"], rows[1]["tolerance"], rows[1]["max |diff|"]) == ("1", "0", "0")
    assert (rows[2]["reproduced"], rows[2]["published / expected"], rows[2]["max |diff|"]) == ("(3, 4)", "(3, 5)", "1")
    assert rows[3]["reproduced"] == "(0.50000, 1.50000, 2.50000, 3.50000, 4.50000, 5.50000, 6.50000, 7.50000, ...)"
    assert (rows[4]["reproduced"], rows[4]["published / expected"], rows[4]["max |diff|"]) == ("–", "2.00000", "–")


def test_checks_show_one_table_in_a_notebook(monkeypatch, capsys):
    """In a notebook the rows are shown once, as assert_all's report table (no printed rows before it)."""
    from labkit.reports import _nbtools

    shown = []
    monkeypatch.setattr(_nbtools, "_in_ipython", lambda: True)
    monkeypatch.setattr(_nbtools, "_display_raw", lambda bundle: shown.append(bundle) or True)
    c = _nbtools.Checks("Seed 000: reach")
    c.check("reach [mm]", 274.0, 274, tol=0.5, note="L1 + L2")
    c.typo("a_1 [mm]", 94, 0, note="text says a_1 = L1")
    c.assert_all()
    assert capsys.readouterr().out == ""
    assert len(shown) == 1 and 'class="lk-report-table"' in shown[0]["text/html"]
    assert shown[0]["text/html"].count("<tr>") == 3 and "<caption>Seed 000: reach</caption>" in shown[0]["text/html"]
    assert [r["result"] for r in shown[0][_nbtools.CHECKS_MIME]["rows"]] == ["pass", "published typo"]


def test_the_code_appendix_leaves_out_where_the_build_writes_files():
    """The lab's parameters stay in the appendix; output_dir (the build's "../../reports/..." path) does not."""
    from labkit.reports._document import _chapter
    from labkit.reports._numbering import number_notebooks

    nb = _nb([("md", "# Demo"), ("code", 'output_dir = "../../reports/demo/files"\nport = "sim://"'),
              ("code", '# Parameters\noutput_dir = "/tmp/build/x_files"\nrepeats = 3'), ("code", "x = 1")])
    nb.cells[1].metadata["tags"] = ["parameters"]
    nb.cells[2].metadata["tags"] = ["injected-parameters"]
    chapter = _chapter(0, nb, "demo", number_notebooks([nb]), show_code=False, unresolved=[])
    listing = "\n".join(chapter.code)
    assert "output_dir" not in listing and "reports/" not in listing and "/tmp" not in listing
    assert 'port = "sim://"' in listing and "repeats = 3" in listing and "x = 1" in listing


def test_error_names_the_notebook_one_cell_and_the_line():
    from labkit.reports._execute import _first_error

    nb = _nb([("md", "# x"), ("code", "p = 1"), ("code", "a = 1\nb = 1\n1 / 0", [{
        "output_type": "error", "ename": "ZeroDivisionError", "evalue": "division by zero",
        "traceback": ["\x1b[31m---\x1b[0m", "Cell \x1b[0;32mIn[7], line 3\x1b[0m\n  1 / 0", "ZeroDivisionError"]}])])
    nb.cells[1].metadata["tags"] = ["injected-parameters"]  # papermill's cell is not counted
    index, message = _first_error(nb, "lab.ipynb")
    assert index == 2
    assert message == "lab.ipynb, cell 2, line 3: ZeroDivisionError: division by zero"


def test_papermill_parameter_warnings_are_filtered():
    from labkit.reports._execute import _quiet_papermill

    _quiet_papermill()
    records = []

    class Keep(logging.Handler):
        def emit(self, record):
            records.append(record.getMessage())

    log = logging.getLogger("papermill")
    handler = Keep()
    log.addHandler(handler)
    try:
        log.warning("Unable to parse line 2 'port = \"sim://?a=b\"  # c'.")
        log.warning("Passed unknown parameter: port")
        log.warning("something else")
    finally:
        log.removeHandler(handler)
    assert records == ["something else"]


# ---------------------------------------------------------------- a whole lab, read back

WIDE = ("import pandas as pd\n"
        "wide = pd.DataFrame([[k * 1.23456 + j for j in range(16)] for k in range(4)],\n"
        "                    columns=[f'quantity {j} [mm]' for j in range(16)])\nwide")
LONG_LINE = "print(" + " + ".join(f"'{k:02d}'" for k in range(40)) + ")"


def _lab(root):
    nbformat = require("nbformat")
    lab = root / "demo_lab"
    lab.mkdir(parents=True)
    (lab / "lab.toml").write_text('[lab]\ntitle = "Demo lab report"\ncourse = "ROBO101 Robotics"\n'
                                  'team = "Team 3"\nauthors = ["Ada Lovelace", "Alan Turing"]\ndate = "1 Dec 2026"\n')
    first = nbformat.v4.new_notebook()
    first.cells = [
        nbformat.v4.new_markdown_cell("# Forward kinematics\n\nThe arm is in @fig-arm, its numbers in @tbl-wide; "
                                      "the law is @eq-law and the next chapter's table is @tbl-second.\n\n"
                                      "$$ x = L_1 \\cos q_1 $$ {#eq-law}"),
        nbformat.v4.new_code_cell("output_dir = '.'", metadata={"tags": ["parameters"]}),
        nbformat.v4.new_code_cell("#| label: fig-arm\n#| fig-cap: \"The arm (the seed's Figure 2.1)\"\n"
                                  "import matplotlib.pyplot as plt\nfig, ax = plt.subplots(figsize=(9, 3))\n"
                                  "ax.plot([0, 1], [0, 1])\nplt.show()"),
        nbformat.v4.new_code_cell("#| label: tbl-wide\n#| tbl-cap: \"A table wider than the page (the seed's Table 4)\"\n"
                                  + WIDE),
        nbformat.v4.new_code_cell("import os\nprint('wrote', os.path.abspath('x.csv'))\n" + LONG_LINE),
        nbformat.v4.new_code_cell("from labkit.reports import Checks\nc = Checks()\n"
                                  "c.check('x [m]', [0.1, -2.77556e-17], [0.1, 0.0], tol=1e-9, note='round-off')\n"
                                  "c.typo('T06', [1, 2], [1, 2, 3], 'missing row')\nc.assert_all()"),
    ]
    second = nbformat.v4.new_notebook()
    second.cells = [
        nbformat.v4.new_markdown_cell("# Inverse kinematics\n\nBack to @fig-arm; @tbl-second lists the angles."),
        nbformat.v4.new_code_cell("#| label: tbl-second\n#| tbl-cap: Joint angles\nimport pandas as pd\n"
                                  "pd.DataFrame({'q1 [deg]': [10.0], 'q2 [deg]': [20.0]})"),
    ]
    for name, nb in (("01_fk.ipynb", first), ("02_ik.ipynb", second)):
        nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
        nbformat.write(nb, str(lab / name))
    return lab


def _read_back(pdf):
    """(width, height, text, words, chars) of every page; words with their boxes."""
    pdfplumber = require("pdfplumber")
    with pdfplumber.open(str(pdf)) as doc:
        pages = [(p.width, p.height, p.extract_text() or "", p.extract_words(keep_blank_chars=False), p.chars)
                 for p in doc.pages]
    return pages


def _pieces(word):
    """A word split after its hyphens and underscores ("0-180" -> "0-", "180"): a header may wrap there."""
    return [p for p in re.split(r"(?<=[-_/])(?=.)", word) if p]


def _stacked(words, tokens):
    """True when ``tokens`` appear as words of one table header: each on the same line as the
    previous one or just below it, overlapping its column (a header wrapped at spaces)."""
    def follows(prev, col, w):
        if w["x0"] == prev["x0"] and w["top"] == prev["top"]:
            return True  # the next piece of the same hyphenated word
        same_line = abs(w["top"] - prev["top"]) < 2 and 0 <= w["x0"] - prev["x1"] < 12
        below = 0 < w["top"] - prev["top"] < 30 and w["x0"] < col[1] + 8 and w["x1"] > col[0] - 8
        return same_line or below

    def search(k, prev, col, pool):
        if k == len(tokens):
            return True
        return any(search(k + 1, w, (min(col[0], w["x0"]), max(col[1], w["x1"])), pool)
                   for w in pool if w["text"] == tokens[k] and follows(prev, col, w))

    for k, w in enumerate(words):
        if w["text"] == tokens[0]:
            near = [v for v in words[max(0, k - 400):k + 400] if abs(v["top"] - w["top"]) < 40]
            if search(1, w, (w["x0"], w["x1"]), near):
                return True
    return False


def _assert_report(pdf, html, chapters, tmp_path, title_page):
    pages = _read_back(pdf)
    texts = [t for _, _, t, _, _ in pages]
    whole = "\n".join(texts)
    # nothing outside the page box (a clipped table or code line would run past the right edge)
    for k, (w, h, _, _, chars) in enumerate(pages):
        out = [c["text"] for c in chars if c["x0"] < -0.5 or c["x1"] > w + 0.5 or c["top"] < -0.5 or c["bottom"] > h + 0.5]
        assert not out, f"page {k + 1}: {len(out)} glyphs outside the page: {''.join(out)[:60]}"
    # every column header of every table of the HTML is in the PDF: its words stacked in one column
    words = [{**w, "text": piece} for _, _, _, page_words, _ in pages for w in page_words
             for piece in _pieces(w["text"])]
    body_html = re.sub(r"<(script|style)\b.*?</\1>", "", html, flags=re.S)
    headers = re.findall(r"<th(?:\s[^>]*)?>(.*?)</th>", body_html, re.S)
    assert headers
    for header in headers:
        text = _html.unescape(re.sub(r"<[^>]+>", " ", header)).split()
        if text:
            text = [piece for token in text for piece in _pieces(token)]
            assert _stacked(words, text), f"column header {' '.join(text)[:80]!r} is not in the PDF"
    # Figure / Table numbers: chapter.n, in sequence within each chapter
    for kind in ("Figure", "Table"):
        seen = {}
        for ch, n in re.findall(rf"{kind} (\d+)\.(\d+):", whole):
            seen.setdefault(int(ch), []).append(int(n))
        assert seen, f"no numbered {kind}"
        for ch, numbers in seen.items():
            assert numbers == list(range(1, len(numbers) + 1)), (kind, ch, numbers)
    assert "??" not in whole and "?@" not in whole  # every cross-reference resolved
    # title page and contents: one link per chapter (+ verification, code appendix), titles in order
    flat_pages = [re.sub(r"\s+", "", t) for t in texts]
    assert all(word.replace(" ", "") in flat_pages[0] for word in title_page), title_page
    plain = [re.sub(r"\s+", "", re.sub(r"[`*]", "", c)) for c in chapters]
    positions = [flat_pages[1].find(c) for c in plain]
    assert -1 not in positions and positions == sorted(positions), (plain, flat_pages[1][:300])
    pypdf = require("pypdf")
    toc_page = pypdf.PdfReader(str(pdf)).pages[1]
    links = [a.get_object() for a in toc_page.get("/Annots") or [] if a.get_object().get("/Subtype") == "/Link"]
    assert len(links) == len(chapters) + 2, len(links)
    body = re.sub(r"\s+", "", "\n".join(texts[2:]))
    for k, title in enumerate(plain, start=1):
        assert f"{k}{title}" in body, title  # the chapter heading "k Title"
    # each contents entry ends with a page number: the page that starts with that chapter's heading
    headings = [f"{k}{t}" for k, t in enumerate(plain, start=1)] + [f"{len(plain) + 1}Verification", "ACode"]
    toc = flat_pages[1]
    assert toc.endswith("2")  # the contents page's number in its footer
    starts = [toc.find(h) for h in headings]
    assert -1 not in starts and starts == sorted(starts), (headings, toc)
    for k, heading in enumerate(headings):
        end = starts[k + 1] if k + 1 < len(headings) else len(toc) - 1  # the page's footer: "2"
        page = toc[starts[k] + len(heading):end]
        assert page.isdigit(), (heading, page)
        page = int(page)
        assert 3 <= page <= len(pages) and flat_pages[page - 1].startswith(heading), (heading, page)
        assert [n for n, t in enumerate(flat_pages) if t.startswith(heading)] == [page - 1], heading
    assert not MACHINE_PATH.search(whole) and str(tmp_path) not in html
    return whole


@pytest.mark.slow
def test_lab_report_pdf_html_docx_read_back(tmp_path):
    require("papermill")
    pypdf = require("pypdf")
    from labkit.cli import main

    lab = _lab(tmp_path)
    out = tmp_path / "out" / "demo"
    assert main(["report", str(lab), "-o", str(out), "--to", "pdf,html,docx", "--jobs", "1"]) == 0
    pdf, html_path, docx = (out.with_suffix(s) for s in (".pdf", ".html", ".docx"))
    html = html_path.read_text("utf-8")
    whole = _assert_report(pdf, html, ["Forward kinematics", "Inverse kinematics"], tmp_path,
                           ["Demo lab report", "ROBO101 Robotics", "Team 3", "Ada Lovelace", "1 Dec 2026"])
    # references written out, the verification table closes the report, the code is in the appendix
    prose = re.sub(r"\s+", " ", whole)
    assert "Figure 1.1: The arm (the seed's Figure 2.1)" in prose
    assert "The arm is in Figure 1.1, its numbers in Table 1.1" in prose
    assert "the next chapter's table is Table 2.1" in prose and "Equation (1.1)" in prose
    verification = whole[whole.index("Verification", whole.index("Inverse kinematics", 200)):]
    assert "round-off" in verification and "typo" in verification and "nan" not in verification.lower()
    assert "2.77556e-17" not in whole[:whole.index("The code of every chapter")]  # (the listing has it)
    appendix = whole[whole.rindex("Code"):]
    assert "import pandas as pd" in appendix and "#| label" not in whole
    assert "import pandas as pd" not in whole[:whole.rindex("Code")]  # not in the body by default
    assert "'39'" in re.sub(r"\s+", "", appendix)  # the long line wrapped, not cut
    # A4, fonts embedded
    reader = pypdf.PdfReader(str(pdf))
    w, h = (float(v) for v in reader.pages[0].mediabox[2:])
    assert abs(w - 595) < 2 and abs(h - 842) < 2
    for page in reader.pages:
        for font in (page["/Resources"].get("/Font") or {}).values():
            font = font.get_object()
            desc = (font["/DescendantFonts"][0].get_object() if "/DescendantFonts" in font else font)["/FontDescriptor"]
            assert any(k in desc for k in ("/FontFile", "/FontFile2", "/FontFile3")), font["/BaseFont"]
    # DOCX: the same numbered captions, no machine path
    with zipfile.ZipFile(docx) as z:
        xml = z.read("word/document.xml").decode("utf-8")
        assert any(n.startswith("word/media/") for n in z.namelist())  # the figure is embedded
    assert "<m:oMath" in xml  # the equation is a Word equation, not TeX text
    doc = re.sub(r"<[^>]+>", "", xml)
    assert "Figure 1.1" in doc and "Table 2.1" in doc and "Forward kinematics" in doc
    assert str(tmp_path) not in doc


def test_report_rejects_unknown_formats(tmp_path):
    from labkit.reports import build_report

    lab = tmp_path / "lab"
    lab.mkdir()
    with pytest.raises(LabkitError, match="--to expects some of pdf, html, docx, got odt"):
        build_report(lab, to=["odt"])


def test_lab_info_and_labkit_new_writes_it(tmp_path):
    from labkit.reports import LabInfo, lab_info, write_lab_info

    write_lab_info(tmp_path, LabInfo(title='The "arm" lab', course="ROBO 1", authors=("A", "B")))
    info = lab_info(tmp_path)
    assert info.title == 'The "arm" lab' and info.authors == ("A", "B") and info.course == "ROBO 1"
    from labkit.labs import new_lab

    made = new_lab("puma560", tmp_path / "puma", title="PUMA lab")
    assert lab_info(made.folder).title == "PUMA lab" and (made.folder / "lab.toml").is_file()
    for lab in sorted((REPO / "notebooks").iterdir()):
        if any(lab.glob("*.ipynb")):
            seed = lab_info(lab)
            assert (lab / "lab.toml").is_file() and seed.course and seed.authors, lab.name


@pytest.mark.parametrize("path", sorted((REPO / "notebooks").glob("*/*.ipynb"))
                         + sorted((REPO / "labkit" / "labs" / "templates").glob("*.ipynb")),
                         ids=lambda p: f"{p.parent.name}/{p.name}")
def test_every_lab_notebook_has_captions_and_resolved_references(path):
    nbformat = require("nbformat")
    from labkit.reports._numbering import REFERENCE, number_notebooks

    nb = nbformat.read(str(path), as_version=4)
    labels = number_notebooks([nb])["local"][0]
    assert any(lab.kind == "fig" for lab in labels.values()) or any(lab.kind == "tbl" for lab in labels.values())
    assert all(lab.caption for lab in labels.values() if lab.kind in ("fig", "tbl")), "every figure/table has a caption"
    refs = [m.group("label") or m.group("linked") for c in nb.cells if c.cell_type == "markdown"
            for m in REFERENCE.finditer(c.source)]
    assert refs and all(r in labels for r in refs), [r for r in refs if r not in labels]
    # what JupyterLab would show as raw text: Quarto's @fig-x references and {#eq-x} / {#sec-x} attributes
    raw = [m.group(0) for c in nb.cells if c.cell_type == "markdown"
           for m in re.finditer(r"\{#(?:eq|sec)-[\w-]+\}|(?<![\w@/.#\[(])@(?:fig|tbl|eq|sec)-[\w-]+", c.source)]
    assert raw == [], f"label syntax a live notebook shows as text: {raw}"
    # a table a cell shows is a report table: no DataFrame left as a cell's value without report_table
    raw_tables = []
    for c in nb.cells:
        if c.cell_type != "code":
            continue
        try:
            tree = ast.parse("\n".join(line for line in c.source.splitlines() if not line.startswith(("%", "!"))))
        except SyntaxError:
            continue
        shown = [s.value for s in tree.body[-1:] if isinstance(s, ast.Expr)]
        shown += [a for s in tree.body for n in ast.walk(s) if isinstance(n, ast.Call)
                  and getattr(n.func, "id", "") == "display" for a in n.args]
        for e in shown:
            names = {getattr(n, "id", None) or getattr(n, "attr", None) for n in ast.walk(e)}
            if "DataFrame" in names and not names & {"report_table", "error_report_table"}:
                raw_tables.append(c.get("id"))
    assert raw_tables == [], f"cells that show a DataFrame as pandas prints it: {raw_tables}"
    # a caption that names a seed table or figure says so ("the seed's Table 4")
    for lab in labels.values():
        if re.search(r"\b(Table|Figure)s? \d", lab.caption):
            assert re.search(r"seed", lab.caption), lab.caption


@pytest.mark.slow
@pytest.mark.notebooks
def test_seed000_lab_report(tmp_path):
    """The acceptance run: the seed000 lab as one PDF, read back like the small lab above."""
    require("papermill")
    from labkit.reports import build_report

    lab = REPO / "notebooks" / "seed000_arduino_arm"
    res = build_report(lab, tmp_path / "seed000", to=["pdf", "html"], progress=None)
    assert res.ok, (res.errors, res.warnings)
    pdf, html = res.files["pdf"], res.files["html"].read_text("utf-8")
    assert pdf.stat().st_size <= 3_000_000, pdf.stat().st_size
    _assert_report(pdf, html, list(res.chapters), tmp_path, ["ELEC0129", "Team 6", "Nandini Chavda"])
