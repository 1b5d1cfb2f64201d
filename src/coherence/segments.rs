//! Segment records: the other form of the voxel records (`--records segments`, the default).
//!
//! The voxel tables ([`super::tables`]) are filled as the rays are traced: every segment is
//! walked through the grid then, although most of what it marks is never read (a record is
//! read only when its voxel changes, and a block retraced before that drops it unread). Here
//! each block keeps the segments themselves instead, clipped to the box around the voxels
//! where a later frame changes something, and a frame walks them, with the same 3-D DDA,
//! through the voxels that changed in it. The blocks found are those whose bit the tables
//! would hold in a changed voxel, so the same blocks are retraced; what changes is when the
//! walking is done, and how much of it: only for the segments near a change, once per frame
//! they stay relevant, and not at all for the rest. Recording a ray costs the clip and a
//! copy of two points instead of a walk (docs/animation.md, "Segment records", has the
//! measurements). The price is memory: 24 bytes a segment that reaches the box.

use super::grid::ActiveVoxels;
use super::tables::{BlockLayout, BlockSet, Table, VoxelTables};
use crate::math::Vec3;
use rayon::prelude::*;

/// A recorded segment's end points, clipped to the recording box.
pub type Segment = [Vec3; 2];

/// What one block's rays recorded.
#[derive(Clone, Debug)]
pub struct BlockSegments {
    /// Segments of rays looking for surfaces (camera, reflection, refraction, bounces).
    pub surface: Vec<Segment>,
    /// Segments of shadow rays.
    pub shadow: Vec<Segment>,
    /// The box around every segment of both lists (empty: lo > hi), made by
    /// [`seal`](Self::seal) when the lists are complete (not per push: recording is the
    /// part every ray pays for).
    lo: Vec3,
    hi: Vec3,
}

impl Default for BlockSegments {
    fn default() -> Self {
        BlockSegments::new()
    }
}

impl BlockSegments {
    pub const fn new() -> BlockSegments {
        BlockSegments {
            surface: Vec::new(),
            shadow: Vec::new(),
            lo: Vec3::splat(f32::INFINITY),
            hi: Vec3::splat(f32::NEG_INFINITY),
        }
    }

    #[inline]
    pub fn push(&mut self, table: Table, s: Segment) {
        match table {
            Table::Surface => self.surface.push(s),
            Table::Shadow => self.shadow.push(s),
        }
    }

    /// Adds another part's segments (a block traced in several tiles); the box is the union
    /// of both boxes (exact if both lists were sealed).
    pub fn append(&mut self, mut other: BlockSegments) {
        if self.is_empty() {
            // The usual case (a block traced in one task): no copy.
            *self = other;
        } else {
            self.surface.append(&mut other.surface);
            self.shadow.append(&mut other.shadow);
            (self.lo, self.hi) = (self.lo.min(other.lo), self.hi.max(other.hi));
        }
    }

    /// Whether the box is missing although there are segments (not sealed yet).
    fn unsealed(&self) -> bool {
        !self.is_empty() && !self.lo.cmple(self.hi).all()
    }

    /// Makes the box around the segments.
    pub fn seal(&mut self) {
        // Plain comparisons (the clipped ends are never NaN): one instruction each.
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in self.surface.iter().chain(&self.shadow).flatten() {
            for k in 0..3 {
                lo[k] = if p[k] < lo[k] { p[k] } else { lo[k] };
                hi[k] = if p[k] > hi[k] { p[k] } else { hi[k] };
            }
        }
        (self.lo, self.hi) = (Vec3::from_array(lo), Vec3::from_array(hi));
    }

    /// Empties the lists, keeping their memory.
    pub fn clear(&mut self) {
        self.surface.clear();
        self.shadow.clear();
        self.lo = Vec3::splat(f32::INFINITY);
        self.hi = Vec3::splat(f32::NEG_INFINITY);
    }

