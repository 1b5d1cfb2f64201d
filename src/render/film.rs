//! The film of a Monte Carlo render: per pixel, the sum of its camera samples' estimates
//! (filter-weighted when samples are splatted, with the sum of their weights) and the
//! filter-weighted splats of light paths, with the count of passes taken. The image is their
//! mean; a checkpoint stores them exactly.

use super::adaptive::PixelStats;
use super::{tiles, Tile, TILE_SIZE};
use crate::image::filter::{Filter, FilterWeights, Reconstruction};
use crate::image::Image;
use crate::math::{Rgb, Vec2};
use crate::transport::passes::{next_pass, reachable, MAX_PASS, MAX_SPP};
use crate::transport::Splat;

/// The accumulated film.
pub struct Film {
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) filter: Filter,
    pub(crate) reconstruction: Reconstruction,
    /// 1 / ∫ filter over the plane, in pixel units.
    filter_norm: f64,
    /// Per pixel: the sum of its camera-sample estimates (filter-weighted, if splatted).
    pub(crate) sums: Vec<[f64; 3]>,
    /// Per pixel: the sum of the filter weights of the camera samples splatted into it
    /// (unused when each sample counts in its own pixel alone).
    pub(crate) weights: Vec<f64>,
    /// Per pixel: splatted contributions, filter-weighted.
    splats: Vec<[f64; 3]>,
    /// Samples per pixel of every finished pass.
    pub spp: u32,
    /// The pass in progress when a render was interrupted: its size (0: none) and how many
    /// of the image's tiles, in order, already have its samples. A resumed render finishes
    /// it tile by tile, adding exactly what the uninterrupted render would have added.
    pub(crate) pass: u32,
    pub(crate) tiles_done: u32,
    /// Samples that returned NaN or infinity and were dropped.
    pub invalid: u64,
    /// With adaptive sampling, or when kept for the variance and error layers: each
    /// pixel's sample count, sums of squares (and of its own samples, when they are
    /// splatted) and whether it goes on.
    pub(crate) stats: Option<PixelStats>,
    /// The largest pass its render takes ([`MAX_PASS`], or 1 for a technique whose every
    /// sample index is an iteration over the whole image).
    pub(crate) max_pass: u32,
    /// A technique's own per-pixel state, when its image is not a mean of samples
    /// (stochastic progressive photon mapping's photon statistics): `state_len` values a
    /// pixel, row-major, saved and restored by checkpoints as they are. The sums then hold
    /// each pixel's estimate times the passes taken, so that the image is still their mean.
    pub(crate) state: Vec<f64>,
    pub(crate) state_len: usize,
}

