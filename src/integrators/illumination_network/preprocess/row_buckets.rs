//! One slot's scan: its polygons in depth order ([`scan_order`]) scanned into buckets by
//! intercept row, each hit's side key computed in the lanes ([`CellMap`]), then the buckets
//! sorted by line with one counting pass by column ([`RowBuckets::sorted_into`]).

use super::counting_sort::starts_from_counts;
use super::scan::{line_point, scan_cells, RowCells, Rows, SlotPlane, LANES};
use super::sorted_hits::SortedHits;
#[cfg(test)]
use super::LineHit;
use crate::integrators::illumination_network::patches::{Patches, Polygon};
use crate::integrators::illumination_network::ray_space::RaySpace;
use crate::math::Vec3;
use wide::{f32x4, i16x8, i32x4, u32x4};

#[cfg(test)]
/// The scan-conversion hits of one slot, sorted by line (on a line, in the [`scan_order`] of
/// the polygons).
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
