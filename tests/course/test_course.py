"""A course's loop: labkit assign -> simulated submissions -> labkit grade (sandboxed), locally (on dask:
tests/course/test_dask.py)."""

import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import time
from pathlib import Path

import pytest

from tests.course import course_lab as cl
from conftest import require
from labkit.exceptions import LabkitError

# the course loop's grading tests: one xdist group, beside the attack batches' (tests/course/test_attacks.py says why)
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("grading-loop")]
REMOTE = re.compile(r"""<(?:script|link|img)\b[^>]*\b(?:src|href)\s*=\s*["']?(?:https?:)?//""", re.IGNORECASE)
LIMITS = dict(cpu_seconds=4, memory_bytes=2 * 2**30, wall_seconds=120)


def tags(cell):
    return cell.get("metadata", {}).get("tags", [])


@pytest.fixture
def course(tmp_path):
    """The instructor's lab and its student version (written by the CLI)."""
    require("nbgrader")
    from labkit.cli import main

    lab = cl.write_lab(tmp_path / "lab")
    assert main(["assign", str(lab), str(tmp_path / "student"), "--no-baseline"]) == 0
    return lab, tmp_path / "student"


def test_assign_writes_the_student_version(course):
    nbformat = require("nbformat")
    lab, student = course
    text = (student / cl.NOTEBOOK).read_text()
    assert "SECRET-HIDDEN-MARKER" not in text and "SECRET-HIDDEN-MARKER" in (lab / cl.NOTEBOOK).read_text()
    assert (student / "data.txt").read_text() == "lab data\n"
    source, nb = (nbformat.read(str(p / cl.NOTEBOOK), as_version=4) for p in (lab, student))
    by_id = {c.id: c for c in nb.cells}
    assert [c.id for c in nb.cells] == [c.id for c in source.cells if "hidden-tests" not in tags(c)]
    work = by_id["work"].source
    assert work.startswith("# Hint: labkit.kinematics.fk") and "raise NotImplementedError()" in work
    assert "T = fk(arm, q)" not in work
    assert by_id["params"].source == source.cells[1].source and tags(by_id["params"]) == ["parameters"]
    assert by_id["public"].source == source.cells[4].source
    assert by_id["public"].metadata["editable"] is False and by_id["public"].metadata["deletable"] is False
    assert all(not c.get("outputs") for c in nb.cells if c.cell_type == "code")


DOCS = Path(__file__).resolve().parents[2] / "docs" / "course.md"


def _words(text):
    return " ".join(text.split())


def test_one_maximum_in_assign_grade_gradebook_feedback_and_docs(tmp_path, capsys):
    """labkit assign grades the untouched student version and says which rows pass without work, and why; the maximum
    it prints is the one labkit grade prints, the gradebook's max_points, every feedback page's and the docs' (issue 37)."""
    require("nbgrader")
    pd = require("pandas")
    from labkit.cli import main

    lab = cl.write_lab(tmp_path / "lab")
    student = tmp_path / "student"
    assert main(["assign", str(lab), str(student)]) == 0
    out = capsys.readouterr().out
    assert "passes 1 check row(s)" in out and "free: 01_fk.ipynb: x is a number, on sim://" in out, out
    assert "assertion 2" in out
    summary = out.splitlines()[1]
    maximum = float(re.search(r"can earn at most ([\d.]+) points \(of the ([\d.]+) the checks declare", summary)[1])
    assert maximum == 4
    assert _words(summary) in _words(DOCS.read_text()), "docs/course.md shows another labkit assign output"
    subs = tmp_path / "subs"
    cl.write_submission(student, subs / "correct", cl.SOLUTION)
    shutil.copytree(student, subs / "untouched")
    gradebook = tmp_path / "g.csv"
    assert main(["grade", str(subs), "--lab", str(lab), "-o", str(gradebook), "--cpu", "10", "--memory", "2",
                 "--wall", "60"]) == 0
    out = capsys.readouterr().out
    assert f"mean 2.00 / {maximum:g} points" in out, out
    table = pd.read_csv(gradebook, index_col="student")
    assert set(table["max_points"]) == {maximum} and table.loc["correct", "points"] == maximum
    assert table.loc["untouched", "points"] == 0
    for name in ("correct", "untouched"):
        page = (tmp_path / "g_feedback" / "students" / name / "index.html").read_text()
        assert re.search(rf"Score <b>[\d.]+ / {maximum:g}</b>", page), page[:400]
    assert f"{table.loc['correct', 'points']:g} / {maximum:g}" in (tmp_path / "g_feedback" / "index.html").read_text()


