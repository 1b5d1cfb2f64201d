#!/usr/bin/env bash
# The Python package's tests: a fresh virtual environment (Debian's python3) with maturin,
# NumPy and pytest from PyPI, the wheel built (release, into the shared target directory,
# so the renderer's compiled dependencies are reused) and installed there, and pytest run
# against it and the release `raylink` command (what the tests compare with).
# Usage: python/test.sh [pytest arguments]   (CARGO_TARGET_DIR is honoured)
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
python=${PYTHON:-/usr/bin/python3}
target=${CARGO_TARGET_DIR:-$repo/target}
export CARGO_TARGET_DIR=$target
start=$(date +%s)
work=$(mktemp -d /tmp/raylink-python-XXXXXX)
trap 'rm -rf "$work"' EXIT
"$python" -m venv "$work/venv"
"$work/venv/bin/pip" install --quiet --disable-pip-version-check maturin numpy pytest
cargo build --release --quiet --bin raylink
(cd python && "$work/venv/bin/maturin" build --release --quiet -i "$python" --out "$work/wheels")
wheel=$(ls "$work"/wheels/raylink-*.whl)
"$work/venv/bin/pip" install --quiet --disable-pip-version-check "$wheel"
echo "python: wheel $(basename "$wheel"), $(du -k "$wheel" | cut -f1) KiB; built and installed in $(( $(date +%s) - start )) s"
# From outside the source tree: the installed package is imported, not python/raylink.
cd "$work"
RAYLINK_BIN="$target/release/raylink" "$work/venv/bin/python" -m pytest -q -p no:cacheprovider \
  "$repo/python/tests" "$@"
echo "python: done in $(( $(date +%s) - start )) s"
