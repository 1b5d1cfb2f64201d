//! A sphere: a centre and a radius. The backends intersect it natively (Embree's sphere
//! point, the BVH's own test); light sampling draws from the cone it subtends.

use super::{Geometry, Primitives, ShapeModel, Tangents, UvMap};
use crate::math::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
}

impl ShapeModel for Sphere {
    #[inline]
    fn primitives(&self) -> Primitives<'_> {
        Primitives::Sphere {
            center: self.center,
            radius: self.radius,
        }
    }

    fn bounds(&self) -> (Vec3, Vec3) {
        (self.center - self.radius, self.center + self.radius)
    }

    fn area(&self) -> f32 {
        4.0 * PI * self.radius * self.radius
    }

    fn primitive_count(&self) -> usize {
        1
    }

    fn triangles(&self) -> Vec<[Vec3; 3]> {
        Vec::new()
    }

    fn uv_maps(&self) -> Vec<UvMap> {
        Vec::new()
    }

    #[inline]
    fn hit_uv(&self, _prim_id: u32, _u: f32, _v: f32, p: Vec3) -> Vec2 {
        sphere_uv((p - self.center).normalize())
    }

    fn tangents(&self, _prim: usize, _u: f32, _v: f32, p: Vec3, ng: Vec3) -> Tangents {
        tangents_at(p - self.center, self.radius, ng)
    }

    fn same_topology(&self, end: &Geometry) -> bool {
        matches!(end, Geometry::Sphere(_))
    }
}

/// The uv of a point on a sphere whose outward unit normal is `n`.
pub fn sphere_uv(n: Vec3) -> Vec2 {
    Vec2::new(
        0.5 + n.z.atan2(n.x) / std::f32::consts::TAU,
        n.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI,
    )
}

/// A sphere point `d` from the centre, with u = ½ + φ/2π, v = θ/π as
/// [`crate::accel::Hit::surface_point`] maps it (φ = atan2(z, x), θ from +y).
fn tangents_at(d: Vec3, radius: f32, ng: Vec3) -> Tangents {
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
