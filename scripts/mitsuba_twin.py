"""Mitsuba 3 XML for a native raylink TOML scene, and a small EXR writer: what the room
scripts (scripts/lamp-room-scene.py, scripts/window-room-scene.py) use to write each scene's
Mitsuba twin (benches/interiors/*.xml) from the TOML they write, so that both renderers are
given one description. Plain Python (no numpy, no Mitsuba needed to write the files).

The subset the rooms use: a perspective camera; quads that are parallelograms (Mitsuba
`rectangle`s, whose normal follows raylink's vertex order, so one-sided emitters face the same
way) and spheres; materials with a Lambertian `diffuse`, a GGX `specular` lobe (`roughness`,
no `fresnel`) and `emission`; `directional` lights; a world `environment` map (file, scale,
rotate and scale steps) or a constant `background`.

How raylink's model maps to Mitsuba's:

- raylink's surfaces reflect on both sides: every BSDF is wrapped in `twosided`;
- `diffuse` alone is Mitsuba's `diffuse`;
- `diffuse` kd plus `specular` ks with GGX α is f = kd/π + ks·D·G/(4 cos cos), with no
  Fresnel factor: Mitsuba's `blendbsdf` of a `diffuse` (kd/(1−w)) and a `roughconductor`
  (`material` none, i.e. reflectance 1, times ks/w) with w = max ks/(max kd + max ks), exact
  but for the masking term (Mitsuba's separable Smith G1·G1, raylink's height-correlated G);
- `fov` spans the shorter image axis: Mitsuba's `fov_axis` `smaller`;
- raylink's `max_depth` counts bounces, Mitsuba's path vertices after the camera: it is
  raylink's + 1;
- pixels are box-filtered (raylink: `--filter box`);
- environment maps: raylink reads a lat-long map with light-space +z at the top row and
  u = 0 at +x, u = 1/4 at +y; Mitsuba with +y at the top, u = 0 at −z and u = 1/4 at +x.
  The twin's `to_world` is raylink's transform times the (mirroring) change between them.
  raylink puts the texel centres of an H-row map at θ = π(y + 1/2)/H, Mitsuba its rows at
  θ = πy/(H − 1), from pole to pole: one file would be a slightly stretched sky in Mitsuba,
  so a room script writes the twin its own map, the same sky sampled at Mitsuba's rows
  (on the window room, one file for both made Mitsuba's sky-lit mean 1% brighter, the two
  files 0.5%: what is left is raylink's nearest texel against Mitsuba's bilinear lookup).
"""

import math
import struct

# Mitsuba light space from raylink light space, column by column: raylink's +x (u = 0) is
# Mitsuba's -z, its +y (u = 1/4) Mitsuba's +x, its +z (the top row) Mitsuba's +y.
_RAYLINK_TO_MITSUBA_LIGHT = [[0, 1, 0], [0, 0, 1], [-1, 0, 0]]


def _mat_mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def _transpose(a):
    return [list(r) for r in zip(*a)]


def _sub(a, b):
    return [x - y for x, y in zip(a, b)]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _norm(a):
    n = math.sqrt(sum(x * x for x in a))
    return [x / n for x in a]


def _colour(value, default):
    if value is None:
        value = default
    if isinstance(value, (int, float)):
        value = [value] * 3
    return [float(v) for v in value]


def _f(x):
    return "%.9g" % x


def _vec(v):
    return ", ".join(_f(x) for x in v)


def _matrix(rows):
    """A Mitsuba 4x4 matrix value from a 3x4 (or 3x3) row list."""
    full = [list(r) + [0.0] * (4 - len(r)) for r in rows] + [[0, 0, 0, 1]]
    return " ".join(_f(x) for r in full for x in r)


