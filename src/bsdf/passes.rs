//! The BSDF split by kind of lobe, for the light passes a compositor reads (Blender
//! Cycles' diffuse, glossy and transmission passes): each lobe's colour, and how much of
//! f(wo, wi)·|cos θi| each kind of lobe gives. The kinds are [`DIFFUSE`] (Lambertian
//! reflection and diffuse transmission), [`GLOSSY`] (mirror and GGX reflection, a
//! conductor's, a dielectric's, a tabulated reflectance) and [`TRANSMISSION`] (smooth and
//! rough refraction, straight-on transmission through a thin sheet). A coat is not split:
//! a coated diffuse base counts as diffuse, a coated conductor as glossy, coat included.

use super::{Bsdf, BsdfSample, Transport};
use crate::math::{Rgb, Vec3};

/// The diffuse lobes.
pub const DIFFUSE: usize = 0;
/// The glossy and mirror reflection lobes.
pub const GLOSSY: usize = 1;
/// The refracting lobes.
pub const TRANSMISSION: usize = 2;

impl Bsdf<'_> {
    /// The one kind of lobe the whole BSDF counts as, when it is not split: a coat (over a
    /// diffuse base: diffuse; over a conductor: glossy) or a tabulated reflectance (glossy).
    fn single_kind(&self) -> Option<usize> {
        if self.coating.is_some() {
            return Some(if self.conductor.is_some() {
                GLOSSY
            } else {
                DIFFUSE
            });
        }
        self.table.is_some().then_some(GLOSSY)
    }

    /// The colour of each kind of lobe (the weights a compositor's colour passes hold):
    /// diffuse kd + kdt, glossy ks (a conductor's reflectance at normal incidence times
    /// ks; a table's largest reflectance), transmission kt. A coated BSDF's kind gets its
    /// base's colour.
    pub fn lobe_colours(&self) -> [Rgb; 3] {
        let glossy = match self.conductor {
            Some(c) => self.ks * c.reflectance(1.0),
            None => self.ks,
        };
        let mut colours = [self.kd + self.kdt, glossy, self.kt];
        if let Some(table) = self.table {
            colours = [Rgb::ZERO, table.most_reflected(), Rgb::ZERO];
        } else if let Some(kind) = self.single_kind() {
            let base = colours[kind];
            colours = [Rgb::ZERO; 3];
            colours[kind] = base;
        }
        colours
    }

    /// Each kind's share of [`Bsdf::eval`] for `wo`, `wi`, per channel (the shares sum to 1
    /// where `eval` is not zero, and are zero where it is).
    pub fn eval_shares(&self, wo: Vec3, wi: Vec3) -> [Rgb; 3] {
        if let Some(kind) = self.single_kind() {
            return one_kind(kind);
        }
        let Some((lo, li)) = self.connectable(wo, wi) else {
            return [Rgb::ZERO; 3];
        };
        let Some((diffuse, glossy, _, _)) = self.eval_lobes(wo, wi, lo, li, Transport::Radiance)
        else {
            return [Rgb::ZERO; 3];
        };
        let mut parts = [diffuse, Rgb::ZERO, Rgb::ZERO];
        parts[self.glossy_kind(wo, wi)] = glossy;
        shares(parts)
    }

    /// Each kind's share of the weight of a direction `s` that [`Bsdf::sample`] drew from
    /// `wo`: a delta direction belongs to the mirror (glossy) or the refraction
    /// (transmission); any other to the lobes that give f there, in proportion.
    pub fn sample_shares(&self, wo: Vec3, s: &BsdfSample) -> [Rgb; 3] {
        if let Some(kind) = self.single_kind() {
            return one_kind(kind);
        }
        if s.delta {
            return one_kind(self.glossy_kind(wo, s.wi));
        }
        self.eval_shares(wo, s.wi)
    }

    /// Glossy for a direction on `wo`'s side of the surface, transmission through it.
    fn glossy_kind(&self, wo: Vec3, wi: Vec3) -> usize {
        if wo.dot(self.ng) * wi.dot(self.ng) < 0.0 {
            TRANSMISSION
        } else {
            GLOSSY
        }
    }
}

/// All of it to one kind.
fn one_kind(kind: usize) -> [Rgb; 3] {
    let mut s = [Rgb::ZERO; 3];
    s[kind] = Rgb::ONE;
    s
}

/// `parts` as fractions of their sum, channel by channel (zero where the sum is).
fn shares(parts: [Rgb; 3]) -> [Rgb; 3] {
    let total = parts[0] + parts[1] + parts[2];
    let inv = |t: f32| if t > 0.0 { 1.0 / t } else { 0.0 };
    let scale = Rgb::new(inv(total.x), inv(total.y), inv(total.z));
    parts.map(|p| p * scale)
}
