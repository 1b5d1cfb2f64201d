//! The Embree builder: every jittered line of a slot followed through the scene with repeated
//! closest-hit queries, and its hits radix-sorted by line.

use super::counting_sort::{scatter_stably, starts_from_counts};
use super::link_buffers::LinkBuffers;
use super::scan::line_point;
use super::LineHit;
use crate::integrators::illumination_network::patches::{Patches, Polygon};
use crate::integrators::illumination_network::ray_space::{axes, RaySpace};
use crate::math::spawn::Spot;
use crate::math::{Ray, Vec3};
use crate::transport::{Context, RayStats};

/// The side key of a hit on polygon `pg` at unit-space point `p`, facing direction `d`.
#[inline]
fn side_key(pg: &Polygon, p: Vec3, d: Vec3) -> u32 {
    let (s, t) = pg.st(p);
    let cell = pg.cell_at(s, t);
    cell * 2 + u32::from(pg.normal_at(p).dot(d) <= 0.0)
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
                let at = hit.spot(ctx.scene, &ray);
                let p = space.to_unit(at.p);
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
                // Continue from just past this surface (off its error box), along the same
                // line for what is left of it. A line lying in the surface's plane gains no
                // ground from the normal's side: it steps past the box along itself.
                let left = ray.tmax - hit.t;
                let step = if hit.t > 0.0 {
                    at.spawn(dir)
                } else {
                    Spot { n: dir, ..at }.spawn(dir)
                };
                ray = Ray { tmax: left, ..step };
            }
        }
    }
    hits
}

/// Stable LSD radix sort of hits by line (into `buf.sorted`) in two passes of about half the
/// line bits each: the digit counters stay in the first-level cache, where one counter per
/// line (hundreds of kilobytes at fine intercept steps) would not.
pub(super) fn radix_by_line(hits: &[LineHit], lines: usize, buf: &mut LinkBuffers) {
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
