#!/usr/bin/env bash
# Builds raylink and runs its test suite on a clean Debian 13 (trixie) root, as root, to
# prove the Embree 4 path (trixie's libembree-dev is Embree 4.3.3, OpenImageIO 2.5):
#  1. unpacks a minbase trixie root (debootstrap, cached by packaging/debootstrap-cache.sh)
#     and installs the build dependencies there with apt (that root is cached too, as
#     trixie-build.tar beside the minbase one);
#  2. bind-mounts this source tree at /src, and the host's Rust toolchain (~/.cargo,
#     ~/.rustup) into it;
#  3. runs `cargo test` there and checks that the binary reports Embree 4.
# The build directory is RAYLINK_DEB13_TARGET (default /var/cache/raylink-debootstrap/
# target-trixie) so reruns are incremental. Exits non-zero if any step or test fails.
set -euo pipefail
cd "$(dirname "$0")/.."
[ "$(id -u)" -eq 0 ] || { echo "test-deb13.sh: run as root (debootstrap and chroot)" >&2; exit 1; }
src=$(pwd)
cache=${RAYLINK_DEBOOTSTRAP_CACHE:-/var/cache/raylink-debootstrap}
target=${RAYLINK_DEB13_TARGET:-$cache/target-trixie}
cargo_home=${CARGO_HOME:-$HOME/.cargo}
rustup_home=${RUSTUP_HOME:-$HOME/.rustup}
toolchain=$(rustup show active-toolchain | cut -d' ' -f1)
# chromium and chromium-driver: the studio's browser test (as scripts/install-deps.sh --tests).
build_deps=(build-essential pkg-config libclang-dev libembree-dev libopenimageio-dev libpng-dev ca-certificates bsdextrautils
  chromium chromium-driver)
t0=$(date +%s)
step() { echo "== $(( $(date +%s) - t0 ))s: $*"; }

work=$(mktemp -d /tmp/raylink-test-deb13.XXXXXX)
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

step "a trixie root with the build dependencies"
build_tar="$cache/trixie-build.tar"
mkdir "$root"
if [ ! -s "$build_tar" ] || [ "$(cat "$build_tar.packages" 2>/dev/null)" != "${build_deps[*]}" ]; then
  minbase=$(packaging/debootstrap-cache.sh trixie | tail -n 1)
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
grep -q '^13\|^trixie' "$root/etc/debian_version" || { echo "not a trixie root: $(cat "$root/etc/debian_version")" >&2; exit 1; }
# debootstrap writes no /etc/hosts: without it "localhost" does not resolve, and chromedriver
# cannot reach the browser it starts (the studio's browser test).
printf '127.0.0.1 localhost\n::1 localhost ip6-localhost ip6-loopback\n' > "$root/etc/hosts"
mount -t proc proc "$root/proc"; mounts+=("$root/proc")
bind /dev /dev
# The pseudo-terminals (a separate mount) for the progress test's script(1).
bind /dev/pts /dev/pts
mkdir -p "$target"
bind "$src" /src
bind "$cargo_home" /opt/cargo
bind "$rustup_home" /opt/rustup
bind "$target" /target
in_root() {
  chroot "$root" /usr/bin/env -i HOME=/root LC_ALL=C.UTF-8 TERM=dumb \
    PATH=/opt/cargo/bin:/usr/sbin:/usr/bin:/sbin:/bin CARGO_HOME=/opt/cargo RUSTUP_HOME=/opt/rustup \
    RUSTUP_TOOLCHAIN="$toolchain" CARGO_TARGET_DIR=/target "$@"
}
echo "Debian $(cat "$root/etc/debian_version"); $(in_root dpkg-query -W libembree-dev libopenimageio-dev | tr '\t\n' ' ')"

step "cargo test (Embree 4)"
in_root sh -c 'cd /src && cargo test --locked --no-fail-fast 2>&1' | tee "$work/test.log"
echo "== summary"
grep -E "^test result:" "$work/test.log" | awk '{p+=$4; f+=$6; i+=$8} END {print "passed " p ", failed " f ", ignored " i}'
# cargo test built the binary too (the integration tests run it): it must report Embree 4.
version=$(in_root /target/debug/raylink --version)
echo "$version"
echo "$version" | grep -q "Embree 4\." || { echo "the trixie build does not use Embree 4" >&2; exit 1; }
step "all checks passed"
