//! The distribution process: light shot from the emitting nodes travels over the links until
//! the flux still to be shot falls below `tolerance` of the emitted flux.
//!
//! **Reflectance.** Each node's reflectance maps incoming links to outgoing links:
//! - diffuse kd: the paper's bypass: incoming flux is summed into one accumulator and leaves
//!   as the same radiance kd·Φ/W on every slot (flux ∝ w);
//! - specular ks, roughness below half a slope step (mirror at this resolution): the
//!   reflected direction split bilinearly over the linked (or escaping) ones of its four
//!   bounding slots, else the nearest linked slot;
//! - specular ks, roughness α (glossy): a GGX lobe D·G/(4 cosθi cosθo) times the étendue of
//!   the outgoing slot, over the slots near the reflected direction, normalised;
//! - transmission kt: the identity onto the other side of the patch (the same line continues),
//!   or with roughness α (frosted) a lobe of angular width α around it.
//!
//! Every row of a directional map is normalised to 1 and scaled by ks or kt, so a row sums
//! exactly to the material's albedo (kd + ks + kt is scaled down to at most 1 per channel,
//! Fresnel weighting is not modelled). Directional maps are built here, not in the
//! preprocess: they depend on materials, which relighting may change.
//!
//! **Order.** Jacobi sweeps: in each sweep every node gathers what its neighbours shot in the
//! previous sweep over its links (links are symmetric, so gathering over a node's own links is
//! the scatter of its neighbours), then passes it through its reflectance. Each sweep is
//! parallel over nodes and independent of the thread count. Sweep k carries exactly the
//! light of k bounces, so the first sweep's output is direct illumination (kept for the
//! hybrid rendering). The gather is branchless for the diffuse light (`Ends::gather`);
//! directional ends add their rows on top.
//!
//! All-diffuse networks are solved by default with conjugate gradients on the symmetrised
//! system ([`conjugate_gradients`]): the same gather, about 8 of them where the sweeps take
//! 13, and a smaller error. Networks with directional nodes (their maps are not symmetric)
//! use the sweeps whatever the order asked; `Order::Shoot` is the paper-era alternative,
//! sequential.

pub mod conjugate_gradients;

use super::ray_space::RaySpace;
use super::{interleaved_sum, LinkCode, Network, SlotWeights, ESCAPE, NONE};
use crate::bsdf::Ggx;
use crate::math::{Rgb, Vec2, Vec3};
use crate::scene::Scene;
use glam::Vec3A;
use rayon::prelude::*;

/// The surface of one node.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Surface {
    pub kd: Rgb,
    pub ks: Rgb,
    pub kt: Rgb,
    pub alpha: f32,
    /// Emitted radiance (fronts of emissive materials only).
    pub emission: Rgb,
}

