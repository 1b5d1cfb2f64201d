#!/usr/bin/env python3
"""Interiors in raylink against Mitsuba 3's path tracer: time to equal error.

Two rooms, each with its Mitsuba 3 twin (same geometry, materials, lights and camera,
written with the scene by its script, see scripts/mitsuba_twin.py):

- `window`: scenes/window-room.toml, a furnished room lit only through a window by a sky
  (an environment map) and a sun (a directional light), benches/interiors/window-room.xml;
- `lamp`: scenes/lamp-room.toml, a hall lit by 288 small lamps and split by a wall,
  benches/interiors/lamp-room.xml.

Each is rendered at --width x --height with box filters and the scene's path length by:

- raylink plain: `--integrator path` (--raylink-plain-args) on the scene without its
  environment's portal (a copy of the file with the `portal` key taken out);
- raylink best: `--integrator path` followed by --raylink-best-args, its best settings,
  on the scene as it is (today the path tracer's defaults: the light hierarchy, and the
  sky sampled through the window room's portal; add new options here, e.g.
  --raylink-best-args="--adaptive-threshold 0.01");
- Mitsuba 3 (scalar_rgb, `path`) with each of --mitsuba-samplers; the fastest to equal
  error is the one compared.

Runs are interleaved (plain, best, Mitsuba with each sampler, then again), so that a change
in the machine's load hits all alike; each run has its own seed. Time is render time (scene
loading excluded for both). Error is the relative RMSE: the square root of the mean over
pixels and channels of (v - r)^2 / (r^2 + 0.01) for a value v and its reference r (so that
the bright lamps seen directly do not outweigh the room), with r the renderer's own
converged render (--reference-spp, the mean of two halves with their own seeds; cached in
--cache), less the reference's own noise (estimated from its halves). Each renderer is measured against its own reference so
that the small differences between the two material models (see scripts/mitsuba_twin.py)
do not count as error; the two references' per-channel means are printed to show that the
twins agree. The error of an unbiased estimator falls as 1/sqrt(samples), so a run of t
seconds with error e reaches --target E in t (e/E)^2; the medians over the runs are
compared. --reps must be at least 3.

With --with-guiding, raylink guided (the best options and `--guiding true`) runs too.

With --images DIR, each configuration (Mitsuba: its fastest sampler) then renders the room
once more at --image-width x --image-height, all at equal time: raylink plain at
--image-spp, every other at the samples that take the same time by the runs' median time
per sample; the images are written to DIR as PNG (`window-room-raylink-plain.png`, ...).

Setup: python3 -m venv /tmp/mi && /tmp/mi/bin/pip install mitsuba
Run:   cargo build --release && /tmp/mi/bin/python benches/interiors_compare.py --reps 5
"""

import argparse
import hashlib
import os
import re
import shlex
import statistics
import subprocess
import sys
import tempfile
import time

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# The relative error of a value v against a reference r is (v - r)^2 / (r^2 + EPSILON).
EPSILON = 0.01
ROOMS = {
    "window": ("window room", "scenes/window-room.toml", "benches/interiors/window-room.xml"),
    "lamp": ("lamp room", "scenes/lamp-room.toml", "benches/interiors/lamp-room.xml"),
}


