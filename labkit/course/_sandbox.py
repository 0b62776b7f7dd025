"""Executing an untrusted notebook: a Jupyter kernel in an allow-list bubblewrap sandbox with limits.

The notebook client (nbclient) runs in the grading process; the kernel, where the
student's code runs, is started as ``prlimit --cpu --as --fsize -- bwrap ... -- python -s -P -c
<launcher>`` (:data:`labkit.course._client.KERNEL_MAIN`: nothing of the submission runs before the
kernel's sockets are bound). The sandbox shows **only what the kernel needs**:

* read-only: ``/usr`` (and the ``/bin``, ``/lib`` links into it), a few files of ``/etc``
  (loader cache, time zone, fonts, alternatives, passwd), the Python installation
  (``sys.prefix``, ``sys.base_prefix``, the site-packages folders) and the labkit package;
* read-write: its own copy of the submission, at :data:`SANDBOX_HOME` (also ``$HOME`` and
  the working directory), and the ``sockets/`` folder of the run's own new runtime folder (its
  Unix sockets: jupyter_client's ``ipc`` transport, no TCP port at all); read-only: its
  connection file; ``MPLCONFIGDIR`` and ``IPYTHONDIR`` on its own RAM disk. The grader reads
  nothing there by name (:mod:`labkit.course._safefs`), never reconnects, and keeps the
  kernel's stderr in an unnamed file;
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
import re
import shutil
import signal
import site
import subprocess
import sys
import sysconfig
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

from labkit.exceptions import LabkitError, needs_extra
from labkit.course._cgroup import memory_cgroup
from labkit.course._client import KERNEL_MAIN, ChannelClosed, client_class, runtime_folder
from labkit.course._safefs import remove_tree, socket_ready
from labkit.course._watchdog import Watchdog, dies_with_this_process, kill_tree
from labkit.course._wire import MAX_EXPORT_BYTES
from labkit.reports import kernel_manager_class

__all__ = ["Limits", "RunResult", "RunStatus", "SANDBOX_HOME", "check_sandbox", "run_untrusted", "sandbox_args"]

#: outcomes of one execution (RunStatus values)
RunStatus = ("ok", "error", "timeout", "cpu-time", "memory", "crash")
#: where the submission's copy appears inside the sandbox (its $HOME and working directory)
SANDBOX_HOME = "/home/student"
_ETC = ("ld.so.cache", "ld.so.conf", "ld.so.conf.d", "localtime", "fonts", "alternatives", "passwd", "group",
        "nsswitch.conf", "mime.types")
#: largest output a cell may send to the grader [bytes]; more is dropped with a note
MAX_CELL_OUTPUT = 2 * 2**20
#: largest output a whole notebook may send to the grader [bytes]; more is dropped with a note
MAX_NOTEBOOK_OUTPUT = 16 * 2**20
#: largest single message the grader accepts from a kernel [bytes]: an export of the checks' values and room
MAX_MESSAGE_BYTES = MAX_EXPORT_BYTES + 2**20
#: the matplotlib and IPython folders inside the sandbox (on its RAM disk: fresh for every kernel)
_MPL_DIR, _IPYTHON_DIR = "/tmp/matplotlib", "/tmp/ipython"


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
    output_bytes : int
        Output a cell may send to the grader [bytes]: each message is measured as it arrives,
        and one that would take the cell over this is dropped (the run's detail says so).
    notebook_output_bytes : int
        Output the whole notebook may send to the grader [bytes], the same way (a notebook of
        many cells, each under ``output_bytes``). With ``message_bytes`` it bounds what the
        grader holds of a run: about ``notebook_output_bytes + message_bytes`` characters.
    message_bytes : int
        Largest single message the grader's sockets accept [bytes] (a larger one closes the
        kernel's channel: ZeroMQ's ``ZMQ_MAXMSGSIZE``; the run is graded ``crash`` and says
        why). Bounds the grader's own memory; it must hold an export of the checks' values.
    """

    cpu_seconds: float = 120.0
    memory_bytes: int = 4 * 2**30
    wall_seconds: float = 300.0
    sandbox: bool = True
    max_processes: int = 32
    cgroup: bool = True
    output_bytes: int = MAX_CELL_OUTPUT
    message_bytes: int = MAX_MESSAGE_BYTES
    notebook_output_bytes: int = MAX_NOTEBOOK_OUTPUT

    def __post_init__(self):
        for name in ("cpu_seconds", "memory_bytes", "wall_seconds", "max_processes", "output_bytes", "message_bytes",
                     "notebook_output_bytes"):
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


