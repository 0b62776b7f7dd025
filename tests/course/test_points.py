"""Points (issue 37, items 4 and 5): free rows, derivation rows and their groups, one maximum everywhere.

The fast tests score the checker's verdicts as a submission of each kind would get them (no kernel);
the slow one grades the derivation lab for real, with a submission that fakes ``q`` and the steps.
"""

import copy
import re
import shutil
from pathlib import Path

import pytest

from conftest import require
from tests.course import course_lab as cl

ROOT = Path(__file__).resolve().parents[2]
SEED004 = ROOT / "notebooks" / "seed004_planar3r_ik"


def _plans(nb, name):
    from labkit.course import graded_cells
    from labkit.course._plan import plan_check

    texts = {str(c.get("id")): c.source for c in nb.cells}
    return {chk.cell_id: plan_check(texts[chk.cell_id], chk.cell_id, chk.name) for chk in graded_cells(nb, name)}


def _score(nb, name, passed, untouched):
    """Total points and the CellScores for per-row verdicts ``{(cell id, row): bool}`` (missing rows fail)."""
    from labkit.course._points import score_notebook

    results = {cid: [{"passed": passed.get((cid, r.index), False), "error": "", "line": r.line} for r in plan.rows]
               for cid, plan in _plans(nb, name).items()}
    scores = score_notebook(nb, name, results, {(name, cid): {i for c, i in untouched if c == cid}
                                                for cid, _ in untouched})
    return round(sum(s.points for s in scores), 9), scores


@pytest.fixture(scope="module")
def ik_lab(tmp_path_factory):
    nbformat = require("nbformat")
    lab = cl.write_ik_lab(tmp_path_factory.mktemp("ik") / "lab")
    return lab, nbformat.read(str(lab / cl.IK_NOTEBOOK), as_version=4)


def test_a_derivation_row_counts_and_gates_its_group(ik_lab):
    """FK(q) - target passes untouched but proves the q the steps are compared with: it is not free; a fake q
    fails it and voids every row that rests on q (the hidden wrist row too, through frames = fk_frames(arm, q))."""
    from labkit.course._points import link_rows, row_values

    _, nb = ik_lab
    values = row_values(nb, _plans(nb, cl.IK_NOTEBOOK))
    assert values[("public", 1)] == {"q", "arm"}  # xe, ye, phie: the trusted parameters cell, never linked
    assert {"frames", "q", "x3", "y3"} <= values[("hidden", 0)]  # frames is a value of q (the lab's own cell)
    untouched = {("public", 1)}
    links = link_rows(values, untouched)
    assert links.derivations == {("public", 1)} and not links.free
    verdicts = {  # what the checker says on each row, per kind of submission
        "honest": {("public", 0): True, ("public", 1): True, ("hidden", 0): True},
        "untouched": {("public", 1): True},
        "faked": {("public", 0): True, ("hidden", 0): True},  # q = 0, steps = 0: FK(q) misses the target
        "half_done": {("public", 1): True, ("hidden", 0): True},  # the wrist point, then the stub
    }
    points = {k: _score(nb, cl.IK_NOTEBOOK, v, untouched) for k, v in verdicts.items()}
    assert {k: p for k, (p, _) in points.items()} == {"honest": 3, "untouched": 0, "faked": 0, "half_done": 1}
    assert {sum(s.max_points for s in scores) for _, scores in points.values()} == {3}
    faked = {r.name: r for s in points["faked"][1] for r in s.rows}
    assert not faked["steps (t1, t2, t3) - the lab's IK [rad]"].passed
    assert "earns nothing" in faked["wrist point (x3, y3) [m]"].error
    half = {r.name: r for s in points["half_done"][1] for r in s.rows}
    assert "earns its share only with the rows it backs" in half["FK(q) - target"].error


