//! From pbrt shapes to raylink geometry: placing meshes in world space with pbrt-v4's
//! orientation rules, tessellating quadrics, and copying object instances.
//!
//! Orientation. raylink's front side (the side an area light emits to) is that of the
//! geometric normal (v1 − v0) × (v2 − v0). pbrt-v4's geometric normal is:
//! - for triangles and bilinear patches without normals, the cross product of the edges in
//!   world space, negated when `ReverseOrientation` XOR the transform swaps handedness,
//!   which is the object-space normal carried as a normal (M⁻ᵀ n), negated by
//!   `ReverseOrientation`;
//! - for meshes with per-vertex normals `N`, turned to the side of the (transformed,
//!   `ReverseOrientation`-negated) shading normal;
//! - for quadrics, the object-space outward normal carried as a normal and negated when
//!   `ReverseOrientation` XOR the transform swaps handedness.
//!
//! Windings are chosen here so that raylink's normal falls on pbrt's side.

use crate::math::{Vec2, Vec3};
use crate::scene::ply::PlyMesh;
use crate::scene::{Geometry, Shape, Sphere};
use glam::{DMat3, DMat4, DVec3};

/// Whether the linear part of `m` mirrors.
pub fn swaps_handedness(m: &DMat4) -> bool {
    DMat3::from_mat4(*m).determinant() < 0.0
}

/// Some(s) when the linear part of `m` is a rotation (or mirror) times the uniform scale s.
pub fn uniform_scale(m: &DMat4) -> Option<f64> {
    let l = DMat3::from_mat4(*m);
    let cols = [l.x_axis, l.y_axis, l.z_axis];
    let len = cols.map(DVec3::length);
    let mean = (len[0] + len[1] + len[2]) / 3.0;
    let tol = 1e-5 * mean;
    let equal = len.iter().all(|&x| (x - mean).abs() <= tol);
    let orth = (0..3).all(|i| cols[i].dot(cols[(i + 1) % 3]).abs() <= tol * mean);
    (equal && orth && mean > 0.0).then_some(mean)
}

fn point(m: &DMat4, p: Vec3) -> Vec3 {
    m.transform_point3(p.as_dvec3()).as_vec3()
}

