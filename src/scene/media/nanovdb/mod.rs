//! NanoVDB files (`.nvdb`, version 32): the float grids pbrt-v4's `nanovdb` medium reads
//! ("density", "temperature"), made dense for [`super::UniformGrid`], or kept sparse for
//! [`super::SparseGrid`] when the box of their active voxels is too large to hold dense.
//!
//! A file is one or more segments: a 16-byte header (magic, version, grid count, codec), a
//! 176-byte record and a name for each grid, then each grid's bytes as it lies in memory: the
//! grid (672 bytes: name, index-to-world map, value type), the tree (64 bytes: offsets to the
//! nodes), the root (its tiles each a 4096³ region of index space), upper nodes (32³ children
//! of 128³), lower nodes (16³ children of 8³) and leaves (8³ values). A child is a signed byte
//! offset from its parent. Values sit at integer index coordinates; between them NanoVDB (and
//! pbrt-v4) interpolate trilinearly, as the dense grid does between its samples.
//!
//! Uncompressed (codec NONE) and ZIP-compressed files of little-endian float grids are read;
//! Blosc is refused (no decoder of it is at hand without a C library). Everything the file
//! says is checked before it is used, so a damaged file is refused with one line.

mod tree;
mod zip;

use super::MAX_GRID_SAMPLES;
use super::{
    MediumKind, MediumPoint, MediumProblem, SparseGrid, SparseSource, SparseValues, UniformGrid,
};
use crate::error::{Error, Result};
use crate::input_file::{self, Allowance};
use crate::math::{Mat4, Vec3, Vec4};
use std::path::Path;

/// "NanoVDB0" (files and grids of every version 32 writer), "NanoVDB1" (grids of later ones)
/// and "NanoVDB2" (files of later ones), little-endian.
const MAGIC_OLD: u64 = 0x3042_4456_6f6e_614e;
const MAGIC_GRID: u64 = 0x3142_4456_6f6e_614e;
const MAGIC_FILE: u64 = 0x3242_4456_6f6e_614e;
/// The only major version whose layout is read here.
const MAJOR: u32 = 32;

/// The codecs read: none, and zlib streams (NanoVDB's ZIP).
const CODEC_NONE: u16 = 0;
const CODEC_ZIP: u16 = 1;

const SEGMENT_HEADER: usize = 16;
const GRID_RECORD: usize = 176;
const GRID_DATA: usize = 672;
const TREE_DATA: usize = 64;
/// A float grid's node sizes and where their tables start (NanoVDB's layout for `float`).
const ROOT_SIZE: usize = 64;
const ROOT_TILE: usize = 32;
const UPPER_SIZE: usize = 270_400;
const LOWER_SIZE: usize = 33_856;
const LEAF_SIZE: usize = 2144;
const LEAF_VALUES: usize = 96;

/// A float grid over the box of its active voxels with one voxel of background around it
/// (so that interpolation towards the background is kept).
#[derive(Clone, Debug, PartialEq)]
pub struct FloatGrid {
    /// Samples along x, y and z.
    pub res: [usize; 3],
    pub values: Values,
    /// The index coordinates of the first sample.
    pub origin: [i32; 3],
    /// The grid's index space to its world space (NanoVDB's map).
    pub index_to_world: Mat4,
}

/// A grid's values: dense (x fastest) when the box fits [`MAX_GRID_SAMPLES`], else its
/// leaves and tiles as the file has them.
#[derive(Clone, Debug, PartialEq)]
pub enum Values {
    Dense(Vec<f32>),
    Sparse(SparseValues),
}

/// How [`read_as`] keeps a grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// Dense when the box fits [`MAX_GRID_SAMPLES`], sparse otherwise.
    Fitting,
    /// Sparse always (to compare the two).
    Sparse,
}

