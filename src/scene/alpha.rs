//! Alpha cut-outs, as pbrt-v4 has them: a shape's alpha says where the surface is present.
//! Where alpha is 0 a ray passes through, where it is 1 it stops; in between, a ray passes
//! with probability 1 − alpha, decided by a hash of the ray and the primitive, so that the
//! same ray always gets the same answer (renders stay a function of scene, settings and
//! seed, whatever the thread count).

use super::texture::ImageTexture;
use crate::math::{Vec2, Vec3};
use std::sync::Arc;

/// A shape's alpha: a constant, or an image's first channel looked up by the hit's uv.
#[derive(Clone, Debug, PartialEq)]
pub enum Alpha {
    Constant(f32),
    /// pbrt-v4's float image texture: the first (red) channel of the decoded image.
    Image(Arc<ImageTexture>),
}

impl Alpha {
    /// The alpha at surface coordinates `uv`.
    pub fn value(&self, uv: Vec2) -> f32 {
        match self {
            Alpha::Constant(a) => *a,
            Alpha::Image(image) => image.eval(uv).x,
        }
    }

    /// Whether a hit at `uv` on primitive `prim_id` of shape `geom_id` stops a ray from
    /// `origin` along `dir`. pbrt-v4 draws its stochastic test from a hash of the ray it
    /// traces again after every skipped hit; the primitive stands in for that new ray here,
    /// so that two overlapping half-transparent layers each let half through.
    pub(crate) fn keeps_hit(
        &self,
        uv: Vec2,
        origin: Vec3,
        dir: Vec3,
        geom_id: u32,
        prim_id: u32,
    ) -> bool {
        let a = self.value(uv);
        // NaN counts as opaque, as in pbrt (`a < 1` is false).
        if a >= 1.0 || a.is_nan() {
            return true;
        }
        if a <= 0.0 {
            return false;
        }
        hash_float(origin, dir, geom_id, prim_id) <= a
    }
}

/// A number in [0, 1) from the bits of a ray and a primitive: splitmix64's finaliser folded
/// over the words.
fn hash_float(origin: Vec3, dir: Vec3, geom_id: u32, prim_id: u32) -> f32 {
    let words = [
        origin.x.to_bits(),
        origin.y.to_bits(),
        origin.z.to_bits(),
        dir.x.to_bits(),
        dir.y.to_bits(),
        dir.z.to_bits(),
        geom_id,
        prim_id,
    ];
    let mix = |mut z: u64| {
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    let h = words.iter().fold(0x9e37_79b9_7f4a_7c15_u64, |h, &w| {
        mix(h.wrapping_add(w as u64).wrapping_add(0x9e37_79b9_7f4a_7c15))
    });
    // The top 24 bits: exact in an f32, strictly below 1.
    (h >> 40) as f32 * (1.0 / (1u32 << 24) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_and_one_are_exact_and_half_keeps_half() {
        let dir = Vec3::new(0.3, -1.0, 0.2);
        let (mut kept, n) = (0, 100_000);
        for i in 0..n {
            let origin = Vec3::new(i as f32 * 1e-3, 2.0, (i % 37) as f32);
            assert!(!Alpha::Constant(0.0).keeps_hit(Vec2::ZERO, origin, dir, 0, 0));
            assert!(Alpha::Constant(1.0).keeps_hit(Vec2::ZERO, origin, dir, 0, 0));
            kept += Alpha::Constant(0.5).keeps_hit(Vec2::ZERO, origin, dir, 3, 7) as usize;
        }
        // Binomial: sigma = sqrt(n / 4) ≈ 158; five sigma.
        assert!(
            (kept as f64 - n as f64 / 2.0).abs() < 800.0,
            "{kept} of {n}"
        );
    }

    #[test]
    fn the_test_is_a_function_of_ray_and_primitive() {
        let (o, d) = (Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.0, 0.0, -1.0));
        let a = Alpha::Constant(0.5);
        let first = a.keeps_hit(Vec2::ZERO, o, d, 1, 2);
        assert!((0..10).all(|_| a.keeps_hit(Vec2::ZERO, o, d, 1, 2) == first));
        let differs = (0..64).any(|p| a.keeps_hit(Vec2::ZERO, o, d, 1, p) != first);
        assert!(differs, "the primitive enters the hash");
    }
}
