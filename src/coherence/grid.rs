//! The uniform voxel grid the coherence records live in, and the 3-D DDA (Amanatides & Woo
//! 1987) that walks a ray segment through it. The grid is independent of the intersection
//! backend: it only has to cover every place geometry or lights occupy during the sequence.

use super::adaptive::AdaptiveGrid;
use crate::math::Vec3;
use glam::Vec3A;

/// A grid's box (what the records' lattice is laid over).
pub trait Extent {
    fn extent(&self) -> (Vec3, Vec3);
}

impl Extent for Grid {
    fn extent(&self) -> (Vec3, Vec3) {
        (self.lo, self.hi)
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    pub lo: Vec3,
    pub hi: Vec3,
    pub res: [u32; 3],
    cell: Vec3,
    inv_cell: Vec3,
}

impl Grid {
    /// A grid over `[lo, hi]` with `res` voxels along each axis (each at least 1).
    pub fn new(lo: Vec3, hi: Vec3, res: [u32; 3]) -> Grid {
        let res = res.map(|r| r.max(1));
        let size = (hi - lo).max(Vec3::splat(1e-6));
        let hi = lo + size;
        let cell = size / Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
        Grid {
            lo,
            hi,
            res,
            cell,
            inv_cell: cell.recip(),
        }
    }

    /// A grid over `[lo, hi]` with about `voxels` roughly cubic voxels.
    pub(crate) fn with_voxels(lo: Vec3, hi: Vec3, voxels: u32) -> Grid {
        let size = (hi - lo).max(Vec3::splat(1e-6));
        let side = (size.x * size.y * size.z / voxels.max(1) as f32).cbrt();
        let res = (size / side)
            .ceil()
            .to_array()
            .map(|r| (r as u32).clamp(1, 1024));
        Grid::new(lo, hi, res)
    }

    /// The size of a voxel.
    pub(crate) fn cell_size(&self) -> Vec3 {
        self.cell
    }

    pub fn len(&self) -> usize {
        self.res.iter().map(|&r| r as usize).product()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn index(&self, c: [u32; 3]) -> usize {
        (c[2] as usize * self.res[1] as usize + c[1] as usize) * self.res[0] as usize
            + c[0] as usize
    }

    pub(crate) fn coords(&self, index: usize) -> [u32; 3] {
        let (rx, ry) = (self.res[0] as usize, self.res[1] as usize);
        [
            (index % rx) as u32,
            (index / rx % ry) as u32,
            (index / (rx * ry)) as u32,
        ]
    }

    /// The box of voxel `index`.
    pub(crate) fn voxel_box(&self, index: usize) -> (Vec3, Vec3) {
        let c = self.coords(index);
        let lo = self.lo + Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * self.cell;
        (lo, lo + self.cell)
    }

    /// The voxel coordinates holding `p`, clamped into the grid.
    #[inline(always)]
    fn cell_of(&self, p: Vec3) -> [u32; 3] {
        // Truncation is the floor for the non-negative values kept (and the cast saturates).
        let f = ((p - self.lo) * self.inv_cell).max(Vec3::ZERO);
        [
            (f.x as u32).min(self.res[0] - 1),
            (f.y as u32).min(self.res[1] - 1),
            (f.z as u32).min(self.res[2] - 1),
        ]
    }

    /// Every voxel overlapping the box `[lo, hi]` (none if it misses the grid).
    pub(crate) fn voxels_in_box(&self, lo: Vec3, hi: Vec3, mut f: impl FnMut(usize)) {
        if lo.cmpgt(self.hi).any() || hi.cmplt(self.lo).any() {
            return;
        }
        let (a, b) = (self.cell_of(lo), self.cell_of(hi));
        for z in a[2]..=b[2] {
            for y in a[1]..=b[1] {
                for x in a[0]..=b[0] {
                    f(self.index([x, y, z]));
                }
            }
        }
    }

    /// Walks the segment `origin + t·dir`, `t ∈ [t0, t1]`, through the grid, calling `f` on
    /// every voxel it crosses, in order. Parts outside the grid are skipped.
    #[cfg(test)]
    pub fn walk(&self, origin: Vec3, dir: Vec3, t0: f32, t1: f32, mut f: impl FnMut(usize)) {
        self.walk_spans(origin, dir, t0, t1, |v, _, _| f(v));
    }

    /// [`walk`](Self::walk), also giving the parameter span `[ta, tb]` the segment spends
    /// in each voxel.
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
        if let Some((tin, tout)) = clip(self.lo, self.hi, origin, dir, inv, t0, t1) {
            self.walk_clipped(origin, dir, inv, tin, tout, f);
        }
    }

