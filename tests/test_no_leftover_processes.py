"""The suite's own check (tests/conftest.py): a run whose tests leave a process alive fails and names it."""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from conftest import require

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_a_run_that_leaves_a_process_behind_fails_naming_it(tmp_path):
    psutil = require("psutil")
    (tmp_path / "test_leaks.py").write_text(textwrap.dedent("""
        import subprocess, sys

        def test_leaves_a_child():
            subprocess.Popen(["sleep", "97"], start_new_session=True)

        def test_leaves_an_orphan():  # its parent exits: the sleep is reparented (PID 1 or a subreaper)
            subprocess.run([sys.executable, "-c",
                            "import subprocess; subprocess.Popen(['sleep', '98'], start_new_session=True)"])

        def test_leaves_one_with_a_clean_environment(tmp_path):  # found by the run's folder on its command line
            subprocess.Popen(["sh", "-c", f"sleep 99; : {tmp_path}"], env={}, start_new_session=True)
    """))
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_") and k != "LABKIT_TEST_SESSION"}
    env.update(PYTHONPATH=f"{REPO / 'tests'}:{REPO}", LABKIT_TEST_LINGER="1")  # a run of its own, not this one's
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "conftest", "-c",
                          os.devnull, "--rootdir", str(tmp_path), "-n", "2", str(tmp_path / "test_leaks.py")],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 1, run.stdout[-3000:] + run.stderr[-2000:]
    assert "3 passed" in run.stdout and "processes that outlived the suite" in run.stdout, run.stdout[-3000:]
    named = [line for line in run.stdout.splitlines() if line.startswith("  pid ")]
    for seconds, test in (("97", "test_leaves_a_child"), ("98", "test_leaves_an_orphan")):  # and the test that did
        assert any(f"sleep {seconds}" in line and f"started by test_leaks.py::{test}:" in line
                   for line in named), run.stdout[-3000:]
    assert any("sleep 99" in line for line in named), run.stdout[-3000:]  # its environment is empty: no test named
    left = [p.pid for p in psutil.process_iter(["cmdline"]) if (p.info["cmdline"] or [])[:2] in (
        ["sleep", "97"], ["sleep", "98"], ["sleep", "99"])]
    assert not left, f"the check names them and stops them: {left} still alive"
