"""Which memory limit a grader picks, on made-up ``/proc/self`` and ``/sys/fs/cgroup`` layouts.

The development and CI machines are cgroup v1 (``/sys/fs/cgroup`` is a tmpfs holding v1 hierarchies), so
the cgroup v2 paths (a delegated subtree, a systemd scope with ``Delegate=yes``) cannot run for real here:
these tests point :mod:`labkit.course._cgroup` at a fake ``/proc/self`` (``mountinfo``, ``cgroup``) and a
fake cgroup file system of plain folders and files, and check the choice, the files written and the
fallback to the watchdog.
"""

import os

import pytest

from labkit.course import _cgroup, memory_cgroup, memory_mechanism
from labkit.course._leftovers import process_start

LIMIT = 300 * 2**20


def _layout(tmp_path, monkeypatch, cgroup_lines, mounts):
    """A fake /proc/self with ``cgroup`` and ``mountinfo``; ``mounts`` is [(mount point, root, fstype, options)]."""
    proc = tmp_path / "proc_self"
    proc.mkdir()
    (proc / "cgroup").write_text("".join(f"{line}\n" for line in cgroup_lines))
    info = [f"{30 + k} 23 0:{28 + k} {root} {point} rw,relatime - {fstype} {fstype} {options}"
            for k, (point, root, fstype, options) in enumerate(mounts)]
    (proc / "mountinfo").write_text("\n".join(["22 1 8:1 / / rw - ext4 /dev/sda1 rw", *info]) + "\n")
    monkeypatch.setattr(_cgroup, "_PROC_SELF", proc)
    return proc


def _v2_folder(base, rel, subtree="", controllers="cpu io memory pids", procs=()):
    folder = base / rel.lstrip("/")
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "cgroup.subtree_control").write_text(subtree + "\n")
    (folder / "cgroup.controllers").write_text(controllers + "\n")
    (folder / "cgroup.procs").write_text("".join(f"{p}\n" for p in procs))
    return folder


def _kernel_files(monkeypatch, under, names):
    """New folders under ``under`` get the files ``names`` at once, as the kernel fills a new cgroup's folder."""
    cls = type(under)
    real_mkdir = cls.mkdir

    def mkdir(path, *args, **kwargs):
        real_mkdir(path, *args, **kwargs)
        if under in path.parents and path.name.startswith("labkit-") and not path.name.endswith("-grader"):
            for name in names:
                (path / name).write_text("0\n")

    monkeypatch.setattr(cls, "mkdir", mkdir)


def _mark_delegated(folder, monkeypatch):
    """systemd's mark of a delegated cgroup (the xattr; faked where the file system has no user xattrs)."""
    try:
        os.setxattr(folder, "user.delegate", b"1")
    except OSError:
        real = os.getxattr
        monkeypatch.setattr(os, "getxattr", lambda p, n: b"1" if (str(p), n) == (str(folder), "user.delegate")
                            else real(p, n))


def test_v1_as_on_this_machine(tmp_path, monkeypatch):
    """cgroup v1 (tmpfs at /sys/fs/cgroup, a memory hierarchy, the process in a cgroup of its own): cgroup v1,
    with memory.limit_in_bytes and, where swap is accounted, memory.memsw.limit_in_bytes."""
    fs = tmp_path / "sys_fs_cgroup"
    own = fs / "memory" / "process_api" / "abc"
    own.mkdir(parents=True)
    (own / "memory.limit_in_bytes").write_text("9223372036854771712\n")
    _kernel_files(monkeypatch, fs, ["memory.memsw.limit_in_bytes"])
    _layout(tmp_path, monkeypatch, ["4:memory:/process_api/abc", "1:cpu:/", "0::/"],
            [(fs, "/", "tmpfs", "rw,mode=755"), (fs / "memory", "/", "cgroup", "rw,memory"),
             (fs / "cpu", "/", "cgroup", "rw,cpu")])
    cgroup = memory_cgroup(LIMIT)
    assert cgroup is not None and cgroup.mechanism == "cgroup v1" and cgroup.path.parent == own
    assert (cgroup.path / "memory.limit_in_bytes").read_text() == str(LIMIT)
    assert (cgroup.path / "memory.memsw.limit_in_bytes").read_text() == str(LIMIT)
    assert cgroup.enter_prefix()[-1] == str(cgroup.path / "cgroup.procs")
    (cgroup.path / "memory.oom_control").write_text("oom_kill_disable 0\nunder_oom 0\noom_kill 2\n")
    assert cgroup.oom_kills() == 2
    for name in ("memory.limit_in_bytes", "memory.memsw.limit_in_bytes", "memory.oom_control"):
        (cgroup.path / name).unlink()  # a real cgroup's files vanish with it
    assert cgroup.remove() and not cgroup.path.exists()
    assert memory_mechanism() == "cgroup v1"


