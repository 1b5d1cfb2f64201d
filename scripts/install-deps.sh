#!/usr/bin/env bash
# Installs the Debian packages raylink builds against: Embree (libembree-dev: Embree 3 on
# Debian 12, Embree 4 on Debian 13), OpenImageIO and libpng (read first to report damaged
# PNGs in one line), libclang for bindgen, and a C++ compiler.
# With --tests, also what the test suite runs: bsdextrautils, whose `script` the progress
# tests run (Debian 13 moved it there from the essential bsdutils), and chromium with
# chromium-driver, the headless browser that tests/studio_browser.rs drives through
# WebDriver to test `raylink serve`'s page (a large download a render does not need), and
# python3-venv for the Python package's tests (python/test.sh).
set -euo pipefail
packages=(build-essential pkg-config libclang-dev libembree-dev libopenimageio-dev libpng-dev)
case "${1:-}" in
  "") ;;
  --tests) packages+=(bsdextrautils chromium chromium-driver python3-venv) ;;
  *) echo "usage: scripts/install-deps.sh [--tests]" >&2; exit 2 ;;
esac
sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update
  $sudo apt-get install -y --no-install-recommends "${missing[@]}"
fi
