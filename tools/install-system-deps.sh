#!/bin/sh
# Install the Debian packages labkit's tests and reports need, if any is missing.
#   tools/install-system-deps.sh test     -> AVR toolchain, arduino-builder, simavr, clang (fuzzing), Chromium (PDF), bubblewrap, util-linux, passwd, procps (grading sandbox; the unprivileged-user grading test: useradd, runuser, unshare, ps)
#   tools/install-system-deps.sh reports  -> Chromium (PDF)
#   tools/install-system-deps.sh venv [PYTHON]  -> what `PYTHON -m venv` needs (Debian/Ubuntu: python3.X-venv, which
#                                            carries ensurepip; the distribution's python3 lacks it)
# As root, or through sudo. apt waits up to 10 minutes for a dpkg lock another apt holds.
set -eu
case "${1:-test}" in
  test)    pkgs="bubblewrap util-linux passwd procps gcc-avr avr-libc arduino-core-avr arduino-builder libsimavr-dev simavr clang libclang-rt-14-dev chromium fonts-dejavu-core make" ;;
  reports) pkgs="chromium fonts-dejavu-core" ;;
  venv)
    python="${2:-python3}"
    "$python" -c "import ensurepip, venv" 2>/dev/null && { echo "python venv: present"; exit 0; }
    pkgs="$("$python" -c 'import sys; print("python3.%d-venv" % sys.version_info[1])')" ;;
  *) echo "usage: $0 [test|reports|venv [PYTHON]]" >&2; exit 2 ;;
esac
missing=""
for p in $pkgs; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
[ -z "$missing" ] && { echo "system packages: all present"; exit 0; }
echo "installing Debian packages:$missing"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null 2>&1 || { echo "error: need root or sudo to install:$missing" >&2; exit 1; }
  SUDO="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
apt="apt-get -o DPkg::Lock::Timeout=600"
$SUDO env DEBIAN_FRONTEND=noninteractive $apt update -qq
$SUDO env DEBIAN_FRONTEND=noninteractive $apt install -y -qq --no-install-recommends $missing