def test_v1_in_a_container_sees_its_own_root(tmp_path, monkeypatch):
    """A container's memory hierarchy mounted with its own cgroup as root: the folder is found under the mount;
    a cgroup outside what the mount shows is not used (watchdog)."""
    fs = tmp_path / "sys_fs_cgroup"
    (fs / "memory" / "job").mkdir(parents=True)
    (fs / "memory" / "job" / "memory.limit_in_bytes").write_text("1\n")
    _layout(tmp_path, monkeypatch, ["4:memory:/docker/c0ffee/job"],
            [(fs / "memory", "/docker/c0ffee", "cgroup", "rw,memory")])
    assert _cgroup._parents() == [(1, fs / "memory" / "job")]
    (tmp_path / "proc_self" / "cgroup").write_text("4:memory:/elsewhere\n")
    assert _cgroup._parents() == [] and memory_mechanism() == "watchdog"


def test_v2_delegated_subtree_comes_first(tmp_path, monkeypatch):
    """A cgroup v2 whose memory controller is enabled for its children (a delegated subtree) is chosen before the
    v1 hierarchy of a hybrid layout; the run's cgroup gets memory.max, memory.swap.max 0 and memory.oom.group 1."""
    fs = tmp_path / "sys_fs_cgroup"
    unified = _v2_folder(fs / "unified", "/grading.slice/grader.service", subtree="memory pids")
    v1 = fs / "memory" / "grading.slice" / "grader.service"
    v1.mkdir(parents=True)
    (v1 / "memory.limit_in_bytes").write_text("1\n")
    _layout(tmp_path, monkeypatch, ["4:memory:/grading.slice/grader.service", "0::/grading.slice/grader.service"],
            [(fs / "memory", "/", "cgroup", "rw,memory"), (fs / "unified", "/", "cgroup2", "rw,nsdelegate")])
    assert _cgroup._parents() == [(2, unified), (1, v1)]
    _kernel_files(monkeypatch, fs, ["memory.swap.max", "memory.oom.group"])
    cgroup = memory_cgroup(LIMIT)
    assert cgroup.mechanism == "cgroup v2" and cgroup.path.parent == unified
    assert [(cgroup.path / n).read_text() for n in ("memory.max", "memory.swap.max", "memory.oom.group")] \
        == [str(LIMIT), "0", "1"]
    (cgroup.path / "memory.events").write_text("low 0\nhigh 0\nmax 7\noom 1\noom_kill 1\noom_group_kill 1\n")
    assert cgroup.oom_kills() == 1


def test_v2_without_delegation_falls_back_to_the_watchdog(tmp_path, monkeypatch):
    """A systemd login session (pure cgroup v2): memory available but not enabled, and the session's scope not
    delegated: nothing is moved, no cgroup is made, the watchdog limits memory (and the gradebook says so)."""
    fs = tmp_path / "sys_fs_cgroup"
    scope = _v2_folder(fs, "/user.slice/user-1000.slice/session-3.scope", procs=(4242,))
    _layout(tmp_path, monkeypatch, ["0::/user.slice/user-1000.slice/session-3.scope"], [(fs, "/", "cgroup2", "rw")])
    assert _cgroup._parents() == [] and memory_cgroup(LIMIT) is None and memory_mechanism() == "watchdog"
    assert (scope / "cgroup.procs").read_text() == "4242\n" and not any(scope.glob("labkit-*"))


