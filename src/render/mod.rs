//! The render loops: the image is cut into tiles that the one tile driver
//! (`crate::transport::driver`) renders in parallel. Every image sample draws from a random stream keyed by
//! (seed, sample position), never by thread or tile, and results are merged in tile order, so
//! an image is the same bit for bit for any thread count and schedule.

mod adaptive;
pub(crate) mod aov;
pub mod checkpoint;
mod film;
pub(crate) mod light_passes;
pub(crate) mod pixels;
pub(crate) mod progressive;
mod sampling;
pub(crate) mod small_objects;
mod watch;
pub(crate) mod whole;

pub use film::Film;
pub use watch::{Shown, Watch};

pub(crate) use crate::transport::driver::MERGE_WINDOW;
use crate::transport::RayStats;
pub use crate::transport::{tiles, tiles_in, PixelSampling, Tile, TILE_SIZE};

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
