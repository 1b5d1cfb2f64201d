#!/usr/bin/env python3
"""Dutré, Lafortune & Willems, "A Mathematical Framework for Global Illumination
Algorithms": the flux through a set of surfaces is the same by the rendering equation and by
the potential equation, <L, We> = <Le, W>. Estimates it both ways (gathering: paths from the
surfaces; shooting: particles from the lights) on sets of scenes/cornell-spheres.toml (a
rough gold sphere, the mirror and glass spheres, the floor under the glass) and prints the
agreement as a Markdown table (docs/reproductions.md holds its output).

  python3 reproduce/dutre_lafortune_willems.py [--paths N]

Builds and runs `cargo run --release --example flux_agreement` (examples/flux_agreement.rs,
through the library's raylink::flux API).
"""
import argparse
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--paths', type=int, default=1_000_000, help='paths per estimate')
    args = ap.parse_args()
    cmd = ['cargo', 'run', '--quiet', '--release', '--example', 'flux_agreement', '--',
           'scenes/cornell-spheres.toml', str(args.paths)]
    run = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{run.stderr}")
    print(run.stdout, end='')


if __name__ == '__main__':
    main()
