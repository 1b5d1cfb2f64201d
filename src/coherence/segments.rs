//! Segment records: the other form of the voxel records (`--records segments`, the default).
//!
//! The voxel tables ([`super::tables`]) are filled as the rays are traced: every segment is
//! walked through the grid then, although most of what it marks is never read (a record is
//! read only when its voxel changes, and a block retraced before that drops it unread). Here
//! each block keeps the segments themselves instead, clipped to the box around the voxels
//! where a later frame changes something, and a frame walks them, with the same 3-D DDA,
//! through the voxels that changed in it (the voxels a changed surface passes through cut
//! finer: `super::adaptive`; the segments do not depend on the grid). Recording a ray costs
//! the clip and a copy of two points instead of a walk (docs/animation.md, "Segment
//! records", has the measurements).
//!
//! The points are kept in 16 bits an axis over the grid's box ([`Quantiser`]): 12 bytes a
//! segment, half the memory (and the memory traffic of frame 0) of two `Vec3`. Most
//! segments share one end with others of their block (a pinhole camera's position, a point
//! light's): those are kept as their other end alone, in a list per shared point ([`Shared`],
//! 6 bytes a segment). A kept
//! segment is then within one step of the 16-bit lattice of the traced one, so the renderer
//! grows the changed boxes by that step ([`Quantiser::error`]): a segment that met a changed
//! object still crosses a voxel marked changed, and the frames stay the same.

use super::grid::{ActiveVoxels, Extent, Grid};
use super::tables::{BlockLayout, BlockSet, Table, VoxelTables};
use crate::math::Vec3;
use glam::Vec3A;
use rayon::prelude::*;

/// A point in 16 bits an axis over the quantiser's box.
pub type Point16 = [u16; 3];

/// A recorded segment's end points, clipped to the recording box and quantised.
pub type Segment = [Point16; 2];

/// The 16-bit lattice over a grid's box (grown by a hair, so that the clipped ends, which
/// may lie that far outside the grid, are not clamped).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantiser {
    lo: Vec3A,
    scale: Vec3A,
    step: Vec3,
}

/// The largest 16-bit coordinate.
const TOP: f32 = u16::MAX as f32;

impl Quantiser {
    pub fn new(grid: &impl Extent) -> Quantiser {
        let (lo, hi) = grid.extent();
        // Twice the growth of the box around the active voxels (`ActiveVoxels::bounds`).
        let pad = (hi - lo).length() * 2e-5;
        let (lo, hi) = (lo - pad, hi + pad);
        let step = (hi - lo) / TOP;
        Quantiser {
            lo: lo.into(),
            scale: step.recip().into(),
            step,
        }
    }

    /// How far (along any axis) a decoded point can be from the point encoded, with room
    /// to spare: half a step of rounding, and the float rounding of both ways.
    pub fn error(&self) -> f32 {
        self.step.max_element()
    }

    /// The nearest lattice point to `p` (clamped to the box).
    #[inline(always)]
    pub fn encode(&self, p: Vec3A) -> Point16 {
        // Adding 2^23 to a value in [0, 2^16) leaves it, rounded to the nearest integer, in
        // the low bits of the sum: one addition in the SSE lanes instead of three
        // saturating conversions.
        let f = ((p - self.lo) * self.scale)
            .max(Vec3A::ZERO)
            .min(Vec3A::splat(TOP))
            + Vec3A::splat(8_388_608.0);
        [f.x, f.y, f.z].map(|x| x.to_bits() as u16)
    }

    /// The lattice point `q` lies at or beyond `p` on every axis (`up`), or at or before it.
    fn bound(&self, p: Vec3, up: bool) -> Point16 {
        let f = ((Vec3A::from(p) - self.lo) * self.scale).clamp(Vec3A::ZERO, Vec3A::splat(TOP));
        let f = if up { f.ceil() } else { f.floor() };
        [f.x as u16, f.y as u16, f.z as u16]
    }

