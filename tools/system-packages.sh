#!/usr/bin/env bash
# Install the Debian packages the named test groups need (tools/system-packages.txt), e.g.
#   bash tools/system-packages.sh test browser
# Nothing to do: silent, exit 0. Missing packages: `apt-get install` as root; not root (or no
# apt on this host): one line naming them, exit 2. FACESYNTH_SYSTEM_PACKAGES names another list.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
list="${FACESYNTH_SYSTEM_PACKAGES:-$here/system-packages.txt}"
if [ "$#" -eq 0 ]; then
  echo "usage: tools/system-packages.sh GROUP..." >&2
  exit 2
fi
if [ ! -r "$list" ]; then
  echo "system-packages: error: cannot read the package list $list" >&2
  exit 2
fi
wanted=()
for group in "$@"; do
  line=$(grep -E "^${group}:" "$list" || true)
  if [ -z "$line" ]; then
    echo "system-packages: error: no group '$group' in $list" >&2
    exit 2
  fi
  read -r -a packages <<<"${line#*:}"
  wanted+=("${packages[@]}")
done
# Every group runs in the project's venv: Debian's python3 makes one only with python3-venv.
if ! "${PYTHON:-python3}" -c "import venv, ensurepip" >/dev/null 2>&1; then
  wanted+=(python3-venv)
fi
missing=()
for package in "${wanted[@]}"; do
  case " ${missing[*]-} " in *" $package "*) continue ;; esac
  status=$(dpkg-query -W -f='${Status}' "$package" 2>/dev/null || true)
  [ "$status" = "install ok installed" ] || missing+=("$package")
done
if [ "${#missing[@]}" -gt 0 ]; then
  if ! command -v apt-get >/dev/null 2>&1 || ! command -v dpkg-query >/dev/null 2>&1; then
    echo "system-packages: error: the $* tests need the Debian packages ${missing[*]} (or this host's equivalents); this host has no apt" >&2
    exit 2
  fi
  if [ "$(id -u)" -ne 0 ]; then
    echo "system-packages: error: the $* tests need the Debian packages ${missing[*]}: run as root, or sudo apt-get install ${missing[*]}" >&2
    exit 2
  fi
  echo "system-packages: installing ${missing[*]} for the $* tests" >&2
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
fi
# The arm64 group runs arm64 programs through binfmt_misc: qemu-aarch64-static registered.
if [[ " $* " == *" arm64 "* ]] && [ ! -e /proc/sys/fs/binfmt_misc/qemu-aarch64 ]; then
  if [ "$(id -u)" -ne 0 ]; then
    echo "system-packages: error: the arm64 tests need qemu-aarch64 registered in binfmt_misc: run as root" >&2
    exit 2
  fi
  [ -e /proc/sys/fs/binfmt_misc/status ] || mount -t binfmt_misc binfmt_misc /proc/sys/fs/binfmt_misc
  [ -e /proc/sys/fs/binfmt_misc/qemu-aarch64 ] || update-binfmts --enable qemu-aarch64
fi
