//! The Monte Carlo render loop: whole sample passes over the image until the sample count or
//! the time limit is reached. Sample `i` of pixel (x, y) always draws the same sample values
//! (keyed by seed, pixel and `i`), each pixel sums its samples in index order, and splats
//! from light paths are merged in tile order, so the image is the same bit for bit for any
//! thread count.

use super::{progress_bar, tiles, RenderStats, Tile};
use crate::image::filter::{Filter, FilterSampler};
use crate::image::Image;
use crate::integrators::{Context, MonteCarlo, RayStats, Splat};
use crate::math::sobol::Sampler;
use crate::math::{Ray, Rgb, Vec2};
use crate::scene::camera::CameraBasis;
use crate::scene::Scene;
use crate::{Error, Result};
use rayon::prelude::*;
use std::time::Instant;

/// Upper bound on samples per pixel.
pub const MAX_SPP: u32 = 1 << 20;
/// Tiles rendered between two merges of their splats (bounds the memory splats take).
const TILE_GROUP: usize = 64;

#[derive(Clone, Debug, PartialEq)]
pub struct ProgressiveOptions {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel; with a time limit, the most that will be taken.
    pub spp: u32,
    /// Stop after the last whole pass that fits in this many seconds.
    pub time_limit: Option<f64>,
    pub threads: Option<usize>,
    pub seed: u64,
    pub progress: bool,
    pub filter: Filter,
}

/// The accumulated film.
pub struct Film {
    width: u32,
    height: u32,
    filter: Filter,
    /// 1 / ∫ filter over the plane, in pixel units.
    filter_norm: f64,
    /// Per pixel: the sum of its camera-sample estimates.
    sums: Vec<[f64; 3]>,
    /// Per pixel: splatted contributions, filter-weighted.
    splats: Vec<[f64; 3]>,
    /// Samples per pixel of every finished pass.
    pub spp: u32,
    /// The pass in progress when a render was interrupted: its size (0: none) and how many
    /// of the image's tiles, in order, already have its samples. A resumed render finishes
    /// it tile by tile, adding exactly what the uninterrupted render would have added.
    pass: u32,
    tiles_done: u32,
    /// Samples that returned NaN or infinity and were dropped.
    pub invalid: u64,
}

impl Film {
    /// An empty film (no samples) of this size and filter.
    pub fn new(width: u32, height: u32, filter: Filter) -> Film {
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
        Film {
            width,
            height,
            filter,
            filter_norm: 1.0 / integral,
            sums: vec![[0.0; 3]; pixels],
            splats: vec![[0.0; 3]; pixels],
            spp: 0,
            pass: 0,
            tiles_done: 0,
            invalid: 0,
        }
    }

    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The per-pixel sums of sample estimates and of splats (for checkpoints).
    pub(super) fn accumulators(&self) -> (&[[f64; 3]], &[[f64; 3]]) {
        (&self.sums, &self.splats)
    }

    /// The pass in progress: its size and the tiles that have it (0, 0 between passes).
    pub(super) fn pass_in_progress(&self) -> (u32, u32) {
        (self.pass, self.tiles_done)
    }

    /// This (empty) film with saved accumulators and counts, checked for consistency.
    pub(super) fn restored(
        mut self,
        sums: Vec<[f64; 3]>,
        splats: Vec<[f64; 3]>,
        spp: u32,
        pass: u32,
        tiles_done: u32,
        invalid: u64,
    ) -> std::result::Result<Film, String> {
        let tile_count = tiles(self.width, self.height).len() as u32;
        if spp > MAX_SPP
            || pass > MAX_SPP
            || tiles_done >= tile_count.max(1)
            || (pass == 0) != (tiles_done == 0)
        {
            return Err("inconsistent sample counts".into());
        }
        if sums.len() != self.sums.len() || splats.len() != self.splats.len() {
            return Err("wrong number of pixels".into());
        }
        self.sums = sums;
        self.splats = splats;
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
        let tiles_x = self.width.div_ceil(super::TILE_SIZE);
        let tile = (y / super::TILE_SIZE) * tiles_x + x / super::TILE_SIZE;
        self.spp + if tile < self.tiles_done { self.pass } else { 0 }
    }

