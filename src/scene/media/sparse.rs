//! A density grid too large to hold dense (a cloud whose active voxels span thousands of
//! voxels but fill few of them): NanoVDB's leaves (8³ voxels) and constant tiles kept as
//! they are, looked up by their origin, the background elsewhere. Lookups and the walk
//! through a coarse majorant grid are the dense grid's ([`super::UniformGrid`]), sample for
//! sample, so that a grid reads the same either way.

use super::grid_space::{cell_samples, GridSpace, MAJORANT_CELLS};
use super::{check_coefficients, check_g, MediumModel, MediumPoint, MediumProblem, Segment};
use crate::math::{Mat4, Ray, Rgb, Vec3};
use rustc_hash::FxHashMap;
use std::path::PathBuf;

/// The values of a sparse grid at integer index coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct SparseValues {
    /// Leaf origin to the index of its 512 values (x slowest, z fastest) in `values`.
    leaves: FxHashMap<[i32; 3], u32>,
    values: Vec<f32>,
    /// Constant tiles of 8³, 128³ and 4096³ voxels that differ from the background, by
    /// their origin.
    tiles: [FxHashMap<[i32; 3], f32>; 3],
    background: f32,
}

const TILE_SPANS: [i64; 3] = [8, 128, 4096];

impl SparseValues {
    /// Bytes one leaf takes (its values and its entry in the map, roughly).
    pub const LEAF_BYTES: u64 = 512 * 4 + 32;

    /// No leaves or tiles: `background` everywhere.
    pub fn new(background: f32) -> SparseValues {
        SparseValues {
            leaves: FxHashMap::default(),
            values: Vec::new(),
            tiles: Default::default(),
            background,
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        self.leaves.len() as u64 * Self::LEAF_BYTES
            + self.tiles.iter().map(|t| t.len() as u64 * 24).sum::<u64>()
    }

    /// Leaves held.
    pub fn leaf_count(&self) -> usize {
        self.leaves.len()
    }

    pub fn background(&self) -> f32 {
        self.background
    }

    /// A tile of `span` voxels (8, 128 or 4096) at `at` holding `v`.
    pub fn tile(&mut self, at: [i64; 3], span: i64, v: f32) {
        if v != self.background {
            if let Some(level) = TILE_SPANS.iter().position(|&s| s == span) {
                self.tiles[level].insert(at.map(|c| c as i32), v);
            }
        }
    }

    /// The leaf at `at` holds `values` (x slowest, z fastest).
    pub fn leaf(&mut self, at: [i64; 3], values: &[f32; 512]) {
        let index = (self.values.len() / 512) as u32;
        self.values.extend_from_slice(values);
        self.leaves.insert(at.map(|c| c as i32), index);
    }

    /// The value at index coordinates `ijk`.
    pub fn value(&self, ijk: [i64; 3]) -> f32 {
        let base = |span: i64| ijk.map(|c| c.div_euclid(span) * span);
        let key = |o: [i64; 3]| o.map(|c| c as i32);
        let leaf = base(8);
        if let Some(&i) = self.leaves.get(&key(leaf)) {
            let l = [0, 1, 2].map(|a| (ijk[a] - leaf[a]) as usize);
            return self.values[i as usize * 512 + (l[0] << 6 | l[1] << 3 | l[2])];
        }
        for (level, &span) in TILE_SPANS.iter().enumerate() {
            if let Some(&v) = self.tiles[level].get(&key(base(span))) {
                return v;
            }
        }
        self.background
    }

    /// Calls `visit` with each leaf's and tile's box (lowest voxel, highest voxel) and its
    /// largest value.
    fn regions(&self, visit: &mut dyn FnMut([i64; 3], [i64; 3], f32)) {
        for (at, &i) in &self.leaves {
            let at = at.map(i64::from);
            let v = &self.values[i as usize * 512..(i as usize + 1) * 512];
            visit(at, at.map(|c| c + 7), v.iter().fold(0f32, |m, &x| m.max(x)));
        }
        for (level, &span) in TILE_SPANS.iter().enumerate() {
            for (at, &v) in &self.tiles[level] {
                let at = at.map(i64::from);
                visit(at, at.map(|c| c + span - 1), v);
            }
        }
    }
}

/// Where a sparse grid came from, so that `convert` can name the file again.
#[derive(Clone, Debug, PartialEq)]
pub struct SparseSource {
    pub file: PathBuf,
    pub grid: String,
    /// The scene's transform, before the grid's own index-to-world map.
    pub transform: Mat4,
}

/// A medium whose density is a sparse grid, scaling one absorption and scattering (what
/// pbrt-v4's `nanovdb` medium is for a large cloud).
#[derive(Clone, Debug, PartialEq)]
pub struct SparseGrid {
    unit: MediumPoint,
    space: GridSpace,
    /// The index coordinates of the first sample of the box.
    origin: [i64; 3],
    values: SparseValues,
    majorants: Vec<Rgb>,
    source: SparseSource,
}

impl SparseGrid {
    /// The grid `values` over the box of `res` samples from index `origin`, which
    /// `to_world` places, with the coefficients of `unit` at density 1.
    pub fn new(
        unit: MediumPoint,
        res: [usize; 3],
        origin: [i32; 3],
        values: SparseValues,
        to_world: Mat4,
        source: SparseSource,
    ) -> Result<SparseGrid, MediumProblem> {
        check_coefficients(&[
            ("sigma_a", "sigma_a", unit.sigma_a),
            ("sigma_s", "sigma_s", unit.sigma_s),
            ("emission", "Le", unit.le),
        ])?;
        check_g(unit.g)?;
        // The samples at the cells' centres, as the dense grid places them.
        let o = Vec3::new(origin[0] as f32, origin[1] as f32, origin[2] as f32);
        let n = Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
        let bounds = (o - Vec3::splat(0.5), o + n - Vec3::splat(0.5));
        let space = GridSpace::spanning(res, bounds, to_world)?;
        let origin = origin.map(i64::from);
        let majorants = majorants(&values, res, origin);
        Ok(SparseGrid {
            unit,
            space,
            origin,
            values,
            majorants,
            source,
        })
    }

