"""Folders and cgroups named after the process that made them, and the sweep of those whose maker died.

A grader (or a worker of a batch) killed outright, by ``SIGKILL`` or the OOM killer, runs no
``finally``: the temporary folders it made (a submission's working copy, a kernel's runtime
folder, a task's unpacked files) and its memory cgroups stay behind. So every such folder made in
a shared place (the system's temporary folder, ``/tmp``, ``/var/tmp``, ``/dev/shm``, a cgroup
parent) is named after its maker::

    labkit-<kind>-<pid>-<start>-<random>

``kind`` one of :data:`FOLDER_KINDS` (``mem`` for a memory cgroup), ``pid`` the maker's process id
and ``start`` its start time (clock ticks after boot, field 22 of ``/proc/<pid>/stat``): a pid
the kernel has since given to another process has another start time. :func:`sweep` removes the
entries of a folder whose maker is dead (or a zombie) and nothing else: a name that is not
exactly of that form, an entry that is not a folder (a symbolic link is never followed), a
folder of another user, and a folder whose maker still runs are left alone. The driver of a
batch sweeps the temporary folders as the batch starts and as soon as a worker of its local pool
dies, and every pool or dask worker at its first task, on its own machine
(:func:`remove_leftovers`, through :func:`labkit.course._safefs.remove_tree`, which never follows
a link however deep: a kernel may have left links and odd names inside); each run sweeps the
empty memory cgroups of dead graders beside its own (:mod:`labkit.course._cgroup`).

A maker is looked up in this process's PID namespace: graders in other PID namespaces (containers)
must not share a temporary folder with this one (each container has its own ``/tmp`` by default).

Example
-------
>>> import os
>>> from labkit.course._leftovers import owner_of, owner_prefix
>>> owner_of(owner_prefix("grade") + "x1y2z3w4", ("grade",))[0] == os.getpid()
True
>>> owner_of("labkit-grade-12-34-x1y2z3w4/", ("grade",)) is None  # not exactly the form: never swept
True
"""

from __future__ import annotations

import contextlib
import os
import re
import stat
import tempfile
from pathlib import Path

from labkit.course._safefs import remove_tree
from labkit.course._watchdog import stat_fields

__all__ = ["FOLDER_KINDS", "TEMP_PLACES", "owner_prefix", "owner_of", "process_start", "new_folder",
           "temporary_folder", "sweep", "remove_leftovers"]

#: what the grader and its workers make in a temporary folder: a submission's grading, a batch task, a kernel's
#: runtime folder, a render task, the untouched student version's grading
FOLDER_KINDS = ("grade", "task", "run", "render", "baseline")
#: short system temporary folders, where a kernel's runtime folder goes when ``TMPDIR`` is too long for a socket path
TEMP_PLACES = ("/tmp", "/var/tmp", "/dev/shm")
_NAME = re.compile(r"labkit-([a-z]+)-([1-9][0-9]{0,9})-([0-9]{1,20})-[a-z0-9_]{1,32}", re.ASCII)


def process_start(pid):
    """When process ``pid`` started, if it runs (a zombie has exited).

    Parameters
    ----------
    pid : int

    Returns
    -------
    int or None
        Clock ticks after boot (field 22 of ``/proc/<pid>/stat``); None if there is no such
        process, it is a zombie, or ``/proc`` does not say.
    """
    try:
        fields = stat_fields(pid)
        return None if fields[0] in (b"Z", b"X") else int(fields[19])
    except (OSError, ValueError, IndexError):
        return None


def owner_prefix(kind) -> str:
    """The start of the name of a folder (or cgroup) this process makes: ``labkit-<kind>-<pid>-<start>-``.

    Parameters
    ----------
    kind : str
        One of :data:`FOLDER_KINDS`, or ``"mem"`` for a memory cgroup.

    Returns
    -------
    str
    """
    pid = os.getpid()
    return f"labkit-{kind}-{pid}-{process_start(pid) or 0}-"


def owner_of(name, kinds):
    """The maker named in ``name``, if it is exactly a name :func:`owner_prefix` starts, of one of ``kinds``.

    Parameters
    ----------
    name : str
        An entry's name (untrusted: any bytes a kernel could have chosen).
    kinds : sequence of str

    Returns
    -------
    (int, int) or None
        ``(pid, start)``; None for any other name.
    """
    found = _NAME.fullmatch(name) if isinstance(name, str) else None
    if found is None or found.group(1) not in kinds:
        return None
    return int(found.group(2)), int(found.group(3))


def new_folder(kind, dir=None) -> Path:
    """A new folder of this process's (``0700``), named after it (:func:`owner_prefix`).

    Parameters
    ----------
    kind : str
        One of :data:`FOLDER_KINDS`.
    dir : str or os.PathLike, optional
        Where (default the system's temporary folder).

    Returns
    -------
    pathlib.Path
    """
    return Path(tempfile.mkdtemp(prefix=owner_prefix(kind), dir=dir))


@contextlib.contextmanager
def temporary_folder(kind):
    """:func:`new_folder` in the system's temporary folder, removed (:func:`remove_tree`) however the block ends.

    Parameters
    ----------
    kind : str
        One of :data:`FOLDER_KINDS`.

    Yields
    ------
    pathlib.Path
    """
    folder = new_folder(kind)
    try:
        yield folder
    finally:
        remove_tree(folder)


def sweep(parent, kinds, remove) -> list:
    """Remove the entries of ``parent`` that dead processes made (named by :func:`owner_prefix`); nothing else.

    An entry is removed only if its name is exactly ``labkit-<kind>-<pid>-<start>-<random>`` with
    ``kind`` in ``kinds``, it is a folder (not a link to one), it belongs to this user, and no running
    process has that pid and start time.

    Parameters
    ----------
    parent : str or os.PathLike
        A temporary folder or a cgroup parent.
    kinds : sequence of str
    remove : callable
        ``remove(path)`` removes one entry; it must not raise.

    Returns
    -------
    list of pathlib.Path
        The entries handed to ``remove``.
    """
    if process_start(os.getpid()) is None:  # no /proc here: no maker can be told alive or dead
        return []
    try:
        with os.scandir(parent) as it:
            entries = list(it)
    except OSError:
        return []
    removed, uid = [], os.geteuid()
    for entry in entries:
        owner = owner_of(entry.name, kinds)
        if owner is None:
            continue
        try:
            st = entry.stat(follow_symlinks=False)
        except OSError:
            continue
        if not stat.S_ISDIR(st.st_mode) or st.st_uid != uid or process_start(owner[0]) == owner[1]:
            continue
        path = Path(parent) / entry.name
        remove(path)
        removed.append(path)
    return removed


def remove_leftovers() -> list:
    """Remove the temporary folders that dead graders and workers left (:func:`sweep` with :func:`remove_tree`).

    Looks in the system's temporary folder and in :data:`TEMP_PLACES`.

    Returns
    -------
    list of pathlib.Path
        The folders handed to :func:`remove_tree` (it leaves what it cannot remove, and never raises).
    """
    places = dict.fromkeys(os.path.realpath(p) for p in (tempfile.gettempdir(), *TEMP_PLACES))
    return [path for place in places for path in sweep(place, FOLDER_KINDS, remove_tree)]
