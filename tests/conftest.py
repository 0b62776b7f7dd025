"""Shared pytest configuration.

``require(name)`` imports an optional dependency. Locally it skips the test when
the dependency is missing; under ``LABKIT_REQUIRE_ALL=1`` (set by ``make test``,
hence CI) a missing dependency is an error, so CI never silently skips.
"""

import importlib
import os

import matplotlib
import pytest

matplotlib.use("Agg")

REQUIRE_ALL = os.environ.get("LABKIT_REQUIRE_ALL") == "1"


def require(name):
    """Import module ``name`` or skip (locally) / fail (CI)."""
    if REQUIRE_ALL:
        return importlib.import_module(name)
    return pytest.importorskip(name)


@pytest.fixture
def rng():
    """A seeded random generator (same numbers every run)."""
    import numpy as np

    return np.random.default_rng(12345)


# --- no process outlives the suite -------------------------------------------------------------------------------
# Every process the tests start (kernels, bwrap sandboxes, JupyterLab, dask workers, simavr, emulators, ...) inherits
# this marker in its environment (set here, before xdist starts its workers). When the whole run ends, the process
# that ran it (the xdist controller, or pytest alone) looks for processes still alive that carry the marker, descend
# from one that does or from pytest itself, or name the run's temporary folder on their command line: the run fails
# and names each (then stops them, so a leak never lingers on the machine).
SESSION_MARKER = "LABKIT_TEST_SESSION"
if not (os.environ.get("PYTEST_XDIST_WORKER") and os.environ.get(SESSION_MARKER, "").split("-")[0] == str(os.getppid())):
    os.environ[SESSION_MARKER] = f"{os.getpid()}-{os.urandom(4).hex()}"  # a run of its own (also a pytest a test runs)
#: seconds the processes get to finish stopping after the last test (a kernel shutting down, a worker exiting)
LINGER_SECONDS = float(os.environ.get("LABKIT_TEST_LINGER", "15"))


def _leftover_processes(marker, basetemp):
    """psutil.Process objects of this run still alive (not this process, not its ancestors)."""
    import psutil

    me = psutil.Process()
    spared = {me.pid} | {p.pid for p in me.parents()}
    found = {}

    def add(proc):
        try:
            if proc.pid not in spared and proc.is_running() and proc.status() != psutil.STATUS_ZOMBIE:
                found[proc.pid] = proc
                for child in proc.children(recursive=True):
                    if child.pid not in spared:
                        found[child.pid] = child
        except psutil.Error:
            pass

    for child in me.children(recursive=True):
        add(child)
    for proc in psutil.process_iter():
        if proc.pid in spared or proc.pid in found:
            continue
        try:
            if proc.environ().get(SESSION_MARKER) == marker or (basetemp and any(
                    arg == basetemp or basetemp + "/" in arg for arg in proc.cmdline())):
                add(proc)
        except psutil.Error:  # gone, a zombie, or another user's process
            continue
    return [p for p in found.values() if p.is_running() and p.status() != psutil.STATUS_ZOMBIE
            and not _ends_with(me, p)]


def _ends_with(me, proc):
    """True for multiprocessing's helpers of this very process (resource tracker, forkserver): they exit with it."""
    import psutil

    try:
        return proc.ppid() == me.pid and any(f"multiprocessing.{name} import main" in " ".join(proc.cmdline())
                                             for name in ("resource_tracker", "forkserver"))
    except psutil.Error:
        return False


def _describe(proc):
    try:
        cmd = " ".join(proc.cmdline()) or proc.name()
        test = proc.environ().get("PYTEST_CURRENT_TEST", "").rsplit(" ", 1)[0]  # the test that started it, if known
        return f"pid {proc.pid} (parent {proc.ppid()}){f', started by {test}' if test else ''}: {cmd[:300]}"
    except Exception:  # noqa: BLE001 - gone while we looked
        return f"pid {proc.pid}"


@pytest.hookimpl(trylast=True)  # after xdist has stopped its workers
def pytest_sessionfinish(session, exitstatus):
    """Fail the run if a process the tests started is still alive, naming it."""
    import time

    import psutil

    if hasattr(session.config, "workerinput"):  # an xdist worker: the controller checks once, at the very end
        return
    try:
        basetemp = str(session.config._tmp_path_factory.getbasetemp())
    except Exception:  # noqa: BLE001 - no temporary folder made
        basetemp = None
    marker = os.environ[SESSION_MARKER]
    deadline = time.monotonic() + LINGER_SECONDS
    left = _leftover_processes(marker, basetemp)
    while left and time.monotonic() < deadline:
        time.sleep(0.5)
        left = _leftover_processes(marker, basetemp)
    if not left:
        return
    session.config._labkit_leftovers = [_describe(p) for p in left]
    for proc in left:
        try:
            proc.kill()
        except psutil.Error:
            pass
    session.exitstatus = pytest.ExitCode.TESTS_FAILED


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    """Name the processes that outlived the suite (found by :func:`pytest_sessionfinish`)."""
    left = getattr(config, "_labkit_leftovers", None)
    if left:
        terminalreporter.section("processes that outlived the suite", sep="=", red=True, bold=True)
        terminalreporter.write_line(f"{len(left)} process(es) started by the tests were still alive at the end "
                                    f"(stopped now; the run fails):")
        for line in left:
            terminalreporter.write_line("  " + line)