def _linear(transform):
    """The linear part of a raylink transform (rotate and scale steps, in order)."""
    steps = transform if isinstance(transform, list) else [transform]
    m = [[1.0 if i == j else 0.0 for j in range(3)] for i in range(3)]
    for step in steps:
        (kind, value), = step.items()
        if kind == "rotate":
            x, y, z = _norm([float(v) for v in value["axis"]])
            a = math.radians(float(value["degrees"]))
            c, s, t = math.cos(a), math.sin(a), 1 - math.cos(a)
            r = [[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
                 [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
                 [t * x * z - s * y, t * y * z + s * x, t * z * z + c]]
        elif kind == "scale":
            k = _colour(value, 1)
            r = [[k[0], 0, 0], [0, k[1], 0], [0, 0, k[2]]]
        else:
            raise ValueError(f"environment transform step {kind} is not written")
        m = _mat_mul(r, m)
    return m


def _bsdf(m, indent):
    kd = _colour(m.get("diffuse"), 0.5)
    ks = _colour(m.get("specular"), 0)
    for key in m:
        if key not in ("diffuse", "specular", "roughness", "emission"):
            raise ValueError(f"material key {key} is not written")
    pad = " " * indent
    if max(ks) == 0:
        return (f'{pad}<bsdf type="twosided">\n{pad}    <bsdf type="diffuse">\n'
                f'{pad}        <rgb name="reflectance" value="{_vec(kd)}"/>\n'
                f'{pad}    </bsdf>\n{pad}</bsdf>\n')
    alpha = float(m.get("roughness", 0))
    if not isinstance(m.get("roughness", 0), (int, float)) or alpha <= 0:
        raise ValueError("only an isotropic, rough specular lobe is written")
    w = max(ks) / (max(kd) + max(ks))
    if max(kd) + max(ks) > 1:
        raise ValueError("diffuse + specular above 1 cannot be blended")
    return (f'{pad}<bsdf type="twosided">\n{pad}    <bsdf type="blendbsdf">\n'
            f'{pad}        <float name="weight" value="{_f(w)}"/>\n'
            f'{pad}        <bsdf type="diffuse">\n'
            f'{pad}            <rgb name="reflectance" value="{_vec([c / (1 - w) for c in kd])}"/>\n'
            f'{pad}        </bsdf>\n'
            f'{pad}        <bsdf type="roughconductor">\n'
            f'{pad}            <string name="material" value="none"/>\n'
            f'{pad}            <string name="distribution" value="ggx"/>\n'
            f'{pad}            <float name="alpha" value="{_f(alpha)}"/>\n'
            f'{pad}            <rgb name="specular_reflectance" value="{_vec([c / w for c in ks])}"/>\n'
            f'{pad}        </bsdf>\n'
            f'{pad}    </bsdf>\n{pad}</bsdf>\n')


def mitsuba_xml(scene, environment_file=None, title=""):
    """Mitsuba 3 scene XML for the parsed TOML `scene`. `environment_file` is the map's
    path as the XML should name it (relative to the XML file). Resolution, samples per
    pixel, sampler and path length are parameters ($width, $height, $spp, $sampler,
    $max_depth) defaulting to the TOML's."""
    cam, render = scene["camera"], scene.get("render", {})
    out = ['<?xml version="1.0" encoding="utf-8"?>', f"<!-- {title} -->" if title else None,
           '<scene version="3.0.0">',
           f'    <default name="width" value="{cam["width"]}"/>',
           f'    <default name="height" value="{cam["height"]}"/>',
           f'    <default name="spp" value="{render.get("spp", 16)}"/>',
           '    <default name="sampler" value="independent"/>',
           f'    <default name="max_depth" value="{int(render.get("max_depth", 8)) + 1}"/>',
           '    <integrator type="path">',
           '        <integer name="max_depth" value="$max_depth"/>',
           '    </integrator>',
           '    <sensor type="perspective">',
           f'        <float name="fov" value="{_f(float(cam.get("fov", 45)))}"/>',
           '        <string name="fov_axis" value="smaller"/>',
           '        <transform name="to_world">',
           f'            <lookat origin="{_vec(cam["position"])}" target="{_vec(cam["look_at"])}" '
           f'up="{_vec(cam.get("up", [0, 1, 0]))}"/>',
           '        </transform>',
           '        <sampler type="$sampler">',
           '            <integer name="sample_count" value="$spp"/>',
           '        </sampler>',
           '        <film type="hdrfilm">',
           '            <integer name="width" value="$width"/>',
           '            <integer name="height" value="$height"/>',
           '            <string name="pixel_format" value="rgb"/>',
           '            <rfilter type="box"/>',
           '        </film>',
           '    </sensor>']
    out = [line for line in out if line is not None]
    materials = scene.get("materials", {})
    for name, m in materials.items():
        out.append(_bsdf(m, 4).rstrip("\n").replace('<bsdf type="twosided">',
                                                    f'<bsdf type="twosided" id="{name}">', 1))
    world = scene.get("world", {})
    env = world.get("environment")
    if env is not None:
        t = _linear(env.get("transform", []))
        # raylink's light direction is T^-1 d, Mitsuba's W^-1 d = M T^-1 d: W = T M^-1.
        w = _mat_mul(t, _transpose(_RAYLINK_TO_MITSUBA_LIGHT))
        scale = _colour(env.get("scale"), 1)
        if len(set(scale)) != 1:
            raise ValueError("a coloured environment scale is not written")
        out += ['    <emitter type="envmap">',
                f'        <string name="filename" value="{environment_file}"/>',
                f'        <float name="scale" value="{_f(scale[0])}"/>',
                f'        <transform name="to_world"><matrix value="{_matrix(w)}"/></transform>',
                '    </emitter>']
    elif max(_colour(world.get("background"), 0)) > 0:
        out += ['    <emitter type="constant">',
                f'        <rgb name="radiance" value="{_vec(_colour(world["background"], 0))}"/>',
                '    </emitter>']
    for light in scene.get("lights", []):
        if light["type"] != "directional":
            raise ValueError(f"light type {light['type']} is not written")
        out += ['    <emitter type="directional">',
                f'        <vector name="direction" value="{_vec(light["direction"])}"/>',
                f'        <rgb name="irradiance" value="{_vec(_colour(light["irradiance"], 0))}"/>',
                '    </emitter>']
    for shape in scene["shapes"]:
        m = materials[shape["material"]]
        if shape["type"] == "quad":
            v = [[float(x) for x in p] for p in shape["vertices"]]
            if max(abs(x) for x in _sub(_sub(v[2], v[1]), _sub(v[3], v[0]))) > 1e-9:
                raise ValueError(f"quad {v} is not a parallelogram")
            a = [x / 2 for x in _sub(v[1], v[0])]
            b = [x / 2 for x in _sub(v[3], v[0])]
            n = _norm(_cross(a, b))
            c = [(p + q) / 2 for p, q in zip(v[0], v[2])]
            rows = [[a[i], b[i], n[i], c[i]] for i in range(3)]
            out += ['    <shape type="rectangle">',
                    f'        <transform name="to_world"><matrix value="{_matrix(rows)}"/></transform>']
        elif shape["type"] == "sphere":
            out += ['    <shape type="sphere">',
                    f'        <point name="center" value="{_vec(shape["center"])}"/>',
                    f'        <float name="radius" value="{_f(float(shape["radius"]))}"/>']
        else:
            raise ValueError(f"shape type {shape['type']} is not written")
        out.append(f'        <ref id="{shape["material"]}"/>')
        emission = _colour(m.get("emission"), 0)
        if max(emission) > 0:
            out += ['        <emitter type="area">',
                    f'            <rgb name="radiance" value="{_vec(emission)}"/>',
                    '        </emitter>']
        out.append('    </shape>')
    out.append('</scene>')
    return "\n".join(out) + "\n"


def write_exr(path, width, height, pixel):
    """An uncompressed scanline OpenEXR file of half-float R, G, B: pixel(x, y) gives the
    linear RGB of column x, row y (row 0 at the top)."""

    def attribute(name, kind, data):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(data)) + data

    channels = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 1, 0, 1, 1) for c in "BGR") + b"\0"
    window = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = (struct.pack("<ii", 20000630, 2)
              + attribute("channels", "chlist", channels)
              + attribute("compression", "compression", b"\0")
              + attribute("dataWindow", "box2i", window)
              + attribute("displayWindow", "box2i", window)
              + attribute("lineOrder", "lineOrder", b"\0")
              + attribute("pixelAspectRatio", "float", struct.pack("<f", 1.0))
              + attribute("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0))
              + attribute("screenWindowWidth", "float", struct.pack("<f", 1.0))
              + b"\0")
    line_bytes = width * 3 * 2
    first = len(header) + 8 * height
    offsets = b"".join(struct.pack("<Q", first + y * (8 + line_bytes)) for y in range(height))
    lines = []
    for y in range(height):
        row = [pixel(x, y) for x in range(width)]
        data = b"".join(struct.pack(f"<{width}e", *[p[c] for p in row]) for c in (2, 1, 0))
        lines.append(struct.pack("<ii", y, len(data)) + data)
    with open(path, "wb") as f:
        f.write(header + offsets + b"".join(lines))
