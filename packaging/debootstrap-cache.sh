#!/usr/bin/env bash
# Makes (once) a tarball of a clean minbase Debian root for SUITE (bookworm, trixie) and
# prints its path. Reruns reuse the tarball, so a test root costs an unpack, not a
# debootstrap. The cache directory is RAYLINK_DEBOOTSTRAP_CACHE (default
# /var/cache/raylink-debootstrap); delete the tarball to start from the archive again.
# Usage: packaging/debootstrap-cache.sh SUITE     (as root)
set -euo pipefail
suite=${1:?usage: $0 SUITE}
mirror=${DEBIAN_MIRROR:-http://deb.debian.org/debian}
cache=${RAYLINK_DEBOOTSTRAP_CACHE:-/var/cache/raylink-debootstrap}
tarball="$cache/$suite-minbase.tar"
if [ ! -s "$tarball" ]; then
  command -v debootstrap >/dev/null || { echo "debootstrap is not installed (apt-get install debootstrap)" >&2; exit 1; }
  mkdir -p "$cache"
  work=$(mktemp -d "$cache/build-$suite.XXXXXX")
  trap 'rm -rf "$work"' EXIT
  echo "debootstrap --variant=minbase $suite (first run; cached in $tarball)" >&2
  debootstrap --variant=minbase "$suite" "$work/root" "$mirror" >&2
  # Empty the package cache; the root is a fresh install otherwise.
  rm -f "$work/root"/var/cache/apt/archives/*.deb
  tar -C "$work/root" --numeric-owner -cf "$tarball.part" .
  mv "$tarball.part" "$tarball"
fi
echo "$tarball"
