//! Mixed materials (pbrt-v4's `MixMaterial`): at each hit one of two materials is chosen,
//! the second with probability `amount`, by a hash of the hit point and the direction the
//! ray arrived from. The choice is a function of the scene alone (no random stream, no
//! thread), so images stay the same for any thread count, and on average over the hits
//! the surface scatters as the blend (1 − amount)·f₀ + amount·f₁.
//!
//! The choice is made where a ray's hit becomes a surface point
//! ([`crate::transport::Context::intersect`]), so every integrator that follows rays
//! sees one plain material. Asked directly, a mix answers as its material with the larger
//! weight; the illumination network, which reads a shape's material without a ray, blends
//! the two materials' reflectance instead.

use super::{Classic, Material, Surface, SurfaceModel};
use crate::bsdf::{Bsdf, TabulatedBrdf};
use crate::math::{Vec2, Vec3};
use crate::scene::{Scene, SurfacePoint, Texture};
use std::sync::Arc;

/// Nested mixes deeper than this resolve to the material reached (a guard against a cycle,
/// which the readers do not build).
const MAX_NESTING: usize = 16;

/// The two materials of a mix, as indices into the scene's materials, and the probability
/// of choosing the second.
#[derive(Clone, Debug, PartialEq)]
pub struct Mix {
    pub materials: [usize; 2],
    /// The probability; with `amount_map`, the map's mean (for the illumination network).
    pub amount: f32,
    /// A probability varying over the surface (a float texture), in place of `amount`.
    pub amount_map: Option<Arc<Texture>>,
    /// The surface of the material with the larger weight (the first when equal), which
    /// the mix answers as when asked directly.
    pub dominant: Box<Surface>,
}

impl SurfaceModel for Mix {
    fn kind(&self) -> &'static str {
        "mix"
    }

    fn bsdf<'a>(&'a self, sp: &SurfacePoint, wo: Vec3) -> Bsdf<'a> {
        self.dominant.model().bsdf(sp, wo)
    }

    fn approximation(&self) -> &Classic {
        self.dominant.model().approximation()
    }

    fn diffuse_mut(&mut self) -> Option<&mut Texture> {
        None
    }

    fn table(&self) -> Option<&Arc<TabulatedBrdf>> {
        self.dominant.model().table()
    }
}

impl Mix {
    /// The material chosen at point `p` with surface coordinates `uv` and geometric normal
    /// `n`, for a ray arriving from direction `wo` (pointing away from the surface).
    pub fn choose(&self, p: Vec3, uv: Vec2, n: Vec3, wo: Vec3) -> usize {
        let amount = match &self.amount_map {
            Some(t) => t.eval_float(p, uv, n),
            None => self.amount,
        };
        if amount <= 0.0 {
            return self.materials[0];
        }
        if amount >= 1.0 {
            return self.materials[1];
        }
        let key = [p.x, p.y, p.z, wo.x, wo.y, wo.z].map(|v| u64::from(v.to_bits()));
        let u = hash_to_unit(&key, self.materials);
        self.materials[usize::from(u < amount)]
    }
}

/// A uniform number in [0, 1) from the bits of `key` and the mix's materials (so nested
/// mixes choose independently).
fn hash_to_unit(key: &[u64; 6], materials: [usize; 2]) -> f32 {
    let mut h = 0x243f_6a88_85a3_08d3u64 ^ materials[0] as u64 ^ ((materials[1] as u64) << 32);
    for &k in key {
        h = splitmix(h ^ k.wrapping_mul(0x9e37_79b9_7f4a_7c15));
    }
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

/// SplitMix64's finaliser.
fn splitmix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl Material {
    /// The mix of materials `a` and `b` (indices and values) named `name`: it chooses `b`
    /// with probability `amount`. Its own fields are those of the material with the larger
    /// weight (the first when equal), for the techniques that read them directly, and its
    /// emission is the two materials' (which must be the same: a light's shapes emit alike).
    /// A varying `amount` is chosen by at each hit; its mean decides the larger weight.
    pub fn mix_of(
        name: String,
        a: (usize, &Material),
        b: (usize, &Material),
        amount: Texture,
    ) -> Material {
        let (mean, amount_map) = match amount {
            Texture::Constant(c) => (c.x, None),
            t => (t.mean_value().x, Some(Arc::new(t))),
        };
        let mean = mean.clamp(0.0, 1.0);
        let dominant = if mean > 0.5 { b.1 } else { a.1 };
        let dominant_surface = match &dominant.surface {
            Surface::Mix(m) => m.dominant.clone(),
            other => Box::new(other.clone()),
        };
        Material {
            name,
            surface: Surface::Mix(Mix {
                materials: [a.0, b.0],
                amount: mean,
                amount_map,
                dominant: dominant_surface,
            }),
            ..dominant.clone()
        }
    }
}

impl Scene {
    /// The plain material that scatters at point `p` (surface coordinates `uv`, geometric
    /// normal `n`) of a shape of material `index`, for a ray arriving from `wo`: `index`
    /// itself unless it is a mix.
    pub fn material_at(&self, mut index: usize, p: Vec3, uv: Vec2, n: Vec3, wo: Vec3) -> usize {
        for _ in 0..MAX_NESTING {
            match self.materials[index].mix() {
                Some(mix) => index = mix.choose(p, uv, n, wo),
                None => break,
            }
        }
        index
    }

    /// Whether material `index` transmits light, for a mix whether any of its materials
    /// may.
    pub fn may_transmit(&self, index: usize) -> bool {
        self.may_transmit_nested(index, MAX_NESTING)
    }

    fn may_transmit_nested(&self, index: usize, depth: usize) -> bool {
        let m = &self.materials[index];
        match m.mix() {
            Some(mix) if depth > 0 => mix
                .materials
                .iter()
                .any(|&i| self.may_transmit_nested(i, depth - 1)),
            _ => m.is_transmissive(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    /// Over many hits the second material's share is `amount` (within 5 binomial standard
    /// errors), and the choice is the same for the same hit and direction.
    #[test]
    fn the_second_material_is_chosen_with_probability_amount() {
        let mut rng = Rng::for_key(1, &[]);
        for amount in [0.1f32, 0.3, 0.5, 0.9] {
            let mix = Mix {
                materials: [3, 7],
                amount,
                amount_map: None,
                dominant: Box::new(Surface::Classic(Classic::default())),
            };
            let n = 100_000;
            let mut second = 0;
            for _ in 0..n {
                let p = Vec3::new(rng.uniform(), rng.uniform(), 0.0) * 10.0;
                let wo = Vec3::new(rng.uniform() - 0.5, 0.3, 1.0).normalize();
                let c = mix.choose(p, Vec2::ZERO, Vec3::Z, wo);
                assert_eq!(c, mix.choose(p, Vec2::ZERO, Vec3::Z, wo));
                second += usize::from(c == 7);
            }
            let share = second as f64 / n as f64;
            let se = (amount as f64 * (1.0 - amount as f64) / n as f64).sqrt();
            assert!(
                (share - amount as f64).abs() < 5.0 * se,
                "{share} vs {amount}"
            );
        }
        let never = Mix {
            materials: [3, 7],
            amount: 0.0,
            amount_map: None,
            dominant: Box::new(Surface::Classic(Classic::default())),
        };
        assert_eq!(never.choose(Vec3::ONE, Vec2::ZERO, Vec3::Z, Vec3::Z), 3);
    }
}
