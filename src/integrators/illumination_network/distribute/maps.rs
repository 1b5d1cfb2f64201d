//! The directional nodes' reflectance maps (mirror, glossy, clear and frosted transmission),
//! from in-slots to out-slots, built from the materials at each distribution.

use super::Surface;
use crate::bsdf::Ggx;
use crate::integrators::illumination_network::ray_space::{axes, RaySpace};
use crate::integrators::illumination_network::{Network, ESCAPE, NONE};
use crate::math::{Rgb, Vec3};

/// A sparse map from in-slots to out-slots, rows normalised to 1.
#[derive(Clone, Debug, Default)]
pub struct SparseMap {
    /// in-slot → range in `entries`; rows of slots without a link are empty.
    pub offsets: Vec<u32>,
    pub entries: Vec<(u32, f32)>,
}

/// Candidate slots around direction `dir` (unit): every slot within `radius` grid steps of
/// `dir`'s slope coordinates in each family whose slope range it is near.
pub(crate) fn candidates(space: &RaySpace, dir: Vec3, radius: i64, out: &mut Vec<u32>) {
    out.clear();
    for_each_candidate(space, dir, radius, |l| out.push(l));
}

/// [`candidates`], one at a time and in the same order, without a list.
#[inline]
pub(crate) fn for_each_candidate(space: &RaySpace, dir: Vec3, radius: i64, mut f: impl FnMut(u32)) {
    let s = space.slopes as i64;
    let margin = (radius + 1) as f32 * space.slope_step();
    for family in 0..3u32 {
        let (a, u, v) = axes(family);
        if dir[a].abs() < 1e-6 {
            continue;
        }
        let (su, sv) = (dir[u] / dir[a], dir[v] / dir[a]);
        if su.abs() > 1.0 + margin || sv.abs() > 1.0 + margin {
            continue;
        }
        let (cu, cv) = (
            space.slope_coord(su).round() as i64,
            space.slope_coord(sv).round() as i64,
        );
        for ku in (cu - radius).max(0)..=(cu + radius).min(s - 1) {
            for kv in (cv - radius).max(0)..=(cv + radius).min(s - 1) {
                f(space.slot(family, ku as u32, kv as u32));
            }
        }
    }
}

/// The linked (or escaping) slot of `row` nearest to direction `target`; `None` if the row
/// has no slot at all.
fn nearest_linked(space: &RaySpace, row: &[u32], target: Vec3, buf: &mut Vec<u32>) -> Option<u32> {
    let mut radius = 1;
    loop {
        candidates(space, target, radius, buf);
        let best = buf
            .iter()
            .filter(|&&l| row[l as usize] != NONE)
            .map(|&l| (l, space.direction(l).normalize().dot(target).abs()))
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)));
        if let Some((l, _)) = best {
            return Some(l);
        }
        if radius > space.slopes as i64 {
            return None;
        }
        radius *= 2;
    }
}

/// A lobe of directions around `centre` (unit), on the side of `normal`: `weight(d)` for a
/// unit direction d. Its roughness or angular width `alpha` sets how far from the centre
/// the slots are searched (about 3α radians).
struct Lobe<F> {
    normal: Vec3,
    centre: Vec3,
    alpha: f32,
    weight: F,
}

/// A normalised lobe over the linked slots of `row` around the lobe's centre: weight(l) =
/// lobe.weight(direction of l)·w_l; falls back to the nearest slot when the lobe misses every
/// slot.
fn lobe_row(
    space: &RaySpace,
    row: &[u32],
    lobe: Lobe<impl Fn(Vec3) -> f32>,
    buf: &mut Vec<u32>,
    out: &mut Vec<(u32, f32)>,
) {
    let Lobe {
        normal,
        centre,
        alpha,
        weight: lobe,
    } = lobe;
    // Lobe reach ≈ 3α radians; one slope step is about 2/S radians near a family centre.
    let radius =
        ((3.0 * alpha * space.slopes as f32 / 2.0).ceil() as i64 + 1).min(space.slopes as i64);
    candidates(space, centre, radius, buf);
    let start = out.len();
    for &l in buf.iter() {
        if row[l as usize] == NONE {
            continue;
        }
        let d = space.direction_towards(l, normal);
        let w = lobe(d) * space.etendue(l);
        if w > 0.0 && w.is_finite() {
            out.push((l, w));
        }
    }
    // Keep the 64 largest entries: the tail of a wide lobe carries little light.
    out[start..].sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    let keep = (out.len() - start).min(64);
    out.truncate(start + keep);
    let sum: f32 = out[start..].iter().map(|e| e.1).sum();
    if sum > 0.0 {
        for e in &mut out[start..] {
            e.1 /= sum;
        }
    } else {
        out.truncate(start);
        if let Some(l) = nearest_linked(space, row, centre, buf) {
            out.push((l, 1.0));
        }
    }
}

