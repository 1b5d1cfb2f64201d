#!/usr/bin/env python3
"""Writes pool-water.obj: the wavy water surface of scenes/pool-caustics.toml.

A 48x48 grid over x, z in [-1, 1] at height 0.7, displaced by a sum of three sines
(amplitude 0.02-0.03), with the analytic normals as vertex normals, so that the smooth
dielectric focuses the light into a caustic net on the pool's floor.
"""

import math
import pathlib

N = 48
WAVES = [  # (amplitude, kx, kz, phase)
    (0.030, 9.0, 4.0, 0.3),
    (0.025, -5.0, 10.0, 1.7),
    (0.020, 12.0, -7.0, 4.1),
]


def height(x, z):
    return 0.7 + sum(a * math.sin(kx * x + kz * z + p) for a, kx, kz, p in WAVES)


def normal(x, z):
    dx = sum(a * kx * math.cos(kx * x + kz * z + p) for a, kx, kz, p in WAVES)
    dz = sum(a * kz * math.cos(kx * x + kz * z + p) for a, kx, kz, p in WAVES)
    n = (-dx, 1.0, -dz)
    length = math.sqrt(sum(c * c for c in n))
    return tuple(c / length for c in n)


def main():
    lines = ["# Written by pool_water.py: a wavy water surface, 48x48 quads."]
    coords = [-1.0 + 2.0 * i / N for i in range(N + 1)]
    for z in coords:
        for x in coords:
            lines.append(f"v {x:.6f} {height(x, z):.6f} {z:.6f}")
    for z in coords:
        for x in coords:
            n = normal(x, z)
            lines.append(f"vn {n[0]:.6f} {n[1]:.6f} {n[2]:.6f}")
    for j in range(N):
        for i in range(N):
            a = j * (N + 1) + i + 1
            b, c, d = a + 1, a + N + 2, a + N + 1
            # Counter-clockwise seen from above: the geometric normal points up.
            lines.append(f"f {a}//{a} {d}//{d} {c}//{c} {b}//{b}")
    out = pathlib.Path(__file__).with_name("pool-water.obj")
    out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