    /// The walk of a segment already clipped to `[tin, tout]` inside the grid's box
    /// (`inv` = 1 / `dir`).
    #[inline(always)]
    pub(super) fn walk_clipped(
        &self,
        origin: Vec3,
        dir: Vec3,
        inv: Vec3,
        tin: f32,
        tout: f32,
        mut f: impl FnMut(usize, f32, f32),
    ) {
        // The cells at both ends fix how many boundaries the walk crosses on each axis; it
        // then takes exactly those steps, in the order the ray meets the boundaries (no
        // per-step range or distance checks, and rounding cannot push it off the grid).
        let first = self.cell_of(origin + dir * tin);
        let last = self.cell_of(origin + dir * tout);
        let mut index = self.index(first) as isize;
        let strides = [
            1isize,
            self.res[0] as isize,
            self.res[0] as isize * self.res[1] as isize,
        ];
        let mut left = [0u32; 3];
        let mut next = [f32::INFINITY; 3];
        let mut delta = [0f32; 3];
        let mut step = [0isize; 3];
        for a in 0..3 {
            let (c0, c1) = (first[a], last[a]);
            if dir[a] > 0.0 && c1 > c0 {
                left[a] = c1 - c0;
                step[a] = strides[a];
                let boundary = self.lo[a] + (c0 + 1) as f32 * self.cell[a];
                next[a] = (boundary - origin[a]) * inv[a];
                delta[a] = self.cell[a] * inv[a];
            } else if dir[a] < 0.0 && c1 < c0 {
                left[a] = c0 - c1;
                step[a] = -strides[a];
                let boundary = self.lo[a] + c0 as f32 * self.cell[a];
                next[a] = (boundary - origin[a]) * inv[a];
                delta[a] = -self.cell[a] * inv[a];
            }
        }
        // The loop keeps its state in registers. (The compiler makes branches of the choice
        // of axis; forcing masks instead was slower, 43 against 33 ns a segment on frame 0 of
        // the circus: the rays of a block are alike, so the branches are well predicted.)
        let [mut n0, mut n1, mut n2] = next;
        let [mut l0, mut l1, mut l2] = left;
        let mut t = tin;
        for _ in 0..left[0] + left[1] + left[2] {
            // The axis whose boundary comes first (the lowest axis on ties).
            let x = n0 <= n1 && n0 <= n2;
            let y = !x && n1 <= n2;
            let z = !x && !y;
            let boundary = n0.min(n1).min(n2).min(tout);
            f(index as usize, t, boundary);
            t = boundary;
            index += if x {
                step[0]
            } else if y {
                step[1]
            } else {
                step[2]
            };
            l0 -= x as u32;
            l1 -= y as u32;
            l2 -= z as u32;
            n0 = if l0 == 0 {
                f32::INFINITY
            } else if x {
                n0 + delta[0]
            } else {
                n0
            };
            n1 = if l1 == 0 {
                f32::INFINITY
            } else if y {
                n1 + delta[1]
            } else {
                n1
            };
            n2 = if l2 == 0 {
                f32::INFINITY
            } else if z {
                n2 + delta[2]
            } else {
                n2
            };
        }
        f(index as usize, t, tout);
    }
}

/// Whether both ends of the finite segment `origin + t·dir`, `t ∈ [max(t0, 0), t1]`, lie
/// beyond the same face of the box `[lo, hi]`, so that it misses the box: a test without a
/// division. (Plain comparisons, no branch per axis: this runs for every ray recorded. A NaN
/// compares false, and an infinite `t1` is never rejected here: the slab test decides.)
#[inline(always)]
fn ends_beyond_one_face(lo: Vec3, hi: Vec3, origin: Vec3, dir: Vec3, t0: f32, t1: f32) -> bool {
    if t1 >= f32::INFINITY || t1.is_nan() {
        return false;
    }
    let (a, b) = (origin + dir * t0.max(0.0), origin + dir * t1);
    let mut out = false;
    for k in 0..3 {
        out |= (a[k] > hi[k]) & (b[k] > hi[k]);
        out |= (a[k] < lo[k]) & (b[k] < lo[k]);
    }
    out
}

/// The part `[tin, tout]` of `[max(t0, 0), t1]` where `origin + t·dir` is inside the box
/// `[lo, hi]` (`inv` = 1 / `dir`); `None` if it misses.
#[inline(always)]
pub(super) fn clip(
    lo: Vec3,
    hi: Vec3,
    origin: Vec3,
    dir: Vec3,
    inv: Vec3,
    t0: f32,
    t1: f32,
) -> Option<(f32, f32)> {
    let (mut tin, mut tout) = (t0.max(0.0), t1);
    if dir.cmpne(Vec3::ZERO).all() {
        let (a, b) = ((lo - origin) * inv, (hi - origin) * inv);
        tin = tin.max(a.min(b).max_element());
        tout = tout.min(a.max(b).min_element());
    } else {
        for k in 0..3 {
            if dir[k] == 0.0 {
                if origin[k] < lo[k] || origin[k] > hi[k] {
                    return None;
                }
                continue;
            }
            let (a, b) = ((lo[k] - origin[k]) * inv[k], (hi[k] - origin[k]) * inv[k]);
            tin = tin.max(a.min(b));
            tout = tout.min(a.max(b));
        }
    }
    // False when either is NaN.
    (tin <= tout).then_some((tin, tout))
}

/// The voxels worth recording: those where a change can happen (the boxes the sequence's
/// changes mark), and a coarse grid of blocks of voxels, so that a ray crosses the parts
/// where nothing ever changes in a few coarse steps (Jevans's hierarchical grid, used here
/// to skip what needs no records).
#[derive(Clone, Debug)]
pub struct ActiveVoxels {
    /// The voxels: a uniform grid, or one cut finer where a frame's changes lie.
    pub fine: AdaptiveGrid,
    /// Over the top grid of `fine`.
    coarse: Grid,
    /// One bit per fine voxel.
    active: Vec<u64>,
    /// Per coarse cell: whether any of its fine voxels is active.
    coarse_active: Vec<bool>,
    /// The box around the active voxels (a little grown), if any: a segment that misses it
    /// is not walked at all.
    bounds: Option<(Vec3, Vec3)>,
}

/// Top voxels per coarse cell along each axis.
const COARSE: u32 = 4;

impl ActiveVoxels {
    /// Every voxel of `fine` is worth recording.
    pub fn all(fine: impl Into<AdaptiveGrid>) -> ActiveVoxels {
        let fine = fine.into();
        let n = fine.len();
        ActiveVoxels::from_mask(fine, &vec![true; n])
    }

