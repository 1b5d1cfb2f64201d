//! The preprocess: which patches each grid line meets, in order along the line, and the links
//! between consecutive ones.
//!
//! **Scan conversion** (the paper's builder). For one slot (slope pair) and one polygon, the
//! polygon is projected onto the intercept plane along the slot's direction; the lines whose
//! (jittered) intercepts fall inside the projection meet the polygon. Rows of the intercept
//! grid are scanned; along a row the intersection coordinate p_a follows the paper's
//! recurrence: with the plane n·p + D = 0 and δ = n_a + n_u s_u + n_v s_v computed once per
//! slope and polygon, B' = n_u/δ, C' = n_v/δ, D' = D/δ,
//!
//! ```text
//! p_a = −D' − B'·i_u − C'·i_v at the row's first cell, then p_a ← p_a − B'·h per cell,
//! ```
//!
//! and the line's jitter (a fraction of h on each intercept, hashed from the seed and the
//! line) adds −B'·δ_u − C'·δ_v. The inside test uses the jittered intercept itself, so both
//! builders meet exactly the same lines. A row's cells go four at a time through SIMD lanes
//! (the jitter hash, the intercepts, the inside test, the patch keys); the depths still
//! follow the recurrence cell after cell.
//!
//! **Embree casting**. The same jittered lines are cast through the intersection backend with
//! repeated closest-hit queries (for geometry the scan converter cannot project, and as a
//! cross-check).
//!
//! **Links.** The hits of one slot are sorted by (line, p_a): the scan converter buckets them
//! by intercept row as it finds them and one counting pass by column finishes the sort by
//! line ([`RowBuckets`]); Embree's hits take a radix sort. Consecutive hits k, k+1 on a line
//! link the side of k facing +d with the side of k+1 facing −d; the first and last hits have
//! an *escape* slot (light leaving that way leaves the scene). Work is parallel over batches
//! of slots (the paper's slope queue; [`LinkBatch`]) and merged in slot order: the network
//! does not depend on the thread count.

use super::patches::{Patches, Polygon};
use super::ray_space::{axes, jitter_seed, slot_jitter_seed, RaySpace};
use super::MAX_KEY_BLOCK_BITS;
use crate::integrators::{Context, RayStats};
use crate::math::{Ray, Vec3};
use rayon::prelude::*;
use wide::{f32x4, i16x8, i32x4, u32x4};

/// A line meeting a patch: the line within its slot, p_a along it, and the key of the side
/// facing +d (cell·2 + 0 for the front, + 1 for the back).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineHit {
    pub line: u32,
    pub depth: f32,
    pub key: u32,
}

/// How a link end is packed into 32 bits: the side key's offset within its key block in the
/// high `block_bits`, the side key at the other end in the low `target_bits`. Half the bytes
/// of a (key, target) pair: the ends of every slot are held until the assembly (hundreds of
/// megabytes on large networks, all of it memory the system must first clear), and the
/// assembly streams them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EndPacking {
    pub block_bits: u32,
    pub target_bits: u32,
}

impl EndPacking {
    /// The packing for `keys` side keys: target bits for every key, and blocks of up to
    /// 2^[`MAX_KEY_BLOCK_BITS`] keys in the rest (at least 64 keys, a word of node marks).
    /// Networks of up to 2^23 side keys (millions of patches) all take the usual packing.
    pub fn for_keys(keys: usize) -> Result<EndPacking, String> {
        let needed = usize::BITS - keys.saturating_sub(1).leading_zeros();
        let target_bits = needed.max(Self::USUAL.target_bits);
        let block_bits = 32u32.saturating_sub(target_bits);
        if block_bits < 6 {
            return Err(format!(
                "the network would have {} patches, more than its 32-bit link ends can \
                 address ({}); use a larger --patch-size",
                keys / 2,
                1u64 << 25
            ));
        }
        Ok(EndPacking {
            block_bits,
            target_bits,
        })
    }

    /// The packing of every network of up to 2^23 side keys: blocks of
    /// 2^[`MAX_KEY_BLOCK_BITS`] keys, the targets in the other bits. The loops over link ends
    /// are compiled for it apart ([`EndPacking::known`]), its shifts and masks constants.
    pub const USUAL: EndPacking = EndPacking {
        block_bits: MAX_KEY_BLOCK_BITS,
        target_bits: 32 - MAX_KEY_BLOCK_BITS,
    };

    /// The packing as a loop over link ends sees it: the usual one as a constant when `USUAL`
    /// (a loop is compiled twice, `f::<true>` run for the usual packing and `f::<false>` for
    /// others), else as read at run time. A shift by a count from memory takes a load and the
    /// count register; by a constant, neither.
    #[inline(always)]
    pub fn known<const USUAL: bool>(self) -> EndPacking {
        if USUAL {
            debug_assert_eq!(self, Self::USUAL);
            Self::USUAL
        } else {
            self
        }
    }

    /// Side keys per block.
    #[inline]
    pub fn block(&self) -> usize {
        1 << self.block_bits
    }

    /// The block of a side key (a shift: a division by the block's size, unknown to the
    /// compiler, would cost tens of cycles per link end).
    #[inline]
    pub fn block_of(&self, key: u32) -> usize {
        (key >> self.block_bits) as usize
    }

    #[inline]
    fn pack(&self, key: u32, target: u32) -> u32 {
        (key & (self.block() as u32 - 1)) << self.target_bits | target
    }

    /// The side key and the key at the other end of an end of block `block`.
    #[cfg(test)]
    #[inline]
    pub fn unpack(&self, block: usize, end: u32) -> (u32, u32) {
        let key = (block << self.block_bits) as u32 | end >> self.target_bits;
        (key, end & ((1 << self.target_bits) - 1))
    }
}

/// Slots linked by one task, one after the other: a few, so that the assembly reads each key
/// block's ends and escapes in runs of several slots rather than a short piece per slot.
pub const SLOT_BATCH: usize = 8;

