"""Every attack of issue 23 and more, graded in one batch (``--jobs 2``) with honest submissions.

The instructor's lab lies under ``/var/tmp``, with copies of it (and of an honest student's
work) under ``/tmp``, ``$HOME`` and ``/srv``: the sandbox must show none of them, wherever
they are. Each attack must score 0 points, and the honest submissions graded alongside
keep their full 4 points.

Memory: where a memory cgroup can be made (:func:`labkit.course.memory_mechanism`), the batch
runs under ``--memory 0.5`` (the honest submissions pass under it), the memory attacks
(forked children, full RAM disks) must be graded ``"memory"`` and every cgroup must be gone
afterwards; elsewhere under ``--memory 1.5`` and the sampling watchdog (tested on its own in
``test_watchdog_limits_forked_memory``).
"""

import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import uuid
from pathlib import Path

import pytest

from conftest import require
from labkit.course import _safefs
from tests.course import attacks as at
from tests.course import course_lab as cl

# The grading tests run in two xdist groups side by side (`pytest -n 2 --dist loadgroup`): "grading-batches" (this
# file and test_dask.py) and "grading-loop" (test_course.py, test_points.py, test_cgroup.py, test_watchdog.py,
# test_safefs.py). A test has one group: xdist joins the names of every xdist_group marker on it into a new group,
# so a file's tests stay in its module's group. The batches share a group: both plant an orphan `sleep 987654` and
# look for it by name. The cgroup check below ignores cgroups made by a live grader that is not this test's; a grader
# killed outright leaves its cgroup until the next run sweeps it, so test_dask.py, which kills one, is in this group.
# Kernels side by side on a loaded machine: the one that died before its first reply in CI was the watchdog reading
# the host's /tmp (test_watchdog.py).
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("grading-batches")]
LIMITS = dict(cpu_seconds=10, wall_seconds=25)
HONEST = ("honest_a", "honest_b", "honest_c")


def _memory_gib(mechanism) -> float:
    """The batch's memory limit [GiB]: small under a cgroup; under the watchdog ``RLIMIT_AS`` is the limit too."""
    return 0.5 if mechanism != "watchdog" else 1.5


def _cgroups() -> set:
    """The labkit cgroups that exist now (in every hierarchy a grader here would use)."""
    from labkit.course._cgroup import _parents

    return {p for _, parent in _parents() for p in parent.glob("labkit-*")}


def _ancestors(pid) -> set:
    """The pids above ``pid`` (its parent, grandparent ...); empty once it has exited."""
    out = set()
    while pid > 1:
        try:
            pid = int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            break
        out.add(pid)
    return out


def _outlived(new) -> set:
    """The new cgroups that outlived their run: every one but those of a live grader outside this test.

    A cgroup is named after the process that made it (``labkit-mem-<pid>-<start>-...``). One whose maker is alive
    and not this test's descendant belongs to a grading test on the other xdist worker.
    """
    from labkit.course._leftovers import owner_of

    me = os.getpid()
    left = set()
    for path in new:
        owner = owner_of(path.name, ("mem",))
        if owner is None:
            left.add(path)
            continue
        maker = owner[0]
        ancestors = _ancestors(maker)
        if maker == me or me in ancestors or not ancestors:  # ours, or its maker is gone
            if path.exists():
                left.add(path)
    return left


def _places(tag):
    """A fresh folder under each of /tmp, $HOME, /var/tmp and /srv (or a /srv-like stand-in)."""
    srv = Path("/srv") if os.access("/srv", os.W_OK) else Path(os.path.expanduser("~")) / "srv-like"
    return {k: Path(v) / f"labkit-{tag}-{uuid.uuid4().hex[:8]}"
            for k, v in (("tmp", "/tmp"), ("home", os.path.expanduser("~")), ("var_tmp", "/var/tmp"), ("srv", srv))}