impl Surface {
    pub fn directional(&self) -> bool {
        self.ks.max_element() > 0.0 || self.kt.max_element() > 0.0
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistributeOptions {
    /// Stop when the flux still to be shot is below this fraction of the emitted flux.
    pub tolerance: f32,
    pub max_sweeps: u32,
    /// Emission multiplier (relighting).
    pub light_scale: f32,
    pub order: Order,
}

/// The order in which nodes process their light.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Order {
    /// Jacobi sweeps over all nodes, in parallel.
    Sweeps,
    /// Largest unshot flux first (Southwell iteration, as progressive radiosity), one node at
    /// a time. Networks with directional nodes use sweeps.
    Shoot,
    /// Conjugate gradients on the symmetrised system ([`conjugate_gradients`]): about half
    /// the gathers of the sweeps for the same tolerance. Networks with directional nodes use
    /// sweeps.
    #[default]
    ConjugateGradients,
}

impl Default for DistributeOptions {
    fn default() -> Self {
        DistributeOptions {
            tolerance: super::DEFAULT_TOLERANCE,
            max_sweeps: 100_000,
            light_scale: 1.0,
            order: Order::ConjugateGradients,
        }
    }
}

/// A sparse map from in-slots to out-slots, rows normalised to 1.
#[derive(Clone, Debug, Default)]
pub struct SparseMap {
    /// in-slot → range in `entries`; rows of slots without a link are empty.
    pub offsets: Vec<u32>,
    pub entries: Vec<(u32, f32)>,
}

/// The converged network: what rendering reads.
#[derive(Clone, Debug, Default)]
pub struct Solution {
    pub surfaces: Vec<Surface>,
    /// Reflected radiance of each node's diffuse part (every slot).
    pub diffuse: Vec<Rgb>,
    /// The part of `diffuse` reflected from light that came straight from the emitters (the
    /// first sweep), for the hybrid rendering.
    pub direct: Vec<Rgb>,
    /// For directional nodes: index into `directional` rows, else [`NONE`].
    pub dir_index: Vec<u32>,
    /// Reflected directional radiance per slot, one row of `slots` per directional node.
    pub directional: Vec<Rgb>,
    /// Radiance that arrived over each slot, one row per directional node (the in-buffers
    /// accumulated over the sweeps), for rendering.
    pub incoming: Vec<Rgb>,
    /// The link rows of the directional nodes (in `dir_index` order): rendering gathers over
    /// their linked slots without the network's link table (relighting from a stored basis
    /// does not read it).
    pub dir_rows: Vec<u32>,
    pub stats: DistributeStats,
    /// The emission multiplier the solution was computed with.
    pub light_scale: f32,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DistributeStats {
    /// Passes over the links: sweeps, or the gathers of conjugate gradients (one each), or
    /// for [`Order::Shoot`] the shots.
    pub sweeps: u32,
    /// Flux (RGB) emitted, escaped over links that leave the scene, absorbed, and still
    /// unshot at the end: emitted = escaped + absorbed + unshot.
    pub emitted: [f64; 3],
    pub escaped: [f64; 3],
    pub absorbed: [f64; 3],
    pub unshot: [f64; 3],
    /// Entries of the directional maps.
    pub map_entries: u64,
    /// Started from a guess ([`distribute_from`]).
    pub warm_start: bool,
    pub seconds: f64,
}

/// The nodes' surfaces from the scene's materials (diffuse textures are evaluated at the
/// patch centre).
pub fn surfaces(net: &Network, scene: &Scene, light_scale: f32) -> Vec<Surface> {
    let emission: Vec<Rgb> = scene
        .materials
        .iter()
        .map(|m| m.emission * light_scale)
        .collect();
    surfaces_with(net, scene, &emission)
}

/// [`surfaces`] with the emission of each material given (indexed as `scene.materials`):
/// relighting distributes one emissive material at a time.
pub fn surfaces_with(net: &Network, scene: &Scene, emission: &[Rgb]) -> Vec<Surface> {
    (0..net.nodes() as u32)
        .map(|node| {
            let (poly, cell, side) = net.node_place(node);
            let pg = &net.patches.polygons[poly as usize];
            let mi = scene.shapes[pg.shape as usize].material;
            let m = &scene.materials[mi];
            let (s, t) = pg.cell_centre(cell);
            let p = net.space.to_world(pg.point(s, t));
            let kd = m.diffuse.eval(p, Vec2::new(s, t));
            let (mut kd, mut ks, mut kt) = (kd, m.specular, m.transmission);
            let total = kd + ks + kt;
            for c in 0..3 {
                if total[c] > 1.0 {
                    kd[c] /= total[c];
                    ks[c] /= total[c];
                    kt[c] /= total[c];
                }
            }
            Surface {
                kd,
                ks,
                kt,
                alpha: m.roughness,
                emission: if side == 0 { emission[mi] } else { Rgb::ZERO },
            }
        })
        .collect()
}

/// The colour channel (0 red, 1 green, 2 blue) in which emitted light can never leave some
/// part of the scene: a group of nodes that reflect or transmit all of it (kd + ks + kt = 1),
/// holding an emitter, with no link from it to an absorbing node or out of the scene (the
/// whole scene when it is closed, or a sealed box inside an open one). Its radiance has no
/// finite value (each bounce carries all of it on), so no distribution converges: the sweeps
/// would run to `max_sweeps`, conjugate gradients stop at a value set by rounding. Gives the
/// channel and an emitting node of such a group, `None` when every channel is bounded.
/// Needs the link table; walks the links of the lossless nodes joined to a lossless
/// emitter, none when no emitter is lossless (the usual case).
pub fn lossless_channel(net: &Network, surfaces: &[Surface]) -> Option<(usize, u32)> {
    let nodes = net.nodes();
    (0..3).find_map(|c| {
        let lossless = |i: usize| {
            let s = &surfaces[i];
            s.kd[c] + s.ks[c] + s.kt[c] >= 1.0 - 1e-6
        };
        let mut seen = vec![false; nodes];
        let mut stack = Vec::new();
        (0..nodes)
            .filter(|&i| surfaces[i].emission[c] > 0.0 && lossless(i))
            .find(|&emitter| {
                if seen[emitter] {
                    // Its group was walked whole from an earlier emitter, and can leave.
                    return false;
                }
                // The whole group of lossless nodes the emitter's light can reach: over links,
                // and through transmitting patches to their other side.
                let mut leaves = false;
                seen[emitter] = true;
                stack.push(emitter as u32);
                while let Some(i) = stack.pop() {
                    let through = (surfaces[i as usize].kt[c] > 0.0).then(|| net.twin(i));
                    let links = net.links_of(i).iter().map(|&l| net.code.target(l));
                    for t in links.chain(through) {
                        if t == ESCAPE || t == NONE || !lossless(t as usize) {
                            leaves = true;
                        } else if !seen[t as usize] {
                            seen[t as usize] = true;
                            stack.push(t);
                        }
                    }
                }
                !leaves
            })
            .map(|emitter| (c, emitter as u32))
    })
}

/// Candidate slots around direction `dir` (unit): every slot within `radius` grid steps of
/// `dir`'s slope coordinates in each family whose slope range it is near.
pub(crate) fn candidates(space: &RaySpace, dir: Vec3, radius: i64, out: &mut Vec<u32>) {
    out.clear();
    let s = space.slopes as i64;
    let margin = (radius + 1) as f32 * space.slope_step();
    for f in 0..3u32 {
        let (a, u, v) = super::ray_space::axes(f);
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
                out.push(space.slot(f, ku as u32, kv as u32));
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

#[allow(clippy::too_many_arguments)]
/// A normalised lobe over the linked slots of `row` around `centre`: weight(l) =
/// lobe(direction of l)·w_l; falls back to the nearest slot when the lobe misses every slot.
fn lobe_row(
    space: &RaySpace,
    row: &[u32],
    normal: Vec3,
    centre: Vec3,
    alpha: f32,
    lobe: impl Fn(Vec3) -> f32,
    buf: &mut Vec<u32>,
    out: &mut Vec<(u32, f32)>,
) {
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
fn maps(net: &Network, node: u32, surface: &Surface, twin: u32) -> (SparseMap, SparseMap) {
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
                    let ggx = Ggx {
                        alpha: surface.alpha.max(1e-3),
                    };
                    let ci = n.dot(wi);
                    let lobe = |wo: Vec3| {
                        let co = n.dot(wo);
                        if co <= 0.0 {
                            return 0.0;
                        }
                        let h = (wi + wo).normalize();
                        ggx.d(local(n.dot(h))) * ggx.g(local(co), local(ci)) / (4.0 * ci * co)
                    };
                    lobe_row(
                        space,
                        &row,
                        n,
                        r,
                        surface.alpha,
                        lobe,
                        &mut buf,
                        &mut reflect.entries,
                    );
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
                    lobe_row(
                        space,
                        &trow,
                        -n,
                        through,
                        surface.alpha,
                        lobe,
                        &mut buf,
                        &mut transmit.entries,
                    );
                }
            }
        }
        reflect.offsets.push(reflect.entries.len() as u32);
        transmit.offsets.push(transmit.entries.len() as u32);
    }
    (reflect, transmit)
}

/// A value as it is (the `size` of [`sum3`] for signed sums).
fn same(c: Rgb) -> Rgb {
    c
}

/// Σ size(v_i)·w(i) per channel, in f64.
fn sum3(v: &[Rgb], size: impl Fn(Rgb) -> Rgb, w: impl Fn(usize) -> f32) -> [f64; 3] {
    let mut s = [0.0f64; 3];
    for (i, c) in v.iter().map(|&c| size(c)).enumerate() {
        let k = w(i) as f64;
        for ch in 0..3 {
            s[ch] += c[ch] as f64 * k;
        }
    }
    s
}

/// Carries light over the network until convergence.
pub fn distribute(net: &Network, scene: &Scene, options: &DistributeOptions) -> Solution {
    let start = std::time::Instant::now();
    distribute_surfaces(
        net,
        surfaces(net, scene, options.light_scale),
        options,
        start,
    )
}

/// [`distribute`] for given node surfaces (their emission included).
pub fn distribute_surfaces(
    net: &Network,
    surfaces: Vec<Surface>,
    options: &DistributeOptions,
    start: std::time::Instant,
) -> Solution {
    distribute_from(net, surfaces, options, start, None)
}

/// [`distribute_surfaces`] starting from `guess`, a solution of the same network for other
/// surfaces (incremental radiosity, after Chen 1990): the first sweep gathers the whole guess
/// X₀ (emission included) and passes it through the new reflectances T; what that changes,
/// r = E + T·X₀ − X₀ (negative where a reflectance went down), is then shot like emission
/// until it falls below the tolerance. The result is X₀ + Σ Tᵏ·r, the new solution whatever
/// the guess; the closer the guess, the fewer sweeps. When one material changes, r is
/// mostly that material's light. The sweeps and conjugate gradients start from the guess
/// (CG from its reflected light); the shooting order starts cold.
pub fn distribute_from(
    net: &Network,
    surfaces: Vec<Surface>,
    options: &DistributeOptions,
    start: std::time::Instant,
    guess: Option<&Solution>,
) -> Solution {
    let nodes = net.nodes();
    let slots = net.slots();
    let w: Vec<f32> = (0..slots as u32).map(|s| net.space.etendue(s)).collect();
    // Directional nodes and their maps.
    let mut dir_index = vec![NONE; nodes];
    let mut dir_nodes = Vec::new();
    for (i, s) in surfaces.iter().enumerate() {
        if s.directional() {
            dir_index[i] = dir_nodes.len() as u32;
            dir_nodes.push(i as u32);
        }
    }
    let maps: Vec<(SparseMap, SparseMap)> = dir_nodes
        .par_iter()
        .map(|&n| maps(net, n, &surfaces[n as usize], net.twin(n)))
        .collect();
    let map_entries = maps
        .iter()
        .map(|(r, t)| (r.entries.len() + t.entries.len()) as u64)
        .sum();

    if options.order == Order::Shoot && dir_nodes.is_empty() {
        return shoot(net, surfaces, options, start);
    }
    let guess = guess.filter(|g| {
        let dir = g.dir_index.iter().filter(|&&k| k != NONE).count();
        g.diffuse.len() == nodes && g.dir_index.len() == nodes && g.directional.len() == dir * slots
    });
    if options.order == Order::ConjugateGradients && dir_nodes.is_empty() {
        return conjugate_gradients::solve(net, surfaces, options, start, guess);
    }
    let mut shot_d: Vec<Rgb> = surfaces.iter().map(|s| s.emission).collect();
    let mut shot_dir = vec![Rgb::ZERO; dir_nodes.len() * slots];
    let mut in_buf = vec![Rgb::ZERO; dir_nodes.len() * slots];
    let mut diffuse = vec![Rgb::ZERO; nodes];
    let mut direct = vec![Rgb::ZERO; nodes];
    let mut directional = vec![Rgb::ZERO; dir_nodes.len() * slots];
    let mut incoming = vec![Rgb::ZERO; dir_nodes.len() * slots];
    let mut stats = DistributeStats {
        map_entries,
        ..DistributeStats::default()
    };
    // The flux of what the nodes shoot, or with `size` = `Rgb::abs` its absolute value.
    let flux_by = |shot_d: &[Rgb], shot_dir: &[Rgb], size: fn(Rgb) -> Rgb| {
        let mut f = sum3(shot_d, size, |i| net.etendue[i]);
        // Directional radiance leaves over every link of its slot (a slot with two links
        // carries it twice). Per node in parallel, added up in node order.
        let per_node: Vec<[f64; 3]> = dir_nodes
            .par_iter()
            .enumerate()
            .map(|(k, &n)| {
                let mut f = [0.0; 3];
                for (l, _) in net.slot_links(n) {
                    let r = size(shot_dir[k * slots + l]) * w[l];
                    for c in 0..3 {
                        f[c] += r[c] as f64;
                    }
                }
                f
            })
            .collect();
        for node in per_node {
            for c in 0..3 {
                f[c] += node[c];
            }
        }
        f
    };
    let flux_of = |shot_d: &[Rgb], shot_dir: &[Rgb]| flux_by(shot_d, shot_dir, same);
    stats.emitted = flux_of(&shot_d, &shot_dir);
    let emitted_total: f64 = stats.emitted.iter().sum();
    let mut unshot = stats.emitted;
    // What is still to be shot, in absolute value: a warm start shoots negative light too
    // (a cold one never does, and sums the signed flux it has).
    let unshot_size = |shot_d: &[Rgb], shot_dir: &[Rgb], signed: [f64; 3]| {
        let flux = if guess.is_none() {
            signed
        } else {
            flux_by(shot_d, shot_dir, Rgb::abs)
        };
        flux.iter().sum::<f64>()
    };
    let mut to_shoot = emitted_total;
    let mut guess_flux = [0.0; 3];
    if let Some(g) = guess {
        stats.warm_start = true;
        // X₀: the guess's reflected light on top of the emission, the directional rows of
        // the nodes that were directional then and are now.
        diffuse.copy_from_slice(&g.diffuse);
        for (s, d) in shot_d.iter_mut().zip(&g.diffuse) {
            *s += *d;
        }
        for (k, &n) in dir_nodes.iter().enumerate() {
            let old = g.dir_index[n as usize];
            if old != NONE {
                let from = &g.directional[old as usize * slots..(old as usize + 1) * slots];
                directional[k * slots..(k + 1) * slots].copy_from_slice(from);
            }
        }
        shot_dir.copy_from_slice(&directional);
        direct = direct_light(net, &surfaces, &w);
        // The first sweep passes on X₀'s reflected light too: not absorbed.
        guess_flux = flux_of(&diffuse, &directional);
    }
    let mut in_total = vec![Rgb::ZERO; nodes];
    // What the diffuse nodes shot, as four-lane vectors for the gather (one load and one
    // multiply-add of a register per link; the lanes' arithmetic is Rgb's, so the same bits).
    let mut padded = vec![Vec3A::ZERO; Ends::padded_len(nodes)];
    let w_pow2 = SlotWeights::new(&net.space);
    // Each node's directional row, NONE for diffuse nodes and the escapes' zero past the end.
    let mut row_of = dir_index.clone();
    row_of.resize(padded.len(), NONE);
    let escape_etendue = &net.escape_etendue;
    let mut escaped = vec![Rgb::ZERO; nodes];
    while to_shoot > options.tolerance as f64 * emitted_total && stats.sweeps < options.max_sweeps {
        // Gather: flux arriving over each node's links from what the other ends shot.
        let radiance = |j: u32, l: usize| {
            let mut r = shot_d[j as usize];
            let k = dir_index[j as usize];
            if k != NONE {
                r += shot_dir[k as usize * slots + l];
            }
            r
        };
        // Each node gathers: the diffuse part branchless (an escape reads a zero past the last
        // node), the directional part of directional ends on top (none in an all-diffuse
        // network, whose loop has no test for it).
        for (p, s) in padded.iter_mut().zip(&shot_d) {
            *p = Vec3A::from(*s);
        }
        let all_diffuse = dir_nodes.is_empty();
        let ends = Ends {
            code: net.code,
            padded: &padded,
            w: &w_pow2,
            row_of: &row_of,
            shot_dir: &shot_dir,
            slots,
        };
        in_total
            .par_iter_mut()
            .zip(escaped.par_iter_mut())
            .enumerate()
            .for_each(|(i, (tot, esc))| {
                let links = net.links_of(i as u32);
                *tot = if all_diffuse {
                    ends.gather::<false>(links)
                } else {
                    ends.gather::<true>(links)
                };
                // Light leaving over escapes: the diffuse part over their étendue, and a
                // directional node's own directional radiance on each.
                let mut out = shot_d[i] * escape_etendue[i];
                let k = dir_index[i];
                if k != NONE {
                    let row = &ends.shot_dir[k as usize * slots..(k as usize + 1) * slots];
                    for (l, _) in net.slot_links(i as u32).filter(|&(_, j)| j == ESCAPE) {
                        out += row[l] * w[l];
                    }
                }
                *esc = out;
            });
        in_buf
            .par_chunks_mut(slots)
            .zip(&dir_nodes)
            .for_each(|(buf, &i)| {
                buf.fill(Rgb::ZERO);
                for (l, j) in net.slot_links(i) {
                    if j < ESCAPE {
                        buf[l] += radiance(j, l) * w[l];
                    }
                }
            });
        incoming
            .par_chunks_mut(slots)
            .zip(in_buf.par_chunks(slots))
            .zip(&dir_nodes)
            .for_each(|((acc, flux), &i)| {
                // Links are in slot order: a slot with m links had m times the étendue. Only
                // linked slots receive anything (the others' flux is zero).
                for (l, m) in slot_runs(net, i) {
                    acc[l] += flux[l] / (w[l] * m as f32);
                }
            });
        let arrived = sum3(&in_total, same, |_| 1.0);
        let esc = sum3(&escaped, same, |_| 1.0);
        // Reflect: the diffuse bypass, then the directional maps.
        shot_d
            .par_iter_mut()
            .enumerate()
            .for_each(|(i, s)| *s = surfaces[i].kd * in_total[i] / net.etendue[i]);
        shot_dir
            .par_chunks_mut(slots)
            .enumerate()
            .for_each(|(k, out)| {
                out.fill(Rgb::ZERO);
                let node = dir_nodes[k] as usize;
                let (reflect, _) = &maps[k];
                let own = &in_buf[k * slots..(k + 1) * slots];
                apply(reflect, own, surfaces[node].ks, out);
                let twin = net.twin(node as u32);
                if twin != NONE {
                    let t = dir_index[twin as usize];
                    if t != NONE {
                        let (_, transmit) = &maps[t as usize];
                        let theirs = &in_buf[t as usize * slots..(t as usize + 1) * slots];
                        apply(transmit, theirs, surfaces[twin as usize].kt, out);
                    }
                }
                // Flux to radiance on the slots the maps reach (linked or escaping ones, the
                // others stay zero); a slot with several links spreads its flux over all of them.
                for (l, m) in slot_runs(net, node as u32) {
                    out[l] /= w[l];
                    if m > 1 {
                        out[l] /= m as f32;
                    }
                }
            });
        if guess.is_some() && stats.sweeps == 0 {
            // T·X₀ less X₀'s reflected light: the change r, shot from now on.
            shot_d
                .par_iter_mut()
                .zip(&diffuse)
                .for_each(|(s, d)| *s -= *d);
            shot_dir
                .par_iter_mut()
                .zip(&directional)
                .for_each(|(s, d)| *s -= *d);
        }
        diffuse
            .par_iter_mut()
            .zip(&shot_d)
            .for_each(|(d, s)| *d += *s);
        directional
            .par_iter_mut()
            .zip(&shot_dir)
            .for_each(|(d, s)| *d += *s);
        let next = flux_of(&shot_d, &shot_dir);
        for c in 0..3 {
            stats.escaped[c] += esc[c];
            stats.absorbed[c] += arrived[c] - next[c] - std::mem::take(&mut guess_flux[c]);
        }
        unshot = next;
        to_shoot = unshot_size(&shot_d, &shot_dir, next);
        if stats.sweeps == 0 && guess.is_none() {
            direct.copy_from_slice(&shot_d);
        }
        stats.sweeps += 1;
    }
    stats.unshot = unshot;
    stats.seconds = start.elapsed().as_secs_f64();
    let dir_rows = net.rows_of(dir_nodes.iter().copied());
    Solution {
        surfaces,
        diffuse,
        direct,
        dir_index,
        directional,
        incoming,
        dir_rows,
        stats,
        light_scale: options.light_scale,
    }
}

/// The diffuse light reflected from what comes straight from the emitters (what the first
/// sweep from the emission finds), shot from the emitters alone: a warm start's first sweep
/// gathers more than emission.
fn direct_light(net: &Network, surfaces: &[Surface], w: &[f32]) -> Vec<Rgb> {
    let mut arrived = vec![Rgb::ZERO; net.nodes()];
    for (i, s) in surfaces.iter().enumerate() {
        if s.emission != Rgb::ZERO {
            for (l, j) in net.slot_links(i as u32) {
                if j < ESCAPE {
                    arrived[j as usize] += s.emission * w[l];
                }
            }
        }
    }
    arrived
        .iter()
        .zip(surfaces)
        .zip(&net.etendue)
        .map(|((a, s), &e)| s.kd * *a / e)
        .collect()
}

/// The slots of a node's links with their number of links, in slot order.
fn slot_runs(net: &Network, node: u32) -> impl Iterator<Item = (usize, usize)> + '_ {
    let code = net.code;
    net.links_of(node)
        .chunk_by(move |a, b| code.slot(*a) == code.slot(*b))
        .map(move |r| (code.slot(r[0]), r.len()))
}

