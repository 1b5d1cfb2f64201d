//! The view a job renders: the image's size and tiles, the part of it rendered, the seed and
//! threads, and the Monte Carlo view the progressive passes sample.

use crate::accel::Backend;
use crate::image::filter::{Filter, Reconstruction};
use crate::transport::technique::MonteCarloSettings;

/// Side of the square tiles the image is cut into.
pub const TILE_SIZE: u32 = 16;

/// A rectangle of pixels, `[x0, x1) × [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Tile {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl Tile {
    /// The whole `width` × `height` image.
    pub fn whole(width: u32, height: u32) -> Tile {
        Tile {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }

    pub fn pixels(&self) -> u64 {
        self.width() as u64 * self.height() as u64
    }

    /// This rectangle grown by `by` pixels on every side, within `bounds`.
    pub(crate) fn grown(&self, by: u32, bounds: &Tile) -> Tile {
        Tile {
            x0: self.x0.saturating_sub(by).max(bounds.x0),
            y0: self.y0.saturating_sub(by).max(bounds.y0),
            x1: (self.x1 + by).min(bounds.x1),
            y1: (self.y1 + by).min(bounds.y1),
        }
    }

    /// The pixels this rectangle shares with `other`, if any.
    pub(crate) fn intersection(&self, other: &Tile) -> Option<Tile> {
        let t = Tile {
            x0: self.x0.max(other.x0),
            y0: self.y0.max(other.y0),
            x1: self.x1.min(other.x1),
            y1: self.y1.min(other.y1),
        };
        (t.x0 < t.x1 && t.y0 < t.y1).then_some(t)
    }
}

/// The image's tiles, row by row.
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
    tiles(region.width(), region.height())
        .into_iter()
        .map(|t| Tile {
            x0: region.x0 + t.x0,
            y0: region.y0 + t.y0,
            x1: region.x0 + t.x1,
            y1: region.y0 + t.y1,
        })
        .collect()
}

/// The view a job renders: its size, its part of the image, its random streams, its
/// threads and its intersection backend. The one declaration of it below the job: what a
/// technique's preparation reads, and the first half of a one-pass ([`PixelView`]) or Monte
/// Carlo ([`ProgressiveOptions`]) render's options.
///
/// [`PixelView`]: crate::render::pixels::PixelView
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct View {
    pub width: u32,
    pub height: u32,
    /// Only these pixels (a part of the image), if any.
    pub region: Option<Tile>,
    pub seed: u64,
    pub threads: Option<usize>,
    pub accel: Backend,
}

impl View {
    /// The whole `width` x `height` image, seed 0, every core, the default backend.
    pub(crate) fn new(width: u32, height: u32) -> View {
        View {
            width,
            height,
            region: None,
            seed: 0,
            threads: None,
            accel: Backend::default(),
        }
    }

    /// The Monte Carlo render of this view with `mc`'s samples and filter.
    pub(crate) fn progressive(&self, mc: &MonteCarloSettings) -> ProgressiveOptions {
        ProgressiveOptions {
            view: *self,
            spp: mc.spp,
            time_limit: mc.time_limit,
            filter: mc.filter,
            reconstruction: mc.reconstruction,
            adaptive: mc.adaptive,
            max_component_value: mc.max_component_value,
            statistics: false,
        }
    }
}

/// A Monte Carlo render: the view and how it is sampled.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ProgressiveOptions {
    pub view: View,
    /// Samples per pixel; with a time limit, the most that will be taken.
    pub spp: u32,
    /// Stop after the last whole pass that fits in this many seconds.
    pub time_limit: Option<f64>,
    pub filter: Filter,
    pub reconstruction: Reconstruction,
    /// Adaptive sampling, if on.
    pub adaptive: Option<crate::transport::settings::AdaptiveSampling>,
    /// Samples scaled down so that no channel exceeds this.
    pub max_component_value: Option<f32>,
    /// Keep each pixel's sample statistics (count, sums of squares) for the variance and
    /// error layers, without adaptive sampling (which keeps them anyway).
    pub statistics: bool,
}
