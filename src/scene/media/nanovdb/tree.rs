//! Walking a float grid's tree (root tiles, upper and lower nodes, leaves) over the box the
//! grid is kept for, handing each constant region and each leaf to a [`Sink`]: the dense
//! grid writes them into its samples, the sparse one keeps them as they are.

use super::{Bytes, LEAF_SIZE, LEAF_VALUES, LOWER_SIZE, ROOT_SIZE, ROOT_TILE, UPPER_SIZE};
use crate::error::{Error, Result};
use crate::scene::media::sparse::SparseValues;

/// An upper node's child mask and table, and a lower node's (NanoVDB's layout for `float`).
const UPPER_TABLE: usize = 8256;
const UPPER_CHILD_MASK: usize = 4128;
const LOWER_TABLE: usize = 1088;
const LOWER_CHILD_MASK: usize = 544;

/// Where the tree's values go.
pub(super) trait Sink {
    /// The cube of `span` voxels at `at` holds `v` (a tile).
    fn fill(&mut self, at: [i64; 3], span: i64, v: f32) -> Result<()>;
    /// The leaf at `at` holds `values` (x slowest, z fastest), checked where in the box.
    fn leaf(&mut self, at: [i64; 3], values: &[f32; 512]) -> Result<()>;
}

/// An internal node's shape: children per axis (log2), the span of a child, where its child
/// mask and table lie.
#[derive(Clone, Copy)]
struct Level {
    log: u32,
    child_span: i64,
    child_mask: usize,
    table: usize,
}

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

/// The tree of the grid in `b` whose root is at byte `root`, over the box of `res` samples
/// from `origin`.
pub(super) struct Walk<'a, 'b> {
    pub(super) b: &'a Bytes<'b>,
    pub(super) res: [usize; 3],
    pub(super) origin: [i64; 3],
    /// The nodes met so far: a node is the child of one parent, or a small file could make
    /// a walk of billions of nodes (a sparse grid's box does not bound it).
    pub(super) seen: std::cell::RefCell<rustc_hash::FxHashSet<usize>>,
}

impl Walk<'_, '_> {
    /// The node `offset` bytes from `base` (see [`Bytes::child`]), met for the first time.
    fn node(&self, base: usize, offset: u64, size: usize, what: &str) -> Result<usize> {
        let at = self.b.child(base, offset, size, what)?;
        if !self.seen.borrow_mut().insert(at) {
            return Err(self
                .b
                .corrupt(format!("{what} is the child of two parents")));
        }
        Ok(at)
    }

    /// Whether the cube of `span` voxels at `at` meets the box.
    pub(super) fn touches(&self, at: [i64; 3], span: i64) -> bool {
        (0..3).all(|a| at[a] + span > self.origin[a] && at[a] < self.origin[a] + self.res[a] as i64)
    }

    /// Whether the voxel `p` lies in the box.
    pub(super) fn holds(&self, p: [i64; 3]) -> bool {
        (0..3).all(|a| p[a] >= self.origin[a] && p[a] < self.origin[a] + self.res[a] as i64)
    }

    /// A value checked as a density.
    pub(super) fn check(&self, v: f32, at: [i64; 3]) -> Result<f32> {
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

    /// Every tile and leaf of the tree at `root` that meets the box, into `sink`.
    pub(super) fn run(&self, root: usize, sink: &mut dyn Sink) -> Result<()> {
        let b = self.b;
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
            if !self.touches(at, 4096) {
                continue;
            }
            let child = b.u64(tile + 8)?;
            if child == 0 {
                sink.fill(at, 4096, self.check(b.f32(tile + 20)?, at)?)?;
            } else {
                let upper = self.node(root, child, UPPER_SIZE, "an upper node")?;
                self.internal(upper, at, UPPER, sink)?;
            }
        }
        Ok(())
    }

