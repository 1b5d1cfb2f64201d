#!/usr/bin/env python3
"""Writes tests/scenes/media-grid-box.toml: a closed box lit by a small ceiling light, holding
a cloud of smoke given as a `uniformgrid` density (lumps of smooth noise, zero on the grid's
outer samples so that renderers which clamp at a grid's edge and those which fall to zero
there agree). The benchmark against Mitsuba 3 (benches/media_compare.py --scene grid) and
tests/media.rs render it.

    python3 scripts/media-grid-scene.py > tests/scenes/media-grid-box.toml
"""

import math
import random

N = 24
BOUNDS = [[-0.85, 0.02, -0.85], [0.85, 1.62, 0.85]]


def density():
    rng = random.Random(11)
    lumps = [([rng.uniform(0.3, 0.7) for _ in range(3)], rng.uniform(0.06, 0.12),
              rng.uniform(0.6, 1.0)) for _ in range(12)]
    values = []
    for z in range(N):
        for y in range(N):
            for x in range(N):
                if min(x, y, z) == 0 or max(x, y, z) == N - 1:
                    values.append(0.0)
                    continue
                p = [(x + 0.5) / N, (y + 0.5) / N, (z + 0.5) / N]
                d = 0.0
                for c, r, w in lumps:
                    q = sum((a - b) ** 2 for a, b in zip(p, c))
                    d += w * math.exp(-q / (2 * r * r))
                values.append(round(min(d, 1.5), 3))
    return values


WALLS = """
# The box, faces inward: floor, ceiling, back, front, left, right.
[[shapes]]
type = "mesh"
material = "white"
positions = [[-1, 0, -1], [1, 0, -1], [1, 0, 3], [-1, 0, 3]]
indices = [[0, 2, 1], [0, 3, 2]]

[[shapes]]
type = "mesh"
material = "white"
positions = [[-1, 2, -1], [1, 2, -1], [1, 2, 3], [-1, 2, 3]]
indices = [[0, 1, 2], [0, 2, 3]]

[[shapes]]
type = "mesh"
material = "white"
positions = [[-1, 0, -1], [1, 0, -1], [1, 2, -1], [-1, 2, -1]]
indices = [[0, 1, 2], [0, 2, 3]]

[[shapes]]
type = "mesh"
material = "white"
positions = [[-1, 0, 3], [1, 0, 3], [1, 2, 3], [-1, 2, 3]]
indices = [[0, 2, 1], [0, 3, 2]]

[[shapes]]
type = "mesh"
material = "red"
positions = [[-1, 0, -1], [-1, 0, 3], [-1, 2, 3], [-1, 2, -1]]
indices = [[0, 2, 1], [0, 3, 2]]

[[shapes]]
type = "mesh"
material = "green"
positions = [[1, 0, -1], [1, 0, 3], [1, 2, 3], [1, 2, -1]]
indices = [[0, 1, 2], [0, 2, 3]]

# The light, facing down.
[[shapes]]
type = "mesh"
material = "light"
positions = [[-0.3, 1.99, -0.3], [0.3, 1.99, -0.3], [0.3, 1.99, 0.3], [-0.3, 1.99, 0.3]]
indices = [[0, 1, 2], [0, 2, 3]]
"""


def cube(lo, hi):
    """A closed box with outward normals (the medium's boundary)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    positions = [[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
                 [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]]
    indices = [[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
               [3, 7, 6], [3, 6, 2], [0, 4, 7], [0, 7, 3], [1, 2, 6], [1, 6, 5]]
    return positions, indices


def main():
    values = density()
    rows = [", ".join(f"{v:g}" for v in values[i:i + N]) for i in range(0, len(values), N)]
    positions, indices = cube(*BOUNDS)
    print("# A closed box lit by a small ceiling light, holding a cloud of chromatic smoke given")
    print("# as a density grid. Written by scripts/media-grid-scene.py; benches/media_compare.py")
    print("# --scene grid and tests/media.rs render it against Mitsuba 3's volpath.")
    print()
    print("[camera]\nposition = [0, 1, 2.8]\nlook_at = [0, 0.9, 0]\nfov = 50\nwidth = 64\nheight = 64")
    print()
    print("[media.smoke]\ntype = \"uniformgrid\"\nsigma_a = [1, 1.5, 2.2]\nsigma_s = [10, 11, 12]")
    print("g = 0.3")
    print(f"resolution = [{N}, {N}, {N}]")
    print(f"bounds = {BOUNDS}")
    print("density = [\n" + ",\n".join("  " + r for r in rows) + ",\n]")
    print()
    print("[materials.white]\ndiffuse = 0.7\n\n[materials.red]\ndiffuse = [0.6, 0.1, 0.1]")
    print("\n[materials.green]\ndiffuse = [0.1, 0.5, 0.1]\n")
    print("[materials.light]\ndiffuse = 0\nemission = [20, 20, 20]\n")
    print("[materials.boundary]\ninterface = true")
    print(WALLS)
    print("# The smoke's boundary, on the grid's box.")
    print("[[shapes]]\ntype = \"mesh\"\nmaterial = \"boundary\"")
    print(f"positions = {positions}")
    print(f"indices = {indices}")
    print("media = { inside = \"smoke\" }")
    print()
    print("[render]\nintegrator = \"path\"\nmax_depth = 64")


if __name__ == "__main__":
    main()