def test_assign_rejects_bad_tags(tmp_path):
    nbformat = require("nbformat")
    from labkit.course import assign

    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell("x = 1", metadata={"tags": ["solution", "tests"]})])
    (tmp_path / "lab").mkdir()
    nbformat.write(nb, str(tmp_path / "lab" / "a.ipynb"))
    with pytest.raises(LabkitError, match="expected at most one of"):
        assign(tmp_path / "lab", tmp_path / "out")
    with pytest.raises(LabkitError, match="found none"):
        assign(tmp_path / "out_missing", tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_graded_notebook_restores_deleted_and_edited_checks(course):
    nbformat = require("nbformat")
    from labkit.course import graded_notebook

    lab, student = course
    source, nb = (nbformat.read(str(p / cl.NOTEBOOK), as_version=4) for p in (lab, student))
    nb.cells = [c for c in nb.cells if c.id != "public"]  # the student deleted the public check
    nb.cells.append(nbformat.v4.new_code_cell("pass", metadata={"tags": ["tests"]}))  # and added a fake one
    merged = graded_notebook(source, nb)
    ids = [c.id for c in merged.cells]
    assert ids.index("work") < ids.index("public") < ids.index("hidden-x") < ids.index("hidden-y") < ids.index("end")
    assert merged.cells[ids.index("hidden-x")].source == cl.HIDDEN_1
    assert sum("tests" in tags(c) or "hidden-tests" in tags(c) for c in merged.cells) == 3


def make_submissions(student, folder, lab):
    for name, code in cl.SUBMISSIONS.items():
        cl.write_submission(student, folder / name, code)
    shutil.copytree(student, folder / "untouched")
    (folder / "correct" / "private_notes.txt").write_text("only mine")


def test_round_trip_grade_on_the_local_pool(course, tmp_path):
    """Assign -> five submissions -> grade (CLI, local pool): scores, failure kinds, gradebook, feedback pages."""
    require("openpyxl")
    pd = require("pandas")
    from labkit.cli import main
    from labkit.course import Limits

    lab, student = course
    subs = tmp_path / "submissions"
    make_submissions(student, subs, lab)
    gradebook = tmp_path / "grades" / "gradebook.csv"
    argv = ["grade", str(subs), "--lab", str(lab), "-o", str(gradebook), "--jobs", "2",
            "--cpu", str(LIMITS["cpu_seconds"]), "--memory", "2", "--wall", str(LIMITS["wall_seconds"])]
    assert Limits(**LIMITS).memory_bytes == 2 * 2**30
    assert main(argv) == 0
    table = pd.read_csv(gradebook, index_col="student")
    excel = pd.read_excel(gradebook.with_suffix(".xlsx"), index_col="student")
    expected = dict(cl.EXPECTED, untouched=(0, "error"))  # its free row ("on sim://") is worth nothing
    assert list(excel.index) == list(table.index) == sorted(expected)
    for name, (points, status) in expected.items():
        assert (table.loc[name, "points"], table.loc[name, "status"]) == (points, status), name
        assert excel.loc[name, "points"] == points
    assert table.loc["correct", "max_points"] == 4
    assert table.loc["partly_wrong", "01_fk.ipynb: x value (hidden)"] == 0
    assert table.loc["partly_wrong", "01_fk.ipynb: x is a number, on sim://"] == 1
    assert "CPU-time limit" in table.loc["infinite_loop", "detail"]

    assert "NotImplementedError" not in table.loc["raising", "detail"]
    assert "ValueError: I gave up in cell 4 (id work), line 1" in table.loc["raising", "detail"]  # as the student counts

    feedback = tmp_path / "grades" / "gradebook_feedback"
    assert "correct/index.html" in (feedback / "index.html").read_text()
    for name in cl.EXPECTED:
        page = (feedback / "students" / name / "index.html").read_text()
        assert REMOTE.search(page) is None and "Score" in page and len(page.encode()) < 2**20
        assert "SECRET-HIDDEN-MARKER" not in page and "fk(arm, q)[0, 3]" not in page  # hidden: names and results
        assert "tool y [m]" in page and "x value" in page
    assert not any(p.name == "private_notes.txt" for p in feedback.rglob("*"))


def test_run_tasks_local_pool_keeps_input_order():
    from labkit.course import run_tasks

    assert run_tasks(json.dumps, [([i],) for i in range(5)], jobs=2, progress=False) == [f"[{i}]" for i in range(5)]
    with pytest.raises(LabkitError, match="jobs >= 1"):
        run_tasks(json.dumps, [(1,)], jobs=0, progress=False)


def test_the_driver_holds_no_submissions_files(tmp_path, monkeypatch):
    """On the local pool each grading task gets its submission's folder, not its files: the driver's memory does not
    grow with the class (50 MiB per submission allowed); over a cap, the worker gives the "invalid" row."""
    require("nbgrader")
    from labkit.course import Limits, _batch, grade

    lab = cl.write_lab(tmp_path / "lab")
    subs = tmp_path / "subs"
    for name in ("a", "b"):
        cl.write_submission(lab, subs / name, cl.SOLUTION)
    (subs / "b" / "data.bin").write_bytes(b"\0" * 2**20)
    seen = []

    def run_tasks(fn, argsets, **kw):
        seen.extend(argsets)
        return [_batch._failed(a[0], a[2], {}, "crash", "not run") for a in argsets]

    monkeypatch.setattr(_batch, "run_tasks", run_tasks)
    grade(subs, lab, tmp_path / "fb", limits=Limits(sandbox=False), count_free=True, html=False, progress=False)
    assert [(a[0], a[1]) for a in seen] == [("a", str(subs / "a")), ("b", str(subs / "b"))]
    monkeypatch.setattr(_batch, "MAX_ENTRIES", 1)  # b holds two files
    row = _batch._grade_task("b", str(subs / "b"), seen[0][2], Limits(sandbox=False), False, {})
    assert row.status == "invalid" and "files and folders" in row.detail, row


def test_a_worker_that_dies_loses_only_its_own_task():
    """A task that kills its worker process (as the OOM killer or a crash in C would) breaks the local pool: the
    tasks it took down with it are run again one at a time, and only the one that kills its pool alone is lost
    (``on_lost`` gives its result: labkit grade's row for that student); without ``on_lost`` the batch stops with a
    LabkitError naming the task."""
    from tests.course import attacks as at
    from labkit.course import run_tasks

    argsets = [(i, i == 2) for i in range(5)]
    results = run_tasks(at.task_dies_on, argsets, jobs=2, progress=False, on_lost=lambda i, why: ("lost", i, why))
    assert results[:2] + results[3:] == [0, 1, 3, 4], results
    assert results[2][:2] == ("lost", 2) and "worker process died" in results[2][2], results[2]
    with pytest.raises(LabkitError, match="task 1 of 'tasks' .*was lost"):
        run_tasks(at.task_dies_on, [(0, False), (1, True)], jobs=1, progress=False)


def test_seed004_is_a_worked_assignment(tmp_path):
    """The worked example: seed 004's lab tagged; its student version keeps hints and checks, not answers."""
    nbformat = require("nbformat")
    from labkit.course import assign, graded_cells

    lab = Path(__file__).resolve().parents[2] / "notebooks" / "seed004_planar3r_ik"
    result = assign(lab, tmp_path / "student")
    assert [c.hidden for c in result.checks] == [False, True, False, False]
    assert sum(c.points for c in result.checks) == 9
    student = nbformat.read(str(tmp_path / "student" / "01_ik_elbow_minus.ipynb"), as_version=4)
    text = "\n".join(c.source for c in student.cells)
    assert "np.linalg.solve(M, [x3, y3])" not in text and "Hidden checks" not in text
    assert "# Hint: step 1 joint 3" in text and "raise NotImplementedError()" in text
    original = nbformat.read(str(lab / "01_ik_elbow_minus.ipynb"), as_version=4)
    assert "np.linalg.solve(M, [x3, y3])" in "\n".join(c.source for c in original.cells)
    assert graded_cells(original)[1].name == "A.2 steps"
    assert [c.id for c in student.cells] == [c.id for c in original.cells
                                             if not {"hidden-tests", "reference"} & set(tags(c))]
    assert "frames_ref = " not in text  # the reference cell (issue 37) is the checker's only


@pytest.mark.parametrize("sandbox", [True, False])
def test_run_untrusted_wall_clock_limit(tmp_path, sandbox):
    """A kernel that sleeps (no CPU used) is stopped at the wall-clock limit; without the sandbox too."""
    nbformat = require("nbformat")
    from labkit.course import Limits, run_untrusted

    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell("import os\nprint(os.getcwd())"),
                                         nbformat.v4.new_code_cell("import time\ntime.sleep(120)")])
    t0 = time.monotonic()
    status, detail, _ = run_untrusted(nb, tmp_path, limits=Limits(cpu_seconds=10, memory_bytes=2 * 2**30,
                                                                  wall_seconds=8, sandbox=sandbox))
    assert (status, time.monotonic() - t0 < 60) == ("timeout", True), detail
    from labkit.course import SANDBOX_HOME

    assert nb.cells[0].outputs[0]["text"].strip() == (SANDBOX_HOME if sandbox else str(tmp_path.resolve()))


