#!/usr/bin/env bash
# raylink studio's latencies, as the server measures them (docs/studio.md): from a camera
# request's arrival to the first image of the new view, and from a relight request's
# arrival to its image, for the network integrator. Starts `raylink serve` on a free port,
# moves the camera along an orbit and relights the lamp, and prints the medians.
#   scripts/studio-latency.sh [SCENE [WIDTH HEIGHT [MOVES]]] [-- SERVE OPTIONS]
# Default: scenes/network-room.toml at 640x480, 20 moves and 20 relights, with the release
# binary (RAYLINK=path to use another).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${RAYLINK:-target/release/raylink}
scene=${1:-scenes/network-room.toml}
width=${2:-640}
height=${3:-480}
moves=${4:-20}
shift $(( $# < 4 ? $# : 4 ))
[ "${1:-}" = "--" ] && shift
[ -x "$bin" ] || { echo "no $bin: cargo build --release first (or set RAYLINK)" >&2; exit 2; }
work=$(mktemp -d)
"$bin" serve "$scene" --integrator network --width "$width" --height "$height" --port 0 \
  --quiet "$@" > "$work/url" &
pid=$!
trap 'kill -INT $pid 2>/dev/null || true; wait $pid 2>/dev/null || true; rm -rf "$work"' EXIT
for _ in $(seq 200); do grep -q http "$work/url" && break; sleep 0.05; done
url=$(grep -o 'http://[^ ]*' "$work/url")
python3 - "$url" "$moves" <<'EOF'
import json, math, statistics, sys, time, urllib.request

url, moves = sys.argv[1].rstrip('/'), int(sys.argv[2])

def state():
    with urllib.request.urlopen(url + '/api/state') as r:
        return json.load(r)

def post(path, body):
    req = urllib.request.Request(url + path, json.dumps(body).encode(),
                                 {'Content-Type': 'application/json'})
    urllib.request.urlopen(req).read()

def wait(ready):
    start = time.time()
    while True:
        s = state()
        if s['status'] == 'failed':
            sys.exit(f"failed: {s['error']}")
        if ready(s):
            return s
        if time.time() - start > 300:
            sys.exit('timed out')
        time.sleep(0.005)

s = wait(lambda s: s['status'] == 'done')
print(f"first view (network built and lit): {s['elapsed']:.3f} s render, {s['width']}x{s['height']}")
cam = s['camera']
look, pos = cam['look_at'], cam['position']
r = math.dist(pos, look)
view_ms, full_ms = [], []
for i in range(moves):
    a = 0.6 * math.sin(2 * math.pi * (i + 1) / moves)
    p = [look[0] + r * math.sin(a), pos[1], look[2] + r * math.cos(a)]
    view = s['view'] + 1
    post('/api/camera', {'position': p, 'look_at': look, 'up': cam['up'], 'fov': cam['fov']})
    s = wait(lambda t: t['view'] == view and t['status'] == 'done')
    view_ms.append(s['view_ms'])
    full_ms.append(1e3 * s['elapsed'])
light = s['lights'][0]['name']
relight, prepare = [], []
for i in range(moves + 1):
    k = 0.5 + 1.5 * i / moves
    before = s['version']
    post('/api/relight', {'lights': {light: k}})
    s = wait(lambda t: t['version'] > before and t['status'] == 'done'
             and max(abs(f - k) for f in t['lights'][0]['factor']) < 1e-6)
    relight.append(s['relight_ms'])
    prepare.append(s['relight_prepare_ms'])
med = statistics.median
print(f"camera move -> first image: median {med(view_ms):.1f} ms, max {max(view_ms):.1f} ms over {len(view_ms)} moves")
print(f"then the finished image (the scene's sampling): median {med(full_ms):.1f} ms more")
print(f"first relight (computes the light basis): {relight[0]:.1f} ms")
print(f"relight -> image: median {med(relight[1:]):.1f} ms (the relight alone {med(prepare[1:]):.1f} ms), max {max(relight[1:]):.1f} ms over {len(relight) - 1}")
EOF
