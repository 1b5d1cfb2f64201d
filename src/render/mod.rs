//! The rendering engine: the image is cut into tiles rendered in parallel by rayon. Every
//! image sample draws from a random stream keyed by (seed, sample position), never by thread
//! or tile, so an image is the same bit for bit for any thread count and tile order.

pub mod aov;
pub mod checkpoint;
pub mod progressive;
mod sampling;

pub use sampling::{PixelSampling, DEFAULT_AA_DEPTH, DEFAULT_AA_THRESHOLD, MAX_ADAPTIVE_DEPTH};

use crate::accel::embree::set_flush_denormals;
use crate::image::Image;
use crate::integrators::{Context, Integrator, RayStats};
use crate::math::Rgb;
use crate::{Error, Result};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use std::io::IsTerminal;
use std::time::Instant;

/// Side of the square tiles the image is cut into.
pub const TILE_SIZE: u32 = 16;

#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    pub width: u32,
    pub height: u32,
    pub sampling: PixelSampling,
    /// Worker threads; `None` uses every core.
    pub threads: Option<usize>,
    pub seed: u64,
    /// Show a progress bar (only ever drawn on a terminal).
    pub progress: bool,
}

/// What a render did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    pub seconds: f64,
    pub rays: RayStats,
    /// Image samples (camera rays) taken.
    pub samples: u64,
    /// Samples whose value was NaN or infinite, dropped (counted as black).
    pub invalid: u64,
    /// The render stopped early on a signal ([`crate::interrupt`]); the image holds what
    /// was finished.
    pub interrupted: bool,
}

impl RenderStats {
    pub fn mrays_per_second(&self) -> f64 {
        self.rays.total() as f64 / self.seconds.max(1e-9) / 1e6
    }

    /// The closing summary line.
    pub fn summary(&self) -> String {
        format!(
            "rendered in {:.2} s: {} rays ({} camera samples), {:.2} Mrays/s",
            self.seconds,
            self.rays.total(),
            self.samples,
            self.mrays_per_second()
        )
    }
}

/// A rectangle of pixels, `[x0, x1) × [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

pub fn tiles(width: u32, height: u32) -> Vec<Tile> {
    (0..height.div_ceil(TILE_SIZE))
        .flat_map(|ty| {
            (0..width.div_ceil(TILE_SIZE)).map(move |tx| Tile {
                x0: tx * TILE_SIZE,
                y0: ty * TILE_SIZE,
                x1: ((tx + 1) * TILE_SIZE).min(width),
                y1: ((ty + 1) * TILE_SIZE).min(height),
            })
        })
        .collect()
}

/// The tiles of a region of the image (the image's own tiling, shifted to the region).
pub fn tiles_in(region: &Tile) -> Vec<Tile> {
    tiles(region.x1 - region.x0, region.y1 - region.y0)
        .into_iter()
        .map(|t| Tile {
            x0: region.x0 + t.x0,
            y0: region.y0 + t.y0,
            x1: region.x0 + t.x1,
            y1: region.y0 + t.y1,
        })
        .collect()
}

/// Renders the image seen by the scene's camera (at the options' resolution).
pub fn render(
    ctx: &Context,
    integrator: &dyn Integrator,
    options: &RenderOptions,
) -> Result<(Image, RenderStats)> {
    options.sampling.validate()?;
    if options.width == 0 || options.height == 0 {
        return Err(Error::Options(
            "the image needs a width and height of at least 1".into(),
        ));
    }
    let tiles = tiles(options.width, options.height);
    let (done, stats) = render_tiles(ctx, integrator, options, &tiles)?;
    let mut image = Image::new(options.width, options.height);
    for (tile, pixels) in tiles.iter().zip(done) {
        let w = tile.x1 - tile.x0;
        for (i, c) in pixels.into_iter().enumerate() {
            image.set(tile.x0 + i as u32 % w, tile.y0 + i as u32 / w, c);
        }
    }
    Ok((image, stats))
}

/// Renders `tiles` of the image in parallel: each tile's pixels (row-major), in order. On a
/// signal ([`crate::interrupt`]) the tiles not yet started are skipped: they come back empty
/// and [`RenderStats::interrupted`] is set.
pub fn render_tiles(
    ctx: &Context,
    integrator: &dyn Integrator,
    options: &RenderOptions,
    tiles: &[Tile],
) -> Result<(Vec<Vec<Rgb>>, RenderStats)> {
    let pool = thread_pool(options.threads)?;
    let progress = progress_bar(options.progress, tiles.len() as u64, "tiles");
    let start = Instant::now();
    let results: Vec<Option<sampling::TileOutput>> = pool.install(|| {
        tiles
            .par_iter()
            .map(|tile| {
                (!crate::interrupt::requested()).then(|| {
                    let result = region(ctx, integrator, options, tile);
                    progress.inc(1);
                    result
                })
            })
            .collect()
    });
    progress.finish_and_clear();

    let mut stats = RenderStats::default();
    let mut done = Vec::with_capacity(tiles.len());
    for result in results {
        let Some(out) = result else {
            stats.interrupted = true;
            done.push(Vec::new());
            continue;
        };
        stats.rays.add(&out.rays);
        stats.samples += out.samples;
        stats.invalid += out.invalid;
        done.push(out.pixels);
    }
    stats.seconds = start.elapsed().as_secs_f64();
    Ok((done, stats))
}

/// Renders the pixels of one rectangle (row-major); [`render`] renders each of its tiles
/// with this, and a pixel's value does not depend on the tiling. Returns the pixels, rays traced and samples.
pub fn render_region(
    ctx: &Context,
    integrator: &dyn Integrator,
    options: &RenderOptions,
    tile: &Tile,
) -> (Vec<Rgb>, RayStats, u64) {
    let out = region(ctx, integrator, options, tile);
    (out.pixels, out.rays, out.samples)
}

fn region(
    ctx: &Context,
    integrator: &dyn Integrator,
    options: &RenderOptions,
    tile: &Tile,
) -> sampling::TileOutput {
    let mut camera = ctx.scene.camera.clone();
    camera.width = options.width;
    camera.height = options.height;
    let basis = camera.basis();
    sampling::render_tile(
        ctx,
        integrator,
        &basis,
        &options.sampling,
        options.seed,
        tile,
    )
}

/// The render threads: `None` uses every core; each thread flushes denormals to zero.
pub(crate) fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .start_handler(|_| set_flush_denormals())
        .build()
        .map_err(|e| Error::Options(format!("cannot start render threads: {e}")))
}

/// A progress bar over `total` units (a spinner when the total is unknown, i.e. 0).
fn progress_bar(wanted: bool, total: u64, unit: &str) -> ProgressBar {
    if !wanted || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    if total == 0 {
        return ProgressBar::new_spinner();
    }
    let bar = ProgressBar::new(total);
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{{spinner}} [{{elapsed_precise}}] {{wide_bar}} {{pos}}/{{len}} {unit}, ETA {{eta}}"
        ))
        .expect("the progress template is valid"),
    );
    bar
}