impl FloatGrid {
    /// The box the samples span in index space, with the samples at the cells' centres (as
    /// [`super::UniformGrid`] places them): sample i lies at index `origin + i`.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let o = Vec3::new(
            self.origin[0] as f32,
            self.origin[1] as f32,
            self.origin[2] as f32,
        );
        let n = Vec3::new(self.res[0] as f32, self.res[1] as f32, self.res[2] as f32);
        (o - Vec3::splat(0.5), o + n - Vec3::splat(0.5))
    }

    /// The dense values, if the grid is held dense.
    pub fn dense(&self) -> Option<&[f32]> {
        match &self.values {
            Values::Dense(v) => Some(v),
            Values::Sparse(_) => None,
        }
    }

    /// Bytes the values take.
    pub fn bytes(&self) -> u64 {
        match &self.values {
            Values::Dense(v) => v.len() as u64 * 4,
            Values::Sparse(s) => s.bytes(),
        }
    }

    /// The value at integer index coordinates (beyond the box: 0).
    pub fn value(&self, ijk: [i32; 3]) -> f32 {
        let d = [0, 1, 2].map(|a| ijk[a] as i64 - self.origin[a] as i64);
        if (0..3).any(|a| d[a] < 0 || d[a] >= self.res[a] as i64) {
            return 0.0;
        }
        match &self.values {
            Values::Dense(v) => {
                v[(d[2] as usize * self.res[1] + d[1] as usize) * self.res[0] + d[0] as usize]
            }
            Values::Sparse(s) => s.value(ijk.map(i64::from)),
        }
    }
}

/// The bytes of one grid, and the file they came from, for messages.
struct Bytes<'a> {
    data: &'a [u8],
    path: &'a Path,
    grid: &'a str,
}

impl Bytes<'_> {
    fn corrupt(&self, what: impl std::fmt::Display) -> Error {
        Error::input(
            self.path,
            format!("grid \"{}\" is corrupt: {what}", self.grid),
        )
    }

    fn array<const N: usize>(&self, at: usize) -> Result<[u8; N]> {
        at.checked_add(N)
            .and_then(|end| self.data.get(at..end))
            .map(|s| s.try_into().expect("N bytes"))
            .ok_or_else(|| {
                self.corrupt(format!(
                    "byte {at} lies beyond its {} bytes",
                    self.data.len()
                ))
            })
    }

    fn u32(&self, at: usize) -> Result<u32> {
        self.array(at).map(u32::from_le_bytes)
    }

    fn i32(&self, at: usize) -> Result<i32> {
        self.array(at).map(i32::from_le_bytes)
    }

    fn u64(&self, at: usize) -> Result<u64> {
        self.array(at).map(u64::from_le_bytes)
    }

    fn f32(&self, at: usize) -> Result<f32> {
        self.array(at).map(f32::from_le_bytes)
    }

    fn f64(&self, at: usize) -> Result<f64> {
        self.array(at).map(f64::from_le_bytes)
    }

    /// The node `offset` bytes from `base`, checked to lie wholly within the grid.
    fn child(&self, base: usize, offset: u64, size: usize, what: &str) -> Result<usize> {
        let at = (base as i128) + (offset as i64 as i128);
        match usize::try_from(at) {
            Ok(at)
                if at
                    .checked_add(size)
                    .is_some_and(|end| end <= self.data.len()) =>
            {
                Ok(at)
            }
            _ => Err(self.corrupt(format!("{what} lies outside the grid's bytes"))),
        }
    }
}

/// The version's three numbers, for messages.
fn version_text(v: u32) -> String {
    format!("{}.{}.{}", v >> 21, (v >> 10) & 0x7ff, v & 0x3ff)
}