def test_seed004_checks_rest_on_trusted_values_and_without_them_the_rule_still_holds():
    """Seed 004 reads q, arm, the target and frames_ref from its reference and parameters cells: no row links
    through them, none of its free rows is a derivation row and the maximum stays 5. Written the first way (no
    reference cell, the lab's own q and frames in the kernel), q_handout's row proves q, and a fake q (steps
    faked to agree) earns nothing more than the untouched version."""
    nbformat = require("nbformat")
    from labkit.course._points import link_rows, row_values

    name = "01_ik_elbow_minus.ipynb"
    nb = nbformat.read(str(SEED004 / name), as_version=4)
    values = row_values(nb, _plans(nb, name))
    assert not set().union(*values.values()) & {"q", "arm", "frames_ref", "xe", "ye", "phie"}
    public, hidden = "01_ik_elbow_minus-10", "01_ik_elbow_minus-11"
    untouched = {(public, 2), (public, 3), (public, 4)}  # q_handout, T_other, tips_drawn: the lab's own values
    links = link_rows(values, untouched)
    assert links.free == untouched and not links.derivations
    honest = {k: True for k in values}
    assert _score(nb, name, honest, untouched)[0] == 5  # 3 public on 2 counted rows, 2 hidden

    naive = copy.deepcopy(nb)  # the lab as first written: no reference cell, the checks read the kernel's values
    naive.cells = [c for c in naive.cells if "reference" not in c.get("metadata", {}).get("tags", [])]
    for c in naive.cells:
        c.source = c.source.replace("frames_ref[2", "frames[2")
    values = row_values(naive, _plans(naive, name))
    assert {"q", "arm"} <= values[(public, 2)] and "frames" in values[(hidden, 0)]
    links = link_rows(values, untouched)
    assert links.derivations == {(public, 2)}, links
    # faked: q = 0, the target moved (trusted: no effect), trivial steps that agree with q and the lab's frames of it
    faked = {(public, 1): True, (public, 3): True, (public, 4): True,
             (hidden, 0): True, (hidden, 1): True, (hidden, 2): True, (hidden, 3): True}
    untouched_points = _score(naive, name, {k: True for k in untouched}, untouched)[0]
    assert _score(naive, name, faked, untouched)[0] <= untouched_points == 0
    assert _score(naive, name, honest, untouched)[0] == 5


@pytest.mark.slow
@pytest.mark.xdist_group("grading-loop")  # beside the attack batches (tests/course/test_attacks.py says why)
def test_faking_q_and_the_steps_earns_no_more_than_untouched(ik_lab, tmp_path):
    """Graded for real (sandbox, checker, baseline): the derivation lab's faked submission scores what the untouched
    one scores (0), honest work 3 / 3, the half-done one keeps the hidden row it earned; one maximum everywhere."""
    require("nbgrader")
    from labkit.course import Limits, assign, grade

    lab, _ = ik_lab
    student = tmp_path / "student"
    assign(lab, student)
    subs = tmp_path / "subs"
    codes = {"honest": cl.IK_SOLUTION, "faked": cl.IK_FAKED, "half_done": cl.IK_HALF_DONE}
    nbformat = require("nbformat")
    for name, code in codes.items():
        nb = nbformat.read(str(student / cl.IK_NOTEBOOK), as_version=4)
        next(c for c in nb.cells if c.get("id") == "steps").source = code
        (subs / name).mkdir(parents=True)
        nbformat.write(nb, str(subs / name / cl.IK_NOTEBOOK))
    shutil.copytree(student, subs / "untouched")
    limits = Limits(cpu_seconds=20, memory_bytes=2 * 2**30, wall_seconds=90)
    results = {r.student: r for r in grade(subs, lab, tmp_path / "fb", limits=limits, jobs=2, progress=False)}
    points = {k: r.points for k, r in results.items()}
    assert points == {"honest": 3, "untouched": 0, "faked": 0, "half_done": 1}, {k: r.detail for k, r in results.items()}
    assert {r.max_points for r in results.values()} == {3}
    assert "earns nothing" in results["faked"].detail and "FK(q) - target" in results["faked"].detail
    page = (tmp_path / "fb" / "students" / "faked" / "index.html").read_text()
    assert re.search(r"Score <b>0 / 3</b>", page), page[:500]


