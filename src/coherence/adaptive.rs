//! An adaptive voxel grid (Jevans & Wyvill 1989, as Jevans 1992 keeps its records in): a
//! uniform top grid whose crowded cells are cut again by a nested grid, recursively, to a
//! small depth. The leaves are numbered `0..len()`, so per-voxel masks and tables index
//! them as they index a uniform grid's voxels; without a cut it *is* the uniform grid (leaf
//! `i` = voxel `i`).
//!
//! What crowds a cell, here, is a frame's changed surfaces: with segment records, a block
//! is retraced when one of its segments crosses a changed voxel, so a voxel much larger
//! than the surface piece that changed in it retraces every block whose rays merely pass
//! near the piece. Cutting exactly the cells a changed surface passes through makes the
//! changed set hug the surfaces; cells where nothing changes are never marked, and cutting
//! them (the paper's object count, which serves intersection speed) would buy nothing.

use super::grid::{Extent, Grid};
use crate::math::Vec3;
use std::sync::Arc;

/// A cell entry of a node: a leaf number, or (with this bit) the index of its child node.
const CHILD: u32 = 1 << 31;

/// The cuts of an [`AdaptiveGrid`]: node 0 is the top grid.
#[derive(Debug, PartialEq)]
struct Cuts {
    nodes: Vec<Node>,
    /// Per leaf: its node and its cell in the node's grid.
    leaves: Vec<(u32, u32)>,
}

#[derive(Debug, PartialEq)]
struct Node {
    grid: Grid,
    /// Per cell: a leaf number, or `CHILD | node`.
    cells: Vec<u32>,
    /// The top grid's cell this node lies in (none for node 0).
    top_cell: u32,
}

/// A uniform grid, some of whose cells are cut by nested grids.
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptiveGrid {
    pub top: Grid,
    /// `None`: no cell is cut.
    cuts: Option<Arc<Cuts>>,
}

impl From<Grid> for AdaptiveGrid {
    fn from(top: Grid) -> AdaptiveGrid {
        AdaptiveGrid { top, cuts: None }
    }
}

impl Extent for AdaptiveGrid {
    fn extent(&self) -> (Vec3, Vec3) {
        (self.top.lo, self.top.hi)
    }
}

impl AdaptiveGrid {
    /// `top` with every cell that one of `boxes` overlaps cut into `split`³ cells, and those
    /// again, down to `depth` levels below the top. A cell is cut only while the leaves
    /// stay under `max_leaves`, top cells first in order (the cut stops short, never the
    /// covering: every part of the grid stays in some leaf).
    pub fn refined(
        top: Grid,
        boxes: &[(Vec3, Vec3)],
        split: u32,
        depth: u32,
        max_leaves: usize,
    ) -> AdaptiveGrid {
        if depth == 0 || boxes.is_empty() || split < 2 {
            return top.into();
        }
        // Per top cell, the boxes overlapping it.
        let mut holding: Vec<Vec<u32>> = vec![Vec::new(); top.len()];
        for (i, (lo, hi)) in boxes.iter().enumerate() {
            top.voxels_in_box(*lo, *hi, |c| holding[c].push(i as u32));
        }
        let mut cuts = Cuts {
            nodes: vec![Node {
                grid: top.clone(),
                cells: vec![0; top.len()],
                top_cell: u32::MAX,
            }],
            leaves: Vec::new(),
        };
        // One more leaf per cut cell would be split³ - 1; the whole subtree at most that many
        // per level below.
        let per_cut = (split as usize).pow(3 * depth);
        let mut budget = max_leaves.saturating_sub(top.len());
        for (c, held) in holding.iter().enumerate() {
            let entry = if !held.is_empty() && per_cut <= budget {
                budget -= per_cut;
                let (lo, hi) = top.voxel_box(c);
                let grid = Grid::new(lo, hi, [split; 3]);
                let mine: Vec<(Vec3, Vec3)> = held.iter().map(|&i| boxes[i as usize]).collect();
                cuts.add_node(grid, &mine, split, depth - 1, c as u32)
            } else {
                cuts.leaves.push((0, c as u32));
                (cuts.leaves.len() - 1) as u32
            };
            cuts.nodes[0].cells[c] = entry;
        }
        AdaptiveGrid {
            top,
            cuts: Some(Arc::new(cuts)),
        }
    }

