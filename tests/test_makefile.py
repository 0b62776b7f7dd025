"""The README's commands install into the right Python: the active virtualenv, else the project's own .venv/."""

import os
import re
import subprocess
import sys
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


def _readme_setup_commands():
    """The commands of the README's set-up block ("make reports", "make test"), in order."""
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    block = readme.split("## Set up", 1)[1].split("```sh\n", 1)[1].split("```", 1)[0]
    return [line.split("#")[0].strip() for line in block.splitlines() if line.strip()]


def test_ci_runs_the_readmes_commands_as_a_newcomer_with_debians_python():
    """.ci/run runs the README's set-up commands, in its order, with the distribution's externally managed
    /usr/bin/python3 first on PATH and no virtualenv active: what CI proves is the project-.venv path."""
    commands = _readme_setup_commands()
    assert commands == ["make reports", "make test"], commands
    ci = (REPO / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    runs = [(i, m.group(1)) for i, m in enumerate(re.match(r"(?:exec )?(make \S+ BASE_PYTHON=\S+)( \|\| status=\$\?)?$",
                                                           line) for line in ci) if m]
    assert [run for _, run in runs] == [f"{c} BASE_PYTHON=/usr/bin/python3" for c in commands], runs
    assert ci[-1] == "exit $status" and "set -eu" in ci  # both run; the run fails if either fails
    first_make = runs[0][0]
    assert ci.index('export PATH="/usr/bin:/bin:$PATH"') < first_make
    assert ci.index("unset VIRTUAL_ENV PYTHONPATH") < first_make
    stdlib = subprocess.run(["/usr/bin/python3", "-c", "import sysconfig; print(sysconfig.get_path('stdlib'))"],
                            capture_output=True, text=True, timeout=60, check=True).stdout.strip()
    assert (Path(stdlib) / "EXTERNALLY-MANAGED").is_file(), f"{stdlib}: /usr/bin/python3 is not externally managed here"


def test_an_active_virtualenv_without_pip_gets_pip(tmp_path):
    """A virtualenv made without pip (`python -m venv --without-pip`, `uv venv`) is used too: make installs pip into
    it with ensurepip before installing labkit."""
    venv = tmp_path / "bare"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    python = str(venv / "bin" / "python")
    assert subprocess.run([python, "-m", "pip", "--version"], capture_output=True).returncode != 0
    base = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MAKELEVEL", "PYTHONPATH")}
    out = subprocess.run(["make", "-C", str(REPO), "pip"], env={**base, "VIRTUAL_ENV": str(venv)},
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    pip = subprocess.run([python, "-m", "pip", "--version"], capture_output=True, text=True)
    assert pip.returncode == 0 and str(venv) in pip.stdout, pip.stdout + pip.stderr
