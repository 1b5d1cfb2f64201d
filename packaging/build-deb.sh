#!/usr/bin/env bash
# Builds target/debian/raylink_VERSION-1_ARCH.deb with cargo-deb: the release binary, the
# man page and the bash/zsh/fish completions generated from the CLI (`raylink
# generate-assets`), the example scenes, README and copyright ([package.metadata.deb] in
# Cargo.toml). Prints the path of the .deb on its last line.
# Needs cargo-deb (`cargo install cargo-deb --locked`) and dpkg-dev (dpkg-shlibdeps computes
# Depends from the linked libraries).
set -euo pipefail
cd "$(dirname "$0")/.."
command -v cargo-deb >/dev/null || { echo "cargo-deb is missing: cargo install cargo-deb --locked" >&2; exit 1; }
target_dir=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
cargo build --release --bin raylink >&2
rm -rf "$target_dir/release/assets"
"$target_dir/release/raylink" generate-assets "$target_dir/release/assets"
gzip -9n "$target_dir"/release/assets/man/*.1
# The binary is built; cargo-deb packs it without building again, stripped (the release
# profile keeps line tables for backtraces; the package does not need them).
cargo deb --no-build --strip >&2
version=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(next(p["version"] for p in json.load(sys.stdin)["packages"] if p["name"] == "raylink"))')
arch=$(dpkg --print-architecture)
deb="$target_dir/debian/raylink_${version}-1_${arch}.deb"
test -s "$deb" || { echo "cargo deb did not write $deb" >&2; exit 1; }
echo "$deb"
