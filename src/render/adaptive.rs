//! Adaptive sampling: each pixel's own statistics (its sample count and the sums of its
//! samples' squares beside the film's sums), an error estimate from them, and the rule that
//! stops a pixel. The same statistics, without the rule, give the variance and error layers
//! of a render sampled uniformly (kept when the job asks for them); when samples are splatted
//! over neighbouring pixels they keep the sums of each pixel's own samples too, as the
//! film's sums then mix neighbours. The error is Cycles' noise measure, the absolute error of the pixel's
//! mean summed over the channels over the square root of its summed value, here estimated
//! from the samples' variance rather than from a buffer of half the samples (the same
//! quantity in expectation, with less noise of its own). Pixels are stopped only between
//! passes, from the film as it stands, so the image is the same for any thread count,
//! tile order or resume.

use crate::math::Rgb;
use crate::transport::settings::AdaptiveSampling;

/// sqrt(2/π): the mean absolute value of a standard normal variable. An estimate of a
/// mean's standard error times this is what Cycles' half-buffer difference averages.
const MEAN_ABSOLUTE_NORMAL: f64 = 0.797_884_560_802_865_4;

/// A checkpoint's statistics: sample counts, sums of squares, which pixels go on, and the
/// sums of each pixel's own samples (empty when the film's sums are those).
pub(crate) type SavedStats = (Vec<u32>, Vec<[f64; 3]>, Vec<bool>, Vec<[f64; 3]>);

/// Per-pixel statistics of a film: of an adaptively sampled one, or of one that keeps them
/// for the variance and error layers.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PixelStats {
    /// Adaptive sampling's rule; `None`: every pixel takes every pass's samples.
    pub rule: Option<AdaptiveSampling>,
    /// Samples taken in each pixel (row-major).
    pub counts: Vec<u32>,
    /// Per pixel and channel: the sum of the squares of its samples' values.
    pub squares: Vec<[f64; 3]>,
    /// Whether each pixel takes the next pass's samples.
    pub active: Vec<bool>,
    /// Per pixel and channel: the sum of its own samples' values, when samples are
    /// splatted (the film's sums then mix neighbours); empty when each sample counts in its
    /// own pixel alone and the film's sums are these.
    pub sums: Vec<[f64; 3]>,
}

impl PixelStats {
    /// No samples yet, every pixel active, keeping the sums of each pixel's own samples if
    /// `own_sums`; [`Error::OutOfMemory`](crate::error::Error) if the buffers cannot be
    /// allocated.
    pub fn new(
        rule: Option<AdaptiveSampling>,
        width: u32,
        height: u32,
        own_sums: bool,
    ) -> crate::error::Result<PixelStats> {
        let pixels = width as usize * height as usize;
        let what = || format!("the sample statistics of a {width}x{height} image");
        Ok(PixelStats {
            rule,
            counts: crate::platform::try_vec(pixels, 0, what)?,
            squares: crate::platform::try_vec(pixels, [0.0; 3], what)?,
            active: crate::platform::try_vec(pixels, true, what)?,
            sums: crate::platform::try_vec(if own_sums { pixels } else { 0 }, [0.0; 3], what)?,
        })
    }

    /// The sums of each pixel's own samples: its own, or the film's `film_sums`.
    pub fn own_sums<'a>(&'a self, film_sums: &'a [[f64; 3]]) -> &'a [[f64; 3]] {
        if self.sums.is_empty() {
            film_sums
        } else {
            &self.sums
        }
    }

    /// Adds a tile's pass of `n` samples a pixel: `squares` (and, if this keeps its own,
    /// `sums`) row-major over `tile`'s pixels (`width` the image's). Only the pixels that
    /// were active took samples.
    pub fn add(
        &mut self,
        tile: &super::Tile,
        width: u32,
        n: u32,
        (squares, sums): (&[[f64; 3]], &[[f64; 3]]),
    ) {
        let own = !self.sums.is_empty();
        let mut k = 0;
        for y in tile.y0..tile.y1 {
            for x in tile.x0..tile.x1 {
                let i = (y * width + x) as usize;
                if self.active[i] {
                    self.counts[i] += n;
                    for (sum, q) in self.squares[i].iter_mut().zip(squares[k]) {
                        *sum += q;
                    }
                    if own {
                        for (sum, v) in self.sums[i].iter_mut().zip(sums[k]) {
                            *sum += v;
                        }
                    }
                }
                k += 1;
            }
        }
    }

    /// After a whole pass that left every active pixel with `spp` samples: stops the
    /// pixels whose error is below the threshold and whose neighbours' (3×3) are too, once
    /// every pixel has the minimum. Returns how many pixels remain active (all of them
    /// without adaptive sampling).
    pub fn end_pass(&mut self, sums: &[[f64; 3]], width: u32, height: u32, spp: u32) -> usize {
        let Some(rule) = self.rule else {
            return self.active.len();
        };
        if spp >= rule.min_samples {
            let threshold = rule.threshold as f64;
            let unconverged: Vec<bool> = (0..self.active.len())
                .map(|i| {
                    self.active[i] && error(sums[i], self.squares[i], self.counts[i]) >= threshold
                })
                .collect();
            let (w, h) = (width as i64, height as i64);
            for y in 0..h {
                for x in 0..w {
                    let i = (y * w + x) as usize;
                    if !self.active[i] {
                        continue;
                    }
                    // A pixel next to one still noisy goes on, so that noise is not left in
                    // a ring around a region that stopped.
                    let mut near = false;
                    for ny in (y - 1).max(0)..=(y + 1).min(h - 1) {
                        for nx in (x - 1).max(0)..=(x + 1).min(w - 1) {
                            near |= unconverged[(ny * w + nx) as usize];
                        }
                    }
                    self.active[i] = near;
                }
            }
        }
        self.active.iter().filter(|a| **a).count()
    }

