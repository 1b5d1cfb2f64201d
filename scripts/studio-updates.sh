#!/usr/bin/env bash
# raylink studio's progressive updates (docs/studio.md): starts `raylink serve` with the path
# tracer, fetches every image as the page does, and prints when each image of the first
# seconds arrived, the updates per second, and the render's time beside `raylink render`'s
# for the same job (what watching costs).
#   scripts/studio-updates.sh [SCENE [WIDTH HEIGHT [SPP]]]
# Default: scenes/cornell-box.toml at 512x512, 64 spp, with the release binary (RAYLINK=path
# to use another).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${RAYLINK:-target/release/raylink}
scene=${1:-scenes/cornell-box.toml}
width=${2:-512}
height=${3:-512}
spp=${4:-64}
[ -x "$bin" ] || { echo "no $bin: cargo build --release first (or set RAYLINK)" >&2; exit 2; }
work=$(mktemp -d)
"$bin" serve "$scene" --integrator path --width "$width" --height "$height" --spp "$spp" \
  --seed 1 --port 0 --quiet > "$work/url" &
pid=$!
trap 'kill -INT $pid 2>/dev/null || true; wait $pid 2>/dev/null || true; rm -rf "$work"' EXIT
for _ in $(seq 200); do grep -q http "$work/url" && break; sleep 0.05; done
url=$(grep -o 'http://[^ ]*' "$work/url")
python3 - "$url" <<'PY'
import json, sys, time, urllib.request

url = sys.argv[1].rstrip('/')
start = time.time()
arrivals, version = [], 0
while True:
    with urllib.request.urlopen(url + '/api/state') as r:
        s = json.load(r)
    if s['image_version'] != version:
        version = s['image_version']
        with urllib.request.urlopen(url + '/api/image') as r:
            r.read()
            spp = float(r.headers['X-Spp'])
        arrivals.append((time.time() - start, spp))
    if s['status'] in ('done', 'failed'):
        break
    time.sleep(0.02)
first = [a for a in arrivals if a[0] <= arrivals[0][0] + 1.0]
print(f"render {s['elapsed']:.2f} s, {len(arrivals)} images; in the first second after the "
      f"first image: {len(first)}")
print("first images (s, spp): " +
      ", ".join(f"{t:.2f} {spp:.1f}" for t, spp in arrivals[:12]))
gaps = [b[0] - a[0] for a, b in zip(arrivals, arrivals[1:])]
if gaps:
    gaps.sort()
    print(f"time between images: median {gaps[len(gaps) // 2] * 1e3:.0f} ms, "
          f"max {gaps[-1] * 1e3:.0f} ms")
PY
"$bin" render "$scene" --integrator path --width "$width" --height "$height" --spp "$spp" \
  --seed 1 -o "$work/render.exr" 2>&1 | grep -o 'rendered in [0-9.]* s' |
  sed 's/^/raylink render: /'