/// What a node gathers over its links from what the other ends shot.
struct Ends<'a> {
    code: LinkCode,
    /// The diffuse radiance shot, and zeros past the last node up to a power of two
    /// ([`Ends::padded_len`]), where escapes read.
    padded: &'a [Vec3A],
    w: &'a SlotWeights,
    /// Each end's directional row, or NONE ([`NONE`] past the last node), as long as `padded`.
    row_of: &'a [u32],
    shot_dir: &'a [Rgb],
    slots: usize,
}

impl<'a> Ends<'a> {
    /// The length of `padded` for `nodes` nodes: a power of two past the last node. A link
    /// masked to it gives its node (below the mask, which is below the target bits) or, for
    /// an escape (all target bits set), the last entry, a zero: one `and` per link, no
    /// bounds check and no branch.
    fn padded_len(nodes: usize) -> usize {
        (nodes + 1).next_power_of_two()
    }

    /// The ends of an all-diffuse network (only [`Ends::gather`]`::<false>`), reading `padded`.
    fn diffuse(code: LinkCode, padded: &'a [Vec3A], w: &'a SlotWeights) -> Ends<'a> {
        Ends {
            code,
            padded,
            w,
            row_of: &[],
            shot_dir: &[],
            slots: 0,
        }
    }

    /// Σ over `links` of the radiance shot toward the node × w: the diffuse part and, with
    /// `DIRECTIONAL`, the directional part of directional ends, in four-lane vectors
    /// ([`interleaved_sum`]). Indices are masked into slices of power-of-two lengths (nodes,
    /// [`Ends::padded_len`]; slots, [`SlotWeights`]), so the diffuse part has no bounds check
    /// per link.
    #[inline(always)]
    fn gather<const DIRECTIONAL: bool>(&self, links: &[u32]) -> Rgb {
        let last = self.padded.len() - 1;
        debug_assert!(self.padded.len().is_power_of_two());
        let padded = &self.padded[..=last];
        let row_of = if DIRECTIONAL {
            &self.row_of[..=last]
        } else {
            &[]
        };
        let ((w, mask), code) = (self.w.table(), self.code);
        let end = |l: u32| {
            let (t, slot) = (l as usize & last, code.slot(l) & mask);
            let mut r = padded[t];
            if DIRECTIONAL {
                let k = row_of[t];
                if k != NONE {
                    r += Vec3A::from(self.shot_dir[k as usize * self.slots + slot]);
                }
            }
            r * w[slot]
        };
        interleaved_sum(links, end).into()
    }
}