    pub fn len(&self) -> usize {
        self.surface.len() + self.shadow.len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether a segment crosses a voxel of `changed` (surface segments) or of `shadows`
    /// (shadow segments; `shadows` holds `changed`). The lists must be sealed.
    fn crosses(&self, changed: &Changed, shadows: &Changed) -> bool {
        let test = |list: &[Segment], c: &Changed| {
            c.overlaps(self.lo, self.hi)
                && list
                    .iter()
                    .any(|s| c.overlaps(s[0].min(s[1]), s[0].max(s[1])) && c.voxels.crosses(*s))
        };
        test(&self.surface, changed) || test(&self.shadow, shadows)
    }
}

/// The voxels that changed in a frame, and the box around them.
pub struct Changed {
    pub voxels: ActiveVoxels,
    bounds: Option<(Vec3, Vec3)>,
}

impl Changed {
    pub fn new(voxels: ActiveVoxels) -> Changed {
        let bounds = voxels.bounds();
        Changed { voxels, bounds }
    }

    /// Whether the box `[lo, hi]` meets the box around the changed voxels (a segment whose
    /// box misses it crosses none of them; the walk would find the same, more slowly).
    #[inline]
    fn overlaps(&self, lo: Vec3, hi: Vec3) -> bool {
        self.bounds
            .is_some_and(|(a, b)| lo.cmple(b).all() && hi.cmpge(a).all())
    }
}

/// Every block's recorded segments, and the blocks whose rays found a surface.
pub struct SegmentRecords {
    blocks: Vec<BlockSegments>,
    hits: BlockSet,
}

impl SegmentRecords {
    pub fn new(layout: &BlockLayout) -> SegmentRecords {
        SegmentRecords {
            blocks: (0..layout.len()).map(|_| BlockSegments::new()).collect(),
            hits: BlockSet::new(layout),
        }
    }

    /// Adds what a part of block `b` recorded (sealed here if it is not).
    pub fn add(&mut self, b: usize, mut segments: BlockSegments, hit: bool) {
        // The recorder seals its lists in the task, while they are in its cache.
        if segments.unsealed() {
            segments.seal();
        }
        self.blocks[b].append(segments);
        if hit {
            self.hits.insert(b);
        }
    }

    /// Forgets the records of `blocks` (about to be retraced).
    pub fn clear(&mut self, blocks: &BlockSet) {
        for b in blocks.iter() {
            self.blocks[b] = BlockSegments::new();
        }
        for (w, m) in self.hits.words.iter_mut().zip(&blocks.words) {
            *w &= !m;
        }
    }

    /// Adds to `into` every block with a surface segment crossing `changed` or a shadow
    /// segment crossing `shadows` (which must hold `changed`). Blocks already in `into` are
    /// not looked at. Parallel over blocks; the set does not depend on the schedule.
    pub fn collect(&self, changed: &Changed, shadows: &Changed, into: &mut BlockSet) {
        let found: Vec<usize> = self
            .blocks
            .par_iter()
            .enumerate()
            .filter(|(b, s)| !into.contains(*b) && s.crosses(changed, shadows))
            .map(|(b, _)| b)
            .collect();
        for b in found {
            into.insert(b);
        }
    }

    pub fn collect_hits(&self, into: &mut BlockSet) {
        for (w, h) in into.words.iter_mut().zip(&self.hits.words) {
            *w |= h;
        }
    }

    /// The same records as voxel tables: every segment walked into the tables of the active
    /// voxels it crosses (what the tables would hold had they been kept from the start,
    /// for every voxel still active).
    pub fn to_tables(&self, voxels: &ActiveVoxels, layout: &BlockLayout) -> VoxelTables {
        let tables = VoxelTables::new(voxels.fine.len(), layout);
        self.blocks.par_iter().enumerate().for_each(|(b, s)| {
            for (table, list) in [(Table::Surface, &s.surface), (Table::Shadow, &s.shadow)] {
                for &[a, e] in list {
                    voxels.walk(a, e - a, 0.0, 1.0, |v| tables.set(table, v, b));
                }
            }
        });
        for b in self.hits.iter() {
            tables.set_hit(b);
        }
        tables
    }

    /// Segments held.
    pub fn segments(&self) -> usize {
        self.blocks.iter().map(BlockSegments::len).sum()
    }

