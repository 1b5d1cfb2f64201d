#!/usr/bin/env python3
"""Renders a native raylink TOML scene with Mitsuba 3's volumetric path tracer (`volpath`,
scalar_rgb), as the reference tests/media.rs holds raylink's media to.

The scene is read from the TOML file itself, so both renderers are given one description. It
takes the subset of the format the media tests use: a camera (with its medium), homogeneous
media and uniform grids (as Mitsuba grid volumes), inline triangle meshes and spheres, and
materials that are diffuse, emitting, interfaces (`interface = true`) or smooth glass
(`transmission = 1`, `ior`). A shape's `media` become Mitsuba's interior and exterior media;
raylink's max_depth bounces are Mitsuba's max_depth + 1 path vertices. Pixels are box-filtered, as tests/media.rs renders.

Mitsuba is not one of raylink's dependencies: install it in a virtual environment outside
the repository:

    python3 -m venv /tmp/mi && /tmp/mi/bin/pip install mitsuba
    /tmp/mi/bin/python scripts/media-reference.py tests/scenes/media-box.toml \
        --spp 16384 --seed 7 -o tests/data/media-box-mitsuba-64.exr
"""

import argparse
import os
import struct
import sys
import tempfile
import time
import tomllib

import mitsuba as mi

mi.set_variant("scalar_rgb")

# Extra parameters of a heterogeneous medium (the benchmark sets Mitsuba's majorant grid here).
MAJORANT = {}


def rgb(value, default):
    """A TOML colour: one number or three."""
    if value is None:
        value = default
    if isinstance(value, (int, float)):
        value = [value] * 3
    return mi.ScalarColor3f(*[float(v) for v in value])


def write_ply(path, positions, indices):
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\n")
        f.write(f"element vertex {len(positions)}\n")
        f.write("property float x\nproperty float y\nproperty float z\n")
        f.write(f"element face {len(indices)}\n")
        f.write("property list uchar int vertex_indices\nend_header\n")
        for p in positions:
            f.write(f"{p[0]} {p[1]} {p[2]}\n")
        for t in indices:
            f.write(f"3 {t[0]} {t[1]} {t[2]}\n")


def write_vol(path, resolution, bounds, density, sigma_t):
    """A Mitsuba grid volume (.vol, float32): the density times each channel of sigma_t."""
    nx, ny, nz = resolution
    (x0, y0, z0), (x1, y1, z1) = bounds
    header = b"VOL" + struct.pack("<B5i6f", 3, 1, nx, ny, nz, 3, x0, y0, z0, x1, y1, z1)
    values = [d * t for d in density for t in sigma_t]
    with open(path, "wb") as f:
        f.write(header)
        f.write(struct.pack(f"<{len(values)}f", *values))


def medium(name, desc, grid_dir):
    sigma_a = rgb(desc.get("sigma_a"), 1.0)
    sigma_s = rgb(desc.get("sigma_s"), 1.0)
    scale = float(desc.get("scale", 1.0))
    kind = desc.get("type")
    if kind not in ("homogeneous", "uniformgrid") or "emission" in desc or "transform" in desc:
        sys.exit("media-reference.py: only homogeneous media and uniform grids, without "
                 "emission or transforms, are written")
    sigma_t = sigma_a + sigma_s
    albedo = mi.ScalarColor3f(
        *[s / t if t > 0 else 0.0 for s, t in zip(sigma_s, sigma_t)]
    )
    # Mitsuba reads an RGB sigma_t as a reflectance (at most 1): its largest channel goes
    # into the scale.
    peak = max(max(sigma_t), 1e-30)
    phase = {"type": "hg", "g": float(desc.get("g", 0.0))}
    if kind == "homogeneous":
        return {
            "type": "homogeneous",
            "sigma_t": {"type": "rgb", "value": sigma_t / peak},
            "albedo": {"type": "rgb", "value": albedo},
            "scale": scale * peak,
            "phase": phase,
        }
    # A uniform grid: samples at the cells' centres over `bounds`, interpolated trilinearly
    # (Mitsuba's grid volume places its samples so too); the grid's outer samples should be 0,
    # where Mitsuba clamps and raylink (as pbrt-v4) falls to zero.
    bounds = desc.get("bounds", [[0, 0, 0], [1, 1, 1]])
    lo, hi = [float(v) for v in bounds[0]], [float(v) for v in bounds[1]]
    path = os.path.join(grid_dir, f"{name}.vol")
    write_vol(path, desc["resolution"], (lo, hi), desc["density"], [t / peak for t in sigma_t])
    to_world = mi.ScalarTransform4f().translate(lo).scale([b - a for a, b in zip(lo, hi)])
    return {
        "type": "heterogeneous",
        "sigma_t": {"type": "gridvolume", "filename": path, "raw": True, "to_world": to_world},
        "albedo": {"type": "rgb", "value": albedo},
        "scale": scale * peak,
        "phase": phase,
        **MAJORANT,
    }


