"""What graders and workers killed outright leave in the temporary folders, and the sweep that removes it.

A folder is named after its maker (``labkit-<kind>-<pid>-<start>-<random>``, :mod:`labkit.course._leftovers`).
The sweep removes only folders of this user whose maker is dead, never through a link, and nothing whose name is
not exactly of that form: a kernel's files, names and links inside are untrusted.
"""

import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from conftest import require
from labkit.course import _leftovers
from labkit.course._leftovers import FOLDER_KINDS, TEMP_PLACES, owner_of, process_start, remove_leftovers, sweep
from labkit.course._safefs import remove_tree
from tests.course import attacks as at
from tests.course import course_lab as cl

NO_SUCH_PID = 2**22 + 12345  # above the largest pid_max (PID_MAX_LIMIT): never a process
LIMITS = dict(cpu_seconds=20, memory_bytes=2 * 2**30, wall_seconds=120)


def _stat_start(pid) -> int:
    """Field 22 of /proc/<pid>/stat, whatever the process's state (a zombie's too)."""
    return int(Path(f"/proc/{pid}/stat").read_bytes().rsplit(b")", 1)[1].split()[19])


def _victim(tmp_path) -> Path:
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "keep.txt").write_text("kept")
    return victim


def _intact(victim) -> bool:
    return (victim / "keep.txt").read_text() == "kept"


def test_names_are_read_exactly():
    """Only ``labkit-<kind>-<pid>-<start>-<random>`` of the kinds asked for names a maker; any other name is not
    labkit's (a kernel's odd names among them)."""
    me = owner_of(f"{_leftovers.owner_prefix('grade')}ab_12xyz", FOLDER_KINDS)
    assert me == (os.getpid(), process_start(os.getpid()))
    assert owner_of("labkit-run-12-345-abcdefgh", FOLDER_KINDS) == (12, 345)
    assert owner_of("labkit-mem-12-345-grader", ("mem",)) == (12, 345)
    for name in ("labkit-mem-12-345-abcdefgh", "labkit-grade-12-345-", "labkit-grade-012-345-abcdefgh",
                 "labkit-grade-12-345-abc/def", "labkit-grade-12-345-abcdefgh\n", "labkit-grade-12-345-ABCDEFGH",
                 "labkit-grade-12-345-abc.def", "labkit-grade-12-abcdefgh", "labkit-grade-12345678901-1-abcdefgh",
                 "labkit-12-abcdefgh", "labkit-grade--12-345-abcdefgh", "xlabkit-grade-12-345-abcdefgh",
                 "labkit-grade-١٢-345-abcdefgh", b"labkit-grade-12-345-abcdefgh", "labkit-grade-12-345-a b"):
        assert owner_of(name, FOLDER_KINDS) is None, name


def test_sweep_removes_only_dead_makers_folders_of_this_user(tmp_path, monkeypatch):
    """In a temporary folder: a dead maker's folder goes (links and odd names inside it removed, never followed, a
    tree deeper than Python's recursion limit too); a live maker's stays, as do a folder whose maker's pid now
    belongs to a later process (its start time differs: the maker is dead, so that one goes), a zombie's (dead:
    goes), a look-alike link to a folder elsewhere, a file, names not exactly labkit's, and another user's folder."""
    victim = _victim(tmp_path)
    place = tmp_path / "tmp"
    place.mkdir()
    sleeper = subprocess.Popen(["sleep", "600"])
    zombie = subprocess.Popen(["true"])
    try:
        deadline = time.monotonic() + 10
        while process_start(zombie.pid) is not None and time.monotonic() < deadline:
            time.sleep(0.02)  # exited, not yet reaped: a zombie
        live = (sleeper.pid, process_start(sleeper.pid))
        gone = {
            "dead": place / f"labkit-grade-{NO_SUCH_PID}-123-abcdefgh",
            "reused": place / f"labkit-task-{live[0]}-{live[1] + 1}-abcdefgh",
            "zombie": place / f"labkit-run-{zombie.pid}-{_stat_start(zombie.pid)}-abcdefgh",
        }
        kept = {
            "live": place / f"labkit-grade-{live[0]}-{live[1]}-abcdefgh",
            "mine": _leftovers.new_folder("render", place),
            "link": place / f"labkit-grade-{NO_SUCH_PID}-123-linkxxxx",
            "file": place / f"labkit-task-{NO_SUCH_PID}-123-filexxxx",
            "newline": place / f"labkit-grade-{NO_SUCH_PID}-123-abcdefgh\n",
            "cgroup kind": place / f"labkit-mem-{NO_SUCH_PID}-123-abcdefgh",
            "other user": place / f"labkit-baseline-{NO_SUCH_PID}-123-abcdefgh",
        }
        for path in [*gone.values(), kept["live"], kept["newline"], kept["cgroup kind"], kept["other user"]]:
            path.mkdir()
            (path / "f.txt").write_text("x")
        kept["link"].symlink_to(victim, target_is_directory=True)
        kept["file"].write_text("not a folder")
        dead = gone["dead"]
        (dead / "home").mkdir()
        (dead / "home" / "to_victim").symlink_to(victim, target_is_directory=True)
        (dead / "home" / "to_file").symlink_to(victim / "keep.txt")
        (dead / "home" / "odd\nname\x1b[31m").mkdir()
        os.mkfifo(dead / "home" / "fifo")
        os.close(at.deep_folder(dead / "home", 1500))
        os.chmod(dead / "home", 0o000)  # a kernel's chmod
        if os.geteuid() == 0:
            os.chown(kept["other user"], 65534, 65534)
        else:  # a folder cannot be given away: seen by another user, every folder here is someone else's
            real = os.geteuid
            monkeypatch.setattr(os, "geteuid", lambda: real() + 1)
            assert sweep(place, FOLDER_KINDS, remove_tree) == []
            monkeypatch.undo()
            gone["other user"] = kept.pop("other user")  # ours after all, and its maker is dead
        removed = sweep(place, FOLDER_KINDS, remove_tree)
        assert sorted(removed) == sorted(gone.values())
        assert not any(p.exists() for p in gone.values()), [p for p in gone.values() if p.exists()]
        assert all(os.path.lexists(p) for p in kept.values()), [p for p in kept.values() if not os.path.lexists(p)]
        assert kept["link"].is_symlink() and _intact(victim) and kept["file"].read_text() == "not a folder"
    finally:
        sleeper.kill()
        sleeper.wait()
        zombie.wait()
        for path in place.iterdir():
            if not path.is_symlink() and path.is_dir():
                remove_tree(path)


