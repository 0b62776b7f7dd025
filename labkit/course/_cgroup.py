"""One memory cgroup per notebook run: the sandbox and everything it forks share one memory limit.

The kernel is started as ``sh -c 'echo 0 > <cgroup>/cgroup.procs && exec "$@"' ...``: the
shell moves itself into the cgroup before it becomes ``prlimit``, then ``bwrap``, then the
kernel, so every process of the submission is born inside it, and the pages its RAM disks
(``/tmp``, ``/dev/shm`` of the sandbox) hold are charged to it too (the kernel charges shmem
to the memory cgroup of the process that writes it). Over the limit the kernel's OOM killer
kills a process of the cgroup, and only of that cgroup (cgroup v2: all of them,
``memory.oom.group``); the kill is counted (``oom_kill`` in ``memory.events`` or
``memory.oom_control``), which tells a memory kill from a crash, and the sandbox's watchdog
then kills the rest of the submission.

Where the cgroup is made, in that order:

* **cgroup v2**: a child of the process's own cgroup (``0::`` in ``/proc/self/cgroup``)
  with ``memory.max`` and ``memory.swap.max``, if the memory controller is enabled for
  its children (``cgroup.subtree_control``). In a cgroup that systemd delegated (marked with
  the extended attribute ``user.delegate`` or ``trusted.delegate``: a unit or scope with
  ``Delegate=yes``, such as ``systemd-run --user --scope -p Delegate=yes labkit grade ...``)
  where the controller is available (``cgroup.controllers``) but not yet enabled, the
  grader first moves the cgroup's processes into a leaf child of its own
  (``labkit-mem-<pid>-<start>-grader``: a cgroup v2 with processes cannot enable controllers for its
  children) and enables ``memory`` there; the runs' cgroups are then siblings of that leaf;
* **cgroup v1**: a child of its own cgroup in the ``memory`` hierarchy, with
  ``memory.limit_in_bytes`` (and ``memory.memsw.limit_in_bytes`` where swap is accounted);
* neither (no such mount, not writable, not delegated): :func:`memory_cgroup` returns
  None and the sandbox falls back on its sampling watchdog.

The cgroup is removed (its processes killed first) when the run ends, however it ends;
one left behind by a grader that was killed outright is removed by the next run that
finds it empty (cgroups are named after their maker, ``labkit-mem-<pid>-<start>-<random>``, and
swept as temporary folders are: :mod:`labkit.course._leftovers`).

Example
-------
>>> from labkit.course import memory_mechanism
>>> memory_mechanism() in ("cgroup v2", "cgroup v1", "watchdog")
True
"""

from __future__ import annotations

import os
import signal
import time
import uuid
from pathlib import Path

from labkit.course._leftovers import owner_of, owner_prefix, sweep

__all__ = ["MemoryCgroup", "memory_cgroup", "memory_mechanism"]

#: how the memory limit of a submission is enforced (values of :func:`memory_mechanism`)
MemoryMechanism = ("cgroup v2", "cgroup v1", "watchdog")
#: the kind of a memory cgroup's name (:func:`labkit.course._leftovers.owner_prefix`)
_KIND = "mem"


#: where this process's mounts and cgroups are read (tests point it at a made-up layout)
_PROC_SELF = Path("/proc/self")
#: the random part of the name of the leaf a delegated cgroup's processes move to
_LEAF = "grader"
_DELEGATE_XATTRS = ("user.delegate", "trusted.delegate")


def _mountinfo() -> list:
    """(mount point, root inside the hierarchy, file-system type, super options) of every mount."""
    mounts = []
    try:
        lines = (_PROC_SELF / "mountinfo").read_text().splitlines()
    except OSError:
        return mounts
    for line in lines:
        left, _, right = line.partition(" - ")
        fields, tail = left.split(), right.split()
        if len(fields) >= 5 and len(tail) >= 3:
            mounts.append((fields[4].replace("\\040", " "), fields[3], tail[0], set(tail[2].split(","))))
    return mounts


def _own_cgroups() -> dict:
    """{controller or "" for cgroup v2: path of this process's cgroup} from ``/proc/self/cgroup``."""
    own = {}
    try:
        lines = (_PROC_SELF / "cgroup").read_text().splitlines()
    except OSError:
        return own
    for line in lines:
        parts = line.split(":", 2)
        if len(parts) == 3:
            for controller in (parts[1].split(",") if parts[1] else [""]):
                own[controller] = parts[2]
    return own


