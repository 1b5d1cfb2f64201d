//! The GGX (Trowbridge-Reitz) microfacet distribution with Smith shadowing, sampled by its
//! distribution of visible normals (Heitz 2018). Directions are in the local frame (+z is
//! the normal) and on the upper side.

use crate::math::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

#[derive(Clone, Copy, Debug)]
pub struct Ggx {
    pub alpha: f32,
}

impl Ggx {
    /// Normal distribution D(h).
    pub fn d(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let k = h.z * h.z * (a2 - 1.0) + 1.0;
        a2 / (PI * k * k)
    }

    /// Smith's Λ(v).
    fn lambda(&self, v: Vec3) -> f32 {
        let cos2 = v.z * v.z;
        if cos2 <= 0.0 {
            return f32::INFINITY;
        }
        let tan2 = ((1.0 - cos2) / cos2).max(0.0);
        0.5 * ((1.0 + self.alpha * self.alpha * tan2).sqrt() - 1.0)
    }

    pub fn g1(&self, v: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(v))
    }

    /// Height-correlated masking-shadowing G(wo, wi).
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Density of the visible normal `h` seen from `wo`: G1(wo) max(0, wo·h) D(h) / cos(wo).
    pub fn visible_pdf(&self, wo: Vec3, h: Vec3) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        self.g1(wo) * wo.dot(h).max(0.0) * self.d(h) / wo.z
    }

    /// A visible normal for `wo` (upper hemisphere).
    pub fn sample_visible(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let a = self.alpha;
        let vh = Vec3::new(a * wo.x, a * wo.y, wo.z).normalize();
        let len2 = vh.x * vh.x + vh.y * vh.y;
        let t1 = if len2 > 0.0 {
            Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt()
        } else {
            Vec3::X
        };
        let t2 = vh.cross(t1);
        let r = u.x.sqrt();
        let phi = TAU * u.y;
        let p1 = r * phi.cos();
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
        let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
        Vec3::new(a * nh.x, a * nh.y, nh.z.max(1e-6)).normalize()
    }
}
