#!/usr/bin/env python3
"""What spectral mode costs against RGB: time to equal error on a scene (default the
Cornell box).

Each mode renders the scene --seeds times at --spp samples per pixel with seeds of its own,
RGB and spectral runs interleaved (RGB seed 1, spectral seed 1, RGB seed 2, ...), so that a
change in the machine's load hits both alike. A mode's error per sample is the relative
variance of its pixels across the seeds (mean over pixels and channels of var / (mean² +
0.01)) times its spp; its cost per sample is the median render time (as raylink prints it,
scene loading excluded) over its spp. Time to equal error is error per sample times cost
per sample, and the printed ratio is spectral's over RGB's: how much longer spectral mode
takes to reach the same noise. (The two modes converge to slightly different images, so
each is measured against its own mean, not against the other.)

Setup: python3 -m venv /tmp/mi && /tmp/mi/bin/pip install mitsuba numpy (for EXR reading)
Run:   cargo build --release && /tmp/mi/bin/python benches/spectral_cost.py
"""

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile

import mitsuba as mi
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def read(path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[:, :, :3]


def render(args, spectral, seed, out):
    command = [args.raylink, "render", args.scene, "--integrator", args.integrator,
               "--width", str(args.width), "--height", str(args.height), "--spp",
               str(args.spp), "--seed", str(seed), "--spectral",
               "true" if spectral else "false", "-o", out]
    done = subprocess.run(command, capture_output=True, text=True, check=True)
    found = re.search(r"rendered in ([0-9.]+) s", done.stdout + done.stderr)
    if not found:
        sys.exit(f"no render time in the output of {' '.join(command)}")
    return float(found.group(1))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--raylink", default=os.path.join(ROOT, "target/release/raylink"))
    parser.add_argument("--scene", default=os.path.join(ROOT, "scenes/cornell-box.toml"))
    parser.add_argument("--integrator", default="path")
    parser.add_argument("--width", type=int, default=128)
    parser.add_argument("--height", type=int, default=128)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--seeds", type=int, default=6)
    args = parser.parse_args()
    mi.set_variant("scalar_rgb")
    times = {False: [], True: []}
    images = {False: [], True: []}
    with tempfile.TemporaryDirectory() as work:
        for seed in range(1, args.seeds + 1):
            for spectral in (False, True):
                out = os.path.join(work, f"{int(spectral)}-{seed}.exr")
                times[spectral].append(render(args, spectral, seed, out))
                images[spectral].append(read(out))
    rows = {}
    for spectral in (False, True):
        stack = np.stack(images[spectral])
        mean = stack.mean(axis=0)
        var = stack.var(axis=0, ddof=1)
        error_per_sample = float(np.mean(var / (mean * mean + 0.01))) * args.spp
        time_per_sample = statistics.median(times[spectral]) / args.spp
        rows[spectral] = (time_per_sample, error_per_sample)
        name = "spectral" if spectral else "rgb"
        print(f"{name:8} time/spp {time_per_sample * 1e3:8.2f} ms   rel. variance x spp "
              f"{error_per_sample:.5f}   product {time_per_sample * error_per_sample:.3e}")
    (ts, es), (tr, er) = rows[True], rows[False]
    print(f"spectral / rgb: time per sample {ts / tr:.2f}x, variance per sample "
          f"{es / er:.2f}x, time to equal error {ts * es / (tr * er):.2f}x")


if __name__ == "__main__":
    main()
