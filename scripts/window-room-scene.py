#!/usr/bin/env python3
"""Writes scenes/window-room.toml: a furnished room (table, shelf, sofa, boxes, a glossy
ball) lit only through a window opening in its left wall, by a sky (a lat-long environment
map, scenes/textures/window-sky.exr, written here too) and a sun (a directional light) whose
patch falls on the floor; the camera looks into the room with the window at its side, so
most of the image is lit indirectly. Also writes the scene's Mitsuba 3 twin,
benches/interiors/window-room.xml (scripts/mitsuba_twin.py), with the same sky sampled where
Mitsuba places its texels (benches/interiors/window-sky-mitsuba.exr). Deterministic: the
same files every run. Usage: scripts/window-room-scene.py"""

import math
import os
import sys
import tomllib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mitsuba_twin import mitsuba_xml, write_exr  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
W, H, D = 5.0, 2.6, 4.0  # x in [-2.5, 2.5], y in [0, 2.6], z in [-4, 0]
x0, x1, z0, z1 = -W / 2, W / 2, -D, 0.0
# The window in the left wall (x = -2.5): y in [0.9, 2.1], z in [-2.9, -1.3].
WY0, WY1, WZ0, WZ1 = 0.9, 2.1, -2.9, -1.3
# The sky enters only through the window: its outer face is the environment's portal
# (corners in order, (c3 - c0) x (c1 - c0) pointing out of the room).
PORTAL = "[[%g, %g, %g], [%g, %g, %g], [%g, %g, %g], [%g, %g, %g]]" % (
    -2.7, WY0, WZ0, -2.7, WY1, WZ0, -2.7, WY1, WZ1, -2.7, WY0, WZ1)


def quad(a, b, c, d, material):
    v = ", ".join("[%g, %g, %g]" % p for p in (a, b, c, d))
    return '[[shapes]]\ntype = "quad"\nvertices = [%s]\nmaterial = "%s"\n' % (v, material)


def box(lo, hi, material, bottom=False):
    """The faces of an axis-aligned box, facing out (the bottom one only if asked: boxes
    standing on the floor do not need it)."""
    (a, b, c), (p, q, r) = lo, hi
    faces = [
        ((a, q, c), (a, q, r), (p, q, r), (p, q, c)),  # top
        ((a, b, r), (p, b, r), (p, q, r), (a, q, r)),  # +z
        ((a, b, c), (a, q, c), (p, q, c), (p, b, c)),  # -z
        ((p, b, c), (p, q, c), (p, q, r), (p, b, r)),  # +x
        ((a, b, c), (a, b, r), (a, q, r), (a, q, c)),  # -x
    ]
    if bottom:
        faces.append(((a, b, c), (p, b, c), (p, b, r), (a, b, r)))
    return [quad(*f, material) for f in faces]


def sky(direction_y):
    """Sky radiance by the sine of the elevation: a bright horizon fading smoothly (a
    Gaussian in the sine, so that the map's texels follow it closely) to a blue zenith above
    and a dim brown ground below."""
    horizon, zenith, ground = (1.6, 1.5, 1.35), (0.35, 0.6, 1.3), (0.35, 0.3, 0.24)
    far = zenith if direction_y > 0 else ground
    t = math.exp(-((direction_y / 0.35) ** 2))
    return tuple(f + (h - f) * t for h, f in zip(horizon, far))


def raylink_sky(x, y, width=64, height=32):
    # raylink's lat-long rows run from light-space +z (the top) with texel centres at
    # theta = pi (y + 1/2) / height; the scene's transform turns light-space +z to world +y.
    return sky(math.cos(math.pi * (y + 0.5) / height))


def mitsuba_sky(x, y, width=64, height=32):
    # Mitsuba's rows run from +y (the top) with the first and last rows at the poles:
    # theta = pi y / (height - 1). The twin has its own file so that both sample one sky.
    return sky(math.cos(math.pi * y / (height - 1)))


