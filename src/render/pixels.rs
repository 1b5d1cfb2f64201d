//! One-pass rendering: each pixel's value from its own samples (Whitted's adaptive corner
//! subdivision or uniform supersampling), for the techniques that give radiance along a
//! camera ray (Whitted, the illumination network).

use super::small_objects::SmallObjects;
use super::{place, sampling, tiles_in, PixelSampling, RenderStats, Tile, MERGE_WINDOW};
use crate::control::Control;
use crate::image::Image;
use crate::math::Rgb;
use crate::scene::camera::CameraBasis;
use crate::transport::driver::drive;
use crate::transport::{Context, Integrator, RayStats, View};
use std::time::Instant;

/// A one-pass render: the view and how each pixel is sampled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PixelView {
    pub view: View,
    pub sampling: PixelSampling,
}

/// Renders the pixels of `region` of the image (the whole image or a part of it: a pixel's
/// value does not depend on which others are rendered with it). Returns the region's image.
/// A cancel leaves the tiles not merged black, and marks the statistics. The image that
/// cannot be allocated is an [`Error::OutOfMemory`](crate::error::Error::OutOfMemory).
pub(crate) fn render_pixels(
    ctx: &Context,
    integrator: &dyn Integrator,
    view: &PixelView,
    region: &Tile,
    control: &Control,
) -> crate::error::Result<(Image, RenderStats)> {
    let tiles = tiles_in(region);
    let phase = control.phase("render", Some(region.pixels()), "pixels");
    let start = Instant::now();
    let mut image = Image::try_new(region.width(), region.height())?;
    let mut stats = RenderStats::default();
    let small = view.small_objects(ctx);
    let driven = drive(
        &tiles,
        view.view.threads,
        MERGE_WINDOW,
        &control.cancel,
        |tile| render_tile(ctx, integrator, view, &small, tile),
        |i, out| {
            place(&mut image, (region.x0, region.y0), &tiles[i], out.pixels);
            stats.rays.add(&out.rays);
            stats.samples += out.samples;
            stats.invalid += out.invalid;
            phase.advance(tiles[i].pixels());
        },
    );
    stats.cancelled = driven.cancelled;
    stats.seconds = start.elapsed().as_secs_f64();
    phase.end(&stats.summary());
    Ok((image, stats))
}

impl PixelView {
    /// The camera of `ctx`'s scene at this view's size.
    fn camera(&self, ctx: &Context) -> CameraBasis {
        let mut camera = ctx.scene.camera.clone();
        camera.width = self.view.width;
        camera.height = self.view.height;
        camera.basis()
    }

    /// The objects smaller than a pixel that the adaptive sampler must look for between
    /// corners (none for uniform supersampling).
    pub fn small_objects(&self, ctx: &Context) -> SmallObjects {
        match self.sampling {
            PixelSampling::Adaptive { max_depth, .. } if max_depth > 0 => {
                SmallObjects::new(ctx.scene, &self.camera(ctx))
            }
            _ => SmallObjects::none(),
        }
    }
}

/// The pixels of one tile (row-major), the rays traced and the samples taken; `small` is
/// [`PixelView::small_objects`] of the same scene and view.
pub(crate) fn render_tile(
    ctx: &Context,
    integrator: &dyn Integrator,
    view: &PixelView,
    small: &SmallObjects,
    tile: &Tile,
) -> TilePixels {
    let out = sampling::render_tile(
        ctx,
        integrator,
        &view.camera(ctx),
        &view.sampling,
        view.view.seed,
        small,
        tile,
    );
    TilePixels {
        pixels: out.pixels,
        rays: out.rays,
        samples: out.samples,
        invalid: out.invalid,
    }
}

/// What one tile produced.
pub(crate) struct TilePixels {
    pub pixels: Vec<Rgb>,
    pub rays: RayStats,
    pub samples: u64,
    pub invalid: u64,
}