@pytest.fixture
def spread_lab():
    """The real lab under /var/tmp, decoys (the lab and an honest student's folder) everywhere else."""
    require("nbgrader")
    from labkit.course import assign

    places = _places("attack")
    try:
        for path in places.values():
            path.mkdir(parents=True)
            cl.write_lab(path / "lab")
            (path / "other_student").mkdir()
            (path / "other_student" / "private_notes.txt").write_text("only mine")
        lab = places["var_tmp"] / "lab"
        assign(lab, places["var_tmp"] / "student")
        yield lab, places["var_tmp"] / "student", places
    finally:
        for path in places.values():
            shutil.rmtree(path, ignore_errors=True)


class _SocketServer(threading.Thread):
    def __init__(self, path):
        super().__init__(daemon=True)
        self.path, self.connections = str(path), []
        self.sock = socket.socket(socket.AF_UNIX)
        self.sock.bind(self.path)
        self.sock.listen(5)
        self.sock.settimeout(0.5)
        self.stop = False

    def run(self):
        while not self.stop:
            try:
                conn, _ = self.sock.accept()
                self.connections.append(conn.recv(100))
                conn.close()
            except OSError:
                continue


def test_attacks_score_nothing_and_disturb_no_one(spread_lab, tmp_path, capsys):
    pd = require("pandas")
    from labkit.cli import main
    from labkit.course import memory_mechanism

    mechanism = memory_mechanism()
    memory_gib = _memory_gib(mechanism)
    cgroups_before = _cgroups()

    lab, student, places = spread_lab
    subs = places["tmp"] / "submissions"
    for name in HONEST:
        cl.write_submission(student, subs / name, cl.SOLUTION)
        (subs / name / "private_notes.txt").write_text("only mine")
    servers = [_SocketServer(places[k] / "grader.sock") for k in ("tmp", "var_tmp")]
    for s in servers:
        s.start()
    codes = dict(at.CHECKS_ATTACKS)
    codes["snoop_filesystem"] = at.snoop_code([p for p in places.values()])
    codes["cross_kernel"] = at.cross_kernel_code()
    codes["unix_socket"] = at.unix_socket_code([s.path for s in servers])
    codes["symlink_escape"] = at.symlink_escape_code(subs / HONEST[0] / cl.NOTEBOOK)
    codes.update(at.memory_attacks(int(memory_gib * 2**30), ram_disks_work=mechanism != "watchdog"))
    for name, code in codes.items():
        cl.write_submission(student, subs / name, code)
    (subs / "symlink_escape" / "peek.ipynb").symlink_to(subs / HONEST[0] / cl.NOTEBOOK)
    (subs / "symlink_escape" / "lab_link").symlink_to(lab)
    # a submission whose notebook is a symlink to a victim's, and malformed notebooks
    (subs / "symlinked_notebook").mkdir()
    (subs / "symlinked_notebook" / cl.NOTEBOOK).symlink_to(subs / HONEST[1] / cl.NOTEBOOK)
    for name, mangle in (("no_cell_type", lambda c: c.pop("cell_type")), ("int_source", lambda c: c.update(source=7))):
        import json

        nb = json.loads((student / cl.NOTEBOOK).read_text())
        mangle(nb["cells"][3])
        (subs / name).mkdir()
        (subs / name / cl.NOTEBOOK).write_text(json.dumps(nb))
    (subs / "stray_file.ipynb").write_text("{}")  # not a folder: still one row
    (subs / "linked_folder").symlink_to(subs / HONEST[2])

    gradebook = tmp_path / "grades" / "gradebook.csv"
    try:
        assert main(["grade", str(subs), "--lab", str(lab), "-o", str(gradebook), "--jobs", "2",
                     "--cpu", str(LIMITS["cpu_seconds"]), "--memory", str(memory_gib), "--wall", str(LIMITS["wall_seconds"])]) == 0
    finally:
        for s in servers:
            s.stop = True
    assert f"memory limited per notebook run by: {mechanism}" in capsys.readouterr().out
    table = pd.read_csv(gradebook, index_col="student")
    expected_rows = set(codes) | set(HONEST) | {"symlinked_notebook", "no_cell_type", "int_source", "stray_file.ipynb",
                                                "linked_folder"}
    assert set(table.index) == expected_rows  # one row per input, however malformed
    for name in HONEST:
        assert (table.loc[name, "points"], table.loc[name, "status"]) == (4, "ok"), (name, table.loc[name, "detail"])
    cheats = {n: (table.loc[n, "points"], table.loc[n, "status"], table.loc[n, "detail"])
              for n in expected_rows - set(HONEST) if table.loc[n, "points"] != 0}
    assert not cheats, cheats
    assert (table["max_points"] == 4).all(), table["max_points"]
    for name in ("symlinked_notebook", "no_cell_type", "int_source", "stray_file.ipynb", "linked_folder"):
        assert table.loc[name, "status"] in ("invalid", "missing"), name
    statuses = dict(at.STATUS, ram_disks="memory" if mechanism != "watchdog" else None)
    for name, status in statuses.items():
        if status:
            assert table.loc[name, "status"] == status, (name, table.loc[name, "detail"])
    graded = table[~table["status"].isin(["invalid", "missing"])]
    assert set(graded["memory_limit"]) == {mechanism}, graded["memory_limit"]
    assert not _outlived(_cgroups() - cgroups_before), "a cgroup outlived its run"
    assert "cpu-time" not in str(table.loc["self_kill", "detail"])
    assert not any(s.connections for s in servers), [s.connections for s in servers]
    leftover = subprocess.run(["pgrep", "-f", "sleep 987654"], capture_output=True, text=True).stdout.split()
    assert not leftover, "a process outlived its sandbox"

    feedback = gradebook.with_name("gradebook_feedback")
    index = (feedback / "index.html").read_text()
    assert all(f"{name}/index.html" in index for name in HONEST)
    for page in feedback.glob("students/*/index.html"):
        text = page.read_text()
        assert len(text.encode()) <= 2**20, page
        assert "SECRET-HIDDEN-MARKER" not in text and "fk(arm, q)[0, 3]" not in text, page
        assert "<script>alert" not in text and "<img src=x" not in text, page
        assert "labkit-grade-" not in text and "labkit-kernel-" not in text, page
        assert "hidden-y" not in text, page  # an unnamed hidden check's cell id (issue 37)
    assert "&lt;script&gt;alert(&quot;in detail&quot;)" in (feedback / "students" / "html_injection" / "index.html").read_text()
    assert not any((subs / n / "planted.txt").exists() for n in HONEST)
    assert sorted(p.name for p in (subs / HONEST[0]).iterdir()) == [cl.NOTEBOOK, "private_notes.txt"]


