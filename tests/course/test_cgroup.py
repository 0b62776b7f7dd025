"""The submission's memory limit: a memory cgroup per run where one can be made, else the sampling watchdog."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import require
from labkit.course import memory_cgroup, memory_mechanism
from labkit.course._cgroup import _parents

# beside the attack batches (tests/course/test_attacks.py says why there are two groups): every cgroup check here
# looks only at the cgroups this test's own grader made, its orphan process has a name of its own
pytestmark = pytest.mark.xdist_group("grading-loop")


def _labkit_cgroups() -> set:
    return {p for _, parent in _parents() for p in parent.glob("labkit-*")}


def test_memory_cgroup_limits_kills_and_is_removed():
    """A process over the limit is OOM-killed and counted; removing the cgroup kills what is left in it."""
    cgroup = memory_cgroup(64 * 2**20)
    if cgroup is None:  # no writable, delegated memory controller here: the grader falls back and says so
        assert memory_mechanism() == "watchdog"
        return
    try:
        assert memory_mechanism() == cgroup.mechanism
        sleeper = subprocess.Popen([*cgroup.enter_prefix(), "sleep", "100"])
        deadline = time.monotonic() + 10
        while sleeper.pid not in cgroup.pids() and time.monotonic() < deadline:
            time.sleep(0.02)
        assert sleeper.pid in cgroup.pids()
        hog = subprocess.run([*cgroup.enter_prefix(), sys.executable, "-c", "b = bytearray(200 * 2**20)"])
        assert hog.returncode == -signal.SIGKILL and cgroup.oom_kills() == 1
        small = subprocess.run([*cgroup.enter_prefix(), sys.executable, "-c", "b = bytearray(8 * 2**20)"])
        assert small.returncode == 0 and cgroup.oom_kills() == 1
    finally:
        assert cgroup.remove()
    assert not cgroup.path.exists() and sleeper.wait(5) == -signal.SIGKILL


@pytest.mark.slow
def test_ctrl_c_removes_the_cgroup_and_the_sandbox(tmp_path):
    """Ctrl-C (SIGINT) during a run: the grader stops, its kernel is gone and so is its cgroup."""
    require("nbclient")
    before = _labkit_cgroups()
    script = ("import signal\nsignal.signal(signal.SIGINT, signal.default_int_handler)\n"  # as in a terminal
              "import nbformat\nfrom labkit.course import Limits, run_untrusted\n"
              "nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell("
              "'import subprocess, time\\nsubprocess.Popen([\"sleep\", str(987000 + 123)])\\nprint(\"started\", flush=True)"
              "\\ntime.sleep(60)')])\n"
              f"run_untrusted(nb, {str(tmp_path)!r}, limits=Limits(cpu_seconds=30, memory_bytes=2**30, "
              "wall_seconds=60))\n")
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))
    proc = subprocess.Popen([sys.executable, "-c", script], env=env, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not subprocess.run(["pgrep", "-f", "sleep 987123"],
                                                                 capture_output=True).stdout:
            time.sleep(0.1)
        assert subprocess.run(["pgrep", "-f", "sleep 987123"], capture_output=True).stdout, "the cell never ran"
        # the cgroups this run made: named after their creator, the grader process (other tests on the
        # other xdist worker may be making their own at the same time)
        mine = {p for p in _labkit_cgroups() - before if p.name.startswith(f"labkit-mem-{proc.pid}-")}
        assert len(mine) == (0 if memory_mechanism() == "watchdog" else 1), mine
        proc.send_signal(signal.SIGINT)
        code = proc.wait(30)
        assert code != 0, (code, proc.stderr.read().decode(errors="replace")[-3000:])  # KeyboardInterrupt
    finally:
        if proc.poll() is None:
            proc.kill()
    assert "KeyboardInterrupt" in proc.stderr.read().decode(errors="replace").strip().splitlines()[-1]
    assert not (mine & _labkit_cgroups()), "a cgroup outlived its run"
    assert not any(p.name.startswith(f"labkit-mem-{proc.pid}-") for p in _labkit_cgroups()), "a cgroup outlived its run"
    time.sleep(0.5)
    assert not subprocess.run(["pgrep", "-f", "sleep 987123"], capture_output=True).stdout, "a process outlived it"


@pytest.mark.slow
def test_watchdog_limits_forked_memory(tmp_path):
    """The fallback where no cgroup can be made: the sampling watchdog adds up the sandbox's processes."""
    nbformat = require("nbformat")
    from labkit.course import Limits, run_untrusted

    code = ("import os, time\nkids = []\nfor _ in range(4):\n    pid = os.fork()\n    if pid == 0:\n"
            "        ballast = bytearray(b'm') * (500 * 2**20)\n        time.sleep(20)\n        os._exit(0)\n"
            "    kids.append(pid)\nfor pid in kids:\n    os.waitpid(pid, 0)")
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(code), nbformat.v4.new_code_cell("print('after')")])
    t0 = time.monotonic()
    status, detail, mechanism = run_untrusted(nb, tmp_path, limits=Limits(
        cpu_seconds=30, memory_bytes=int(1.5 * 2**30), wall_seconds=60, cgroup=False))
    assert (status, mechanism) == ("memory", "watchdog"), detail
    assert "over the limit of 1.5 GiB" in detail and time.monotonic() - t0 < 40
    assert not nb.cells[1].get("outputs")
