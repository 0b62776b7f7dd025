"""The sandbox's sampling watchdog: its processes' CPU time, count and memory, and its RAM disks.

Every 0.1 s it adds up, over the sandbox's processes (the launched process's tree, or the memory
cgroup's list), their CPU time and, without a memory cgroup, their proportional set size plus
what the sandbox's ``/tmp`` and ``/dev/shm`` hold; over a limit it kills the whole sandbox and
records why. See :mod:`labkit.course._sandbox`.
"""

from __future__ import annotations

import os
import signal
import threading
from pathlib import Path

from labkit.exceptions import needs_extra

__all__ = ["Watchdog", "kill_tree"]


def _tree(pid) -> list:
    """``pid`` and all its descendants (psutil), [] once it is gone."""
    with needs_extra("course"):
        import psutil

    try:
        return [pid] + [child.pid for child in psutil.Process(pid).children(recursive=True)]
    except psutil.Error:
        return []


def _pss(pid) -> int:
    try:
        for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
            if line.startswith("Pss:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return 0


def stat_fields(pid) -> list:
    """The fields of ``/proc/<pid>/stat`` after the command name (which may hold spaces and parentheses).

    Parameters
    ----------
    pid : int

    Returns
    -------
    list of bytes
        ``[state, ppid, ...]``: field ``k`` of proc(5) (1-based) at index ``k - 3``.

    Raises
    ------
    OSError
        No such process (or no ``/proc``).
    """
    return Path(f"/proc/{int(pid)}/stat").read_bytes().rsplit(b")", 1)[1].split()


def _cpu(pid) -> float:
    try:
        fields = stat_fields(pid)
        return sum(int(f) for f in fields[11:15]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return 0.0


def _used(root, names) -> int:
    """Bytes used on the file system of folder ``names`` below the folder ``root`` (a descriptor), links refused."""
    fd = os.dup(root)
    try:
        for name in names:
            fd, parent = os.open(name, os.O_PATH | os.O_DIRECTORY | os.O_NOFOLLOW, dir_fd=fd), fd
            os.close(parent)
        st = os.fstatvfs(fd)
    finally:
        os.close(fd)
    return (st.f_blocks - st.f_bfree) * st.f_frsize


def _ram_disks(pids) -> int:
    """What the sandbox's ``/tmp`` and ``/dev/shm`` hold [bytes], seen through the first process inside its root.

    The first pid is bwrap outside the sandbox. A process bwrap has not yet moved into the sandbox's root (a
    busy machine stretches that moment) still sees the grader's root, whose ``/tmp`` is the host's (a disk
    of many GiB): it is skipped. Before any process is inside, 0.
    """
    host = os.stat("/")
    for pid in pids[1:]:
        try:
            root = os.open(f"/proc/{pid}/root", os.O_PATH | os.O_DIRECTORY)
        except OSError:
            continue
        try:
            seen = os.fstat(root)
            if (seen.st_dev, seen.st_ino) == (host.st_dev, host.st_ino):
                continue
            return sum(_used(root, path) for path in (("tmp",), ("dev", "shm")))
        except OSError:
            continue
        finally:
            os.close(root)
    return 0


class Watchdog(threading.Thread):
    """Every ``period`` s: the sandbox's CPU time, processes, and memory (without ``cgroup``: the sum of its
    processes' PSS and RAM disks; with it: the cgroup's OOM kills); kills the whole sandbox over a limit."""

    def __init__(self, proc, limits, period=0.1, sandboxed=True, cgroup=None):
        super().__init__(daemon=True)
        self.proc, self.limits, self.period, self.sandboxed, self.cgroup = proc, limits, period, sandboxed, cgroup
        self.reason, self.peak_memory, self.cpu, self.stop = None, 0, 0.0, threading.Event()

    def run(self):
        """Sample every ``period`` s until the sandbox ends, is killed over a limit, or ``stop`` is set."""
        while not self.stop.is_set() and self.proc.poll() is None:
            if self.check():
                return
            self.stop.wait(self.period)

    def check(self):
        """One sample (also the run's last, once its notebook has ended): over a limit, kill the sandbox.

        Returns
        -------
        tuple of (str, str) or None
            ``(status, detail)`` of the limit reached (also kept in ``reason``), else None.
        """
        if self.reason or self.proc.poll() is not None:
            return self.reason
        # the cgroup's list is one file read; psutil's tree scans all of /proc (every 0.1 s, per submission)
        pids = ([self.proc.pid] + [p for p in self.cgroup.pids() if p != self.proc.pid]) if self.cgroup \
            else _tree(self.proc.pid)
        memory = 0 if self.cgroup else sum(_pss(p) for p in pids) + (_ram_disks(pids) if self.sandboxed else 0)
        kills = self.cgroup.oom_kills() if self.cgroup else 0
        self.cpu = max(self.cpu, sum(_cpu(p) for p in pids))
        self.peak_memory = max(self.peak_memory, memory)
        reason = None
        if kills:
            reason = "memory", (f"the submission (its processes and RAM disks) reached the memory limit of "
                                f"{self.limits.memory_bytes / 2**30:g} GiB: the kernel's OOM killer killed "
                                f"{kills} process(es) ({self.cgroup.mechanism}), then the whole sandbox")
        elif memory > self.limits.memory_bytes:
            reason = "memory", (f"the submission used {memory / 2**30:.2f} GiB (processes and RAM disks), "
                                f"over the limit of {self.limits.memory_bytes / 2**30:g} GiB")
        elif self.cpu > self.limits.cpu_seconds:
            reason = "cpu-time", f"killed at the CPU-time limit of {self.limits.cpu_seconds:g} s"
        elif len(pids) - 1 > self.limits.max_processes:
            reason = "crash", f"more than {self.limits.max_processes} processes at once"
        if reason:
            self.reason = reason
            for p in reversed(pids):
                try:
                    os.kill(p, signal.SIGKILL)
                except OSError:
                    pass
            if self.cgroup:
                self.cgroup.kill()
        return reason


def kill_tree(pid) -> None:
    """SIGKILL ``pid`` and all its descendants (deepest first).

    Parameters
    ----------
    pid : int
    """
    for p in reversed(_tree(pid)):
        try:
            os.kill(p, signal.SIGKILL)
        except OSError:
            pass


def dies_with_this_process() -> list:
    """A command prefix that ties the command's life to this process (``exec``: no process of its own).

    bubblewrap's ``--die-with-parent`` takes effect only after it has made its namespaces (tens of
    milliseconds, longer under load); a grader or worker killed before then leaves the sandbox
    running with no parent. This prefix asks for SIGKILL on the parent's death (``setpriv
    --pdeathsig``) before anything else runs, then checks that the parent is still this process:
    if it died in between, the command never starts.

    Returns
    -------
    list of str
        ``["setpriv", "--pdeathsig", "KILL", "--", "/bin/sh", "-c", ..., "<this pid>"]``.
    """
    return ["setpriv", "--pdeathsig", "KILL", "--", "/bin/sh", "-c", '[ "$PPID" = "$0" ] && exec "$@"',
            str(os.getpid())]