# ---------------------------------------------------------------------------------------------------------------
# issue 37: the grader never touches a path the sandbox could have written, except through labkit.course._safefs

_WATCHED = re.compile(r"/labkit-grade-[^/]+/home/|/labkit-run-[^/]+/sockets/")
_FILE_EVENTS = {"open", "os.remove", "os.rename", "os.rmdir", "os.mkdir", "os.symlink", "os.link", "os.chmod",
                "os.chown", "os.truncate", "os.utime", "shutil.copyfile", "shutil.copymode", "shutil.copystat",
                "shutil.copytree", "shutil.move", "shutil.rmtree", "os.listdir", "os.scandir", "socket.connect"}
_AUDIT = {"on": False, "seen": []}


def _audit(event, args):
    if not _AUDIT["on"] or event not in _FILE_EVENTS:
        return
    if _safefs.active():
        return
    for arg in args[:2]:
        if isinstance(arg, (str, bytes, os.PathLike)):
            path = os.fsdecode(arg)
            if _WATCHED.search(path):
                _AUDIT["seen"].append((event, path))


def _two_notebook_lab(folder):
    cl.write_lab(folder)
    shutil.copy(folder / cl.NOTEBOOK, folder / SECOND)
    return folder


SECOND = "02_fk.ipynb"


