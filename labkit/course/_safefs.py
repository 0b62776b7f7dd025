"""The one way the grader touches files a submission could have written: under a folder's descriptor, never
through a link.

A student's folder, the working copy a kernel ran on and the kernel's socket folder hold
whatever the student's processes (or the unzip of their archive) left there: symlinks to host
files, FIFOs that block a reader, devices, folders nested thousands deep, huge files. Outside the
sandbox the grader reads, writes and removes such files **only** through this module:

* every folder is opened with ``O_DIRECTORY | O_NOFOLLOW`` and every entry under it relative to
  that descriptor (``openat``: ``os.open(name, ..., dir_fd=fd)``), so no path component is
  resolved by name and a link anywhere is refused, not followed;
* files are opened ``O_NOFOLLOW | O_NONBLOCK`` and must be regular files (``fstat``), with a
  size cap checked before and while reading;
* walks are iterative (no recursion) with caps on depth, entry count and bytes;
* new files are created ``O_CREAT | O_EXCL`` (an existing name is never overwritten through);
* a tree is removed under two folder descriptors, without recursion (:func:`remove_tree`): never
  through a link, however deep.

Example
-------
>>> import tempfile, os
>>> from labkit.course._safefs import read_tree, write_tree
>>> with tempfile.TemporaryDirectory() as a, tempfile.TemporaryDirectory() as b:
...     _ = write_tree({"x/f.txt": b"hi"}, a)
...     os.symlink("/etc/passwd", os.path.join(a, "x", "link"))
...     read_tree(a)
{'x/f.txt': b'hi'}
"""

from __future__ import annotations

import contextlib
import os
import stat
import threading
from pathlib import Path, PurePosixPath

from labkit.exceptions import LabkitError

__all__ = ["UnsafeFile", "TreeLimits", "read_file", "read_tree", "write_tree", "remove_tree", "socket_ready", "active"]

_DIR_FLAGS = os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | os.O_CLOEXEC
_FILE_FLAGS = os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC
_NEW_FLAGS = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
_state = threading.local()


class UnsafeFile(LabkitError, OSError):
    """A file the grader will not read or write: a link, not a regular file or folder, or over a cap."""


class TreeLimits(LabkitError, ValueError):
    """A folder over a walk's caps (depth, number of entries, bytes); the message says which."""


def active() -> bool:
    """True while this thread is inside one of this module's functions (for tests auditing file access).

    Returns
    -------
    bool
    """
    return getattr(_state, "depth", 0) > 0


@contextlib.contextmanager
def _inside():
    _state.depth = getattr(_state, "depth", 0) + 1
    try:
        yield
    finally:
        _state.depth -= 1


def _open_dir(path, dir_fd=None) -> int:
    try:
        return os.open(path, _DIR_FLAGS, dir_fd=dir_fd)
    except OSError as exc:
        if exc.errno in (20, 40):  # ENOTDIR, ELOOP: a file or a link where a folder was expected
            raise UnsafeFile(f"expected a folder (not a link), got {os.fsdecode(path)!r}: {exc.strerror}") from None
        raise


def _read_fd(fd, name, max_bytes) -> bytes:
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        raise UnsafeFile(f"expected a regular file, got {name!r} (mode {stat.filemode(st.st_mode)})")
    if st.st_size > max_bytes:
        raise UnsafeFile(f"expected at most {max_bytes} bytes in {name!r}, got {st.st_size}")
    chunks, total = [], 0
    while True:
        chunk = os.read(fd, min(1 << 20, max_bytes + 1 - total))
        if not chunk:
            return b"".join(chunks)
        chunks.append(chunk)
        total += len(chunk)
        if total > max_bytes:  # it grew while we read
            raise UnsafeFile(f"expected at most {max_bytes} bytes in {name!r}, got more")


def read_file(folder, name, *, max_bytes) -> bytes:
    """The bytes of the regular file ``name`` directly in ``folder``, never through a link.

    Parameters
    ----------
    folder : str or os.PathLike
        A folder the grader made (the path itself must not be a link).
    name : str
        The file's name in it (no ``/``).
    max_bytes : int
        Largest size accepted [bytes].

    Returns
    -------
    bytes

    Raises
    ------
    FileNotFoundError
        If there is no such entry.
    UnsafeFile
        If it is a link, a folder, a FIFO, a device or a socket, or over ``max_bytes``.
    """
    if "/" in str(name) or name in ("", ".", ".."):
        raise UnsafeFile(f"expected a file name without '/', got {name!r}")
    with _inside():
        dfd = _open_dir(folder)
        try:
            try:
                fd = os.open(name, _FILE_FLAGS, dir_fd=dfd)
            except OSError as exc:
                if exc.errno == 40:  # ELOOP: the name is a symlink
                    raise UnsafeFile(f"expected a regular file, got a symbolic link {name!r}") from None
                raise
            try:
                return _read_fd(fd, name, max_bytes)
            finally:
                os.close(fd)
        finally:
            os.close(dfd)


