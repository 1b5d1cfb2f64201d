//! The Jacobi sweeps, started cold or from a guess, and the choice among the orders.

use super::conjugate_gradients;
use super::gather::{direct_light, Ends};
use super::maps::Maps;
use super::shoot::shoot;
use super::{DistributeOptions, DistributeStats, Order, Solution, Surface};
use crate::integrators::illumination_network::{Network, SlotWeights, ESCAPE, NONE};
use crate::math::Rgb;
use glam::Vec3A;
use rayon::prelude::*;

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

/// [`distribute_surfaces`] starting from `guess`, a solution of the same network for other
/// surfaces (incremental radiosity, after Chen 1990): the first sweep gathers the whole guess
/// X₀ (emission included) and passes it through the new reflectances T; what that changes,
/// r = E + T·X₀ − X₀ (negative where a reflectance went down), is then shot like emission
/// until it falls below the tolerance. The result is X₀ + Σ Tᵏ·r, the new solution whatever
/// the guess; the closer the guess, the fewer sweeps. When one material changes, r is
/// mostly that material's light. The sweeps and conjugate gradients start from the guess
/// (CG from its reflected light); the shooting order starts cold.
///
/// [`distribute_surfaces`]: super::distribute_surfaces
pub fn distribute_from(
    net: &Network,
    surfaces: Vec<Surface>,
    options: &DistributeOptions,
    run: super::Run,
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
    let maps = Maps::new(net, &dir_nodes, &surfaces);
    let map_entries = maps.entries();

    if options.order == Order::Shoot && dir_nodes.is_empty() {
        return shoot(net, surfaces, options, run);
    }
    let guess = guess.filter(|g| {
        let dir = g.dir_index.iter().filter(|&&k| k != NONE).count();
        g.diffuse.len() == nodes && g.dir_index.len() == nodes && g.directional.len() == dir * slots
    });
    if options.order == Order::ConjugateGradients && dir_nodes.is_empty() {
        return conjugate_gradients::solve(net, surfaces, options, run, guess);
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
    while to_shoot > options.tolerance as f64 * emitted_total
        && stats.sweeps < options.max_sweeps
        && !run.stopped(to_shoot, emitted_total)
    {
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
                let own = &in_buf[k * slots..(k + 1) * slots];
                maps.reflect(k, own, out);
                let twin = net.twin(node as u32);
                if twin != NONE {
                    let t = dir_index[twin as usize];
                    if t != NONE {
                        let theirs = &in_buf[t as usize * slots..(t as usize + 1) * slots];
                        maps.transmit(t as usize, theirs, out);
                    }
                }
                maps.settle(k, out);
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
    stats.seconds = run.start.elapsed().as_secs_f64();
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

/// The slots of a node's links with their number of links, in slot order.
fn slot_runs(net: &Network, node: u32) -> impl Iterator<Item = (usize, usize)> + '_ {
    let code = net.code;
    net.links_of(node)
        .chunk_by(move |a, b| code.slot(*a) == code.slot(*b))
        .map(move |r| (code.slot(r[0]), r.len()))
}
