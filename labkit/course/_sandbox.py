"""Executing an untrusted notebook: a Jupyter kernel in an allow-list bubblewrap sandbox with limits.

The notebook client (nbclient) runs in the grading process; the kernel, where the
student's code runs, is started as ``prlimit --cpu --as --fsize -- bwrap ... -- python -m
ipykernel_launcher``. The sandbox shows **only what the kernel needs**:

* read-only: ``/usr`` (and the ``/bin``, ``/lib`` links into it), a few files of ``/etc``
  (loader cache, time zone, fonts, alternatives, passwd), the Python installation
  (``sys.prefix``, ``sys.base_prefix``, the site-packages folders) and the labkit package;
* read-write: its own copy of the submission, at :data:`SANDBOX_HOME` (also ``$HOME`` and
  the working directory), and a private folder holding the kernel's connection file and
  its Unix sockets (jupyter_client's ``ipc`` transport: no TCP port at all);
* RAM disks ``/tmp`` and ``/dev/shm`` of a bounded size, a private ``/proc`` and ``/dev``;
* nothing else: not the lab folder, other submissions, the feedback folder, ``/tmp``,
  ``/var``, ``/srv``, ``/opt``, ``/run`` or ``$HOME`` of the host, wherever they are;
  folders in ``hide`` are emptied even if they lie inside a bound path.

New user, PID, IPC, UTS, cgroup and network namespaces (no network, no abstract Unix
sockets of the host), no capabilities, a new session, killed with the grader.

**Limits** (:class:`Limits`): memory for the whole sandbox by a memory cgroup made for
the run (:mod:`labkit.course._cgroup`: every process of the submission is born in it and
its RAM disks are charged to it; the kernel's OOM killer enforces it, exactly); where no
cgroup can be made, a watchdog in the grader that every 0.1 s adds up the proportional
set size of every process in the sandbox plus what its ``/tmp`` and ``/dev/shm`` hold
(a fast burst can overshoot it between two samples). Also ``RLIMIT_CPU`` and
``RLIMIT_AS`` per process, the watchdog's CPU time and process count of the whole
sandbox, and a per-cell and per-notebook wall clock. See ``docs/course.md``.

Example
-------
>>> from labkit.course import Limits
>>> Limits(cpu_seconds=30, memory_bytes=2 * 2**30, wall_seconds=120).memory_bytes
2147483648
"""

from __future__ import annotations

import asyncio
import atexit
import os
import shutil
import signal
import site
import subprocess
import sys
import sysconfig
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

from labkit.exceptions import LabkitError, needs_extra
from labkit.course._cgroup import memory_cgroup
from labkit.reports import kernel_manager_class

__all__ = ["Limits", "RunResult", "RunStatus", "SANDBOX_HOME", "run_untrusted", "sandbox_args"]

#: outcomes of one execution (RunStatus values)
RunStatus = ("ok", "error", "timeout", "cpu-time", "memory", "crash")
#: where the submission's copy appears inside the sandbox (its $HOME and working directory)
SANDBOX_HOME = "/home/student"
_ETC = ("ld.so.cache", "ld.so.conf", "ld.so.conf.d", "localtime", "fonts", "alternatives", "passwd", "group",
        "nsswitch.conf", "mime.types")
#: largest output a cell may send to the grader [bytes]; more is dropped with a note
MAX_CELL_OUTPUT = 2 * 2**20


