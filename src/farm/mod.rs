//! Rendering beyond one machine: a render job renders one part of the image (`--tile I/N`
//! or `--crop x0,y0,x1,y1`) and writes it as an OpenEXR file whose data window is that part
//! of the full image (its display window), with the metadata [`merge`] needs to check that
//! parts fit together. A pixel's value depends only on (scene, options, seed, pixel), never
//! on which other pixels are rendered with it (see the tile driver), so merged parts equal
//! the whole render bit for bit. docs/farm.md describes the workflow and the Slurm example.

pub mod merge;

use crate::error::{Error, Result};
use crate::image::Image;
use crate::render::Tile;

/// Metadata attribute: the [`scene_hash`] of the scene rendered, as 16 hex digits.
pub const META_SCENE_HASH: &str = "raylink:scene_hash";
/// Metadata attribute: every setting that changes pixels, as one string (see
/// `raylink render`); tiles merge only if theirs are equal.
pub const META_SETTINGS: &str = "raylink:settings";
/// Metadata attribute of a part: `"I/N"` for `--tile I/N`, absent for `--crop`.
pub const META_TILE: &str = "raylink:tile";
/// Metadata attribute of a part: its pixel bounds `"x0,y0,x1,y1"` (half-open).
pub const META_REGION: &str = "raylink:region";

/// Which part of the image a job renders.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// Band `index` of `count` horizontal bands of (nearly) equal height.
    Tile { index: u32, count: u32 },
    /// Pixel bounds `[x0, x1) × [y0, y1)`.
    Crop(Tile),
}

impl Part {
    /// The pixels of the part in a `width` × `height` image; an error if it does not fit.
    pub fn region(&self, width: u32, height: u32) -> Result<Tile> {
        match *self {
            Part::Tile { index, count } => {
                if count > height {
                    return Err(Error::setting(
                        "tile",
                        format!(
                            "{index}/{count}: the image has only {height} rows, so at most \
                             {height} tiles"
                        ),
                    ));
                }
                Ok(band(index, count, width, height))
            }
            Part::Crop(t) => {
                if t.x1 > width || t.y1 > height {
                    return Err(Error::setting(
                        "crop",
                        format!(
                            "{},{},{},{} reaches outside the {width}x{height} image",
                            t.x0, t.y0, t.x1, t.y1
                        ),
                    ));
                }
                Ok(t)
            }
        }
    }

    /// `"I/N"` for a tile.
    pub fn tile_label(&self) -> Option<String> {
        match *self {
            Part::Tile { index, count } => Some(format!("{index}/{count}")),
            Part::Crop(_) => None,
        }
    }
}

/// Band `index` of `count`: rows `[index·H/N, (index+1)·H/N)`, the whole width.
pub fn band(index: u32, count: u32, width: u32, height: u32) -> Tile {
    let row = |i: u32| (i as u64 * height as u64 / count as u64) as u32;
    Tile {
        x0: 0,
        y0: row(index),
        x1: width,
        y1: row(index + 1),
    }
}

/// `"x0,y0,x1,y1"`.
pub fn region_label(t: &Tile) -> String {
    format!("{},{},{},{}", t.x0, t.y0, t.x1, t.y1)
}

pub use crate::scene::scene_hash;

/// The pixels of `region` of `image`.
pub fn crop(image: &Image, region: &Tile) -> Image {
    let mut out = Image::new(region.x1 - region.x0, region.y1 - region.y0);
    for y in region.y0..region.y1 {
        for x in region.x0..region.x1 {
            out.set(x - region.x0, y - region.y0, image.get(x, y));
        }
    }
    out
}

/// The window of `region` in a `width` × `height` image.
pub fn window(region: &Tile, width: u32, height: u32) -> crate::image::io::Window {
    crate::image::io::Window {
        x: region.x0 as i32,
        y: region.y0 as i32,
        full_x: 0,
        full_y: 0,
        full_width: width,
        full_height: height,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_cover_the_rows_once() {
        for (n, h) in [(1, 7), (3, 7), (7, 7), (4, 100), (5, 13)] {
            let mut next = 0;
            for i in 0..n {
                let b = band(i, n, 10, h);
                assert_eq!((b.x0, b.x1, b.y0), (0, 10, next));
                assert!(b.y1 > b.y0, "{n} bands of {h} rows: band {i} is empty");
                next = b.y1;
            }
            assert_eq!(next, h);
        }
    }
}
