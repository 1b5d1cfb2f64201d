//! The Monte Carlo render loop: whole sample passes over the image until the sample count or
//! the time limit is reached. Sample `i` of pixel (x, y) always draws the same sample values
//! (keyed by seed, pixel and `i`), each pixel sums its samples in index order, and splats
//! from light paths are merged in tile order, so the image is the same bit for bit for any
//! thread count.

use super::driver::{drive, drive_indexed, Merge};
use super::film::pixel_value;
use super::{place, tiles, tiles_in, Film, RenderStats, Shown, Tile, Watch, MERGE_WINDOW};
use crate::control::Control;
use crate::image::filter::{Filter, FilterSampler};
use crate::image::Image;
use crate::integrators::{Context, MonteCarlo, RayStats, Splat};
use crate::math::sobol::Sampler;
use crate::math::{Ray, Rgb};
use crate::scene::camera::CameraBasis;
use crate::scene::Scene;
use crate::{Error, Result};
use std::time::Instant;

/// Upper bound on samples per pixel.
pub const MAX_SPP: u32 = 1 << 20;

/// The view a Monte Carlo render samples.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ProgressiveOptions {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel; with a time limit, the most that will be taken.
    pub spp: u32,
    /// Stop after the last whole pass that fits in this many seconds.
    pub time_limit: Option<f64>,
    pub threads: Option<usize>,
    pub seed: u64,
    pub filter: Filter,
}

/// What one tile produced in one pass.
struct TileResult {
    sums: Vec<[f64; 3]>,
    splats: Vec<Splat>,
    rays: RayStats,
    invalid: u64,
}

impl TileResult {
    fn new(pixels: usize) -> TileResult {
        TileResult {
            sums: Vec::with_capacity(pixels),
            splats: Vec::new(),
            rays: RayStats::default(),
            invalid: 0,
        }
    }
}

/// What every sample of a render needs: the integrator, the camera and the sample streams.
struct Samples<'a> {
    ctx: &'a Context<'a>,
    integrator: &'a dyn MonteCarlo,
    camera: CameraBasis,
    seed: u64,
    filter: FilterSampler,
    /// Whether anything moves during the exposure (else rays need no shutter time).
    moving: bool,
}