/// The links of a batch of consecutive slots as packed link ends ([`EndPacking`]: a side key
/// and the side key at the other end), grouped by key block and, within a block, by slot:
/// group g = b·slots + j (block b, the batch's j-th slot) is `ends[start[g]..start[g + 1]]`, in
/// the order the links were found along the sorted lines (each link's two ends); and the
/// escapes, kept apart, grouped alike. The assembly reads block b of every batch in turn, so
/// a block's share of a batch lies in one piece.
#[derive(Clone, Debug, Default)]
pub struct LinkBatch {
    pub slots: u32,
    pub ends: Vec<u32>,
    pub start: Vec<u32>,
    /// Bit sets over side keys: the sides whose line leaves the scene, per group: group g's
    /// bits are `escapes[g·w..(g + 1)·w]` for w = `words` (block / 64), bit i of word k the
    /// block's key 64·k + i. Escapes can be as many as link ends, and most are on sides that
    /// never become nodes: as bits they take a thirty-second of the memory, and the assembly
    /// skips the sides that are not nodes a word at a time. (Those of sides facing out of
    /// the scene, a room's walls seen from outside, are not recorded at all.)
    pub escapes: Vec<u64>,
    /// Escape words per group: a block's keys / 64.
    pub words: usize,
    /// A side's second and later escapes in a slot (a patch meeting two lines that both
    /// leave), per group: `more_escapes[more_start[g]..more_start[g + 1]]`.
    pub more_escapes: Vec<u32>,
    pub more_start: Vec<u32>,
    /// Links between two sides (each has two ends).
    pub pairs: u64,
    pub intersections: u64,
    /// Consecutive hits on the same side (dropped).
    pub degenerate: u64,
}

impl LinkBatch {
    /// Group of key block `b` and the batch's `j`-th slot.
    #[inline]
    fn group(&self, b: usize, j: usize) -> usize {
        b * self.slots as usize + j
    }

    /// The packed link ends of key block `b` in the batch's `j`-th slot.
    #[inline]
    pub fn ends(&self, b: usize, j: usize) -> &[u32] {
        let g = self.group(b, j);
        &self.ends[self.start[g] as usize..self.start[g + 1] as usize]
    }

    /// The ends of key block `b` in every slot of the batch.
    #[inline]
    pub fn block_ends(&self, b: usize) -> usize {
        let (g0, g1) = (self.group(b, 0), self.group(b + 1, 0));
        (self.start[g1] - self.start[g0]) as usize
    }

    /// The escape bits of key block `b` in the batch's `j`-th slot.
    #[inline]
    pub fn escapes(&self, b: usize, j: usize) -> &[u64] {
        let g = self.group(b, j);
        &self.escapes[g * self.words..(g + 1) * self.words]
    }

    /// The second and later escapes of key block `b` in the batch's `j`-th slot.
    #[inline]
    pub fn more_escapes(&self, b: usize, j: usize) -> &[u32] {
        let g = self.group(b, j);
        &self.more_escapes[self.more_start[g] as usize..self.more_start[g + 1] as usize]
    }
}

/// Which builder finds the line-patch intersections.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Builder {
    Scan,
    Embree,
}

/// The plane coefficients of one polygon for one slot (the paper's B', C', D').
#[derive(Clone, Copy, Debug)]
pub struct SlotPlane {
    pub b: f32,
    pub c: f32,
    pub d: f32,
}

impl SlotPlane {
    /// `None` when the slot's lines are parallel to the polygon.
    pub fn new(pg: &Polygon, family: u32, su: f32, sv: f32) -> Option<SlotPlane> {
        let (a, u, v) = axes(family);
        let n = pg.n;
        let delta = n[a] + n[u] * su + n[v] * sv;
        if delta.abs() < 1e-6 {
            return None;
        }
        let dd = -n.dot(pg.o);
        Some(SlotPlane {
            b: n[u] / delta,
            c: n[v] / delta,
            d: dd / delta,
        })
    }

    #[inline]
    pub fn depth(&self, iu: f32, iv: f32) -> f32 {
        -self.d - self.b * iu - self.c * iv
    }
}

/// The point of a line at depth p_a, in unit-cube space.
#[inline]
pub fn line_point(family: u32, su: f32, sv: f32, iu: f32, iv: f32, pa: f32) -> Vec3 {
    let (a, u, v) = axes(family);
    let mut p = [0.0; 3];
    p[a] = pa;
    p[u] = su * pa + iu;
    p[v] = sv * pa + iv;
    Vec3::from_array(p)
}

/// Scan-converts one polygon for one slot: calls `hit(line, iu, iv, p_a)` for every line of
/// the slot (with jittered intercepts (iu, iv)) that meets the polygon, p_a computed by the
/// incremental recurrence.
#[cfg(test)]
#[allow(clippy::too_many_arguments)]
pub fn scan_polygon(
    space: &RaySpace,
    slot: u32,
    pg: &Polygon,
    seed: u64,
    jitter: f32,
    hit: impl FnMut(u32, f32, f32, f32),
) {
    let intercepts = space.intercepts;
    let each = &mut EachHit { hit, intercepts };
    scan_cells(space, slot, pg, seed, jitter, each)
}

/// Where [`scan_cells`] puts a polygon's candidate cells: `row(jv, cells)` announces a row of
/// them and returns what takes them.
trait Rows {
    type Row<'r>: RowCells
    where
        Self: 'r;
    fn row(&mut self, jv: u32, cells: usize) -> Self::Row<'_>;
}

/// The cells of one row, [`LANES`] at a time: `cells(ju, lanes, iu, iv, p_a, inside)` for the
/// `lanes` candidates from column `ju` on (all but a row's last group are full), with their
/// jittered intercepts, depths, and whether each is inside (bit l for lane l).
trait RowCells {
    fn cells(&mut self, ju: u32, lanes: usize, iu: f32x4, iv: f32x4, pa: f32x4, inside: u32);
}

/// Candidate cells scanned together, one per SIMD lane.
const LANES: usize = 4;

/// [`scan_polygon`]'s callback, for the cells inside, and a row of it.
#[cfg(test)]
struct EachHit<F> {
    hit: F,
    intercepts: u32,
}

#[cfg(test)]
struct EachHitRow<'a, F> {
    each: &'a mut EachHit<F>,
    jv: u32,
}

#[cfg(test)]
impl<F: FnMut(u32, f32, f32, f32)> Rows for EachHit<F> {
    type Row<'r>
        = EachHitRow<'r, F>
    where
        F: 'r;
    fn row(&mut self, jv: u32, _: usize) -> EachHitRow<'_, F> {
        EachHitRow { each: self, jv }
    }
}

#[cfg(test)]
impl<F: FnMut(u32, f32, f32, f32)> RowCells for EachHitRow<'_, F> {
    fn cells(&mut self, ju: u32, lanes: usize, iu: f32x4, iv: f32x4, pa: f32x4, inside: u32) {
        let (iu, iv, pa) = (iu.to_array(), iv.to_array(), pa.to_array());
        for l in (0..lanes).filter(|l| inside >> l & 1 == 1) {
            let line = (ju + l as u32) * self.each.intercepts + self.jv;
            (self.each.hit)(line, iu[l], iv[l], pa[l])
        }
    }
}

