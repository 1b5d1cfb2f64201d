//! The GGX (Trowbridge-Reitz) microfacet distribution with Smith shadowing, sampled by its
//! distribution of visible normals (Heitz 2018), isotropic or anisotropic with α_x along
//! the tangent and α_y along the bitangent (pbrt-v4's `TrowbridgeReitzDistribution`).
//! Directions are in the local frame (+z is the normal) and on the upper side.

use crate::math::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

#[derive(Clone, Copy, Debug)]
pub struct Ggx {
    pub alpha_x: f32,
    pub alpha_y: f32,
}

impl Ggx {
    pub fn isotropic(alpha: f32) -> Ggx {
        Ggx {
            alpha_x: alpha,
            alpha_y: alpha,
        }
    }

    /// Normal distribution D(h).
    pub fn d(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        if self.alpha_x != self.alpha_y {
            // 1 / (π αx αy (hx²/αx² + hy²/αy² + hz²)²).
            let (ax, ay) = (self.alpha_x, self.alpha_y);
            let k = h.x * h.x / (ax * ax) + h.y * h.y / (ay * ay) + h.z * h.z;
            return 1.0 / (PI * ax * ay * k * k);
        }
        let a2 = self.alpha_x * self.alpha_x;
        let k = h.z * h.z * (a2 - 1.0) + 1.0;
        a2 / (PI * k * k)
    }

    /// Smith's Λ(v).
    fn lambda(&self, v: Vec3) -> f32 {
        let cos2 = v.z * v.z;
        if cos2 <= 0.0 {
            return f32::INFINITY;
        }
        if self.alpha_x != self.alpha_y {
            // α² tan²θ with α² = cos²φ αx² + sin²φ αy².
            let (ax, ay) = (self.alpha_x, self.alpha_y);
            let a2_tan2 = (ax * ax * v.x * v.x + ay * ay * v.y * v.y) / cos2;
            return 0.5 * ((1.0 + a2_tan2).sqrt() - 1.0);
        }
        let tan2 = ((1.0 - cos2) / cos2).max(0.0);
        0.5 * ((1.0 + self.alpha_x * self.alpha_x * tan2).sqrt() - 1.0)
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
        let (ax, ay) = (self.alpha_x, self.alpha_y);
        let vh = Vec3::new(ax * wo.x, ay * wo.y, wo.z).normalize();
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
        Vec3::new(ax * nh.x, ay * nh.y, nh.z.max(1e-6)).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ f(h) dω over the upper hemisphere by the midpoint rule in (cos θ, φ).
    fn integrate(f: impl Fn(Vec3) -> f64) -> f64 {
        let n = 600;
        let mut sum = 0.0;
        for i in 0..n {
            // Denser near the pole, where narrow lobes live: z = 1 − t².
            let t = (i as f64 + 0.5) / n as f64;
            let z = 1.0 - t * t;
            let dz = 2.0 * t / n as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            for j in 0..n {
                let phi = std::f64::consts::TAU * (j as f64 + 0.5) / n as f64;
                let h = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                sum += f(h) * dz * std::f64::consts::TAU / n as f64;
            }
        }
        sum
    }

    /// D is a distribution of normals (∫ D cos θh dω = 1) and the visible normals of every
    /// direction integrate to 1 (Smith's G1 matches D), isotropic and anisotropic.
    #[test]
    fn distribution_and_visible_normals_are_normalised() {
        for ggx in [
            Ggx::isotropic(0.3),
            Ggx {
                alpha_x: 0.1,
                alpha_y: 0.5,
            },
        ] {
            let area = integrate(|h| (ggx.d(h) * h.z) as f64);
            assert!((area - 1.0).abs() < 5e-3, "{ggx:?}: ∫D cos = {area}");
            for wo in [Vec3::new(0.5, 0.2, 0.84), Vec3::new(-0.3, 0.9, 0.3)] {
                let wo = wo.normalize();
                let visible = integrate(|h| ggx.visible_pdf(wo, h) as f64);
                assert!((visible - 1.0).abs() < 5e-3, "{ggx:?} {wo}: {visible}");
            }
        }
    }
}
