#!/usr/bin/env python3
"""Path tracing in raylink against Mitsuba 3 on the Bitterli Cornell box: time to equal error.

Both render scenes/cornell-box-bitterli at the same resolution and sample count with their
path integrators and the same path length (Mitsuba's max_depth 8 counts the camera segment:
it is 7 bounces, raylink's --max-depth 7). Runs are interleaved (Mitsuba, raylink, Mitsuba,
raylink, ...) so that a change in the machine's load hits both alike; each run has its own
seed. Time is render time (scene loading excluded for both).

Error is the RMSE against Tungsten's converged render, box-downsampled, with the light's
pixels excluded (as in tests/monte_carlo.rs): by default the 256x256 copy in
scenes/cornell-box-bitterli, which serves --size 256 and its divisors; --reference takes
another (e.g. the full 1024x1024 TungstenRender.exr) for larger sizes.

Time to equal error: the error of an unbiased estimator falls as 1/sqrt(samples), so a run
of t seconds with error e reaches --target-rmse E in t (e/E)^2 (and spp (e/E)^2 samples).
The medians over the runs are compared (the minimum time to that error is printed too);
--reps must be at least 3.

Filters: --filter default keeps each renderer's own (Mitsuba's tent from the scene file,
raylink's Gaussian from scenes/cornell-box.toml, both splatting each sample into the pixels
they cover); --filter box gives both a box, which compares the estimators alone.

--baseline BINARY adds another raylink build (an older commit's target/release/raylink) to
the interleaved runs (Mitsuba, raylink, baseline, ...), for a before/after table measured in
one run.

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


def summary(name, times, errors, spp, target):
    to_target = [t * (e / target) ** 2 for t, e in zip(times, errors)]
    spp_needed = [spp * (e / target) ** 2 for e in errors]
    med = statistics.median
    print(f"{name:<28} time {med(times):6.2f} s (min {min(times):.2f}), "
          f"RMSE {med(errors):.5f}, to RMSE {target}: {med(to_target):6.2f} s "
          f"(min {min(to_target):.2f}), {med(spp_needed):5.0f} spp")
    return med(times), med(to_target)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--max-depth", type=int, default=8, help="Mitsuba's max_depth")
    ap.add_argument("--reps", type=int, default=3, help="runs of each renderer (at least 3)")
    ap.add_argument("--filter", choices=["default", "box"], default="default")
    ap.add_argument("--target-rmse", type=float, default=0.0056)
    ap.add_argument("--threads", type=int, default=None, help="default: every core")
    ap.add_argument("--reference", default=os.path.join(SCENE, "TungstenRender-256.exr"),
                    help="Tungsten's render; its size must be a multiple of --size")
    ap.add_argument("--baseline", help="another raylink binary, run interleaved too")
    args = ap.parse_args()
    if args.reps < 3:
        ap.error(f"--reps must be at least 3 (a median of interleaved runs), got {args.reps}")
    import drjit as dr
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    if args.threads:
        dr.set_thread_count(args.threads)
    tmp = tempfile.mkdtemp()
    binary = os.path.join(ROOT, "target/release/raylink")
    with open(os.path.join(SCENE, "mitsuba-scene_v3.xml")) as f:
        xml = f.read()
    if args.filter == "box":
        xml = xml.replace('<rfilter type="tent" />', '<rfilter type="box" />')

    def mitsuba_run(rep):
        scene = mi.load_string(xml, spp=args.spp, resx=args.size, resy=args.size,
                               max_depth=args.max_depth)
        start = time.perf_counter()
        image = mi.render(scene, seed=rep)
        seconds = time.perf_counter() - start
        path = os.path.join(tmp, f"mitsuba{rep}.exr")
        mi.Bitmap(image).write(path)  # synchronous (write_bitmap may return before the file exists)
        return seconds, rmse(path, args.reference, args.size)

    def raylink_run(rep, binary=binary, name="raylink"):
        path = os.path.join(tmp, f"{name}{rep}.exr")
        command = [binary, "render", os.path.join(ROOT, "scenes/cornell-box.toml"),
                   "--integrator", "path", "--width", str(args.size), "--height",
                   str(args.size), "--spp", str(args.spp), "--max-depth",
                   str(args.max_depth - 1), "--seed", str(rep), "-o", path]
        if args.filter == "box":
            command += ["--filter", "box"]
        if args.threads:
            command += ["--threads", str(args.threads)]
        out = subprocess.run(command, check=True, capture_output=True, text=True).stderr
        seconds = float(re.search(r"rendered in ([0-9.]+) s", out).group(1))
        return seconds, rmse(path, args.reference, args.size)

    load_before = os.getloadavg()
    runs = {"mitsuba": [], "raylink": []}
    if args.baseline:
        runs["baseline"] = []
    for rep in range(args.reps):
        runs["mitsuba"].append(mitsuba_run(rep))
        runs["raylink"].append(raylink_run(rep))
        if args.baseline:
            runs["baseline"].append(raylink_run(rep, args.baseline, "baseline"))
    load_after = os.getloadavg()

    print(f"{args.size}x{args.size}, {args.spp} spp, {args.max_depth - 1} bounces, "
          f"{args.filter} filters, {args.threads or os.cpu_count()} threads, "
          f"{args.reps} interleaved runs each; load average {load_before[0]:.2f} before, "
          f"{load_after[0]:.2f} after, on {os.cpu_count()} cores")
    pixels = args.size * args.size * args.spp
    results = {}
    names = [("mitsuba", f"mitsuba {mi.__version__} scalar_rgb"), ("raylink", "raylink")]
    if args.baseline:
        names.append(("baseline", "baseline raylink"))
    for name, label in names:
        times = [t for t, _ in runs[name]]
        errors = [e for _, e in runs[name]]
        results[name] = summary(label, times, errors, args.spp, args.target_rmse)
        print(f"{'':<28} {pixels / statistics.median(times) / 1e6:.2f} M paths/s")
    (mt, mtt), (rt, rtt) = results["mitsuba"], results["raylink"]
    print(f"raylink/mitsuba: render time {rt / mt:.2f}, time to RMSE {args.target_rmse} "
          f"{rtt / mtt:.2f}")
    if args.baseline:
        bt, btt = results["baseline"]
        print(f"baseline/mitsuba: render time {bt / mt:.2f}, time to RMSE {args.target_rmse} "
              f"{btt / mtt:.2f}")
        print(f"raylink/baseline: render time {rt / bt:.2f}, time to RMSE {args.target_rmse} "
              f"{rtt / btt:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