    /// Mean samples per pixel so far.
    pub fn mean_spp(&self) -> f64 {
        let pixels = self.width as f64 * self.height as f64;
        self.spp as f64 + self.pass as f64 * self.tiles_done_pixels() as f64 / pixels
    }

    fn tiles_done_pixels(&self) -> u64 {
        tiles(self.width, self.height)[..self.tiles_done as usize]
            .iter()
            .map(|t| (t.x1 - t.x0) as u64 * (t.y1 - t.y0) as u64)
            .sum()
    }

    fn add_splat(&mut self, s: &Splat) {
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

    /// The image after the samples taken so far.
    pub fn image(&self) -> Image {
        let mut image = Image::new(self.width, self.height);
        if self.is_partial_pass() {
            // An interrupted pass: each pixel by its own count; one light path per sample.
            let paths = self.mean_spp() * self.width as f64 * self.height as f64;
            for (i, px) in image.pixels.iter_mut().enumerate() {
                let (x, y) = (i as u32 % self.width, i as u32 / self.width);
                let n = self.samples_at(x, y);
                let per_sample = if n == 0 { 0.0 } else { 1.0 / n as f64 };
                *px = pixel_value(self.sums[i], self.splats[i], per_sample, 1.0 / paths);
            }
            return image;
        }
        if self.spp == 0 {
            return image;
        }
        let per_sample = 1.0 / self.spp as f64;
        // Light paths: one per pixel sample over the whole image.
        let per_path = per_sample / (self.width as f64 * self.height as f64);
        for (i, px) in image.pixels.iter_mut().enumerate() {
            *px = pixel_value(self.sums[i], self.splats[i], per_sample, per_path);
        }
        image
    }
}

/// What one tile produced in one pass.
struct TileResult {
    sums: Vec<[f64; 3]>,
    splats: Vec<Splat>,
    rays: RayStats,
    invalid: u64,
}

/// The sum of the estimates of samples `samples` of pixel `(x, y)`: what one pass adds to
/// the pixel. Splats, rays and dropped samples go to `result`.
#[allow(clippy::too_many_arguments)]
fn pixel_pass(
    ctx: &Context,
    integrator: &dyn MonteCarlo,
    camera: &CameraBasis,
    seed: u64,
    filter: &FilterSampler,
    (x, y): (u32, u32),
    samples: std::ops::Range<u32>,
    result: &mut TileResult,
) -> [f64; 3] {
    let mut sum = [0.0f64; 3];
    for i in samples {
        let (mut sampler, ray) = camera_sample(camera, seed, filter, (x, y), i);
        let before = result.splats.len();
        let l = integrator.sample(
            ctx,
            camera,
            &ray,
            &mut sampler,
            &mut result.rays,
            &mut result.splats,
        );
        let splats_ok = result.splats[before..]
            .iter()
            .all(|s| s.value.is_finite() && s.x.is_finite() && s.y.is_finite());
        if !l.is_finite() || !splats_ok {
            // A numerical failure on one sample must not poison the pixel.
            result.splats.truncate(before);
            result.invalid += 1;
            continue;
        }
        sum[0] += l.x as f64;
        sum[1] += l.y as f64;
        sum[2] += l.z as f64;
    }
    sum
}

/// Camera sample `i` of pixel (x, y): its ray, through the pixel centre moved by an offset
/// drawn from the filter, and its sampler with that offset's numbers drawn. Anything that
/// must see exactly the render's camera rays (the irradiance cache's overture) calls this.
pub(crate) fn camera_sample(
    camera: &CameraBasis,
    seed: u64,
    filter: &FilterSampler,
    (x, y): (u32, u32),
    i: u32,
) -> (Sampler, Ray) {
    let mut sampler = Sampler::new(seed, &[x as u64, y as u64], i);
    let offset = filter.sample(sampler.next_2d());
    let ray = camera.ray(x as f32 + 0.5 + offset.x, y as f32 + 0.5 + offset.y);
    (sampler, ray)
}

/// The scene's camera at the render's size, with light-path splats accepted as far outside
/// the film as the filter reaches.
pub fn view_basis(scene: &Scene, options: &ProgressiveOptions) -> CameraBasis {
    let mut camera = scene.camera.clone();
    camera.width = options.width;
    camera.height = options.height;
    let mut basis = camera.basis();
    basis.margin = options.filter.radius();
    basis
}

/// The value of a film pixel from its sample sum and splats (as [`Film::image`] computes it).
fn pixel_value(sum: [f64; 3], splat: [f64; 3], per_sample: f64, per_path: f64) -> Rgb {
    Rgb::new(
        (sum[0] * per_sample + splat[0] * per_path) as f32,
        (sum[1] * per_sample + splat[1] * per_path) as f32,
        (sum[2] * per_sample + splat[2] * per_path) as f32,
    )
}

/// Renders the pixels of one rectangle (row-major) with all `options.spp` samples, exactly
/// as [`render_progressive`] (without a time limit) renders them, pass by pass, for an
/// integrator that splats nothing (the path tracer). Returns the pixels, rays and the number
/// of dropped samples.
pub fn render_region(
    ctx: &Context,
    integrator: &dyn MonteCarlo,
    options: &ProgressiveOptions,
    tile: &Tile,
) -> (Vec<Rgb>, RayStats, u64) {
    let basis = view_basis(ctx.scene, options);
    let filter = FilterSampler::new(options.filter);
    let mut result = TileResult {
        sums: Vec::new(),
        splats: Vec::new(),
        rays: RayStats::default(),
        invalid: 0,
    };
    let per_sample = 1.0 / options.spp as f64;
    let per_path = per_sample / (options.width as f64 * options.height as f64);
    let mut pixels = Vec::with_capacity(((tile.x1 - tile.x0) * (tile.y1 - tile.y0)) as usize);
    for y in tile.y0..tile.y1 {
        for x in tile.x0..tile.x1 {
            let mut total = [0.0f64; 3];
            let mut done = 0;
            while done < options.spp {
                let n = next_pass(done, options.spp);
                let s = pixel_pass(
                    ctx,
                    integrator,
                    &basis,
                    options.seed,
                    &filter,
                    (x, y),
                    done..done + n,
                    &mut result,
                );
                for c in 0..3 {
                    total[c] += s[c];
                }
                done += n;
            }
            pixels.push(pixel_value(total, [0.0; 3], per_sample, per_path));
        }
    }
    (pixels, result.rays, result.invalid)
}

fn render_tile(
    ctx: &Context,
    integrator: &dyn MonteCarlo,
    camera: &CameraBasis,
    options: &ProgressiveOptions,
    filter: &FilterSampler,
    tile: &Tile,
    samples: std::ops::Range<u32>,
) -> TileResult {
    let mut result = TileResult {
        sums: Vec::with_capacity(((tile.x1 - tile.x0) * (tile.y1 - tile.y0)) as usize),
        splats: Vec::new(),
        rays: RayStats::default(),
        invalid: 0,
    };
    for y in tile.y0..tile.y1 {
        for x in tile.x0..tile.x1 {
            let sum = pixel_pass(
                ctx,
                integrator,
                camera,
                options.seed,
                filter,
                (x, y),
                samples.clone(),
                &mut result,
            );
            result.sums.push(sum);
        }
    }
    result
}

/// The sizes of successive passes: 1, 1, 2, 4, 8, 16, 16, ... (early images come quickly,
/// later passes are long enough to keep every thread busy).
fn next_pass(done: u32, target: u32) -> u32 {
    done.clamp(1, 16).min(target - done)
}

/// Renders with a Monte Carlo integrator. `after_pass` sees the image after every pass (for
/// writing intermediate files); an error from it stops the render.
pub fn render_progressive(
    ctx: &Context,
    integrator: &dyn MonteCarlo,
    options: &ProgressiveOptions,
    after_pass: impl FnMut(&Film) -> Result<()>,
) -> Result<(Film, RenderStats)> {
    render_progressive_from(ctx, integrator, options, None, after_pass)
}

/// [`render_progressive`], continuing from `resume` (a film saved by an earlier, interrupted
/// run with the same scene and options: see [`super::checkpoint`]) if given. The result is
/// the same bit for bit as a render that was never interrupted. When a stop is requested
/// ([`crate::interrupt`]) the render returns after the tile in hand with
/// [`RenderStats::interrupted`] set; the film then holds every tile finished so far.
pub fn render_progressive_from(
    ctx: &Context,
    integrator: &dyn MonteCarlo,
    options: &ProgressiveOptions,
    resume: Option<Film>,
    mut after_pass: impl FnMut(&Film) -> Result<()>,
) -> Result<(Film, RenderStats)> {
    if options.width == 0 || options.height == 0 {
        return Err(Error::Options(
            "the image needs a width and height of at least 1".into(),
        ));
    }
    if options.spp == 0 || options.spp > MAX_SPP {
        return Err(Error::Options(format!(
            "--spp must be between 1 and {MAX_SPP}, got {}",
            options.spp
        )));
    }
    if let Some(t) = options.time_limit {
        if !(t.is_finite() && t > 0.0) {
            return Err(Error::Options(format!(
                "--time-limit must be a positive number of seconds, got {t}"
            )));
        }
    }
    options.filter.validate().map_err(Error::Options)?;
    let pool = super::thread_pool(options.threads)?;
    let basis = view_basis(ctx.scene, options);
    let filter_sampler = FilterSampler::new(options.filter);
    let tiles = tiles(options.width, options.height);
    let mut film = match resume {
        Some(film) => {
            if (film.width, film.height, film.filter)
                != (options.width, options.height, options.filter)
            {
                return Err(Error::Options(
                    "the film to resume was rendered at another size or filter".into(),
                ));
            }
            film
        }
        None => Film::new(options.width, options.height, options.filter),
    };
    let mut stats = RenderStats::default();
    let progress = progress_bar(
        options.progress,
        if options.time_limit.is_some() {
            0
        } else {
            options.spp as u64
        },
        "samples",
    );
    let start = Instant::now();
    progress.inc(film.spp as u64);
    while film.spp < options.spp {
        // A resumed film may be in the middle of a pass.
        let n = if film.is_partial_pass() {
            film.pass
        } else {
            next_pass(film.spp, options.spp)
        };
        film.pass = n;
        let pass_start = Instant::now();
        let samples = film.spp..film.spp + n;
        // Tiles are merged in image order whatever the grouping, so a pass finished after a
        // resume adds the same numbers in the same order as an uninterrupted one.
        for group in tiles[film.tiles_done as usize..].chunks(TILE_GROUP) {
            let results: Vec<Option<TileResult>> = pool.install(|| {
                group
                    .par_iter()
                    .map(|tile| {
                        (!crate::interrupt::requested()).then(|| {
                            render_tile(
                                ctx,
                                integrator,
                                &basis,
                                options,
                                &filter_sampler,
                                tile,
                                samples.clone(),
                            )
                        })
                    })
                    .collect()
            });
            for (tile, r) in group.iter().zip(results) {
                // Keep the finished tiles up to the first one skipped.
                let Some(r) = r else {
                    stats.interrupted = true;
                    break;
                };
                let w = tile.x1 - tile.x0;
                for (i, s) in r.sums.iter().enumerate() {
                    let (x, y) = (tile.x0 + i as u32 % w, tile.y0 + i as u32 / w);
                    let p = &mut film.sums[(y * options.width + x) as usize];
                    p[0] += s[0];
                    p[1] += s[1];
                    p[2] += s[2];
                }
                for s in &r.splats {
                    film.add_splat(s);
                }
                stats.rays.add(&r.rays);
                stats.samples += n as u64 * r.sums.len() as u64;
                film.invalid += r.invalid;
                film.tiles_done += 1;
            }
            if stats.interrupted {
                break;
            }
        }
        if stats.interrupted {
            if film.tiles_done == 0 {
                film.pass = 0;
            }
            break;
        }
        film.spp += n;
        film.pass = 0;
        film.tiles_done = 0;
        progress.inc(n as u64);
        after_pass(&film)?;
        if let Some(limit) = options.time_limit {
            // Stop when another pass like the last one would overrun the limit.
            let elapsed = start.elapsed().as_secs_f64();
            let pass = pass_start.elapsed().as_secs_f64();
            let next = next_pass(film.spp, options.spp.max(film.spp + 1)) as f64 / n as f64;
            if elapsed + pass * next > limit {
                break;
            }
        }
    }
    progress.finish_and_clear();
    stats.seconds = start.elapsed().as_secs_f64();
    Ok((film, stats))
}