def test_grade_cli_rejects_a_missing_folder(tmp_path, capsys):
    from labkit.cli import main

    cl.write_lab(tmp_path / "lab")
    assert main(["grade", str(tmp_path / "nope"), "--lab", str(tmp_path / "lab"), "-o", str(tmp_path / "g.csv")]) == 2
    assert "expected one folder per student" in capsys.readouterr().err
    with pytest.raises(LabkitError, match="expected cpu_seconds > 0"):
        from labkit.course import Limits

        Limits(cpu_seconds=0)


def test_sandbox_shows_only_python_labkit_and_its_own_copy(tmp_path, monkeypatch):
    """Allow-list: a folder on PYTHONPATH (not labkit's) and any file beside it stay invisible; labkit imports,
    read-only; the kernel's home is its own copy at /home/student."""
    nbformat = require("nbformat")
    from labkit.course import SANDBOX_HOME, Limits, run_untrusted

    pkg_root = tmp_path / "site"
    (pkg_root / "probe_pkg").mkdir(parents=True)
    (pkg_root / "probe_pkg" / "__init__.py").write_text("VALUE = 42\n")
    (pkg_root / "solutions.txt").write_text("x = 1\n")
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(pkg_root), os.environ.get("PYTHONPATH", "")]))
    work = tmp_path / "work"
    work.mkdir()
    (work / "mine.txt").write_text("mine")
    nb = nbformat.v4.new_notebook(cells=[
        nbformat.v4.new_code_cell("import labkit, os\nprint(labkit.__name__, os.getcwd(), os.listdir('.'))"),
        nbformat.v4.new_code_cell(f"print(os.path.exists({str(pkg_root)!r}), os.path.exists({str(tmp_path)!r}))"),
        nbformat.v4.new_code_cell("import probe_pkg"),
        nbformat.v4.new_code_cell("open(os.path.join(os.path.dirname(labkit.__file__), 'x.py'), 'w')"),
    ])
    status, detail, _ = run_untrusted(nb, work, limits=Limits(cpu_seconds=30, memory_bytes=2 * 2**30, wall_seconds=60))
    assert nb.cells[0].outputs[0]["text"].strip() == f"labkit {SANDBOX_HOME} ['mine.txt']", nb.cells[0].outputs
    assert nb.cells[1].outputs[0]["text"].strip() == "False False"
    assert nb.cells[2].outputs[0]["ename"] == "ModuleNotFoundError"
    assert "Read-only file system" in str(nb.cells[3].outputs), nb.cells[3].outputs
    assert status == "error", detail