def test_remove_leftovers_looks_in_the_temporary_folder_and_the_short_ones(tmp_path, monkeypatch):
    """The sweep a batch starts with covers TMPDIR and /tmp, /var/tmp, /dev/shm (where a kernel's runtime folder
    goes when TMPDIR is too long), through a TMPDIR that is itself a link."""
    real = tmp_path / "real_tmp"
    real.mkdir()
    (tmp_path / "tmp_link").symlink_to(real, target_is_directory=True)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp_link"))
    there = real / f"labkit-task-{NO_SUCH_PID}-1-abcdefgh"
    there.mkdir()
    short = Path(next(p for p in TEMP_PLACES if os.access(p, os.W_OK))) / f"labkit-run-{NO_SUCH_PID}-1-{os.getpid()}"
    short.mkdir()
    try:
        removed = remove_leftovers()
        assert there in removed and short in removed and not there.exists() and not short.exists()
    finally:
        for path in (there, short):
            remove_tree(path)


def _leftovers_of(pids, *places) -> list:
    """The folders named after one of ``pids`` in ``places`` and the short temporary folders."""
    found = []
    for place in dict.fromkeys(map(str, (*places, *TEMP_PLACES))):
        try:
            names = os.listdir(place)
        except OSError:
            continue
        found += [Path(place) / n for n in names if (owner_of(n, FOLDER_KINDS) or (0,))[0] in pids]
    return sorted(found)


def _wait_for(predicate, timeout, what):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        found = predicate()
        if found:
            return found
        time.sleep(0.2)
    raise AssertionError(f"{what} never happened in {timeout} s")


def _kernel_running(private):
    """The pid of a pool worker whose kernel started: its grading folder holds a runtime folder."""
    for grade_folder in private.glob("labkit-grade-*"):
        owner = owner_of(grade_folder.name, FOLDER_KINDS)
        if owner and any(grade_folder.glob("labkit-run-*")):
            return owner[0]
    return None


def _lab(tmp_path, codes):
    """The tiny lab, and a submissions folder with one submission per ``{name: code}``."""
    require("nbgrader")
    from labkit.course import assign

    lab = cl.write_lab(tmp_path / "lab")
    if not (tmp_path / "student").exists():
        assign(lab, tmp_path / "student")
    subs = Path(tempfile.mkdtemp(prefix="subs-", dir=tmp_path))
    for name, code in codes.items():
        cl.write_submission(tmp_path / "student", subs / name, code)
    return lab, subs


@pytest.fixture
def private_tmp(monkeypatch):
    """A short TMPDIR of this test's own (its kernels' socket paths fit), for this process and the ones it starts."""
    private = Path(tempfile.mkdtemp(prefix="lk-", dir="/tmp"))
    monkeypatch.setenv("TMPDIR", str(private))
    monkeypatch.setattr(tempfile, "tempdir", None)
    try:
        yield private
    finally:
        remove_tree(private)