def test_no_gradebook_column_for_a_check_without_student_work():
    """Seed 004's 02 notebook checks labkit only: every row passes untouched, so its check is worth 0 and has no
    gradebook column, while 01's checks (student work) have theirs (scored by the grading's own rules, no kernel)."""
    nbformat = require("nbformat")
    require("pandas")
    from labkit.course import SubmissionResult, gradebook_frame
    from labkit.course._points import score_notebook

    names = ("01_ik_elbow_minus.ipynb", "02_arc_trajectory_animation.ipynb")
    nbs = {n: nbformat.read(str(SEED004 / n), as_version=4) for n in names}
    plans = {n: _plans(nb, n) for n, nb in nbs.items()}
    untouched = {(n, cid): {r.index for r in p.rows} for n in names[1:] for cid, p in plans[n].items()}
    untouched[(names[0], "01_ik_elbow_minus-10")] = {2, 3, 4}
    results = []
    for student, passing in (("solved", True), ("untouched", False)):
        scores = []
        for n, nb in nbs.items():
            verdicts = {cid: [{"passed": passing or r.index in untouched.get((n, cid), ()), "error": "", "line": r.line}
                              for r in p.rows] for cid, p in plans[n].items()}
            scores += score_notebook(nb, n, verdicts, untouched, plans[n])
        results.append(SubmissionResult(student, "ok", "", tuple(scores), 1.0))
    frame = gradebook_frame(results)
    checks = [c for c in frame.columns if ".ipynb: " in c]
    assert checks == ["01_ik_elbow_minus.ipynb: A.4 and part B checks (public)", "01_ik_elbow_minus.ipynb: A.2 steps (hidden)"]
    assert list(frame["points"]) == [5, 0] and list(frame["max_points"]) == [5, 5]


def test_a_failing_row_names_the_values_it_read():
    """The detail of a failing row names the submission's values it compared (``t3 = 3.24``), not only a difference."""
    from labkit.course._checker import check_cell
    from labkit.course._plan import plan_check
    from labkit.reports import Checks

    plan = plan_check('assert t3 < 0\nchecks.check("q", q, [0.1, 0.2, 0.3], tol=1e-12)', "c", "steps")
    rows = check_cell(plan, {"t3": 3.24, "q": [0.0, 0.0, 0.0]}, {"checks": Checks("x", display=False)})
    assert [r["passed"] for r in rows] == [False, False]
    assert rows[0]["error"] == "AssertionError (no message) (t3 = 3.24)", rows[0]
    assert rows[1]["error"].startswith("q: max |diff| 0.300 > tol 1.0e-12 (q = [0"), rows[1]


def test_the_gradebook_writer_makes_every_text_cell_inert(tmp_path):
    """write_gradebook on its own: text columns (pandas 3 makes them "str", not object) lose their control characters
    and a leading ``=``, ``+``, ``-``, ``@`` is quoted, in the CSV and the Excel file; numbers stay numbers."""
    pd = require("pandas")
    openpyxl = require("openpyxl")
    import csv

    from labkit.course import write_gradebook

    frame = pd.DataFrame({"student": ["a", "b"], "status": ["ok", "=1+2"], "points": [1.0, -2.0],
                          "detail": ["-2+3 \x1b[31mred\x07", "@SUM(A1)\x00"]}).set_index("student")
    write_gradebook(frame, tmp_path / "g.csv")
    with open(tmp_path / "g.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert [(r["status"], r["detail"], float(r["points"])) for r in rows] == [
        ("ok", "'-2+3 red", 1.0), ("'=1+2", "'@SUM(A1)", -2.0)], rows
    sheet = openpyxl.load_workbook(tmp_path / "g.xlsx").active
    assert [[c.value for c in row] for row in sheet.iter_rows(min_row=2)] == [
        ["a", "ok", 1, "'-2+3 red"], ["b", "'=1+2", -2, "'@SUM(A1)"]]