/// Places an object-space mesh in world space with transform `m`. With normals, each
/// triangle faces the side of its vertices' normals (after multiplying them by
/// `normal_sign`); without, the winding is reversed when `flip`.
pub fn place(mesh: PlyMesh, m: &DMat4, normal_sign: f32, flip: bool) -> Vec<Geometry> {
    let nm = DMat3::from_mat4(*m).inverse().transpose();
    let positions: Vec<Vec3> = mesh.positions.iter().map(|&p| point(m, p)).collect();
    let normals: Option<Vec<Vec3>> = mesh.normals.map(|ns| {
        ns.iter()
            .map(|n| (nm * n.as_dvec3()).normalize_or_zero().as_vec3() * normal_sign)
            .collect()
    });
    let mut triangles = mesh.triangles;
    let mut quads = mesh.quads;
    if let Some(ns) = &normals {
        for [a, b, c, d] in quads.drain(..) {
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
        for t in &mut triangles {
            let [a, b, c] = t.map(|k| positions[k as usize]);
            let shading: Vec3 = t.iter().map(|&k| ns[k as usize]).sum();
            if (b - a).cross(c - a).dot(shading) < 0.0 {
                t.swap(1, 2);
            }
        }
    } else if flip {
        for t in &mut triangles {
            t.swap(1, 2);
        }
        for q in &mut quads {
            q.swap(1, 3);
        }
    }
    PlyMesh {
        positions,
        normals,
        uvs: mesh.uvs,
        triangles,
        quads,
        skipped_faces: 0,
    }
    .into_geometry()
}

/// A grid of (nu+1)·(nv+1) vertices over (u, v) ∈ [0,1]², from `f(u, v) = (p, n)` with `n`
/// the outward unit normal; triangles wound to face `n`, degenerate ones left out.
fn grid(nu: usize, nv: usize, f: impl Fn(f64, f64) -> (DVec3, DVec3)) -> PlyMesh {
    let mut mesh = PlyMesh::default();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    for j in 0..=nv {
        for i in 0..=nu {
            let (u, v) = (i as f64 / nu as f64, j as f64 / nv as f64);
            let (p, n) = f(u, v);
            mesh.positions.push(p.as_vec3());
            normals.push(n.as_vec3());
            uvs.push(Vec2::new(u as f32, v as f32));
        }
    }
    let at = |i: usize, j: usize| (j * (nu + 1) + i) as u32;
    for j in 0..nv {
        for i in 0..nu {
            for mut t in [
                [at(i, j), at(i + 1, j), at(i + 1, j + 1)],
                [at(i, j), at(i + 1, j + 1), at(i, j + 1)],
            ] {
                let [a, b, c] = t.map(|k| mesh.positions[k as usize]);
                let g = (b - a).cross(c - a);
                if g.length() <= 1e-12 * (b - a).length_squared().max(1e-30) {
                    continue;
                }
                let n: Vec3 = t.iter().map(|&k| normals[k as usize]).sum();
                if g.dot(n) < 0.0 {
                    t.swap(1, 2);
                }
                mesh.triangles.push(t);
            }
        }
    }
    mesh.normals = Some(normals);
    mesh.uvs = Some(uvs);
    mesh
}

fn segments(phimax_deg: f64, full: f64) -> usize {
    ((full * phimax_deg / 360.0).ceil() as usize).max(3)
}

/// pbrt's sphere: radius `r`, cut at heights `zmin`, `zmax` and angle `phimax` (degrees).
pub fn sphere(r: f64, zmin: f64, zmax: f64, phimax: f64) -> PlyMesh {
    let (zlo, zhi) = (zmin.min(zmax).clamp(-r, r), zmin.max(zmax).clamp(-r, r));
    let (t0, t1) = (
        (zlo / r).clamp(-1.0, 1.0).acos(),
        (zhi / r).clamp(-1.0, 1.0).acos(),
    );
    let phimax = phimax.clamp(0.0, 360.0).to_radians();
    let nv = ((32.0 * (t0 - t1).abs() / std::f64::consts::PI).ceil() as usize).max(2);
    grid(segments(phimax.to_degrees(), 64.0), nv, |u, v| {
        let (phi, theta) = (u * phimax, t0 + v * (t1 - t0));
        let n = DVec3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        );
        (n * r, n)
    })
}

/// pbrt's disk: at height `h`, radius `r`, inner radius `ri`, facing +z.
pub fn disk(h: f64, r: f64, ri: f64, phimax: f64) -> PlyMesh {
    let phimax = phimax.clamp(0.0, 360.0).to_radians();
    grid(segments(phimax.to_degrees(), 64.0), 1, |u, v| {
        let (phi, rad) = (u * phimax, r + v * (ri - r));
        (DVec3::new(rad * phi.cos(), rad * phi.sin(), h), DVec3::Z)
    })
}

/// pbrt's cylinder around the z axis.
pub fn cylinder(r: f64, zmin: f64, zmax: f64, phimax: f64) -> PlyMesh {
    let phimax = phimax.clamp(0.0, 360.0).to_radians();
    grid(segments(phimax.to_degrees(), 64.0), 1, |u, v| {
        let phi = u * phimax;
        let n = DVec3::new(phi.cos(), phi.sin(), 0.0);
        (n * r + DVec3::Z * (zmin + v * (zmax - zmin)), n)
    })
}

/// The unit sphere an instance tessellates when its transform does not scale uniformly.
pub(super) fn unit_sphere(m: &DMat4) -> Vec<Geometry> {
    place(sphere(1.0, -1.0, 1.0, 360.0), m, 1.0, false)
}