impl<'a> Samples<'a> {
    fn new(
        ctx: &'a Context<'a>,
        integrator: &'a dyn MonteCarlo,
        options: &ProgressiveOptions,
    ) -> Samples<'a> {
        Samples {
            ctx,
            integrator,
            camera: view_basis(ctx.scene, options),
            seed: options.seed,
            filter: FilterSampler::new(options.filter),
            moving: ctx.scene.moves(),
        }
    }

    /// The sum of the estimates of samples `samples` of pixel `(x, y)`: what one pass adds
    /// to the pixel. Splats, rays and dropped samples go to `result`.
    fn pixel_pass(
        &self,
        (x, y): (u32, u32),
        samples: std::ops::Range<u32>,
        result: &mut TileResult,
    ) -> [f64; 3] {
        let mut sum = [0.0f64; 3];
        for i in samples {
            let (mut sampler, ray) = camera_sample(
                &self.camera,
                self.seed,
                &self.filter,
                self.moving,
                (x, y),
                i,
            );
            let before = result.splats.len();
            let l = self.integrator.sample(
                self.ctx,
                &self.camera,
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

    /// One pass of `samples` over a tile.
    fn tile_pass(&self, tile: &Tile, samples: std::ops::Range<u32>) -> TileResult {
        let mut result = TileResult::new(tile.pixels() as usize);
        for y in tile.y0..tile.y1 {
            for x in tile.x0..tile.x1 {
                let sum = self.pixel_pass((x, y), samples.clone(), &mut result);
                result.sums.push(sum);
            }
        }
        result
    }

    /// Every one of `spp` samples of a tile, pass by pass as a whole render takes them, for
    /// an integrator that splats nothing: the tile's pixels (row-major), the rays and the
    /// dropped samples.
    fn tile_all_passes(&self, tile: &Tile, spp: u32, pixels_in_image: f64) -> TileResult {
        let per_sample = 1.0 / spp as f64;
        let per_path = per_sample / pixels_in_image;
        let mut result = TileResult::new(tile.pixels() as usize);
        for y in tile.y0..tile.y1 {
            for x in tile.x0..tile.x1 {
                let mut total = [0.0f64; 3];
                let mut done = 0;
                while done < spp {
                    let n = next_pass(done, spp);
                    let s = self.pixel_pass((x, y), done..done + n, &mut result);
                    for c in 0..3 {
                        total[c] += s[c];
                    }
                    done += n;
                }
                let v = pixel_value(total, [0.0; 3], per_sample, per_path);
                result.sums.push([v.x as f64, v.y as f64, v.z as f64]);
            }
        }
        result
    }
}

/// Camera sample `i` of pixel (x, y): its ray, through the pixel centre moved by an offset
/// drawn from the filter, and its sampler with that offset's numbers drawn. Anything that
/// must see exactly the render's camera rays (the irradiance cache's overture) calls this.
/// The ray gets a shutter time only if the scene is `moving`: a still scene looks the same
/// at any time, and drawing the time costs as much as a bounce's sample values.
pub(crate) fn camera_sample(
    camera: &CameraBasis,
    seed: u64,
    filter: &FilterSampler,
    moving: bool,
    (x, y): (u32, u32),
    i: u32,
) -> (Sampler, Ray) {
    let mut sampler = Sampler::new(seed, &[x as u64, y as u64], i);
    let offset = filter.sample(sampler.next_2d());
    let (fx, fy) = (x as f32 + 0.5 + offset.x, y as f32 + 0.5 + offset.y);
    // Only a thin lens draws a lens sample, so pinhole images keep their sample streams.
    let ray = if camera.has_lens() {
        camera.ray_through_lens(fx, fy, sampler.next_2d())
    } else {
        camera.ray(fx, fy)
    };
    // From a stream of its own: drawing it leaves the other dimensions as they were.
    let ray = if moving {
        ray.at_time(sampler.shutter_time())
    } else {
        ray
    };
    (sampler, ray)
}

/// The scene's camera at the render's size, with light-path splats accepted as far outside
/// the film as the filter reaches.
pub(crate) fn view_basis(scene: &Scene, options: &ProgressiveOptions) -> CameraBasis {
    let mut camera = scene.camera.clone();
    camera.width = options.width;
    camera.height = options.height;
    let mut basis = camera.basis();
    basis.margin = options.filter.radius();
    basis
}

/// The pixels of one tile (row-major) with all `options.spp` samples, exactly as
/// [`render_passes`] (without a time limit) renders them, for an integrator that splats
/// nothing (the path tracer): the pixels, the rays and the dropped samples.
pub(crate) fn render_tile(
    ctx: &Context,
    integrator: &dyn MonteCarlo,
    options: &ProgressiveOptions,
    tile: &Tile,
) -> (Vec<Rgb>, RayStats, u64) {
    let s = Samples::new(ctx, integrator, options);
    let r = s.tile_all_passes(
        tile,
        options.spp,
        options.width as f64 * options.height as f64,
    );
    let pixels = r
        .sums
        .iter()
        .map(|v| Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32))
        .collect();
    (pixels, r.rays, r.invalid)
}

/// The pixels of `region` of the image [`render_passes`] renders (without a time limit),
/// with the same values bit for bit, for an integrator that splats nothing. A cancel leaves
/// the tiles not merged black and marks the statistics.
pub(crate) fn render_region(
    ctx: &Context,
    integrator: &dyn MonteCarlo,
    options: &ProgressiveOptions,
    region: &Tile,
    control: &Control,
) -> Result<(Image, RenderStats)> {
    if options.time_limit.is_some() {
        return Err(Error::setting(
            "time_limit",
            "cannot be used for a part of an image: every part must take the same samples",
        ));
    }
    let s = Samples::new(ctx, integrator, options);
    let pixels_in_image = options.width as f64 * options.height as f64;
    let tiles = tiles_in(region);
    let phase = control.phase(
        "render",
        Some(region.pixels() * options.spp as u64),
        "samples",
    );
    let start = Instant::now();
    let mut image = Image::try_new(region.width(), region.height())?;
    let mut stats = RenderStats::default();
    let driven = drive(
        &tiles,
        options.threads,
        MERGE_WINDOW,
        &control.cancel,
        |t| s.tile_all_passes(t, options.spp, pixels_in_image),
        |i, r| {
            let t = &tiles[i];
            let pixels = r
                .sums
                .iter()
                .map(|v| Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32));
            place(&mut image, (region.x0, region.y0), t, pixels);
            stats.rays.add(&r.rays);
            stats.samples += options.spp as u64 * t.pixels();
            stats.invalid += r.invalid;
            phase.advance(options.spp as u64 * t.pixels());
        },
    );
    stats.cancelled = driven.cancelled;
    stats.seconds = start.elapsed().as_secs_f64();
    phase.end(&stats.summary());
    Ok((image, stats))
}

/// The sizes of successive passes: 1, 1, 2, 4, 8, 16, 16, ... (early images come quickly,
/// later passes are long enough to keep every thread busy).
pub(crate) fn next_pass(done: u32, target: u32) -> u32 {
    done.clamp(1, 16).min(target - done)
}

/// Whether a render of `target` samples per pixel passes through `spp` whole samples (the
/// passes' sizes are fixed, so a film between passes can only hold certain counts).
pub(crate) fn reachable(spp: u32, target: u32) -> bool {
    let mut done = 0;
    while done < spp && done < target {
        done += next_pass(done, target);
    }
    done == spp
}