    #[inline(always)]
    pub fn decode(&self, q: Point16) -> Vec3 {
        Vec3::from(self.lo) + Vec3::new(q[0] as f32, q[1] as f32, q[2] as f32) * self.step
    }
}

/// Segments of one table that share one end point, kept as their other ends.
#[derive(Clone, Debug)]
pub struct Shared {
    pub table: Table,
    /// Whether the shared point is the segments' start (a camera's position) or their end
    /// (a light's).
    pub start: bool,
    /// The shared point, exact (it may lie outside the grid, as a camera often does).
    pub point: Vec3,
    /// The shared point on the lattice (clamped to its box): what boxes are made of. The
    /// box of the key and another end holds the segment's part inside the grid.
    pub key: Point16,
    pub others: Vec<Point16>,
}

impl Shared {
    /// The segment to `other` (or from it), with the box of its lattice ends.
    #[inline]
    fn segment(&self, q: &Quantiser, other: Point16) -> ([Vec3; 2], Point16, Point16) {
        let (o, k) = (q.decode(other), self.key);
        let ends = if self.start {
            [self.point, o]
        } else {
            [o, self.point]
        };
        let lo = [0, 1, 2].map(|i| k[i].min(other[i]));
        let hi = [0, 1, 2].map(|i| k[i].max(other[i]));
        (ends, lo, hi)
    }
}