/// Names of NanoVDB's value types, for messages.
fn type_name(t: u32) -> String {
    const NAMES: [&str; 27] = [
        "unknown",
        "float",
        "double",
        "int16",
        "int32",
        "int64",
        "Vec3f",
        "Vec3d",
        "mask",
        "half",
        "uint32",
        "bool",
        "RGBA8",
        "Fp4",
        "Fp8",
        "Fp16",
        "FpN",
        "Vec4f",
        "Vec4d",
        "index",
        "on-index",
        "index-mask",
        "on-index-mask",
        "point-index",
        "Vec3u8",
        "Vec3u16",
        "uint8",
    ];
    NAMES
        .get(t as usize)
        .map_or_else(|| format!("type {t}"), |n| (*n).to_string())
}

/// Reads the float grids named `names` from the NanoVDB file at `path` (`None` for a name the
/// file does not hold), within `allowance`: the file's bytes and the grids' values count.
pub fn read(path: &Path, names: &[&str], allowance: &Allowance) -> Result<Vec<Option<FloatGrid>>> {
    read_as(path, names, allowance, Layout::Fitting)
}

/// [`read`], keeping the grids as `layout` says.
pub fn read_as(
    path: &Path,
    names: &[&str],
    allowance: &Allowance,
    layout: Layout,
) -> Result<Vec<Option<FloatGrid>>> {
    let data = input_file::read(path, &input_file::NANOVDB, Some(allowance))?;
    let mut held = data.len() as u64;
    let mut found: Vec<Option<FloatGrid>> = names.iter().map(|_| None).collect();
    let truncated = |what: &str| Error::input(path, format!("is truncated: {what}"));
    let mut at = 0usize;
    while at < data.len() {
        let header = data
            .get(at..at + SEGMENT_HEADER)
            .ok_or_else(|| truncated("a segment's header is cut short"))?;
        let word = |i: usize| u64::from_le_bytes(header[i..i + 8].try_into().expect("8 bytes"));
        let magic = word(0);
        if magic != MAGIC_OLD && magic != MAGIC_FILE {
            let detail = if magic.swap_bytes() == MAGIC_OLD || magic.swap_bytes() == MAGIC_FILE {
                "is a big-endian NanoVDB file, which raylink does not read".to_string()
            } else if at == 0 {
                "is not a NanoVDB file (no NanoVDB magic number at its start)".to_string()
            } else {
                format!("has no NanoVDB magic number at byte {at}, where a segment should start")
            };
            return Err(Error::input(path, detail));
        }
        let version = u32::from_le_bytes(header[8..12].try_into().expect("4 bytes"));
        if version >> 21 != MAJOR {
            return Err(Error::input(
                path,
                format!(
                    "is a NanoVDB file of version {}; raylink reads version {MAJOR}",
                    version_text(version)
                ),
            ));
        }
        let count = u16::from_le_bytes([header[12], header[13]]) as usize;
        let codec = u16::from_le_bytes([header[14], header[15]]);
        match codec {
            CODEC_NONE | CODEC_ZIP => {}
            // Blosc has no decoder in pure Rust; every NanoVDB tool reads the other two.
            2 => {
                return Err(Error::input(
                    path,
                    "is compressed with Blosc, which raylink does not read; re-save it with \
                     nanovdb_convert uncompressed or with ZIP",
                ))
            }
            c => {
                return Err(Error::input(
                    path,
                    format!("is compressed with an unknown codec ({c})"),
                ))
            }
        }
        at += SEGMENT_HEADER;
        // The grids' records, then their bytes in the same order.
        let mut grids = Vec::with_capacity(count.min(1024));
        for _ in 0..count {
            let record = data
                .get(at..at + GRID_RECORD)
                .ok_or_else(|| truncated("a grid's record is cut short"))?;
            let grid_size = u64::from_le_bytes(record[0..8].try_into().expect("8 bytes"));
            let file_size = u64::from_le_bytes(record[8..16].try_into().expect("8 bytes"));
            let name_size = u32::from_le_bytes(record[136..140].try_into().expect("4 bytes"));
            at += GRID_RECORD;
            let name = data
                .get(at..)
                .and_then(|rest| rest.get(..name_size as usize))
                .ok_or_else(|| truncated("a grid's name is cut short"))?;
            let name =
                String::from_utf8_lossy(name.split(|&b| b == 0).next().unwrap_or(&[])).into_owned();
            at += name_size as usize;
            if codec == CODEC_NONE && grid_size != file_size {
                return Err(Error::input(
                    path,
                    format!(
                        "grid \"{name}\" is corrupt: it takes {file_size} bytes in the file but \
                         {grid_size} in memory, and it is not compressed"
                    ),
                ));
            }
            grids.push((name, file_size, grid_size));
        }
        for (name, size, grid_size) in grids {
            let end = usize::try_from(size)
                .ok()
                .and_then(|s| at.checked_add(s))
                .filter(|&end| end <= data.len())
                .ok_or_else(|| {
                    truncated(&format!(
                        "grid \"{name}\" needs {size} bytes from byte {at}, beyond its end"
                    ))
                })?;
            if !names
                .iter()
                .enumerate()
                .any(|(i, w)| found[i].is_none() && *w == name)
            {
                at = end;
                continue;
            }
            let inflated;
            let (bytes, unpacked) = if codec == CODEC_ZIP {
                inflated = zip::inflate(&data[at..end], grid_size, path, &name, allowance, held)?;
                (&inflated[..], inflated.len() as u64)
            } else {
                (&data[at..end], 0)
            };
            let bytes = Bytes {
                data: bytes,
                path,
                grid: &name,
            };
            let grid = grid(&bytes, allowance, held + unpacked, layout)?;
            held += grid.bytes();
            let wanted: Vec<usize> = (0..names.len())
                .filter(|&i| found[i].is_none() && names[i] == name)
                .collect();
            for &i in &wanted[1..] {
                found[i] = Some(grid.clone());
            }
            found[wanted[0]] = Some(grid);
            at = end;
        }
    }
    Ok(found)
}

