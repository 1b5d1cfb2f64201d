#!/usr/bin/env python3
"""Writes scenes/lamp-room.toml: a long hall split by a wall with a doorway, lit only by
288 small ceiling lamps of four colours and strengths (a few hundred emitters, most of
them far from any one point or behind the wall), for light selection. Also writes the
scene's Mitsuba 3 twin, benches/interiors/lamp-room.xml (scripts/mitsuba_twin.py).
Deterministic: the same files every run. Usage: scripts/lamp-room-scene.py"""

import os
import random
import sys
import tomllib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mitsuba_twin import mitsuba_xml  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

rng = random.Random(7)
W, H, D = 12.0, 3.0, 8.0  # x in [-6, 6], y in [0, 3], z in [-8, 0]


def quad(a, b, c, d, material):
    v = ", ".join("[%g, %g, %g]" % p for p in (a, b, c, d))
    return '[[shapes]]\ntype = "quad"\nvertices = [%s]\nmaterial = "%s"\n' % (v, material)


out = [
    "# A hall lit by 288 small ceiling lamps of four colours and strengths, split by a wall",
    "# with a doorway: from any point most lamps are far away or hidden, which is where a",
    "# light hierarchy chooses better than power alone. Written by scripts/lamp-room-scene.py.",
    "",
    "[camera]",
    "position = [-5.2, 1.6, -0.6]",
    "look_at = [2, 1.0, -5.5]",
    "fov = 65",
    "width = 160",
    "height = 120",
    "",
    "[render]",
    'integrator = "path"',
    "spp = 16",
    "max_depth = 5",
    "",
    "[materials.wall]",
    "diffuse = 0.65",
    "[materials.floor]",
    "diffuse = [0.45, 0.35, 0.25]",
    "[materials.ceiling]",
    "diffuse = 0.8",
    "[materials.gloss]",
    "diffuse = [0.1, 0.2, 0.4]",
    "specular = 0.5",
    "roughness = 0.25",
]
lamps = [("warm", [40, 28, 16]), ("cold", [14, 20, 34]), ("dim", [6, 6, 6]), ("red", [30, 6, 4])]
for name, e in lamps:
    out += ["[materials.lamp_%s]" % name, "diffuse = 0", "emission = [%g, %g, %g]" % tuple(e)]
out.append("")
x0, x1, z0, z1 = -W / 2, W / 2, -D, 0.0
out.append(quad((x0, 0, z0), (x0, 0, z1), (x1, 0, z1), (x1, 0, z0), "floor"))
out.append(quad((x0, H, z0), (x1, H, z0), (x1, H, z1), (x0, H, z1), "ceiling"))
out.append(quad((x0, 0, z0), (x1, 0, z0), (x1, H, z0), (x0, H, z0), "wall"))
out.append(quad((x0, 0, z1), (x0, H, z1), (x1, H, z1), (x1, 0, z1), "wall"))
out.append(quad((x0, 0, z0), (x0, H, z0), (x0, H, z1), (x0, 0, z1), "wall"))
out.append(quad((x1, 0, z0), (x1, 0, z1), (x1, H, z1), (x1, H, z0), "wall"))
# The dividing wall at x = 1 with a doorway for z in [-5, -3.8], y below 2.2.
for (za, zb, ya, yb) in [(z0, -5.0, 0, H), (-3.8, z1, 0, H), (-5.0, -3.8, 2.2, H)]:
    out.append(quad((1, ya, za), (1, yb, za), (1, yb, zb), (1, ya, zb), "wall"))
    out.append(quad((1.1, ya, za), (1.1, ya, zb), (1.1, yb, zb), (1.1, yb, za), "wall"))
out.append('[[shapes]]\ntype = "sphere"\ncenter = [-2, 0.6, -4.5]\nradius = 0.6\nmaterial = "gloss"\n')
out.append('[[shapes]]\ntype = "sphere"\ncenter = [-3.5, 0.4, -2.5]\nradius = 0.4\nmaterial = "wall"\n')
# 24 x 12 lamps, 10 cm square, just under the ceiling.
s = 0.05
for i in range(24):
    for j in range(12):
        x = x0 + (i + 0.5) * W / 24
        z = z0 + (j + 0.5) * D / 12
        name = rng.choice(lamps)[0]
        y = H - 0.01
        out.append(quad((x - s, y, z - s), (x + s, y, z - s), (x + s, y, z + s), (x - s, y, z + s), "lamp_" + name))
text = "\n".join(out) + "\n"
os.makedirs(os.path.join(ROOT, "benches/interiors"), exist_ok=True)
with open(os.path.join(ROOT, "scenes/lamp-room.toml"), "w") as f:
    f.write(text)
with open(os.path.join(ROOT, "benches/interiors/lamp-room.xml"), "w") as f:
    f.write(mitsuba_xml(tomllib.loads(text), title="The Mitsuba 3 twin of scenes/lamp-room.toml, "
                        "written by scripts/lamp-room-scene.py"))