/// What one block's rays recorded.
#[derive(Clone, Debug)]
pub struct BlockSegments {
    /// Segments of rays looking for surfaces (camera, reflection, refraction, bounces).
    pub surface: Vec<Segment>,
    /// Segments of shadow rays.
    pub shadow: Vec<Segment>,
    /// More segments, kept by their other end in a list per end point they share (in the
    /// recorder's slot for that point).
    pub shared: Vec<Shared>,
    /// The box around every segment of both lists (empty: lo > hi), made by
    /// [`seal`](Self::seal) when the lists are complete (not per push: recording is the
    /// part every ray pays for).
    lo: Point16,
    hi: Point16,
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
            shared: Vec::new(),
            lo: [u16::MAX; 3],
            hi: [0; 3],
        }
    }

    /// Empty lists with room for as many segments as `like` had room for, or a quarter
    /// more than it holds (the next task's blocks are alike; a list that has to grow is
    /// copied, where room not used is given back in place when the block takes its lists).
    pub fn with_room_of(like: &BlockSegments) -> BlockSegments {
        fn room<T, U>(list: &Vec<T>) -> Vec<U> {
            let n = list.len();
            Vec::with_capacity(list.capacity().max(n + n / 4))
        }
        BlockSegments {
            surface: room(&like.surface),
            shadow: room(&like.shadow),
            shared: (like.shared.iter())
                .map(|l| Shared {
                    others: room(&l.others),
                    ..*l
                })
                .collect(),
            ..BlockSegments::new()
        }
    }

    #[inline]
    pub fn push(&mut self, table: Table, s: Segment) {
        match table {
            Table::Surface => self.surface.push(s),
            Table::Shadow => self.shadow.push(s),
        }
    }

    /// Adds a segment from `other` to the shared point (or from the shared point when
    /// `start`) to the list in `slot`, which keeps the segments of `table` sharing `point`
    /// (`key` on the lattice). The recorder gives each shared point a slot of its own.
    #[inline]
    pub fn push_shared(&mut self, slot: usize, list: (Table, bool, Vec3, Point16), other: Point16) {
        // Every push but a list's first: the list's own point is not even read.
        match self.shared.get_mut(slot) {
            Some(l) if !l.others.is_empty() => l.others.push(other),
            _ => self.open_shared(slot, list, other),
        }
    }

    #[cold]
    #[inline(never)]
    fn open_shared(&mut self, slot: usize, list: (Table, bool, Vec3, Point16), other: Point16) {
        let (table, start, point, key) = list;
        let fresh = || Shared {
            table,
            start,
            point,
            key,
            others: Vec::new(),
        };
        if slot >= self.shared.len() {
            self.shared.resize_with(slot + 1, fresh);
        }
        let l = &mut self.shared[slot];
        if l.others.is_empty() {
            *l = Shared {
                others: std::mem::take(&mut l.others),
                ..fresh()
            };
        }
        debug_assert!(
            l.point == point && l.table == table,
            "a slot keeps one point"
        );
        l.others.push(other);
    }

    /// Every segment of `table` kept in a shared list, with the box of its lattice ends.
    fn shared_of(
        &self,
        table: Table,
        q: Quantiser,
    ) -> impl Iterator<Item = ([Vec3; 2], Point16, Point16)> + '_ {
        (self.shared.iter().filter(move |l| l.table == table))
            .flat_map(move |l| l.others.iter().map(move |&o| l.segment(&q, o)))
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
            for mut l in other.shared {
                let same = |m: &&mut Shared| {
                    (m.table, m.start, m.point.to_array()) == (l.table, l.start, l.point.to_array())
                };
                match self.shared.iter_mut().find(same) {
                    Some(mine) => mine.others.append(&mut l.others),
                    None => self.shared.push(l),
                }
            }
            for k in 0..3 {
                self.lo[k] = self.lo[k].min(other.lo[k]);
                self.hi[k] = self.hi[k].max(other.hi[k]);
            }
        }
    }

    /// Whether the box is missing although there are segments (not sealed yet).
    fn unsealed(&self) -> bool {
        !self.is_empty() && (0..3).any(|k| self.lo[k] > self.hi[k])
    }

    /// Makes the box around the segments.
    pub fn seal(&mut self) {
        let (mut lo, mut hi) = ([u16::MAX; 3], [0u16; 3]);
        let lists = (self.shared.iter()).filter(|l| !l.others.is_empty());
        let flat = [self.surface.as_flattened(), self.shadow.as_flattened()];
        let flat = (flat.into_iter()).chain(lists.map(|l| std::slice::from_ref(&l.key)));
        let others = (self.shared.iter()).map(|l| l.others.as_slice());
        for points in flat.chain(others) {
            let (a, b) = point_box(points);
            for k in 0..3 {
                lo[k] = lo[k].min(a[k]);
                hi[k] = hi[k].max(b[k]);
            }
        }
        (self.lo, self.hi) = (lo, hi);
    }

    /// Frees the lists' spare capacity (in place: the allocator shrinks a block without a
    /// copy).
    pub fn shrink_to_fit(&mut self) {
        self.surface.shrink_to_fit();
        self.shadow.shrink_to_fit();
        self.shared.retain(|l| !l.others.is_empty());
        for l in &mut self.shared {
            l.others.shrink_to_fit();
        }
        self.shared.shrink_to_fit();
    }

    /// Empties the lists, keeping their memory.
    pub fn clear(&mut self) {
        self.surface.clear();
        self.shadow.clear();
        self.shared.clear();
        (self.lo, self.hi) = ([u16::MAX; 3], [0; 3]);
    }

    pub fn len(&self) -> usize {
        let shared: usize = self.shared.iter().map(|l| l.others.len()).sum();
        self.surface.len() + self.shadow.len() + shared
    }

    /// Bytes the lists take (their capacity).
    pub fn memory_bytes(&self) -> usize {
        let point = std::mem::size_of::<Point16>();
        let shared: usize = (self.shared.iter())
            .map(|l| l.others.capacity() * point)
            .sum();
        (self.surface.capacity() + self.shadow.capacity()) * 2 * point
            + self.shared.capacity() * std::mem::size_of::<Shared>()
            + shared
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether a segment crosses a voxel of `changed` (surface segments) or of `shadows`
    /// (shadow segments; `shadows` holds `changed`). The lists must be sealed.
    fn crosses(&self, changed: &Changed, shadows: &Changed) -> bool {
        let q = changed.quantiser;
        let test = |c: &Changed, table: Table, list: &[Segment]| {
            c.overlaps(self.lo, self.hi)
                && (list.iter().any(|&[a, b]| {
                    let lo = [0, 1, 2].map(|k| a[k].min(b[k]));
                    let hi = [0, 1, 2].map(|k| a[k].max(b[k]));
                    c.overlaps(lo, hi) && c.voxels.crosses([q.decode(a), q.decode(b)])
                }) || (self.shared_of(table, q))
                    .any(|(ends, lo, hi)| c.overlaps(lo, hi) && c.voxels.crosses(ends)))
        };
        test(changed, Table::Surface, &self.surface) || test(shadows, Table::Shadow, &self.shadow)
    }
}

