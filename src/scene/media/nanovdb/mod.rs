//! NanoVDB files (`.nvdb`, version 32): the float grids pbrt-v4's `nanovdb` medium reads
//! ("density", "temperature"), made dense for [`super::UniformGrid`].
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

mod zip;

use super::MAX_GRID_SAMPLES;
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
const UPPER_TABLE: usize = 8256;
const UPPER_CHILD_MASK: usize = 4128;
const LOWER_SIZE: usize = 33_856;
const LOWER_TABLE: usize = 1088;
const LOWER_CHILD_MASK: usize = 544;
const LEAF_SIZE: usize = 2144;
const LEAF_VALUES: usize = 96;

/// A float grid made dense: the box of its active voxels with one voxel of background around
/// it (so that interpolation towards the background is kept), x fastest.
#[derive(Clone, Debug, PartialEq)]
pub struct FloatGrid {
    /// Samples along x, y and z.
    pub res: [usize; 3],
    pub values: Vec<f32>,
    /// The index coordinates of the first sample.
    pub origin: [i32; 3],
    /// The grid's index space to its world space (NanoVDB's map).
    pub index_to_world: Mat4,
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

    /// The value at integer index coordinates (the background beyond the box: 0 here).
    pub fn value(&self, ijk: [i32; 3]) -> f32 {
        let mut at = 0usize;
        for a in (0..3).rev() {
            let d = ijk[a] as i64 - self.origin[a] as i64;
            if d < 0 || d >= self.res[a] as i64 {
                return 0.0;
            }
            at = at * self.res[a] + d as usize;
        }
        self.values[at]
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
/// file does not hold), within `allowance`: the file's bytes and the dense grids count.
pub fn read(path: &Path, names: &[&str], allowance: &Allowance) -> Result<Vec<Option<FloatGrid>>> {
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
            let grid = dense(&bytes, allowance, held + unpacked)?;
            held += (grid.values.len() * 4) as u64;
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

/// One float grid's bytes made dense.
fn dense(b: &Bytes, allowance: &Allowance, held: u64) -> Result<FloatGrid> {
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
    let n = res.iter().try_fold(1usize, |acc, &r| acc.checked_mul(r));
    let Some(n) = n.filter(|&n| n <= MAX_GRID_SAMPLES) else {
        return Err(Error::input(
            b.path,
            format!(
                "grid \"{}\" spans {}x{}x{} voxels, more than raylink holds in a dense grid \
                 ({MAX_GRID_SAMPLES} samples)",
                b.grid,
                res[0] - 2,
                res[1] - 2,
                res[2] - 2
            ),
        ));
    };
    let what = || format!("the NanoVDB grid \"{}\" of {}", b.grid, b.path.display());
    allowance.check(&what(), held.saturating_add(n as u64 * 4))?;
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
    let mut values = Vec::new();
    crate::platform::try_reserve(&mut values, n, what)?;
    values.resize(n, background);
    let mut grid = Dense {
        b,
        res,
        origin: origin.map(i64::from),
        values,
    };
    let tiles = b.u32(root + 24)? as usize;
    let table = root + ROOT_SIZE;
    if tiles
        .checked_mul(ROOT_TILE)
        .and_then(|s| s.checked_add(table))
        .is_none_or(|end| end > b.data.len())
    {
        return Err(b.corrupt(format!("its root's {tiles} tiles lie beyond its bytes")));
    }
    let mut keys = rustc_hash::FxHashSet::default();
    for t in 0..tiles {
        let tile = table + t * ROOT_TILE;
        let key = b.u64(tile)?;
        if !keys.insert(key) {
            return Err(b.corrupt("two root tiles have the same place"));
        }
        // Each field holds a coordinate's top 20 bits.
        let coord = |shift: u32| (((key >> shift) & 0xf_ffff) as u32) << 12;
        let at = [coord(42), coord(21), coord(0)].map(|c| c as i32 as i64);
        if !grid.touches(at, 4096) {
            continue;
        }
        let child = b.u64(tile + 8)?;
        if child == 0 {
            grid.fill(at, 4096, b.f32(tile + 20)?)?;
        } else {
            let upper = b.child(root, child, UPPER_SIZE, "an upper node")?;
            grid.internal(upper, at, Level::UPPER)?;
        }
    }
    Ok(FloatGrid {
        res,
        values: grid.values,
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

/// An internal node's shape: children per axis (log2), the span of a child, its size in
/// bytes and where its child mask and table lie.
#[derive(Clone, Copy)]
struct Level {
    log: u32,
    child_span: i64,
    child_mask: usize,
    table: usize,
}

impl Level {
    const UPPER: Level = Level {
        log: 5,
        child_span: 128,
        child_mask: UPPER_CHILD_MASK,
        table: UPPER_TABLE,
    };
    const LOWER: Level = Level {
        log: 4,
        child_span: 8,
        child_mask: LOWER_CHILD_MASK,
        table: LOWER_TABLE,
    };
}

/// The dense grid being filled from the tree.
struct Dense<'a, 'b> {
    b: &'a Bytes<'b>,
    res: [usize; 3],
    origin: [i64; 3],
    values: Vec<f32>,
}

impl Dense<'_, '_> {
    /// Whether the cube of `span` voxels at `at` meets the grid's box.
    fn touches(&self, at: [i64; 3], span: i64) -> bool {
        (0..3).all(|a| at[a] + span > self.origin[a] && at[a] < self.origin[a] + self.res[a] as i64)
    }

    /// A value checked as a density.
    fn check(&self, v: f32, at: [i64; 3]) -> Result<f32> {
        if v.is_finite() && v >= 0.0 {
            Ok(v)
        } else {
            Err(Error::input(
                self.b.path,
                format!(
                    "grid \"{}\" has {v} at voxel ({}, {}, {}): densities must be finite and \
                     not negative",
                    self.b.grid, at[0], at[1], at[2]
                ),
            ))
        }
    }

    /// Sets the cube of `span` voxels at `at` (where it meets the box) to `v`.
    fn fill(&mut self, at: [i64; 3], span: i64, v: f32) -> Result<()> {
        let v = self.check(v, at)?;
        let range = |a: usize| {
            let lo = (at[a] - self.origin[a]).max(0);
            let hi = (at[a].saturating_add(span) - self.origin[a]).min(self.res[a] as i64);
            lo as usize..hi.max(lo) as usize
        };
        let (xs, ys, zs) = (range(0), range(1), range(2));
        for z in zs {
            for y in ys.clone() {
                let row = (z * self.res[1] + y) * self.res[0];
                self.values[row + xs.start..row + xs.end].fill(v);
            }
        }
        Ok(())
    }

    /// An upper or lower node at byte `node` whose region starts at `at`.
    fn internal(&mut self, node: usize, at: [i64; 3], level: Level) -> Result<()> {
        let b = self.b;
        let dim = 1usize << level.log;
        for n in 0..dim * dim * dim {
            let x = (n >> (2 * level.log)) & (dim - 1);
            let y = (n >> level.log) & (dim - 1);
            let z = n & (dim - 1);
            let child_at = [
                at[0] + x as i64 * level.child_span,
                at[1] + y as i64 * level.child_span,
                at[2] + z as i64 * level.child_span,
            ];
            if !self.touches(child_at, level.child_span) {
                continue;
            }
            let entry = node + level.table + 8 * n;
            let is_child = (b.u32(node + level.child_mask + 4 * (n >> 5))? >> (n & 31)) & 1 == 1;
            if !is_child {
                self.fill(child_at, level.child_span, b.f32(entry)?)?;
            } else if level.log == Level::UPPER.log {
                let lower = b.child(node, b.u64(entry)?, LOWER_SIZE, "a lower node")?;
                self.internal(lower, child_at, Level::LOWER)?;
            } else {
                let leaf = b.child(node, b.u64(entry)?, LEAF_SIZE, "a leaf")?;
                self.leaf(leaf, child_at)?;
            }
        }
        Ok(())
    }

    /// A leaf at byte `leaf` whose 8³ voxels start at `at`.
    fn leaf(&mut self, leaf: usize, at: [i64; 3]) -> Result<()> {
        let values = self
            .b
            .data
            .get(leaf + LEAF_VALUES..leaf + LEAF_VALUES + 2048)
            .ok_or_else(|| self.b.corrupt("a leaf lies outside the grid's bytes"))?;
        for n in 0..512 {
            let p = [
                at[0] + (n >> 6) as i64,
                at[1] + ((n >> 3) & 7) as i64,
                at[2] + (n & 7) as i64,
            ];
            let d = [0, 1, 2].map(|a| p[a] - self.origin[a]);
            if (0..3).any(|a| d[a] < 0 || d[a] >= self.res[a] as i64) {
                continue;
            }
            let v = f32::from_le_bytes(values[4 * n..4 * n + 4].try_into().expect("4 bytes"));
            let v = self.check(v, p)?;
            let i = (d[2] as usize * self.res[1] + d[1] as usize) * self.res[0] + d[0] as usize;
            self.values[i] = v;
        }
        Ok(())
    }
}
