#!/usr/bin/env python3
"""Buckalew & Fussell (1989), "Illumination Networks": figures 7-10 and the office's
statistics, rendered by raylink's network integrator at the paper's 500x500, beside the
paper's numbers as two Markdown tables, written into docs/reproductions.md (its blocks
buckalew-fussell:office and buckalew-fussell:figures) and printed.

  python3 reproduce/buckalew_fussell.py [--raylink PATH] [--out DIR]

- Figure 7: colour bleeding in a diffuse room lit from behind the eye (scenes/network-room.toml).
- Figure 8: a mirror floor reflecting coloured stripes (scenes/network-mirror.toml).
- Figures 9 and 10: the office (scenes/network-office.toml) at the paper's resolution of the
  network (--slopes 20: 1200 links a patch, the paper's 1201; --intercept-step 0.043: about
  the paper's 2834 patches); figure 10 gives the carpet a coat of wax (a glossy lobe).

Images go to DIR (default docs/images). Times are wall seconds of this machine, the
paper's of a Convex C1. `cargo test --test reproductions` checks the tables' counts
(patches, nodes, links, intersections, memory, sweeps) against a fresh run.
"""
import os
import re
import subprocess
import sys
import tempfile
import time

from common import ROOT, image_args, write_block

# The paper's office (section "Results"): figure 9 all diffuse, figure 10 a waxed carpet.
PAPER = {
    'patches': ('2834', '2834'),
    'links a patch': ('1201', '1201'),
    'line-patch intersections': ('1.8 M', '1.8 M'),
    'preprocess': ('160 s', '160 s'),
    'network memory': ('15 MB', '18.5 MB'),
    'distribution': ('35 s', '169 s'),
    'eye rays and rendering': ('77 s', '115 s'),
}

OFFICE = ['--slopes', '20', '--intercept-step', '0.043']
WAX = ('[materials.carpet]\ndiffuse = [0.15, 0.45, 0.15]\n',
       '[materials.carpet]\ndiffuse = [0.1, 0.32, 0.1]\nspecular = 0.3\nroughness = 0.08\n')


def render(raylink, scene, image, extra):
    """Renders `scene` at 500x500 with the network's statistics; returns them."""
    cmd = [raylink, 'render', scene, '--integrator', 'network', '--network-stats',
           '--width', '500', '--height', '500', '-o', image] + extra
    start = time.monotonic()
    run = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    wall = time.monotonic() - start
    if run.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{run.stderr}")
    err = run.stderr

    def find(pattern):
        m = re.search(pattern, err)
        if not m:
            sys.exit(f'no "{pattern}" in the statistics of {scene}:\n{err}')
        return m.groups()

    patches, nodes, slots = find(r'(\d+) patches, (\d+) nodes, (\d+) slots per node')
    links, per_node = find(r'(\d+) links \(([\d.]+) per node\)')
    (intersections,) = find(r'(\d+) line-patch intersections')
    network_mb, buffers_mb = find(r'memory ([\d.]+) MB network \+ ([\d.]+) MB buffers')
    pre, dist, sweeps = find(r'preprocess ([\d.]+) s .*distribution ([\d.]+) s, (\d+) sweeps')
    # The image's own time: the summary's total includes the network's preparation.
    (rendered,) = find(r'rendered in [\d.]+ s \([\d.]+ s preparing, ([\d.]+) s the image\)')
    return {
        'patches': int(patches), 'nodes': int(nodes), 'slots': int(slots),
        'links': int(links), 'per_node': float(per_node),
        'intersections': int(intersections),
        'network_mb': float(network_mb), 'buffers_mb': float(buffers_mb),
        'preprocess': float(pre), 'distribution': float(dist), 'sweeps': int(sweeps),
        'render': float(rendered), 'wall': wall,
    }