@dataclass(frozen=True)
class Limits:
    """Resource limits of one notebook execution.

    Attributes
    ----------
    cpu_seconds : float
        CPU time of the whole sandbox [s] (every process; ``RLIMIT_CPU`` per process too).
    memory_bytes : int
        Memory of the whole sandbox [bytes]: everything its processes and RAM disks hold
        (``RLIMIT_AS`` per process too; under a memory cgroup 1 GiB more, for the address space
        a process reserves without using it: thread stacks, allocator arenas, mapped libraries).
    wall_seconds : float
        Wall time of the whole notebook [s]; also the per-cell timeout.
    sandbox : bool
        Run the kernel in bubblewrap (False: limits only, for machines without it).
    max_processes : int
        Processes at once in the sandbox.
    cgroup : bool
        Enforce ``memory_bytes`` with a memory cgroup where one can be made (False: always
        the sampling watchdog).
    """

    cpu_seconds: float = 120.0
    memory_bytes: int = 4 * 2**30
    wall_seconds: float = 300.0
    sandbox: bool = True
    max_processes: int = 32
    cgroup: bool = True

    def __post_init__(self):
        for name in ("cpu_seconds", "memory_bytes", "wall_seconds", "max_processes"):
            value = getattr(self, name)
            if not value > 0:
                raise LabkitError(f"expected {name} > 0, got {value!r}")

    @property
    def tmpfs_bytes(self) -> int:
        """Size of each RAM disk under the watchdog [bytes]: an eighth of the memory, at most 256 MiB.

        Under a memory cgroup each RAM disk may grow to ``memory_bytes``: what it holds is charged
        to the cgroup with the processes' memory.
        """
        return int(min(256 * 2**20, self.memory_bytes // 8))

class RunResult(NamedTuple):
    """Outcome of :func:`run_untrusted`.

    Attributes
    ----------
    status : str
        One of :data:`RunStatus`.
    detail : str
        One line on what happened.
    memory_limit : str
        How the memory limit was enforced: ``"cgroup v2"``, ``"cgroup v1"`` or ``"watchdog"``.
    """

    status: str
    detail: str
    memory_limit: str = "watchdog"


def _python_roots() -> list:
    """The folders of the Python installation the kernel runs from (site-packages included)."""
    roots = [sys.prefix, sys.base_prefix, sys.exec_prefix, os.path.dirname(os.path.realpath(sys.executable))]
    paths = sysconfig.get_paths()
    roots += [paths.get(k) for k in ("stdlib", "platstdlib", "purelib", "platlib")]
    roots += list(site.getsitepackages()) + [site.getusersitepackages()]
    return [p for p in roots if p]


def labkit_root() -> Path:
    """The folder holding the ``labkit`` package.

    Returns
    -------
    pathlib.Path
        site-packages, or a checkout's root for an editable install or a worktree.
    """
    return Path(__file__).resolve().parents[2]


def sandbox_args(home, private, hide=(), *, limits=None, writable_home=True, tmpfs_bytes=None) -> list:
    """The ``bwrap`` command prefix of the allow-list sandbox (ends with ``--``).

    Parameters
    ----------
    home : path-like
        The host folder shown at :data:`SANDBOX_HOME` (the submission's copy).
    private : path-like
        A host folder shown at the same path, read-write (connection file, sockets).
    hide : sequence of path-like
        Folders to empty even if a bound path holds them.
    limits : Limits, optional
        For the size of the RAM disks.
    writable_home : bool
        Bind ``home`` read-write (the kernel) or read-only (the checker).
    tmpfs_bytes : int, optional
        Size of each RAM disk [bytes] (default ``limits.tmpfs_bytes``).

    Returns
    -------
    list of str

    Raises
    ------
    LabkitError
        If bubblewrap is not installed.
    """
    bwrap = shutil.which("bwrap")
    if bwrap is None:
        raise LabkitError("the grading sandbox needs bubblewrap (Debian package 'bubblewrap', command 'bwrap'); "
                          "install it or grade with sandbox=False (--no-sandbox)")
    limits = limits or Limits()
    tmpfs = str(int(tmpfs_bytes if tmpfs_bytes is not None else limits.tmpfs_bytes))
    home, private = Path(home).resolve(), Path(private).resolve()
    args = [bwrap, "--unshare-all", "--die-with-parent", "--new-session", "--cap-drop", "ALL", "--clearenv"]
    # the RAM disks first: a bind below /tmp (a venv, a checkout) must land on top of them, not under
    args += ["--proc", "/proc", "--dev", "/dev", "--size", tmpfs, "--tmpfs", "/tmp",
             "--size", tmpfs, "--tmpfs", "/dev/shm", "--ro-bind", "/usr", "/usr"]
    for top in ("bin", "sbin", "lib", "lib32", "lib64", "libx32"):
        p = Path("/") / top
        if p.is_symlink():
            args += ["--symlink", os.readlink(p), str(p)]
        elif p.is_dir():
            args += ["--ro-bind", str(p), str(p)]
    for name in _ETC:
        args += ["--ro-bind-try", f"/etc/{name}", f"/etc/{name}"]
    bound = [Path("/usr")]
    for root in sorted({Path(p).resolve() for p in _python_roots()} | {labkit_root() / "labkit"}):
        if root.exists() and not any(b == root or b in root.parents for b in bound):
            args += ["--ro-bind", str(root), str(root)]
            bound.append(root)
    for path in hide:
        path = Path(path).resolve()
        if path.is_dir() and any(b == path or b in path.parents for b in bound):
            args += ["--tmpfs", str(path)]
    args += ["--bind" if writable_home else "--ro-bind", str(home), SANDBOX_HOME,
             "--bind", str(private), str(private), "--chdir", SANDBOX_HOME]
    env = {"PATH": f"{os.path.dirname(sys.executable)}:/usr/local/bin:/usr/bin:/bin", "HOME": SANDBOX_HOME,
           "USER": "student", "LOGNAME": "student", "LANG": "C.UTF-8", "MPLCONFIGDIR": str(private / "mpl"),
           "IPYTHONDIR": str(private / "ipython"), "JUPYTER_RUNTIME_DIR": str(private),
           "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "PYDEVD_DISABLE_FILE_VALIDATION": "1", "TMPDIR": "/tmp"}
    if labkit_root().name not in ("site-packages", "dist-packages"):  # a checkout: its root on the path
        env["PYTHONPATH"] = str(labkit_root())
    for key, value in env.items():
        args += ["--setenv", key, value]
    return args + ["--"]


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


def _cpu(pid) -> float:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return sum(int(f) for f in fields[11:15]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return 0.0


def _ram_disks(pids) -> int:
    for pid in pids[1:]:  # the first is bwrap outside the sandbox
        try:
            return sum((st.f_blocks - st.f_bfree) * st.f_frsize
                       for st in (os.statvfs(f"/proc/{pid}/root/tmp"), os.statvfs(f"/proc/{pid}/root/dev/shm")))
        except OSError:
            continue
    return 0


class _Watchdog(threading.Thread):
    """Every ``period`` s: the sandbox's CPU time, processes, and memory (without ``cgroup``: the sum of its
    processes' PSS and RAM disks; with it: the cgroup's OOM kills); kills the whole sandbox over a limit."""

    def __init__(self, proc, limits, period=0.1, sandboxed=True, cgroup=None):
        super().__init__(daemon=True)
        self.proc, self.limits, self.period, self.sandboxed, self.cgroup = proc, limits, period, sandboxed, cgroup
        self.reason, self.peak_memory, self.cpu, self.stop = None, 0, 0.0, threading.Event()

    def run(self):
        while not self.stop.is_set() and self.proc.poll() is None:
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
                return
            self.stop.wait(self.period)


def _client_class():
    with needs_extra("course"):
        from nbclient import NotebookClient

    class CappedClient(NotebookClient):
        """Keeps at most :data:`MAX_CELL_OUTPUT` bytes of output per cell (the rest is dropped, with a note)."""

        def output(self, outs, msg, display_id, cell_index):
            size = sum(len(str(o)) for o in outs)
            if size > MAX_CELL_OUTPUT:
                if not any(o.get("name") == "labkit-truncated" for o in outs):
                    with needs_extra("course"):
                        from nbformat.v4 import new_output

                    outs.append(new_output("stream", name="stderr", text="[labkit grade: further output dropped]\n"))
                    outs[-1]["name"] = "labkit-truncated"
                return None
            return super().output(outs, msg, display_id, cell_index)

    return CappedClient


def _kernel_manager(work: Path, private: Path, limits: Limits, hide, cgroup=None):
    base = kernel_manager_class()
    cpu = int(max(1, round(limits.cpu_seconds)))
    address_space = int(limits.memory_bytes) + (2**30 if cgroup is not None else 0)
    prefix = cgroup.enter_prefix() if cgroup is not None else []
    prefix += ["prlimit", f"--cpu={cpu}:{cpu + 5}", f"--as={address_space}",
               f"--fsize={int(max(limits.memory_bytes, 2**30))}", "--"]
    if limits.sandbox:
        tmpfs = limits.memory_bytes if cgroup is not None else limits.tmpfs_bytes
        prefix += sandbox_args(work, private, hide, limits=limits, tmpfs_bytes=tmpfs)
    launched, dogs = [], []

    class SandboxedKernelManager(base):
        def format_kernel_cmd(self, extra_arguments=None):
            cmd = [sys.executable if c in ("python", "python3", "{python}") else c
                   for c in super().format_kernel_cmd(extra_arguments)]
            return [*prefix, *cmd]  # sh execs prlimit execs bwrap: the launched process is the sandbox

        async def _async_launch_kernel(self, kernel_cmd, **kw):
            kw["stdout"] = subprocess.DEVNULL  # ipykernel's banner; the notebook's output goes over ZMQ
            log = open(private / "kernel.log", "ab")  # noqa: SIM115 - closed by run_untrusted
            launched.append(log)
            kw["stderr"] = log
            kw["cwd"] = str(work)  # the host side; bwrap changes to SANDBOX_HOME inside
            await super()._async_launch_kernel(kernel_cmd, **kw)
            launched.insert(0, self.provisioner.process)
            dogs.append(_Watchdog(self.provisioner.process, limits, sandboxed=limits.sandbox, cgroup=cgroup))
            dogs[-1].start()

    km = SandboxedKernelManager(transport="ipc", ip=str(private / "kernel"),
                                connection_file=str(private / "kernel.json"))
    return km, launched, dogs


def _stop(launched, dogs):
    """Stop the watchdogs, kill whatever of the sandbox is left, close the logs."""
    for dog in dogs:
        dog.stop.set()
    procs = [p for p in launched if hasattr(p, "poll")]
    for proc in procs:
        if proc.poll() is None:
            for p in reversed(_tree(proc.pid)):
                try:
                    os.kill(p, signal.SIGKILL)
                except OSError:
                    pass
            proc.wait()
    for item in launched:
        if hasattr(item, "close"):
            item.close()


def _memory_error(nb) -> bool:
    return any("MemoryError" in str(o.get("ename", "")) for c in nb.cells for o in c.get("outputs", [])
               if o.get("output_type") == "error")


def run_untrusted(nb, work, *, limits=None, hide=(), private=None) -> RunResult:
    """Execute ``nb`` (in place) with its kernel sandboxed on ``work``; never raises for student code.

    Parameters
    ----------
    nb : nbformat.NotebookNode
        The notebook to execute (outputs are written into it).
    work : str or os.PathLike
        The submission's working copy (shown at :data:`SANDBOX_HOME`; the only writable folder).
    limits : Limits, optional
        Resource limits (default :class:`Limits`).
    hide : sequence of path-like
        Folders the kernel must not see even where a bound path holds them.
    private : str or os.PathLike, optional
        The kernel's private folder (default: a new temporary folder, removed afterwards).

    Returns
    -------
    RunResult
        The status (one of :data:`RunStatus`: ``"ok"``, ``"error"`` for an exception in some
        cell, ``"timeout"``, ``"cpu-time"``, ``"memory"`` for a process the memory cgroup's OOM
        killer or the watchdog killed or an allocation over ``RLIMIT_AS``, ``"crash"`` for a
        kernel that died otherwise), a one-line detail, and how memory was limited.

    Raises
    ------
    LabkitError
        If the sandbox cannot be set up (bubblewrap missing).
    """
    limits = limits or Limits()
    cgroup = memory_cgroup(limits.memory_bytes) if limits.cgroup else None
    mechanism = cgroup.mechanism if cgroup is not None else "watchdog"
    try:
        status, detail = _execute(nb, work, limits, hide, private, cgroup)
        kills = cgroup.oom_kills() if cgroup is not None else 0
        if kills and status != "memory":
            status, detail = "memory", (f"the submission (its processes and RAM disks) reached the memory limit of "
                                        f"{limits.memory_bytes / 2**30:g} GiB: {kills} process(es) killed ({mechanism})")
        return RunResult(status, detail, mechanism)
    finally:
        if cgroup is not None:
            cgroup.remove()


def _execute(nb, work, limits, hide, private, cgroup):
    """:func:`run_untrusted`'s run in ``cgroup`` (None: the watchdog limits memory); (status, detail)."""
    with needs_extra("course"):
        from nbclient.exceptions import CellTimeoutError, DeadKernelError

    work = Path(work).resolve()
    own = private is None
    private = Path(tempfile.mkdtemp(prefix="labkit-kernel-")) if own else Path(private)
    launched, dogs, client = [], [], None
    try:
        (private / "mpl").mkdir(exist_ok=True)
        cache = Path(os.path.expanduser("~/.cache/matplotlib"))
        for font_list in cache.glob("fontlist-*.json"):  # no font-cache rebuild in every sandbox
            shutil.copy2(font_list, private / "mpl" / font_list.name)
        cwd = SANDBOX_HOME if limits.sandbox else str(work)
        km = None

        def prepare():
            nonlocal km, client, launched, dogs
            if client is not None:
                atexit.unregister(client._cleanup_kernel)
            km, launched, dogs = _kernel_manager(work, private, limits, hide, cgroup)
            client = _client_class()(nb, km=km, timeout=int(limits.wall_seconds), allow_errors=True,
                                     startup_timeout=60, resources={"metadata": {"path": cwd}})

        interrupted = []

        async def go():
            loop = asyncio.get_running_loop()
            add = loop.add_signal_handler

            def recording(sig, callback, *args):  # nbclient's SIGINT/SIGTERM handler stops the kernel, and we note it
                def handler():
                    interrupted.append(sig)
                    callback(*args)
                return add(sig, handler)

            loop.add_signal_handler = recording
            await asyncio.wait_for(client.async_execute(), limits.wall_seconds)

        def run():
            """``asyncio.run(go())``; Ctrl-C (SIGTERM) raises KeyboardInterrupt (SystemExit) so the grader stops
            (nbclient's handler only stops the kernel: the submission would be graded "crash" and the batch go on)."""
            try:
                asyncio.run(go())
            except BaseException:
                if interrupted:
                    raise (KeyboardInterrupt() if interrupted[0] == signal.SIGINT
                           else SystemExit(128 + interrupted[0])) from None
                raise
            if interrupted:
                raise KeyboardInterrupt() if interrupted[0] == signal.SIGINT else SystemExit(128 + interrupted[0])

        prepare()

        def reason():
            return dogs[0].reason if dogs and dogs[0].reason else None

        timed_out = ("timeout", f"stopped after the wall-clock limit of {limits.wall_seconds:g} s")
        t0 = time.monotonic()
        try:
            try:
                run()
            except RuntimeError as exc:  # the kernel did not start (a busy machine): once more, afresh
                if "kernel" not in str(exc).lower() or any(c.get("execution_count") for c in nb.cells
                                                           if c.cell_type == "code"):
                    raise
                _stop(launched, dogs)
                prepare()
                t0 = time.monotonic()
                run()
        except (asyncio.TimeoutError, CellTimeoutError):
            return (reason() or timed_out)
        except DeadKernelError:
            if reason():
                return reason()
            if time.monotonic() - t0 >= limits.wall_seconds:
                return timed_out
            try:
                code = launched[0].wait(timeout=10) if launched and hasattr(launched[0], "wait") else None
            except subprocess.TimeoutExpired:
                code = None
            if code == 128 + signal.SIGXCPU or (dogs and dogs[0].cpu >= 0.9 * limits.cpu_seconds):
                return "cpu-time", f"killed at the CPU-time limit of {limits.cpu_seconds:g} s"
            return ("memory" if _memory_error(nb) else "crash"), f"the kernel died (exit status {code})"
        except RuntimeError as exc:  # kernel failed to start
            try:
                tail = " ".join((private / "kernel.log").read_text(errors="replace").strip().splitlines()[-2:])
            except OSError:
                tail = ""
            return "crash", f"the kernel did not start: {type(exc).__name__}: {exc} {tail}"[:400]
        if reason():
            return reason()
        if _memory_error(nb):
            return "memory", f"an allocation exceeded the memory limit of {limits.memory_bytes / 2**30:g} GiB"
        for cell in nb.cells:
            for out in cell.get("outputs", []):
                if out.get("output_type") == "error":
                    return "error", f"{out.get('ename')}: {out.get('evalue', '')}"[:300]
        return "ok", ""
    finally:
        _stop(launched, dogs)
        if client is not None:  # nbclient's exit hook for a kernel that is long gone
            atexit.unregister(client._cleanup_kernel)
        if own:
            shutil.rmtree(private, ignore_errors=True)