/// out[l'] += k·c·in[l] over a map's entries.
fn apply(map: &SparseMap, input: &[Rgb], k: Rgb, out: &mut [Rgb]) {
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

impl Solution {
    /// Memory of the buffers (bytes).
    pub fn memory(&self) -> usize {
        std::mem::size_of::<Rgb>()
            * (self.diffuse.len()
                + self.direct.len()
                + self.directional.len()
                + self.incoming.len())
            + 4 * (self.dir_index.len() + self.dir_rows.len())
            + std::mem::size_of::<Surface>() * self.surfaces.len()
    }
}

/// Largest-unshot-first shooting for all-diffuse networks: the node with the most unshot flux
/// sends it over its links; each receiver adds kd·Φ/W to its radiance and to its own unshot
/// radiance. The emitters shoot first, in node order (their receivers' radiance after that is
/// the direct light of the hybrid mode), then the largest first, ties to the lower index.
/// Sequential, so deterministic. `stats.sweeps` counts shots.
fn shoot(
    net: &Network,
    surfaces: Vec<Surface>,
    options: &DistributeOptions,
    start: std::time::Instant,
) -> Solution {
    let nodes = net.nodes();
    let w: Vec<f32> = (0..net.slots() as u32)
        .map(|s| net.space.etendue(s))
        .collect();
    let mut unshot: Vec<Rgb> = surfaces.iter().map(|s| s.emission).collect();
    let mut diffuse = vec![Rgb::ZERO; nodes];
    let mut stats = DistributeStats::default();
    let flux = |u: Rgb, i: usize| (u.x + u.y + u.z) as f64 * net.etendue[i] as f64;
    for (i, u) in unshot.iter().enumerate() {
        for c in 0..3 {
            stats.emitted[c] += u[c] as f64 * net.etendue[i] as f64;
        }
    }
    let emitted_total: f64 = stats.emitted.iter().sum();
    let mut remaining = emitted_total;
    let shoot_one = |i: usize,
                     unshot: &mut Vec<Rgb>,
                     diffuse: &mut Vec<Rgb>,
                     stats: &mut DistributeStats,
                     touched: &mut Vec<u32>| {
        let u = std::mem::replace(&mut unshot[i], Rgb::ZERO);
        for (l, j) in net.slot_links(i as u32) {
            let f = u * w[l];
            if j == ESCAPE {
                for c in 0..3 {
                    stats.escaped[c] += f[c] as f64;
                }
                continue;
            }
            let j = j as usize;
            let kd = surfaces[j].kd;
            let dl = kd * f / net.etendue[j];
            diffuse[j] += dl;
            unshot[j] += dl;
            for c in 0..3 {
                stats.absorbed[c] += (f[c] * (1.0 - kd[c])) as f64;
            }
            touched.push(j as u32);
        }
        stats.sweeps += 1;
    };
    let mut touched = Vec::new();
    let emitters: Vec<usize> = (0..nodes).filter(|&i| unshot[i] != Rgb::ZERO).collect();
    for i in emitters {
        shoot_one(i, &mut unshot, &mut diffuse, &mut stats, &mut touched);
    }
    let direct = diffuse.clone();
    // A tournament tree over the nodes' unshot flux: the root is the largest (ties to the
    // lower index); updating a node costs log N.
    let size = nodes.next_power_of_two().max(1);
    let mut tree = vec![(f64::NEG_INFINITY, u32::MAX); 2 * size];
    let better = |a: (f64, u32), b: (f64, u32)| {
        if a.0 > b.0 || (a.0 == b.0 && a.1 < b.1) {
            a
        } else {
            b
        }
    };
    for i in 0..nodes {
        tree[size + i] = (flux(unshot[i], i), i as u32);
    }
    for k in (1..size).rev() {
        tree[k] = better(tree[2 * k], tree[2 * k + 1]);
    }
    let update = |tree: &mut Vec<(f64, u32)>, i: usize, f: f64| {
        let mut k = size + i;
        tree[k] = (f, i as u32);
        while k > 1 {
            k /= 2;
            tree[k] = better(tree[2 * k], tree[2 * k + 1]);
        }
    };
    let total = |unshot: &[Rgb]| (0..nodes).map(|i| flux(unshot[i], i)).sum::<f64>();
    let mut since_check = 0usize;
    remaining = remaining.min(total(&unshot));
    while remaining > options.tolerance as f64 * emitted_total && tree[1].0 > 0.0 {
        let i = tree[1].1 as usize;
        touched.clear();
        shoot_one(i, &mut unshot, &mut diffuse, &mut stats, &mut touched);
        update(&mut tree, i, 0.0);
        touched.sort_unstable();
        touched.dedup();
        for &j in &touched {
            update(&mut tree, j as usize, flux(unshot[j as usize], j as usize));
        }
        // The exact remaining flux every 256 shots (cheap next to 256 shots).
        since_check += 1;
        if since_check >= 256 {
            remaining = total(&unshot);
            since_check = 0;
        }
    }
    stats.unshot = [0, 1, 2].map(|c| {
        (0..nodes)
            .map(|i| unshot[i][c] as f64 * net.etendue[i] as f64)
            .sum()
    });
    stats.seconds = start.elapsed().as_secs_f64();
    Solution {
        dir_index: vec![NONE; nodes],
        surfaces,
        diffuse,
        direct,
        directional: Vec::new(),
        incoming: Vec::new(),
        dir_rows: Vec::new(),
        stats,
        light_scale: options.light_scale,
    }
}