def test_runtime_folder_escape_reaches_nothing_and_files_go_through_one_helper(tmp_path):
    """The kernel's runtime folder, font cache, IPython folder and home are the sandbox's: links and planted
    files there reach neither the host nor the next notebook, and the grader's file operations on them all
    go through ``labkit.course._safefs`` (an audit hook records every other one)."""
    require("nbgrader")
    from labkit.course import Limits, assign, grade_submission

    lab = _two_notebook_lab(tmp_path / "lab")
    student = tmp_path / "student"
    assign(lab, student)
    host = tmp_path / "host"
    host.mkdir()
    append_to, overwrite, secret = host / "append.txt", host / "fontlist.json", host / "secret.txt"
    append_to.write_text("untouched\n")
    overwrite.write_text('{"untouched": true}')
    secret.write_text("TOP-SECRET-CANARY\n" * 3)
    server = _SocketServer(host / "host.sock")
    server.start()
    subs = tmp_path / "subs"
    for name, first in (("honest", cl.SOLUTION), ("untouched", None),
                        ("runtime_escape", at.runtime_escape_code(append_to, overwrite, secret)),
                        ("socket_links", at.runtime_escape_code(append_to, overwrite, secret, [server.path]))):
        cl.write_submission(student, subs / name, first if first is not None else
                            next(c.source for c in __import__("nbformat").read(str(student / cl.NOTEBOOK), 4).cells
                                 if c.get("id") == "work"))
        shutil.copy(student / SECOND, subs / name / SECOND)
        if name == "honest":
            cl.write_submission(student, tmp_path / "second", cl.SOLUTION)
            shutil.copy(tmp_path / "second" / cl.NOTEBOOK, subs / name / SECOND)
    sys.addaudithook(_audit)
    limits = Limits(cpu_seconds=10, wall_seconds=25, memory_bytes=2 * 2**30)
    results = {}
    _AUDIT.update(on=True, seen=[])
    try:
        for name in ("honest", "untouched", "runtime_escape", "socket_links"):
            results[name] = grade_submission(subs / name, lab, tmp_path / "feedback", limits=limits, free={})
    finally:
        _AUDIT["on"] = False
        server.stop = True
    assert not _AUDIT["seen"], _AUDIT["seen"][:10]
    assert append_to.read_text() == "untouched\n"
    assert overwrite.read_text() == '{"untouched": true}'
    assert not server.connections, server.connections
    honest, untouched = results["honest"], results["untouched"]
    assert honest.points == honest.max_points == 8, honest.detail
    for name in ("runtime_escape", "socket_links"):
        r = results[name]
        assert r.points <= untouched.points, (name, r.points, untouched.points, r.detail)
        by_nb = {s.notebook: 0 for s in r.scores}
        for s in r.scores:
            by_nb[s.notebook] += s.points
        assert by_nb[SECOND] <= sum(s.points for s in untouched.scores if s.notebook == SECOND), (name, r.detail)
        page = (tmp_path / "feedback" / "students" / name / "index.html").read_text()
        assert "TOP-SECRET-CANARY" not in page and "TOP-SECRET-CANARY" not in r.detail
        assert "02_fk.ipynb: crash" not in r.detail, r.detail  # the planted zmq.py did not shadow the next kernel


def test_grader_modules_copy_and_remove_only_through_the_helper():
    """Static half of the rule: no course module but the helper copies, removes or links files by name."""
    import labkit.course

    folder = Path(labkit.course.__file__).parent
    calls = re.compile(r"shutil\.(copy|copy2|copyfile|copytree|rmtree|move)\(|os\.(symlink|link|unlink|remove)\(")
    offenders = {p.name: calls.findall(p.read_text()) for p in folder.glob("*.py") if p.name != "_safefs.py"}
    assert not any(offenders.values()), offenders


def _remove_deep(top: Path):
    """Undo :func:`attacks.deep_folder` one level at a time (``shutil.rmtree`` recurses)."""
    fd = os.open(top, os.O_RDONLY | os.O_DIRECTORY)
    try:
        while True:
            try:
                os.rename("d/d", "up", src_dir_fd=fd, dst_dir_fd=fd)
            except FileNotFoundError:
                break
            os.rmdir("d", dir_fd=fd)
            os.rename("up", "d", src_dir_fd=fd, dst_dir_fd=fd)
        os.rmdir("d", dir_fd=fd)
    finally:
        os.close(fd)


