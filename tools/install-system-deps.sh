#!/bin/sh
# Install the Debian packages labkit's tests and reports need, if any is missing.
#   tools/install-system-deps.sh test     -> AVR toolchain, arduino-builder, simavr, clang (fuzzing), Chromium (PDF), bubblewrap, util-linux, passwd, procps (grading sandbox; the unprivileged-user grading test: useradd, runuser, unshare, ps)
#   tools/install-system-deps.sh reports  -> Chromium (PDF)
set -eu
case "${1:-test}" in
  test)    pkgs="bubblewrap util-linux passwd procps gcc-avr avr-libc arduino-core-avr arduino-builder libsimavr-dev simavr clang libclang-rt-14-dev chromium fonts-dejavu-core make" ;;
  reports) pkgs="chromium fonts-dejavu-core" ;;
  *) echo "usage: $0 [test|reports]" >&2; exit 2 ;;
esac
missing=""
for p in $pkgs; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
[ -z "$missing" ] && { echo "system packages: all present"; exit 0; }
echo "installing Debian packages:$missing"
SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends $missing
