"""labkit render and labkit grade on a dask.distributed cluster (a scheduler and two TCP workers on this machine)."""

import os
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest

from conftest import require
from tests.course import course_lab as cl

# with the attack batches (tests/course/test_attacks.py says why there are two groups): a test here kills a grader
# outright, whose cgroup outlives it until the next run sweeps it; one dask cluster (module fixture) for both tests
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("grading-batches")]
LIMITS = dict(cpu_seconds=4, memory_bytes=2 * 2**30, wall_seconds=120)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def dask_cluster(tmp_path_factory):
    """A dask scheduler and two workers (separate processes, TCP on 127.0.0.1), stopped afterwards."""
    require("distributed")
    tmp_path = tmp_path_factory.mktemp("dask")
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = dict(os.environ, DASK_DISTRIBUTED__WORKER__DAEMON="False")
    log = open(tmp_path / "dask.log", "wb")
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                               "--port", str(port), "--no-dashboard"], stdout=log, stderr=log, env=env)]
    try:
        from distributed import Client

        for i in range(2):
            procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address,
                                           "--nthreads", "1", "--no-nanny", "--no-dashboard", "--name", f"w{i}",
                                           "--local-directory", str(tmp_path / f"w{i}")],
                                          stdout=log, stderr=log, env=env))
        with Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=120)
        yield address, procs
    finally:
        for p in reversed(procs):  # the workers first (killed: nothing of theirs to save), then the scheduler
            if p.poll() is None:
                p.kill() if p is not procs[0] else p.terminate()
        for p in procs:
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        log.close()


def test_render_on_dask_sends_reports_back(tmp_path, dask_cluster):
    """labkit render --scheduler: notebooks shipped to the workers, reports and their files written by the driver."""
    nbformat = require("nbformat")
    from labkit.cli import main

    address, _ = dask_cluster
    nb = nbformat.v4.new_notebook(cells=[
        nbformat.v4.new_code_cell("output_dir = 'out'\nport = 'serial:///dev/ttyACM0'", metadata={"tags": ["parameters"]}),
        nbformat.v4.new_code_cell("import os, pathlib\npathlib.Path(output_dir).mkdir(parents=True, exist_ok=True)\n"
                                  "(pathlib.Path(output_dir) / 'made.txt').write_text(port)\nprint('worker pid', os.getpid())")])
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    (tmp_path / "labx").mkdir()
    for name in ("a", "b"):
        nbformat.write(nb, str(tmp_path / "labx" / f"{name}.ipynb"))
    out = tmp_path / "reports"
    assert main(["render", str(tmp_path / "labx"), "--scheduler", address, "--no-pdf", "-o", str(out),
                 "-p", "port", "sim://"]) == 0
    for name in ("a", "b"):
        assert "worker pid" in (out / "labx" / f"{name}.html").read_text()
        assert (out / "labx" / f"{name}_files" / "made.txt").read_text() == "sim://"
    index = (out / "index.html").read_text()
    assert "2 notebooks, 2 passed, 0 failed" in index


def test_grade_on_dask_survives_a_killed_worker(tmp_path, dask_cluster):
    """Grading on a real scheduler + 2 TCP workers; one worker is killed mid-batch: its task reruns elsewhere."""
    from distributed import Client

    from labkit.course import Limits, assign, grade

    require("nbgrader")
    lab, student = cl.write_lab(tmp_path / "lab"), tmp_path / "student"
    assign(lab, student)
    address, procs = dask_cluster
    subs = tmp_path / "submissions"
    codes = {f"s{i}": cl.SOLUTION if i % 2 == 0 else cl.SUBMISSIONS["partly_wrong"] for i in range(6)}
    for name, code in codes.items():
        cl.write_submission(student, subs / name, code)
    killed = {}

    def kill_busy_worker():
        with Client(address, timeout=30) as client:
            victim = procs[1]
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline and "tasks" not in killed:
                for worker, tasks in client.processing().items():
                    info = client.scheduler_info()["workers"].get(worker, {})
                    if tasks and info.get("name") == "w0":
                        killed["tasks"] = list(tasks)
                        victim.send_signal(signal.SIGKILL)
                        break
                time.sleep(0.05)

    killer = threading.Thread(target=kill_busy_worker)
    killer.start()
    results = grade(subs, lab, tmp_path / "feedback", limits=Limits(**LIMITS), scheduler=address, progress=False)
    killer.join()
    assert killed.get("tasks"), "the worker was never busy"
    assert procs[1].poll() is not None  # it is really dead
    assert [r.student for r in results] == sorted(codes)  # every submission once, none lost or twice
    for r in results:
        assert r.points == (4 if int(r.student[1:]) % 2 == 0 else 2), r
        assert (tmp_path / "feedback" / "students" / r.student / "index.html").is_file()
    assert sorted(p.name for p in (tmp_path / "feedback" / "students").iterdir() if p.is_dir()) == sorted(codes)
    assert not _orphaned_sandboxes(), "a sandbox of the killed worker outlived it"


def _orphaned_sandboxes(wait=10.0) -> list:
    """Command lines of this run's bubblewrap sandboxes whose grader is gone (handed to PID 1), after ``wait`` s."""
    import psutil

    marker, deadline = os.environ["LABKIT_TEST_SESSION"], time.monotonic() + wait
    while True:
        found = []
        for proc in psutil.process_iter():
            try:
                if proc.ppid() == 1 and proc.name() == "bwrap" and proc.environ().get("LABKIT_TEST_SESSION") == marker:
                    found.append(" ".join(proc.cmdline())[:200])
            except psutil.Error:
                continue
        if not found or time.monotonic() > deadline:
            return found
        time.sleep(0.2)