/// [`scan_polygon`] without its branch: every candidate cell of a row goes to `rows` with
/// whether it is inside. Whether a cell near an edge is inside is close to a coin toss: a
/// caller that writes every cell and keeps it by `inside` mispredicts nothing.
#[inline]
fn scan_cells<R: Rows>(
    space: &RaySpace,
    slot: u32,
    pg: &Polygon,
    seed: u64,
    jitter: f32,
    rows: &mut R,
) {
    let (family, su, sv) = space.slot_slopes(slot);
    let Some(plane) = SlotPlane::new(pg, family, su, sv) else {
        return;
    };
    let (a, u, v) = axes(family);
    // Projected corners and edge functions in fixed arrays (a polygon has 3 or 4 corners):
    // this runs for every polygon and slot, and the inside test for every cell scanned.
    let k = pg.corners.len().min(4);
    let mut q = [(0.0f32, 0.0f32); 4];
    for (qi, c) in q.iter_mut().zip(&pg.corners) {
        *qi = (c[u] - su * c[a], c[v] - sv * c[a]);
    }
    let q = &q[..k];
    let mut area = 0.0;
    for i in 0..k {
        let (p0, p1) = (q[i], q[(i + 1) % k]);
        area += p0.0 * p1.1 - p1.0 * p0.1;
    }
    let sign = if area >= 0.0 { 1.0 } else { -1.0 };
    // Edge functions e(x) = a·x_u + b·x_v + c, non-negative inside; a triangle's fourth is
    // the constant 1.
    let mut ea = [0.0f32; 4];
    let mut eb = [0.0f32; 4];
    let mut ec = [1.0f32; 4];
    for i in 0..k {
        let (p0, p1) = (q[i], q[(i + 1) % k]);
        let (a, b) = (-(p1.1 - p0.1) * sign, (p1.0 - p0.0) * sign);
        (ea[i], eb[i], ec[i]) = (a, b, -(a * p0.0 + b * p0.1));
    }
    // All four evaluated, no early exit, for the four lanes at once: whether a cell near an
    // edge is inside is close to a coin toss, which a branch per edge would mispredict.
    let inside = |u: f32x4, v: f32x4| {
        let e = |i: usize| {
            (f32x4::splat(ea[i]) * u + f32x4::splat(eb[i]) * v + f32x4::splat(ec[i]))
                .simd_ge(f32x4::ZERO)
        };
        (e(0) & e(1) & e(2) & e(3)).to_bitmask()
    };
    let h = space.step;
    let n = space.intercepts as i64;
    let amp = 0.5 * jitter * h;
    let slot_seed = slot_jitter_seed(jitter_seed(seed), slot);
    let splat_h = f32x4::splat(h);
    // Lane l of a group holds column ju + l.
    let lane = u32x4::from([0, 1, 2, 3]);
    // ceil and floor by conversion (the baseline x86-64 target calls libm for f32::ceil).
    let ceil = |x: f32| {
        let t = x as i64;
        t + i64::from((t as f32) < x)
    };
    let floor = |x: f32| {
        let t = x as i64;
        t - i64::from((t as f32) > x)
    };
    let index_lo = |x: f32| ceil((x + 1.0) / h - 0.5).clamp(0, n);
    let index_hi = |x: f32| floor((x + 1.0) / h - 0.5).clamp(-1, n - 1);
    let (vmin, vmax) = q
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.1), hi.max(p.1))
        });
    // Per edge: its v-range and u as a function of v (once per polygon and slot, not per row).
    let mut spans = [(0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32); 4];
    for (i, span) in spans.iter_mut().enumerate().take(k) {
        let (p0, p1) = (q[i], q[(i + 1) % k]);
        let dv = p1.1 - p0.1;
        let slope = if dv.abs() < 1e-12 {
            0.0
        } else {
            (p1.0 - p0.0) / dv
        };
        *span = (p0.1.min(p1.1), p0.1.max(p1.1), p0.0, p0.1, slope);
    }
    let spans = &spans[..k];
    // Plain minimum and maximum (`maxss`): `f32::max` keeps a NaN out in several more
    // instructions, and these coordinates are finite.
    let (min, max) = (
        |a: f32, b: f32| if a < b { a } else { b },
        |a: f32, b: f32| if a > b { a } else { b },
    );
    let step = plane.b * h;
    // Lane l's line is l·intercepts past the group's first.
    let per_column = space.intercepts;
    let lane_lines = lane * u32x4::splat(per_column);
    for jv in index_lo(vmin - amp)..=index_hi(vmax + amp) {
        let cv = space.intercept(jv as u32);
        let (blo, bhi) = (cv - amp, cv + amp);
        // The u-extent of the polygon within the row's band of possible jittered v: each
        // edge clipped to the band.
        let (mut umin, mut umax) = (f32::INFINITY, f32::NEG_INFINITY);
        for &(lo, hi, u0, v0, slope) in spans {
            let (a, b) = (max(lo, blo), min(hi, bhi));
            if a > b {
                continue;
            }
            let (xa, xb) = (u0 + (a - v0) * slope, u0 + (b - v0) * slope);
            umin = min(umin, min(xa, xb));
            umax = max(umax, max(xa, xb));
        }
        if umin > umax {
            continue;
        }
        let (ju0, ju1) = (index_lo(umin - amp), index_hi(umax + amp));
        if ju0 > ju1 {
            continue;
        }
        // The paper's recurrence: one multiply-add at the row start, one add per cell.
        let mut pa = plane.depth(space.intercept(ju0 as u32), cv);
        let mut row = rows.row(jv as u32, (ju1 - ju0 + 1) as usize);
        let mut ju = ju0 as u32;
        // The lines (ju·intercepts + jv) of the group's four cells, advanced by an add (a
        // multiply of 32-bit lanes is several instructions in SSE2).
        let mut lines = u32x4::splat(ju * per_column + jv as u32) + lane_lines;
        let next_group = u32x4::splat(LANES as u32 * per_column);
        while ju <= ju1 as u32 {
            let lanes = (ju1 as u32 - ju + 1).min(LANES as u32) as usize;
            // The depths by the recurrence, cell after cell (a lane past the row's end takes
            // one too, unused).
            let depths = std::array::from_fn(|_| {
                let d = pa;
                pa -= step;
                d
            });
            let columns = u32x4::splat(ju) + lane;
            let (du, dv) = space.jitter_lanes(slot_seed, jitter, lines);
            lines += next_group;
            let centres: i32x4 = wide::bytemuck::cast(columns);
            // space.intercept(ju), lane by lane.
            let iu =
                f32x4::splat(-1.0) + (centres.round_float() + f32x4::splat(0.5)) * splat_h + du;
            let iv = f32x4::splat(cv) + dv;
            let pas = f32x4::from(depths) - f32x4::splat(plane.b) * du - f32x4::splat(plane.c) * dv;
            let inside = inside(iu, iv) & ((1 << lanes) - 1);
            row.cells(ju, lanes, iu, iv, pas, inside);
            ju += LANES as u32;
        }
    }
}

