"""The one way the grader touches what a sandbox could write (issue 37, item 1): removing what a kernel left."""

import os
import tempfile
from pathlib import Path

import pytest

from conftest import require
from tests.course import attacks as at
from tests.course import course_lab as cl

DEPTH = 1500  # past Python's recursion limit (1000): shutil.rmtree stops there and leaves the tree


def test_remove_tree_of_any_depth_never_follows_a_link(tmp_path):
    """A tree deeper than Python's recursion limit, with links to a folder and a file outside at the bottom, folders
    the kernel made unreadable, and files beside: all of it goes, nothing outside is touched, nothing raises."""
    from labkit.course._safefs import remove_tree

    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "keep.txt").write_text("kept")
    victim = tmp_path / "victim.txt"
    victim.write_text("kept")
    top = tmp_path / "work"
    top.mkdir()
    (top / "f.txt").write_text("x")
    bottom = at.deep_folder(top, DEPTH)
    try:
        os.symlink(str(outside), "to_folder", dir_fd=bottom)
        os.symlink(str(victim), "to_file", dir_fd=bottom)
        os.mkdir("locked", dir_fd=bottom)
        with open(os.open("locked/file", os.O_WRONLY | os.O_CREAT, 0o600, dir_fd=bottom), "w") as f:
            f.write("x")
        os.chmod(f"/proc/self/fd/{bottom}/locked", 0)
    finally:
        os.close(bottom)
    os.mkdir(top / "closed")
    os.chmod(top / "closed", 0o500)
    remove_tree(top)
    assert not top.exists()
    assert (outside / "keep.txt").read_text() == "kept" and victim.read_text() == "kept"
    remove_tree(top)  # gone already: nothing happens
    link = tmp_path / "link"
    link.symlink_to(outside, target_is_directory=True)
    remove_tree(link)  # a link is not a folder of the grader's: nothing removed through it
    assert (outside / "keep.txt").read_text() == "kept" and link.is_symlink()
    (tmp_path / "real_tmp" / "run").mkdir(parents=True)
    (tmp_path / "tmp_link").symlink_to(tmp_path / "real_tmp", target_is_directory=True)
    remove_tree(tmp_path / "tmp_link" / "run")  # a TMPDIR that is a link: the folder in it goes
    assert not (tmp_path / "real_tmp" / "run").exists()


@pytest.mark.slow
@pytest.mark.xdist_group("grading-loop")  # beside the attack batches (tests/course/test_attacks.py says why)
def test_a_kernels_deep_tree_is_removed_after_grading(tmp_path, monkeypatch):
    """A kernel that leaves a tree 3,000 folders deep (and folders it made unreadable) in its working copy and its
    socket folder gets its row, like any submission, and the grader's temporary folders are gone afterwards (as a
    normal user too: tests/course/test_attacks.py's unprivileged batch)."""
    require("nbgrader")
    from labkit.course import Limits, assign, grade_submission
    from labkit.course._safefs import remove_tree

    lab = cl.write_lab(tmp_path / "lab")
    assign(lab, tmp_path / "student")
    code = cl.SOLUTION + at.deep_tree_code()
    cl.write_submission(tmp_path / "student", tmp_path / "subs" / "deep", code)
    scratch = Path(tempfile.mkdtemp(prefix="lk-", dir="/tmp"))  # short: the kernel's socket paths live under it
    try:
        monkeypatch.setattr(tempfile, "tempdir", str(scratch))
        r = grade_submission(tmp_path / "subs" / "deep", lab, tmp_path / "fb", free={}, html=False,
                             limits=Limits(cpu_seconds=20, wall_seconds=60, memory_bytes=2 * 2**30))
        assert (r.points, r.status) == (4, "ok"), r.detail
        assert not list(scratch.iterdir()), sorted(p.name for p in scratch.iterdir())
    finally:
        monkeypatch.undo()
        remove_tree(scratch)