def _inside(mount, root, path):
    """Host folder of cgroup ``path`` in a hierarchy mounted at ``mount`` (showing ``root``), else None."""
    rel = os.path.relpath(path, root)
    if rel == ".":
        return Path(mount)
    if rel.startswith(".."):
        return None
    return Path(mount) / rel


def _words(path) -> list:
    try:
        return Path(path).read_text().split()
    except OSError:
        return []


def _delegated(folder) -> bool:
    """systemd delegated this cgroup v2 (``Delegate=yes``): its processes and children are its owner's to arrange."""
    for name in _DELEGATE_XATTRS:
        try:
            if os.getxattr(folder, name).strip() == b"1":
                return True
        except OSError:
            continue
    return False


def _v2_parent(folder):
    """The cgroup v2 folder under which a run's cgroup can be made, from this process's own; else None.

    Inside a leaf made by :func:`_enable_memory` the parent is that leaf's parent.
    """
    if owner_of(folder.name, (_KIND,)) is not None and folder.name.endswith(f"-{_LEAF}"):
        folder = folder.parent
    if "memory" in _words(folder / "cgroup.subtree_control"):
        return folder
    if "memory" in _words(folder / "cgroup.controllers") and _delegated(folder):
        return folder  # delegated: memory_cgroup enables the controller first
    return None


def _enable_memory(folder) -> bool:
    """Enable the memory controller for the children of a delegated cgroup v2 (move its processes to a leaf first).

    Parameters
    ----------
    folder : pathlib.Path
        The cgroup (delegated, ``memory`` in its ``cgroup.controllers``).

    Returns
    -------
    bool
        True once ``memory`` is in its ``cgroup.subtree_control``.
    """
    if "memory" in _words(folder / "cgroup.subtree_control"):
        return True
    leaf = folder / f"{owner_prefix(_KIND)}{_LEAF}"
    for _ in range(5):  # a process forked meanwhile is moved on the next round
        try:
            leaf.mkdir(exist_ok=True)
            for pid in _words(folder / "cgroup.procs"):
                try:
                    _write(leaf / "cgroup.procs", pid)
                except ProcessLookupError:
                    continue
            _write(folder / "cgroup.subtree_control", "+memory")
            return True
        except OSError:
            time.sleep(0.01)
    return "memory" in _words(folder / "cgroup.subtree_control")


def _parents() -> list:
    """Candidate (version, folder) parents for a new memory cgroup, best first."""
    own, found = _own_cgroups(), []
    for mount, root, fstype, options in _mountinfo():
        if fstype == "cgroup2" and "" in own:
            folder = _inside(mount, root, own[""])
            parent = _v2_parent(folder) if folder is not None else None
            if parent is not None:
                found.insert(0, (2, parent))
        elif fstype == "cgroup" and "memory" in options and "memory" in own:
            folder = _inside(mount, root, own["memory"])
            if folder is not None and (folder / "memory.limit_in_bytes").exists():
                found.append((1, folder))
    return found


def _write(path, value):
    with open(path, "w") as f:
        f.write(str(value))


def _read_int(path, key=None) -> int:
    """An integer file, or the value of ``key`` in a flat-keyed file; 0 if absent."""
    try:
        text = Path(path).read_text()
    except OSError:
        return 0
    try:
        if key is None:
            return int(text.split()[0])
        for line in text.splitlines():
            name, _, value = line.partition(" ")
            if name == key:
                return int(value)
    except (ValueError, IndexError):
        pass
    return 0