def read_tree(root, *, max_depth=32, max_entries=10_000, max_bytes=None, skip=(".ipynb_checkpoints",)) -> dict:
    """The regular files under ``root`` as ``{relative posix path: bytes}``; links and special files left out.

    The walk is iterative and every folder is opened under its parent's descriptor, so a folder
    replaced by a link is never entered.

    Parameters
    ----------
    root : str or os.PathLike
        The folder (itself not a link).
    max_depth : int
        Deepest folder level accepted (``root`` is level 0).
    max_entries : int
        Most entries (files, folders, links, anything) accepted in all.
    max_bytes : int, optional
        Largest total size of the regular files [bytes].
    skip : sequence of str
        Folder names not entered.

    Returns
    -------
    dict of str to bytes
        Names are the file system's (bytes that are not UTF-8 appear as surrogate escapes).

    Raises
    ------
    TreeLimits
        Over one of the caps (the message names it).
    UnsafeFile
        If ``root`` is not a folder or is a link.
    """
    files, total, count = {}, 0, 0
    with _inside():
        stack = [(_open_dir(root), ())]
        try:
            while stack:
                dfd, parts = stack.pop()
                try:
                    with os.scandir(dfd) as it:
                        entries = sorted(it, key=lambda e: e.name)
                    for entry in entries:
                        count += 1
                        if count > max_entries:
                            raise TreeLimits(f"expected at most {max_entries} files and folders in {Path(root).name!r}, "
                                             "got more")
                        st = entry.stat(follow_symlinks=False)
                        if stat.S_ISDIR(st.st_mode):
                            if entry.name in skip:
                                continue
                            if len(parts) + 1 > max_depth:
                                raise TreeLimits(f"expected folders at most {max_depth} deep in "
                                                 f"{Path(root).name!r}, got deeper")
                            try:
                                stack.append((_open_dir(entry.name, dfd), (*parts, entry.name)))
                            except UnsafeFile:
                                continue  # replaced by a link meanwhile
                        elif stat.S_ISREG(st.st_mode):
                            if max_bytes is not None and total + st.st_size > max_bytes:
                                raise TreeLimits(f"expected at most {max_bytes} bytes in {Path(root).name!r}, got more")
                            try:
                                fd = os.open(entry.name, _FILE_FLAGS, dir_fd=dfd)
                            except OSError:
                                continue  # a link now, or gone
                            try:
                                data = _read_fd(fd, entry.name, max_bytes - total if max_bytes is not None else 2**62)
                            except UnsafeFile:
                                continue
                            finally:
                                os.close(fd)
                            total += len(data)
                            files["/".join((*parts, entry.name))] = data
                finally:
                    os.close(dfd)
        finally:
            for dfd, _ in stack:
                os.close(dfd)
    return dict(sorted(files.items()))


def write_tree(files, dest, *, replace=False) -> Path:
    """Create ``{relative path: bytes}`` under ``dest`` (made if missing), never through a link.

    Parameters
    ----------
    files : dict of str to bytes
        As returned by :func:`read_tree`.
    dest : str or os.PathLike
        Target folder (itself not a link).
    replace : bool
        Replace a file already there (False: leave it and skip the new one). A link in the way
        is removed, never written through.

    Returns
    -------
    pathlib.Path
        ``dest``.

    Raises
    ------
    LabkitError
        For an absolute path or one with ``..``.
    UnsafeFile
        If a folder on the way is a file or a link.
    """
    dest = Path(dest)
    with _inside():
        os.makedirs(dest, exist_ok=True)
        root = _open_dir(dest)
        try:
            for rel, data in files.items():
                pure = PurePosixPath(rel)
                if pure.is_absolute() or ".." in pure.parts or not pure.parts:
                    raise LabkitError(f"expected a relative path inside the folder, got {rel!r}")
                dfd = os.dup(root)
                try:
                    for part in pure.parts[:-1]:
                        try:
                            os.mkdir(part, 0o700, dir_fd=dfd)
                        except FileExistsError:
                            pass
                        nfd = _open_dir(part, dfd)
                        os.close(dfd)
                        dfd = nfd
                    name = pure.parts[-1]
                    try:
                        fd = os.open(name, _NEW_FLAGS, 0o600, dir_fd=dfd)
                    except FileExistsError:
                        st = os.stat(name, dir_fd=dfd, follow_symlinks=False)
                        if not replace and not stat.S_ISLNK(st.st_mode):
                            continue
                        if stat.S_ISDIR(st.st_mode):
                            raise UnsafeFile(f"expected a file at {rel!r}, got a folder") from None
                        os.unlink(name, dir_fd=dfd)
                        fd = os.open(name, _NEW_FLAGS, 0o600, dir_fd=dfd)
                    with os.fdopen(fd, "wb") as f:
                        f.write(data)
                finally:
                    os.close(dfd)
        finally:
            os.close(root)
    return dest


