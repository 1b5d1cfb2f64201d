#!/usr/bin/env python3
"""Path-tracing throughput and error of raylink against Mitsuba 3 on the Bitterli Cornell box.

Both render the scene of scenes/cornell-box-bitterli at the same resolution and sample count
with their path integrators and the same path length (Mitsuba's max_depth 8 counts the
camera segment: it is 7 bounces, raylink's --max-depth 7). Throughput is camera paths per
second of render time (scene loading excluded for both). Errors are RMSEs against Tungsten's
converged render, box-downsampled, with the light's pixels excluded (as in
tests/monte_carlo.rs): by default the 256x256 copy in scenes/cornell-box-bitterli, which
serves --size 256 and its divisors; --reference takes another (e.g. the full 1024x1024
TungstenRender.exr from Bitterli's site) for larger sizes. Both use a box pixel filter:
Mitsuba splats each sample into every pixel its filter covers (a tent shares samples between
neighbours and lowers per-pixel noise while correlating pixels), raylink samples its filter
by importance (each pixel keeps its own samples), so only the box filter compares the
estimators themselves. Each renderer runs --reps times; medians are reported.

Setup: python3 -m venv /tmp/mi && /tmp/mi/bin/pip install mitsuba
Run:   cargo build --release --example compare && /tmp/mi/bin/python benches/mitsuba_compare.py
"""

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(ROOT, "scenes", "cornell-box-bitterli")


def rmse(image, reference, size):
    out = subprocess.run(
        [os.path.join(ROOT, "target/release/examples/compare"), image, reference, str(size)],
        check=True, capture_output=True, text=True).stdout
    return float(re.search(r"without light pixels ([0-9.]+)", out).group(1))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--max-depth", type=int, default=8, help="Mitsuba's max_depth")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--reference", default=os.path.join(SCENE, "TungstenRender-256.exr"),
                    help="Tungsten's render; its size must be a multiple of --size")
    args = ap.parse_args()
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    reference = args.reference
    tmp = tempfile.mkdtemp()
    pixels = args.size * args.size

    mi_times, mi_errors = [], []
    for rep in range(args.reps):
        with open(os.path.join(SCENE, "mitsuba-scene_v3.xml")) as f:
            xml = f.read().replace('<rfilter type="tent" />', '<rfilter type="box" />')
        scene = mi.load_string(xml, spp=args.spp, resx=args.size, resy=args.size,
                               max_depth=args.max_depth)
        start = time.perf_counter()
        image = mi.render(scene, seed=rep)
        mi_times.append(time.perf_counter() - start)
        path = os.path.join(tmp, f"mitsuba{rep}.exr")
        mi.Bitmap(image).write(path)  # synchronous (write_bitmap may return before the file exists)
        mi_errors.append(rmse(path, reference, args.size))

    rl_times, rl_errors = [], []
    binary = os.path.join(ROOT, "target/release/raylink")
    for rep in range(args.reps):
        path = os.path.join(tmp, f"raylink{rep}.exr")
        out = subprocess.run(
            [binary, "render", os.path.join(ROOT, "scenes/cornell-box.toml"), "--integrator",
             "path", "--width", str(args.size), "--height", str(args.size), "--spp",
             str(args.spp), "--max-depth", str(args.max_depth - 1), "--filter", "box", "--seed", str(rep),
             "-o", path],
            check=True, capture_output=True, text=True).stderr
        rl_times.append(float(re.search(r"rendered in ([0-9.]+) s", out).group(1)))
        rl_errors.append(rmse(path, reference, args.size))

    def paths_per_s(times):
        return pixels * args.spp / statistics.median(times)

    mi_rate, rl_rate = paths_per_s(mi_times), paths_per_s(rl_times)
    print(f"{args.size}x{args.size}, {args.spp} spp, {args.max_depth - 1} bounces, "
          f"{os.cpu_count()} threads, median of {args.reps}")
    print(f"mitsuba {mi.__version__} scalar_rgb: {statistics.median(mi_times):.2f} s, "
          f"{mi_rate / 1e6:.2f} M paths/s, RMSE {statistics.median(mi_errors):.5f}")
    print(f"raylink:            {statistics.median(rl_times):.2f} s, "
          f"{rl_rate / 1e6:.2f} M paths/s, RMSE {statistics.median(rl_errors):.5f}")
    print(f"throughput ratio raylink/mitsuba: {rl_rate / mi_rate:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
