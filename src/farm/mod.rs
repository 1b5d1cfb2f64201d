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
use std::path::{Path, PathBuf};

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

/// Parses `I/N` (0 ≤ I < N).
pub fn parse_tile(text: &str) -> std::result::Result<Part, String> {
    let bad = || format!("takes I/N with 0 <= I < N (e.g. 0/4), got \"{text}\"");
    let (i, n) = text.split_once('/').ok_or_else(bad)?;
    let index: u32 = i.trim().parse().map_err(|_| bad())?;
    let count: u32 = n.trim().parse().map_err(|_| bad())?;
    if count == 0 || index >= count {
        return Err(bad());
    }
    Ok(Part::Tile { index, count })
}

/// Parses `x0,y0,x1,y1` (half-open pixel bounds, x0 < x1, y0 < y1).
pub fn parse_crop(text: &str) -> std::result::Result<Part, String> {
    let bad = || {
        format!(
            "takes pixel bounds x0,y0,x1,y1 with x0 < x1 and y0 < y1 (x1 and y1 \
             excluded), got \"{text}\""
        )
    };
    let v: Vec<u32> = text
        .split(',')
        .map(|s| s.trim().parse::<u32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| bad())?;
    match v[..] {
        [x0, y0, x1, y1] if x0 < x1 && y0 < y1 => Ok(Part::Crop(Tile { x0, y0, x1, y1 })),
        _ => Err(bad()),
    }
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

/// An output path with `{tile}` replaced by the tile index and `{tiles}` by the tile count.
/// A pattern without them is used as it is; `{tile}` without `--tile` is an error.
pub fn output_path(pattern: &Path, part: Option<&Part>) -> Result<PathBuf> {
    let text = pattern.to_string_lossy();
    if !text.contains("{tile") {
        return Ok(pattern.to_path_buf());
    }
    match part {
        Some(Part::Tile { index, count }) => Ok(PathBuf::from(
            text.replace("{tiles}", &count.to_string())
                .replace("{tile}", &index.to_string()),
        )),
        _ => Err(Error::setting(
            "tile",
            format!(
                "is needed for {{tile}} and {{tiles}} in an output name ({})",
                pattern.display()
            ),
        )),
    }
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
pub fn window(region: &Tile, width: u32, height: u32) -> crate::image::oiio::Window {
    crate::image::oiio::Window {
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

    #[test]
    fn parses_tiles_and_crops() {
        assert_eq!(parse_tile("2/5"), Ok(Part::Tile { index: 2, count: 5 }));
        for bad in ["5/5", "1", "a/2", "0/0", "-1/3"] {
            assert!(parse_tile(bad).is_err(), "{bad}");
        }
        assert_eq!(
            parse_crop("1,2,3,4"),
            Ok(Part::Crop(Tile {
                x0: 1,
                y0: 2,
                x1: 3,
                y1: 4
            }))
        );
        for bad in ["1,2,1,4", "1,2,3", "0,0,4,4,5", "a,0,1,1", "0,3,2,1"] {
            assert!(parse_crop(bad).is_err(), "{bad}");
        }
        let crop = parse_crop("0,0,20,10").unwrap();
        assert!(crop.region(16, 16).is_err());
        assert!(parse_tile("0/17").unwrap().region(4, 16).is_err());
    }

    #[test]
    fn output_patterns() {
        let p = Part::Tile { index: 3, count: 8 };
        assert_eq!(
            output_path(Path::new("out/t_{tile}_of_{tiles}.exr"), Some(&p)).unwrap(),
            PathBuf::from("out/t_3_of_8.exr")
        );
        assert_eq!(
            output_path(Path::new("a.exr"), Some(&p)).unwrap(),
            PathBuf::from("a.exr")
        );
        assert!(output_path(Path::new("t_{tile}.exr"), None).is_err());
        let crop = parse_crop("0,0,1,1").unwrap();
        assert!(output_path(Path::new("t_{tile}.exr"), Some(&crop)).is_err());
    }
}