out = [
    "# A furnished room lit only through a window in its left wall, by a sky (a lat-long",
    "# environment map) and a sun (a directional light) whose patch falls on the floor: most",
    "# of what the camera sees is lit indirectly. Written by scripts/window-room-scene.py.",
    "",
    "[camera]",
    "position = [2.0, 1.5, -0.2]",
    "look_at = [-0.7, 0.8, -3.3]",
    "fov = 62",
    "width = 160",
    "height = 120",
    "",
    "[render]",
    'integrator = "path"',
    "spp = 16",
    "max_depth = 8",
    "",
    "[world]",
    'environment = { file = "textures/window-sky.exr", transform = { rotate = '
    "{ axis = [1, 0, 0], degrees = -90 } }, portal = %s }" % PORTAL,
    "",
    "[[lights]]",
    'type = "directional"',
    "direction = [1, -0.75, -0.25]",
    "irradiance = [9, 8.2, 7]",
    "",
    "[materials.wall]",
    "diffuse = 0.7",
    "[materials.ceiling]",
    "diffuse = 0.8",
    "[materials.floor]",
    "diffuse = [0.5, 0.36, 0.22]",
    "[materials.wood]",
    "diffuse = [0.35, 0.2, 0.1]",
    "[materials.sofa]",
    "diffuse = [0.2, 0.3, 0.5]",
    "[materials.cushion]",
    "diffuse = [0.7, 0.55, 0.25]",
    "[materials.box]",
    "diffuse = [0.6, 0.6, 0.55]",
    "[materials.red]",
    "diffuse = [0.6, 0.12, 0.08]",
    "[materials.gloss]",
    "diffuse = [0.05, 0.1, 0.2]",
    "specular = 0.6",
    "roughness = 0.15",
    "",
]
# Floor, ceiling, back, front and right walls; the left wall around the window.
out.append(quad((x0, 0, z0), (x0, 0, z1), (x1, 0, z1), (x1, 0, z0), "floor"))
out.append(quad((x0, H, z0), (x1, H, z0), (x1, H, z1), (x0, H, z1), "ceiling"))
out.append(quad((x0, 0, z0), (x1, 0, z0), (x1, H, z0), (x0, H, z0), "wall"))
out.append(quad((x0, 0, z1), (x0, H, z1), (x1, H, z1), (x1, 0, z1), "wall"))
out.append(quad((x1, 0, z0), (x1, 0, z1), (x1, H, z1), (x1, H, z0), "wall"))
for (ya, yb, za, zb) in [(0, WY0, z0, z1), (WY1, H, z0, z1), (WY0, WY1, z0, WZ0), (WY0, WY1, WZ1, z1)]:
    out.append(quad((x0, ya, za), (x0, yb, za), (x0, yb, zb), (x0, ya, zb), "wall"))
# The window's reveal: the wall is 0.2 thick around the opening.
t = 0.2
out.append(quad((x0 - t, WY0, WZ0), (x0, WY0, WZ0), (x0, WY0, WZ1), (x0 - t, WY0, WZ1), "wall"))
out.append(quad((x0 - t, WY1, WZ0), (x0 - t, WY1, WZ1), (x0, WY1, WZ1), (x0, WY1, WZ0), "wall"))
out.append(quad((x0 - t, WY0, WZ0), (x0 - t, WY1, WZ0), (x0, WY1, WZ0), (x0, WY0, WZ0), "wall"))
out.append(quad((x0 - t, WY0, WZ1), (x0, WY0, WZ1), (x0, WY1, WZ1), (x0 - t, WY1, WZ1), "wall"))
# A table: a top on four legs, with the glossy ball on it.
out += box((-0.9, 0.72, -2.7), (0.5, 0.77, -1.8), "wood", bottom=True)
for lx, lz in [(-0.85, -2.65), (0.4, -2.65), (-0.85, -1.9), (0.4, -1.9)]:
    out += box((lx, 0, lz), (lx + 0.05, 0.72, lz + 0.05), "wood")
out.append('[[shapes]]\ntype = "sphere"\ncenter = [-0.1, 0.95, -2.25]\nradius = 0.18\nmaterial = "gloss"\n')
# A shelf against the back wall, with two boards and a red box on the lower one.
out += box((0.6, 0, -3.99), (2.2, 1.9, -3.98), "wood")
for sx, sy in [(0.6, 0), (2.18, 0)]:
    out += box((sx, sy, -3.98), (sx + 0.02, 1.9, -3.6), "wood")
for by in (0.02, 0.65, 1.28, 1.88):
    out += box((0.62, by, -3.98), (2.18, by + 0.02, -3.6), "wood", bottom=True)
out += box((0.8, 0.67, -3.9), (1.25, 0.95, -3.65), "red")
out += box((1.5, 1.3, -3.9), (1.9, 1.45, -3.65), "box")
# A sofa against the back wall, behind the table: seat, back, arms and a cushion.
out += box((-1.05, 0, -4.0), (0.45, 0.42, -3.2), "sofa")
out += box((-1.05, 0.42, -4.0), (0.45, 0.9, -3.8), "sofa")
out += box((-1.05, 0.42, -3.8), (-0.9, 0.62, -3.2), "sofa")
out += box((0.3, 0.42, -3.8), (0.45, 0.62, -3.2), "sofa")
out += box((-0.6, 0.42, -3.8), (-0.1, 0.72, -3.65), "cushion")
# Boxes on the floor by the back-left corner.
out += box((-2.4, 0, -3.9), (-1.8, 0.5, -3.3), "box")
out += box((-2.3, 0.5, -3.8), (-1.9, 0.8, -3.45), "red")
out += box((-1.6, 0, -3.95), (-1.2, 0.35, -3.55), "box")

text = "\n".join(out)
os.makedirs(os.path.join(ROOT, "scenes/textures"), exist_ok=True)
os.makedirs(os.path.join(ROOT, "benches/interiors"), exist_ok=True)
with open(os.path.join(ROOT, "scenes/window-room.toml"), "w") as f:
    f.write(text)
write_exr(os.path.join(ROOT, "scenes/textures/window-sky.exr"), 64, 32, raylink_sky)
write_exr(os.path.join(ROOT, "benches/interiors/window-sky-mitsuba.exr"), 64, 32, mitsuba_sky)
with open(os.path.join(ROOT, "benches/interiors/window-room.xml"), "w") as f:
    f.write(mitsuba_xml(tomllib.loads(text), "window-sky-mitsuba.exr",
                        "The Mitsuba 3 twin of scenes/window-room.toml, written by "
                        "scripts/window-room-scene.py"))