def main():
    args = image_args(__doc__)
    with open(os.path.join(ROOT, 'scenes/network-office.toml')) as f:
        office = f.read()
    if WAX[0] not in office:
        sys.exit("scenes/network-office.toml's carpet is not the one this script waxes")
    with tempfile.TemporaryDirectory() as tmp:
        waxed = os.path.join(tmp, 'network-office-waxed.toml')
        with open(waxed, 'w') as f:
            f.write(office.replace(WAX[0], WAX[1]))
        figures = [
            ('7', 'scenes/network-room.toml', []),
            ('8', 'scenes/network-mirror.toml', []),
            ('9', 'scenes/network-office.toml', OFFICE),
            ('10', waxed, OFFICE),
        ]
        stats = {}
        for fig, scene, extra in figures:
            image = os.path.join(args.out, f'repro-buckalew-fussell-fig{fig}.png')
            stats[fig] = render(args.raylink, scene, image, extra)
            print(f'figure {fig}: {os.path.relpath(image, ROOT)}', file=sys.stderr)

    nine, ten = stats['9'], stats['10']
    ours = {
        'patches': lambda s: f"{s['patches']}",
        'links a patch': lambda s: f"{s['slots']} slots, {s['per_node']:.0f} linked",
        'line-patch intersections': lambda s: f"{s['intersections'] / 1e6:.2f} M",
        'preprocess': lambda s: f"{s['preprocess']:.3f} s",
        'network memory': lambda s: f"{s['network_mb'] + s['buffers_mb']:.1f} MB",
        'distribution': lambda s: f"{s['distribution']:.3f} s ({s['sweeps']} sweeps)",
        'eye rays and rendering': lambda s: f"{s['render']:.2f} s",
    }
    rows = ['| the office, 500x500 | paper, figure 9 | raylink, figure 9 | paper, figure 10 '
            '| raylink, figure 10 |', '|---|---|---|---|---|']
    rows += [f'| {key} | {paper[0]} | {ours[key](nine)} | {paper[1]} | {ours[key](ten)} |'
             for key, paper in PAPER.items()]
    glossy = ten['render'] / max(nine['render'], 1e-9)
    write_block('buckalew-fussell:office', '\n'.join(rows) + '\n\n' + ' '.join([
        "The paper's office is its own model, its times a Convex C1's. raylink's office",
        '(scenes/network-office.toml) is built after its figures 9 and 10, not from its',
        'data, at the nearest resolution of the network raylink\'s options give:',
        f"{nine['patches']} patches for the paper's 2834 (`--intercept-step 0.043`) and",
        f"{nine['slots']} slots a patch for its 1201 links (`--slopes 20`). The paper does not",
        "say how glossy its wax is: raylink's carpet has a lobe of specular 0.3, roughness",
        '0.08. Times are wall seconds on this machine; the glossy carpet made the image',
        f"{glossy:.0f} times slower to render than the diffuse one (the paper's: 1.5 times).",
    ]))
    rows = ['| figure | patches | nodes | links | sweeps | preprocess | distribution | render '
            '| whole run |', '|---|---|---|---|---|---|---|---|---|']
    rows += [f"| {fig} | {s['patches']} | {s['nodes']} | {s['links']} | {s['sweeps']} "
             f"| {s['preprocess']:.3f} s | {s['distribution']:.3f} s | {s['render']:.2f} s "
             f"| {s['wall']:.2f} s |" for fig, s in stats.items()]
    write_block('buckalew-fussell:figures', '\n'.join(rows) + '\n\n' + ' '.join([
        'This table is raylink\'s alone: figures 7 (colour bleeding in a diffuse room lit',
        'from behind the eye, scenes/network-room.toml) and 8 (a mirror floor reflecting',
        'coloured stripes, scenes/network-mirror.toml) are scenes of raylink\'s that show the',
        'effects of the paper\'s figures, not the paper\'s data, at the networks\' default',
        'resolution; the office is as in the table above. "Sweeps" counts the distribution\'s',
        'passes over the links (conjugate-gradient steps for an all-diffuse network, Jacobi',
        'sweeps for one with a mirror or a glossy patch). Counts are the same on every run;',
        'times vary by 10% or more.',
    ]))


if __name__ == '__main__':
    main()
