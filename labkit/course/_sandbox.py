"""Executing an untrusted notebook: a Jupyter kernel in a bubblewrap sandbox with resource limits.

The notebook client (nbclient) runs in the grading process and holds the notebook,
hidden tests included; only the kernel, where the student's code runs, is sandboxed.
It is started as ``prlimit --cpu --as -- bwrap ... -- python -m ipykernel_launcher``:

* **CPU time and memory**: ``RLIMIT_CPU`` (SIGXCPU at the limit, SIGKILL a little
  later) and ``RLIMIT_AS`` (an allocation over the limit raises ``MemoryError``);
* **wall clock**: a per-cell timeout and a deadline for the whole notebook, after
  which the kernel is killed;
* **files**: the whole file system read-only, with ``/tmp``, ``$HOME`` and every
  path in ``hide`` (the submissions folder, the instructor's lab, the output folder)
  replaced by empty tmpfs (the Python installation, the import path and the labkit
  package are shown again, read-only, where they lie under ``/tmp`` or ``$HOME``;
  ``hide`` still wins); only the submission's own working directory is writable;
* **processes and network**: new PID, IPC, UTS and network namespaces (no network
  at all, not even loopback to the host: the kernel talks to the client over Unix
  sockets in a private folder), no capabilities, a new session, killed with its parent.

It does not protect against kernel exploits, reading files elsewhere on the
machine that the grading user can read and that are not hidden, or filling the
disk of the working directory (see ``docs/course.md``).

Example
-------
>>> from labkit.course import Limits
>>> Limits(cpu_seconds=30, memory_bytes=2 * 2**30, wall_seconds=120).memory_bytes
2147483648
"""

from __future__ import annotations

import asyncio
import os
import shutil
import site
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from labkit.exceptions import LabkitError
from labkit.reports import kernel_manager_class

__all__ = ["Limits", "RunStatus", "run_untrusted"]

#: outcomes of one execution (RunStatus values)
RunStatus = ("ok", "error", "timeout", "cpu-time", "memory", "crash")
_SIGXCPU, _SIGKILL = 24, 9


@dataclass(frozen=True)
class Limits:
    """Resource limits of one notebook execution.

    Attributes
    ----------
    cpu_seconds : float
        CPU time of the kernel [s] (``RLIMIT_CPU``).
    memory_bytes : int
        Address space of the kernel [bytes] (``RLIMIT_AS``).
    wall_seconds : float
        Wall time of the whole notebook [s]; also the per-cell timeout.
    sandbox : bool
        Run the kernel in bubblewrap (False: limits only, for machines without it).
    """

    cpu_seconds: float = 120.0
    memory_bytes: int = 4 * 2**30
    wall_seconds: float = 300.0
    sandbox: bool = True

    def __post_init__(self):
        for name in ("cpu_seconds", "memory_bytes", "wall_seconds"):
            value = getattr(self, name)
            if not value > 0:
                raise LabkitError(f"expected {name} > 0, got {value!r}")


def _bwrap_args(work: Path, private: Path, hide) -> list[str]:
    bwrap = shutil.which("bwrap")
    if bwrap is None:
        raise LabkitError("the grading sandbox needs bubblewrap (Debian package 'bubblewrap', command 'bwrap'); "
                          "install it or grade with sandbox=False (--no-sandbox)")
    args = [bwrap, "--ro-bind", "/", "/", "--dev", "/dev", "--proc", "/proc", "--tmpfs", "/tmp"]
    emptied = [Path("/tmp").resolve()]
    home = Path(os.path.expanduser("~")).resolve()
    if home != Path("/") and home not in work.parents and home not in private.parents:
        args += ["--tmpfs", str(home)]
        emptied.append(home)
    # what the kernel imports from may live in $HOME (pyenv, venvs, the user site) or in /tmp (an editable
    # install of a checkout there): show the Python installation, the PYTHONPATH the kernel gets and the
    # labkit package again, read-only (not the grading process's whole sys.path: its working directory
    # may be a checkout full of notebooks)
    roots = [sys.prefix, sys.base_prefix, sys.exec_prefix, site.getusersitepackages(),
             *os.environ.get("PYTHONPATH", "").split(os.pathsep)]
    needed = {Path(p).resolve() for p in roots if p}
    needed.add(Path(__file__).resolve().parents[1])  # the labkit package (an editable install's finder maps to it)
    for path in sorted(needed):
        if (any(root in path.parents for root in emptied) and path.exists()
                and not any(q in path.parents for q in needed)):
            args += ["--ro-bind", str(path), str(path)]
    for path in hide:
        path = Path(path).resolve()
        if path.is_dir() and path != Path("/") and path not in work.parents and path not in private.parents:
            args += ["--tmpfs", str(path)]
    args += ["--bind", str(private), str(private), "--bind", str(work), str(work), "--chdir", str(work),
             "--unshare-all", "--die-with-parent", "--new-session", "--clearenv"]
    env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": str(work), "LANG": "C.UTF-8",
           "MPLCONFIGDIR": str(private / "mpl"), "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
           "MKL_NUM_THREADS": "1", "PYDEVD_DISABLE_FILE_VALIDATION": "1"}
    if os.environ.get("PYTHONPATH"):
        env["PYTHONPATH"] = os.environ["PYTHONPATH"]
    for key, value in env.items():
        args += ["--setenv", key, value]
    return args + ["--"]


