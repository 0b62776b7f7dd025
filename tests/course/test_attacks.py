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
import shutil
import socket
import subprocess
import threading
import uuid
from pathlib import Path

import pytest

from conftest import require
from tests.course import attacks as at
from tests.course import course_lab as cl

# every test that grades shares one xdist group: the attack batch checks that no labkit cgroup outlives
# its run, which a grading test running beside it on the other worker would make look false
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("grading")]
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

    A cgroup is named after the process that made it (``labkit-<pid>-...``). One whose maker is alive
    and not this test's descendant belongs to a grading test on the other xdist worker.
    """
    me = os.getpid()
    left = set()
    for path in new:
        try:
            maker = int(path.name.split("-")[1])
        except (IndexError, ValueError):
            left.add(path)
            continue
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
    for page in feedback.glob("*/index.html"):
        text = page.read_text()
        assert len(text.encode()) <= 2**20, page
        assert "SECRET-HIDDEN-MARKER" not in text and "fk(arm, q)[0, 3]" not in text, page
        assert "<script>alert" not in text and "<img src=x" not in text, page
        assert "labkit-grade-" not in text and "labkit-kernel-" not in text, page
    assert "&lt;script&gt;alert(&quot;in detail&quot;)" in (feedback / "html_injection" / "index.html").read_text()
    assert not any((subs / n / "planted.txt").exists() for n in HONEST)
    assert sorted(p.name for p in (subs / HONEST[0]).iterdir()) == [cl.NOTEBOOK, "private_notes.txt"]