    /// How many leaves there are.
    pub fn len(&self) -> usize {
        match &self.cuts {
            None => self.top.len(),
            Some(cuts) => cuts.leaves.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The box of leaf `leaf`.
    pub(crate) fn voxel_box(&self, leaf: usize) -> (Vec3, Vec3) {
        match &self.cuts {
            None => self.top.voxel_box(leaf),
            Some(cuts) => {
                let (node, cell) = cuts.leaves[leaf];
                cuts.nodes[node as usize].grid.voxel_box(cell as usize)
            }
        }
    }

    /// The top grid's cell holding leaf `leaf`.
    pub(crate) fn top_cell(&self, leaf: usize) -> usize {
        match &self.cuts {
            None => leaf,
            Some(cuts) => {
                let (node, cell) = cuts.leaves[leaf];
                match node {
                    0 => cell as usize,
                    n => cuts.nodes[n as usize].top_cell as usize,
                }
            }
        }
    }

    /// Every leaf overlapping the box `[lo, hi]` (none if it misses the grid).
    pub(crate) fn voxels_in_box(&self, lo: Vec3, hi: Vec3, mut f: impl FnMut(usize)) {
        match &self.cuts {
            None => self.top.voxels_in_box(lo, hi, f),
            Some(cuts) => cuts.in_box(0, lo, hi, &mut f),
        }
    }

    /// Walks the segment `origin + t·dir`, `t ∈ [t0, t1]`, through the leaves, calling `f`
    /// on every leaf it crosses, in order. Parts outside the grid are skipped.
    #[cfg(test)]
    pub fn walk(&self, origin: Vec3, dir: Vec3, t0: f32, t1: f32, mut f: impl FnMut(usize)) {
        self.walk_spans(origin, dir, t0, t1, |v, _, _| f(v));
    }

    /// [`walk`](Self::walk), also giving the parameter span `[ta, tb]` the segment spends
    /// in each leaf.
    #[cfg(test)]
    pub(crate) fn walk_spans(
        &self,
        origin: Vec3,
        dir: Vec3,
        t0: f32,
        t1: f32,
        f: impl FnMut(usize, f32, f32),
    ) {
        let inv = dir.recip();
        if let Some((tin, tout)) =
            super::grid::clip(self.top.lo, self.top.hi, origin, dir, inv, t0, t1)
        {
            self.walk_clipped(origin, dir, inv, tin, tout, f);
        }
    }

    /// The walk of a segment already clipped to `[tin, tout]` inside the top grid's box
    /// (`inv` = 1 / `dir`).
    #[inline(always)]
    pub(crate) fn walk_clipped(
        &self,
        origin: Vec3,
        dir: Vec3,
        inv: Vec3,
        tin: f32,
        tout: f32,
        mut f: impl FnMut(usize, f32, f32),
    ) {
        match &self.cuts {
            // (The uniform walk stays inlined: the recorder of voxel tables runs it.)
            None => self.top.walk_clipped(origin, dir, inv, tin, tout, f),
            Some(cuts) => {
                let mut visit = |v, ta, tb| {
                    f(v, ta, tb);
                    false
                };
                cuts.walk(0, origin, dir, inv, tin, tout, &mut visit, &mut false)
            }
        }
    }

    /// Whether `found` holds for a leaf of the walk of [`walk_clipped`](Self::walk_clipped),
    /// which stops at the first such leaf (in a cut cell: the nested walks after it are
    /// not started).
    #[inline(always)]
    pub(crate) fn find_clipped(
        &self,
        origin: Vec3,
        dir: Vec3,
        inv: Vec3,
        tin: f32,
        tout: f32,
        mut found: impl FnMut(usize) -> bool,
    ) -> bool {
        let mut stop = false;
        match &self.cuts {
            None => (self.top).walk_clipped(origin, dir, inv, tin, tout, |v, _, _| {
                stop = stop || found(v);
            }),
            Some(cuts) => {
                let mut visit = |v, _, _| found(v);
                cuts.walk(0, origin, dir, inv, tin, tout, &mut visit, &mut stop)
            }
        }
        stop
    }
}

impl Cuts {
    /// Adds a node of `grid` (in top cell `top_cell`), its cells holding one of `boxes` cut
    /// `depth` levels more; returns its cell entry.
    fn add_node(
        &mut self,
        grid: Grid,
        boxes: &[(Vec3, Vec3)],
        split: u32,
        depth: u32,
        top_cell: u32,
    ) -> u32 {
        let index = self.nodes.len();
        let mut holding: Vec<Vec<u32>> = vec![Vec::new(); grid.len()];
        if depth > 0 {
            for (i, (lo, hi)) in boxes.iter().enumerate() {
                grid.voxels_in_box(*lo, *hi, |c| holding[c].push(i as u32));
            }
        }
        self.nodes.push(Node {
            grid: grid.clone(),
            cells: vec![0; grid.len()],
            top_cell,
        });
        for (c, held) in holding.iter().enumerate() {
            let entry = if held.is_empty() {
                self.leaves.push((index as u32, c as u32));
                (self.leaves.len() - 1) as u32
            } else {
                let (lo, hi) = grid.voxel_box(c);
                let mine: Vec<(Vec3, Vec3)> = held.iter().map(|&i| boxes[i as usize]).collect();
                let child = Grid::new(lo, hi, [split; 3]);
                self.add_node(child, &mine, split, depth - 1, top_cell)
            };
            self.nodes[index].cells[c] = entry;
        }
        CHILD | index as u32
    }

    fn in_box(&self, node: usize, lo: Vec3, hi: Vec3, f: &mut dyn FnMut(usize)) {
        let n = &self.nodes[node];
        n.grid.voxels_in_box(lo, hi, |c| match n.cells[c] {
            e if e & CHILD != 0 => self.in_box((e & !CHILD) as usize, lo, hi, f),
            leaf => f(leaf as usize),
        });
    }

    /// The walk through `node` of the segment's span `[tin, tout]` in it: each cut cell's
    /// span is walked through its child (whose walk clamps its ends into the child's box,
    /// so rounding at a cell's side cannot drop the span). Once `f` returns true, `stop` is
    /// set and no more leaves are visited.
    #[allow(clippy::too_many_arguments)]
    fn walk(
        &self,
        node: usize,
        origin: Vec3,
        dir: Vec3,
        inv: Vec3,
        tin: f32,
        tout: f32,
        f: &mut dyn FnMut(usize, f32, f32) -> bool,
        stop: &mut bool,
    ) {
        let n = &self.nodes[node];
        n.grid
            .walk_clipped(origin, dir, inv, tin, tout, |c, ta, tb| {
                if *stop {
                    return;
                }
                match n.cells[c] {
                    e if e & CHILD != 0 => {
                        let child = (e & !CHILD) as usize;
                        self.walk(child, origin, dir, inv, ta, tb, f, stop)
                    }
                    leaf => *stop = f(leaf as usize, ta, tb),
                }
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    fn random_point(rng: &mut Rng, lo: Vec3, hi: Vec3) -> Vec3 {
        lo + (hi - lo) * Vec3::new(rng.uniform(), rng.uniform(), rng.uniform())
    }

    /// A grid cut around a few small boxes (one crossing a cell's side, one in a corner).
    fn cut_grid(depth: u32) -> (AdaptiveGrid, Vec<(Vec3, Vec3)>) {
        let top = Grid::new(
            Vec3::new(-1.0, 0.0, 2.0),
            Vec3::new(3.0, 2.0, 5.0),
            [5, 4, 3],
        );
        let boxes = vec![
            (Vec3::new(0.5, 0.4, 3.1), Vec3::new(0.9, 0.6, 3.3)),
            (Vec3::new(0.58, 0.98, 2.98), Vec3::new(0.62, 1.02, 3.02)),
            (Vec3::new(2.9, 1.9, 4.9), Vec3::new(3.0, 2.0, 5.0)),
        ];
        (
            AdaptiveGrid::refined(top, &boxes, 2, depth, usize::MAX),
            boxes,
        )
    }

    /// Leaves are numbered `0..len`, each once; their boxes tile the top grid's box (their
    /// volumes add up to it, and a random point lies in exactly one leaf, up to rounding on
    /// the sides); the cut reaches its depth where the boxes are and only there.
    #[test]
    fn leaves_are_contiguous_and_tile_the_root() {
        for depth in [0, 1, 3] {
            let (grid, boxes) = cut_grid(depth);
            let n = grid.len();
            let mut seen = vec![0u32; n];
            let (lo, hi) = grid.extent();
            grid.voxels_in_box(lo, hi, |v| seen[v] += 1);
            assert!(seen.iter().all(|&s| s == 1), "depth {depth}: {seen:?}");
            let volume = |(a, b): (Vec3, Vec3)| (b - a).x * (b - a).y * (b - a).z;
            let total: f32 = (0..n).map(|v| volume(grid.voxel_box(v))).sum();
            assert!((total / volume((lo, hi)) - 1.0).abs() < 1e-4, "{total}");
            let smallest = (0..n)
                .map(|v| volume(grid.voxel_box(v)))
                .fold(f32::MAX, f32::min);
            let expected = volume(grid.top.voxel_box(0)) / 8f32.powi(depth as i32);
            assert!((smallest / expected - 1.0).abs() < 1e-3, "depth {depth}");
            let mut rng = Rng::for_key(depth as u64, &[]);
            for _ in 0..2000 {
                let p = random_point(&mut rng, lo, hi);
                let holding = (0..n)
                    .filter(|&v| {
                        let (a, b) = grid.voxel_box(v);
                        p.cmpge(a).all() && p.cmplt(b).all()
                    })
                    .count();
                assert_eq!(holding, 1, "{p}");
            }
            // Every leaf the boxes overlap is at the finest depth.
            for (a, b) in &boxes {
                grid.voxels_in_box(*a, *b, |v| {
                    let size = volume(grid.voxel_box(v));
                    assert!((size / expected - 1.0).abs() < 1e-3, "leaf {v} of {size}");
                    let (c, _) = grid.voxel_box(v);
                    let mut top = usize::MAX;
                    grid.top.voxels_in_box(c + 1e-4, c + 1e-4, |t| top = t);
                    assert_eq!(grid.top_cell(v), top);
                });
            }
        }
    }

    /// The walk visits, in order of `t`, exactly the leaves a brute-force test finds the
    /// segment meeting (slab test against each leaf's box), save leaves it only grazes
    /// (within a rounding error of a side or a corner), and its spans join end to end.
    #[test]
    fn walk_visits_the_leaves_the_segment_meets() {
        let (grid, _) = cut_grid(3);
        let (lo, hi) = grid.extent();
        let mut rng = Rng::for_key(11, &[]);
        let eps = 1e-4;
        for i in 0..3000 {
            // Segments from the whole grid, and many through the cut places.
            let near = Vec3::new(0.7, 0.8, 3.1);
            let origin = if i % 2 == 0 {
                random_point(&mut rng, lo - 1.0, hi + 1.0)
            } else {
                random_point(&mut rng, near - 0.5, near + 0.5)
            };
            let to = random_point(&mut rng, lo - 1.0, hi + 1.0);
            let dir = to - origin;
            let (t0, t1) = (0.0, 1.0);
            let mut walked = Vec::new();
            let mut last_t: Option<f32> = None;
            grid.walk_spans(origin, dir, t0, t1, |v, ta, tb| {
                assert!(ta <= tb + 1e-6, "span [{ta}, {tb}]");
                if let Some(t) = last_t {
                    assert!((ta - t).abs() <= 1e-5, "gap {t} .. {ta}");
                }
                last_t = Some(tb);
                walked.push(v);
            });
            let mut sorted = walked.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(
                sorted.len(),
                walked.len(),
                "a leaf walked twice: {walked:?}"
            );
            let meets = |v: usize, grow: f32| {
                let (a, b) = grid.voxel_box(v);
                let inv = dir.recip();
                super::super::grid::clip(a - grow, b + grow, origin, dir, inv, t0, t1).is_some()
            };
            for v in 0..grid.len() {
                let inside = meets(v, -eps);
                let touches = meets(v, eps);
                let found = walked.contains(&v);
                assert!(!inside || found, "segment {i} meets leaf {v} off the walk");
                assert!(!found || touches, "segment {i} walks leaf {v} it misses");
            }
        }
    }
}
