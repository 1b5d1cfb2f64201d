//! The Monte Carlo render loop: whole sample passes over the image until the sample count or
//! the time limit is reached. Sample `i` of pixel (x, y) always draws the same sample values
//! (keyed by seed, pixel and `i`), each tile sums its samples in pixel and index order, and
//! tiles (their camera samples splatted over their neighbours' pixels, and light paths'
//! splats) are merged in pass and tile order, so the image is the same bit for bit for any
//! thread count. A part of the image takes the tiles that reach it in the same order, so
//! it gets the same bits too.

use super::film::{pixel_value, weighted_value, Footprint};
use super::{place, tiles, tiles_in, Film, RenderStats, Shown, Tile, Watch, MERGE_WINDOW};
use crate::control::Control;
use crate::error::{Error, Result};
use crate::guiding::{Deposit, Guidance, Guide, Learning};
use crate::image::filter::Reconstruction;
use crate::image::Image;
use crate::math::{Rgb, Vec3};
use crate::scene::camera::CameraBasis;
use crate::transport::camera_sample::{camera_sample, view_basis, PixelJitter, Splatting};
use crate::transport::driver::{drive, drive_indexed, Merge};
use crate::transport::passes::{next_pass, passes_between, MAX_PASS};
use crate::transport::ProgressiveOptions;
use crate::transport::{Context, IterationStart, IterationWork, MonteCarlo, RayStats, Splat};
use std::time::Instant;

/// What one tile produced in one pass.
struct TileResult {
    /// Its camera samples: over the tile itself (no weights), or splatted over the pixels
    /// they reach.
    camera: Footprint,
    splats: Vec<Splat>,
    /// With per-pixel statistics (adaptive sampling, or kept for the variance layers): per
    /// pixel of the tile (row-major), the sums of its samples' squares, and when samples
    /// are splatted, the sums of its own samples.
    squares: Vec<[f64; 3]>,
    own_sums: Vec<[f64; 3]>,
    /// With path guiding, in a pass that learns: what its samples deposited, in order.
    deposits: Vec<Deposit>,
    rays: RayStats,
    invalid: u64,
}

impl TileResult {
    /// An empty result for `tile`'s samples, received by the pixels of `bounds`.
    fn new(tile: &Tile, splat: Option<&Splatting>, bounds: &Tile) -> TileResult {
        let camera = match splat {
            Some(s) => Footprint::new(tile, s.reach, bounds),
            None => Footprint {
                rect: *tile,
                sums: Vec::with_capacity(tile.pixels() as usize),
                weights: Vec::new(),
            },
        };
        TileResult {
            camera,
            splats: Vec::new(),
            squares: Vec::new(),
            own_sums: Vec::new(),
            deposits: Vec::new(),
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
    jitter: PixelJitter,
    /// Whether anything moves during the exposure (else rays need no shutter time).
    moving: bool,
    /// Samples and splats are scaled down so that no channel exceeds this.
    max_component_value: Option<f32>,
    /// Whether each pixel's sample statistics are kept (adaptive sampling, or the
    /// variance layers): the sums of squares, and of the pixel's own samples when they are
    /// splatted.
    statistics: bool,
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
            seed: options.view.seed,
            jitter: PixelJitter::new(options.filter, options.reconstruction),
            moving: ctx.scene.moves(),
            max_component_value: options.max_component_value,
            statistics: options.statistics || options.adaptive.is_some(),
        }
    }

    /// `l` scaled down so that no channel exceeds the clamp, as pbrt-v4 clamps.
    fn clamped(&self, l: Rgb) -> Rgb {
        match self.max_component_value {
            Some(m) if l.max_element() > m => l * (m / l.max_element()),
            _ => l,
        }
    }