/// The side key of a hit on polygon `pg` at unit-space point `p`, facing direction `d`.
#[inline]
fn side_key(pg: &Polygon, p: Vec3, d: Vec3) -> u32 {
    let (s, t) = pg.st(p);
    let cell = pg.cell_at(s, t);
    cell * 2 + u32::from(pg.normal_at(p).dot(d) <= 0.0)
}

/// The scan-conversion hits of one slot, sorted by line (on a line, in the [`scan_order`] of
/// the polygons).
#[cfg(test)]
pub fn scan_slot(
    space: &RaySpace,
    patches: &Patches,
    slot: u32,
    seed: u64,
    jitter: f32,
) -> Vec<LineHit> {
    let mut rows = RowBuckets::default();
    scan_slot_into(space, patches, slot, seed, jitter, &mut rows);
    let mut hits = SortedHits::default();
    rows.sorted_into(&mut hits);
    (0..hits.len()).map(|i| hits.get(i)).collect()
}

/// A slot's hits sorted by line, as three arrays (hit i is `line[i]`, `depth[i]`, `key[i]`):
/// the linking compares a hit with the one before it four hits at a time.
#[derive(Default)]
pub struct SortedHits {
    line: Vec<u32>,
    depth: Vec<f32>,
    key: Vec<u32>,
}

impl SortedHits {
    fn len(&self) -> usize {
        self.line.len()
    }

    fn get(&self, i: usize) -> LineHit {
        LineHit {
            line: self.line[i],
            depth: self.depth[i],
            key: self.key[i],
        }
    }

    /// `n` hits, their values left to be overwritten (the arrays only grow).
    fn set_len(&mut self, n: usize) {
        if self.line.len() < n {
            self.line.resize(n, 0);
            self.depth.resize(n, 0.0);
            self.key.resize(n, 0);
        }
        self.line.truncate(n);
        self.depth.truncate(n);
        self.key.truncate(n);
    }

    /// Each line's few hits in order of (depth, key): an insertion sort that never moves a hit
    /// past its line's first. The scan order mostly gives the order already, so each hit is
    /// compared with the one before it four at a time, and the sort's step runs only for a
    /// group with a pair out of order (for each of its hits in turn: a step changes what
    /// the next compares).
    fn sort_lines(&mut self) {
        let n = self.len();
        let mut i = 1;
        while i + LANES <= n {
            // The hits before [i, i + 4) and those hits (slices of one length: no bounds
            // checks in the loop).
            let (line, depth, key) = (&self.line[..n], &self.depth[..n], &self.key[..n]);
            let u32s = |v: &[u32], at: usize| {
                let v: [u32; LANES] = v[at..at + LANES].try_into().expect("four hits");
                v
            };
            let f32s = |at: usize| {
                let v: [f32; LANES] = depth[at..at + LANES].try_into().expect("four hits");
                f32x4::from(v)
            };
            let bits = |m: i32x4| wide::bytemuck::cast::<_, f32x4>(m).to_bitmask();
            let same = u32x4::from(u32s(line, i - 1)).simd_eq(u32x4::from(u32s(line, i)));
            // Keys are below 2^31: a signed comparison orders them.
            let (k0, k1): (i32x4, i32x4) = (
                wide::bytemuck::cast(u32s(key, i - 1)),
                wide::bytemuck::cast(u32s(key, i)),
            );
            let (d0, d1) = (f32s(i - 1), f32s(i));
            let before =
                d1.simd_lt(d0).to_bitmask() | (d1.simd_eq(d0).to_bitmask() & bits(k1.simd_lt(k0)));
            if bits(wide::bytemuck::cast(same)) & before != 0 {
                (i..i + LANES).for_each(|h| self.insert(h));
            }
            i += LANES;
        }
        (i..n).for_each(|h| self.insert(h));
    }

    /// The insertion sort's step for hit `h`.
    fn insert(&mut self, mut h: usize) {
        while h > 0 && self.line[h - 1] == self.line[h] && {
            let (x, y) = (self.get(h - 1), self.get(h));
            (y.depth, y.key) < (x.depth, x.key)
        } {
            for v in [&mut self.line, &mut self.key] {
                v.swap(h, h - 1);
            }
            self.depth.swap(h, h - 1);
            h -= 1;
        }
    }
}

/// One slot's scan hits, bucketed by intercept row (jv) as the scan finds them, and counted
/// per column (ju): the first pass of the sort by line, done by the scan itself (a row of a
/// polygon goes to one bucket). A bucket holds whole groups of lanes, those outside too
/// (`HitGroup`): the scan stores a group in a few vector stores, where packing its cells
/// inside took a store and some arithmetic per lane.
#[derive(Default)]
pub struct RowBuckets {
    /// The polygons' scan order ([`scan_order`]).
    order: Vec<(f32, u32)>,
    rows: Vec<Vec<HitGroup>>,
    filled: Vec<u32>,
    columns: Vec<u32>,
}

/// A group of [`LANES`] candidate cells of a row: columns `column..column + LANES`, their
/// depths and side keys, and which are inside (bit l for lane l).
#[derive(Clone, Copy, Default)]
struct HitGroup {
    column: u32,
    inside: u32,
    depths: [f32; LANES],
    keys: [u32; LANES],
}

impl RowBuckets {
    fn clear(&mut self, intercepts: usize) {
        self.rows.resize_with(intercepts, Vec::new);
        self.filled.clear();
        self.filled.resize(intercepts, 0);
        // Padded so a row's last group of lanes counts into whole lanes. Past the last
        // column, nothing is counted: the sort sends the cells outside there.
        self.columns.clear();
        self.columns.resize(intercepts + 1 + LANES, 0);
    }