    /// Only the voxels overlapping one of `boxes` (grown by `margin`).
    pub fn boxes(
        fine: impl Into<AdaptiveGrid>,
        boxes: &[(Vec3, Vec3)],
        margin: f32,
    ) -> ActiveVoxels {
        let fine = fine.into();
        let mut mask = vec![false; fine.len()];
        for (lo, hi) in boxes {
            fine.voxels_in_box(*lo - margin, *hi + margin, |v| mask[v] = true);
        }
        ActiveVoxels::from_mask(fine, &mask)
    }

    /// The voxels `v` with `mask[v]`.
    pub(crate) fn from_mask(fine: impl Into<AdaptiveGrid>, mask: &[bool]) -> ActiveVoxels {
        let fine = fine.into();
        let top = &fine.top;
        let res = top.res.map(|r| r.div_ceil(COARSE));
        let scale = Vec3::new(
            (res[0] * COARSE) as f32 / top.res[0] as f32,
            (res[1] * COARSE) as f32 / top.res[1] as f32,
            (res[2] * COARSE) as f32 / top.res[2] as f32,
        );
        let coarse = Grid::new(top.lo, top.lo + (top.hi - top.lo) * scale, res);
        let mut active = vec![0u64; fine.len().div_ceil(64)];
        let mut coarse_active = vec![false; coarse.len()];
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for (v, _) in mask.iter().enumerate().filter(|(_, &m)| m) {
            active[v / 64] |= 1 << (v % 64);
            let c = top.coords(fine.top_cell(v));
            coarse_active[coarse.index(c.map(|x| x / COARSE))] = true;
            let (a, b) = fine.voxel_box(v);
            lo = lo.min(a);
            hi = hi.max(b);
        }
        let bounds = (lo.x <= hi.x).then(|| {
            // Grown by a hair, so that rounding in the clip cannot cut off a crossing that
            // the walk over the whole grid would have found.
            let eps = (top.hi - top.lo).length() * 1e-5;
            (lo - eps, hi + eps)
        });
        ActiveVoxels {
            active,
            coarse_active,
            fine,
            coarse,
            bounds,
        }
    }