def sandbox_args(home, private, hide=(), *, limits=None, writable_home=True, tmpfs_bytes=None, read_only=()) -> list:
    """The ``bwrap`` command prefix of the allow-list sandbox (ends with ``--``).

    Parameters
    ----------
    home : path-like
        The host folder shown at :data:`SANDBOX_HOME` (the submission's copy).
    private : path-like
        A host folder shown at the same path, read-write (the kernel's sockets; the checker's files).
    hide : sequence of path-like
        Folders to empty even if a bound path holds them.
    limits : Limits, optional
        For the size of the RAM disks.
    writable_home : bool
        Bind ``home`` read-write (the kernel) or read-only (the checker).
    tmpfs_bytes : int, optional
        Size of each RAM disk [bytes] (default ``limits.tmpfs_bytes``).
    read_only : sequence of path-like
        Host files shown read-only at the same path (the kernel's connection file).

    Returns
    -------
    list of str

    Raises
    ------
    LabkitError
        If bubblewrap is not installed.

    Notes
    -----
    ``MPLCONFIGDIR`` and ``IPYTHONDIR`` are folders of the sandbox's own ``/tmp`` RAM disk, new
    for every kernel; the grader's matplotlib font list is bound there read-only (no rebuild,
    no write back). Nothing of them outlives the sandbox or is read by the grader.
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
    for path in read_only:
        args += ["--ro-bind", str(path), str(path)]
    args += ["--dir", _MPL_DIR, "--dir", _IPYTHON_DIR]
    for font_list in _font_lists():
        args += ["--ro-bind", str(font_list), f"{_MPL_DIR}/{font_list.name}"]
    env = {"PATH": f"{os.path.dirname(sys.executable)}:/usr/local/bin:/usr/bin:/bin", "HOME": SANDBOX_HOME,
           "USER": "student", "LOGNAME": "student", "LANG": "C.UTF-8", "MPLCONFIGDIR": _MPL_DIR,
           "IPYTHONDIR": _IPYTHON_DIR, "JUPYTER_RUNTIME_DIR": str(private),
           "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "PYDEVD_DISABLE_FILE_VALIDATION": "1", "TMPDIR": "/tmp"}
    if labkit_root().name not in ("site-packages", "dist-packages"):  # a checkout: its root on the path
        env["PYTHONPATH"] = str(labkit_root())
    for key, value in env.items():
        args += ["--setenv", key, value]
    return args + ["--"]


def check_sandbox() -> None:
    """Stop before grading if bubblewrap cannot make its namespaces here, saying how to fix it.

    Starts ``bwrap --unshare-all ... /bin/true`` once. Ubuntu 24.04 and later restrict
    unprivileged user namespaces through AppArmor (``kernel.apparmor_restrict_unprivileged_userns
    = 1``): bubblewrap then fails (``setting up uid map: Permission denied``) unless an AppArmor
    profile allows it; some kernels turn them off (``kernel.unprivileged_userns_clone = 0``,
    ``user.max_user_namespaces = 0``).

    Raises
    ------
    LabkitError
        If bubblewrap is missing or cannot start a sandbox; the message names the setting and the fix.
    """
    bwrap = shutil.which("bwrap")
    if bwrap is None:
        raise LabkitError("the grading sandbox needs bubblewrap (Debian package 'bubblewrap', command 'bwrap'); "
                          "install it or grade with sandbox=False (--no-sandbox)")
    try:
        probe = subprocess.run([bwrap, "--unshare-all", "--die-with-parent", "--ro-bind", "/", "/", "--", "/bin/true"],
                               capture_output=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise LabkitError(f"expected bubblewrap to start a sandbox, got {type(exc).__name__}: {exc}") from None
    if probe.returncode == 0:
        return
    said = " ".join(probe.stderr.decode("utf-8", "replace").split())[:300]
    settings = {name: _sysctl(path) for name, path in (
        ("kernel.apparmor_restrict_unprivileged_userns", "/proc/sys/kernel/apparmor_restrict_unprivileged_userns"),
        ("kernel.unprivileged_userns_clone", "/proc/sys/kernel/unprivileged_userns_clone"),
        ("user.max_user_namespaces", "/proc/sys/user/max_user_namespaces"))}
    if settings["kernel.apparmor_restrict_unprivileged_userns"] == "1":
        fix = ("AppArmor restricts unprivileged user namespaces here (kernel.apparmor_restrict_unprivileged_userns = 1, "
               "Ubuntu 24.04 and later): allow bubblewrap with an AppArmor profile (/etc/apparmor.d/bwrap: "
               "'abi <abi/4.0>, include <tunables/global> profile bwrap /usr/bin/bwrap flags=(unconfined) "
               "{ userns, }', then 'sudo apparmor_parser -r /etc/apparmor.d/bwrap'), or "
               "'sudo sysctl kernel.apparmor_restrict_unprivileged_userns=0' for the whole machine")
    elif settings["kernel.unprivileged_userns_clone"] == "0":
        fix = "unprivileged user namespaces are off: 'sudo sysctl kernel.unprivileged_userns_clone=1'"
    elif settings["user.max_user_namespaces"] == "0":
        fix = "user namespaces are off: 'sudo sysctl user.max_user_namespaces=15000'"
    else:
        fix = "check that unprivileged user namespaces are allowed (AppArmor, SELinux, a container's seccomp profile)"
    raise LabkitError(f"expected bubblewrap to start the grading sandbox, got exit status {probe.returncode}: "
                      f"{said or '(no message)'}; {fix}; or grade without the sandbox (--no-sandbox, see docs/course.md)")


def _sysctl(path) -> str:
    try:
        return Path(path).read_text().strip()
    except OSError:
        return ""


def _font_lists() -> list:
    """The grader's matplotlib font lists (regular files of its own cache, never links), to bind read-only."""
    cache = Path(os.path.expanduser("~/.cache/matplotlib"))
    return sorted(p for p in cache.glob("fontlist-*.json")
                  if re.fullmatch(r"fontlist-v[0-9.]+\.json", p.name) and p.is_file() and not p.is_symlink())


