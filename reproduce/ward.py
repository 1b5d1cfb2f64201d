#!/usr/bin/env python3
"""Ward, Rubinstein & Clear (1988), "A Ray Tracing Solution for Diffuse Interreflection":
section 4's validation, a sphere resting on a plane under a parallel light, the first bounce
on the sphere's underside computed by the cache against a quadrature of the exact
integral, for several accuracies a, without gradients (the 1988 method) and with Ward &
Heckbert's gradients. The paper found the mean error about a fourth and the largest about
twice the split sphere's estimate 1.4a, growing linearly with a. Then the paper's figure
5a and 5b in a room lit only by the bounce of an uplight (scenes/indirect-room.toml): the
image, and the same image with the first-bounce values the camera sees marked in red
(--show-cache-points). Prints Markdown tables (docs/reproductions.md holds their output).

  python3 reproduce/ward.py [--raylink PATH] [--out DIR]

Runs the library's tests that measure it (src/tests/irradiance_cache.rs,
`sphere_on_plane_matches_quadrature` and `gradients_lower_the_error_for_the_values_cached`)
and reads the figures they print.
"""
import os
import re
import subprocess
import sys

from common import ROOT, image_args
LINE = re.compile(r'sphere on plane: a = ([\d.]+), gradients (true|false): mean error ([\d.]+), '
                  r'largest ([\d.]+), (\d+) values, (\d+) points')


def room(raylink, out):
    """Figure 5a and 5b: the room's image and its cache points; returns the overture's line."""
    overture = None
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
        marked = re.search(r'marked (\d+) irradiance cache values', run.stderr)
        overture = overture or m
        print(f'{os.path.relpath(image, ROOT)}', file=sys.stderr)
    if not overture or not marked:
        sys.exit(f'no overture or marked values in the output of {cmd}:\n{run.stderr}')
    return overture, int(marked[1])


def main():
    args = image_args(__doc__)
    cmd = ['cargo', 'test', '--quiet', '--release', '--lib', '--',
           'sphere_on_plane_matches_quadrature', 'gradients_lower_the_error_for_the_values_cached',
           '--nocapture', '--test-threads', '1']
    run = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{run.stdout}\n{run.stderr}")
    rows = {}
    for m in LINE.finditer(run.stdout + run.stderr):
        a, gradients = float(m[1]), m[2] == 'true'
        rows[(a, gradients)] = (float(m[3]), float(m[4]), int(m[5]), int(m[6]))
    if not rows:
        sys.exit(f'the tests printed no figures:\n{run.stderr}')
    points = max(r[3] for r in rows.values())
    print('| a | paper: mean, largest error (about 0.35a, 2.8a) | raylink, 1988 method: mean, '
          'largest, values | raylink with gradients: mean, largest, values |')
    print('|---|---|---|---|')
    for a in sorted({a for a, _ in rows}):
        def cell(gradients):
            r = rows.get((a, gradients))
            return '' if r is None else f'{100 * r[0]:.1f}%, {100 * r[1]:.0f}%, {r[2]}'
        print(f'| {a:g} | {100 * 0.35 * a:.1f}%, {100 * 2.8 * a:.0f}% | {cell(False)} '
              f'| {cell(True)} |')
    print(f'\nErrors relative to the quadrature at {points} points of the sphere\'s underside, '
          '2048 rays a value, one bounce.')
    overture, marked = room(args.raylink, args.out)
    print('\n| the room (320x240, 7 bounces, a = 0.25, 2048 rays a first-bounce value) | raylink |')
    print('|---|---|')
    print(f'| values computed | {overture[1]} |')
    print(f'| per bounce, first to last | {overture[2]} |')
    print(f'| first-bounce values the camera sees (marked) | {marked} |')
    print(f'| time to compute them (the overture) | {float(overture[3]):.1f} s |')


if __name__ == '__main__':
    main()