/// Renders with a Monte Carlo integrator in passes, continuing from `resume` (a film saved by
/// an earlier, cancelled run with the same scene and options: see [`super::checkpoint`]) if
/// given; the result is the same bit for bit as a render that was never cancelled.
/// `watch` sees the film after every whole pass (to write intermediate files or
/// checkpoints) and, if it asks, in the middle of passes; an error from it stops the
/// render. On a cancel the render returns after the tiles in hand with
/// [`RenderStats::cancelled`] set; the film then holds every tile merged.
pub(crate) fn render_passes(
    ctx: &Context,
    integrator: &dyn MonteCarlo,
    options: &ProgressiveOptions,
    resume: Option<Film>,
    watch: Watch,
    control: &Control,
) -> Result<(Film, RenderStats)> {
    let s = Samples::new(ctx, integrator, options);
    let tiles = tiles(options.width, options.height);
    let mut film = match resume {
        Some(film) => {
            if (film.width, film.height, film.filter)
                != (options.width, options.height, options.filter)
            {
                return Err(Error::Invalid(
                    "the film to resume was rendered at another size or filter".into(),
                ));
            }
            film
        }
        None => Film::new(options.width, options.height, options.filter)?,
    };
    let mut stats = RenderStats::default();
    let pixels = options.width as u64 * options.height as u64;
    let phase = control.phase(
        "render",
        options
            .time_limit
            .is_none()
            .then_some(pixels * options.spp as u64),
        "samples",
    );
    let start = Instant::now();
    phase.advance((film.mean_spp() * pixels as f64) as u64);
    // Every pass still to take, as (first sample, samples); a resumed film may be in the
    // middle of one. The passes run as one stream of tiles with no pause between them, and
    // tiles are merged in pass and image order, so a pass finished after a resume adds the
    // same numbers in the same order as an uninterrupted one.
    let mut passes = Vec::new();
    let mut done = film.spp;
    if film.is_partial_pass() {
        passes.push((done, film.pass));
        done += film.pass;
    }
    while done < options.spp {
        let n = next_pass(done, options.spp);
        passes.push((done, n));
        done += n;
    }
    let skipped = film.tiles_done as usize;
    let locate = |k: usize| ((k + skipped) / tiles.len(), (k + skipped) % tiles.len());
    let mut failure = None;
    let mut pass_start = Instant::now();
    let mut shown = Instant::now();
    let driven = drive_indexed(
        (passes.len() * tiles.len()).saturating_sub(skipped),
        options.threads,
        MERGE_WINDOW,
        &control.cancel,
        |k| {
            let (p, t) = locate(k);
            let (first, n) = passes[p];
            s.tile_pass(&tiles[t], first..first + n)
        },
        |k, r| {
            let (p, t) = locate(k);
            let (tile, n) = (&tiles[t], passes[p].1);
            film.pass = n;
            let w = tile.width();
            for (k, v) in r.sums.iter().enumerate() {
                let (x, y) = (tile.x0 + k as u32 % w, tile.y0 + k as u32 / w);
                let px = &mut film.sums[(y * options.width + x) as usize];
                px[0] += v[0];
                px[1] += v[1];
                px[2] += v[2];
            }
            for splat in &r.splats {
                film.add_splat(splat);
            }
            stats.rays.add(&r.rays);
            stats.samples += n as u64 * r.sums.len() as u64;
            film.invalid += r.invalid;
            film.tiles_done += 1;
            phase.advance(n as u64 * tile.pixels());
            if (film.tiles_done as usize) < tiles.len() {
                if watch.mid_pass.is_some_and(|d| shown.elapsed() >= d) {
                    stats.seconds = start.elapsed().as_secs_f64();
                    if let Err(e) = (watch.film)(&film, Shown::MidPass, &stats) {
                        failure = Some(e);
                        return Merge::Stop;
                    }
                    shown = Instant::now();
                }
                return Merge::Continue;
            }
            film.spp += n;
            film.pass = 0;
            film.tiles_done = 0;
            stats.seconds = start.elapsed().as_secs_f64();
            if let Err(e) = (watch.film)(&film, Shown::AfterPass, &stats) {
                failure = Some(e);
                return Merge::Stop;
            }
            shown = Instant::now();
            if let Some(limit) = options.time_limit {
                // Stop when another pass like the last one would overrun the limit.
                let elapsed = start.elapsed().as_secs_f64();
                let pass = pass_start.elapsed().as_secs_f64();
                let next = next_pass(film.spp, options.spp.max(film.spp + 1)) as f64 / n as f64;
                if elapsed + pass * next > limit {
                    return Merge::Stop;
                }
            }
            pass_start = Instant::now();
            Merge::Continue
        },
    );
    if let Some(e) = failure {
        return Err(e);
    }
    if driven.cancelled {
        stats.cancelled = true;
        if film.tiles_done == 0 {
            film.pass = 0;
        }
    }
    stats.seconds = start.elapsed().as_secs_f64();
    phase.end(&stats.summary());
    Ok((film, stats))
}
