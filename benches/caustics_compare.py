#!/usr/bin/env python3
"""Vertex connection and merging against raylink's other techniques: time to equal error.

Two scenes, each rendered at --width x --height by `vcm`, `bdpt`, `path` and `sppm`:

- `pool`: scenes/pool-caustics.toml, a pool whose wavy water focuses a small lamp into
  caustics on its floor, seen through the same water;
- `box`: scenes/cornell-box.toml, the Cornell box (every surface diffuse).

The reference of each scene is --reference FILE if given (the pool's default at 64x48 is
the one the tests keep, tests/data/pool-caustics-reference-64x48.exr), else the mean of
two halves of --reference-spp samples with their own seeds, rendered by
--reference-integrator (vcm for the pool, bdpt for the box by default; cached in
--cache), less its own noise (estimated from the halves). --photons N and --radius R are
given to vcm and sppm (their light subpaths or photons per iteration, and initial
radius). Error is the
relative RMSE: the square root of the mean over pixels and channels of (v - r)^2 /
(r^2 + 0.01).

Each technique renders at 1, 2, 4, ... samples per pixel (SPPM: iterations) until its error
is below --target or a run takes more than --cap seconds; the time to the target is
interpolated between the two runs around it on a log-log line (no assumption that the
error falls as 1/sqrt(samples): VCM's and SPPM's merges are biased, with the bias
shrinking as the iterations go on). Runs are interleaved (each technique at one count,
then the next count), so that a change in the machine's load hits all alike; --reps
repeats it all with other seeds and the medians are compared. Time is render time, as
raylink prints it (scene loading excluded).

With --images DIR, each technique then renders the scene once more at the time VCM takes
to the target (its samples from the runs' median time per sample), written to DIR as PNG
(`pool-vcm.png`, ...).

Setup: python3 -m venv /tmp/mi && /tmp/mi/bin/pip install mitsuba numpy (for EXR reading)
Run:   cargo build --release && /tmp/mi/bin/python benches/caustics_compare.py --reps 3
"""

import argparse
import hashlib
import math
import os
import re
import statistics
import subprocess
import sys

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EPSILON = 0.01
SCENES = {
    "pool": ("pool-caustics.toml", "vcm"),
    "box": ("cornell-box.toml", "bdpt"),
}
TECHNIQUES = ["vcm", "bdpt", "path", "sppm"]
KEPT = {"pool": "tests/data/pool-caustics-reference-64x48.exr"}