def test_v2_delegated_scope_moves_its_processes_to_a_leaf(tmp_path, monkeypatch):
    """``systemd-run --user --scope -p Delegate=yes labkit grade ...``: the scope is marked delegated and has the
    memory controller but has not enabled it (its processes live in it). The grader moves them into a leaf
    ``labkit-<pid>-grader``, enables memory, and makes each run's cgroup beside the leaf; a grader already in such a
    leaf uses its parent."""
    fs = tmp_path / "sys_fs_cgroup"
    rel = "/user.slice/user-1000.slice/user@1000.service/app.slice/run-u7.scope"
    scope = _v2_folder(fs, rel, procs=(os.getpid(), 4242))
    _mark_delegated(scope, monkeypatch)
    _layout(tmp_path, monkeypatch, [f"0::{rel}"], [(fs, "/", "cgroup2", "rw,nsdelegate")])
    assert _cgroup._parents() == [(2, scope)]
    moved = []
    real_write = _cgroup._write

    def write(path, value):  # the kernel: a pid written to a leaf's cgroup.procs leaves the scope
        real_write(path, value)
        if path.name == "cgroup.procs" and path.parent != scope:
            moved.append(int(value))
            left = [p for p in (scope / "cgroup.procs").read_text().split() if int(p) != int(value)]
            (scope / "cgroup.procs").write_text("".join(f"{p}\n" for p in left))
        if path == scope / "cgroup.subtree_control":
            assert not (scope / "cgroup.procs").read_text().split(), "memory enabled with processes inside"
            (scope / "cgroup.subtree_control").write_text("memory\n")

    monkeypatch.setattr(_cgroup, "_write", write)
    cgroup = memory_cgroup(LIMIT)
    leaf = scope / f"labkit-mem-{os.getpid()}-{process_start(os.getpid())}-grader"
    assert cgroup is not None and cgroup.mechanism == "cgroup v2" and cgroup.path.parent == scope
    assert sorted(moved) == sorted([os.getpid(), 4242]) and leaf.is_dir()
    assert (scope / "cgroup.subtree_control").read_text().split() == ["memory"]
    assert (cgroup.path / "memory.max").read_text() == str(LIMIT)
    (tmp_path / "proc_self" / "cgroup").write_text(f"0::{rel}/{leaf.name}\n")  # the grader now lives in the leaf
    assert _cgroup._parents() == [(2, scope)]


def test_no_cgroup_file_system_at_all(tmp_path, monkeypatch):
    """No /proc/self/cgroup, no cgroup mount (a chroot, a very old container): the watchdog."""
    monkeypatch.setattr(_cgroup, "_PROC_SELF", tmp_path / "absent")
    assert _cgroup._parents() == [] and memory_cgroup(LIMIT) is None and memory_mechanism() == "watchdog"


@pytest.mark.parametrize("owner", ["alive", "dead", "pid reused"])
def test_a_dead_graders_empty_cgroup_is_swept(tmp_path, monkeypatch, owner):
    """A cgroup left by a grader killed outright (its pid gone, or given to a process started later) is removed by
    the next run; a live one's is kept, and so is anything not named exactly as labkit names its cgroups."""
    fs = tmp_path / "sys_fs_cgroup"
    own = fs / "memory" / "g"
    own.mkdir(parents=True)
    (own / "memory.limit_in_bytes").write_text("1\n")
    _layout(tmp_path, monkeypatch, ["4:memory:/g"], [(fs / "memory", "/", "cgroup", "rw,memory")])
    pid = os.getppid() if owner != "dead" else 2**22 + 12345  # above pid_max's default: no such process
    start = process_start(os.getppid()) + (1 if owner == "pid reused" else 0)
    left = own / f"labkit-mem-{pid}-{start}-deadbeef"
    others = [own / f"labkit-{pid}-deadbeef", own / f"labkit-grade-{pid}-{start}-deadbeef", own / "labkit-mem-x"]
    for path in [left, *others]:
        path.mkdir()
    cgroup = memory_cgroup(LIMIT)
    assert cgroup is not None and left.exists() == (owner == "alive")
    assert all(p.exists() for p in others)


def test_v2_kill_peak_and_remove(tmp_path, monkeypatch):
    """A run's cgroup v2: killed through cgroup.kill (one write, no pid signalled), its peak read from memory.peak,
    and removed once the kernel has taken its files away."""
    fs = tmp_path / "sys_fs_cgroup"
    unified = _v2_folder(fs, "/grading", subtree="memory")
    _layout(tmp_path, monkeypatch, ["0::/grading"], [(fs, "/", "cgroup2", "rw")])
    _kernel_files(monkeypatch, fs, ["memory.peak", "cgroup.kill", "cgroup.procs"])
    cgroup = memory_cgroup(LIMIT)
    assert cgroup is not None and cgroup.version == 2 and cgroup.path.parent == unified
    (cgroup.path / "cgroup.procs").write_text("4242\n")
    (cgroup.path / "memory.peak").write_text(f"{123 * 2**20}\n")
    signalled = []
    monkeypatch.setattr(os, "kill", lambda pid, sig: signalled.append(pid))
    cgroup.kill()
    assert (cgroup.path / "cgroup.kill").read_text() == "1" and not signalled
    assert cgroup.peak_bytes() == 123 * 2**20 and cgroup.pids() == [4242]
    for f in list(cgroup.path.iterdir()):
        f.unlink()  # what the kernel does when the last process has left
    assert cgroup.remove() and not cgroup.path.exists()