impl Film {
    /// An empty film (no samples) of this size, filter and reconstruction, or
    /// [`Error::OutOfMemory`](crate::error::Error::OutOfMemory) if it cannot be allocated.
    pub fn new(
        width: u32,
        height: u32,
        filter: Filter,
        reconstruction: Reconstruction,
    ) -> crate::error::Result<Film> {
        // ∫ filter by the midpoint rule on a fine grid.
        let r = filter.radius();
        let n = 256;
        let h = 2.0 * r / n as f32;
        let mut integral = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let d = Vec2::new(-r + (i as f32 + 0.5) * h, -r + (j as f32 + 0.5) * h);
                integral += filter.eval(d) as f64;
            }
        }
        integral *= (h * h) as f64;
        let pixels = width as usize * height as usize;
        let what = || format!("the film of a {width}x{height} image");
        Ok(Film {
            width,
            height,
            filter,
            reconstruction,
            filter_norm: 1.0 / integral,
            sums: crate::platform::try_vec(pixels, [0.0; 3], what)?,
            weights: crate::platform::try_vec(pixels, 0.0, what)?,
            splats: crate::platform::try_vec(pixels, [0.0; 3], what)?,
            spp: 0,
            pass: 0,
            tiles_done: 0,
            invalid: 0,
            stats: None,
            max_pass: MAX_PASS,
            state: Vec::new(),
            state_len: 0,
        })
    }

    /// This film, sampled adaptively by `rule` (if any): it then keeps each pixel's
    /// statistics, and its pixels must take their samples from the filter.
    pub fn with_adaptive(
        mut self,
        rule: Option<crate::transport::settings::AdaptiveSampling>,
    ) -> crate::error::Result<Film> {
        if let Some(rule) = rule {
            if self.reconstruction != Reconstruction::Importance {
                return Err(crate::error::Error::Invalid(
                    "adaptive sampling needs pixels that take their samples from the filter".into(),
                ));
            }
            self.stats = Some(PixelStats::new(Some(rule), self.width, self.height, false)?);
        }
        Ok(self)
    }

    /// This film, for a render that takes one sample a pass (`one`: a technique whose
    /// every sample index is an iteration over the whole image, see
    /// `Technique::one_sample_passes`).
    pub fn with_one_sample_passes(mut self, one: bool) -> Film {
        self.max_pass = if one { 1 } else { MAX_PASS };
        self
    }

    /// This film, keeping `per_pixel` values of a technique's own state for each pixel
    /// (zero at first), or [`Error::OutOfMemory`](crate::error::Error::OutOfMemory).
    pub(crate) fn with_state(mut self, per_pixel: usize) -> crate::error::Result<Film> {
        let values = self.width as usize * self.height as usize * per_pixel;
        let (w, h) = (self.width, self.height);
        self.state = crate::platform::try_vec(values, 0.0, || {
            format!("the per-pixel state of a {w}x{h} image")
        })?;
        self.state_len = per_pixel;
        Ok(self)
    }

    /// This film, keeping each pixel's sample statistics (count, sums of squares, and the
    /// sums of its own samples when they are splatted over its neighbours) if `keep`, for
    /// [`Film::statistics_images`]; adaptive sampling keeps them already.
    pub fn with_statistics(mut self, keep: bool) -> crate::error::Result<Film> {
        if keep && self.stats.is_none() {
            let own_sums = self.reconstruction == Reconstruction::Splat;
            self.stats = Some(PixelStats::new(None, self.width, self.height, own_sums)?);
        }
        Ok(self)
    }

    /// Whether the film keeps each pixel's sample statistics.
    pub fn has_statistics(&self) -> bool {
        self.stats.is_some()
    }

    /// Adaptive sampling's rule, if the film is sampled adaptively.
    pub(crate) fn adaptive(&self) -> Option<crate::transport::settings::AdaptiveSampling> {
        self.stats.as_ref().and_then(|s| s.rule)
    }

    /// The per-pixel statistics when the film is sampled adaptively (kept ones stop no
    /// pixel and count no differently from the film).
    fn adaptive_stats(&self) -> Option<&PixelStats> {
        self.stats.as_ref().filter(|s| s.rule.is_some())
    }

    /// The per-pixel statistics, for checkpoints: sample counts, sums of squares, which
    /// pixels go on and the sums of their own samples.
    pub(crate) fn statistics(&self) -> Option<&PixelStats> {
        self.stats.as_ref()
    }

    /// Adds a tile's pass of `n` samples a pixel to the statistics (nothing if the film
    /// keeps none); `squares` and `sums` (each pixel's own samples, when they are splatted)
    /// row-major over the tile.
    pub(crate) fn add_statistics(
        &mut self,
        tile: &Tile,
        n: u32,
        (squares, sums): (&[[f64; 3]], &[[f64; 3]]),
    ) {
        if let Some(stats) = &mut self.stats {
            stats.add(tile, self.width, n, (squares, sums));
        }
    }

    /// After a whole pass: stops the pixels adaptive sampling finds converged. Returns
    /// whether any pixel goes on (always, without adaptive sampling).
    pub(crate) fn end_adaptive_pass(&mut self) -> bool {
        let (w, h, spp) = (self.width, self.height, self.spp);
        match &mut self.stats {
            Some(stats) => stats.end_pass(&self.sums, w, h, spp) > 0,
            None => true,
        }
    }

    /// Which pixels take the next pass's samples (`None`: all, without adaptive sampling).
    pub(crate) fn active(&self) -> Option<&[bool]> {
        self.adaptive_stats().map(|s| s.active.as_slice())
    }

    /// Per pixel, with adaptive sampling or kept statistics ([`Film::with_statistics`]):
    /// the error estimate adaptive sampling uses, the variance per channel of the samples
    /// taken for the pixel (pbrt-v4's per-pixel variance; of the pixel's own samples, even
    /// when they are splatted over its neighbours) and the sample count, as images; `None`
    /// without statistics.
    pub fn statistics_images(&self) -> crate::error::Result<Option<[Image; 3]>> {
        let Some(stats) = &self.stats else {
            return Ok(None);
        };
        let mut error = Image::try_new(self.width, self.height)?;
        let mut variance = Image::try_new(self.width, self.height)?;
        let mut samples = Image::try_new(self.width, self.height)?;
        for (px, e) in error.pixels.iter_mut().zip(stats.errors(&self.sums)) {
            *px = Rgb::splat(e as f32);
        }
        for (px, v) in variance.pixels.iter_mut().zip(stats.variances(&self.sums)) {
            *px = v;
        }
        for (px, n) in samples.pixels.iter_mut().zip(&stats.counts) {
            *px = Rgb::splat(*n as f32);
        }
        Ok(Some([error, variance, samples]))
    }

    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The per-pixel sums of sample estimates, of their weights and of light-path splats
    /// (for checkpoints).
    pub(crate) fn accumulators(&self) -> (&[[f64; 3]], &[f64], &[[f64; 3]]) {
        (&self.sums, &self.weights, &self.splats)
    }

    /// The pass in progress: its size and the tiles that have it (0, 0 between passes).
    pub(crate) fn pass_in_progress(&self) -> (u32, u32) {
        (self.pass, self.tiles_done)
    }

    /// This (empty) film with saved accumulators and counts, checked against each other and
    /// against a render of `target` samples per pixel: the counts must be ones that render
    /// passes through, and the sums finite and not negative.
    pub(crate) fn restored(
        mut self,
        (sums, weights, splats): (Vec<[f64; 3]>, Vec<f64>, Vec<[f64; 3]>),
        (spp, pass, tiles_done, invalid): (u32, u32, u32, u64),
        stats: Option<super::adaptive::SavedStats>,
        state: Vec<f64>,
        target: u32,
    ) -> std::result::Result<Film, String> {
        let tile_count = tiles(self.width, self.height).len() as u32;
        if spp > MAX_SPP
            || pass > MAX_SPP
            || tiles_done >= tile_count.max(1)
            || (pass == 0) != (tiles_done == 0)
        {
            return Err("inconsistent sample counts".into());
        }
        if spp >= target {
            return Err(format!(
                "holds {spp} samples per pixel, and this render takes {target}: nothing to resume"
            ));
        }
        let m = self.max_pass;
        if !reachable(spp, target, m) || (pass != 0 && pass != next_pass(spp, target, m)) {
            return Err(format!(
                "its sample counts ({spp} per pixel, a pass of {pass} under way) are not those \
                 of a render of {target} samples per pixel"
            ));
        }
        let pixels = self.width as u64 * self.height as u64;
        if invalid > (spp as u64 + pass as u64) * pixels {
            return Err("more dropped samples than samples".into());
        }
        if sums
            .iter()
            .chain(&splats)
            .flatten()
            .chain(&weights)
            .any(|v| v.is_nan() || *v < 0.0)
        {
            return Err("a pixel sum is negative or not a number".into());
        }
        if sums.len() != self.sums.len()
            || weights.len() != self.weights.len()
            || splats.len() != self.splats.len()
        {
            return Err("wrong number of pixels".into());
        }
        match (&mut self.stats, stats) {
            (None, None) => {}
            (Some(mine), Some((counts, squares, active, own))) => {
                let n = mine.active.len();
                if counts.len() != n
                    || squares.len() != n
                    || active.len() != n
                    || own.len() != mine.sums.len()
                {
                    return Err("wrong number of pixels".into());
                }
                if mine.rule.is_none() && active.iter().any(|a| !a) {
                    return Err("a pixel stopped, and this render samples every pixel".into());
                }
                if counts.iter().any(|&c| c > spp + pass) {
                    return Err("a pixel counts more samples than its passes hold".into());
                }
                if squares.iter().flatten().any(|v| v.is_nan() || *v < 0.0) {
                    return Err("a pixel's sum of squares is negative or not a number".into());
                }
                if own.iter().flatten().any(|v| v.is_nan() || *v < 0.0) {
                    return Err(
                        "a pixel's sum of its own samples is negative or not a number".into(),
                    );
                }
                (mine.counts, mine.squares, mine.active, mine.sums) =
                    (counts, squares, active, own);
            }
            (None, Some(_)) => {
                return Err("holds per-pixel sample statistics, and this render has none".into())
            }
            (Some(_), None) => {
                return Err(
                    "holds no per-pixel sample statistics, and this render needs them".into(),
                )
            }
        }
        if state.len() != self.state.len() {
            return Err("wrong number of pixels".into());
        }
        if state.iter().any(|v| !v.is_finite() || *v < 0.0) {
            return Err("a pixel's state is negative or not finite".into());
        }
        self.sums = sums;
        self.weights = weights;
        self.splats = splats;
        self.state = state;
        self.spp = spp;
        self.pass = pass;
        self.tiles_done = tiles_done;
        self.invalid = invalid;
        Ok(self)
    }

    /// Whether a pass was cut short (the image then mixes pixels with `spp` and `spp + pass`
    /// samples).
    pub fn is_partial_pass(&self) -> bool {
        self.tiles_done > 0
    }

    /// Samples taken in pixel (x, y).
    fn samples_at(&self, x: u32, y: u32) -> u32 {
        let tiles_x = self.width.div_ceil(TILE_SIZE);
        let tile = (y / TILE_SIZE) * tiles_x + x / TILE_SIZE;
        self.spp + if tile < self.tiles_done { self.pass } else { 0 }
    }

    /// Mean samples per pixel so far.
    pub fn mean_spp(&self) -> f64 {
        let pixels = self.width as f64 * self.height as f64;
        if let Some(stats) = self.adaptive_stats() {
            return stats.samples() as f64 / pixels;
        }
        self.spp as f64 + self.pass as f64 * self.tiles_done_pixels() as f64 / pixels
    }

    fn tiles_done_pixels(&self) -> u64 {
        tiles(self.width, self.height)[..self.tiles_done as usize]
            .iter()
            .map(|t| (t.x1 - t.x0) as u64 * (t.y1 - t.y0) as u64)
            .sum()
    }

    /// Adds a tile's camera samples (see [`Footprint::absorb`]).
    pub(crate) fn add_camera(&mut self, part: &Footprint) {
        let whole = Tile::whole(self.width, self.height);
        add_over(&whole, &mut self.sums, &mut self.weights, part);
    }

    pub(crate) fn add_splat(&mut self, s: &Splat) {
        let r = self.filter.radius();
        let x0 = ((s.x - r - 0.5).ceil().max(0.0)) as i64;
        let x1 = ((s.x + r - 0.5).floor()).min(self.width as f32 - 1.0) as i64;
        let y0 = ((s.y - r - 0.5).ceil().max(0.0)) as i64;
        let y1 = ((s.y + r - 0.5).floor()).min(self.height as f32 - 1.0) as i64;
        for y in y0..=y1 {
            for x in x0..=x1 {
                let d = Vec2::new(x as f32 + 0.5 - s.x, y as f32 + 0.5 - s.y);
                let w = self.filter.eval(d) as f64 * self.filter_norm;
                if w > 0.0 {
                    let p = &mut self.splats[y as usize * self.width as usize + x as usize];
                    p[0] += w * s.value.x as f64;
                    p[1] += w * s.value.y as f64;
                    p[2] += w * s.value.z as f64;
                }
            }
        }
    }

    /// The image after the samples taken so far, or
    /// [`Error::OutOfMemory`](crate::error::Error::OutOfMemory) if it cannot be allocated.
    pub fn image(&self) -> crate::error::Result<Image> {
        let mut image = Image::try_new(self.width, self.height)?;
        if self.reconstruction == Reconstruction::Splat {
            // Each pixel is its weighted mean, whatever its samples: a pass cut short needs
            // no counting. One light path per camera sample.
            let paths = self.mean_spp() * self.width as f64 * self.height as f64;
            let per_path = if paths > 0.0 { 1.0 / paths } else { 0.0 };
            for (i, px) in image.pixels.iter_mut().enumerate() {
                *px = weighted_value(self.sums[i], self.weights[i], self.splats[i], per_path);
            }
            return Ok(image);
        }
        if let Some(stats) = self.adaptive_stats() {
            // Adaptive sampling: each pixel by its own count (no light paths).
            for ((px, sum), n) in image.pixels.iter_mut().zip(&self.sums).zip(&stats.counts) {
                let per_sample = if *n == 0 { 0.0 } else { 1.0 / *n as f64 };
                *px = pixel_value(*sum, [0.0; 3], per_sample, 0.0);
            }
            return Ok(image);
        }
        if self.is_partial_pass() {
            // An interrupted pass: each pixel by its own count; one light path per sample.
            let paths = self.mean_spp() * self.width as f64 * self.height as f64;
            for (i, px) in image.pixels.iter_mut().enumerate() {
                let (x, y) = (i as u32 % self.width, i as u32 / self.width);
                let n = self.samples_at(x, y);
                let per_sample = if n == 0 { 0.0 } else { 1.0 / n as f64 };
                *px = pixel_value(self.sums[i], self.splats[i], per_sample, 1.0 / paths);
            }
            return Ok(image);
        }
        if self.spp == 0 {
            return Ok(image);
        }
        let per_sample = 1.0 / self.spp as f64;
        // Light paths: one per pixel sample over the whole image.
        let per_path = per_sample / (self.width as f64 * self.height as f64);
        for (i, px) in image.pixels.iter_mut().enumerate() {
            *px = pixel_value(self.sums[i], self.splats[i], per_sample, per_path);
        }
        Ok(image)
    }
}

