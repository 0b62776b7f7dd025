"""The sandbox's watchdog while a kernel starts: it reads only the sandbox's RAM disks, and a limit it enforces
before the kernel's first reply is what the result says.

On a busy machine bubblewrap takes a while to move the sandbox's first process into its own root; until then that
process sees the grader's root, whose ``/tmp`` is the host's (a disk of many GiB on CI). A watchdog that read the RAM
disks through it killed an honest kernel for "memory" before its first reply, twice (start and retry), and the
result said only that the kernel "did not start".
"""

import os
import subprocess
import sys
import time

import pytest

from conftest import require
from labkit.course._watchdog import _ram_disks, _tree, dies_with_this_process, kill_tree

# beside the attack batches (tests/course/test_attacks.py says why there are two groups)
pytestmark = pytest.mark.xdist_group("grading-loop")
MIB = 2**20


def _notebook(code="print(6 * 7)"):
    nbformat = require("nbformat")
    return nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(code)])


def _counted_watchdogs(monkeypatch) -> list:
    """The watchdogs the sandbox starts from now on (one per kernel started), in order."""
    from labkit.course import _sandbox

    starts = []

    class Counted(_sandbox.Watchdog):
        def start(self):
            starts.append(self)
            super().start()

    monkeypatch.setattr(_sandbox, "Watchdog", Counted)
    return starts


def test_ram_disks_are_read_inside_the_sandbox_only(tmp_path):
    """A process still on the grader's root is skipped; the sandbox's /tmp and /dev/shm are added up exactly."""
    from labkit.course._sandbox import sandbox_args

    (tmp_path / "home").mkdir()
    (tmp_path / "private").mkdir()
    host_side = subprocess.Popen(["sleep", "60"])  # what bwrap's child is until it enters the sandbox's root
    write = "head -c 3145728 /dev/zero > /tmp/a && head -c 1048576 /dev/zero > /dev/shm/b && echo ready && sleep 60"
    sandbox = subprocess.Popen([*sandbox_args(tmp_path / "home", tmp_path / "private", tmpfs_bytes=64 * MIB),
                                "/bin/sh", "-c", write], stdout=subprocess.PIPE, text=True)
    try:
        assert sandbox.stdout.readline().strip() == "ready"
        host = os.statvfs("/tmp")
        assert (host.f_blocks - host.f_bfree) * host.f_frsize != 4 * MIB  # the host's /tmp would show
        inside = _tree(sandbox.pid)
        assert len(inside) >= 3  # bwrap, bwrap in the sandbox, the shell (and its sleep)
        assert _ram_disks([inside[0], host_side.pid, *inside[1:]]) == 4 * MIB
        assert _ram_disks([inside[0], host_side.pid]) == 0
    finally:
        host_side.kill()
        kill_tree(sandbox.pid)
        host_side.wait()
        sandbox.wait()
        sandbox.stdout.close()


def test_an_honest_kernel_starts_while_bubblewrap_is_slow(tmp_path, monkeypatch):
    """A slow start (a child outside the sandbox for 0.5 s, five of the watchdog's samples) under the watchdog's
    memory limit: graded ok at the first start. Reading the host's /tmp through that child killed it (where the
    host's /tmp holds more than the limit, as on CI)."""
    from labkit.course import Limits, run_untrusted
    from labkit.course import _sandbox

    slow = tmp_path / "bin" / "bwrap"
    slow.parent.mkdir()
    slow.write_text(f'#!/bin/sh\nsleep 0.5\nexec {_sandbox.shutil.which("bwrap")} "$@"\n')
    slow.chmod(0o755)
    monkeypatch.setenv("PATH", f"{slow.parent}{os.pathsep}{os.environ['PATH']}")
    starts = _counted_watchdogs(monkeypatch)
    nb = _notebook()
    (tmp_path / "work").mkdir()
    result = run_untrusted(nb, tmp_path / "work", limits=Limits(cpu_seconds=20, memory_bytes=int(1.5 * 2**30),
                                                                wall_seconds=60, cgroup=False))
    assert result.status == "ok", result.detail
    assert nb.cells[0].outputs[0]["text"].strip() == "42"
    assert len(starts) == 1 and starts[0].reason is None  # no kill, no second start