def remove_tree(path) -> None:
    """Remove a folder and everything in it, never following a link, however deep (nothing if it is gone).

    The walk holds two folder descriptors at a time and no recursion: a sub-folder that is not
    empty has its entries moved up into ``path`` (renamed under the two descriptors), then is
    removed; so a tree thousands of folders deep (a kernel can make one in its working copy)
    goes as a flat one does (:func:`shutil.rmtree` recurses and stops at Python's recursion
    limit, leaving the tree). A folder the grader may not enter or change (a kernel ran
    ``chmod 000`` on it: the grader owns it) is made ``0700`` first, through a descriptor
    opened without following a link. Errors on the way leave the rest in place, never raise.

    Parameters
    ----------
    path : str or os.PathLike
        A folder the grader made (itself not a link: then nothing is removed).
    """
    with _inside():
        path = os.path.abspath(os.fspath(path))
        try:  # the folders above are the grader's (a TMPDIR that is a link is followed); the folder itself is not
            parent = _open_dir(os.path.realpath(os.path.dirname(path)))
        except OSError:
            return
        name = os.path.basename(path)
        try:
            top = _open_dir_owned(name, parent)
            if top is None:
                return
            try:
                _empty(top)
            finally:
                os.close(top)
            os.rmdir(name, dir_fd=parent)
        except OSError:
            pass
        finally:
            os.close(parent)


def _owned(name, dir_fd) -> bool:
    """True if ``name`` under ``dir_fd`` is a folder, made ``rwx`` for its owner if it was not (a kernel's chmod: the
    grader could not list, empty or move it), through a descriptor that follows no link."""
    try:
        st = os.stat(name, dir_fd=dir_fd, follow_symlinks=False)
    except OSError:
        return False
    if not stat.S_ISDIR(st.st_mode):
        return False
    if st.st_mode & 0o700 != 0o700:
        try:
            handle = os.open(name, os.O_PATH | os.O_NOFOLLOW | os.O_DIRECTORY | os.O_CLOEXEC, dir_fd=dir_fd)
        except OSError:
            return False
        try:
            os.chmod(f"/proc/self/fd/{handle}", 0o700)  # the folder opened above, never a link's target
        except OSError:
            pass
        finally:
            os.close(handle)
    return True


def _open_dir_owned(name, dir_fd):
    """``_open_dir(name, dir_fd)`` after :func:`_owned`; None if it is gone, not a folder or cannot be opened."""
    if not _owned(name, dir_fd):
        return None
    try:
        return _open_dir(name, dir_fd)
    except OSError:
        return None


def _empty(top) -> None:
    """Remove everything in the folder open as ``top``, moving the entries of deeper folders up into it first."""
    fresh = 0
    while True:
        with os.scandir(top) as it:
            names = [e.name for e in it]
        if not names:
            return
        progress = False
        for name in names:
            try:
                st = os.stat(name, dir_fd=top, follow_symlinks=False)
            except OSError:
                continue
            if not stat.S_ISDIR(st.st_mode):
                try:
                    os.unlink(name, dir_fd=top)
                    progress = True
                except OSError:
                    pass
                continue
            try:
                os.rmdir(name, dir_fd=top)
                progress = True
                continue
            except OSError:
                pass
            child = _open_dir_owned(name, top)
            if child is None:
                continue
            try:
                with os.scandir(child) as it:
                    inner = [e.name for e in it]
                for entry in inner:
                    while True:
                        fresh += 1
                        moved = f".labkit-rm-{fresh}"
                        try:
                            os.stat(moved, dir_fd=top, follow_symlinks=False)
                        except FileNotFoundError:
                            break
                    _owned(entry, child)  # a folder moves only with write permission on it (its "..")
                    try:
                        os.rename(entry, moved, src_dir_fd=child, dst_dir_fd=top)
                        progress = True
                    except OSError:
                        pass
            except OSError:
                pass
            finally:
                os.close(child)
        if not progress:
            return


def socket_ready(folder, name) -> bool:
    """True once ``folder/name`` is a listening Unix socket (not a link, not a file): it accepts a connection.

    Parameters
    ----------
    folder : str or os.PathLike
        A folder the grader made (the kernel's socket folder).
    name : str
        The socket's file name.

    Returns
    -------
    bool
    """
    import socket

    with _inside():
        try:
            dfd = _open_dir(folder)
        except OSError:
            return False
        try:
            try:
                st = os.stat(name, dir_fd=dfd, follow_symlinks=False)
            except OSError:
                return False
            if not stat.S_ISSOCK(st.st_mode):
                return False
            probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            try:
                probe.connect(f"/proc/self/fd/{dfd}/{name}")  # the folder by its descriptor, the name a socket
                return True
            except OSError:
                return False
            finally:
                probe.close()
        finally:
            os.close(dfd)
