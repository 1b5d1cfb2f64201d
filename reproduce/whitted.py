#!/usr/bin/env python3
"""Whitted (1980), "An Improved Illumination Model for Shaded Display": the glass and mirror
spheres over a checkerboard (the paper's figure 7), rendered by raylink's Whitted integrator
at the paper's 640x480 with adaptive anti-aliasing, and the paper's figures beside raylink's
as a Markdown table (docs/reproductions.md holds its output).

  python3 reproduce/whitted.py [--raylink PATH] [--out DIR]

The paper's breakdown of its time (overhead, intersection, shading) is measured with Linux
`perf` on one thread when `perf` is installed: the share of the samples in Embree is the
intersection, raylink's own code the shading and ray generation, the rest start-up and
writing the image. The image goes to DIR (default docs/images).
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

from common import ROOT, image_args


def render(cmd):
    run = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    if run.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{run.stderr}")
    m = re.search(r'rendered in ([\d.]+) s: (\d+) rays \((\d+) camera samples\), ([\d.]+) Mrays/s',
                  run.stderr)
    if not m:
        sys.exit(f'no "rendered in" line from {" ".join(cmd)}:\n{run.stderr}')
    return float(m[1]), int(m[2]), int(m[3]), float(m[4])


def breakdown(cmd):
    """Shares of one thread's time in Embree, raylink and the rest, from `perf`; None
    without it."""
    if not shutil.which('perf'):
        return None
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, 'perf.data')
        rec = subprocess.run(['perf', 'record', '-q', '-F', '2000', '-o', data, '--'] + cmd,
                             capture_output=True, text=True, cwd=ROOT)
        if rec.returncode != 0:
            return None
        rep = subprocess.run(['perf', 'report', '-i', data, '--sort', 'dso', '--stdio'],
                             capture_output=True, text=True)
    shares = {'embree': 0.0, 'raylink': 0.0, 'rest': 0.0}
    for line in rep.stdout.splitlines():
        m = re.match(r'\s*([\d.]+)%\s+(\S+)', line)
        if not m:
            continue
        share, dso = float(m[1]), m[2]
        key = 'embree' if 'embree' in dso else 'raylink' if dso == 'raylink' else 'rest'
        shares[key] += share
    return shares if sum(shares.values()) > 0 else None


def main():
    args = image_args(__doc__)
    image = os.path.join(args.out, 'repro-whitted-fig7.png')
    cmd = [args.raylink, 'render', 'scenes/whitted.toml', '--integrator', 'whitted',
           '--width', '640', '--height', '480', '-o', image]
    seconds, rays, camera, mrays = render(cmd)
    one = render(cmd + ['--threads', '1'])
    shares = breakdown(cmd + ['--threads', '1'])
    print(f'figure 7: {os.path.relpath(image, ROOT)}', file=sys.stderr)
    pixels = 640 * 480
    print('| Whitted\'s figure 7, 640x480 | paper (VAX-11/780) | raylink |')
    print('|---|---|---|')
    print(f'| image time | 74 minutes | {seconds:.2f} s on every core, {one[0]:.2f} s on one |')
    print(f'| rays | not given | {rays / 1e6:.2f} M ({mrays:.1f} Mrays/s) |')
    print(f'| camera rays (adaptive anti-aliasing) | not given | {camera / 1e6:.2f} M, '
          f'{camera / pixels:.2f} a pixel |')
    if shares:
        print(f"| intersection (Embree) | 75% | {shares['embree']:.0f}% |")
        print(f"| shading and ray generation (raylink) | 12% | {shares['raylink']:.0f}% |")
        print(f"| overhead (start-up, image output, kernel) | 13% | {shares['rest']:.0f}% |")
    else:
        print('| time breakdown | 75% intersection | (needs Linux `perf`) |')


if __name__ == '__main__':
    main()