    /// The hits sorted by line (line = ju · intercepts + jv), stably: a stable counting sort
    /// by column of the rows taken in order. A group's four columns are consecutive, so
    /// their places are read and advanced as one vector (by the lanes inside, as the scan
    /// counted them); a cell outside goes to one place past the hits, without a branch.
    pub fn sorted_into(&mut self, out: &mut SortedHits) {
        let n = self.rows.len() as u32;
        let total = self.columns.iter().sum::<u32>() as usize;
        out.set_len(total + 1);
        let (lines, depths, keys) = (
            &mut out.line[..total + 1],
            &mut out.depth[..total + 1],
            &mut out.key[..total + 1],
        );
        starts_from_counts(&mut self.columns);
        let past = u32x4::splat(total as u32);
        // A loop per row (a flattening iterator over the rows costs a few times as much).
        for (jv, (row, &filled)) in self.rows.iter().zip(&self.filled).enumerate() {
            for g in &row[..filled as usize] {
                let at: &mut [u32; LANES] = (&mut self.columns[g.column as usize..][..LANES])
                    .try_into()
                    .expect("a group of lanes");
                let (places, inside) = (u32x4::from(*at), INSIDE_LANES[g.inside as usize & 15]);
                let inside = u32x4::from(inside);
                *at = (places + inside).to_array();
                // Lanes inside take their column's place, lanes outside the one past the hits.
                let to = (u32x4::ZERO - inside).bitselect(places, past).to_array();
                let mut line = g.column * n + jv as u32;
                for l in 0..LANES {
                    let to = to[l] as usize;
                    (lines[to], depths[to], keys[to]) = (line, g.depths[l], g.keys[l]);
                    line += n;
                }
            }
        }
        out.set_len(total);
    }
}

/// [`scan_slot`] into reused buckets (cleared first); [`RowBuckets::sorted_into`] then sorts
/// them by line.
pub fn scan_slot_into(
    space: &RaySpace,
    patches: &Patches,
    slot: u32,
    seed: u64,
    jitter: f32,
    rows: &mut RowBuckets,
) {
    rows.clear(space.intercepts as usize);
    let (family, su, sv) = space.slot_slopes(slot);
    let d = space.direction(slot);
    scan_order(patches, d, &mut rows.order);
    for i in 0..rows.order.len() {
        let pg = &patches.polygons[rows.order[i].1 as usize];
        if pg.n == Vec3::ZERO {
            continue;
        }
        let Some(plane) = SlotPlane::new(pg, family, su, sv) else {
            continue;
        };
        let back = u32::from(pg.n.dot(d) <= 0.0);
        let at = |iu: f32, iv: f32| {
            let p = line_point(family, su, sv, iu, iv, plane.depth(iu, iv));
            let (s, t) = pg.st(p);
            (s * pg.ns as f32, t * pg.nt as f32)
        };
        let p0 = at(0.0, 0.0);
        let (pu, pv) = (at(1.0, 0.0), at(0.0, 1.0));
        let map = CellMap::new(
            p0,
            (pu.0 - p0.0, pv.0 - p0.0),
            (pu.1 - p0.1, pv.1 - p0.1),
            pg,
            back,
        );
        scan_cells(
            space,
            slot,
            pg,
            seed,
            jitter,
            &mut PolygonRows { b: rows, map },
        );
    }
}

/// The order in which a slot's polygons are scanned (into `order`: (key, polygon)): by their
/// centres along the slot's direction `d`. A line's hits then mostly come in depth order
/// already, and the linking's sort by depth mostly finds them sorted, its branches
/// predicted: of the office scene's 21 million two-hit lines, 8.9 million came out of depth
/// order in the polygons' own order, and 9 lines in this one. The links do not depend on
/// this order.
pub fn scan_order(patches: &Patches, d: Vec3, order: &mut Vec<(f32, u32)>) {
    order.clear();
    order.extend(patches.polygons.iter().enumerate().map(|(i, pg)| {
        let centre = pg.corners.iter().copied().sum::<Vec3>() / pg.corners.len() as f32;
        (centre.dot(d), i as u32)
    }));
    order.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
}

/// A polygon's cell (and side key) from a hit's intercept: the hit point is affine in the
/// intercept, and so are (s, t), scaled to cell units. Its constants are held in lanes
/// already: a polygon's rows take them from here, with no splat per row.
#[derive(Clone, Copy)]
struct CellMap {
    /// s at intercept (0, 0), and its changes per unit of i_u and of i_v; t alike.
    s: [f32x4; 3],
    t: [f32x4; 3],
    /// The last cell index in s and in t.
    last: [f32x4; 2],
    /// Cells per row (nt), as 16-bit halves for the dot product.
    row: i16x8,
    first_cell: i32x4,
    back: i32x4,
}

impl CellMap {
    /// The map of polygon `pg`'s side facing +d (`back` 1 when that is its back), from (s, t)
    /// at intercept (0, 0) and their changes per unit of i_u and of i_v.
    fn new(p0: (f32, f32), ds: (f32, f32), dt: (f32, f32), pg: &Polygon, back: u32) -> CellMap {
        let splat = f32x4::splat;
        CellMap {
            s: [splat(p0.0), splat(ds.0), splat(ds.1)],
            t: [splat(p0.1), splat(dt.0), splat(dt.1)],
            last: [splat((pg.ns - 1) as f32), splat((pg.nt - 1) as f32)],
            row: wide::bytemuck::cast(i32x4::splat(pg.nt as i32)),
            first_cell: i32x4::splat(pg.first_cell as i32),
            back: i32x4::splat(back as i32),
        }
    }

    /// The side keys of four hits. (Clamped before the conversion, which gives the same
    /// cell as clamping the converted index; the plain SSE forms, since a NaN becomes 0 in
    /// `maxps` with 0 as its second operand, and a clamped value converts exactly.)
    #[inline]
    fn keys(&self, iu: f32x4, iv: f32x4) -> i32x4 {
        let cell = |[p, du, dv]: [f32x4; 3], last: f32x4| {
            let x = p + du * iu + dv * iv;
            x.fast_max(f32x4::ZERO).fast_min(last).fast_trunc_int()
        };
        let i = cell(self.s, self.last[0]);
        let j = cell(self.t, self.last[1]);
        // The cell's row times the row length as a dot product of 16-bit halves (one
        // instruction; a multiply of 32-bit lanes is several in SSE2). Exact: both are at most
        // 4096 (the patches' cells per side), so their high halves are zero.
        let row = wide::bytemuck::cast::<_, i16x8>(i).dot(self.row);
        let cell = self.first_cell + row + j;
        cell + cell + self.back
    }
}

