//! Irradiance gradients (Ward & Heckbert, "Irradiance Gradients", 1992), computed from the
//! same stratified hemisphere samples as the primary value at no extra rays: how E changes
//! as the point moves (translation) and as its normal turns (rotation). Interpolation then
//! extrapolates each cached value to the point, E_i + (n_i × n)·∇_r + (P − P_i)·∇_t, which
//! follows smooth irradiance fields far better than the plain weighted average, so the
//! same error takes fewer values.

use crate::math::{Rgb, Vec3};
use std::f32::consts::PI;

/// The gradients of one value, per colour channel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Gradients {
    /// ∂E/∂P: change per unit of distance along each world axis.
    pub translation: [Vec3; 3],
    /// Change per radian of rotation of the normal about each world axis.
    pub rotation: [Vec3; 3],
}

/// One hemisphere sample of the primary method: stratum (j in θ, k in φ), direction, the
/// radiance found along it and the distance to what it hit (infinite for none).
#[derive(Clone, Copy, Debug)]
pub struct HemisphereSample {
    pub dir: Vec3,
    pub cos_theta: f32,
    pub radiance: Rgb,
    pub distance: f32,
}

impl Gradients {
    /// The change of E from the value at (`p_i`, `n_i`) to (`p`, `n`), to first order.
    pub fn change(&self, p_i: Vec3, n_i: Vec3, p: Vec3, n: Vec3) -> Rgb {
        let (dp, turn) = (p - p_i, n_i.cross(n));
        Rgb::new(
            dp.dot(self.translation[0]) + turn.dot(self.rotation[0]),
            dp.dot(self.translation[1]) + turn.dot(self.rotation[1]),
            dp.dot(self.translation[2]) + turn.dot(self.rotation[2]),
        )
    }

    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        self.translation
            .iter()
            .chain(&self.rotation)
            .all(|v| v.is_finite())
    }

    /// The gradients from the `m`×`n` samples of a primary value at a point with normal
    /// `normal` and tangent frame (`t`, `b`), stored row by row (`samples[j * n + k]`: j-th
    /// stratum in sin²θ, k-th in φ = 2π(k + ξ)/n from `t` towards `b`).
    pub fn from_samples(
        samples: &[HemisphereSample],
        m: usize,
        n: usize,
        normal: Vec3,
        (t, b): (Vec3, Vec3),
    ) -> Gradients {
        debug_assert_eq!(samples.len(), m * n);
        let mut g = Gradients::default();
        let add = |to: &mut [Vec3; 3], dir: Vec3, value: Rgb| {
            for (c, v) in to.iter_mut().enumerate() {
                *v += dir * value[c];
            }
        };
        // Rotation: ∇_r E = ∫ L(ω) (n × ω) dω, estimated with the cosine-distributed samples
        // (density cos θ/π): π/(mn) Σ L (n × ω)/cos θ.
        let scale = PI / (m * n) as f32;
        for s in samples {
            if s.cos_theta > 1e-4 && s.radiance != Rgb::ZERO {
                add(
                    &mut g.rotation,
                    normal.cross(s.dir) * (scale / s.cos_theta),
                    s.radiance,
                );
            }
        }
        // Translation: moving the point moves the walls between neighbouring strata across
        // what they see, at a rate inversely proportional to the distance of the nearer of
        // the two (Ward & Heckbert's eq. for ∇_t), over the θ walls and the φ walls.
        let at = |j: usize, k: usize| &samples[j * n + k];
        let inv_min = |a: &HemisphereSample, b: &HemisphereSample| 1.0 / a.distance.min(b.distance);
        let azimuth = |phi: f32| t * phi.cos() + b * phi.sin();
        let dphi = 2.0 * PI / n as f32;
        for k in 0..n {
            // The θ walls of column k face its middle azimuth.
            let u_k = azimuth(dphi * (k as f32 + 0.5));
            let mut theta_walls = Rgb::ZERO;
            for j in 1..m {
                let (sin2, (lo, hi)) = (j as f32 / m as f32, (at(j - 1, k), at(j, k)));
                let w = sin2.sqrt() * (1.0 - sin2) * inv_min(lo, hi);
                theta_walls += (hi.radiance - lo.radiance) * w;
            }
            add(&mut g.translation, u_k * dphi, theta_walls);
            // The φ wall between columns k − 1 and k, across its azimuth.
            let v_k = azimuth(dphi * k as f32 + PI * 0.5);
            let prev = (k + n - 1) % n;
            let mut phi_walls = Rgb::ZERO;
            for j in 0..m {
                let s_minus = (j as f32 / m as f32).sqrt();
                let s_plus = ((j + 1) as f32 / m as f32).sqrt();
                let (a, c) = (at(j, prev), at(j, k));
                phi_walls += (c.radiance - a.radiance) * ((s_plus - s_minus) * inv_min(a, c));
            }
            add(&mut g.translation, v_k, phi_walls);
        }
        g
    }
}