/// The value of a film pixel from its splatted camera samples' weighted sum and weights and
/// its light-path splats (as [`Film::image`] computes it); black where no sample reached.
pub(crate) fn weighted_value(sum: [f64; 3], weight: f64, splat: [f64; 3], per_path: f64) -> Rgb {
    let per_weight = if weight > 0.0 { 1.0 / weight } else { 0.0 };
    pixel_value(sum, splat, per_weight, per_path)
}

/// Camera samples splatted into the pixels of `rect` (a tile and the pixels its filter
/// reaches, within the pixels rendered) before they join the film.
pub(crate) struct Footprint {
    pub rect: Tile,
    /// Row-major over `rect`: weighted sums and weights.
    pub sums: Vec<[f64; 3]>,
    pub weights: Vec<f64>,
}

impl Footprint {
    /// The pixels of `bounds` that the samples of `tile` can reach through a filter of
    /// `reach` pixels.
    pub fn new(tile: &Tile, reach: u32, bounds: &Tile) -> Footprint {
        let rect = tile.grown(reach, bounds);
        let pixels = rect.pixels() as usize;
        Footprint {
            rect,
            sums: vec![[0.0; 3]; pixels],
            weights: vec![0.0; pixels],
        }
    }

    /// An empty footprint over exactly `rect`, or
    /// [`Error::OutOfMemory`](crate::error::Error::OutOfMemory) if it cannot be allocated.
    pub fn try_over(rect: Tile) -> crate::error::Result<Footprint> {
        let pixels = rect.pixels() as usize;
        let what = || format!("the film of a {}x{} region", rect.width(), rect.height());
        Ok(Footprint {
            rect,
            sums: crate::platform::try_vec(pixels, [0.0; 3], what)?,
            weights: crate::platform::try_vec(pixels, 0.0, what)?,
        })
    }