@pytest.mark.parametrize("limit", ["cpu-time", "processes"])
def test_a_limit_hit_before_the_first_reply_is_the_result(tmp_path, monkeypatch, limit):
    """A kernel killed at a limit while it starts is graded for that limit, not as a kernel that "did not start",
    and is not started twice. Start-up costs are simulated with a launcher (students cannot change it)."""
    from labkit.course import Limits, run_untrusted
    from labkit.course import _sandbox

    if limit == "cpu-time":  # burns CPU before the kernel exists: the watchdog stops it at 0.3 s (else RLIMIT_CPU, 1 s)
        monkeypatch.setattr(_sandbox, "KERNEL_MAIN", "import time\nt = time.process_time()\n"
                            "while time.process_time() - t < 30:\n    pass\n" + _sandbox.KERNEL_MAIN)
        limits, expected = Limits(cpu_seconds=0.3, wall_seconds=60), ("cpu-time", "killed at the CPU-time limit of 0.3 s")
    else:  # bwrap, bwrap in the sandbox and the kernel: three processes, the limit is one
        limits, expected = Limits(max_processes=1, wall_seconds=60), ("crash", "more than 1 processes at once")
    starts = _counted_watchdogs(monkeypatch)
    (tmp_path / "work").mkdir()
    nb = _notebook()
    t0 = time.monotonic()
    status, detail, _ = run_untrusted(nb, tmp_path / "work", limits=limits)
    assert (status, detail) == expected
    assert not nb.cells[0].get("outputs") and time.monotonic() - t0 < 30
    if limit == "processes":  # the watchdog's kill, seen at its first sample of the three: no second start
        assert [dog.reason for dog in starts] == [expected]


def test_processes_over_the_limit_as_the_notebook_ends_count(tmp_path, monkeypatch):
    """The watchdog samples once more when the notebook has ended: 40 processes started by the last cell are over the
    limit of 32 however the samples fell (one at the start here, the next an hour later: a loaded machine's worst)."""
    from labkit.course import Limits, _sandbox, run_untrusted

    class Slow(_sandbox.Watchdog):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **{**kwargs, "period": 3600})

    monkeypatch.setattr(_sandbox, "Watchdog", Slow)
    nb = _notebook("import subprocess\nps = [subprocess.Popen(['sleep', '30']) for _ in range(40)]")
    status, detail, _ = run_untrusted(nb, tmp_path, limits=Limits(cpu_seconds=20, memory_bytes=2 * 2**30,
                                                                  wall_seconds=60))
    assert (status, detail) == ("crash", "more than 32 processes at once"), detail


def test_a_command_tied_to_the_grader_never_starts_once_the_grader_is_gone(tmp_path):
    """The guard's check: run by this process the command starts; run on behalf of a parent that is not its
    parent (the grader died before the guard looked: the command was handed to PID 1) it never does."""
    guard = dies_with_this_process()
    assert guard[-1] == str(os.getpid())
    subprocess.run([*guard, "touch", str(tmp_path / "ran")], check=True, timeout=30)
    assert (tmp_path / "ran").exists()
    orphaned = subprocess.run([*guard[:-1], "1", "touch", str(tmp_path / "orphan")], timeout=30)
    assert orphaned.returncode != 0 and not (tmp_path / "orphan").exists()


def test_a_command_tied_to_the_grader_dies_when_the_grader_is_killed():
    """A grader SIGKILLed while its command runs (a dask worker killed mid-batch) takes the command with it."""
    grader = subprocess.Popen([sys.executable, "-c", (
        "import os, signal, subprocess, sys\n"
        "from labkit.course._watchdog import dies_with_this_process\n"
        "child = subprocess.Popen([*dies_with_this_process(), 'sleep', '977'])\n"
        "print(child.pid, flush=True)\n"
        "sys.stdin.readline()\n"
        "os.kill(os.getpid(), signal.SIGKILL)\n")], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    pid = int(grader.stdout.readline())
    try:
        _killed_grader_takes_along(grader, pid)
    finally:
        grader.kill()
        grader.wait()
        kill_tree(pid)


def _killed_grader_takes_along(grader, pid):
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and "sleep" not in _cmdline(pid):  # the guard has exec'd the command
        time.sleep(0.02)
    assert "977" in _cmdline(pid)
    grader.stdin.write("\n")
    grader.stdin.flush()
    assert grader.wait(10) == -9
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and _cmdline(pid):
        time.sleep(0.02)
    assert not _cmdline(pid), "the command outlived its grader"


def _cmdline(pid) -> str:
    try:
        return open(f"/proc/{pid}/cmdline", "rb").read().replace(b"\0", b" ").decode()
    except OSError:
        return ""
