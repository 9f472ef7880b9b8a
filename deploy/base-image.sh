#!/usr/bin/env bash
# Make the base image facesynth's Dockerfile builds on, without an image registry: a minimal
# Debian bookworm (debootstrap) with python3 and venv, imported into the container engine.
#   deploy/base-image.sh [--arch ARCH] [NAME]
# NAME defaults to facesynth-base:bookworm for this machine's architecture and to
# facesynth-base:bookworm-ARCH for another one (--arch arm64: a Raspberry Pi's; Debian names, as
# dpkg --print-architecture prints them). Another architecture's second stage runs under
# qemu-user-static through binfmt_misc (apt-get install qemu-user-static binfmt-support), and the
# image is marked with that architecture, so `podman build --platform linux/ARCH` finds it.
# ENGINE=docker for Docker. Then: FACESYNTH_BASE_IMAGE=NAME docker-compose build. Where a
# registry is reachable, skip this: the default base image is python:3.11-slim. An existing image
# of that name is kept (FORCE=1 rebuilds it). Needs root and debootstrap; DEBIAN_MIRROR overrides
# debootstrap's mirror.
set -euo pipefail
fail() { echo "base-image.sh: error: $*" >&2; exit 2; }
host_arch=$(dpkg --print-architecture 2>/dev/null || uname -m)
arch=$host_arch
while [ $# -gt 0 ]; do
  case $1 in
    --arch) [ $# -ge 2 ] || fail "--arch needs an architecture (e.g. arm64)"; arch=$2; shift 2 ;;
    --arch=*) arch=${1#--arch=}; shift ;;
    -*) fail "unknown option $1 (usage: base-image.sh [--arch ARCH] [NAME])" ;;
    *) break ;;
  esac
done
[ $# -le 1 ] || fail "one image name at most (usage: base-image.sh [--arch ARCH] [NAME])"
case $arch in
  amd64 | arm64 | armhf | i386 | ppc64el | s390x | riscv64) ;;
  *) fail "unknown architecture '$arch' (Debian names: amd64, arm64, armhf, ...)" ;;
esac
if [ "$arch" = "$host_arch" ]; then default_name=facesynth-base:bookworm
else default_name=facesynth-base:bookworm-$arch; fi
name=${1:-$default_name}
engine=${ENGINE:-podman}
if [ -z "${FORCE:-}" ] && "$engine" image inspect "$name" >/dev/null 2>&1; then
  echo "base image $name exists (FORCE=1 rebuilds it)"
  exit 0
fi
command -v debootstrap >/dev/null || fail "debootstrap is not installed"
if [ "$arch" != "$host_arch" ] && command -v arch-test >/dev/null && ! arch-test "$arch" >/dev/null; then
  fail "this machine cannot run $arch programs: apt-get install qemu-user-static binfmt-support, and mount -t binfmt_misc binfmt_misc /proc/sys/fs/binfmt_misc if it is not mounted"
fi
root=$(mktemp -d)
log=$(mktemp)
trap 'rm -rf "$root" "$log"' EXIT
stage() { "$@" >>"$log" 2>&1 || { tail -20 "$log" >&2; exit 1; }; }
if [ "$arch" = "$host_arch" ]; then
  # shellcheck disable=SC2086 # DEBIAN_MIRROR is one optional word
  stage debootstrap --variant=minbase --include=python3,python3-venv bookworm "$root" \
    ${DEBIAN_MIRROR:-}
else
  # Another architecture: the first stage (downloads, unpacking) runs here, the second (dpkg
  # and the packages' scripts) in the new root under emulation, which makes every program there
  # tens of times slower. The second stage's own parsing of the suite's whole package list
  # (about 50 MB) is such a program: it gets only the stanzas of the packages it installs.
  # shellcheck disable=SC2086 # DEBIAN_MIRROR is one optional word
  stage debootstrap --foreign --arch="$arch" --variant=minbase \
    --include=python3,python3-venv bookworm "$root" ${DEBIAN_MIRROR:-}
  wanted=$(cat "$root/debootstrap/required" "$root/debootstrap/base")
  for list in "$root"/var/lib/apt/lists/*_Packages; do
    awk -v wanted="$wanted" 'BEGIN { n = split(wanted, w, " "); for (i = 1; i <= n; i++) keep[w[i]]
                                    RS = ""; ORS = "\n\n" }
      { split($0, line, "\n"); sub(/^Package: /, "", line[1]); if (line[1] in keep) print }' \
      "$list" >"$list.wanted"
    mv "$list.wanted" "$list"
  done
  stage chroot "$root" /debootstrap/debootstrap --second-stage
fi
# What a container never needs: package caches and lists, documentation, translations.
rm -rf "$root"/var/cache/apt/archives/*.deb "$root"/var/lib/apt/lists/* \
  "$root"/usr/share/doc/* "$root"/usr/share/man/* "$root"/usr/share/locale/* "$root"/usr/share/info/*
tar -C "$root" -c . | "$engine" import --arch "$arch" --change 'CMD ["python3"]' \
  --change 'ENV LANG=C.UTF-8' - "$name" >/dev/null
echo "base image $name ($arch): $("$engine" image inspect --format '{{.Size}}' "$name") bytes"