/// A world-space shape of an object definition, copied by an instance's transform `t`.
/// The instance's normals are the definition's carried as normals (pbrt-v4 does not flip
/// them for a mirroring instance transform).
pub fn instance(shape: &Shape, t: &DMat4) -> Vec<Shape> {
    let geometries = placed_geometry(&shape.geometry, t);
    // A moving shape's end goes through the same placement, into as many pieces.
    let mut ends = shape
        .motion
        .as_ref()
        .map(|end| placed_geometry(end, t).into_iter());
    geometries
        .into_iter()
        .map(|geometry| Shape {
            media: shape.media,
            geometry,
            material: shape.material,
            alpha: shape.alpha.clone(),
            motion: ends.as_mut().and_then(Iterator::next),
        })
        .collect()
}

/// `geometry` copied by transform `t`: a sphere under a non-uniform scale is tessellated.
fn placed_geometry(geometry: &Geometry, t: &DMat4) -> Vec<Geometry> {
    let flip = swaps_handedness(t);
    match geometry {
        Geometry::Sphere(Sphere { center, radius }) => match uniform_scale(t) {
            Some(s) => vec![Geometry::Sphere(Sphere {
                center: point(t, *center),
                radius: (*radius as f64 * s) as f32,
            })],
            None => {
                let m = *t
                    * DMat4::from_translation(center.as_dvec3())
                    * DMat4::from_scale(DVec3::splat(*radius as f64));
                unit_sphere(&m)
            }
        },
        Geometry::Triangles(mesh) => place(
            PlyMesh {
                positions: mesh.positions.clone(),
                normals: mesh.normals.clone(),
                uvs: mesh.uvs.clone(),
                triangles: mesh.indices.clone(),
                ..PlyMesh::default()
            },
            t,
            1.0,
            flip,
        ),
        Geometry::Quads(q) => place(
            PlyMesh {
                positions: q.positions.clone(),
                quads: q.indices.clone(),
                ..PlyMesh::default()
            },
            t,
            1.0,
            flip,
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(g: &[Geometry]) -> f32 {
        g.iter().map(Geometry::area).sum()
    }

    #[test]
    fn tessellations_approach_the_areas_and_face_out() {
        use std::f32::consts::PI;
        let s = place(sphere(2.0, -2.0, 2.0, 360.0), &DMat4::IDENTITY, 1.0, false);
        assert!((area(&s) / (16.0 * PI) - 1.0).abs() < 0.01, "{}", area(&s));
        for [a, b, c] in s[0].triangles() {
            assert!(
                (b - a).cross(c - a).dot(a + b + c) > 0.0,
                "sphere faces out"
            );
        }
        let d = place(disk(1.0, 1.0, 0.5, 360.0), &DMat4::IDENTITY, 1.0, false);
        assert!((area(&d) / (0.75 * PI) - 1.0).abs() < 0.01);
        for [a, b, c] in d[0].triangles() {
            assert!((b - a).cross(c - a).z > 0.0 && a.z == 1.0);
        }
        let c = place(cylinder(1.0, 0.0, 2.0, 180.0), &DMat4::IDENTITY, 1.0, false);
        assert!((area(&c) / (2.0 * PI) - 1.0).abs() < 0.01);
        // A negated normal sign turns the sphere inside out.
        let inward = place(sphere(1.0, -1.0, 1.0, 360.0), &DMat4::IDENTITY, -1.0, false);
        for [a, b, c] in inward[0].triangles() {
            assert!((b - a).cross(c - a).dot(a + b + c) < 0.0);
        }
    }

    #[test]
    fn mirrored_instances_keep_their_side() {
        let tri = Shape {
            media: None,
            geometry: Geometry::Triangles(crate::scene::TriangleMesh {
                positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
                indices: vec![[0, 1, 2]],
                ..Default::default()
            }),
            material: 0,
            alpha: None,
            motion: None,
        };
        // Mirror z: the triangle lies in z = 0 and faced +z; it must face -z now.
        let m = DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0));
        let out = instance(&tri, &m);
        let [a, b, c] = out[0].geometry.triangles()[0];
        assert!((b - a).cross(c - a).z < 0.0);
        assert!(uniform_scale(&DMat4::from_scale(DVec3::splat(-2.0))).is_some());
        assert!(uniform_scale(&DMat4::from_scale(DVec3::new(1.0, 2.0, 1.0))).is_none());
    }
}