    /// Adds `part`'s sums (and its weights, if it has them: samples counted in their own
    /// pixel have none) to the pixels they cover, which must lie within this footprint.
    pub fn absorb(&mut self, part: &Footprint) {
        add_over(&self.rect, &mut self.sums, &mut self.weights, part);
    }

    /// Adds a sample at raster position `at` with `value` to every pixel whose centre its
    /// filter reaches; a dropped sample (no value) adds its weights alone, as black.
    pub fn add(&mut self, filter: &FilterWeights, at: (f32, f32), value: Option<Rgb>) {
        let v = value.map_or([0.0; 3], |l| [l.x as f64, l.y as f64, l.z as f64]);
        for_each_reached(filter, at, &self.rect, |i, wt| {
            let px = &mut self.sums[i];
            px[0] += wt * v[0];
            px[1] += wt * v[1];
            px[2] += wt * v[2];
            self.weights[i] += wt;
        });
    }
}

/// Calls `each(i, weight)` for every pixel of `rect` (`i` row-major over it) whose centre
/// the filter of a sample at raster position `at` reaches with a positive weight, row by
/// row: how a sample is splatted over the pixels around it.
pub(super) fn for_each_reached(
    filter: &FilterWeights,
    at: (f32, f32),
    rect: &Tile,
    mut each: impl FnMut(usize, f64),
) {
    let r = filter.radius();
    let span = |s: f32, lo: u32, hi: u32| {
        let a = (s - r - 0.5).ceil().max(lo as f32);
        let b = (s + r - 0.5).floor().min(hi as f32 - 1.0);
        (a as u32, b as i64)
    };
    let (x0, x1) = span(at.0, rect.x0, rect.x1);
    let (y0, y1) = span(at.1, rect.y0, rect.y1);
    // The radius is at most 16 pixels, so a sample reaches at most 33 columns.
    let mut wx = [0.0f32; 34];
    let columns = (x0 as i64..=x1).zip(wx.iter_mut());
    for (x, c) in columns {
        *c = filter.weight_1d(x as f32 + 0.5 - at.0);
    }
    let w = rect.width() as usize;
    for y in y0 as i64..=y1 {
        let wy = filter.weight_1d(y as f32 + 0.5 - at.1);
        if wy <= 0.0 {
            continue;
        }
        let row = (y as u32 - rect.y0) as usize * w;
        for (x, wx) in (x0 as i64..=x1).zip(wx) {
            let wt = (wx * wy) as f64;
            if wt > 0.0 {
                each(row + (x as u32 - rect.x0) as usize, wt);
            }
        }
    }
}