/// The box around `points` (empty: lo > hi). Eight points (24 coordinates) at a time, each
/// lane keeping one axis, so that the loop runs in vector lanes (sealing reads every record
/// of frame 0); as signed numbers (the top bit flipped: the same order), whose minimum and
/// maximum the baseline x86-64 lanes have.
fn point_box(points: &[Point16]) -> (Point16, Point16) {
    const LANES: usize = 24;
    let signed = |x: u16| (x ^ 0x8000) as i16;
    let flat = points.as_flattened();
    let chunks = flat.chunks_exact(LANES);
    let rest = chunks.remainder();
    let (mut lo, mut hi) = ([i16::MAX; LANES], [i16::MIN; LANES]);
    for c in chunks {
        for i in 0..LANES {
            lo[i] = lo[i].min(signed(c[i]));
            hi[i] = hi[i].max(signed(c[i]));
        }
    }
    for (i, &x) in rest.iter().enumerate() {
        lo[i] = lo[i].min(signed(x));
        hi[i] = hi[i].max(signed(x));
    }
    let (mut a, mut b) = ([u16::MAX; 3], [0u16; 3]);
    for i in 0..LANES {
        a[i % 3] = a[i % 3].min(lo[i] as u16 ^ 0x8000);
        b[i % 3] = b[i % 3].max(hi[i] as u16 ^ 0x8000);
    }
    (a, b)
}

/// The voxels that changed in a frame, and the box around them on the records' lattice.
pub struct Changed {
    pub voxels: ActiveVoxels,
    quantiser: Quantiser,
    /// The lattice box holding the box around the changed voxels, if any.
    bounds: Option<(Point16, Point16)>,
}

impl Changed {
    pub fn new(voxels: ActiveVoxels, quantiser: Quantiser) -> Changed {
        let bounds = voxels
            .bounds()
            .map(|(lo, hi)| (quantiser.bound(lo, false), quantiser.bound(hi, true)));
        Changed {
            voxels,
            quantiser,
            bounds,
        }
    }

    /// Whether the lattice box `[lo, hi]` meets the box around the changed voxels (a
    /// segment whose box misses it crosses none of them; the walk would find the same,
    /// more slowly).
    #[inline]
    fn overlaps(&self, lo: Point16, hi: Point16) -> bool {
        self.bounds
            .is_some_and(|(a, b)| (0..3).all(|k| lo[k] <= b[k] && hi[k] >= a[k]))
    }
}

/// Every block's recorded segments, and the blocks whose rays found a surface.
pub struct SegmentRecords {
    blocks: Vec<BlockSegments>,
    hits: BlockSet,
    quantiser: Quantiser,
}

impl SegmentRecords {
    /// Records over `grid` (whose box the points are quantised over).
    pub fn new(layout: &BlockLayout, grid: &Grid) -> SegmentRecords {
        SegmentRecords {
            blocks: (0..layout.len()).map(|_| BlockSegments::new()).collect(),
            hits: BlockSet::new(layout),
            quantiser: Quantiser::new(grid),
        }
    }