def _kernel_manager(work: Path, runtime: Path, limits: Limits, hide, log, cgroup=None):
    """The kernel manager of one run: its connection file in the grader's ``runtime`` folder (read-only in the
    sandbox), its sockets in ``runtime/sockets`` (the only folder of it the sandbox can write), stderr to
    ``log`` (a file of the grader's, not in any folder the sandbox sees)."""
    with needs_extra("course"):
        import zmq
        import zmq.asyncio

    base = kernel_manager_class()
    sockets, connection = runtime / "sockets", runtime / "kernel.json"
    cpu = int(max(1, round(limits.cpu_seconds)))
    address_space = int(limits.memory_bytes) + (2**30 if cgroup is not None else 0)
    prefix = dies_with_this_process() + (cgroup.enter_prefix() if cgroup is not None else [])
    prefix += ["prlimit", f"--cpu={cpu}:{cpu + 5}", f"--as={address_space}",
               f"--fsize={int(max(limits.memory_bytes, 2**30))}", "--"]
    if limits.sandbox:
        tmpfs = limits.memory_bytes if cgroup is not None else limits.tmpfs_bytes
        prefix += sandbox_args(work, sockets, hide, limits=limits, tmpfs_bytes=tmpfs, read_only=[connection])
    context = zmq.asyncio.Context()
    context.setsockopt(zmq.RECONNECT_IVL, -1)  # never reconnect by name to a socket file the sandbox could replace
    context.setsockopt(zmq.MAXMSGSIZE, int(limits.message_bytes))
    launched, dogs = [context], []

    class SandboxedKernelManager(base):
        def format_kernel_cmd(self, extra_arguments=None):
            cmd = [sys.executable if c in ("python", "python3", "{python}") else c
                   for c in super().format_kernel_cmd(extra_arguments)]
            if cmd[1:3] == ["-m", "ipykernel_launcher"]:
                cmd[1:3] = ["-s", "-P", "-c", KERNEL_MAIN]
            return [*prefix, *cmd]  # setpriv, sh, prlimit exec in turn: the launched process is the sandbox

        async def _async_launch_kernel(self, kernel_cmd, **kw):
            kw["stdout"] = subprocess.DEVNULL  # ipykernel's banner; the notebook's output goes over ZMQ
            kw["stderr"] = log
            kw["cwd"] = str(work)  # the host side; bwrap changes to SANDBOX_HOME inside
            await super()._async_launch_kernel(kernel_cmd, **kw)
            launched.insert(0, self.provisioner.process)
            dogs.append(Watchdog(self.provisioner.process, limits, sandboxed=limits.sandbox, cgroup=cgroup))
            dogs[-1].start()
            await self._sockets_bound()

        async def _sockets_bound(self):
            """Wait until the kernel listens on its sockets (before any code of the submission runs: the kernel
            binds them first), so the clients connect once and never again."""
            names = [f"kernel-{port}" for port in (self.shell_port, self.iopub_port, self.stdin_port,
                                                    self.control_port)]
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline and self.provisioner.process.poll() is None:
                if all(socket_ready(sockets, name) for name in names):
                    return
                await asyncio.sleep(0.05)

        def cleanup_ipc_files(self):
            """Nothing by name: the run removes its whole runtime folder (:func:`remove_tree`)."""

        def client(self, **kw):
            return super().client(context=context, **kw)

    km = SandboxedKernelManager(transport="ipc", ip=str(sockets / "kernel"), connection_file=str(connection),
                                context=context)
    return km, launched, dogs


