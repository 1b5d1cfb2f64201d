#!/usr/bin/env bash
# Tests the .deb on a clean Debian 12 (bookworm) root, as root:
#  1. builds the .deb (packaging/build-deb.sh);
#  2. unpacks a minbase bookworm root (debootstrap, cached by packaging/debootstrap-cache.sh);
#  3. installs the .deb there with `apt-get install ./raylink_*.deb`, so Depends resolve
#     from Debian's archive;
#  4. renders the installed /usr/share/raylink/scenes/cornell-box.toml to EXR and PNG and
#     compares the EXR with one rendered from the source tree with the same options;
#  5. runs `man raylink` and loads the bash completion;
#  6. `dpkg -r raylink` and checks that none of the files it installed are left.
# Any failed step exits non-zero. Needs debootstrap, cargo-deb, dpkg-dev and idiff
# (openimageio-tools). Set RAYLINK_DEB to test an existing .deb instead of building one.
set -euo pipefail
# Pipes into grep read all their input (no -q): with pipefail, a producer still writing
# when grep -q has exited would die of SIGPIPE and fail the test.
cd "$(dirname "$0")/.."
[ "$(id -u)" -eq 0 ] || { echo "test-deb.sh: run as root (debootstrap and chroot)" >&2; exit 1; }
export DEBIAN_FRONTEND=noninteractive LC_ALL=C
render_opts=(--width 64 --height 64 --spp 4 --quiet)
t0=$(date +%s)
step() { echo "== $(( $(date +%s) - t0 ))s: $*"; }

step "build the .deb"
if [ -n "${RAYLINK_DEB:-}" ]; then deb=$RAYLINK_DEB; else deb=$(packaging/build-deb.sh | tail -n 1); fi
test -s "$deb"
dpkg-deb --info "$deb" | sed -n '/Package:/,$p'
# OpenImageIO is loaded at run time through /usr/lib/raylink/libraylink_oiio.so, whose
# libraries dpkg-shlibdeps must have turned into dependencies.
dpkg-deb --field "$deb" Depends | grep libopenimageio >/dev/null ||
  { echo "the package does not depend on OpenImageIO" >&2; exit 1; }
echo "size: $(stat -c %s "$deb") bytes"

step "reference render from the source tree"
work=$(mktemp -d /tmp/raylink-test-deb.XXXXXX)
root="$work/root"
cleanup() {
  for m in "$root/proc" "$root/dev/pts" "$root/dev"; do
    if mountpoint -q "$m" 2>/dev/null; then umount -l "$m" || true; fi
  done
  rm -rf --one-file-system "$work"
}
trap cleanup EXIT
cargo run --release --quiet --bin raylink -- render scenes/cornell-box.toml "${render_opts[@]}" -o "$work/reference.exr"
test -s "$work/reference.exr"

step "unpack a clean bookworm root"
tarball=$(packaging/debootstrap-cache.sh bookworm | tail -n 1)
mkdir "$root"
tar -C "$root" -xf "$tarball"
cp /etc/resolv.conf "$root/etc/resolv.conf"
mount -t proc proc "$root/proc"
mount --bind /dev "$root/dev"
in_root() { chroot "$root" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin HOME=/root LC_ALL=C DEBIAN_FRONTEND=noninteractive TERM=dumb "$@"; }
in_root sh -c '! command -v raylink'   # really clean

step "apt-get install ./$(basename "$deb") (and man-db)"
cp "$deb" "$root/tmp/"
in_root apt-get update -q
t_install=$(date +%s)
in_root apt-get install -y -q --no-install-recommends "/tmp/$(basename "$deb")"
in_root raylink --version
# Installed, the program loads its interface to OpenImageIO from /usr/lib/raylink.
in_root env LD_DEBUG=files raylink render /usr/share/raylink/scenes/cornell-box.toml \
  --width 8 --height 8 --spp 1 --quiet -o /tmp/probe.png 2>&1 |
  grep "file=/usr/lib/raylink/libraylink_oiio.so" >/dev/null ||
  { echo "the installed libraylink_oiio.so was not loaded" >&2; exit 1; }