    /// Samples taken over the whole image.
    pub fn samples(&self) -> u64 {
        self.counts.iter().map(|&n| n as u64).sum()
    }

    /// Per pixel: the error estimate (infinite below two samples); `sums` the film's.
    pub fn errors<'a>(&'a self, sums: &'a [[f64; 3]]) -> impl Iterator<Item = f64> + 'a {
        self.own_sums(sums)
            .iter()
            .zip(&self.squares)
            .zip(&self.counts)
            .map(|((s, q), n)| error(*s, *q, *n))
    }

    /// Per pixel: its samples' variance per channel (zero below two samples); `sums` the
    /// film's.
    pub fn variances<'a>(&'a self, sums: &'a [[f64; 3]]) -> impl Iterator<Item = Rgb> + 'a {
        self.own_sums(sums)
            .iter()
            .zip(&self.squares)
            .zip(&self.counts)
            .map(|((s, q), n)| {
                let v = sample_variance(*s, *q, *n);
                Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32)
            })
    }
}

/// The unbiased variance of `n` samples per channel, from their sum and sum of squares
/// (zero below two samples).
fn sample_variance(sum: [f64; 3], squares: [f64; 3], n: u32) -> [f64; 3] {
    if n < 2 {
        return [0.0; 3];
    }
    let n = n as f64;
    std::array::from_fn(|c| ((squares[c] - sum[c] * sum[c] / n) / (n - 1.0)).max(0.0))
}

/// The error estimate of a pixel of `n` samples: the expected absolute error of its mean,
/// summed over the channels, over the square root of its summed mean (plus 10⁻⁴, as
/// Cycles). Infinite below two samples.
pub(crate) fn error(sum: [f64; 3], squares: [f64; 3], n: u32) -> f64 {
    if n < 2 {
        return f64::INFINITY;
    }
    let v = sample_variance(sum, squares, n);
    let nf = n as f64;
    let absolute: f64 = v.iter().map(|v| (v / nf).sqrt()).sum::<f64>() * MEAN_ABSOLUTE_NORMAL;
    let intensity = (sum[0] + sum[1] + sum[2]).max(0.0) / nf;
    absolute / (1e-4 + intensity.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    /// The estimate follows the mean's actual error: over many pixels of independent
    /// samples of a known distribution, the mean of |pixel − truth| summed over channels
    /// over √(truth summed) matches the mean estimate within 5%.
    #[test]
    fn the_error_estimate_matches_the_error_of_the_mean() {
        let mut rng = Rng::for_key(3, &[1]);
        let (n, pixels) = (64u32, 4000);
        let truth = [0.5f64, 0.25, 1.0]; // exponential samples with these means
        let mut estimated = 0.0;
        let mut actual = 0.0;
        for _ in 0..pixels {
            let (mut sum, mut sq) = ([0.0f64; 3], [0.0f64; 3]);
            for _ in 0..n {
                for c in 0..3 {
                    let x = -truth[c] * (1.0 - rng.uniform() as f64).ln();
                    sum[c] += x;
                    sq[c] += x * x;
                }
            }
            estimated += error(sum, sq, n);
            let diff: f64 = (0..3).map(|c| (sum[c] / n as f64 - truth[c]).abs()).sum();
            actual += diff / (1e-4 + truth.iter().sum::<f64>().sqrt());
        }
        let ratio = estimated / actual;
        assert!((ratio - 1.0).abs() < 0.05, "estimated / actual = {ratio}");
    }

    /// Converged pixels stop, noisy ones and their neighbours go on; nothing stops before
    /// the minimum.
    #[test]
    fn pixels_stop_where_converged_and_keep_a_ring_around_noise() {
        let rule = AdaptiveSampling {
            threshold: 0.01,
            min_samples: 4,
        };
        let (w, h) = (5u32, 1u32);
        let mut stats = PixelStats::new(Some(rule), w, h, false).unwrap();
        // Pixel 0 noisy (samples 0 and 2), the rest constant 1.
        let n = 4;
        let mut sums = vec![[n as f64; 3]; 5];
        stats.squares = vec![[n as f64; 3]; 5];
        sums[0] = [4.0; 3];
        stats.squares[0] = [8.0; 3];
        stats.counts = vec![n; 5];
        assert_eq!(stats.end_pass(&sums, w, h, 2), 5, "before the minimum");
        assert_eq!(stats.end_pass(&sums, w, h, n), 2);
        assert_eq!(stats.active, [true, true, false, false, false]);
        // A stopped pixel does not come back, even next to noise.
        assert_eq!(stats.end_pass(&sums, w, h, n), 2);
        assert!(error([4.0; 3], [4.0; 3], n) < 1e-3);
        assert!(error([1.0; 3], [1.0; 3], 1).is_infinite());
    }
}