    /// The sum of the estimates of samples `samples` of pixel `(x, y)`: what one pass adds
    /// to the pixel (when samples are splatted they go to `result`'s footprint, and the sum
    /// is only kept with statistics). Splats, rays and dropped samples go to `result`; the
    /// sum of the estimates' squares to `squares`. With `guidance`, samples are guided.
    fn pixel_pass(
        &self,
        integrator: &dyn MonteCarlo,
        (x, y): (u32, u32),
        samples: std::ops::Range<u32>,
        result: &mut TileResult,
        squares: &mut [f64; 3],
        mut guidance: Option<&mut Guidance>,
    ) -> [f64; 3] {
        let mut sum = [0.0f64; 3];
        for i in samples {
            let (mut sampler, ray, at) = camera_sample(
                &self.camera,
                self.seed,
                &self.jitter,
                self.moving,
                (x, y),
                i,
            );
            let before = result.splats.len();
            let l = match guidance.as_deref_mut() {
                Some(g) => integrator.sample_guided(
                    self.ctx,
                    &self.camera,
                    &ray,
                    &mut sampler,
                    &mut result.rays,
                    &mut result.splats,
                    g,
                ),
                None => integrator.sample(
                    self.ctx,
                    &self.camera,
                    &ray,
                    &mut sampler,
                    &mut result.rays,
                    &mut result.splats,
                ),
            };
            let l = self.clamped(l);
            for s in &mut result.splats[before..] {
                s.value = self.clamped(s.value);
            }
            let splats_ok = result.splats[before..]
                .iter()
                .all(|s| s.value.is_finite() && s.x.is_finite() && s.y.is_finite());
            if !l.is_finite() || !splats_ok {
                // A numerical failure on one sample must not poison the pixel.
                result.splats.truncate(before);
                result.invalid += 1;
                if let Some(s) = self.jitter.splatting() {
                    result.camera.add(&s.weights, at, None);
                }
                continue;
            }
            if let Some(s) = self.jitter.splatting() {
                result.camera.add(&s.weights, at, Some(l));
                if !self.statistics {
                    continue;
                }
            }
            let l = [l.x as f64, l.y as f64, l.z as f64];
            for c in 0..3 {
                sum[c] += l[c];
                squares[c] += l[c] * l[c];
            }
        }
        sum
    }

    /// One pass of `samples` over a tile, whose splatted samples reach the pixels of
    /// `bounds` only. With adaptive sampling, only the pixels `active` (row-major over an
    /// image `width` wide) take samples. With statistics, the pixels' sums of squares (and
    /// of their own samples, when splatted) are kept. With a guide the samples are guided,
    /// and deposit into it if the pass learns.
    fn tile_pass(
        &self,
        integrator: &dyn MonteCarlo,
        tile: &Tile,
        samples: std::ops::Range<u32>,
        bounds: &Tile,
        active: Option<(&[bool], u32)>,
        guide: Option<(&Guide, bool)>,
    ) -> TileResult {
        let splatting = self.jitter.splatting();
        let mut result = TileResult::new(tile, splatting, bounds);
        let mut guidance = guide.map(|(guide, learns)| Guidance {
            guide,
            deposits: learns.then(Vec::new),
        });
        for y in tile.y0..tile.y1 {
            for x in tile.x0..tile.x1 {
                let mut squares = [0.0; 3];
                let sum = match active {
                    Some((a, width)) if !a[(y * width + x) as usize] => [0.0; 3],
                    _ => self.pixel_pass(
                        integrator,
                        (x, y),
                        samples.clone(),
                        &mut result,
                        &mut squares,
                        guidance.as_mut(),
                    ),
                };
                if splatting.is_none() {
                    result.camera.sums.push(sum);
                } else if self.statistics {
                    result.own_sums.push(sum);
                }
                if self.statistics {
                    result.squares.push(squares);
                }
            }
        }
        if let Some(deposits) = guidance.and_then(|g| g.deposits) {
            result.deposits = deposits;
        }
        result
    }

    /// Every one of `spp` samples of a tile, pass by pass as a whole render takes them, for
    /// an integrator that splats nothing: the tile's pixels (row-major), the rays and the
    /// dropped samples.
    fn tile_all_passes(&self, tile: &Tile, spp: u32, pixels_in_image: f64) -> TileResult {
        let per_sample = 1.0 / spp as f64;
        let per_path = per_sample / pixels_in_image;
        let mut result = TileResult::new(tile, None, tile);
        let passes = passes_between(0, spp, MAX_PASS);
        for y in tile.y0..tile.y1 {
            for x in tile.x0..tile.x1 {
                let mut total = [0.0f64; 3];
                for &(first, n) in &passes {
                    let s = self.pixel_pass(
                        self.integrator,
                        (x, y),
                        first..first + n,
                        &mut result,
                        &mut [0.0; 3],
                        None,
                    );
                    for c in 0..3 {
                        total[c] += s[c];
                    }
                }
                let v = pixel_value(total, [0.0; 3], per_sample, per_path);
                result
                    .camera
                    .sums
                    .push([v.x as f64, v.y as f64, v.z as f64]);
            }
        }
        result
    }
}