/// One float grid's bytes, dense or sparse as `layout` says.
fn grid(b: &Bytes, allowance: &Allowance, held: u64, layout: Layout) -> Result<FloatGrid> {
    if b.data.len() < GRID_DATA + TREE_DATA {
        return Err(b.corrupt(format!("{} bytes cannot hold a grid", b.data.len())));
    }
    let magic = b.u64(0)?;
    if magic != MAGIC_OLD && magic != MAGIC_GRID {
        return Err(b.corrupt("no NanoVDB magic number at its start"));
    }
    let version = b.u32(16)?;
    if version >> 21 != MAJOR {
        return Err(Error::input(
            b.path,
            format!(
                "grid \"{}\" is of NanoVDB version {}; raylink reads version {MAJOR}",
                b.grid,
                version_text(version)
            ),
        ));
    }
    let class = b.u32(632)?;
    let ty = b.u32(636)?;
    if ty != 1 {
        return Err(Error::input(
            b.path,
            format!(
                "grid \"{}\" holds {} values; raylink reads float grids",
                b.grid,
                type_name(ty)
            ),
        ));
    }
    // pbrt-v4 takes fog volumes (and grids of no stated class); a level set is a distance.
    if class != 0 && class != 2 {
        let what = match class {
            1 => "a level set".to_string(),
            c => format!("of class {c}"),
        };
        return Err(Error::input(
            b.path,
            format!(
                "grid \"{}\" is {what}, not a fog volume of densities",
                b.grid
            ),
        ));
    }
    let index_to_world = map(b)?;
    let tree = GRID_DATA;
    let root = b.child(tree, b.u64(tree + 24)?, ROOT_SIZE, "the root")?;
    let lo = [b.i32(root)?, b.i32(root + 4)?, b.i32(root + 8)?];
    let hi = [b.i32(root + 12)?, b.i32(root + 16)?, b.i32(root + 20)?];
    if (0..3).any(|a| lo[a] > hi[a]) {
        return Err(Error::input(
            b.path,
            format!("grid \"{}\" holds no active voxels", b.grid),
        ));
    }
    // One background voxel beyond the active box on every side.
    let mut res = [0usize; 3];
    let mut origin = [0i32; 3];
    for a in 0..3 {
        let (l, h) = (lo[a] as i64 - 1, hi[a] as i64 + 1);
        origin[a] =
            i32::try_from(l).map_err(|_| b.corrupt("its box lies at the edge of index space"))?;
        res[a] = (h - l + 1) as usize;
    }
    let what = || format!("the NanoVDB grid \"{}\" of {}", b.grid, b.path.display());
    let n = res.iter().try_fold(1usize, |acc, &r| acc.checked_mul(r));
    let dense = n.filter(|&n| n <= MAX_GRID_SAMPLES && layout == Layout::Fitting);
    if let Some(n) = dense {
        allowance.check(&what(), held.saturating_add(n as u64 * 4))?;
    }
    let background = b.f32(root + 28)?;
    if !(background.is_finite() && background >= 0.0) {
        return Err(Error::input(
            b.path,
            format!(
                "grid \"{}\" has the background {background}: densities must be finite and \
                 not negative",
                b.grid
            ),
        ));
    }
    let walk = tree::Walk {
        b,
        res,
        origin: origin.map(i64::from),
        seen: Default::default(),
    };
    let values = if let Some(n) = dense {
        let mut values = Vec::new();
        crate::platform::try_reserve(&mut values, n, what)?;
        values.resize(n, background);
        let mut sink = tree::Dense {
            res,
            origin: walk.origin,
            values,
        };
        walk.run(root, &mut sink)?;
        Values::Dense(sink.values)
    } else {
        // Too large to hold dense: the leaves and tiles, counted as they are kept.
        let budget = |bytes: u64| allowance.check(&what(), held.saturating_add(bytes));
        let mut sink = tree::Sparse {
            values: SparseValues::new(background),
            budget: &budget,
        };
        walk.run(root, &mut sink)?;
        Values::Sparse(sink.values)
    };
    Ok(FloatGrid {
        res,
        values,
        origin,
        index_to_world,
    })
}

