#!/usr/bin/env python3
"""Participating media in raylink against Mitsuba 3's volpath: time to equal error.

Both render tests/scenes/media-box.toml (haze filling a closed box, a ball of scattering ink,
a glass ball holding an absorbing medium) at its 64x64 with box filters and the scene's
path length, Mitsuba from the same file through scripts/media-reference.py (scalar_rgb,
volpath). Runs are interleaved (Mitsuba, raylink, Mitsuba, raylink, ...) so that a change in
the machine's load hits both alike; each run has its own seed. Time is render time (scene
loading excluded for both).

Error is the RMSE against tests/data/media-box-mitsuba-64.exr (Mitsuba at 16384 samples per
pixel; raylink's mean agrees with it within 0.3% per channel). The error of an unbiased
estimator falls as 1/sqrt(samples), so a run of t seconds with error e reaches --target-rmse
E in t (e/E)^2. The medians over the runs are compared; --reps must be at least 3.

Setup: python3 -m venv /tmp/mi && /tmp/mi/bin/pip install mitsuba
Run:   cargo build --release && /tmp/mi/bin/python benches/media_compare.py --reps 5
"""

import argparse
import importlib.util
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(ROOT, "tests/scenes/media-box.toml")
REFERENCE = os.path.join(ROOT, "tests/data/media-box-mitsuba-64.exr")


def load_reference_script():
    spec = importlib.util.spec_from_file_location(
        "media_reference", os.path.join(ROOT, "scripts/media-reference.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--reps", type=int, default=3, help="runs of each renderer (at least 3)")
    ap.add_argument("--target-rmse", type=float, default=0.02)
    args = ap.parse_args()
    if args.reps < 3:
        sys.exit("--reps must be at least 3")
    reference_script = load_reference_script()
    mi = reference_script.mi
    reference = np.array(mi.Bitmap(REFERENCE), dtype=np.float64)[:, :, :3]
    with open(SCENE, "rb") as f:
        scene = tomllib.load(f)
    binary = os.path.join(ROOT, "target/release/raylink")

    def rmse(image):
        return float(np.sqrt(np.mean((np.asarray(image, dtype=np.float64)[:, :, :3] - reference) ** 2)))

    with tempfile.TemporaryDirectory() as tmp:
        loaded = mi.load_dict(reference_script.scene_dict(scene, args.spp, tmp))

        def mitsuba_run(rep):
            start = time.perf_counter()
            image = mi.render(loaded, seed=rep)
            seconds = time.perf_counter() - start
            return seconds, rmse(image)

        def raylink_run(rep):
            path = os.path.join(tmp, f"raylink{rep}.exr")
            command = [binary, "render", SCENE, "--spp", str(args.spp), "--filter", "box",
                       "--filter-radius", "0.5", "--seed", str(rep), "-o", path]
            out = subprocess.run(command, check=True, capture_output=True, text=True).stderr
            seconds = float(re.search(r"rendered in ([0-9.]+) s", out).group(1))
            return seconds, rmse(mi.Bitmap(path))

        load_before = os.getloadavg()
        runs = {"mitsuba": [], "raylink": []}
        for rep in range(args.reps):
            runs["mitsuba"].append(mitsuba_run(rep))
            runs["raylink"].append(raylink_run(rep))
        load_after = os.getloadavg()

    print(f"media box 64x64, {args.spp} spp, box filters, {args.reps} interleaved runs each; "
          f"load average {load_before[0]:.2f} before, {load_after[0]:.2f} after, on "
          f"{os.cpu_count()} cores")
    med = statistics.median
    results = {}
    for name, label in [("mitsuba", f"mitsuba {mi.__version__} scalar_rgb"), ("raylink", "raylink")]:
        times = [t for t, _ in runs[name]]
        errors = [e for _, e in runs[name]]
        to_target = [t * (e / args.target_rmse) ** 2 for t, e in zip(times, errors)]
        print(f"{label:<28} time {med(times):6.2f} s (min {min(times):.2f}), RMSE "
              f"{med(errors):.5f}, to RMSE {args.target_rmse}: {med(to_target):6.2f} s "
              f"(min {min(to_target):.2f})")
        results[name] = (med(times), med(to_target))
    (mt, mtt), (rt, rtt) = results["mitsuba"], results["raylink"]
    print(f"raylink/mitsuba: render time {rt / mt:.2f}, time to RMSE {args.target_rmse} "
          f"{rtt / mtt:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