/// Adds `part` to the sums and weights (row-major over `rect`) it lies within.
fn add_over(rect: &Tile, sums: &mut [[f64; 3]], weights: &mut [f64], part: &Footprint) {
    let w = part.rect.width();
    for (k, v) in part.sums.iter().enumerate() {
        let (x, y) = (part.rect.x0 + k as u32 % w, part.rect.y0 + k as u32 / w);
        let i = ((y - rect.y0) * rect.width() + x - rect.x0) as usize;
        let px = &mut sums[i];
        px[0] += v[0];
        px[1] += v[1];
        px[2] += v[2];
        if let Some(weight) = part.weights.get(k) {
            weights[i] += weight;
        }
    }
}

/// The value of a film pixel from its sample sum and splats (as [`Film::image`] computes it).
pub(crate) fn pixel_value(sum: [f64; 3], splat: [f64; 3], per_sample: f64, per_path: f64) -> Rgb {
    Rgb::new(
        (sum[0] * per_sample + splat[0] * per_path) as f32,
        (sum[1] * per_sample + splat[1] * per_path) as f32,
        (sum[2] * per_sample + splat[2] * per_path) as f32,
    )
}

impl std::fmt::Debug for Film {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Film")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("filter", &self.filter)
            .field("spp", &self.spp)
            .field("pass", &self.pass)
            .field("tiles_done", &self.tiles_done)
            .field("invalid", &self.invalid)
            .field("adaptive", &self.adaptive())
            .field("statistics", &self.stats.is_some())
            .finish_non_exhaustive()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A splatted sample gives each pixel within the filter's radius the filter's weight at
    /// that pixel's centre (through the table, within its tolerance), and nothing to the
    /// others; a footprint cut by the image's edge keeps its pixels' weights as they are.
    #[test]
    fn a_splat_weighs_each_pixel_by_the_filter_at_its_centre() {
        let filter = Filter::Gaussian {
            radius: 2.0,
            sigma: 0.5,
        };
        let weights = FilterWeights::new(filter);
        let tile = Tile {
            x0: 4,
            y0: 4,
            x1: 8,
            y1: 8,
        };
        let at = (5.3, 7.8);
        let value = Rgb::new(2.0, 1.0, 0.5);
        let whole = Tile::whole(20, 20);
        let mut f = Footprint::new(&tile, 3, &whole);
        assert_eq!((f.rect.x0, f.rect.y0, f.rect.x1, f.rect.y1), (1, 1, 11, 11));
        f.add(&weights, at, Some(value));
        let mut reached = 0;
        for (k, w) in f.weights.iter().enumerate() {
            let (x, y) = (f.rect.x0 + k as u32 % 10, f.rect.y0 + k as u32 / 10);
            let d = Vec2::new(x as f32 + 0.5 - at.0, y as f32 + 0.5 - at.1);
            let exact = filter.eval(d) as f64;
            assert!((w - exact).abs() < 1e-5, "({x}, {y}): {w} vs {exact}");
            assert!((f.sums[k][0] - 2.0 * w).abs() < 1e-12);
            reached += (*w > 0.0) as u32;
        }
        assert_eq!(reached, 16);
        // The same sample cut by an image whose last column is 5 and last row 7.
        let edge = Tile::whole(6, 8);
        let mut cut = Footprint::new(&tile, 3, &edge);
        cut.add(&weights, at, Some(value));
        for (k, w) in cut.weights.iter().enumerate() {
            let (x, y) = (
                cut.rect.x0 + k as u32 % cut.rect.width(),
                cut.rect.y0 + k as u32 / cut.rect.width(),
            );
            let i = ((y - f.rect.y0) * 10 + x - f.rect.x0) as usize;
            assert_eq!(*w, f.weights[i], "({x}, {y})");
        }
        // A pixel's value is its samples' weighted mean: a constant stays that constant.
        let i = ((7 - f.rect.y0) * 10 + 5 - f.rect.x0) as usize;
        let v = weighted_value(f.sums[i], f.weights[i], [0.0; 3], 0.0);
        assert!((v - value).abs().max_element() < 1e-6, "{v}");
    }
}
