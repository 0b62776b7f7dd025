"""The README's commands install into the right Python: the active virtualenv, else the project's own .venv/."""

import os
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _dry_run(target, **env):
    base = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "MAKEFLAGS", "MAKELEVEL")}
    out = subprocess.run(["make", "-n", "-C", str(REPO), target], env={**base, **env}, capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_without_a_virtualenv_make_uses_the_projects_venv(tmp_path):
    # the base interpreter named by BASE_PYTHON makes the venv (Debian's /usr/bin/python3 in CI); pip runs in it
    out = _dry_run("install", VENV=str(tmp_path / "v"), BASE_PYTHON="/usr/bin/python3")
    assert f"tools/install-system-deps.sh venv /usr/bin/python3\n/usr/bin/python3 -m venv {tmp_path / 'v'}" in out
    assert f"{tmp_path / 'v'}/bin/python -m pip install -q --config-settings editable_mode=compat -e '.[all]'" in out
    default = _dry_run("install-test")
    assert f"{REPO / '.venv'}/bin/python -m pip install" in default and "'.[all,test,crosscheck]'" in default


def test_an_active_virtualenv_is_used_as_it_is(tmp_path):
    venv = tmp_path / "active"
    (venv / "bin").mkdir(parents=True)
    (venv / "bin" / "python").touch()
    out = _dry_run("reports", VIRTUAL_ENV=str(venv))
    assert " -m venv " not in out and ".venv" not in out
    assert f"{venv}/bin/python -m pip install" in out and f"{venv}/bin/python -m labkit render" in out
