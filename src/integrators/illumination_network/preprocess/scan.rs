//! Scan conversion of one polygon for one slot: the lines whose jittered intercepts fall in
//! the polygon's projection, four cells at a time in SIMD lanes, their depths by the paper's
//! recurrence (the preprocess's module docs give it).

use crate::integrators::illumination_network::patches::Polygon;
use crate::integrators::illumination_network::ray_space::{
    axes, jitter_seed, slot_jitter_seed, RaySpace,
};
use crate::math::Vec3;
use wide::{f32x4, i32x4, u32x4};

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

#[cfg(test)]
/// Scan-converts one polygon for one slot: calls `hit(line, iu, iv, p_a)` for every line of
/// the slot (with jittered intercepts (iu, iv)) that meets the polygon, p_a computed by the
/// incremental recurrence.
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
pub(super) trait Rows {
    type Row<'r>: RowCells
    where
        Self: 'r;
    fn row(&mut self, jv: u32, cells: usize) -> Self::Row<'_>;
}

/// The cells of one row, [`LANES`] at a time: `cells(ju, lanes, iu, iv, p_a, inside)` for the
/// `lanes` candidates from column `ju` on (all but a row's last group are full), with their
/// jittered intercepts, depths, and whether each is inside (bit l for lane l).
pub(super) trait RowCells {
    fn cells(&mut self, ju: u32, lanes: usize, iu: f32x4, iv: f32x4, pa: f32x4, inside: u32);
}

/// Candidate cells scanned together, one per SIMD lane.
pub(super) const LANES: usize = 4;

#[cfg(test)]
/// [`scan_polygon`]'s callback, for the cells inside, and a row of it.
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
pub(super) fn scan_cells<R: Rows>(
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