def read(path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[:, :, :3]


def render(args, scene, integrator, spp, seed, out, size=None):
    width, height = size or (args.width, args.height)
    command = [args.raylink, "render", os.path.join(ROOT, "scenes", scene), "--integrator",
               integrator, "--width", str(width), "--height", str(height), "--spp", str(spp),
               "--max-depth", str(args.max_depth), "--seed", str(seed), "--filter", "box",
               "--filter-radius", "0.5", "--quiet", "-o", out]
    if integrator in ("vcm", "sppm"):
        if args.photons:
            command += ["--photons-per-iteration", str(args.photons)]
        if args.radius:
            command += ["--sppm-radius", str(args.radius)]
    err = subprocess.run(command, check=True, capture_output=True, text=True).stderr
    found = re.search(r"rendered in ([0-9.]+) s", err)
    if found:
        return float(found.group(1))
    command.remove("--quiet")
    err = subprocess.run(command, check=True, capture_output=True, text=True).stderr
    return float(re.search(r"rendered in ([0-9.]+) s", err).group(1))


def reference(args, key):
    scene, integrator = SCENES[key]
    kept = args.reference or (KEPT.get(key) if (args.width, args.height) == (64, 48) else None)
    if kept:
        image = read(os.path.join(ROOT, kept) if not os.path.isabs(kept) else kept)
        return image, np.zeros_like(image)
    integrator = args.reference_integrator or integrator
    digest = hashlib.sha256()
    for f in (os.path.join(ROOT, "scenes", scene), args.raylink):
        with open(f, "rb") as fh:
            digest.update(fh.read())
    digest.update(f"{integrator} {args.width} {args.height} {args.reference_spp} "
                  f"{args.max_depth}".encode())
    os.makedirs(args.cache, exist_ok=True)
    halves = []
    for half in range(2):
        path = os.path.join(args.cache, f"{key}-{digest.hexdigest()[:16]}-{half}.exr")
        if not os.path.exists(path):
            tmp = path + ".tmp.exr"
            render(args, scene, integrator, args.reference_spp // 2, 1000 + half, tmp)
            os.replace(tmp, path)
        halves.append(read(path))
    h0, h1 = halves
    return (h0 + h1) / 2, (h0 - h1) ** 2 / 4


def error(image, ref, ref_var):
    d = ((image - ref) ** 2 - ref_var) / (ref ** 2 + EPSILON)
    return math.sqrt(max(float(np.mean(d)), 0.0))


def time_to(target, runs):
    """Seconds to reach error `target` from runs [(spp, seconds, error)], log-log
    interpolated; None if never reached."""
    for (s0, t0, e0), (s1, t1, e1) in zip(runs, runs[1:]):
        if e1 <= target < e0 and e1 > 0:
            f = math.log(e0 / target) / math.log(e0 / e1)
            return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0)))
    if runs and runs[0][2] <= target:
        return runs[0][1]
    return None


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--raylink", default=os.path.join(ROOT, "target/release/raylink"))
    p.add_argument("--scenes", default="pool,box")
    p.add_argument("--techniques", default=",".join(TECHNIQUES))
    p.add_argument("--width", type=int, default=128)
    p.add_argument("--height", type=int, default=96)
    p.add_argument("--max-depth", type=int, default=8)
    p.add_argument("--target", type=float, default=0.1)
    p.add_argument("--cap", type=float, default=60.0)
    p.add_argument("--reps", type=int, default=3)
    p.add_argument("--reference-spp", type=int, default=8192)
    p.add_argument("--reference-integrator")
    p.add_argument("--reference")
    p.add_argument("--photons", type=int)
    p.add_argument("--radius", type=float)
    p.add_argument("--cache", default="/tmp/raylink-caustics-cache")
    p.add_argument("--images")
    p.add_argument("--image-width", type=int, default=320)
    p.add_argument("--image-height", type=int, default=240)
    args = p.parse_args()
    techniques = args.techniques.split(",")
    work = os.path.join(args.cache, "runs")
    os.makedirs(work, exist_ok=True)
    extra = ""
    if args.photons or args.radius:
        extra = f"; vcm and sppm: {args.photons or 'default'} light paths an iteration, " \
                f"radius {args.radius or 'default'}"
    print(f"time to relative RMSE {args.target} at {args.width}x{args.height}, "
          f"{args.max_depth} bounces, {args.reps} interleaved reps (median seconds){extra}",
          flush=True)
    for key in args.scenes.split(","):
        scene = SCENES[key][0]
        ref, ref_var = reference(args, key)
        times = {t: [] for t in techniques}
        per_sample = {t: [] for t in techniques}
        for rep in range(args.reps):
            runs = {t: [] for t in techniques}
            going = set(techniques)
            spp = 1
            while going:
                for t in techniques:
                    if t not in going:
                        continue
                    out = os.path.join(work, f"{key}-{t}.exr")
                    seconds = render(args, scene, t, spp, 7 + 100 * rep, out)
                    e = error(read(out), ref, ref_var)
                    runs[t].append((spp, seconds, e))
                    if e <= args.target or seconds > args.cap:
                        going.discard(t)
                spp *= 2
            for t in techniques:
                times[t].append(time_to(args.target, runs[t]))
                s, secs, _ = runs[t][-1]
                per_sample[t].append(secs / s)
        print(f"\n{key} ({scene}):")
        print(f"| technique | seconds to {args.target} | against vcm |")
        print("|---|---|---|")
        medians = {}
        for t in techniques:
            reached = [x for x in times[t] if x is not None]
            if len(reached) * 2 > len(times[t]):
                medians[t] = statistics.median(x if x is not None else math.inf
                                               for x in times[t])
            else:
                medians[t] = None
        for t in techniques:
            m = medians[t]
            if m is None:
                print(f"| {t} | not reached within {args.cap:.0f} s | - |")
            else:
                ratio = (f"{m / medians['vcm']:.2f}x" if medians.get("vcm")
                         else "-")
                print(f"| {t} | {m:.2f} | {ratio} |")
        if args.images and medians.get("vcm"):
            os.makedirs(args.images, exist_ok=True)
            budget = medians["vcm"] * (args.image_width * args.image_height) / (
                args.width * args.height)
            for t in techniques:
                spp = max(1, round(budget / statistics.median(per_sample[t]) *
                                   (args.width * args.height) /
                                   (args.image_width * args.image_height)))
                out = os.path.join(args.images, f"{key}-{t}.png")
                seconds = render(args, scene, t, spp, 5, out,
                                 (args.image_width, args.image_height))
                print(f"{out}: {spp} samples per pixel, {seconds:.1f} s")


if __name__ == "__main__":
    sys.exit(main())