    /// Bytes the segments take (their lists' capacity).
    pub fn memory_bytes(&self) -> usize {
        self.blocks
            .iter()
            .map(|s| (s.surface.capacity() + s.shadow.capacity()) * std::mem::size_of::<Segment>())
            .sum::<usize>()
            + self.hits.words.len() * 8
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coherence::grid::Grid;
    use crate::math::Rng;

    /// A kept segment finds a changed voxel exactly when the voxel tables would have the
    /// block's bit in one: the same walk, made later over the clipped segment, against the
    /// recording set's walk made at once. Random segments (through, into, out of and past
    /// the recording region; to infinity too) and random changed subsets of it.
    #[test]
    fn a_kept_segment_crosses_the_changed_voxels_the_tables_would_hold() {
        let grid = Grid::new(
            Vec3::new(-1.0, 0.0, 0.5),
            Vec3::new(3.0, 2.5, 2.0),
            [13, 9, 6],
        );
        let mut rng = Rng::for_key(7, &[1]);
        let mut point = |scale: f32| {
            Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 8.0 * scale
                - Vec3::splat(3.0 * scale)
        };
        let (mut crossing, mut total) = (0, 0);
        for round in 0..40 {
            // The recording region: two boxes; the changed voxels: about half of it.
            let boxes = [(point(0.4), point(0.4)), (point(0.3), point(0.3))]
                .map(|(a, b)| (a.min(b), a.max(b)));
            let recording = ActiveVoxels::boxes(grid.clone(), &boxes, 0.0);
            let mut mask = vec![false; grid.len()];
            let mut select = Rng::for_key(7, &[2, round]);
            for (v, m) in mask.iter_mut().enumerate() {
                *m = recording.is_active(v) && select.uniform() < 0.5;
            }
            let changed = Changed::new(ActiveVoxels::from_mask(grid.clone(), &mask));
            for i in 0..500 {
                let o = point(0.6);
                let d = point(0.6) - o;
                let (t0, t1) = match i % 4 {
                    0 => (0.0, 1.0),
                    1 => (0.2, 0.7),
                    2 => (1e-4, f32::INFINITY),
                    _ => (0.0, 0.05),
                };
                let mut tables = false;
                recording.walk(o, d, t0, t1, |v| tables |= mask[v]);
                let mut kept = BlockSegments::new();
                if let Some(s) = recording.clip_segment(o, d, t0, t1) {
                    kept.push(Table::Surface, s);
                }
                kept.seal();
                let none = Changed::new(ActiveVoxels::from_mask(grid.clone(), &[]));
                assert_eq!(
                    kept.crosses(&changed, &none),
                    tables,
                    "segment {o} + t {d}, t in [{t0}, {t1}], round {round}"
                );
                // Shadow segments answer to the shadow set.
                let mut shadow = BlockSegments::new();
                if let Some(s) = recording.clip_segment(o, d, t0, t1) {
                    shadow.push(Table::Shadow, s);
                }
                shadow.seal();
                assert_eq!(shadow.crosses(&none, &changed), tables);
                assert!(!shadow.crosses(&changed, &none));
                crossing += tables as usize;
                total += 1;
            }
        }
        // The test means something only if both answers occur often.
        assert!(
            crossing > total / 20 && crossing < total * 9 / 10,
            "{crossing} of {total}"
        );
    }

    #[test]
    fn records_of_retraced_blocks_are_forgotten() {
        let layout = BlockLayout::new(40, 30, 4, 3);
        let grid = Grid::new(Vec3::ZERO, Vec3::ONE, [4, 4, 4]);
        let all = Changed::new(ActiveVoxels::all(grid.clone()));
        let mut records = SegmentRecords::new(&layout);
        let through = [Vec3::new(-1.0, 0.5, 0.5), Vec3::new(2.0, 0.5, 0.5)];
        for b in [1, 5, 7] {
            let mut s = BlockSegments::new();
            s.push(Table::Surface, through);
            records.add(b, s, b == 5);
        }
        let mut found = BlockSet::new(&layout);
        records.collect(&all, &all, &mut found);
        assert_eq!(found.iter().collect::<Vec<_>>(), [1, 5, 7]);
        let mut hits = BlockSet::new(&layout);
        records.collect_hits(&mut hits);
        assert_eq!(hits.iter().collect::<Vec<_>>(), [5]);
        let mut retraced = BlockSet::new(&layout);
        retraced.insert(5);
        records.clear(&retraced);
        let mut found = BlockSet::new(&layout);
        records.collect(&all, &all, &mut found);
        assert_eq!(found.iter().collect::<Vec<_>>(), [1, 7]);
        let mut hits = BlockSet::new(&layout);
        records.collect_hits(&mut hits);
        assert_eq!(hits.count(), 0);
        assert_eq!(records.segments(), 2);
    }
}
