//! The shooting order: largest unshot flux first, one node at a time.

use super::{DistributeOptions, DistributeStats, Solution, Surface};
use crate::integrators::illumination_network::{Network, ESCAPE, NONE};
use crate::math::Rgb;

/// Largest-unshot-first shooting for all-diffuse networks: the node with the most unshot flux
/// sends it over its links; each receiver adds kd·Φ/W to its radiance and to its own unshot
/// radiance. The emitters shoot first, in node order (their receivers' radiance after that is
/// the direct light of the hybrid mode), then the largest first, ties to the lower index.
/// Sequential, so deterministic. `stats.sweeps` counts shots.
pub(super) fn shoot(
    net: &Network,
    surfaces: Vec<Surface>,
    options: &DistributeOptions,
    run: super::Run,
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
    while remaining > options.tolerance as f64 * emitted_total
        && tree[1].0 > 0.0
        && !run.stopped(remaining, emitted_total)
    {
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
    stats.seconds = run.start.elapsed().as_secs_f64();
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