def test_seed004_untouched_scores_0_half_done_earns_its_steps(tmp_path):
    """The worked lab: the rows the untouched student version passes are free (notebook 02's checks test labkit
    only), a half-done submission (steps 1-2 right, then the stub) earns the hidden check's step rows, the
    instructor's solution earns everything that is not free (Robot, IKSolutions, Trajectory reach the checker)."""
    nbformat = require("nbformat")
    from labkit.course import Limits, assign, grade, graded_cells

    seed = Path(__file__).resolve().parents[2] / "notebooks" / "seed004_planar3r_ik"
    lab = tmp_path / "seed004"  # part A-C (student work) and D-E (checks of labkit only: free); 03 is like 02
    lab.mkdir()
    for name in ("00_model_sine_motion.ipynb", "01_ik_elbow_minus.ipynb", "02_arc_trajectory_animation.ipynb"):
        shutil.copy(seed / name, lab / name)  # 00 has no checks: not run at grading
    student = tmp_path / "student"
    assign(lab, student)
    subs = tmp_path / "subs"
    shutil.copytree(lab, subs / "solved", ignore=shutil.ignore_patterns(".ipynb_checkpoints"))
    shutil.copytree(student, subs / "half_done")
    nb = nbformat.read(str(subs / "half_done" / "01_ik_elbow_minus.ipynb"), as_version=4)
    solution = next(c for c in nbformat.read(str(lab / "01_ik_elbow_minus.ipynb"), as_version=4).cells
                    if "solution" in tags(c)).source
    steps = solution.split("M = np.array")[0]  # steps 1 and 2 only
    for c in nb.cells:
        if "solution" in tags(c):
            c.source = steps + "raise NotImplementedError()"
    nbformat.write(nb, str(subs / "half_done" / "01_ik_elbow_minus.ipynb"))
    # issue 37: fake q, the target and trivial steps that agree with them; the checks read the instructor's
    # target (parameters cell) and reference solution (reference cell), computed outside the student's kernel
    shutil.copytree(student, subs / "faked")
    nb = nbformat.read(str(subs / "faked" / "01_ik_elbow_minus.ipynb"), as_version=4)
    for c in nb.cells:
        if "solution" in tags(c):
            c.source = ("q = np.zeros(3)\nxe, ye, phie = L1 + L2 + L3, 0.0, 0.0\nx3, y3 = L1 + L2, 0.0\ncos_t2 = 1.0\n"
                        "c1, s1 = 1.0, 0.0\nt1 = t2 = t3 = 0.0\narm = arm")
    nbformat.write(nb, str(subs / "faked" / "01_ik_elbow_minus.ipynb"))
    shutil.copytree(student, subs / "untouched")
    limits = Limits(cpu_seconds=60, memory_bytes=3 * 2**30, wall_seconds=180)
    results = {r.student: r for r in grade(subs, lab, tmp_path / "fb", limits=limits, jobs=2, progress=False)}
    solved, half = results["solved"], results["half_done"]
    assert solved.points == solved.max_points == 5, solved  # 3 public + 2 hidden; notebook 02's checks are free
    assert {r.max_points for r in results.values()} == {5}
    assert results["faked"].points <= results["untouched"].points == 0, results["faked"]
    # the docs' figures: the full lab declares 9 points; 03 has no student work (no solution cell), so its checks,
    # which pass untouched and back no row needing work, are free like 02's: the maximum is the one graded here
    declared = sum(c.points for p in sorted(seed.glob("*.ipynb")) for c in graded_cells(p))
    assert not any("solution" in tags(c) for c in nbformat.read(str(seed / "03_straight_line.ipynb"), 4).cells)
    assert f"at most {solved.max_points:g} of the {declared:g} declared points" in _words(DOCS.read_text())
    assert f"reports a maximum of {solved.max_points:g}" in _words(DOCS.read_text())
    hidden = next(s for s in half.scores if s.name == "A.2 steps")
    assert [r.passed for r in hidden.rows] == [True, True, False, False]  # steps 1 and 2, not steps 3 and 4
    assert half.points == pytest.approx(2 * 2 / 4), half
    assert results["faked"].points == 0, results["faked"]
    assert "NotImplementedError" in half.detail and "cell" in half.detail and "line" in half.detail
    free = [s for s in solved.scores if s.free]
    assert {s.notebook for s in free} == {"02_arc_trajectory_animation.ipynb"}
    assert all(s.passed for s in solved.scores)  # the data reached the checker (Robot, IKSolutions, Trajectory)
    assert not any(s.notebook.startswith("00_") for s in solved.scores)