/// The pixels of one tile (row-major) with all `options.spp` samples, exactly as
/// [`render_passes`] (without a time limit) renders them, for an integrator that splats
/// nothing (the path tracer) and samples that count in their own pixel alone
/// ([`Reconstruction::Importance`]): the pixels, the rays and the dropped samples.
pub(crate) fn render_tile(
    ctx: &Context,
    integrator: &dyn MonteCarlo,
    options: &ProgressiveOptions,
    tile: &Tile,
) -> (Vec<Rgb>, RayStats, u64) {
    debug_assert_eq!(options.reconstruction, Reconstruction::Importance);
    let s = Samples::new(ctx, integrator, options);
    let r = s.tile_all_passes(
        tile,
        options.spp,
        options.view.width as f64 * options.view.height as f64,
    );
    let pixels = r
        .camera
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
    crate::transport::settings::refuse_for_parts(
        options.time_limit,
        options.adaptive,
        integrator.guided(),
    )?;
    if options.reconstruction == Reconstruction::Splat {
        return render_region_splatted(ctx, integrator, options, region, control);
    }
    let s = Samples::new(ctx, integrator, options);
    let pixels_in_image = options.view.width as f64 * options.view.height as f64;
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
        options.view.threads,
        MERGE_WINDOW,
        &control.cancel,
        |t| s.tile_all_passes(t, options.spp, pixels_in_image),
        |i, r| {
            let t = &tiles[i];
            let pixels = r
                .camera
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

/// [`render_region`] with splatted samples: the image's own tiles that reach the region
/// (cut to the pixels whose samples reach it), pass by pass in the order the whole render
/// takes them, so that every pixel of the region adds the same numbers in the same order.
fn render_region_splatted(
    ctx: &Context,
    integrator: &dyn MonteCarlo,
    options: &ProgressiveOptions,
    region: &Tile,
    control: &Control,
) -> Result<(Image, RenderStats)> {
    let s = Samples::new(ctx, integrator, options);
    let reach = s.jitter.splatting().map_or(0, |s| s.reach);
    let whole = Tile::whole(options.view.width, options.view.height);
    let reaching = region.grown(reach, &whole);
    let tiles: Vec<Tile> = tiles(options.view.width, options.view.height)
        .iter()
        .filter_map(|t| t.intersection(&reaching))
        .collect();
    let passes = passes_between(0, options.spp, MAX_PASS);
    let phase = control.phase(
        "render",
        Some(region.pixels() * options.spp as u64),
        "samples",
    );
    let start = Instant::now();
    // The region's own accumulators, as the whole film's would be over its pixels.
    let mut film = Footprint::try_over(*region)?;
    let mut stats = RenderStats::default();
    let driven = drive_indexed(
        passes.len() * tiles.len(),
        options.view.threads,
        MERGE_WINDOW,
        &control.cancel,
        |k| {
            let (first, n) = passes[k / tiles.len()];
            s.tile_pass(
                s.integrator,
                &tiles[k % tiles.len()],
                first..first + n,
                region,
                None,
                None,
            )
        },
        |k, r| {
            let (t, n) = (&tiles[k % tiles.len()], passes[k / tiles.len()].1);
            film.absorb(&r.camera);
            stats.rays.add(&r.rays);
            stats.samples += n as u64 * t.pixels();
            stats.invalid += r.invalid;
            if let Some(inside) = t.intersection(region) {
                phase.advance(n as u64 * inside.pixels());
            }
            Merge::Continue
        },
    );
    // The film is row-major over the region, as the image is.
    let mut image = Image::try_new(region.width(), region.height())?;
    for (px, (sum, weight)) in image
        .pixels
        .iter_mut()
        .zip(film.sums.iter().zip(&film.weights))
    {
        *px = weighted_value(*sum, *weight, [0.0; 3], 0.0);
    }
    stats.cancelled = driven.cancelled;
    stats.seconds = start.elapsed().as_secs_f64();
    phase.end(&stats.summary());
    Ok((image, stats))
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
    if integrator.guided() && resume.is_some() {
        return Err(Error::setting(
            "guiding",
            "cannot resume a render: a checkpoint does not keep the guide",
        ));
    }
    let s = Samples::new(ctx, integrator, options);
    let tiles = tiles(options.view.width, options.view.height);
    // A technique whose sample indices are iterations over the whole image takes them one
    // a pass, each pass through its iteration.
    let iterative = integrator.iterative();
    let max_pass = if iterative { 1 } else { MAX_PASS };
    if iterative && options.adaptive.is_some() {
        return Err(Error::setting(
            "adaptive",
            "does not apply to techniques whose samples are iterations over the whole image",
        ));
    }
    let mut film = match resume {
        Some(film) => {
            if (film.width, film.height, film.filter, film.reconstruction)
                != (
                    options.view.width,
                    options.view.height,
                    options.filter,
                    options.reconstruction,
                )
            {
                return Err(Error::Invalid(
                    "the film to resume was rendered at another size or filter".into(),
                ));
            }
            film
        }
        None => Film::new(
            options.view.width,
            options.view.height,
            options.filter,
            options.reconstruction,
        )?
        .with_adaptive(options.adaptive)?
        .with_statistics(options.statistics)?
        .with_one_sample_passes(iterative),
    };
    if film.max_pass != max_pass {
        return Err(Error::Invalid(
            "the film to resume was rendered by a technique with other passes".into(),
        ));
    }
    if film.adaptive() != options.adaptive {
        return Err(Error::Invalid(
            "the film to resume was rendered with other adaptive sampling".into(),
        ));
    }
    if film.has_statistics() != (options.statistics || options.adaptive.is_some()) {
        return Err(Error::Invalid(
            "the film to resume was rendered with other per-pixel sample statistics".into(),
        ));
    }
    let mut stats = RenderStats::default();
    let pixels = options.view.width as u64 * options.view.height as u64;
    let phase = control.phase(
        "render",
        (options.time_limit.is_none() && options.adaptive.is_none())
            .then_some(pixels * options.spp as u64),
        "samples",
    );
    let start = Instant::now();
    phase.advance((film.mean_spp() * pixels as f64) as u64);
    // Every pass still to take, as (first sample, samples); a resumed film may be in the
    // middle of one. The passes run as one stream of tiles with no pause between them, and
    // tiles are merged in pass and image order, so a pass finished after a resume adds the
    // same numbers in the same order as an uninterrupted one. With adaptive sampling each
    // pass waits for the one before, which decides the pixels it samples.
    let mut passes = Vec::new();
    let mut done = film.spp;
    if film.is_partial_pass() {
        passes.push((done, film.pass));
        done += film.pass;
    }
    passes.extend(passes_between(done, options.spp, max_pass));
    // With path guiding, the guide is learned from the samples up to each of its builds
    // and sampled from by the next ones.
    let mut learning = integrator.guided().then(|| {
        let bounds = ctx.scene.bounds().unwrap_or((Vec3::ZERO, Vec3::ONE));
        Learning::new(bounds, options.spp)
    });
    // As (first pass, passes): a pass ends its group when the next depends on it. An
    // iterative technique's passes go in groups of the iterations it may hold at once.
    let together = integrator
        .iterations_together((options.view.width, options.view.height))
        .max(1);
    let groups = group_passes(&passes, |end| {
        (iterative && end % together == 0)
            || film.adaptive().is_some()
            || learning.as_ref().is_some_and(|l| l.builds_at(end))
    });
    let whole = Tile::whole(options.view.width, options.view.height);
    let width = options.view.width;
    let mut failure = None;
    let mut ended = false;
    let mut cancelled = false;
    let mut pass_start = Instant::now();
    let mut shown = Instant::now();
    for (group_start, group_len) in groups {
        // Only the first pass may have tiles done already.
        let skipped = if group_start == 0 {
            film.tiles_done as usize
        } else {
            0
        };
        let locate = |k: usize| {
            (
                group_start + (k + skipped) / tiles.len(),
                (k + skipped) % tiles.len(),
            )
        };
        let active = film.active().map(<[bool]>::to_vec);
        // The guide stays the same through the group.
        let guide = learning
            .as_ref()
            .map(|l| (l.guide(), l.learns_at(passes[group_start].0)));
        // The integrators taking each pass's samples (one for every pass of the group, or
        // the same for all) and what their iterations gave the image besides.
        let mut run = |its: &[&dyn MonteCarlo], works: Vec<IterationWork>| {
            let mut works: Vec<Option<IterationWork>> = works.into_iter().map(Some).collect();
            drive_indexed(
                (group_len * tiles.len()).saturating_sub(skipped),
                options.view.threads,
                MERGE_WINDOW,
                &control.cancel,
                |k| {
                    let (p, t) = locate(k);
                    let (first, n) = passes[p];
                    let active = active.as_deref().map(|a| (a, width));
                    let guide = guide.as_ref().map(|(g, learns)| (&**g, *learns));
                    let it = its[(p - group_start).min(its.len() - 1)];
                    s.tile_pass(it, &tiles[t], first..first + n, &whole, active, guide)
                },
                |k, r| {
                    let (p, t) = locate(k);
                    let (tile, n) = (&tiles[t], passes[p].1);
                    // An iteration's own splats come with its first tile (a pass resumed
                    // after it has them already).
                    let work = works.get_mut(p - group_start).and_then(Option::take);
                    if let Some(w) = work.filter(|_| t == 0) {
                        for splat in &w.splats {
                            film.add_splat(splat);
                        }
                        stats.rays.add(&w.rays);
                    }
                    film.pass = n;
                    film.add_camera(&r.camera);
                    film.add_statistics(tile, n, (&r.squares, &r.own_sums));
                    for splat in &r.splats {
                        film.add_splat(splat);
                    }
                    stats.rays.add(&r.rays);
                    let sampled = match &active {
                        Some(a) => n as u64 * count_active(a, width, tile),
                        None => n as u64 * tile.pixels(),
                    };
                    stats.samples += sampled;
                    film.invalid += r.invalid;
                    film.tiles_done += 1;
                    if let Some(l) = learning.as_mut() {
                        l.absorb(&r.deposits);
                    }
                    phase.advance(sampled);
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
                    // Adaptive sampling stops the pixels that have converged; when none is left
                    // the render is done.
                    let going_on = film.end_adaptive_pass();
                    stats.seconds = start.elapsed().as_secs_f64();
                    if let Err(e) = (watch.film)(&film, Shown::AfterPass, &stats) {
                        failure = Some(e);
                        return Merge::Stop;
                    }
                    shown = Instant::now();
                    if !going_on {
                        ended = true;
                        return Merge::Stop;
                    }
                    if let Some(limit) = options.time_limit {
                        // Stop when another pass like the last one would overrun the limit.
                        let elapsed = start.elapsed().as_secs_f64();
                        let pass = pass_start.elapsed().as_secs_f64();
                        let next = next_pass(film.spp, options.spp.max(film.spp + 1), max_pass)
                            as f64
                            / n as f64;
                        if elapsed + pass * next > limit {
                            ended = true;
                            return Merge::Stop;
                        }
                    }
                    pass_start = Instant::now();
                    Merge::Continue
                },
            )
            .cancelled
        };
        let driven_cancelled = if iterative {
            let start = IterationStart {
                camera: &s.camera,
                seed: options.view.seed,
                size: (options.view.width, options.view.height),
                index: passes[group_start].0,
                threads: options.view.threads,
                cancel: &control.cancel,
            };
            let mut stopped = true;
            let count = group_len as u32;
            let ran = integrator.iterations(ctx, &start, count, &mut |its, works| {
                stopped = run(its, works)
            });
            !ran || stopped
        } else {
            run(&[integrator], Vec::new())
        };
        if driven_cancelled {
            cancelled = true;
        }
        if cancelled || ended || failure.is_some() {
            break;
        }
        if let Some(l) = learning.as_mut().filter(|l| l.builds_at(film.spp)) {
            l.build(film.spp);
        }
    }
    if let Some(e) = failure {
        return Err(e);
    }
    if cancelled {
        stats.cancelled = true;
        if film.tiles_done == 0 {
            film.pass = 0;
        }
    }
    stats.seconds = start.elapsed().as_secs_f64();
    phase.end(&stats.summary());
    Ok((film, stats))
}

/// `passes` (as (first sample, samples)) in groups, as (first pass, passes): a pass after
/// which `ends_group(samples per pixel then)` is true ends its group.
fn group_passes(passes: &[(u32, u32)], ends_group: impl Fn(u32) -> bool) -> Vec<(usize, usize)> {
    let mut groups = Vec::new();
    let mut start = 0;
    for (p, &(first, n)) in passes.iter().enumerate() {
        if ends_group(first + n) || p + 1 == passes.len() {
            groups.push((start, p + 1 - start));
            start = p + 1;
        }
    }
    groups
}

/// How many of `tile`'s pixels are `active` (row-major over an image `width` wide).
fn count_active(active: &[bool], width: u32, tile: &Tile) -> u64 {
    (tile.y0..tile.y1)
        .map(|y| {
            let row = (y * width) as usize;
            active[row + tile.x0 as usize..row + tile.x1 as usize]
                .iter()
                .filter(|a| **a)
                .count() as u64
        })
        .sum()
}
