#!/usr/bin/env python3
"""Jevans's Table 2 for scenes/anim-audition.toml, online and with --lookahead, beside the
paper's figures. Renders the sequence with `raylink animate --verify` (every coherent frame
checked against its full render in the same run, which also gives the traditional
algorithm's rays and CPU time), one ray per pixel as in the paper.

  python3 reproduce/jevans.py [--raylink PATH] [--width 640 --height 480] [--frames A..B]
                            [--overhead-reps 5]

The paper counted primary rays (one per pixel): its "# Rays" columns compare with the
pixels columns here; "all rays" adds reflection, refraction and shadow rays.
"""
import argparse
import csv
import os
import re
import subprocess
import sys
import tempfile

PAPER = {  # frame: (rays traditional, CPU traditional s, rays coherent, CPU coherent s)
    0: (307200, 666, 307200, 780),
    1: (307200, 669, 122400, 418),
    75: (307200, 684, 146400, 528),
    150: (307200, 649, 58800, 209),
    200: (307200, 634, 9600, 44),
    350: (307200, 655, 8400, 43),
}
PAPER_ALL = (107827200, 63.32 * 3600, 20866800, 16.92 * 3600)


def run(args, mode, out):
    csv_path = os.path.join(out, f"{mode}.csv")
    cmd = [
        args.raylink, "animate", args.scene, "-o", os.path.join(out, mode + "_%03d.exr"),
        "--spp", "1", "--width", str(args.width), "--height", str(args.height),
        "--verify", "--stats", "--quiet", "--csv", csv_path,
        "--overhead-reps", str(args.overhead_reps),
    ]
    if args.frames:
        cmd += ["--frames", args.frames]
    if mode == "lookahead":
        cmd.append("--lookahead")
    print("$", " ".join(cmd), file=sys.stderr, flush=True)
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"raylink failed ({done.returncode}):\n{done.stderr}{done.stdout}")
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    overhead = re.search(r"median ([+-][0-9.]+)% CPU", done.stdout)
    memory = re.search(r"records: .*= ([0-9.]+) KiB", done.stdout)
    camera = re.search(r"at most ([0-9.]+) KiB kept", done.stdout)
    return rows, overhead.group(1) if overhead else "?", memory, camera, done.stdout


def table(mode, rows, overhead, memory, camera, pixels):
    print(f"\n{mode}: frame-0 overhead (median of the repeats) {overhead}%; ", end="")
    print(f"records at most {memory.group(1) if memory else '?'} KiB", end="")
    print(f", camera hits at most {camera.group(1)} KiB" if camera else "")
    head = ("frame", "pixels full", "pixels coh.", "ratio", "all rays ratio",
            "CPU full", "CPU coh.", "ratio", "| paper: rays ratio", "CPU ratio")
    print("{:>8} {:>11} {:>11} {:>7} {:>14} {:>9} {:>9} {:>7} {:>19} {:>9}".format(*head))
    tot = [0, 0, 0, 0, 0.0, 0.0]
    first = int(rows[0]["frame"])
    for r in rows:
        f = int(r["frame"])
        full_cpu, coh_cpu = float(r["full_cpu_seconds"]), float(r["cpu_seconds"])
        coh_px, full_rays, coh_rays = int(r["pixels_retraced"]), int(r["full_rays"]), int(r["rays"])
        vals = (pixels, coh_px, full_rays, coh_rays, full_cpu, coh_cpu)
        tot = [a + b for a, b in zip(tot, vals)]
        if f - first in PAPER or f == int(rows[-1]["frame"]):
            p = PAPER.get(f - first)
            paper = f"{p[2] / p[0]:>19.4f} {p[3] / p[1]:>9.4f}" if p else ""
            print(f"{f:>8} {pixels:>11} {coh_px:>11} {coh_px / pixels:>7.4f} "
                  f"{coh_rays / full_rays:>14.4f} {full_cpu:>9.3f} {coh_cpu:>9.3f} "
                  f"{coh_cpu / full_cpu:>7.4f} {paper}")
    p = PAPER_ALL
    print(f"{'all':>8} {tot[0]:>11} {tot[1]:>11} {tot[1] / tot[0]:>7.4f} "
          f"{tot[3] / tot[2]:>14.4f} {tot[4]:>9.2f} {tot[5]:>9.2f} {tot[5] / tot[4]:>7.4f} "
          f"{p[2] / p[0]:>19.4f} {p[3] / p[1]:>9.4f}")
    if not all(r["identical"] == "true" for r in rows):
        sys.exit("a coherent frame differs from its full render")


def main():
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--raylink", default=os.path.join(root, "target", "release", "raylink"))
    ap.add_argument("--scene", default=os.path.join(root, "scenes", "anim-audition.toml"))
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--frames")
    ap.add_argument("--overhead-reps", type=int, default=5)
    args = ap.parse_args()
    pixels = args.width * args.height
    with tempfile.TemporaryDirectory() as out:
        for mode in ("online", "lookahead"):
            rows, overhead, memory, camera, _ = run(args, mode, out)
            table(mode, rows, overhead, memory, camera, pixels)
            for name in os.listdir(out):
                if name.endswith(".exr"):
                    os.remove(os.path.join(out, name))


if __name__ == "__main__":
    main()
