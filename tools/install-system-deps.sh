#!/bin/sh
# Install the Debian packages labkit's tests and reports need, if any is missing.
#   tools/install-system-deps.sh test     -> AVR toolchain, arduino-builder, simavr, clang and libFuzzer's runtime (fuzzing), Chromium (PDF), bubblewrap, util-linux, passwd, procps (grading sandbox; the unprivileged-user grading test: useradd, runuser, unshare, ps)
#   tools/install-system-deps.sh reports  -> Chromium (PDF)
#   tools/install-system-deps.sh venv [PYTHON]  -> what `PYTHON -m venv` needs (Debian/Ubuntu: python3.X-venv, which
#                                            carries ensurepip; the distribution's python3 lacks it)
# As root, or through sudo. apt waits up to 10 minutes for a dpkg lock another apt holds.
set -eu
# Chromium: Debian's package `chromium`; Ubuntu has none of that name, its `chromium-browser` installs the snap
chromium=chromium
[ "$(. "${OS_RELEASE:-/etc/os-release}" 2>/dev/null && echo "${ID:-}")" = ubuntu ] && chromium=chromium-browser
case "${1:-test}" in
  test)    pkgs="bubblewrap util-linux passwd procps gcc-avr avr-libc arduino-core-avr arduino-builder libsimavr-dev simavr
                 clang $chromium fonts-dejavu-core make" ;;
  reports) pkgs="$chromium fonts-dejavu-core" ;;
  venv)
    python="${2:-python3}"
    "$python" -c "import ensurepip, venv" 2>/dev/null && { echo "python venv: present"; exit 0; }
    pkgs="$("$python" -c 'import sys; print("python3.%d-venv" % sys.version_info[1])')" ;;
  *) echo "usage: $0 [test|reports|venv [PYTHON]]" >&2; exit 2 ;;
esac

# the packages named that are not installed, each preceded by a space
missing_of() {
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || printf ' %s' "$p"
  done
}

updated=""
# apt-get install the packages named (after one apt-get update), as root or through sudo
apt_install() {
  echo "installing Debian packages: $*"
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null 2>&1 || { echo "error: need root or sudo to install: $*" >&2; exit 1; }
    sudo="sudo"
  fi
  apt="apt-get -o DPkg::Lock::Timeout=600"
  [ -n "$updated" ] || $sudo env DEBIAN_FRONTEND=noninteractive $apt update -qq
  updated=1
  $sudo env DEBIAN_FRONTEND=noninteractive $apt install -y -qq --no-install-recommends "$@"
}

missing="$(missing_of $pkgs)"
[ -z "$missing" ] || apt_install $missing
if [ "${1:-test}" = test ]; then
  # libFuzzer's runtime belongs to the clang the distribution calls `clang` (Debian 12: clang-14, Ubuntu 24.04:
  # clang-18), read from the installed package's dependencies
  version="$(dpkg-query -W -f='${Depends}' clang | sed -n 's/^clang-\([0-9][0-9]*\).*/\1/p')"
  [ -n "$version" ] || { echo "error: cannot tell which clang-N the package clang depends on" >&2; exit 1; }
  runtime="$(missing_of "libclang-rt-$version-dev")"
  [ -z "$runtime" ] || apt_install $runtime
  missing="$missing$runtime"
fi
[ -n "$missing" ] || echo "system packages: all present"