/// One polygon's rows into the slot's buckets.
struct PolygonRows<'a> {
    b: &'a mut RowBuckets,
    map: CellMap,
}

impl Rows for PolygonRows<'_> {
    type Row<'r>
        = BucketRow<'r>
    where
        Self: 'r;
    #[inline]
    fn row(&mut self, jv: u32, cells: usize) -> BucketRow<'_> {
        let RowBuckets {
            rows,
            filled,
            columns,
            ..
        } = &mut *self.b;
        let (bucket, filled) = (&mut rows[jv as usize], &mut filled[jv as usize]);
        let need = *filled as usize + cells.div_ceil(LANES);
        if bucket.len() < need {
            bucket.resize(2 * need, HitGroup::default());
        }
        BucketRow {
            n: *filled,
            out: bucket,
            filled,
            columns,
            map: &self.map,
        }
    }
}

/// A row's groups of cells written at the end of its bucket (the row announced its cells,
/// so the bucket has room). The count is kept here (in a register) and stored when the row
/// ends.
struct BucketRow<'r> {
    out: &'r mut [HitGroup],
    n: u32,
    filled: &'r mut u32,
    columns: &'r mut [u32],
    map: &'r CellMap,
}

impl RowCells for BucketRow<'_> {
    #[inline]
    fn cells(&mut self, ju: u32, lanes: usize, iu: f32x4, iv: f32x4, pa: f32x4, inside: u32) {
        debug_assert!(lanes <= LANES && inside >> lanes == 0);
        self.out[self.n as usize] = HitGroup {
            column: ju,
            inside,
            depths: pa.to_array(),
            keys: wide::bytemuck::cast(self.map.keys(iu, iv)),
        };
        self.n += 1;
        // The four columns counted at once: a table gives the lanes' inside bits as a vector.
        let columns: &mut [u32; LANES] = (&mut self.columns[ju as usize + 1..][..LANES])
            .try_into()
            .expect("a group of lanes");
        *columns =
            (u32x4::from(*columns) + u32x4::from(INSIDE_LANES[inside as usize & 15])).to_array();
    }
}

/// The lanes of a group's inside bits, one 0 or 1 per lane, for each of the 16 bit patterns.
const INSIDE_LANES: [[u32; LANES]; 16] = {
    let mut t = [[0; LANES]; 16];
    let mut m = 0;
    while m < 16 {
        let mut l = 0;
        while l < LANES {
            t[m][l] = (m >> l & 1) as u32;
            l += 1;
        }
        m += 1;
    }
    t
};

impl Drop for BucketRow<'_> {
    fn drop(&mut self) {
        *self.filled = self.n;
    }
}

/// The Embree-cast hits of one slot: every line of the slot that crosses the unit cube is
/// followed through the scene with repeated closest-hit queries.
pub fn cast_slot(
    ctx: &Context,
    space: &RaySpace,
    patches: &Patches,
    slot: u32,
    seed: u64,
    jitter: f32,
    stats: &mut RayStats,
) -> Vec<LineHit> {
    let (family, su, sv) = space.slot_slopes(slot);
    let (a, _, _) = axes(family);
    let d = space.direction(slot);
    let dir = d.normalize();
    let h = space.step;
    let n = space.intercepts as i64;
    // Intercepts of lines through the unit cube: i = p_u − s·p_a over the cube's corners.
    let range = |s: f32| {
        let (lo, hi) = (0.0f32.min(-s), 1.0f32.max(1.0 - s));
        let amp = 0.5 * jitter * h;
        let j0 = (((lo - amp + 1.0) / h - 0.5).ceil() as i64).clamp(0, n - 1);
        let j1 = (((hi + amp + 1.0) / h - 0.5).floor() as i64).clamp(0, n - 1);
        j0..=j1
    };
    let mut hits = Vec::new();
    let start_depth = -0.5;
    for ju in range(su) {
        for jv in range(sv) {
            let (du, dv) = space.jitter(seed, jitter, slot, ju as u32, jv as u32);
            let (iu, iv) = (
                space.intercept(ju as u32) + du,
                space.intercept(jv as u32) + dv,
            );
            let origin = space.to_world(line_point(family, su, sv, iu, iv, start_depth));
            let mut ray = Ray::new(origin, dir);
            // Lines through the cube span at most its diagonal in p_a (plus the start).
            ray.tmax = 3.0 * space.scale * d.length();
            let line = ju as u32 * space.intercepts + jv as u32;
            while let Some(hit) = ctx.intersect_hit(&ray, stats) {
                let pw = ray.at(hit.t);
                let p = space.to_unit(pw);
                if let Some((poly, _)) = patches.locate(hit.geom_id, hit.prim_id, p) {
                    let pg = &patches.polygons[poly as usize];
                    if pg.n != Vec3::ZERO || pg.sphere.is_some() {
                        hits.push(LineHit {
                            line,
                            depth: p[a],
                            key: side_key(pg, p, d),
                        });
                    }
                }
                // Continue just past this hit (a relative epsilon of the scene's size).
                ray.tmin = hit.t + 1e-5 * space.scale;
            }
        }
    }
    hits
}

/// Hits closer than this along a line (unit-cube units of p_a) are on touching surfaces.
pub const COINCIDENT: f32 = 1e-5;

/// Reusable buffers of a batch's linking and the sorts before it.
#[derive(Default)]
pub struct LinkBuffers {
    counts: Vec<u32>,
    tmp: Vec<LineHit>,
    radix: Vec<LineHit>,
    sorted: SortedHits,
    rows: RowBuckets,
    /// The batch's packed link ends, one bucket per key block, each in the order the links
    /// were found, slot after slot (so grouped by slot already); `bucket_at[b·slots + j]` is
    /// block b's length before the batch's j-th slot.
    buckets: Vec<Vec<u32>>,
    bucket_at: Vec<u32>,
    /// The batch's later escapes, slot after slot: slot j's are
    /// `more[more_at[j]..more_at[j + 1]]` (past the last, room for the next slot's).
    more: Vec<u32>,
    more_at: Vec<usize>,
    /// A slot's escapes, over all side keys (cleared after each slot).
    escapes: Vec<u64>,
}

