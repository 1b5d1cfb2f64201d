#!/usr/bin/env python3
"""Ward, Rubinstein & Clear (1988), "A Ray Tracing Solution for Diffuse Interreflection":
section 4's validation in the paper's setting (a sphere resting on a plane of 70%
reflectance under a parallel light straight overhead; the irradiance, direct plus first
bounce, over the sphere against a quadrature) for several accuracies a, with and without
the minimum-radius clamp and Ward & Heckbert's gradients. Then the paper's figure 5a and 5b
in a room lit only by the bounce of an uplight (scenes/indirect-room.toml): the image, and
the same image with the first-bounce values the camera sees marked in red
(--show-cache-points). Writes both tables into docs/reproductions.md (its blocks
ward:section-4 and ward:room) and prints them.

  python3 reproduce/ward.py [--raylink PATH] [--out DIR]

Section 4's table is computed and formatted by the library's test
`ward_section_4_in_the_papers_setting` (src/tests/reproductions.rs), which `cargo test`
runs too and which fails when the page holds other numbers; this script runs it with
`cargo test --release --lib` (CARGO_TARGET_DIR is honoured) and copies its table.
"""
import os
import re
import subprocess
import sys

from common import PRINT_ONLY, ROOT, block_of, image_args, write_block

TEST = 'ward_section_4_in_the_papers_setting'


def section_4():
    """The table the library's test prints."""
    cmd = ['cargo', 'test', '--quiet', '--release', '--lib', '--',
           f'tests::reproductions::{TEST}', '--exact', '--nocapture']
    run = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True,
                         env={**os.environ, PRINT_ONLY: '1'})
    table = block_of(run.stderr, 'ward:section-4')
    if run.returncode != 0 or not table:
        sys.exit(f"{' '.join(cmd)} failed:\n{run.stdout}\n{run.stderr}")
    return table


def room(raylink, out):
    """Figure 5a and 5b: the room's image and its cache points; returns the overture's line
    and the number of values marked."""
    overture = marked = None
    for name, extra in [('repro-ward-room.png', []),
                        ('repro-ward-room-points.png', ['--show-cache-points'])]:
        image = os.path.join(out, name)
        # 2048 rays a value and ar 8: denser values than the scene's own settings, so that
        # the figure shows where they crowd.
        cmd = [raylink, 'render', 'scenes/indirect-room.toml', '--ic-samples', '2048',
               '--ar', '8', '-o', image] + extra
        run = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
        if run.returncode != 0:
            sys.exit(f"{' '.join(cmd)} failed:\n{run.stderr}")
        m = re.search(r'overture: (\d+) values .*?per bounce level: \[([\d, ]+)\] \(([\d.]+) s\)',
                      run.stderr)
        found = re.search(r'marked (\d+) irradiance cache values', run.stderr)
        overture = overture or m
        marked = marked or found
        print(f'{os.path.relpath(image, ROOT)}', file=sys.stderr)
    if not overture or not marked:
        sys.exit(f'no overture or marked values in the output of {cmd}:\n{run.stderr}')
    return overture, int(marked[1])


def main():
    args = image_args(__doc__)
    write_block('ward:section-4', section_4())
    overture, marked = room(args.raylink, args.out)
    write_block('ward:room', '\n'.join([
        '| the room (320x240, 7 bounces, a = 0.25, ar 8, 2048 rays a first-bounce value) '
        '| raylink |',
        '|---|---|',
        f'| values computed | {overture[1]} |',
        f'| per bounce, first to last | {overture[2]} |',
        f'| first-bounce values the camera sees (marked) | {marked} |',
        f'| time to compute them (the overture) | {float(overture[3]):.1f} s |',
    ]))


if __name__ == '__main__':
    main()
