//! Deterministic random streams. A stream is a pure function of a key such as
//! (seed, pixel, sample), never of the thread that draws from it, so renders are the same for
//! any thread count or tile order. PCG32 (O'Neill 2014) is small and fixed here on purpose:
//! general-purpose RNG crates do not promise the same sequence across their versions.

/// PCG32 (XSH RR) generator.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
}

const MULTIPLIER: u64 = 6364136223846793005;

/// SplitMix64's finaliser: spreads nearby keys over the whole 64-bit range.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
    z ^ (z >> 31)
}

impl Rng {
    /// The stream for a key: each distinct key gives an independent-looking stream.
    pub fn for_key(seed: u64, key: &[u64]) -> Self {
        let mut h = mix(seed ^ 0x9e3779b97f4a7c15);
        for &k in key {
            h = mix(h ^ k.wrapping_mul(0x9e3779b97f4a7c15));
        }
        let mut rng = Rng {
            state: 0,
            inc: (mix(h ^ 0xda3e39cb94b95bdb) << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(h);
        rng.next_u32();
        rng
    }

    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(MULTIPLIER).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f32 {
        // 24 random mantissa bits: exactly representable, never 1.0.
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// A standard normal deviate (Box-Muller).
    pub fn normal(&mut self) -> f32 {
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u32> = (0..8)
            .scan(Rng::for_key(7, &[1, 2]), |r, _| Some(r.next_u32()))
            .collect();
        let b: Vec<u32> = (0..8)
            .scan(Rng::for_key(7, &[1, 2]), |r, _| Some(r.next_u32()))
            .collect();
        let c: Vec<u32> = (0..8)
            .scan(Rng::for_key(7, &[2, 1]), |r, _| Some(r.next_u32()))
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn uniform_mean_is_one_half() {
        let mut rng = Rng::for_key(1, &[]);
        let n = 100_000;
        let mean: f64 = (0..n).map(|_| rng.uniform() as f64).sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 0.005, "mean {mean}");
    }
}