    pub fn quantiser(&self) -> Quantiser {
        self.quantiser
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
            let q = self.quantiser;
            for (table, list) in [(Table::Surface, &s.surface), (Table::Shadow, &s.shadow)] {
                let whole = list.iter().map(|&[a, e]| [q.decode(a), q.decode(e)]);
                let shared = s.shared_of(table, q).map(|(ends, _, _)| ends);
                for [a, e] in whole.chain(shared) {
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
            .map(BlockSegments::memory_bytes)
            .sum::<usize>()
            + self.hits.words.len() * 8
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coherence::grid::Grid;
    use crate::math::Rng;

    /// The box made in vector lanes is the box of the points, for every count (whole groups
    /// of eight and the rest), with coordinates across the whole 16-bit range.
    #[test]
    fn point_box_is_the_box_of_the_points() {
        let mut rng = Rng::for_key(7, &[2]);
        let mut coordinate = || (rng.uniform() * 65535.0) as u16;
        let points: Vec<Point16> = (0..200)
            .map(|_| [coordinate(), coordinate(), coordinate()])
            .chain([[0, u16::MAX, 0x8000], [0x7fff, 1, u16::MAX]])
            .collect();
        for n in (0..40).chain([200, 201, 202]) {
            let (mut lo, mut hi) = ([u16::MAX; 3], [0u16; 3]);
            for p in &points[points.len() - n..] {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            assert_eq!(
                point_box(&points[points.len() - n..]),
                (lo, hi),
                "{n} points"
            );
        }
    }

    /// The segment kept for `o + t·d`, `t ∈ [t0, t1]` (clipped to `recording`, quantised),
    /// as the shadow or surface list of a block.
    fn kept(
        recording: &ActiveVoxels,
        q: &Quantiser,
        table: Table,
        (o, d, t0, t1): (Vec3, Vec3, f32, f32),
    ) -> BlockSegments {
        let mut kept = BlockSegments::new();
        if let Some([a, b]) = recording.clip_segment(o, d, t0, t1) {
            kept.push(table, [q.encode(a), q.encode(b)]);
        }
        kept.seal();
        kept
    }

    /// Whether `o + t·d`, `t ∈ [max(t0, 0), t1]`, meets the box `[lo, hi]` (in f64).
    fn meets((lo, hi): (Vec3, Vec3), (o, d, t0, t1): (Vec3, Vec3, f32, f32)) -> bool {
        let (mut a, mut b) = (f64::from(t0.max(0.0)), f64::from(t1));
        for k in 0..3 {
            let (o, d, l, h) = (o[k] as f64, d[k] as f64, lo[k] as f64, hi[k] as f64);
            if d == 0.0 {
                if o < l || o > h {
                    return false;
                }
                continue;
            }
            let (u, v) = ((l - o) / d, (h - o) / d);
            (a, b) = (a.max(u.min(v)), b.min(u.max(v)));
        }
        a <= b
    }

    /// Random segments (through, into, out of and past the recording region; to infinity
    /// too), and their `t` ranges.
    fn random_segments(seed: u64) -> impl FnMut(usize) -> (Vec3, Vec3, f32, f32) {
        let mut rng = Rng::for_key(seed, &[3]);
        move |i| {
            let mut point = || Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.8 - 1.8;
            let o = point();
            let d = point() - o;
            let (t0, t1) = match i % 4 {
                0 => (0.0, 1.0),
                1 => (0.2, 0.7),
                2 => (1e-4, f32::INFINITY),
                _ => (0.0, 0.05),
            };
            (o, d, t0, t1)
        }
    }

    fn grid() -> Grid {
        Grid::new(
            Vec3::new(-1.0, 0.0, 0.5),
            Vec3::new(3.0, 2.5, 2.0),
            [13, 9, 6],
        )
    }

    /// What keeps the frames identical: a kept segment whose ray met a changed box crosses
    /// a voxel marked by that box grown by the lattice's error, whatever the quantisation
    /// did to it (`meets` decides in f64). Random boxes and segments, many of them aimed
    /// into the box; shadow segments answer to the shadow set alone.
    #[test]
    fn a_kept_segment_finds_every_changed_box_its_ray_met() {
        let grid = grid();
        let q = Quantiser::new(&grid);
        let mut rng = Rng::for_key(7, &[1]);
        let mut segment = random_segments(7);
        let none = Changed::new(ActiveVoxels::from_mask(grid.clone(), &[]), q);
        let (mut met, mut total) = (0, 0);
        for round in 0..60 {
            let mut point = || {
                grid.lo
                    + Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * (grid.hi - grid.lo)
            };
            // A small changed box (a tenth of a voxel to two voxels), and a recording region
            // holding it and another box.
            let c = point();
            let half = grid.cell_size() * (0.05 + 0.95 * (round % 7) as f32 / 6.0);
            // (Inside the grid: a change outside it retraces the whole frame.)
            let changed_box = ((c - half).max(grid.lo), (c + half).min(grid.hi));
            let other = (point(), point());
            let region = [changed_box, (other.0.min(other.1), other.0.max(other.1))];
            let recording = ActiveVoxels::boxes(grid.clone(), &region, 2.0 * q.error());
            let changed = Changed::new(
                ActiveVoxels::boxes(grid.clone(), &[changed_box], q.error()),
                q,
            );
            for i in 0..400 {
                let mut s = segment(i);
                if i % 2 == 0 {
                    // Aimed at a point of the box, or just past its side.
                    let target = c + half
                        * 1.02
                        * (Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0 - 1.0);
                    s.1 = target - s.0;
                    s.3 = if i % 4 == 0 { 1.0 } else { f32::INFINITY };
                }
                let meets = meets(changed_box, s);
                let surface = kept(&recording, &q, Table::Surface, s);
                let shadow = kept(&recording, &q, Table::Shadow, s);
                if meets {
                    assert!(surface.crosses(&changed, &none), "round {round}: {s:?}");
                    assert!(shadow.crosses(&none, &changed), "round {round}: {s:?}");
                }
                assert!(!shadow.crosses(&changed, &none));
                met += meets as usize;
                total += 1;
            }
        }
        assert!(met > total / 10 && met < total * 9 / 10, "{met} of {total}");
    }

    /// A kept segment finds a changed voxel when the voxel tables would have the block's bit
    /// in one (the same walk, made later over the clipped, quantised segment), but for the
    /// few that pass within a lattice step of a voxel's side. Random changed subsets of the
    /// recording region.
    #[test]
    fn a_kept_segment_mostly_crosses_the_changed_voxels_the_tables_would_hold() {
        let grid = grid();
        let q = Quantiser::new(&grid);
        let mut rng = Rng::for_key(7, &[1]);
        let mut point = |scale: f32| {
            Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 8.0 * scale
                - Vec3::splat(3.0 * scale)
        };
        let mut segment = random_segments(8);
        let none = Changed::new(ActiveVoxels::from_mask(grid.clone(), &[]), q);
        let (mut crossing, mut differ, mut total) = (0, 0, 0);
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
            let changed = Changed::new(ActiveVoxels::from_mask(grid.clone(), &mask), q);
            for i in 0..500 {
                let s = segment(i);
                let mut tables = false;
                recording.walk(s.0, s.1, s.2, s.3, |v| tables |= mask[v]);
                let found = kept(&recording, &q, Table::Surface, s).crosses(&changed, &none);
                differ += (found != tables) as usize;
                crossing += tables as usize;
                total += 1;
            }
        }
        // The test means something only if both answers occur often.
        assert!(
            crossing > total / 20 && crossing < total * 9 / 10,
            "{crossing} of {total}"
        );
        assert!(differ * 500 < total, "{differ} of {total} differ");
    }

    /// Segments kept in shared lists (shadow segments by their start, surface segments by
    /// their end) answer every question as the same segments kept whole: their box, count, the blocks a changed set finds, and the tables made
    /// from them, also when a block's parts are appended (one slot holding its end in
    /// both, another only in the second part).
    #[test]
    fn segments_in_shared_lists_are_the_same_segments() {
        let grid = grid();
        let q = Quantiser::new(&grid);
        let layout = BlockLayout::new(32, 16, 4, 2);
        let mut rng = Rng::for_key(9, &[1]);
        let point = |rng: &mut Rng| {
            let u = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
            q.encode((grid.lo + u * (grid.hi - grid.lo)).into())
        };
        let ends = [point(&mut rng), point(&mut rng), point(&mut rng)];
        let (mut by_end, mut whole) = (
            SegmentRecords::new(&layout, &grid),
            SegmentRecords::new(&layout, &grid),
        );
        for b in 0..layout.len() {
            for part in 0..2 {
                let (mut e, mut w) = (BlockSegments::new(), BlockSegments::new());
                for i in 0..(b % 5) * 3 {
                    let start = point(&mut rng);
                    let slot = (i + part + b) % if part == 0 { 2 } else { 3 };
                    let list = (Table::Shadow, false, q.decode(ends[slot]), ends[slot]);
                    e.push_shared(slot, list, start);
                    w.push(Table::Shadow, [start, ends[slot]]);
                    let surface = [point(&mut rng), point(&mut rng)];
                    e.push(Table::Surface, surface);
                    w.push(Table::Surface, surface);
                    // A surface segment from a shared start (slot 3: a camera's).
                    let end = point(&mut rng);
                    let from = (Table::Surface, true, q.decode(ends[0]), ends[0]);
                    e.push_shared(3, from, end);
                    w.push(Table::Surface, [ends[0], end]);
                }
                e.seal();
                w.seal();
                assert_eq!((e.lo, e.hi, e.len()), (w.lo, w.hi, w.len()));
                by_end.add(b, e, false);
                whole.add(b, w, false);
            }
        }
        assert_eq!(by_end.segments(), whole.segments());
        let mut found_any = 0;
        for round in 0..30 {
            let mut select = Rng::for_key(9, &[2, round]);
            let mask: Vec<bool> = (0..grid.len()).map(|_| select.uniform() < 0.02).collect();
            let changed = Changed::new(ActiveVoxels::from_mask(grid.clone(), &mask), q);
            let none = Changed::new(ActiveVoxels::from_mask(grid.clone(), &[]), q);
            for (c, s) in [(&changed, &changed), (&none, &changed), (&changed, &none)] {
                let (mut a, mut b) = (BlockSet::new(&layout), BlockSet::new(&layout));
                by_end.collect(c, s, &mut a);
                whole.collect(c, s, &mut b);
                assert_eq!(a.words, b.words, "round {round}");
                found_any += a.count();
            }
        }
        assert!(found_any > 0);
        let all = ActiveVoxels::all(grid.clone());
        let (ta, tb) = (
            by_end.to_tables(&all, &layout),
            whole.to_tables(&all, &layout),
        );
        for v in 0..grid.len() {
            for t in [Table::Surface, Table::Shadow] {
                let (mut a, mut b) = (BlockSet::new(&layout), BlockSet::new(&layout));
                ta.collect(t, v, &mut a);
                tb.collect(t, v, &mut b);
                assert_eq!(a.words, b.words);
            }
        }
    }

    #[test]
    fn records_of_retraced_blocks_are_forgotten() {
        let layout = BlockLayout::new(40, 30, 4, 3);
        let grid = Grid::new(Vec3::ZERO, Vec3::ONE, [4, 4, 4]);
        let q = Quantiser::new(&grid);
        let all = Changed::new(ActiveVoxels::all(grid.clone()), q);
        let mut records = SegmentRecords::new(&layout, &grid);
        let through = [Vec3A::new(0.0, 0.5, 0.5), Vec3A::new(1.0, 0.5, 0.5)].map(|p| q.encode(p));
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