def _sandboxed_kernel_manager(work: Path, private: Path, limits: Limits, hide):
    base = kernel_manager_class()
    cpu = int(max(1, round(limits.cpu_seconds)))
    prefix = ["prlimit", f"--cpu={cpu}:{cpu + 5}", f"--as={int(limits.memory_bytes)}", "--"]
    if limits.sandbox:
        prefix += _bwrap_args(work, private, hide)
    launched = []

    class SandboxedKernelManager(base):
        def format_kernel_cmd(self, extra_arguments=None):
            cmd = [sys.executable if c in ("python", "python3", "{python}") else c
                   for c in super().format_kernel_cmd(extra_arguments)]
            return [*prefix, *cmd]  # prlimit execs bwrap: the launched process is the sandbox

        async def _async_launch_kernel(self, kernel_cmd, **kw):
            kw["stdout"] = subprocess.DEVNULL  # ipykernel's banner; the notebook's output goes over ZMQ
            log = open(private / "kernel.log", "ab")  # noqa: SIM115 - closed by run_untrusted
            launched.append(log)
            kw["stderr"] = log
            await super()._async_launch_kernel(kernel_cmd, **kw)
            launched.insert(0, self.provisioner.process)  # its exit status tells a CPU-limit kill

    km = SandboxedKernelManager(transport="ipc", ip=str(private / "kernel"),
                                connection_file=str(private / "kernel.json"))
    return km, launched


def _memory_error(nb) -> bool:
    return any("MemoryError" in o.get("ename", "") for c in nb.cells for o in c.get("outputs", [])
               if o.get("output_type") == "error")


def run_untrusted(nb, work, *, limits=None, hide=()):
    """Execute ``nb`` (in place) with its kernel sandboxed in ``work``; never raises for student code.

    Parameters
    ----------
    nb : nbformat.NotebookNode
        The notebook to execute (outputs are written into it).
    work : str or os.PathLike
        The submission's working directory (the kernel's cwd and only writable folder).
    limits : Limits, optional
        Resource limits (default :class:`Limits`).
    hide : sequence of path-like
        Folders the kernel must not see (replaced by empty folders).

    Returns
    -------
    (str, str)
        The status (one of :data:`RunStatus`: ``"ok"``, ``"error"`` for an exception in some
        cell, ``"timeout"``, ``"cpu-time"``, ``"memory"``, ``"crash"`` for a kernel that died
        otherwise) and a one-line detail.

    Raises
    ------
    LabkitError
        If the sandbox cannot be set up (bubblewrap missing).
    """
    from nbclient import NotebookClient
    from nbclient.exceptions import CellTimeoutError, DeadKernelError

    limits = limits or Limits()
    work = Path(work).resolve()
    private = Path(tempfile.mkdtemp(prefix="labkit-kernel-"))
    launched = []  # the sandbox's Popen, then its log file
    try:
        (private / "mpl").mkdir()
        cache = Path(os.path.expanduser("~/.cache/matplotlib"))
        for font_list in cache.glob("fontlist-*.json"):  # no font-cache rebuild in every sandbox
            shutil.copy2(font_list, private / "mpl" / font_list.name)
        km, launched = _sandboxed_kernel_manager(work, private, limits, hide)
        client = NotebookClient(nb, km=km, timeout=int(limits.wall_seconds), allow_errors=True,
                                startup_timeout=60, resources={"metadata": {"path": str(work)}})

        async def go():
            await asyncio.wait_for(client.async_execute(), limits.wall_seconds)

        timed_out = ("timeout", f"stopped after the wall-clock limit of {limits.wall_seconds:g} s")
        t0 = time.monotonic()
        try:
            asyncio.run(go())
        except (asyncio.TimeoutError, CellTimeoutError):
            return timed_out
        except DeadKernelError:
            if time.monotonic() - t0 >= limits.wall_seconds:  # killed by the client at the deadline
                return timed_out
            try:
                code = launched[0].wait(timeout=10) if launched and hasattr(launched[0], "wait") else None
            except subprocess.TimeoutExpired:
                code = None
            if code in (128 + _SIGXCPU, 128 + _SIGKILL):
                return "cpu-time", f"killed at the CPU-time limit of {limits.cpu_seconds:g} s"
            try:
                tail = " ".join((private / "kernel.log").read_text(errors="replace").strip().splitlines()[-2:])
            except OSError:
                tail = ""
            return ("memory" if _memory_error(nb) else "crash"), f"the kernel died (exit status {code}) {tail}"[:400]
        except RuntimeError as exc:  # kernel failed to start
            return "crash", f"{type(exc).__name__}: {exc}"
        if _memory_error(nb):
            return "memory", f"an allocation exceeded the memory limit of {limits.memory_bytes / 2**30:g} GiB"
        for cell in nb.cells:
            for out in cell.get("outputs", []):
                if out.get("output_type") == "error":
                    return "error", f"{out.get('ename')}: {out.get('evalue', '')}"[:300]
        return "ok", ""
    finally:
        for item in launched[1:]:
            item.close()
        shutil.rmtree(private, ignore_errors=True)