def read(path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[:, :, :3]


class Room:
    def __init__(self, args, key):
        self.args = args
        self.label, toml, xml = ROOMS[key]
        self.toml, self.xml = os.path.join(ROOT, toml), os.path.join(ROOT, xml)
        self.loaded = {}
        # The plain run's scene: the file without its portal, its files named absolutely.
        with open(self.toml) as f:
            text = f.read()
        text = re.sub(r", portal = \[\[[^]]*\](, \[[^]]*\])*\]", "", text)
        text = re.sub(r'file = "', 'file = "' + os.path.dirname(self.toml) + "/", text)
        self.plain_dir = tempfile.mkdtemp(prefix="raylink-interiors-")
        self.plain_toml = os.path.join(self.plain_dir, os.path.basename(self.toml))
        with open(self.plain_toml, "w") as f:
            f.write(text)
        self.plain_toml_differs = "portal" not in text and "portal" in open(self.toml).read()

    def raylink(self, extra, spp, seed, out, plain=False, size=None):
        a = self.args
        toml = self.plain_toml if plain else self.toml
        width, height = size or (a.width, a.height)
        command = [a.raylink, "render", toml, "--width", str(width), "--height",
                   str(height), "--spp", str(spp), "--filter", "box", "--filter-radius",
                   "0.5", "--seed", str(seed), "-o", out] + extra
        err = subprocess.run(command, check=True, capture_output=True, text=True).stderr
        return float(re.search(r"rendered in ([0-9.]+) s", err).group(1))

    def mitsuba(self, sampler, spp, seed, out, size=None):
        width, height = size or (self.args.width, self.args.height)
        if (sampler, spp, width) not in self.loaded:
            self.loaded[(sampler, spp, width)] = mi.load_file(
                self.xml, width=width, height=height, spp=spp, sampler=sampler)
        start = time.perf_counter()
        image = mi.render(self.loaded[(sampler, spp, width)], seed=seed)
        seconds = time.perf_counter() - start
        bitmap = mi.Bitmap(image)
        if out.endswith(".png"):
            bitmap = bitmap.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, True)
        bitmap.write(out)
        return seconds

    def reference(self, renderer):
        """The mean of two half renders, and the variance of that mean per value."""
        a = self.args
        key = hashlib.sha256()
        for f in (self.toml, self.xml, a.raylink if renderer == "raylink" else mi.__file__):
            with open(f, "rb") as fh:
                key.update(fh.read())
        key.update(f"{renderer} {a.width} {a.height} {a.reference_spp} {a.raylink_plain_args}".encode())
        os.makedirs(a.cache, exist_ok=True)
        halves = []
        for half in range(2):
            path = os.path.join(a.cache, f"{key.hexdigest()[:16]}-{half}.exr")
            if not os.path.exists(path):
                seed = 1000 + half
                tmp = path + ".tmp.exr"
                if renderer == "raylink":
                    self.raylink(shlex.split(a.raylink_plain_args), a.reference_spp // 2, seed, tmp)
                else:
                    self.mitsuba("independent", a.reference_spp // 2, seed, tmp)
                os.replace(tmp, path)
            halves.append(read(path))
        h0, h1 = halves
        return (h0 + h1) / 2, (h0 - h1) ** 2 / 4


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rooms", default="window,lamp", help="comma-separated: window, lamp")
    ap.add_argument("--width", type=int, default=80)
    ap.add_argument("--height", type=int, default=60)
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel of each run")
    ap.add_argument("--reps", type=int, default=3, help="runs of each configuration (at least 3)")
    ap.add_argument("--target", type=float, default=0.05, help="relative RMSE to reach")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--cache", default="/tmp/raylink-interiors-references")
    ap.add_argument("--raylink", default=os.path.join(
        os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")), "release/raylink"))
    ap.add_argument("--raylink-plain-args", default="--integrator path")
    ap.add_argument("--raylink-best-args", default="",
                    help="options added to the plain ones for raylink's best settings")
    ap.add_argument("--mitsuba-samplers", default="independent,multijitter,ldsampler")
    ap.add_argument("--with-guiding", action="store_true",
                    help="also raylink's best settings with --guiding true")
    ap.add_argument("--images", metavar="DIR", help="write images at equal time into DIR")
    ap.add_argument("--image-width", type=int, default=320)
    ap.add_argument("--image-height", type=int, default=240)
    ap.add_argument("--image-spp", type=int, default=64, help="raylink plain's samples")
    args = ap.parse_args()
    if args.reps < 3:
        sys.exit("--reps must be at least 3")
    plain = shlex.split(args.raylink_plain_args)
    best = plain + shlex.split(args.raylink_best_args)
    samplers = args.mitsuba_samplers.split(",")
    med = statistics.median
    summary = []
    for key in args.rooms.split(","):
        room = Room(args, key)
        references = {r: room.reference(r) for r in ("raylink", "mitsuba")}
        configs = [("raylink plain", "raylink", plain), ("raylink best", "raylink", best)]
        if args.with_guiding:
            configs.append(("raylink guided", "raylink", best + ["--guiding", "true"]))
        plain_scene = {"raylink plain": True}
        configs += [(f"mitsuba {s}", "mitsuba", s) for s in samplers]
        runs = {name: [] for name, _, _ in configs}
        load_before = os.getloadavg()
        with tempfile.TemporaryDirectory() as tmp:
            for rep in range(args.reps):
                for name, renderer, what in configs:
                    out = os.path.join(tmp, "run.exr")
                    if renderer == "raylink":
                        seconds = room.raylink(what, args.spp, rep, out,
                                               plain=plain_scene.get(name, False))
                    else:
                        seconds = room.mitsuba(what, args.spp, rep, out)
                    ref, ref_var = references[renderer]
                    weight = 1 / (ref ** 2 + EPSILON)
                    mse = np.mean((read(out) - ref) ** 2 * weight) - np.mean(ref_var * weight)
                    error = np.sqrt(max(mse, 0.0))
                    runs[name].append((seconds, error))
        load_after = os.getloadavg()
        print(f"{room.label} {args.width}x{args.height}, {args.spp} spp per run, box filters, "
              f"{args.reps} interleaved runs each, references {args.reference_spp} spp; load "
              f"average {load_before[0]:.2f} before, {load_after[0]:.2f} after, on "
              f"{os.cpu_count()} cores")
        to_target = {}
        for name, renderer, what in configs:
            times = [t for t, _ in runs[name]]
            errors = [e for _, e in runs[name]]
            needed = [t * (e / args.target) ** 2 for t, e in zip(times, errors)]
            to_target[name] = med(needed)
            shown = f"{name} ({' '.join(what)})" if renderer == "raylink" else name
            if plain_scene.get(name) and room.plain_toml_differs:
                shown += " no portal"
            print(f"  {shown:<44} time {med(times):6.2f} s, rel. RMSE {med(errors):.4f}, "
                  f"to {args.target:g}: {med(needed):7.2f} s (min {min(needed):.2f})")
        fastest = min(samplers, key=lambda s: to_target[f"mitsuba {s}"])
        means = {}
        for r, (ref, ref_var) in references.items():
            n = ref.shape[0] * ref.shape[1]
            means[r] = (ref.reshape(-1, 3).mean(0), np.sqrt(ref_var.reshape(-1, 3).sum(0)) / n)
        (rm, rse), (mm, mse_) = means["raylink"], means["mitsuba"]
        diff = ", ".join(f"{100 * (r / m - 1):+.2f}%" for r, m in zip(rm, mm))
        print(f"  reference means: raylink [{', '.join(f'{v:.5f}' for v in rm)}], mitsuba "
              f"[{', '.join(f'{v:.5f}' for v in mm)}]: raylink/mitsuba - 1 = [{diff}] "
              f"(standard errors under {100 * max(max(rse / rm), max(mse_ / mm)):.2f}%)")
        summary.append((room.label, to_target["raylink plain"], to_target["raylink best"],
                        fastest, to_target[f"mitsuba {fastest}"]))
        if args.images:
            write_images(args, room, key, configs, runs, fastest, plain_scene)
    print()
    print(f"time to relative RMSE {args.target:g} (s, medians of {args.reps}) at "
          f"{args.width}x{args.height}, Mitsuba {mi.__version__} scalar_rgb:")
    print(f"| room | raylink plain | raylink best | Mitsuba (sampler) | best/Mitsuba | best/plain |")
    print(f"|---|---|---|---|---|---|")
    for label, p, b, s, m in summary:
        print(f"| {label} | {p:.2f} | {b:.2f} | {m:.2f} ({s}) | {b / m:.2f} | {b / p:.2f} |")
    return 0


def write_images(args, room, key, configs, runs, fastest, plain_scene):
    """Each configuration's image at the time raylink plain takes for --image-spp."""
    os.makedirs(args.images, exist_ok=True)
    per_sample = {name: statistics.median(t for t, _ in runs[name]) / args.spp
                  for name, _, _ in configs}
    budget = per_sample["raylink plain"] * args.image_spp
    size = (args.image_width, args.image_height)
    for name, renderer, what in configs:
        if renderer == "mitsuba" and what != fastest:
            continue
        spp = max(1, round(budget / per_sample[name]))
        slug = name.replace(" ", "-")
        out = os.path.join(args.images, f"{key}-room-{slug}.png")
        if renderer == "raylink":
            room.raylink(what, spp, 7, out, plain=plain_scene.get(name, False), size=size)
        else:
            room.mitsuba(what, spp, 7, out, size=size)
        print(f"  image at equal time: {out}, {name}, {spp} spp")


if __name__ == "__main__":
    sys.exit(main())
