//! Low-discrepancy sample values: the first two dimensions of the Sobol sequence (a
//! (0,2)-sequence), shuffled and Owen-scrambled per pixel and per dimension pair with
//! Burley's hash-based scrambling ("Practical Hash-based Owen Scrambling", JCGT 2020). This is
//! pbrt-v4's padded Sobol sampler: every pair of dimensions of a path is well stratified over
//! a pixel's samples, at any sample count (best at powers of two), and the value depends only
//! on (seed, pixel, sample index, dimension), never on threads or timing.

use super::Vec2;

/// Sample values for one pixel sample: dimension pairs are consumed in order.
#[derive(Clone, Debug)]
pub struct Sampler {
    key: u64,
    index: u32,
    /// `index` with its bits reversed: the first step of every dimension pair's shuffle.
    index_reversed: u32,
    dimension: u32,
}

fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
    z ^ (z >> 31)
}

/// Laine-Karras style permutation: an Owen scramble of bit-reversed input.
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50b47c);
    x ^= x.wrapping_mul(0xb82f1e52);
    x ^= x.wrapping_mul(0xc7afe638);
    x ^= x.wrapping_mul(0x8d22f6e6);
    x
}

/// Sobol's second dimension (primitive polynomial x + 1), by the direction number of each
/// index bit.
const fn sobol_dim1_bits(mut index: u32, first_bit: u32) -> u32 {
    let mut v = 1u32 << 31;
    let mut k = 0;
    while k < first_bit {
        v ^= v >> 1;
        k += 1;
    }
    let mut x = 0;
    while index != 0 {
        if index & 1 != 0 {
            x ^= v;
        }
        index >>= 1;
        v ^= v >> 1;
    }
    x
}

/// The second dimension is linear over GF(2) in the index bits: the value is the XOR of
/// one table entry per index byte (a shuffled index has all 32 bits set at random, so a
/// bit-by-bit loop would take 32 steps). The entries are stored bit-reversed, since the
/// scramble that follows works on the reversed value.
const SOBOL_DIM1_REVERSED: [[u32; 256]; 4] = {
    let mut t = [[0u32; 256]; 4];
    let mut byte = 0;
    while byte < 4 {
        let mut b = 0;
        while b < 256 {
            t[byte][b] = sobol_dim1_bits(b as u32, 8 * byte as u32).reverse_bits();
            b += 1;
        }
        byte += 1;
    }
    t
};

/// Sobol's second dimension of `index`, bit-reversed.
fn sobol_dim1_reversed(index: u32) -> u32 {
    let t = &SOBOL_DIM1_REVERSED;
    t[0][(index & 0xff) as usize]
        ^ t[1][((index >> 8) & 0xff) as usize]
        ^ t[2][((index >> 16) & 0xff) as usize]
        ^ t[3][(index >> 24) as usize]
}

/// Dimension pairs drawn from the scrambled Sobol sequence (the pixel filter and the first
/// three bounces of a path); later pairs are independent hashed values.
pub(crate) const SOBOL_PAIRS: u32 = 10;

const TO_UNIT: f32 = 1.0 / 4294967296.0;
/// The largest f32 below one.
pub(crate) const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

