#!/usr/bin/env bash
# FFI hygiene: runs the tests of the Embree and OpenImageIO wrappers (tests/embree.rs,
# tests/oiio.rs) under valgrind. Any invalid read or write, use of uninitialised memory or
# definite leak fails the script. Needs valgrind (apt-get install valgrind).
set -euo pipefail
cd "$(dirname "$0")/.."

# The test executables, built once (cargo prints their paths as JSON).
mapfile -t binaries < <(cargo test --no-run --test embree --test oiio --message-format=json 2>/dev/null |
    python3 -c 'import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m.get("executable") and m["target"]["kind"] == ["test"]:
        print(m["executable"])')
[ ${#binaries[@]} -eq 2 ] || { echo "valgrind-ffi: expected 2 test binaries, got ${#binaries[@]}" >&2; exit 1; }

for bin in "${binaries[@]}"; do
    echo "== valgrind $(basename "$bin")"
    # valgrind does not emulate the flush-to-zero bits of MXCSR, so that one test is skipped.
    valgrind --quiet --error-exitcode=99 --leak-check=full --show-leak-kinds=definite \
        --suppressions=scripts/valgrind-ffi.supp \
        --errors-for-leak-kinds=definite "$bin" --test-threads=1 --skip flush_to_zero
done
echo "valgrind-ffi: no memory errors and no definite leaks in the wrapper tests"