def bsdf(desc):
    if desc.get("interface"):
        return {"type": "null"}
    if desc.get("transmission") is not None:
        return {"type": "dielectric", "int_ior": float(desc.get("ior", 1.5)), "ext_ior": 1.0}
    return {"type": "diffuse", "reflectance": {"type": "rgb", "value": rgb(desc.get("diffuse"), 0.5)}}


def scene_dict(scene, spp, mesh_dir):
    cam = scene["camera"]
    media = {name: medium(name, d, mesh_dir) for name, d in scene.get("media", {}).items()}
    materials = scene["materials"]
    integrator_depth = int(scene.get("render", {}).get("max_depth", 8)) + 1
    sensor = {
        "type": "perspective",
        "fov": float(cam.get("fov", 45.0)),
        "fov_axis": "smaller",
        "to_world": mi.ScalarTransform4f().look_at(
            origin=cam["position"], target=cam["look_at"], up=cam.get("up", [0, 1, 0])
        ),
        "sampler": {"type": "independent", "sample_count": spp},
        "film": {
            "type": "hdrfilm",
            "width": int(cam["width"]),
            "height": int(cam["height"]),
            "rfilter": {"type": "box"},
            "pixel_format": "rgb",
        },
    }
    if "medium" in cam:
        sensor["medium"] = media[cam["medium"]]
    d = {
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": integrator_depth},
        "sensor": sensor,
    }
    for i, shape in enumerate(scene["shapes"]):
        m = materials[shape["material"]]
        if shape["type"] == "mesh":
            path = os.path.join(mesh_dir, f"mesh{i}.ply")
            write_ply(path, shape["positions"], shape["indices"])
            s = {"type": "ply", "filename": path, "face_normals": True}
        elif shape["type"] == "sphere":
            s = {
                "type": "sphere",
                "center": [float(v) for v in shape.get("center", [0, 0, 0])],
                "radius": float(shape.get("radius", 1.0)),
            }
        else:
            sys.exit(f"media-reference.py: shape type {shape['type']} is not written")
        s["bsdf"] = bsdf(m)
        if "emission" in m:
            s["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": rgb(m["emission"], 0)}}
        inside_outside = shape.get("media", {})
        if "inside" in inside_outside:
            s["interior"] = media[inside_outside["inside"]]
        if "outside" in inside_outside:
            s["exterior"] = media[inside_outside["outside"]]
        d[f"shape{i}"] = s
    return d


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--spp", type=int, default=4096)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("-o", "--output", required=True)
    args = ap.parse_args()
    with open(args.scene, "rb") as f:
        scene = tomllib.load(f)
    with tempfile.TemporaryDirectory() as mesh_dir:
        loaded = mi.load_dict(scene_dict(scene, args.spp, mesh_dir))
        start = time.time()
        image = mi.render(loaded, seed=args.seed)
        seconds = time.time() - start
    mi.Bitmap(image).write(args.output)
    pixels = mi.TensorXf(image).numpy().reshape(-1, 3)
    mean = [float(pixels[:, c].mean()) for c in range(3)]
    print(f"{args.output}: Mitsuba {mi.__version__} scalar_rgb volpath, {args.spp} spp, "
          f"seed {args.seed}, {seconds:.1f} s; mean RGB [{mean[0]:.6f}, {mean[1]:.6f}, {mean[2]:.6f}]")


if __name__ == "__main__":
    main()
