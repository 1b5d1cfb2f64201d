#!/usr/bin/env python3
"""Writes scenes/anim-audition.toml: 351 frames in the spirit of the sequence of Jevans's
Table 2 ("The Audition": a weight drops onto a see-saw and launches Eric the worm). The set
and the meshes are those of scenes/anim-circus.toml; here the act never stops: the weight
lands on the raised end, the plank flips and launches the worm, the worm comes down on its
raised end and launches the weight back, and so on, 16 times over. Each flight is a
ballistic arc (keys every frame, so the motion is the physics, not an interpolation).

Run from the repository root: python3 scripts/anim-audition.py
"""
import math
import os

FRAMES = 351
FLIGHT = 19  # frames in the air
FLIP = 3  # frames for the plank to flip
PERIOD = FLIGHT + FLIP
APEX = 2.3  # height of a flight above its seat

# Seats on the plank (which pivots about (0, 0.5, 0.5) by +-12 degrees): (x, y) of each
# object's centre with its end of the plank up or down.
WEIGHT = {"up": (1.3, 1.06), "down": (1.35, 0.48)}
WORM = {"up": (-1.25, 1.28), "down": (-1.25, 0.73)}
Z = 0.5

HERE = os.path.dirname(os.path.abspath(__file__))
CIRCUS = os.path.join(HERE, "..", "scenes", "anim-circus.toml")
OUT = os.path.join(HERE, "..", "scenes", "anim-audition.toml")


def smooth(s):
    s = min(max(s, 0.0), 1.0)
    return s * s * (3 - 2 * s)


def lerp(a, b, s):
    return a + (b - a) * s


def state(frame):
    """(plank degrees, weight (x, y, degrees), worm (x, y, degrees)) at `frame`."""
    t = frame + FLIGHT / 2  # frame 0 is the weight's first apex
    k = int(t // PERIOD)
    u = t - k * PERIOD
    weight_flies = k % 2 == 0
    # The flyer's end of the plank is up during its flight; the right (weight's) end is up
    # at +12 degrees.
    up = 12.0 if weight_flies else -12.0
    flights = k  # completed flights before this one, for the spin
    if u <= FLIGHT:
        s = u / FLIGHT
        lift = 4 * APEX * s * (1 - s)
        if weight_flies:
            wx, wy = WEIGHT["up"]
            weight = (wx, wy + lift, up + 180 * (flights // 2 + s))
            worm = (*WORM["down"], up - 360 * (flights // 2))
        else:
            x, y = WORM["up"]
            worm = (x, y + lift, up - 360 * (flights // 2 + s))
            weight = (*WEIGHT["down"], up + 180 * ((flights + 1) // 2))
        return up, weight, worm
    s = smooth((u - FLIGHT) / FLIP)
    plank = lerp(up, -up, s)
    if weight_flies:
        wx = lerp(WEIGHT["up"][0], WEIGHT["down"][0], s)
        wy = lerp(WEIGHT["up"][1], WEIGHT["down"][1], s)
        weight = (wx, wy, plank + 180 * (flights // 2 + 1))
        worm = (WORM["down"][0], lerp(WORM["down"][1], WORM["up"][1], s), plank - 360 * (flights // 2))
    else:
        x = WORM["up"][0]
        worm = (x, lerp(WORM["up"][1], WORM["down"][1], s), plank - 360 * (flights // 2 + 1))
        weight = (
            lerp(WEIGHT["down"][0], WEIGHT["up"][0], s),
            lerp(WEIGHT["down"][1], WEIGHT["up"][1], s),
            plank + 180 * ((flights + 1) // 2),
        )
    return plank, weight, worm


def keys(make):
    return "keyframes = [\n" + "".join(f"  {make(f)},\n" for f in range(FRAMES)) + "]\n"


def rot(deg):
    return f"rotate = {{ axis = [0, 0, 1], degrees = {deg:.3f} }}"


def main():
    circus = open(CIRCUS).read()
    # The set: everything of the circus before its see-saw, and its lights.
    head = circus[circus.index("[world]") : circus.index("# The see-saw")]
    lights = circus[circus.index("[[lights]]") :]
    plank = keys(lambda f: f"{{ frame = {f}, {rot(state(f)[0])}, translate = [0, 0.5, 0.5] }}")
    weight = keys(
        lambda f: "{{ frame = {}, {}, translate = [{:.4f}, {:.4f}, {}] }}".format(
            f, rot(state(f)[1][2]), state(f)[1][0], state(f)[1][1], Z
        )
    )
    worm = keys(
        lambda f: "{{ frame = {}, {}, translate = [{:.4f}, {:.4f}, {}] }}".format(
            f, rot(state(f)[2][2]), state(f)[2][0], state(f)[2][1], Z
        )
    )
    text = f"""# {FRAMES} frames in the spirit of the sequence of Jevans's Table 2 ("The Audition", 351
# frames, 6,000 polygons, 4 lights): before a circus tent, a weight and a worm (a torus)
# launch each other from a see-saw, 16 flights, while the rest of the scene stands still.
# Written by scripts/anim-audition.py (the set and meshes of anim-circus.toml); about 3,900
# polygons, four point lights. scripts/table2.sh renders it as the paper's Table 2.

[animation]
frames = {FRAMES}
fps = 24

[camera]
position = [0, 2.4, 9.5]
look_at = [0, 1.8, 0]
fov = 40
width = 640
height = 480

{head}# The see-saw: a fulcrum and a plank that pivots about (0, 0.5, 0.5).
[[shapes]]
type = "obj"
file = "meshes/anim-box.obj"
material = "wood"
transform = [{{ scale = [0.3, 0.45, 0.6] }}, {{ translate = [0, 0.225, 0.5] }}]

[[shapes]]
type = "obj"
file = "meshes/anim-box.obj"
material = "wood"
transform = {{ scale = [3.0, 0.1, 0.5] }}
{plank}
# The weight.
[[shapes]]
type = "obj"
file = "meshes/anim-box.obj"
material = "iron"
transform = {{ scale = 0.4 }}
{weight}
# The worm.
[[shapes]]
type = "obj"
file = "meshes/anim-torus.obj"
material = "worm"
{worm}
{lights}"""
    with open(OUT, "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