in_root raylink render /usr/share/raylink/scenes/cornell-box.toml "${render_opts[@]}" -o /tmp/out.exr -o /tmp/out.png
echo "install to first render: $(( $(date +%s) - t_install ))s"

step "check the outputs"
test -s "$root/tmp/out.exr" && test -s "$root/tmp/out.png"
file_type=$(head -c 8 "$root/tmp/out.png" | od -An -tx1 | tr -d ' \n')
[ "$file_type" = "89504e470d0a1a0a" ] || { echo "out.png is not a PNG" >&2; exit 1; }
iinfo "$root/tmp/out.exr" | grep "64 x   64" >/dev/null || { iinfo "$root/tmp/out.exr"; echo "out.exr: wrong size" >&2; exit 1; }
# The same binary, scene, options and fixed seed, and the image does not depend on the
# thread count: the EXRs are expected to be identical. The 1e-6 tolerance only absorbs
# last-bit differences should the math libraries of the two systems ever differ.
idiff -fail 1e-6 -failpercent 0 -warn 1e-6 "$work/reference.exr" "$root/tmp/out.exr"
# Every installed example scene loads (renders at 8x8, 1 spp).
for s in "$root"/usr/share/raylink/scenes/*.toml "$root"/usr/share/raylink/scenes/*.pbrt; do
  in_root raylink render "/usr/share/raylink/scenes/$(basename "$s")" --width 8 --height 8 --spp 1 --quiet -o /tmp/scene.png
done

step "man raylink and the completions"
in_root apt-get install -y -q --no-install-recommends man-db
in_root man -P cat raylink > "$work/man.txt"
grep -q "raylink" "$work/man.txt" && grep -q "render" "$work/man.txt"
head -n 12 "$work/man.txt"
in_root apt-get install -y -q --no-install-recommends bash-completion
in_root bash -c 'set -e; source /usr/share/bash-completion/bash_completion; source /usr/share/bash-completion/completions/raylink; complete -p raylink'
# Complete `raylink re<TAB>` with the loaded function.
in_root bash -c 'source /usr/share/bash-completion/completions/raylink
  COMP_WORDS=(raylink re); COMP_CWORD=1; COMP_LINE="raylink re"; COMP_POINT=${#COMP_LINE}
  f=$(complete -p raylink | sed -E "s/.*-F ([^ ]+).*/\1/"); "$f" raylink re raylink
  printf "%s\n" "${COMPREPLY[@]}"' | grep -x render >/dev/null
# zsh: compinit finds _raylink on the default fpath and binds it to raylink.
in_root apt-get install -y -q --no-install-recommends zsh fish
in_root zsh -fc 'autoload -Uz compinit && compinit -u && print -r -- "$_comps[raylink]"' | grep -x _raylink >/dev/null
# fish: completing `raylink re` from the vendor completions offers `render`.
in_root fish -c 'complete --do-complete "raylink re"' | grep "^render" >/dev/null
# The documents the man page names are installed.
grep -q "/usr/share/doc/raylink" "$work/man.txt"
test -s "$root/usr/share/doc/raylink/scene-format.md"

step "dpkg -r raylink leaves nothing behind"
in_root dpkg -L raylink > "$work/files.txt"
in_root dpkg -r raylink
left=0
while IFS= read -r f; do
  [ "$f" = "/." ] && continue
  if [ -d "$root$f" ] && [ ! -L "$root$f" ]; then
    # A directory may stay only if another package owns it.
    if ! in_root dpkg -S "$f" >/dev/null 2>&1; then echo "left behind: $f/" >&2; left=1; fi
  elif [ -e "$root$f" ] || [ -L "$root$f" ]; then
    echo "left behind: $f" >&2; left=1
  fi
done < "$work/files.txt"
[ "$left" -eq 0 ]
if in_root dpkg -s raylink 2>/dev/null | grep "^Status: install" >/dev/null; then echo "raylink still installed" >&2; exit 1; fi
in_root sh -c '! command -v raylink'
step "all checks passed"