/// The local-frame vector with cosine `c` to the normal (for the isotropic GGX terms).
pub(crate) fn local(c: f32) -> Vec3 {
    Vec3::new((1.0 - c * c).max(0.0).sqrt(), 0.0, c)
}

/// Reflection (on the node's own slots) and transmission (onto its twin's slots) maps.
pub(super) fn maps(
    net: &Network,
    node: u32,
    surface: &Surface,
    twin: u32,
) -> (SparseMap, SparseMap) {
    let space = &net.space;
    let (mut row, mut trow) = (Vec::new(), Vec::new());
    net.row_into(node, &mut row);
    // The twin's row, for transmission only.
    if surface.kt.max_element() > 0.0 && twin != NONE {
        net.row_into(twin, &mut trow);
    }
    let n = net.node_normal(node);
    let mut buf = Vec::new();
    let mut reflect = SparseMap {
        offsets: vec![0],
        ..SparseMap::default()
    };
    let mut transmit = reflect.clone();
    // A lobe narrower than the slot spacing cannot be sampled by the slots: it is a mirror
    // (or clear transmission) at this resolution.
    let sharp = 0.5 * space.slope_step();
    for l in 0..row.len() as u32 {
        // Light arrives only over real links.
        if row[l as usize] < ESCAPE {
            let wi = space.direction_towards(l, n);
            if surface.ks.max_element() > 0.0 {
                let r = 2.0 * n.dot(wi) * n - wi;
                if surface.alpha <= sharp {
                    // The linked slots among the four bounding the mirror direction, with
                    // bilinear weights (so reflections move smoothly with the direction),
                    // else the nearest linked slot.
                    let start = reflect.entries.len();
                    let mut sum = 0.0;
                    for (o, wgt) in space.bounding_slots(r) {
                        if row[o as usize] != NONE && wgt > 0.0 {
                            match reflect.entries[start..].iter_mut().find(|e| e.0 == o) {
                                Some(e) => e.1 += wgt,
                                None => reflect.entries.push((o, wgt)),
                            }
                            sum += wgt;
                        }
                    }
                    if sum > 0.0 {
                        for e in &mut reflect.entries[start..] {
                            e.1 /= sum;
                        }
                    } else if let Some(o) = nearest_linked(space, &row, r, &mut buf) {
                        reflect.entries.push((o, 1.0));
                    }
                } else {
                    let ggx = Ggx::isotropic(surface.alpha.max(1e-3));
                    let ci = n.dot(wi);
                    let lobe = |wo: Vec3| {
                        let co = n.dot(wo);
                        if co <= 0.0 {
                            return 0.0;
                        }
                        let h = (wi + wo).normalize();
                        ggx.d(local(n.dot(h))) * ggx.g(local(co), local(ci)) / (4.0 * ci * co)
                    };
                    let lobe = Lobe {
                        normal: n,
                        centre: r,
                        alpha: surface.alpha,
                        weight: lobe,
                    };
                    lobe_row(space, &row, lobe, &mut buf, &mut reflect.entries);
                }
            }
            if surface.kt.max_element() > 0.0 && twin != NONE {
                let through = -wi;
                if surface.alpha <= sharp {
                    let o = if trow[l as usize] != NONE {
                        Some(l)
                    } else {
                        nearest_linked(space, &trow, through, &mut buf)
                    };
                    if let Some(o) = o {
                        transmit.entries.push((o, 1.0));
                    }
                } else {
                    // Frosted: a Gaussian spread of angular width α around the straight line.
                    let sigma2 = surface.alpha * surface.alpha;
                    let lobe = |wo: Vec3| {
                        let c = wo.dot(through).clamp(-1.0, 1.0);
                        if c <= 0.0 {
                            return 0.0;
                        }
                        let th = c.acos();
                        (-0.5 * th * th / sigma2).exp()
                    };
                    let lobe = Lobe {
                        normal: -n,
                        centre: through,
                        alpha: surface.alpha,
                        weight: lobe,
                    };
                    lobe_row(space, &trow, lobe, &mut buf, &mut transmit.entries);
                }
            }
        }
        reflect.offsets.push(reflect.entries.len() as u32);
        transmit.offsets.push(transmit.entries.len() as u32);
    }
    (reflect, transmit)
}

/// out[l'] += k·c·in[l] over a map's entries.
pub(super) fn apply(map: &SparseMap, input: &[Rgb], k: Rgb, out: &mut [Rgb]) {
    for (l, flux) in input.iter().enumerate() {
        if *flux == Rgb::ZERO {
            continue;
        }
        let (a, b) = (map.offsets[l] as usize, map.offsets[l + 1] as usize);
        for &(o, c) in &map.entries[a..b] {
            out[o as usize] += *flux * k * c;
        }
    }
}
