"""The seed lab reports as a course would receive them, read back from the PDF and the HTML.

Every page carries text (at least 25 words) unless a figure or a table fills it (the title
page, the contents and the last page are what they are); no report table prints ``NaN``,
``True``/``False`` or a pandas index column.
"""

import html as _html
import re
from pathlib import Path

import pytest

from conftest import require

REPO = Path(__file__).resolve().parents[2]
SEED_LABS = sorted(p.name for p in (REPO / "notebooks").iterdir() if (p / "lab.toml").is_file())
MIN_WORDS = 25
#: a figure or table that covers this share of the text area fills the page
FULL_PAGE = 0.45
_RAW = re.compile(r"^(?:NaN|nan|None|True|False|<NA>|NaT)$")


def sparse_pages(pdf):
    """Pages (1-based) with fewer than MIN_WORDS words that no figure or table fills, with their text."""
    pdfplumber = require("pdfplumber")
    out = []
    with pdfplumber.open(str(pdf)) as doc:
        for k, page in enumerate(doc.pages, start=1):
            words = page.extract_words()
            text = page.extract_text() or ""
            # the title page, the contents and the document's last page end where they end
            if k in (1, len(doc.pages)) or text.startswith("Contents") or len(words) >= MIN_WORDS:
                continue
            area = page.width * page.height
            covered = sum((im["x1"] - im["x0"]) * (im["bottom"] - im["top"]) for im in page.images)
            rules = [r for r in page.rects + page.lines if r["x1"] - r["x0"] > 0.3 * page.width]
            table_height = (max(r["bottom"] for r in rules) - min(r["top"] for r in rules)) if len(rules) >= 2 else 0
            if covered < FULL_PAGE * area and table_height * page.width < FULL_PAGE * area:
                out.append((k, " ".join(w["text"] for w in words)))
    return out


def table_problems(html):
    """Report tables in ``html`` that print a raw value (NaN, True, ...) or a pandas index column."""
    body = re.sub(r"<(script|style)\b.*?</\1>", "", html, flags=re.S)
    body = re.sub(r'<section class="lk-appendix".*?</section>', "", body, flags=re.S)
    problems = []
    for k, table in enumerate(re.findall(r"<table\b.*?</table>", body, flags=re.S), start=1):
        cells = [_html.unescape(re.sub(r"<[^>]+>", "", c)).strip()
                 for c in re.findall(r"<t[dh]\b[^>]*>(.*?)</t[dh]>", table, flags=re.S)]
        raw = sorted({c for c in cells if _RAW.match(c)})
        if raw:
            problems.append(f"table {k}: {', '.join(raw)}")
        rows = re.findall(r"<tbody>(.*?)</tbody>", table, flags=re.S)
        first = [_html.unescape(re.sub(r"<[^>]+>", "", m)).strip()
                 for m in re.findall(r"<tr[^>]*>\s*<t[hd]\b[^>]*>(.*?)</t[hd]>", rows[0] if rows else "", flags=re.S)]
        if len(first) >= 2 and first == [str(i) for i in range(len(first))]:
            problems.append(f"table {k}: a pandas index column 0..{len(first) - 1}")
    return problems


_REPR = re.compile(r"\b(?:array\(|np\.float64\(|Comparison\(|<pandas\.|DataFrame\()|\[ *-?\d+\. +-?\d")


def raw_reprs(html):
    """Python reprs printed in the body of a report (outside the code appendix): numpy arrays, objects."""
    body = re.sub(r"<(script|style)\b.*?</\1>", "", html, flags=re.S)
    body = re.sub(r'<section class="lk-appendix".*?</section>', "", body, flags=re.S)
    text = _html.unescape(re.sub(r"<[^>]+>", " ", body))
    return sorted({m.group(0) for m in _REPR.finditer(text)})


def test_the_checks_find_what_they_look_for():
    index_table = ("<table><thead><tr><th></th><th>x</th></tr></thead><tbody><tr><th>0</th><td>1.0</td></tr>"
                   "<tr><th>1</th><td>NaN</td></tr></tbody></table>")
    assert table_problems(index_table) == ["table 1: NaN", "table 1: a pandas index column 0..1"]
    import pandas as pd

    from labkit.reports import report_table

    good = report_table(pd.DataFrame({"x": [1.0, None], "ok": [True, False]})).to_html()
    assert table_problems(good) == []
    code = '<section class="lk-appendix"><table><tr><td>True</td></tr></table></section>'
    assert table_problems(code) == []
    assert raw_reprs("<pre>FK at q = 0 [mm]: [274.   0.   0.]</pre><p>Comparison(name='x')</p>") == ["Comparison(", "[274.   0"]
    assert raw_reprs('<p>(274.0, 0.0, 0.0) mm</p><section class="lk-appendix">array([1.])</section>') == []


@pytest.mark.slow
@pytest.mark.notebooks
@pytest.mark.parametrize("lab", SEED_LABS)
def test_seed_report_pages_and_tables(lab, tmp_path):
    require("papermill")
    from labkit.reports import build_report

    res = build_report(REPO / "notebooks" / lab, tmp_path / lab, to=["pdf", "html"], progress=None)
    assert res.ok, (res.errors, res.warnings)
    assert sparse_pages(res.files["pdf"]) == []
    html = res.files["html"].read_text("utf-8")
    assert table_problems(html) == []
    assert raw_reprs(html) == []