/// Stable LSD radix sort of hits by line (into `buf.sorted`) in two passes of about half the
/// line bits each: the digit counters stay in the first-level cache, where one counter per
/// line (hundreds of kilobytes at fine intercept steps) would not.
fn radix_by_line(hits: &[LineHit], lines: usize, buf: &mut LinkBuffers) {
    let bits = usize::BITS - lines.max(2).saturating_sub(1).leading_zeros();
    let lo_bits = bits.div_ceil(2);
    let blank = LineHit {
        line: 0,
        depth: 0.0,
        key: 0,
    };
    let (counts, tmp, sorted) = (&mut buf.counts, &mut buf.tmp, &mut buf.radix);
    // Every element is overwritten by the passes: only grow, never clear.
    for v in [&mut *tmp, &mut *sorted] {
        if v.len() < hits.len() {
            v.resize(hits.len(), blank);
        }
    }
    let (tmp, sorted) = (&mut tmp[..hits.len()], &mut sorted[..hits.len()]);
    let mut pass = |from: &[LineHit], to: &mut [LineHit], shift: u32, digits: usize| {
        counts.clear();
        counts.resize(digits + 1, 0);
        let digit = |h: LineHit| (h.line >> shift) as usize & (digits - 1);
        for &h in from {
            counts[digit(h) + 1] += 1;
        }
        starts_from_counts(counts);
        scatter_stably(counts, from.iter().copied(), digit, |h| h, to);
    };
    pass(hits, tmp, 0, 1 << lo_bits);
    pass(tmp, sorted, lo_bits, 1 << (bits - lo_bits));
    let out = &mut buf.sorted;
    out.set_len(0);
    for h in sorted.iter() {
        out.line.push(h.line);
        out.depth.push(h.depth);
        out.key.push(h.key);
    }
}

/// Sorts one slot's hits (sorted by line) by depth within each line's few hits and links
/// consecutive ones, as the `j`-th slot of `out`: the packed link ends go to their key
/// block's bucket and a side's second and later escapes to `more` (both joined later,
/// [`LinkBatch::group_ends`]), the escapes straight into `out`. (Which sides are nodes, the
/// assembly reads off the link ends.) Not inlined: in the batch's loop, its loop reloaded
/// the buckets' and the hits' addresses from the stack for every pair.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn link_slot<const USUAL: bool>(
    hits: &mut SortedHits,
    j: usize,
    packing: EndPacking,
    outer: &[u64],
    buckets: &mut [Vec<u32>],
    more: &mut Vec<u32>,
    more_at: &mut Vec<usize>,
    escapes: &mut [u64],
    out: &mut LinkBatch,
) {
    let packing = packing.known::<USUAL>();
    let len = hits.len();
    out.intersections += len as u64;
    // The slot's escapes gather in `escapes` (a bit set over all side keys: dense, so it
    // stays in cache, where the batch's block-major copy would not) and go to `out` after.
    // A side's later escapes go to `more` without a branch (whether a side has escaped
    // already is data, not a pattern): each escape is written at the next place, which
    // advances only for a later one. A line has at most two.
    let mut n = *more_at.last().expect("a batch's escapes start at 0");
    if more.len() < n + 2 * len {
        more.resize(n + 2 * len, 0);
    }
    // A slice: the compiler keeps its address and length in registers, where it reloaded
    // the Vec's from memory for every escape.
    let more = &mut more[..];
    let mut escape = |k: u32| {
        let (w, bit) = (k as usize / 64, k % 64);
        // A side facing out of the scene is never a node: its escape is dropped here, not
        // carried to the assembly (in a room, nearly every escape is a wall's outer side).
        if outer[w] >> bit & 1 == 1 {
            return;
        }
        let seen = escapes[w] >> bit & 1;
        more[n] = k;
        n += seen as usize;
        escapes[w] |= 1 << bit;
    };
    hits.sort_lines();
    // Entering the scene: the first side facing −d looks out of it; leaving it, the last
    // side facing +d. Consecutive hits on a line link; between lines, one leaves and the
    // next enters (the same order as line by line).
    let (line, depth, key) = (&hits.line[..len], &hits.depth[..len], &hits.key[..len]);
    if let (Some(&first), Some(&last)) = (key.first(), key.last()) {
        escape(first ^ 1);
        for i in 1..len {
            if line[i - 1] != line[i] {
                escape(key[i - 1]);
                escape(key[i] ^ 1);
                continue;
            }
            let (x, y) = (key[i - 1], key[i] ^ 1);
            // A line meeting the same side twice in a row (a hit on an edge counted by both
            // of its cells' polygon) carries nothing; coincident surfaces (a box standing on
            // the floor) touch, and no light passes between them.
            if x != y && depth[i] - depth[i - 1] > COINCIDENT {
                for (k, t) in [(x, y), (y, x)] {
                    buckets[packing.block_of(k)].push(packing.pack(k, t));
                }
            } else {
                out.degenerate += 1;
            }
        }
        escape(last);
    }
    more_at.push(n);
    let (words, slots) = (out.words, out.slots as usize);
    for (b, bits) in escapes.chunks_mut(words).enumerate() {
        let g = b * slots + j;
        out.escapes[g * words..g * words + bits.len()].copy_from_slice(bits);
        bits.fill(0);
    }
}

impl LinkBatch {
    /// An empty batch of `slots` slots, for `keys` side keys.
    fn new(slots: usize, keys: usize, packing: EndPacking) -> LinkBatch {
        let groups = keys.div_ceil(packing.block()) * slots;
        let words = packing.block() / 64;
        LinkBatch {
            slots: slots as u32,
            start: vec![0; groups + 1],
            escapes: vec![0; groups * words],
            words,
            more_start: vec![0; groups + 1],
            ..LinkBatch::default()
        }
    }

    /// Joins the batch's buckets of link ends block after block (each is grouped by slot
    /// already) and groups its later escapes (`buf`, slot after slot) by key block and slot,
    /// keeping their order within a group.
    fn group_ends(&mut self, buf: &LinkBuffers, packing: EndPacking) {
        let slots = self.slots as usize;
        let total: usize = buf.buckets.iter().map(Vec::len).sum();
        self.pairs = total as u64 / 2;
        let mut ends = Vec::with_capacity(total);
        for (b, bucket) in buf.buckets.iter().enumerate() {
            let base = ends.len() as u32;
            let at = &buf.bucket_at[b * slots..(b + 1) * slots];
            for (to, &at) in self.start[b * slots..(b + 1) * slots].iter_mut().zip(at) {
                *to = base + at;
            }
            ends.extend_from_slice(bucket);
        }
        *self.start.last_mut().expect("a batch has a group") = total as u32;
        self.ends = ends;
        self.more_escapes = group_slots(&mut self.more_start, &buf.more, &buf.more_at, |k| {
            (packing.block_of(k) * slots, k)
        });
    }
}

