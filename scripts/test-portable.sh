#!/usr/bin/env bash
# Builds and tests the portable build (`--no-default-features --features portable`: the
# pure-Rust BVH and image codecs) on a clean Debian 12 (bookworm) root that has none of the
# default build's system libraries, as root:
#  1. unpacks a minbase bookworm root (debootstrap, cached by packaging/debootstrap-cache.sh)
#     and installs only what Rust's linker needs (build-essential); that root is cached too,
#     as bookworm-portable.tar beside the minbase one;
#  2. checks that the root has no Embree, OpenImageIO or libclang;
#  3. bind-mounts this source tree at /src and the host's Rust toolchain (~/.cargo,
#     ~/.rustup) into it, the crates fetched on the host first, so that the build is offline;
#  4. builds the binary and runs tests/portable.rs there, then checks with ldd that the
#     binary links no Embree, OpenImageIO or C++ library, and renders the Cornell box.
# The build directory is RAYLINK_PORTABLE_TARGET (default /var/cache/raylink-debootstrap/
# target-portable) so reruns are incremental. Exits non-zero if any step or test fails.
set -euo pipefail
cd "$(dirname "$0")/.."
[ "$(id -u)" -eq 0 ] || { echo "test-portable.sh: run as root (debootstrap and chroot)" >&2; exit 1; }
src=$(pwd)
cache=${RAYLINK_DEBOOTSTRAP_CACHE:-/var/cache/raylink-debootstrap}
target=${RAYLINK_PORTABLE_TARGET:-$cache/target-portable}
cargo_home=${CARGO_HOME:-$HOME/.cargo}
rustup_home=${RUSTUP_HOME:-$HOME/.rustup}
toolchain=$(rustup show active-toolchain | cut -d' ' -f1)
build_deps=(build-essential)
features=(--no-default-features --features portable)
t0=$(date +%s)
step() { echo "== $(( $(date +%s) - t0 ))s: $*"; }

step "fetch the crates on the host (the root builds offline)"
cargo fetch --locked

work=$(mktemp -d /tmp/raylink-test-portable.XXXXXX)
root="$work/root"
mounts=()
cleanup() {
  local i
  for (( i=${#mounts[@]}-1; i>=0; i-- )); do umount -l "${mounts[i]}" 2>/dev/null || true; done
  # Only remove the root once nothing is mounted in it any more.
  if ! grep -q " $root" /proc/mounts; then rm -rf --one-file-system "$work"; fi
}
trap cleanup EXIT
bind() { mkdir -p "$root$2"; mount --bind "$1" "$root$2"; mounts+=("$root$2"); }

step "a bookworm root with only a C toolchain for the linker"
build_tar="$cache/bookworm-portable.tar"
mkdir "$root"
if [ ! -s "$build_tar" ] || [ "$(cat "$build_tar.packages" 2>/dev/null)" != "${build_deps[*]}" ]; then
  minbase=$(packaging/debootstrap-cache.sh bookworm | tail -n 1)
  tar -C "$root" -xf "$minbase"
  cp /etc/resolv.conf "$root/etc/resolv.conf"
  mount -t proc proc "$root/proc"; mounts+=("$root/proc")
  chroot "$root" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin DEBIAN_FRONTEND=noninteractive \
    sh -c "apt-get update -q && apt-get install -y -q --no-install-recommends ${build_deps[*]} && apt-get clean"
  umount "$root/proc"; mounts=()
  tar -C "$root" --numeric-owner -cf "$build_tar.part" .
  mv "$build_tar.part" "$build_tar"
  echo "${build_deps[*]}" > "$build_tar.packages"
else
  tar -C "$root" -xf "$build_tar"
fi
grep -q '^12\|^bookworm' "$root/etc/debian_version" || { echo "not a bookworm root: $(cat "$root/etc/debian_version")" >&2; exit 1; }
mount -t proc proc "$root/proc"; mounts+=("$root/proc")
bind /dev /dev
mkdir -p "$target"
bind "$src" /src
bind "$cargo_home" /opt/cargo
bind "$rustup_home" /opt/rustup
bind "$target" /target
in_root() {
  chroot "$root" /usr/bin/env -i HOME=/root LC_ALL=C.UTF-8 TERM=dumb \
    PATH=/opt/cargo/bin:/usr/sbin:/usr/bin:/sbin:/bin CARGO_HOME=/opt/cargo RUSTUP_HOME=/opt/rustup \
    RUSTUP_TOOLCHAIN="$toolchain" CARGO_TARGET_DIR=/target CARGO_NET_OFFLINE=true "$@"
}

step "the root has no Embree, OpenImageIO or libclang"
found=$(in_root sh -c "dpkg-query -W -f '\${Package}\n' 2>/dev/null; ldconfig -p" |
  grep -iE 'embree|openimageio|libclang|libOpenImageIO' || true)
[ -z "$found" ] || { echo "the root is not clean: $found" >&2; exit 1; }
echo "Debian $(cat "$root/etc/debian_version"); $(in_root gcc --version | head -n 1)"

step "cargo build --release ${features[*]}"
in_root sh -c "cd /src && cargo build --release --locked ${features[*]} 2>&1"

step "cargo test --release ${features[*]} --test portable"
in_root sh -c "cd /src && cargo test --release --locked ${features[*]} --test portable 2>&1"

step "the binary links no system library beyond the C library"
libs=$(in_root ldd /target/release/raylink)
echo "$libs"
if echo "$libs" | grep -iE 'embree|openimageio|oiio|clang|stdc\+\+|not found'; then
  echo "the portable binary links a library it must not" >&2
  exit 1
fi
version=$(in_root /target/release/raylink --version)
echo "$version"
echo "$version" | grep -q "no Embree" || { echo "the portable build reports Embree" >&2; exit 1; }
in_root sh -c 'cd /tmp && /target/release/raylink render /src/scenes/cornell-box.toml \
  --width 64 --height 64 --spp 4 --quiet -o cornell.png && test -s cornell.png'
step "all checks passed"
