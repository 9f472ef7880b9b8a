#!/usr/bin/env bash
# Make the base image facesynth's Dockerfile builds on, without an image registry: a minimal
# Debian bookworm (debootstrap) with python3 and venv, imported into the container engine.
#   deploy/base-image.sh [NAME]        (default facesynth-base:bookworm; ENGINE=docker for Docker)
# Then: FACESYNTH_BASE_IMAGE=NAME docker-compose build. Where a registry is reachable, skip this:
# the default base image is python:3.11-slim. An existing image of that name is kept
# (FORCE=1 rebuilds it). Needs root and debootstrap; DEBIAN_MIRROR overrides debootstrap's mirror.
set -euo pipefail
name=${1:-facesynth-base:bookworm}
engine=${ENGINE:-podman}
if [ -z "${FORCE:-}" ] && "$engine" image inspect "$name" >/dev/null 2>&1; then
  echo "base image $name exists (FORCE=1 rebuilds it)"
  exit 0
fi
command -v debootstrap >/dev/null || { echo "base-image.sh: error: debootstrap is not installed" >&2; exit 2; }
root=$(mktemp -d)
trap 'rm -rf "$root"' EXIT
# shellcheck disable=SC2086 # DEBIAN_MIRROR is one optional word
debootstrap --variant=minbase --include=python3,python3-venv bookworm "$root" ${DEBIAN_MIRROR:-} \
  >"$root.log" 2>&1 || { tail -20 "$root.log" >&2; rm -f "$root.log"; exit 1; }
rm -f "$root.log"
# What a container never needs: package caches and lists, documentation, translations.
rm -rf "$root"/var/cache/apt/archives/*.deb "$root"/var/lib/apt/lists/* \
  "$root"/usr/share/doc/* "$root"/usr/share/man/* "$root"/usr/share/locale/* "$root"/usr/share/info/*
tar -C "$root" -c . | "$engine" import --change 'CMD ["python3"]' \
  --change 'ENV LANG=C.UTF-8' - "$name" >/dev/null
echo "base image $name: $("$engine" image inspect --format '{{.Size}}' "$name") bytes"