impl Sampler {
    /// The sampler for sample `index` of a pixel identified by `pixel_key` (e.g. derived from
    /// seed, pixel and frame).
    pub fn new(seed: u64, pixel_key: &[u64], index: u32) -> Self {
        let mut h = mix64(seed ^ 0x517c_c1b7_2722_0a95);
        for &k in pixel_key {
            h = mix64(h ^ k.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        }
        Sampler {
            key: h,
            index,
            index_reversed: index.reverse_bits(),
            dimension: 0,
        }
    }

    /// An independent stream for a step of a path that draws a varying number of values
    /// (free flights through a medium), keyed by this sample and the dimension it uses up.
    pub fn stream(&mut self) -> super::Rng {
        let rng = super::Rng::for_key(self.key, &[self.index as u64, self.dimension as u64]);
        self.dimension += 1;
        rng
    }

    /// The next pair of dimensions.
    pub fn next_2d(&mut self) -> Vec2 {
        let h = mix64(self.key ^ (self.dimension as u64).wrapping_mul(0xd1b5_4a32_d192_ed03));
        self.dimension += 1;
        if self.dimension > SOBOL_PAIRS {
            // Deep in a path, stratification no longer pays for its cost: hashed values.
            let r = mix64(h ^ (self.index as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
            return Vec2::new(
                ((r >> 40) as f32 * (1.0 / (1u32 << 24) as f32)).min(ONE_MINUS_EPSILON),
                (((r >> 8) & 0xff_ffff) as f32 * (1.0 / (1u32 << 24) as f32))
                    .min(ONE_MINUS_EPSILON),
            );
        }
        // Shuffle the index (a nested uniform scramble), then scramble both coordinates.
        // Each scramble is reverse(LK(reverse(v))): the reversals that cancel are left out
        // (Sobol's first dimension is the reversed index itself), which keeps every value.
        let index = laine_karras(self.index_reversed, h as u32).reverse_bits();
        let x = laine_karras(index, (h >> 32) as u32).reverse_bits();
        let y =
            laine_karras(sobol_dim1_reversed(index), (h >> 16) as u32 ^ 0x9e37_79b9).reverse_bits();
        Vec2::new(
            (x as f32 * TO_UNIT).min(ONE_MINUS_EPSILON),
            (y as f32 * TO_UNIT).min(ONE_MINUS_EPSILON),
        )
    }

    /// One more dimension (uses a whole pair: simple, and keeps dimensions aligned).
    pub(crate) fn next_1d(&mut self) -> f32 {
        self.next_2d().x
    }

    /// The shutter time of this sample, in \[0, 1): a stratified value from a stream of its
    /// own, so drawing it leaves the other dimensions (and still scenes' images) as they were.
    pub(crate) fn shutter_time(&self) -> f32 {
        let mut own = Sampler {
            key: mix64(self.key ^ 0x7133_5a11_c0de_d1e5),
            dimension: 0,
            ..self.clone()
        };
        own.next_1d()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_matches_the_bitwise_definition() {
        let mut rng = crate::math::Rng::for_key(2, &[]);
        for _ in 0..10_000 {
            let i = rng.next_u32();
            assert_eq!(sobol_dim1_reversed(i), sobol_dim1_bits(i, 0).reverse_bits());
        }
    }

    /// pbrt-v4's padded Sobol value written out as the paper defines it (every nested
    /// uniform scramble as reverse, Laine-Karras, reverse), for the dimension pairs that
    /// are not hashed.
    fn defined_value(sampler: &Sampler, dimension: u32) -> Vec2 {
        let nested = |x: u32, seed: u32| laine_karras(x.reverse_bits(), seed).reverse_bits();
        let h = mix64(sampler.key ^ (dimension as u64).wrapping_mul(0xd1b5_4a32_d192_ed03));
        let index = nested(sampler.index, h as u32);
        let x = nested(index.reverse_bits(), (h >> 32) as u32);
        let y = nested(sobol_dim1_bits(index, 0), (h >> 16) as u32 ^ 0x9e37_79b9);
        Vec2::new(
            (x as f32 * TO_UNIT).min(ONE_MINUS_EPSILON),
            (y as f32 * TO_UNIT).min(ONE_MINUS_EPSILON),
        )
    }

    #[test]
    fn values_are_the_defined_scrambles() {
        let mut rng = crate::math::Rng::for_key(5, &[]);
        for _ in 0..2_000 {
            let mut s = Sampler::new(
                rng.next_u32() as u64,
                &[rng.next_u32() as u64],
                rng.next_u32(),
            );
            let start = s.clone();
            for d in 0..SOBOL_PAIRS {
                let v = s.next_2d();
                let want = defined_value(&start, d);
                assert_eq!(
                    (v.x.to_bits(), v.y.to_bits()),
                    (want.x.to_bits(), want.y.to_bits())
                );
            }
        }
    }

    /// 64 samples of any dimension pair fill the 8x8 strata of the square exactly once
    /// (Owen scrambling of a (0,2)-sequence keeps it a (0,m,2)-net).
    #[test]
    fn every_pair_is_stratified() {
        for pixel in 0..4u64 {
            for dim in 0..SOBOL_PAIRS {
                let mut seen = [false; 64];
                for i in 0..64 {
                    let mut s = Sampler::new(3, &[pixel], i);
                    for _ in 0..dim {
                        s.next_2d();
                    }
                    let u = s.next_2d();
                    assert!((0.0..1.0).contains(&u.x) && (0.0..1.0).contains(&u.y));
                    let cell = (u.x * 8.0) as usize + 8 * (u.y * 8.0) as usize;
                    assert!(!seen[cell], "pixel {pixel} dim {dim}: stratum hit twice");
                    seen[cell] = true;
                    // Elementary intervals 64x1 and 1x64 too.
                }
                let mut xs = [false; 64];
                for i in 0..64 {
                    let mut s = Sampler::new(3, &[pixel], i);
                    for _ in 0..dim {
                        s.next_2d();
                    }
                    let u = s.next_2d();
                    let c = (u.x * 64.0) as usize;
                    assert!(!xs[c]);
                    xs[c] = true;
                }
            }
        }
    }

    /// Different pixels and dimensions are decorrelated: their means are 1/2 and their
    /// products average 1/4.
    #[test]
    fn pixels_and_dimensions_are_decorrelated() {
        let n = 20_000;
        let mut prod = 0.0f64;
        for p in 0..n {
            let mut a = Sampler::new(9, &[p], 0);
            let u = a.next_2d();
            let v = a.next_2d();
            prod += (u.x * v.y) as f64;
        }
        assert!((prod / n as f64 - 0.25).abs() < 0.01);
    }
}
