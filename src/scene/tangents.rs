//! How a surface point moves and turns with its texture coordinates: ∂p/∂u, ∂p/∂v and
//! ∂n/∂u, ∂n/∂v, which normal maps and bump maps need to turn the shading normal (pbrt-v4
//! computes the same per shape).

use super::{Geometry, TriangleMesh};
use crate::math::{frame, Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// The partial derivatives of position and normal in (u, v) at a surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tangents {
    pub dpdu: Vec3,
    pub dpdv: Vec3,
    pub dndu: Vec3,
    pub dndv: Vec3,
}

impl Tangents {
    /// An arbitrary frame around unit normal `n`, for points whose parametrisation is
    /// degenerate (a sphere's pole, a triangle with repeated texture coordinates).
    fn around(n: Vec3) -> Tangents {
        let (t, b) = frame(n);
        Tangents {
            dpdu: t,
            dpdv: b,
            dndu: Vec3::ZERO,
            dndv: Vec3::ZERO,
        }
    }
}

impl Geometry {
    /// The derivatives at point `p` of primitive `prim`, hit at barycentric (`u`, `v`)
    /// (as [`crate::accel::Hit`] reports them), with unit geometric normal `ng`.
    pub fn tangents(&self, prim: usize, u: f32, v: f32, p: Vec3, ng: Vec3) -> Tangents {
        match self {
            Geometry::Sphere { center, radius } => sphere(p - *center, *radius, ng),
            Geometry::Triangles(mesh) => triangle(mesh, prim, ng),
            Geometry::Quads(q) => {
                // Embree's quad parametrisation: p0 the origin, p1 − p0 along u, p3 − p0
                // along v (bilinear across the quad).
                let [p0, p1, p2, p3] = q.quad(prim);
                let dpdu = (p1 - p0) * (1.0 - v) + (p2 - p3) * v;
                let dpdv = (p3 - p0) * (1.0 - u) + (p2 - p1) * u;
                if dpdu.cross(dpdv).length_squared() > 0.0 {
                    Tangents {
                        dpdu,
                        dpdv,
                        dndu: Vec3::ZERO,
                        dndv: Vec3::ZERO,
                    }
                } else {
                    Tangents::around(ng)
                }
            }
        }
    }
}

/// A sphere point `d` from the centre, with u = ½ + φ/2π, v = θ/π as
/// [`crate::accel::Hit::surface_point`] maps it (φ = atan2(z, x), θ from +y).
fn sphere(d: Vec3, radius: f32, ng: Vec3) -> Tangents {
    let rho = (d.x * d.x + d.z * d.z).sqrt();
    if rho <= 1e-6 * radius {
        return Tangents::around(ng);
    }
    let dpdu = Vec3::new(-d.z, 0.0, d.x) * TAU;
    let dpdv = Vec3::new(d.y * d.x / rho, -rho, d.y * d.z / rho) * PI;
    Tangents {
        dpdu,
        dpdv,
        dndu: dpdu / radius,
        dndv: dpdv / radius,
    }
}

fn triangle(mesh: &TriangleMesh, prim: usize, ng: Vec3) -> Tangents {
    let [a, b, c] = mesh.indices[prim].map(|i| i as usize);
    let [p0, p1, p2] = [a, b, c].map(|i| mesh.positions[i]);
    // Without texture coordinates, (u, v) are the barycentrics of vertices 1 and 2.
    let [uv0, uv1, uv2] = match &mesh.uvs {
        Some(t) => [t[a], t[b], t[c]],
        None => [Vec2::ZERO, Vec2::X, Vec2::Y],
    };
    let (duv02, duv12) = (uv0 - uv2, uv1 - uv2);
    let (dp02, dp12) = (p0 - p2, p1 - p2);
    let det = duv02.x * duv12.y - duv02.y * duv12.x;
    if det.abs() < 1e-12 {
        return Tangents::around(ng);
    }
    let inv = 1.0 / det;
    let dpdu = (dp02 * duv12.y - dp12 * duv02.y) * inv;
    let dpdv = (dp12 * duv02.x - dp02 * duv12.x) * inv;
    if !dpdu.cross(dpdv).is_finite() || dpdu.cross(dpdv).length_squared() == 0.0 {
        return Tangents::around(ng);
    }
    let (dndu, dndv) = match &mesh.normals {
        Some(n) => {
            let (dn02, dn12) = (n[a] - n[c], n[b] - n[c]);
            (
                (dn02 * duv12.y - dn12 * duv02.y) * inv,
                (dn12 * duv02.x - dn02 * duv12.x) * inv,
            )
        }
        None => (Vec3::ZERO, Vec3::ZERO),
    };
    Tangents {
        dpdu,
        dpdv,
        dndu,
        dndv,
    }
}
