#!/usr/bin/env python3
"""Whitted (1980), "An Improved Illumination Model for Shaded Display": the glass and mirror
spheres over a checkerboard (the paper's figure 7), rendered by raylink's Whitted integrator
at the paper's 640x480 with adaptive anti-aliasing, and the paper's figures beside raylink's
as a Markdown table, written into docs/reproductions.md (its block whitted:table) and
printed.

  python3 reproduce/whitted.py [--raylink PATH] [--out DIR]

The paper's breakdown of its time (intersection, shading, overhead) is measured with Linux
`perf` on one thread when `perf` is installed, each sampled function put in the paper's
category by what it does (RULES below): intersection is Embree's traversal and raylink's
accelerator (its own BVH, and the hit point and surface point of a hit); shading is the
Whitted integrator's illumination model, materials, textures, lights and the maths library
they call; overhead is the rest (loading the libraries, camera and secondary ray
generation, the adaptive anti-aliasing, writing the image, the kernel). The image goes to
DIR (default docs/images). `cargo test --test reproductions` checks the table's ray counts
against a fresh run.
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

from common import ROOT, image_args, write_block


def render(cmd):
    run = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    if run.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{run.stderr}")
    m = re.search(r'rendered in ([\d.]+) s: (\d+) rays \((\d+) camera samples\), ([\d.]+) Mrays/s',
                  run.stderr)
    if not m:
        sys.exit(f'no "rendered in" line from {" ".join(cmd)}:\n{run.stderr}')
    return float(m[1]), int(m[2]), int(m[3]), float(m[4])


# (category, shared objects, symbols): the first rule a sample's shared object or
# symbol matches decides.
RULES = [
    ('intersection', re.compile(r'embree'),
     re.compile(r'raylink::accel::|raylink::transport::Context::(intersect|occluded|complete)'
                r'|rtc\w*(Intersect|Occluded)')),
    ('shading', re.compile(r'^libm[.-]'),
     re.compile(r'raylink::integrators::|raylink::scene::(materials|texture|lights)::'
                r'|libm_math|^(floor|ceil|round|pow|exp|log|sin|cos|tan|atan2?|sqrt|fmod)f?$')),
]


def category(dso, symbol):
    for name, dsos, symbols in RULES:
        if dsos.search(dso) or symbols.search(symbol):
            return name
    return 'overhead'


def breakdown(cmd):
    """Shares of one thread's time in intersection, shading and overhead, from `perf`;
    None without it."""
    if not shutil.which('perf'):
        return None
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, 'perf.data')
        rec = subprocess.run(['perf', 'record', '-q', '-F', '2000', '-o', data, '--'] + cmd,
                             capture_output=True, text=True, cwd=ROOT)
        if rec.returncode != 0:
            return None
        rep = subprocess.run(['perf', 'report', '-i', data, '--no-children', '--sort',
                              'dso,sym', '--stdio'], capture_output=True, text=True)
    shares = {'intersection': 0.0, 'shading': 0.0, 'overhead': 0.0}
    for line in rep.stdout.splitlines():
        m = re.match(r'\s*([\d.]+)%\s+(\S+)\s+\[.\]\s+(.*\S)', line)
        if m:
            shares[category(m[2], m[3])] += float(m[1])
    total = sum(shares.values())
    return {k: 100 * v / total for k, v in shares.items()} if total > 0 else None


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
    rows = [
        "| Whitted's figure 7, 640x480 | paper (VAX-11/780) | raylink |",
        '|---|---|---|',
        f'| image time | 74 minutes | {seconds:.2f} s on every core, {one[0]:.2f} s on one |',
        f'| rays | not given | {rays} ({mrays:.1f} Mrays/s) |',
        f'| camera rays (adaptive anti-aliasing) | not given | {camera}, '
        f'{camera / pixels:.2f} a pixel |',
    ]
    if shares:
        rows += [
            f"| intersection | 75% | {shares['intersection']:.0f}% |",
            f"| shading | 12% | {shares['shading']:.0f}% |",
            f"| overhead | 13% | {shares['overhead']:.0f}% |",
        ]
    else:
        rows.append('| time breakdown | 75% intersection | (needs Linux `perf`) |')
    write_block('whitted:table', '\n'.join(rows))


if __name__ == '__main__':
    main()
