//! The rendering engine: the image is cut into tiles that the one tile driver
//! ([`driver`]) renders in parallel. Every image sample draws from a random stream keyed by
//! (seed, sample position), never by thread or tile, and results are merged in tile order, so
//! an image is the same bit for bit for any thread count and schedule.

pub(crate) mod aov;
pub mod checkpoint;
pub(crate) mod driver;
mod film;
pub(crate) mod passes;
pub(crate) mod pixels;
pub(crate) mod progressive;
mod sampling;
pub(crate) mod small_objects;
mod watch;

pub use film::Film;
pub use sampling::{PixelSampling, DEFAULT_AA_DEPTH, DEFAULT_AA_THRESHOLD};
pub use watch::{Shown, Watch};

use crate::integrators::RayStats;

/// Side of the square tiles the image is cut into.
pub const TILE_SIZE: u32 = 16;

/// What a render did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Seconds rendering the image's tiles.
    pub seconds: f64,
    /// Seconds the technique spent preparing before the first tile (the irradiance
    /// cache's overture, the network's transport), 0 for techniques with nothing to prepare
    /// or a renderer prepared by an earlier render.
    pub prepare_seconds: f64,
    pub rays: RayStats,
    /// Image samples (camera rays) taken.
    pub samples: u64,
    /// Samples whose value was NaN or infinite, dropped (counted as black).
    pub invalid: u64,
    /// The render was cancelled before it finished; the image holds what was finished.
    pub cancelled: bool,
}

impl RenderStats {
    pub fn mrays_per_second(&self) -> f64 {
        self.rays.total() as f64 / self.seconds.max(1e-9) / 1e6
    }

    /// A one-line summary: the whole time, preparation included, then the image's rays.
    pub fn summary(&self) -> String {
        let time = if self.prepare_seconds > 0.0 {
            format!(
                "{:.2} s ({:.2} s preparing, {:.2} s the image)",
                self.prepare_seconds + self.seconds,
                self.prepare_seconds,
                self.seconds
            )
        } else {
            format!("{:.2} s", self.seconds)
        };
        format!(
            "rendered in {time}: {} rays ({} camera samples), {:.2} Mrays/s",
            self.rays.total(),
            self.samples,
            self.mrays_per_second()
        )
    }
}

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

/// Results merged per tile, at most this many tiles ahead of the slowest (bounds the memory
/// finished tiles hold while they wait to be merged in order).
pub(crate) const MERGE_WINDOW: usize = 64;

/// Copies a tile's pixels (row-major) into `image`, whose top-left pixel is `origin`.
pub(crate) fn place(
    image: &mut crate::image::Image,
    origin: (u32, u32),
    tile: &Tile,
    pixels: impl IntoIterator<Item = crate::math::Rgb>,
) {
    let w = tile.width();
    for (i, c) in pixels.into_iter().enumerate() {
        let (x, y) = (tile.x0 + i as u32 % w, tile.y0 + i as u32 / w);
        image.set(x - origin.0, y - origin.1, c);
    }
}