def _stop(launched, dogs, monitors=()):
    """Stop the watchdogs, kill whatever of the sandbox is left, close the sockets."""
    for dog in dogs:
        dog.stop.set()
    procs = [p for p in launched if hasattr(p, "poll")]
    for proc in procs:
        if proc.poll() is None:
            kill_tree(proc.pid)
            proc.wait()
    for monitor in monitors:
        monitor.close(linger=0)
    for item in launched:
        if hasattr(item, "destroy"):
            item.destroy(linger=0)


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
        A folder of the grader's (never one the sandbox sees) in which the run makes its own new
        runtime folder (default: the system's temporary folder). The runtime folder holds the
        connection file (read-only in the sandbox) and the socket folder (the only part the
        sandbox can write); the kernel's stderr goes to an unnamed file; all of it is removed
        when the run ends. Each run starts from a new runtime folder (elsewhere if its socket paths
        would not fit a Unix socket: :func:`labkit.course._client.runtime_folder`).

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
    runtime = runtime_folder(private)  # new for every run, the grader's (0700), its socket paths short enough
    (runtime / "sockets").mkdir()
    log = tempfile.TemporaryFile(dir=runtime)  # noqa: SIM115 - the kernel's stderr, no name anyone can link
    launched, dogs, client = [], [], None
    try:
        cwd = SANDBOX_HOME if limits.sandbox else str(work)
        km = None

        def prepare():
            nonlocal km, client, launched, dogs
            if client is not None:
                atexit.unregister(client._cleanup_kernel)
            km, launched, dogs = _kernel_manager(work, runtime, limits, hide, log, cgroup)
            client = client_class()(nb, km=km, timeout=int(limits.wall_seconds), allow_errors=True,
                                     startup_timeout=60, resources={"metadata": {"path": cwd}},
                                     output_bytes=limits.output_bytes,
                                     notebook_output_bytes=limits.notebook_output_bytes,
                                     message_bytes=limits.message_bytes)

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

        def dropped():
            if not client.dropped:
                return ""
            ids = list(dict.fromkeys(str(nb.cells[i].get("id")) for i, _ in client.dropped))
            return (f"output over the limit of {limits.output_bytes} bytes per cell "
                    f"({limits.notebook_output_bytes} per notebook) dropped: "
                    f"{len(client.dropped)} message(s) (largest {max(n for _, n in client.dropped)} characters) "
                    f"in the cell(s) with id {', '.join(ids[:5])}{' ...' if len(ids) > 5 else ''}")

        timed_out = ("timeout", f"stopped after the wall-clock limit of {limits.wall_seconds:g} s")

        def died(crash, wait):
            """(status, detail) of a kernel that died or never answered: the limit it hit (the watchdog's reason,
            the wall clock, ``RLIMIT_CPU``, a ``MemoryError``), else ``crash(exit status)``."""
            if reason():
                return reason()
            if time.monotonic() - t0 >= limits.wall_seconds:
                return timed_out
            try:
                code = launched[0].wait(timeout=wait) if launched and hasattr(launched[0], "wait") else None
            except subprocess.TimeoutExpired:
                code = None
            if code == 128 + signal.SIGXCPU or (dogs and dogs[0].cpu >= 0.9 * limits.cpu_seconds):
                return "cpu-time", f"killed at the CPU-time limit of {limits.cpu_seconds:g} s"
            return ("memory" if _memory_error(nb) else "crash"), crash(code)

        t0 = time.monotonic()
        try:
            try:
                run()
            except RuntimeError as exc:  # the kernel did not start (a busy machine): once more, afresh, if no limit hit
                if "kernel" not in str(exc).lower() or reason() or (cgroup is not None and cgroup.oom_kills()) \
                        or any(c.get("execution_count") for c in nb.cells if c.cell_type == "code"):
                    raise
                _stop(launched, dogs, client.monitors)
                remove_tree(runtime / "sockets")
                (runtime / "sockets").mkdir()
                prepare()
                t0 = time.monotonic()
                run()
        except ChannelClosed as exc:
            return "crash", (f"the kernel sent a message over the limit of {limits.message_bytes} bytes: the grader "
                             f"dropped it and closed the kernel's channel; the notebook stopped before cell "
                             f"{exc.args[0] + 1}")
        except (asyncio.TimeoutError, CellTimeoutError):
            return (reason() or timed_out)
        except DeadKernelError:
            return died(lambda code: f"the kernel died (exit status {code})", wait=10)
        except RuntimeError as exc:  # the kernel did not start: the limit it hit on the way, else a crash
            return died(lambda code: f"the kernel did not start: {type(exc).__name__}: {exc} {_tail(log)}"[:400],
                        wait=0)
        if dogs:  # a last sample: what is over a limit as the notebook ends counts (a burst between samples may not)
            dogs[0].check()
        if reason():
            return reason()
        if client.closed():
            return "crash", (f"the kernel sent a message over the limit of {limits.message_bytes} bytes: the grader "
                             "dropped it and closed the kernel's channel; later outputs were lost")
        if _memory_error(nb):
            return "memory", f"an allocation exceeded the memory limit of {limits.memory_bytes / 2**30:g} GiB"
        for cell in nb.cells:
            for out in cell.get("outputs", []):
                if out.get("output_type") == "error":
                    return "error", f"{out.get('ename')}: {out.get('evalue', '')}"[:300]
        return "ok", dropped()
    finally:
        _stop(launched, dogs, client.monitors if client is not None else ())
        if client is not None:  # nbclient's exit hook for a kernel that is long gone
            atexit.unregister(client._cleanup_kernel)
        log.close()
        remove_tree(runtime)


def _tail(log, limit=4096) -> str:
    """The last two lines of the kernel's stderr (an unnamed file of the grader's), control characters removed."""
    try:
        size = os.fstat(log.fileno()).st_size
        log.seek(max(0, size - limit))
        text = log.read(limit).decode("utf-8", errors="replace")
    except (OSError, ValueError):
        return ""
    return " ".join(re.sub(r"[\x00-\x1f\x7f-\x9f]", " ", line) for line in text.strip().splitlines()[-2:])