def test_names_and_trees_never_stop_the_gradebook(tmp_path, capsys):
    """Issue 37: one gradebook row per folder, whatever its name or tree; nothing a spreadsheet runs, no escape
    codes on the terminal, the class index never overwritten."""
    require("nbgrader")
    pd = require("pandas")
    openpyxl = require("openpyxl")
    import csv

    from labkit.cli import main
    from labkit.course import assign

    lab = cl.write_lab(tmp_path / "lab")
    student = tmp_path / "student"
    assign(lab, student)
    subs = tmp_path / "subs"
    subs.mkdir()
    escape = "raise ValueError('\\x1b]0;pwned\\x07\\x1b[2J\\x1b[31mred\\x07')"
    names = {"honest": cl.SOLUTION, "index.html": cl.SOLUTION, "=1+2": "x = 1", '=HYPERLINK("x.invalid","y")': "",
             "-2+3": "", "@SUM(A1)": "", "cr\rname": cl.SOLUTION, "escape_codes": escape}
    for name, code in names.items():
        cl.write_submission(student, subs / name, code)
    latin1 = os.path.join(os.fsencode(subs), b"caf\xe9")  # an unzip of a Latin-1 archive
    os.mkdir(latin1)
    shutil.copy(subs / "honest" / cl.NOTEBOOK, os.fsdecode(os.path.join(latin1, cl.NOTEBOOK.encode())))
    cl.write_submission(student, subs / "deep", cl.SOLUTION)
    os.close(at.deep_folder(subs / "deep", 1100))
    cl.write_submission(student, subs / "many_files", cl.SOLUTION)
    for i in range(6000):
        (subs / "many_files" / f"f{i}").touch()
    gradebook = tmp_path / "out" / "gradebook.csv"
    try:
        code = main(["grade", str(subs), "--lab", str(lab), "-o", str(gradebook), "--jobs", "2",
                     "--cpu", "10", "--memory", "2", "--wall", "25"])
    finally:
        _remove_deep(subs / "deep")
    printed = capsys.readouterr()
    assert code == 0, printed.err[-2000:]
    assert not re.search(r"[\x00-\x08\x0b-\x1f\x7f]", printed.out + printed.err.replace("\r", "")), printed
    expected = {"honest", "index.html", "'=1+2", "'=HYPERLINK(\"x.invalid\",\"y\")", "'-2+3", "'@SUM(A1)",
                "cr\\x0dname", "escape_codes", "caf\\xe9", "deep", "many_files"}
    with open(gradebook, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(expected) and {r["student"] for r in rows} == expected, [r["student"] for r in rows]
    table = {r["student"]: r for r in rows}
    for name in ("honest", "index.html", "cr\\x0dname", "caf\\xe9"):
        assert (float(table[name]["points"]), table[name]["status"]) == (4.0, "ok"), (name, table[name]["detail"])
    assert table["deep"]["status"] == "invalid" and "deep" in table["deep"]["detail"], table["deep"]
    assert table["many_files"]["status"] == "invalid" and "files and folders" in table["many_files"]["detail"]
    assert not re.search(r"[\x00-\x1f\x7f]", table["escape_codes"]["detail"]), table["escape_codes"]["detail"]
    assert "ValueError" in table["escape_codes"]["detail"] and "pwned" in table["escape_codes"]["detail"]
    for r in rows:
        assert not any(v.startswith(("=", "+", "-", "@", "\t", "\r")) for v in r.values()), r
    book = openpyxl.load_workbook(gradebook.with_suffix(".xlsx"))
    cells = [c for row in book.active.iter_rows() for c in row]
    assert not [c.value for c in cells if c.data_type == "f"], "a formula cell in the Excel gradebook"
    assert book.active.max_row == len(expected) + 1
    assert len(pd.read_excel(gradebook.with_suffix(".xlsx"), index_col=0)) == len(expected)
    feedback = gradebook.with_name("gradebook_feedback")
    assert "Gradebook: lab" in (feedback / "index.html").read_text()
    assert "Feedback: index.html" in (feedback / "students" / "index.html" / "index.html").read_text()
    pages = list((feedback / "students").glob("*/index.html"))
    assert len(pages) == len(expected) - 2, sorted(p.parent.name for p in pages)  # the two over the caps: no page


_MEASURE = """
import json, resource, sys
from pathlib import Path
from labkit.course import Limits, grade_submission
limits = Limits(cpu_seconds=20, wall_seconds=60, memory_bytes=2 * 2**30, output_bytes=256 * 2**10, message_bytes=2**20)
r = grade_submission(Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3]), limits=limits, free={}, html=False)
print(json.dumps({"status": r.status, "points": r.points, "detail": r.detail,
                  "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def test_huge_outputs_keep_the_grader_small(tmp_path):
    """Issue 37: every output message is measured as it arrives (one over the cell's cap is dropped, the row says
    so; one over the message cap closes the channel before the grader holds it), a notebook is capped before it is
    parsed, and the grader's own peak memory stays within 64 MiB of an honest grading's. Caps scaled down
    (256 KiB per cell, 1 MiB per message) so that the outputs stay small: 8 cells of 20 MB."""
    require("nbgrader")
    import json

    import nbformat

    from labkit.course import Limits, assign, grade_submission

    lab = cl.write_lab(tmp_path / "lab")
    student = tmp_path / "student"
    assign(lab, student)
    subs = tmp_path / "subs"
    for name, extra in (("honest", ""), ("chatty", "print('c' * 600_000)"), ("huge", "print('y' * 20_000_000)")):
        cl.write_submission(student, subs / name, cl.SOLUTION)
        if extra:
            nb = nbformat.read(str(subs / name / cl.NOTEBOOK), 4)
            at_work = next(i for i, c in enumerate(nb.cells) if c.get("id") == "work")
            for k in range(8):
                nb.cells.insert(at_work + 1, nbformat.v4.new_code_cell(extra, id=f"extra-{k}"))
            nbformat.write(nb, str(subs / name / cl.NOTEBOOK))
    runs = {}
    for name in ("honest", "chatty", "huge"):
        proc = subprocess.run([sys.executable, "-c", _MEASURE, str(subs / name), str(lab), str(tmp_path / "fb")],
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr[-2000:]
        runs[name] = json.loads(proc.stdout.strip().splitlines()[-1])
    honest, chatty, huge = runs["honest"], runs["chatty"], runs["huge"]
    assert (honest["points"], honest["status"]) == (4, "ok"), honest
    assert (chatty["points"], chatty["status"]) == (4, "ok"), chatty  # the values still reach the checks
    assert "output over the limit of 262144 bytes per cell (16777216 per notebook) dropped: 8 message(s)" \
        in chatty["detail"], chatty
    assert huge["status"] == "crash" and "over the limit of 1048576 bytes" in huge["detail"], huge
    assert huge["points"] == 0, huge
    for run in (chatty, huge):
        assert run["peak_mib"] < honest["peak_mib"] + 64, runs

    # a notebook over the size or cell cap is refused before it is parsed
    big = subs / "many_cells"
    cl.write_submission(student, big, cl.SOLUTION)
    nb = nbformat.read(str(big / cl.NOTEBOOK), 4)
    nb.cells += [nbformat.v4.new_raw_cell("", id=f"raw-{k}") for k in range(2500)]
    nbformat.write(nb, str(big / cl.NOTEBOOK))
    limits = Limits(cpu_seconds=10, wall_seconds=25)
    r = grade_submission(big, lab, tmp_path / "fb", limits=limits, free={}, html=False)
    assert r.status == "invalid" and "expected at most 2000 cells, got 25" in r.detail, r.detail
    (big / cl.NOTEBOOK).write_bytes(b" " * (17 * 2**20) + b"{}")
    r = grade_submission(big, lab, tmp_path / "fb", limits=limits, free={}, html=False)
    assert r.status == "invalid" and "expected at most 16777216 bytes" in r.detail, r.detail


def test_a_refused_user_namespace_stops_grading_with_the_fix(tmp_path, monkeypatch, capsys):
    """Ubuntu 24.04's AppArmor refuses bubblewrap's user namespace: labkit grade stops before grading, naming the
    setting and the fix (a bwrap that fails the way it fails there, and the sysctl as Ubuntu sets it)."""
    from labkit.cli import main
    from labkit.course import _sandbox

    fake = tmp_path / "bin" / "bwrap"
    fake.parent.mkdir()
    fake.write_text("#!/bin/sh\necho 'bwrap: setting up uid map: Permission denied' >&2\nexit 1\n")
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", f"{fake.parent}:{os.environ['PATH']}")
    real = _sandbox._sysctl
    monkeypatch.setattr(_sandbox, "_sysctl", lambda path: "1" if "apparmor_restrict" in str(path) else real(path))
    lab = cl.write_lab(tmp_path / "lab")
    cl.write_submission(lab, tmp_path / "subs" / "someone", cl.SOLUTION)
    code = main(["grade", str(tmp_path / "subs"), "--lab", str(lab), "-o", str(tmp_path / "g.csv")])
    err = capsys.readouterr().err
    assert code != 0 and not (tmp_path / "g.csv").exists()
    assert "setting up uid map: Permission denied" in err and "kernel.apparmor_restrict_unprivileged_userns" in err
    assert "/etc/apparmor.d/bwrap" in err and "--no-sandbox" in err, err


GRADER_USER = "labkit-grader"


def _as_grader_user(argv, env, cwd) -> subprocess.CompletedProcess:
    """Run ``argv`` as an unprivileged user: as root, the user ``labkit-grader`` (made with useradd if missing),
    in a mount namespace where the Python installation is reachable (a folder above it that only root may enter,
    such as ``/root`` of a pyenv, is replaced by a tmpfs holding just the installation); otherwise as oneself."""
    if os.geteuid() != 0:
        return subprocess.run(argv, env=env, cwd=cwd, capture_output=True, text=True, timeout=900)
    if subprocess.run(["id", "-u", GRADER_USER], capture_output=True).returncode != 0:
        subprocess.run(["useradd", "--system", "--no-create-home", "--shell", "/usr/sbin/nologin", GRADER_USER],
                       check=True)
    prefix = Path(sys.base_prefix).resolve()
    closed = [p for p in reversed(prefix.parents) if p != Path("/") and not os.stat(p).st_mode & 0o001]
    script = "set -e\n"
    if closed:
        top, keep = closed[0], prefix.relative_to(closed[0]).parts[0]
        view = Path(cwd) / "python-view"
        view.mkdir(exist_ok=True)
        script += (f"mount --bind {top / keep} {view}\nmount -t tmpfs -o mode=755 tmpfs {top}\n"
                   f"mkdir {top / keep}\nmount --bind {view} {top / keep}\n")
    script += 'exec runuser -u "$0" -- "$@"\n'
    return subprocess.run(["unshare", "--mount", "--propagation", "private", "sh", "-c", script, GRADER_USER, *argv],
                          env=env, cwd=cwd, capture_output=True, text=True, timeout=900)


def test_attack_and_normal_batches_as_an_unprivileged_user(tmp_path):
    """Issue 37: graded as a normal user (as root the test makes one and drops to it), the honest submissions keep
    their points, the attacks score nothing and touch none of that user's files, nothing of the user outlives the
    batch, and the gradebook says how memory was limited for that user (here: what memory_mechanism says as them)."""
    require("nbgrader")
    import json

    from labkit.course import assign

    base = Path(tempfile.mkdtemp(prefix="labkit-user-batch-", dir="/var/tmp"))
    try:
        base.chmod(0o755)
        lab = cl.write_lab(base / "lab")
        assign(lab, base / "student")
        mine = base / "mine"  # the grading user's own files: the attacks aim at them
        mine.mkdir()
        append_to, overwrite, secret = mine / "append.txt", mine / "fontlist.json", mine / "secret.txt"
        append_to.write_text("untouched\n")
        overwrite.write_text("{}")
        secret.write_text("TOP-SECRET-CANARY\n")
        subs = base / "subs"
        codes = {"honest_a": cl.SOLUTION, "honest_b": cl.SOLUTION, "untouched": "raise NotImplementedError()",
                 "runtime_escape": at.runtime_escape_code(append_to, overwrite, secret)}
        for name in ("patch_assert_all", "write_outside", "orphan_process", "process_flood", "baseline_values"):
            codes[name] = at.CHECKS_ATTACKS[name]
        codes["deep_tree"] = at.deep_tree_code()  # removed afterwards though this user may not enter its folders
        for name, code in codes.items():
            cl.write_submission(base / "student", subs / name, code)
        home = base / "home"
        home.mkdir()
        if os.geteuid() == 0:
            subprocess.run(["chown", "-R", f"{GRADER_USER}:", str(base)] if subprocess.run(
                ["id", "-u", GRADER_USER], capture_output=True).returncode == 0 else ["true"], check=True)
        env = {"PATH": f"{os.path.dirname(sys.executable)}:/usr/sbin:/usr/bin:/bin", "HOME": str(home),
               "LANG": "C.UTF-8", "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
        probe = _as_grader_user([sys.executable, "-c", "import os, json; from labkit.course import memory_mechanism; "
                                 "print(json.dumps([os.geteuid(), memory_mechanism()]))"], env, base)
        assert probe.returncode == 0, probe.stderr[-2000:]
        if os.geteuid() == 0:  # the user now exists: give it its files
            subprocess.run(["chown", "-R", f"{GRADER_USER}:", str(base)], check=True)
            probe = _as_grader_user([sys.executable, "-c", "import os, json; from labkit.course import memory_mechanism; "
                                     "print(json.dumps([os.geteuid(), memory_mechanism()]))"], env, base)
        uid, mechanism = json.loads(probe.stdout.strip().splitlines()[-1])
        assert uid != 0
        memory = "0.5" if mechanism != "watchdog" else "1.5"
        tmp_before = set(Path(tempfile.gettempdir()).glob("labkit-*"))
        run = _as_grader_user([sys.executable, "-m", "labkit", "grade", str(subs), "--lab", str(lab), "-o",
                               str(base / "out" / "gradebook.csv"), "--jobs", "2", "--cpu", "20", "--memory", memory,
                               "--wall", "90"], env, base)  # wide limits: a loaded CI machine starts kernels slowly
        assert run.returncode == 0, (run.stdout[-2000:], run.stderr[-3000:])
        assert f"memory limited per notebook run by: {mechanism}" in run.stdout, run.stdout
        pd = require("pandas")
        table = pd.read_csv(base / "out" / "gradebook.csv", index_col="student")
        assert set(table.index) == set(codes)
        for name in ("honest_a", "honest_b"):
            assert (table.loc[name, "points"], table.loc[name, "status"]) == (4, "ok"), table.loc[name, "detail"]
        cheats = {n: table.loc[n, "detail"] for n in codes if not n.startswith("honest") and table.loc[n, "points"] != 0}
        assert not cheats, cheats
        assert table.loc["process_flood", "status"] == "crash"
        assert set(table["memory_limit"]) == {mechanism}
        assert append_to.read_text() == "untouched\n" and overwrite.read_text() == "{}"
        assert "TOP-SECRET-CANARY" not in (base / "out" / "gradebook.csv").read_text()
        left = [p for p in set(Path(tempfile.gettempdir()).glob("labkit-*")) - tmp_before if p.lstat().st_uid == uid]
        assert uid == os.geteuid() or not left, f"the grading user's temporary folders outlived the batch: {left}"
        if os.geteuid() == 0:
            rows = subprocess.run(["ps", "-o", "stat=,pid=,args=", "-u", GRADER_USER], capture_output=True,
                                  text=True).stdout.splitlines()
            alive = [r for r in rows if not r.strip().startswith("Z")]  # a zombie has exited (init reaps it)
            assert not alive, f"a process of the grading user outlived the batch: {alive}"
    finally:
        shutil.rmtree(base, ignore_errors=True)