@pytest.mark.parametrize("where", ["tmp", "home"])
def test_sandbox_works_from_a_virtualenv_under_tmp_or_home(tmp_path, where):
    """The suite holds with the virtualenv under /tmp or $HOME: the sandbox shows that venv (read-only) and labkit."""
    import uuid

    base = tmp_path if where == "tmp" else Path(os.path.expanduser("~")) / f".labkit-venv-test-{uuid.uuid4().hex[:8]}"
    venv = base / "venv"
    try:
        subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", "--without-pip", str(venv)], check=True)
        if sys.prefix != sys.base_prefix:
            # the suite runs in a virtualenv itself (make test's .venv): the new one is made from the base
            # interpreter, whose packages are not this venv's, so its site-packages becomes this venv's
            purelib = Path(sysconfig.get_paths()["purelib"])
            nested = venv / purelib.relative_to(sys.prefix)
            shutil.rmtree(nested)
            nested.symlink_to(purelib, target_is_directory=True)
        script = ("import nbformat\nfrom labkit.course import Limits, run_untrusted\n"
                  "nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell("
                  "'import sys, labkit, numpy\\nprint(sys.prefix)')])\n"
                  f"print(tuple(run_untrusted(nb, {str(tmp_path)!r}, limits=Limits(cpu_seconds=30, "
                  "memory_bytes=2 * 2**30, wall_seconds=60))[:2]))\nprint(nb.cells[0].outputs[0]['text'].strip())\n")
        env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))
        out = subprocess.run([str(venv / "bin" / "python"), "-c", script], capture_output=True, text=True, env=env,
                             timeout=180)
        assert out.stdout.splitlines()[-2:] == ["('ok', '')", str(venv)], out.stdout + out.stderr[-2000:]
    finally:
        if where == "home":
            shutil.rmtree(base, ignore_errors=True)
