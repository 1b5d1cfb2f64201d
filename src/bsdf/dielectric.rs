//! The rough dielectric interface: GGX microfacet reflection and refraction after Walter et
//! al. 2007, as pbrt-v4's `DielectricBxDF` does it. Each microfacet normal m reflects with
//! weight ks·F(wo·m) and refracts with weight kt·(1 − F(wo·m)) (F = 1 and 1 − F = 1 when
//! Fresnel is off); sampling picks a visible normal, then reflection or refraction in
//! proportion to those weights, so the transmission is a glossy lobe like the reflection.
//!
//! Directions are in the local frame with `lo` on the upper side (z > 0); `eta` is
//! n_wo / n_other, the ratio of the indices on `lo`'s side and on the other side.

use super::{Ggx, Transport};
use crate::math::optics::{fresnel_dielectric, refract};
use crate::math::{luminance, Rgb, Vec3};

/// The interface's lobes as one microfacet BSDF.
#[derive(Clone, Copy, Debug)]
pub(super) struct RoughInterface {
    pub ggx: Ggx,
    pub ks: Rgb,
    /// Zero when the transmission is not a microfacet lobe (none, or a smooth refraction).
    pub kt: Rgb,
    pub fresnel: bool,
    pub eta: f32,
}

impl RoughInterface {
    /// Fresnel reflectance at the microfacet with normal `h` (1 without Fresnel).
    fn fresnel_at(&self, lo: Vec3, h: Vec3) -> f32 {
        if self.fresnel {
            fresnel_dielectric(lo.dot(h), self.eta)
        } else {
            1.0
        }
    }

    /// The share of the transmission at a microfacet of reflectance `f`.
    fn transmitted(&self, f: f32) -> f32 {
        if self.fresnel {
            1.0 - f
        } else {
            1.0
        }
    }

    /// Probability of reflecting (rather than refracting) at the microfacet `h`; `None` when
    /// the microfacet neither reflects nor refracts.
    fn reflect_probability(&self, lo: Vec3, h: Vec3) -> Option<f32> {
        let f = self.fresnel_at(lo, h);
        let pr = luminance(self.ks) * f;
        let pt = luminance(self.kt) * self.transmitted(f);
        let total = pr + pt;
        (total > 0.0).then(|| pr / total)
    }

    /// The microfacet normal that takes `lo` to `li` (the generalised half vector, on the
    /// upper side), and whether `li` is transmitted; `None` for a backfacing microfacet.
    fn half_vector(&self, lo: Vec3, li: Vec3) -> Option<(Vec3, bool)> {
        let transmitted = li.z < 0.0;
        let etap = if transmitted { 1.0 / self.eta } else { 1.0 };
        let h = lo + li * etap;
        if lo.z == 0.0 || li.z == 0.0 || h.length_squared() == 0.0 {
            return None;
        }
        let h = h.normalize();
        let h = if h.z < 0.0 { -h } else { h };
        // Both directions must see the microfacet from the side they are on.
        if h.dot(li) * li.z <= 0.0 || h.dot(lo) <= 0.0 {
            return None;
        }
        Some((h, transmitted))
    }

    /// f(lo, li) (without the cosine): reflection when `li` is on `lo`'s side, refraction
    /// otherwise, with the (n_wo/n_other)² radiance scaling of refraction in radiance
    /// transport.
    pub fn eval(&self, lo: Vec3, li: Vec3, mode: Transport) -> Rgb {
        let Some((h, transmitted)) = self.half_vector(lo, li) else {
            return Rgb::ZERO;
        };
        let f = self.fresnel_at(lo, h);
        let dg = self.ggx.d(h) * self.ggx.g(lo, li);
        if !transmitted {
            return self.ks * (dg * f / (4.0 * lo.z * li.z));
        }
        if self.kt.max_element() <= 0.0 {
            return Rgb::ZERO;
        }
        let (hi, ho) = (li.dot(h), lo.dot(h));
        let denom = (hi + ho * self.eta) * (hi + ho * self.eta);
        let mut ft = dg * self.transmitted(f) * (hi * ho).abs() / (denom * lo.z * li.z.abs());
        if mode == Transport::Radiance {
            ft *= self.eta * self.eta;
        }
        self.kt * ft
    }

    /// Density (solid angle) of [`RoughInterface::sample`] producing `li`, times `weight`
    /// (the lobe's probability, multiplied first so that a reflection-only lobe rounds as
    /// plain GGX reflection does).
    pub fn pdf(&self, lo: Vec3, li: Vec3, weight: f32) -> f32 {
        let Some((h, transmitted)) = self.half_vector(lo, li) else {
            return 0.0;
        };
        let Some(pr) = self.reflect_probability(lo, h) else {
            return 0.0;
        };
        let visible = self.ggx.visible_pdf(lo, h);
        if !transmitted {
            return weight * pr * visible / (4.0 * lo.dot(h));
        }
        let (hi, ho) = (li.dot(h), lo.dot(h));
        let denom = (hi + ho * self.eta) * (hi + ho * self.eta);
        weight * (1.0 - pr) * visible * hi.abs() / denom
    }

    /// A direction from `lo`: a visible microfacet normal from `u`, then reflection or
    /// refraction through it chosen by `u_choice`.
    pub fn sample(&self, lo: Vec3, u_choice: f32, u: crate::math::Vec2) -> Option<Vec3> {
        let h = self.ggx.sample_visible(lo, u);
        let pr = self.reflect_probability(lo, h)?;
        if u_choice < pr || pr == 1.0 {
            let li = 2.0 * lo.dot(h) * h - lo;
            (li.z > 0.0).then_some(li)
        } else {
            let li = refract(-lo, h, self.eta)?;
            (li.z < 0.0).then_some(li)
        }
    }
}