@pytest.mark.slow
@pytest.mark.xdist_group("grading-batches")  # kills graders outright (tests/course/test_attacks.py says why)
def test_a_killed_batchs_folders_are_removed_by_the_next_batch(tmp_path, private_tmp):
    """A grading batch killed outright (SIGKILL of its process group while a kernel runs) leaves its workers'
    folders; the next batch removes them as it starts, without following a link a kernel left in them, and leaves
    a live grader's folder and a look-alike link named after the dead worker."""
    psutil = require("psutil")
    from labkit.course import Limits, grade

    slow = cl.SOLUTION + "\nimport time\ntime.sleep(60)"
    lab, subs = _lab(tmp_path, {"slow_a": slow, "slow_b": slow})
    script = ("import sys\nfrom labkit.course import Limits, grade\n"
              f"grade({str(subs)!r}, {str(lab)!r}, {str(tmp_path / 'killed')!r}, limits=Limits(**{LIMITS!r}), "
              "jobs=2, progress=False, count_free=True)\n")
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))
    batch = subprocess.Popen([sys.executable, "-c", script], env=env, start_new_session=True)
    try:
        _wait_for(lambda: _kernel_running(private_tmp), 180, "a kernel start in the batch")
        killed = {batch.pid, *(p.pid for p in psutil.Process(batch.pid).children(recursive=True))}
        os.killpg(batch.pid, signal.SIGKILL)
    finally:
        if batch.poll() is None:
            os.killpg(batch.pid, signal.SIGKILL)
        batch.wait()
    left = _wait_for(lambda: _leftovers_of(killed, private_tmp), 10, "a leftover")
    assert {owner_of(p.name, FOLDER_KINDS) is not None for p in left} == {True}
    kinds = {p.name.split("-")[1] for p in left}
    assert {"task", "grade"} <= kinds, left
    victim = _victim(tmp_path)
    grading = next(p for p in left if p.name.startswith("labkit-grade-"))
    (grading / "home" / "escape").symlink_to(victim, target_is_directory=True)  # what a kernel could leave
    dead_pid, dead_start = owner_of(grading.name, FOLDER_KINDS)
    look_alike = private_tmp / f"labkit-grade-{dead_pid}-{dead_start}-zzzzzzzz"
    look_alike.symlink_to(victim, target_is_directory=True)
    live = subprocess.Popen(["sleep", "600"])  # a grader that still runs, with a folder of its own
    try:
        live_folder = private_tmp / f"labkit-task-{live.pid}-{process_start(live.pid)}-abcdefgh"
        (live_folder / "home").mkdir(parents=True)
        (live_folder / "home" / "work.txt").write_text("in use")
        print(f"\nfolders of the killed batch before the next batch: {len(left)} ({', '.join(sorted(kinds))})")
        lab, honest = _lab(tmp_path, {"honest": cl.SOLUTION})
        results = grade(honest, lab, tmp_path / "next", limits=Limits(**LIMITS), jobs=1, progress=False,
                        count_free=True)
        assert [(r.status, r.points) for r in results] == [("ok", 4)], results
        after = _leftovers_of(killed, private_tmp)
        print(f"folders of the killed batch after the next batch: {len(set(after) - {look_alike})} "
              "(and the look-alike link, kept)")
        assert after == [look_alike], after
        assert look_alike.is_symlink() and _intact(victim)
        assert (live_folder / "home" / "work.txt").read_text() == "in use"
        assert not [p for p in private_tmp.iterdir() if p not in (look_alike, live_folder)], list(private_tmp.iterdir())
    finally:
        live.kill()
        live.wait()


def _hold_a_folder(release):
    """A pool task (module level: pickled to a spawned worker): a folder of its own until ``release`` exists."""
    folder = _leftovers.new_folder("task")
    (folder / "work.txt").write_text("in use")
    deadline = time.monotonic() + 60
    while not os.path.exists(release) and time.monotonic() < deadline:
        time.sleep(0.05)
    remove_tree(folder)
    return os.getpid()


def test_a_killed_pool_workers_folders_go_when_the_driver_notices(tmp_path, private_tmp):
    """A worker of the local pool killed outright (SIGKILL) in the middle of a task: the driver reruns the task in a
    new pool and removes the dead worker's folders as soon as its pool is down, before the batch returns."""
    import threading

    from labkit.course import run_tasks

    release, killed = tmp_path / "release", []

    def kill_the_worker():
        def holder():
            return next((o[0] for o in map(lambda p: owner_of(p.name, FOLDER_KINDS), private_tmp.iterdir())
                         if o and o[0] != os.getpid()), None)

        killed.append(_wait_for(holder, 120, "a worker's folder"))
        os.kill(killed[0], signal.SIGKILL)
        release.touch()

    killer = threading.Thread(target=kill_the_worker, daemon=True)
    killer.start()
    done = run_tasks(_hold_a_folder, [(str(release),)], jobs=1, progress=False)
    killer.join(10)
    assert killed and done[0] != killed[0], (killed, done)  # the task ran again, in another worker
    assert _leftovers_of(set(killed), private_tmp) == [] and list(private_tmp.iterdir()) == []