    /// The box around the active voxels (a little grown), if any.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        self.bounds
    }

    pub(crate) fn is_active(&self, v: usize) -> bool {
        self.active[v / 64] >> (v % 64) & 1 != 0
    }

    /// How many voxels are active.
    pub fn count(&self) -> usize {
        self.active.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// The part `[tin, tout]` of the segment inside the box around the active voxels, with
    /// 1 / `dir`; `None` if it misses the box.
    #[inline(always)]
    fn clip_to_bounds(
        &self,
        origin: Vec3,
        dir: Vec3,
        t0: f32,
        t1: f32,
    ) -> Option<(Vec3, f32, f32)> {
        // Most segments miss the box around the active voxels. The box around the segment's
        // ends rejects most of those without a division; one slab test the rest.
        let (lo, hi) = self.bounds?;
        if ends_beyond_one_face(lo, hi, origin, dir, t0, t1) {
            return None;
        }
        let inv = dir.recip();
        let (tin, tout) = clip(lo, hi, origin, dir, inv, t0, t1)?;
        Some((inv, tin, tout))
    }

    /// The end points of the part of the segment inside the box around the active voxels
    /// (`None` if it misses): what a segment record keeps for a later
    /// [`crosses`](Self::crosses). (In SSE lanes: a `Vec3` pair, written in pieces and read
    /// back whole, stalled the recorder on the store.)
    #[inline]
    pub fn clip_segment(&self, origin: Vec3, dir: Vec3, t0: f32, t1: f32) -> Option<[Vec3A; 2]> {
        let (lo, hi) = self.bounds?;
        // The same tests as `clip_to_bounds`, on the three axes at once (SSE lanes) and in
        // plain comparisons: this runs for every ray recorded. A NaN may drop out of a
        // comparison here, so non-finite ends are refused at the end.
        let (lo, hi, o, d) = (
            Vec3A::from(lo),
            Vec3A::from(hi),
            Vec3A::from(origin),
            Vec3A::from(dir),
        );
        let t0 = if t0 > 0.0 { t0 } else { 0.0 };
        if t1 < f32::INFINITY {
            let (a, b) = (o + d * t0, o + d * t1);
            // Both ends inside (most segments, online, where the box is the whole grid): the
            // segment is its own clip. (The slab test below could move an end lying on a
            // side by a rounding error; a NaN fails the comparisons.)
            if (a.cmpge(lo) & a.cmple(hi) & b.cmpge(lo) & b.cmple(hi)).all() {
                return Some([a, b]);
            }
            // Both ends beyond one face (`ends_beyond_one_face`; a NaN or infinite t1 skips
            // it).
            if ((a.cmpgt(hi) & b.cmpgt(hi)) | (a.cmplt(lo) & b.cmplt(lo))).any() {
                return None;
            }
        }
        // A zero direction gives ±∞ (outside the slab: the segment misses) or NaN (on its
        // face, the box grown by a hair around the voxels: it misses them too).
        let inv = Vec3A::ONE / d;
        let (a, b) = ((lo - o) * inv, (hi - o) * inv);
        let ordered = a.cmplt(b);
        let (near, far) = (Vec3A::select(ordered, a, b), Vec3A::select(ordered, b, a));
        let (near, far) = (near.to_array(), far.to_array());
        let (mut tin, mut tout) = (t0, t1);
        for k in 0..3 {
            tin = if near[k] > tin { near[k] } else { tin };
            tout = if far[k] < tout { far[k] } else { tout };
        }
        // (A NaN t1 passes here and gives non-finite ends.)
        if tin > tout {
            return None;
        }
        let ends = [o + d * tin, o + d * tout];
        // Finite: strictly between ±∞ (NaN fails both). glam's `is_finite` is a call here.
        let finite = |e: Vec3A| e.cmplt(Vec3A::INFINITY) & e.cmpgt(Vec3A::NEG_INFINITY);
        let finite = finite(ends[0]) & finite(ends[1]);
        finite.all().then_some(ends)
    }

    /// Whether the segment from `a` to `b` crosses an active voxel.
    #[inline]
    pub fn crosses(&self, [a, b]: [Vec3; 2]) -> bool {
        self.crossed_by(a, b - a, 0.0, 1.0)
    }

    /// Whether the segment `origin + t·dir`, `t ∈ [t0, t1]`, crosses an active voxel (the
    /// walk stops at the first).
    #[inline]
    pub(crate) fn crossed_by(&self, origin: Vec3, dir: Vec3, t0: f32, t1: f32) -> bool {
        self.stretch(origin, dir, t0, t1)
            .is_some_and(|(inv, a, b)| {
                (self.fine).find_clipped(origin, dir, inv, a, b, |v| self.is_active(v))
            })
    }

    /// Calls `f` on every active voxel the segment crosses (and possibly on an active
    /// neighbour of a coarse cell's boundary, where rounding puts the crossing).
    #[inline]
    pub fn walk(&self, origin: Vec3, dir: Vec3, t0: f32, t1: f32, mut f: impl FnMut(usize)) {
        if let Some((inv, a, b)) = self.stretch(origin, dir, t0, t1) {
            self.fine.walk_clipped(origin, dir, inv, a, b, |v, _, _| {
                if self.is_active(v) {
                    f(v)
                }
            });
        }
    }

    /// The stretch `[a, b]` of the segment over active coarse cells, with 1 / `dir`: one
    /// fine walk then covers it.
    #[inline(always)]
    fn stretch(&self, origin: Vec3, dir: Vec3, t0: f32, t1: f32) -> Option<(Vec3, f32, f32)> {
        let (inv, tin, tout) = self.clip_to_bounds(origin, dir, t0, t1)?;
        let (mut a, mut b) = (f32::INFINITY, f32::NEG_INFINITY);
        self.coarse
            .walk_clipped(origin, dir, inv, tin, tout, |c, ta, tb| {
                if self.coarse_active[c] {
                    a = a.min(ta);
                    b = b.max(tb);
                }
            });
        (a <= b).then_some((inv, a, b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_and_coords_round_trip() {
        let g = Grid::new(Vec3::ZERO, Vec3::ONE, [3, 4, 5]);
        for i in 0..g.len() {
            assert_eq!(g.index(g.coords(i)), i);
        }
    }

    /// The record-time clip (SSE lanes, plain comparisons) keeps what the walk's clip keeps,
    /// with the same ends (to a rounding error), also for axis-parallel rays, rays to
    /// infinity and rays starting inside the box; it refuses non-finite ends.
    #[test]
    fn record_clip_matches_walk_clip() {
        let grid = Grid::new(Vec3::ZERO, Vec3::ONE, [8, 8, 8]);
        let mask: Vec<bool> = (0..grid.len()).map(|v| grid.coords(v)[1] < 3).collect();
        let voxels = ActiveVoxels::from_mask(grid, &mask);
        let mut state = 7u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut kept, mut dropped) = (0, 0);
        for i in 0..20_000 {
            let origin = Vec3::new(next(), next(), next()) * 2.0 - 0.5;
            let mut dir = Vec3::new(next(), next(), next()) * 2.0 - 1.0;
            if i % 3 == 0 {
                dir[i / 3 % 3] = 0.0;
            }
            let (t0, t1) = match i % 4 {
                0 => (0.0, f32::INFINITY),
                1 => (-0.5, 0.7),
                _ => (1e-4, next() * 2.0),
            };
            let walk = voxels
                .clip_to_bounds(origin, dir, t0, t1)
                .map(|(_, tin, tout)| [origin + dir * tin, origin + dir * tout])
                .filter(|e| e[0].is_finite() && e[1].is_finite());
            let record = voxels
                .clip_segment(origin, dir, t0, t1)
                .map(|e| e.map(Vec3::from));
            let close = match (record, walk) {
                (Some(r), Some(w)) => (0..2).all(|i| r[i].abs_diff_eq(w[i], 1e-6)),
                (r, w) => r == w,
            };
            assert!(
                close,
                "{origin} + t {dir}, t in [{t0}, {t1}]: {record:?} {walk:?}"
            );
            if record.is_some() {
                kept += 1;
            } else {
                dropped += 1;
            }
        }
        assert!(
            kept > 2_000 && dropped > 2_000,
            "{kept} kept, {dropped} dropped"
        );
        let nan = Vec3::new(f32::NAN, 0.1, 0.1);
        assert_eq!(voxels.clip_segment(nan, Vec3::X, 0.0, 1.0), None);
        assert_eq!(
            voxels.clip_segment(Vec3::splat(0.1), Vec3::X, 0.0, f32::NAN),
            None
        );
    }
}
