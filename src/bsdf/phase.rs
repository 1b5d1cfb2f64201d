//! The Henyey–Greenstein phase function: how a medium (a participating medium of the scene,
//! or the one between a coat and its base) scatters light by the angle between the
//! directions. One parameter, the mean cosine g: 0 scatters evenly, g > 0 forward.

use crate::math::{frame, Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, TAU};

/// The Henyey–Greenstein phase function for the angle between `wo` and `wi`, both pointing
/// away from the scattering point (pbrt-v4's convention: g > 0 scatters forward, wi ≈ −wo).
pub fn hg(wo: Vec3, wi: Vec3, g: f32) -> f32 {
    let denom = 1.0 + g * g + 2.0 * g * wo.dot(wi);
    0.25 * FRAC_1_PI * (1.0 - g * g) / (denom * denom.max(0.0).sqrt())
}

/// A direction from the Henyey–Greenstein phase function around `wo` and its density.
pub fn sample_hg(wo: Vec3, g: f32, u: Vec2) -> (Vec3, f32) {
    let cos = if g.abs() < 1e-3 {
        1.0 - 2.0 * u.x
    } else {
        let s = (1.0 - g * g) / (1.0 + g - 2.0 * g * u.x);
        -(1.0 + g * g - s * s) / (2.0 * g)
    };
    let cos = cos.clamp(-1.0, 1.0);
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = TAU * u.y;
    let (t, b) = frame(wo);
    let wi = t * (sin * phi.cos()) + b * (sin * phi.sin()) + wo * cos;
    (wi, hg(wo, wi, g))
}