    /// An upper or lower node at byte `node` whose region starts at `at`.
    fn internal(&self, node: usize, at: [i64; 3], level: Level, sink: &mut dyn Sink) -> Result<()> {
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
                let v = self.check(b.f32(entry)?, child_at)?;
                sink.fill(child_at, level.child_span, v)?;
            } else if level.log == UPPER.log {
                let lower = self.node(node, b.u64(entry)?, LOWER_SIZE, "a lower node")?;
                self.internal(lower, child_at, LOWER, sink)?;
            } else {
                let leaf = self.node(node, b.u64(entry)?, LEAF_SIZE, "a leaf")?;
                self.leaf(leaf, child_at, sink)?;
            }
        }
        Ok(())
    }

    /// A leaf at byte `leaf` whose 8³ voxels start at `at`: values outside the box are never
    /// looked up, so they are neither checked nor kept (0).
    fn leaf(&self, leaf: usize, at: [i64; 3], sink: &mut dyn Sink) -> Result<()> {
        let bytes = self
            .b
            .data
            .get(leaf + LEAF_VALUES..leaf + LEAF_VALUES + 2048)
            .ok_or_else(|| self.b.corrupt("a leaf lies outside the grid's bytes"))?;
        let mut values = [0f32; 512];
        for (n, v) in values.iter_mut().enumerate() {
            let p = [
                at[0] + (n >> 6) as i64,
                at[1] + ((n >> 3) & 7) as i64,
                at[2] + (n & 7) as i64,
            ];
            if self.holds(p) {
                let raw = f32::from_le_bytes(bytes[4 * n..4 * n + 4].try_into().expect("4 bytes"));
                *v = self.check(raw, p)?;
            }
        }
        sink.leaf(at, &values)
    }
}

/// The dense grid being filled from the tree.
pub(super) struct Dense {
    pub(super) res: [usize; 3],
    pub(super) origin: [i64; 3],
    pub(super) values: Vec<f32>,
}

impl Dense {
    /// The samples of the cube of `span` voxels at `at`, where it meets the box.
    fn range(&self, at: [i64; 3], span: i64, a: usize) -> std::ops::Range<usize> {
        let lo = (at[a] - self.origin[a]).max(0);
        let hi = (at[a].saturating_add(span) - self.origin[a]).min(self.res[a] as i64);
        lo as usize..hi.max(lo) as usize
    }
}

impl Sink for Dense {
    fn fill(&mut self, at: [i64; 3], span: i64, v: f32) -> Result<()> {
        let (xs, ys, zs) = (
            self.range(at, span, 0),
            self.range(at, span, 1),
            self.range(at, span, 2),
        );
        for z in zs {
            for y in ys.clone() {
                let row = (z * self.res[1] + y) * self.res[0];
                self.values[row + xs.start..row + xs.end].fill(v);
            }
        }
        Ok(())
    }

    fn leaf(&mut self, at: [i64; 3], values: &[f32; 512]) -> Result<()> {
        for (n, v) in values.iter().enumerate() {
            let d = [
                at[0] + (n >> 6) as i64 - self.origin[0],
                at[1] + ((n >> 3) & 7) as i64 - self.origin[1],
                at[2] + (n & 7) as i64 - self.origin[2],
            ];
            if (0..3).all(|a| d[a] >= 0 && d[a] < self.res[a] as i64) {
                let i = (d[2] as usize * self.res[1] + d[1] as usize) * self.res[0] + d[0] as usize;
                self.values[i] = *v;
            }
        }
        Ok(())
    }
}

/// The sparse grid being gathered from the tree, its bytes counted as they grow.
pub(super) struct Sparse<'a> {
    pub(super) values: SparseValues,
    /// Checks the bytes held so far against the budget.
    pub(super) budget: &'a dyn Fn(u64) -> Result<()>,
}

impl Sink for Sparse<'_> {
    fn fill(&mut self, at: [i64; 3], span: i64, v: f32) -> Result<()> {
        self.values.tile(at, span, v);
        (self.budget)(self.values.bytes())
    }

    fn leaf(&mut self, at: [i64; 3], values: &[f32; 512]) -> Result<()> {
        (self.budget)(self.values.bytes() + SparseValues::LEAF_BYTES)?;
        self.values.leaf(at, values);
        Ok(())
    }
}
