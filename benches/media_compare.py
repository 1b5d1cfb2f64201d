#!/usr/bin/env python3
"""Participating media in raylink against Mitsuba 3's volpath: time to equal error.

Both render one of two scenes at its 64x64 with box filters and the scene's path length,
Mitsuba from the same file through scripts/media-reference.py (scalar_rgb, volpath):

- `--scene box`: tests/scenes/media-box.toml, haze filling a closed box, a ball of
  scattering ink, a glass ball holding an absorbing medium (homogeneous media);
- `--scene grid`: tests/scenes/media-grid-box.toml, a cloud of chromatic smoke given as a
  24^3 density grid in a closed box (Mitsuba: a grid volume under one majorant, its only
  kind in scalar_rgb; raylink: its majorant grid).
 Runs are interleaved (Mitsuba, raylink, Mitsuba, raylink, ...) so that a change in
the machine's load hits both alike; each run has its own seed. Time is render time (scene
loading excluded for both). Mitsuba samples with its `multijitter` sampler, its fastest to
equal error on both scenes among independent, stratified, multijitter, ldsampler and
orthogonal (--sampler picks another).

Error is the RMSE against Mitsuba's converged render of the scene
(tests/data/media-box-mitsuba-64.exr at 16384 samples per pixel,
tests/data/media-grid-box-mitsuba-64.exr at 8192; tests/media.rs holds raylink's mean to
each within 1% per channel). The error of an unbiased
estimator falls as 1/sqrt(samples), so a run of t seconds with error e reaches --target-rmse
E in t (e/E)^2. The medians over the runs are compared; --reps must be at least 3.

Setup: python3 -m venv /tmp/mi && /tmp/mi/bin/pip install mitsuba
Run:   cargo build --release && /tmp/mi/bin/python benches/media_compare.py --reps 5
       /tmp/mi/bin/python benches/media_compare.py --scene grid --reps 5
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
SCENES = {
    "box": ("media box", "tests/scenes/media-box.toml", "tests/data/media-box-mitsuba-64.exr"),
    "grid": ("media grid box", "tests/scenes/media-grid-box.toml",
             "tests/data/media-grid-box-mitsuba-64.exr"),
}


def load_reference_script():
    spec = importlib.util.spec_from_file_location(
        "media_reference", os.path.join(ROOT, "scripts/media-reference.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", choices=sorted(SCENES), default="box")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--sampler", default="multijitter",
                    help="Mitsuba's sampler (its fastest to equal error on both scenes)")
    ap.add_argument("--reps", type=int, default=3, help="runs of each renderer (at least 3)")
    ap.add_argument("--target-rmse", type=float, default=0.02)
    args = ap.parse_args()
    if args.reps < 3:
        sys.exit("--reps must be at least 3")
    label, scene_file, reference_file = SCENES[args.scene]
    scene_path = os.path.join(ROOT, scene_file)
    reference_script = load_reference_script()
    mi = reference_script.mi
    reference = np.array(mi.Bitmap(os.path.join(ROOT, reference_file)), dtype=np.float64)[:, :, :3]
    with open(scene_path, "rb") as f:
        scene = tomllib.load(f)
    binary = os.path.join(ROOT, "target/release/raylink")

    def rmse(image):
        return float(np.sqrt(np.mean((np.asarray(image, dtype=np.float64)[:, :, :3] - reference) ** 2)))

    with tempfile.TemporaryDirectory() as tmp:
        description = reference_script.scene_dict(scene, args.spp, tmp)
        description["sensor"]["sampler"]["type"] = args.sampler
        loaded = mi.load_dict(description)

        def mitsuba_run(rep):
            start = time.perf_counter()
            image = mi.render(loaded, seed=rep)
            seconds = time.perf_counter() - start
            return seconds, rmse(image)

        def raylink_run(rep):
            path = os.path.join(tmp, f"raylink{rep}.exr")
            command = [binary, "render", scene_path, "--spp", str(args.spp), "--filter", "box",
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

    print(f"{label} 64x64, {args.spp} spp, box filters, Mitsuba's {args.sampler} sampler, {args.reps} interleaved runs each; "
          f"load average {load_before[0]:.2f} before, {load_after[0]:.2f} after, on "
          f"{os.cpu_count()} cores")
    med = statistics.median
    results = {}
    for name, who in [("mitsuba", f"mitsuba {mi.__version__} scalar_rgb"), ("raylink", "raylink")]:
        times = [t for t, _ in runs[name]]
        errors = [e for _, e in runs[name]]
        to_target = [t * (e / args.target_rmse) ** 2 for t, e in zip(times, errors)]
        print(f"{who:<28} time {med(times):6.2f} s (min {min(times):.2f}), RMSE "
              f"{med(errors):.5f}, to RMSE {args.target_rmse}: {med(to_target):6.2f} s "
              f"(min {min(to_target):.2f})")
        results[name] = (med(times), med(to_target))
    (mt, mtt), (rt, rtt) = results["mitsuba"], results["raylink"]
    print(f"raylink/mitsuba: render time {rt / mt:.2f}, time to RMSE {args.target_rmse} "
          f"{rtt / mtt:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