class MemoryCgroup:
    """A memory cgroup made for one run (see the module's description); remove it with :meth:`remove`.

    Attributes
    ----------
    path : pathlib.Path
        Its folder in the cgroup file system.
    version : int
        1 or 2.
    limit_bytes : int
        Its memory limit [bytes].
    """

    def __init__(self, path, version, limit_bytes):
        self.path, self.version, self.limit_bytes = Path(path), int(version), int(limit_bytes)

    @property
    def mechanism(self) -> str:
        """``"cgroup v1"`` or ``"cgroup v2"``."""
        return f"cgroup v{self.version}"

    def enter_prefix(self) -> list:
        """A command prefix that moves itself into this cgroup, then runs the rest (``exec``).

        Returns
        -------
        list of str
            ``["/bin/sh", "-c", ..., "<cgroup>/cgroup.procs"]``: if the move fails, nothing runs.
        """
        return ["/bin/sh", "-c", 'echo 0 > "$0" && exec "$@"', str(self.path / "cgroup.procs")]

    def oom_kills(self) -> int:
        """Processes the kernel's OOM killer killed in this cgroup so far.

        Returns
        -------
        int
            ``oom_kill`` of ``memory.events`` (v2) or ``memory.oom_control`` (v1).
        """
        if self.version == 2:
            return _read_int(self.path / "memory.events", "oom_kill")
        return _read_int(self.path / "memory.oom_control", "oom_kill")

    def peak_bytes(self) -> int:
        """Most memory charged at once so far.

        Returns
        -------
        int
            [bytes]; 0 where the kernel does not say.
        """
        return _read_int(self.path / ("memory.peak" if self.version == 2 else "memory.max_usage_in_bytes"))

    def pids(self) -> list:
        """The processes in it now.

        Returns
        -------
        list of int
            Their ids (in the grader's PID namespace).
        """
        try:
            return [int(p) for p in (self.path / "cgroup.procs").read_text().split()]
        except (OSError, ValueError):
            return []

    def kill(self):
        """SIGKILL every process in it (``cgroup.kill`` where the kernel has it)."""
        if self.version == 2 and (self.path / "cgroup.kill").exists():
            try:
                _write(self.path / "cgroup.kill", 1)
                return
            except OSError:
                pass
        for pid in self.pids():
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass

    def remove(self, timeout=10.0) -> bool:
        """Kill what is left in it and remove it.

        Parameters
        ----------
        timeout : float
            How long to keep trying [s].

        Returns
        -------
        bool
            True once its folder is gone.
        """
        deadline = time.monotonic() + timeout
        while self.path.exists():
            self.kill()
            try:
                self.path.rmdir()
            except FileNotFoundError:
                break
            except OSError:
                if time.monotonic() > deadline:
                    return False
                time.sleep(0.02)
        return True


def _rmdir(path):
    try:
        path.rmdir()  # fails for a cgroup that still holds a process
    except OSError:
        pass


def memory_cgroup(limit_bytes):
    """A new memory cgroup limited to ``limit_bytes``, or None where none can be made here.

    Parameters
    ----------
    limit_bytes : int
        Memory of everything the run's processes and RAM disks hold [bytes].

    Returns
    -------
    MemoryCgroup or None
    """
    limit_bytes = int(limit_bytes)
    for version, parent in _parents():
        if version == 2 and not _enable_memory(parent):
            continue
        path = parent / f"{owner_prefix(_KIND)}{uuid.uuid4().hex[:12]}"
        sweep(parent, (_KIND,), _rmdir)  # the empty cgroups of graders killed outright
        try:
            path.mkdir()
        except OSError:
            continue
        try:
            if version == 2:
                _write(path / "memory.max", limit_bytes)
                if (path / "memory.swap.max").exists():
                    _write(path / "memory.swap.max", 0)
                if (path / "memory.oom.group").exists():  # an OOM kill takes the whole submission
                    _write(path / "memory.oom.group", 1)
            else:
                _write(path / "memory.limit_in_bytes", limit_bytes)
                if (path / "memory.memsw.limit_in_bytes").exists():
                    _write(path / "memory.memsw.limit_in_bytes", limit_bytes)
            return MemoryCgroup(path, version, limit_bytes)
        except OSError:
            try:
                path.rmdir()
            except OSError:
                pass
    return None


def memory_mechanism() -> str:
    """How a submission's memory would be limited on this machine now (one of ``MemoryMechanism``).

    Returns
    -------
    str
        ``"cgroup v2"``, ``"cgroup v1"`` (a test cgroup was made and removed), or ``"watchdog"``.
    """
    cgroup = memory_cgroup(2**30)
    if cgroup is None:
        return "watchdog"
    cgroup.remove()
    return cgroup.mechanism