/// A stable counting sort of a batch's items (slot j's are `items[at[j]..at[j + 1]]`; `items`
/// may hold more after the last slot's) into groups: `place(item)` gives its group for the
/// batch's first slot (slot j's group is j further on) and its value. `start` (zeros on
/// entry, one more than the groups) gives on return group g's first index in `start[g]`.
fn group_slots<T: Copy, V: Copy + Default>(
    start: &mut [u32],
    items: &[T],
    at: &[usize],
    place: impl Fn(T) -> (usize, V),
) -> Vec<V> {
    for (j, r) in at.windows(2).enumerate() {
        for &x in &items[r[0]..r[1]] {
            start[place(x).0 + j + 1] += 1;
        }
    }
    starts_from_counts(start);
    let mut grouped = vec![V::default(); at.last().map_or(0, |&n| n)];
    let mut next = start.to_vec();
    // A loop per slot (the slot a constant in it).
    for (j, r) in at.windows(2).enumerate() {
        scatter_stably(
            &mut next,
            items[r[0]..r[1]].iter().copied(),
            |x| place(x).0 + j,
            |x| place(x).1,
            &mut grouped,
        );
    }
    grouped
}

/// Counts to starts, in place: `at[g + 1]` holds group g's item count (`at[0]` is 0), and
/// becomes the end of group g (so `at[g]` its start).
pub(super) fn starts_from_counts(at: &mut [u32]) {
    for i in 1..at.len() {
        at[i] += at[i - 1];
    }
}

/// The scatter of a stable counting sort, shared by the sorts of the preprocess: `at[g]` is
/// the next place of group g in `out` ([`starts_from_counts`]); `value` of every item goes
/// there, in the items' order.
pub(super) fn scatter_stably<T: Copy, V>(
    at: &mut [u32],
    items: impl IntoIterator<Item = T>,
    group_of: impl Fn(T) -> usize,
    value: impl Fn(T) -> V,
    out: &mut [V],
) {
    items.into_iter().for_each(|x| {
        let to = &mut at[group_of(x)];
        out[*to as usize] = value(x);
        *to += 1;
    });
}

/// Runs a builder over every slot, in parallel over batches of [`SLOT_BATCH`] slots,
/// returning the batches in slot order. Escapes at the side keys of `outer` (a bit set:
/// sides that can never be nodes, [`Patches::outer_sides`]) are dropped.
#[allow(clippy::too_many_arguments)]
pub fn build_links(
    ctx: Option<&Context>,
    space: &RaySpace,
    patches: &Patches,
    seed: u64,
    jitter: f32,
    builder: Builder,
    packing: EndPacking,
    outer: &[u64],
) -> (Vec<LinkBatch>, RayStats) {
    let slots = space.slots();
    let keys = 2 * patches.cells as usize;
    let results: Vec<(LinkBatch, RayStats)> = (0..slots.div_ceil(SLOT_BATCH))
        .into_par_iter()
        .map_init(LinkBuffers::default, |buf, batch| {
            let first = batch * SLOT_BATCH;
            let mut out = LinkBatch::new(SLOT_BATCH.min(slots - first), keys, packing);
            let mut stats = RayStats::default();
            let (slots, blocks) = (out.slots as usize, keys.div_ceil(packing.block()));
            buf.more_at.clear();
            buf.more_at.push(0);
            buf.buckets.resize_with(blocks, Vec::new);
            buf.buckets.iter_mut().for_each(Vec::clear);
            buf.bucket_at.clear();
            buf.bucket_at.resize(blocks * slots, 0);
            buf.escapes.resize(keys.div_ceil(64), 0);
            for j in 0..slots {
                let slot = (first + j) as u32;
                match (builder, ctx) {
                    (Builder::Embree, Some(ctx)) => {
                        let hits = cast_slot(ctx, space, patches, slot, seed, jitter, &mut stats);
                        radix_by_line(&hits, space.lines_per_slot(), buf);
                    }
                    _ => {
                        scan_slot_into(space, patches, slot, seed, jitter, &mut buf.rows);
                        buf.rows.sorted_into(&mut buf.sorted);
                    }
                }
                for (b, bucket) in buf.buckets.iter().enumerate() {
                    buf.bucket_at[b * slots + j] = bucket.len() as u32;
                }
                let sorted = &mut buf.sorted;
                let (buckets, escapes) = (&mut buf.buckets, &mut buf.escapes);
                let (more, more_at) = (&mut buf.more, &mut buf.more_at);
                let (p, out) = (packing, &mut out);
                if p == EndPacking::USUAL {
                    link_slot::<true>(sorted, j, p, outer, buckets, more, more_at, escapes, out);
                } else {
                    link_slot::<false>(sorted, j, p, outer, buckets, more, more_at, escapes, out);
                }
            }
            out.group_ends(buf, packing);
            (out, stats)
        })
        .collect();
    let mut stats = RayStats::default();
    let links = results
        .into_iter()
        .map(|(l, s)| {
            stats.add(&s);
            l
        })
        .collect();
    (links, stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_ends_round_trip() {
        // Small networks take the usual packing; larger ones give block bits to the targets.
        for (keys, block_bits) in [
            (3usize, 9u32),
            (151_722, 9),
            (1 << 23, 9),
            ((1 << 23) + 1, 8),
            (1 << 26, 6),
        ] {
            let p = EndPacking::for_keys(keys).unwrap();
            assert_eq!(p.block_bits, block_bits, "{keys} keys");
            assert_eq!(p == EndPacking::USUAL, block_bits == 9, "{keys} keys");
            assert!(p.block_bits + p.target_bits <= 32);
            let last = keys as u32 - 1;
            for key in [0, 1, last / 2, last] {
                let block = key as usize / p.block();
                for target in [0, 1, last / 3, last] {
                    let end = p.pack(key, target);
                    assert_eq!(p.unpack(block, end), (key, target), "{keys} keys");
                }
            }
        }
        let e = EndPacking::for_keys((1 << 26) + 1).unwrap_err();
        assert!(e.contains("--patch-size"), "{e}");
    }
}