    pub fn unit(&self) -> &MediumPoint {
        &self.unit
    }

    pub fn values(&self) -> &SparseValues {
        &self.values
    }

    pub fn source(&self) -> &SparseSource {
        &self.source
    }

    /// The sample at box coordinates: 0 beyond the box, as the dense grid.
    fn sample(&self, x: i64, y: i64, z: i64) -> f32 {
        let res = self.space.res;
        let inside = |v: i64, n: usize| v >= 0 && (v as usize) < n;
        if !(inside(x, res[0]) && inside(y, res[1]) && inside(z, res[2])) {
            return 0.0;
        }
        let o = self.origin;
        self.values.value([o[0] + x, o[1] + y, o[2] + z])
    }
}

/// The largest density each majorant cell's interpolation can reach: each leaf's and
/// tile's largest value in every cell whose samples it meets (the background in all).
fn majorants(values: &SparseValues, res: [usize; 3], origin: [i64; 3]) -> Vec<Rgb> {
    let m = MAJORANT_CELLS;
    let mut out = vec![values.background(); m * m * m];
    // The cells whose samples meet samples lo..=hi along an axis.
    let cells = |lo: i64, hi: i64, a: usize| {
        (0..m).filter(move |&c| {
            let r = cell_samples(c, res[a]);
            *r.start() <= hi && lo <= *r.end()
        })
    };
    values.regions(&mut |lo, hi, v| {
        let (lo, hi) = (
            [0, 1, 2].map(|a| lo[a] - origin[a]),
            [0, 1, 2].map(|a| hi[a] - origin[a]),
        );
        for z in cells(lo[2], hi[2], 2) {
            for y in cells(lo[1], hi[1], 1) {
                for x in cells(lo[0], hi[0], 0) {
                    let cell = &mut out[(z * m + y) * m + x];
                    *cell = cell.max(v);
                }
            }
        }
    });
    out.into_iter().map(Rgb::splat).collect()
}

impl MediumModel for SparseGrid {
    fn kind(&self) -> &'static str {
        "nanovdb"
    }

    fn at(&self, p: Vec3) -> MediumPoint {
        let u = self.space.unit_coords(p);
        let d = if GridSpace::inside(u) {
            self.space.lookup_with(u, |x, y, z| self.sample(x, y, z))
        } else {
            0.0
        };
        MediumPoint {
            sigma_a: self.unit.sigma_a * d,
            sigma_s: self.unit.sigma_s * d,
            le: self.unit.le,
            g: self.unit.g,
        }
    }

    fn segments(&self, ray: &Ray, t_max: f32, visit: &mut dyn FnMut(Segment) -> bool) {
        let sigma_t = (self.unit.sigma_a + self.unit.sigma_s) * ray.dir.length();
        self.space.walk(&self.majorants, sigma_t, ray, t_max, visit);
    }

    fn emits(&self) -> bool {
        (self.unit.le * self.unit.sigma_a).max_element() > 0.0
    }

    fn colours(&self) -> Option<&MediumPoint> {
        Some(&self.unit)
    }
}