/// NanoVDB's index-to-world map (in doubles: a 3×3 matrix, row-major, and a translation).
fn map(b: &Bytes) -> Result<Mat4> {
    let mut m = [0f32; 12];
    for (i, v) in m.iter_mut().enumerate() {
        // The matrix at 384, the translation at 528 (the map's double-precision half).
        let at = if i < 9 {
            384 + 8 * i
        } else {
            528 + 8 * (i - 9)
        };
        *v = b.f64(at)? as f32;
    }
    let to_world = Mat4::from_cols(
        Vec4::new(m[0], m[3], m[6], 0.0),
        Vec4::new(m[1], m[4], m[7], 0.0),
        Vec4::new(m[2], m[5], m[8], 0.0),
        Vec4::new(m[9], m[10], m[11], 1.0),
    );
    let det = to_world.determinant();
    if !to_world.is_finite() || !det.is_finite() || det == 0.0 {
        return Err(b.corrupt("its index-to-world map cannot be inverted"));
    }
    Ok(to_world)
}

/// The medium a grid makes with the coefficients of `unit` at density 1, placed by the
/// grid's map and then `source`'s transform: a `uniformgrid` when dense.
pub fn medium(
    grid: FloatGrid,
    unit: MediumPoint,
    source: SparseSource,
) -> std::result::Result<MediumKind, MediumProblem> {
    let to_world = source.transform * grid.index_to_world;
    let bounds = grid.bounds();
    Ok(match grid.values {
        Values::Dense(values) => MediumKind::UniformGrid(Box::new(UniformGrid::new(
            unit, grid.res, values, None, bounds, to_world,
        )?)),
        Values::Sparse(values) => MediumKind::SparseGrid(Box::new(SparseGrid::new(
            unit,
            grid.res,
            grid.origin,
            values,
            to_world,
            source,
        )?)),
    })
}
