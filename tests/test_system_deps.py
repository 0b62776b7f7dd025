"""tools/install-system-deps.sh on a make-believe Debian or Ubuntu: what it asks apt for, and how.

dpkg-query, apt-get, id and sudo are stand-ins on PATH: a file lists the installed packages (with the
dependencies of the ``clang`` package), apt-get logs its arguments and "installs" what it is asked for.
"""

import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SCRIPT = REPO / "tools" / "install-system-deps.sh"

STUBS = {
    # dpkg-query -W -f=FORMAT PACKAGE: the installed package's status or dependencies, else "no packages found"
    "dpkg-query": r"""#!/bin/sh
eval "pkg=\${$#}"
line=$(grep "^$pkg|" "$FAKE/installed") || { echo "dpkg-query: no packages found matching $pkg" >&2; exit 1; }
case "$2" in
  *Status*) echo "install ok installed" ;;
  *Depends*) echo "${line#*|}" ;;
esac
""",
    # apt-get logs its arguments; `install` adds the packages (clang depends on the distribution's clang-N)
    "apt-get": r"""#!/bin/sh
echo "apt-get $*" >> "$FAKE/log"
case " $* " in *" install "*) ;; *) exit 0 ;; esac
for p in "$@"; do
  case "$p" in
    -*|install|DPkg::*) ;;
    clang) echo "clang|clang-$CLANG (>= $CLANG~)" >> "$FAKE/installed" ;;
    *) echo "$p|" >> "$FAKE/installed" ;;
  esac
done
""",
    "id": "#!/bin/sh\necho 1000\n",  # not root: the script goes through sudo
    "sudo": '#!/bin/sh\necho "sudo $1" >> "$FAKE/log"\nexec "$@"\n',
}


def _run(tmp_path, mode, installed=(), clang=14, distro="debian"):
    """Run the script as `sh install-system-deps.sh MODE`; ``installed`` lists "package|its dependencies"."""
    fake = tmp_path / "fake"
    bin_dir = fake / "bin"
    bin_dir.mkdir(parents=True, exist_ok=True)
    for name, text in STUBS.items():
        (bin_dir / name).write_text(text)
        (bin_dir / name).chmod(0o755)
    listed = [p if "|" in p else p + "|" for p in installed]
    (fake / "installed").write_text("".join(line + "\n" for line in listed))
    (fake / "log").write_text("")
    (fake / "os-release").write_text(f'NAME="{distro.title()}"\nID={distro}\n')
    env = {"PATH": f"{bin_dir}:/usr/bin:/bin", "FAKE": str(fake), "CLANG": str(clang),
           "OS_RELEASE": str(fake / "os-release")}
    run = subprocess.run(["sh", str(SCRIPT), *mode.split()], env=env, capture_output=True, text=True, timeout=60)
    return run, (fake / "log").read_text().splitlines()


def _installs(log):
    """The packages of each `apt-get install` call, in order."""
    return [[w for w in line.split()[1:] if not w.startswith("-") and "::" not in w and w != "install"]
            for line in log if line.startswith("apt-get") and " install " in line]


@pytest.mark.parametrize("distro, clang, chromium", [("debian", 14, "chromium"), ("ubuntu", 18, "chromium-browser")])
def test_a_fresh_machine_gets_its_own_clangs_fuzzing_runtime_and_chromium(tmp_path, distro, clang, chromium):
    """Debian 12: clang-14 and the package chromium; Ubuntu 24.04: clang-18, and chromium-browser (no `chromium`
    there: apt-get would stop with "Package 'chromium' has no installation candidate")."""
    run, log = _run(tmp_path, "test", clang=clang, distro=distro)
    assert run.returncode == 0, run.stderr
    first, runtime = _installs(log)
    assert {"clang", "simavr", "bubblewrap", chromium, "gcc-avr"} <= set(first)
    assert {"chromium", "chromium-browser"} & set(first) == {chromium}, first
    assert not any(p.startswith("libclang-rt") for p in first), first
    assert runtime == [f"libclang-rt-{clang}-dev"], log
    assert sum(line.startswith("apt-get") and " update" in line for line in log) == 1, log  # one update, first
    assert log[1].startswith("apt-get") and log[1].endswith("update -qq"), log


def test_apt_waits_for_the_dpkg_lock_and_goes_through_sudo(tmp_path):
    run, log = _run(tmp_path, "reports")
    assert run.returncode == 0, run.stderr
    calls = [line for line in log if line.startswith("apt-get")]
    assert len(calls) == 2 and all(" -o DPkg::Lock::Timeout=600 " in line for line in calls), log
    assert _installs(log) == [["chromium", "fonts-dejavu-core"]]
    assert [line for line in log if line.startswith("sudo")] == ["sudo env", "sudo env"], log
    assert "installing Debian packages: chromium fonts-dejavu-core" in run.stdout


EVERYTHING = ("bubblewrap util-linux passwd procps gcc-avr avr-libc arduino-core-avr arduino-builder libsimavr-dev "
              "simavr chromium fonts-dejavu-core make").split()


def test_nothing_is_installed_when_everything_is_there(tmp_path):
    run, log = _run(tmp_path, "test", installed=[*EVERYTHING, "clang|clang-18 (>= 18~)", "libclang-rt-18-dev"])
    assert run.returncode == 0 and log == [], (run.stderr, log)
    assert run.stdout == "system packages: all present\n"


def test_a_clang_of_unknown_version_is_an_error_not_a_guess(tmp_path):
    run, log = _run(tmp_path, "test", installed=[*EVERYTHING, "clang|llvm-defaults"])
    assert run.returncode == 1 and log == [], log
    assert "cannot tell which clang-N the package clang depends on" in run.stderr, run.stderr
