//! Reflectance series: the nodes' radiance as a power series in one diffuse material's
//! colour.
//!
//! A new colour for one diffuse material m is not linear, but it is a power series (after
//! Ben-Artzi et al. 2008, who expand an image in the coefficients of edited BRDFs). Per
//! channel, with m's nodes at a constant kd = ρ, R' the other nodes' reflectances, P the
//! projector on m's nodes and A = W⁻¹K the links' transport, the total radiance
//! y = E + (R' + ρP) A y is
//!
//! ```text
//! y(ρ) = Σ_n ρⁿ Tₙ,   T₀ = M E,   Tₙ₊₁ = M P A Tₙ,   M = (I − R'A)⁻¹:
//! ```
//!
//! T₀ is the network lit with m black; Tₙ₊₁ is what m's nodes send on after one more
//! reflection at unit albedo (P A Tₙ, the radiance arriving at them) and everything that
//! light does before it comes back to m. Each term is one distribution with m black. The
//! terms fall by the fraction of m's light that returns to m (0.36–0.38 for the office's
//! carpet), so a dozen reach the tolerance even at ρ = 1, and any ρ ≤ 1 is then a weighted
//! sum: no distribution, and (stored with the light basis, before the links) no link table.
//! The direct light (for the hybrid rendering) is affine in ρ: T₀'s plus ρ·P A E.

use super::basis::{lit_surfaces, reflectance_hash, LightBasis};
use crate::integrators::illumination_network::distribute::{
    self, DistributeOptions, DistributeStats, Solution, Surface,
};
use crate::integrators::illumination_network::{Network, ESCAPE};
use crate::math::Rgb;
use crate::scene::Scene;
use rayon::prelude::*;
use std::time::Instant;

/// Terms a reflectance series stops at if they have not fallen below the tolerance.
pub const MAX_SERIES_TERMS: usize = 40;

/// One diffuse material's reflectance series (module docs): the terms Tₙ of the nodes'
/// radiance in powers of its kd, for the lights of the basis at their stored emission.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReflectanceSeries {
    /// Index into the scene's materials, and its name (checked on use).
    pub material: u32,
    pub name: String,
    /// [`reflectance_hash`] of the surfaces with this material's nodes blanked: the rest of
    /// the scene the series holds for.
    pub others: u64,
    /// Gathers over the links that computing the series took.
    pub sweeps: u32,
    pub terms: Vec<SeriesTerm>,
}

/// One term of a [`ReflectanceSeries`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SeriesTerm {
    /// Each node's reflected radiance (on the material's nodes: what they send on, at unit
    /// albedo, of the previous term), and the direct part (terms 0 and 1 only, else empty).
    pub diffuse: Vec<Rgb>,
    pub direct: Vec<Rgb>,
    /// Flux per channel: the term's total radiance times W over the nodes, and what its
    /// distribution let escape.
    pub flux: [f64; 3],
    pub escaped: [f64; 3],
}

/// The scene material of each node.
fn node_materials(net: &Network, scene: &Scene) -> Vec<usize> {
    (0..net.nodes() as u32)
        .map(|node| net.node_material(node, scene).0)
        .collect()
}

/// `surfaces` with material `m`'s nodes black (kd, ks, kt, α zero; emission kept).
fn blanked(surfaces: &[Surface], materials: &[usize], m: usize) -> Vec<Surface> {
    surfaces
        .iter()
        .zip(materials)
        .map(|(s, &mi)| {
            if mi == m {
                Surface {
                    emission: s.emission,
                    ..Surface::default()
                }
            } else {
                s.clone()
            }
        })
        .collect()
}

/// P A y: on material `m`'s nodes the radiance arriving over their links (Σ w·y at the other
/// end, over W), elsewhere zero.
fn arriving(net: &Network, materials: &[usize], m: usize, y: &[Rgb]) -> Vec<Rgb> {
    (0..net.nodes())
        .into_par_iter()
        .map(|i| {
            if materials[i] != m {
                return Rgb::ZERO;
            }
            let mut sum = Rgb::ZERO;
            for (slot, t) in net.slot_links(i as u32) {
                if t != ESCAPE {
                    sum += y[t as usize] * net.space.etendue(slot as u32);
                }
            }
            sum / net.etendue[i]
        })
        .collect()
}

/// Flux per channel: Σ radiance × W over the nodes.
fn flux(net: &Network, y: &[Rgb]) -> [f64; 3] {
    let mut f = [0.0; 3];
    for (v, w) in y.iter().zip(&net.etendue) {
        for (c, fc) in f.iter_mut().enumerate() {
            *fc += v[c] as f64 * *w as f64;
        }
    }
    f
}

/// The series' rest is held to this fraction of the tolerance (of the emitted flux).
pub const SERIES_REST: f64 = 0.1;

impl ReflectanceSeries {
    /// The series of material `m` for the nodes' other reflectances and `emission` (indexed
    /// as the scene's materials): terms until the rest of the series at kd = 1 is below
    /// [`SERIES_REST`] of the tolerance (or [`MAX_SERIES_TERMS`]). Networks with directional
    /// nodes are refused (the light arriving at m is then not the nodes' radiance).
    pub fn compute(
        net: &Network,
        scene: &Scene,
        emission: &[Rgb],
        (options, run): (&DistributeOptions, distribute::Run),
        m: usize,
    ) -> Result<ReflectanceSeries, String> {
        let name = &scene.materials[m].name;
        let materials = node_materials(net, scene);
        if !materials.contains(&m) {
            return Err(format!("material '{name}' is on no node of the network"));
        }
        let lit = distribute::surfaces_with(net, scene, emission);
        let blank = blanked(&lit, &materials, m);
        if let Some(i) = blank.iter().position(Surface::directional) {
            return Err(format!(
                "a reflectance series needs a network of diffuse surfaces, and material '{}' \
                 reflects or transmits specularly",
                scene.materials[materials[i]].name
            ));
        }
        let emitted_light: Vec<Rgb> = lit.iter().map(|s| s.emission).collect();
        let emitted = flux(net, &emitted_light);
        let mut series = ReflectanceSeries {
            material: m as u32,
            name: name.clone(),
            others: reflectance_hash(net, scene, &blank),
            ..ReflectanceSeries::default()
        };
        // T₀: the network with m black; y is each term's total radiance.
        let sol = distribute::distribute_surfaces(net, blank.clone(), options, run);
        let mut y: Vec<Rgb> = (emitted_light.iter().zip(&sol.diffuse))
            .map(|(e, d)| *e + *d)
            .collect();
        series.sweeps += sol.stats.sweeps;
        series.terms.push(SeriesTerm {
            flux: flux(net, &y),
            escaped: sol.stats.escaped,
            diffuse: sol.diffuse,
            direct: sol.direct,
        });
        let limit = SERIES_REST * options.tolerance as f64;
        let cancelled = || run.cancel.is_some_and(|c| c.is_cancelled());
        while series.terms.len() < MAX_SERIES_TERMS
            && !cancelled()
            && !series
                .rest(Rgb::ONE)
                .is_some_and(|rest| (0..3).all(|c| rest[c] <= limit * emitted[c]))
        {
            let sent = arriving(net, &materials, m, &y);
            series.sweeps += 1;
            let surfaces = (blank.iter().zip(&sent))
                .map(|(s, e)| Surface {
                    emission: *e,
                    ..s.clone()
                })
                .collect();
            let sol = distribute::distribute_surfaces(net, surfaces, options, run);
            series.sweeps += sol.stats.sweeps;
            y = sent
                .iter()
                .zip(&sol.diffuse)
                .map(|(e, d)| *e + *d)
                .collect();
            // The direct light is affine in kd: T₁'s is P A E.
            let direct = if series.terms.len() == 1 {
                arriving(net, &materials, m, &emitted_light)
            } else {
                Vec::new()
            };
            series.terms.push(SeriesTerm {
                flux: flux(net, &y),
                escaped: sol.stats.escaped,
                diffuse: y.clone(),
                direct,
            });
        }
        Ok(series)
    }

    /// The rest of the series after its last term for kd = `rho`, per channel (flux): the
    /// terms taken to fall on geometrically at 1.25 times the ratio of the last two (the
    /// ratio still grows slowly toward its limit); `None` where that times ρ reaches 1.
    fn rest(&self, rho: Rgb) -> Option<[f64; 3]> {
        let n = self.terms.len();
        let last = &self.terms[n - 1].flux;
        let mut rest = [0.0; 3];
        for c in 0..3 {
            if last[c] <= 0.0 {
                continue;
            }
            let q = if n >= 2 && self.terms[n - 2].flux[c] > 0.0 {
                1.25 * last[c] / self.terms[n - 2].flux[c]
            } else {
                1.0
            };
            let r = rho[c] as f64 * q;
            if r >= 1.0 {
                return None;
            }
            rest[c] = last[c] * (rho[c] as f64).powi(n as i32) * q / (1.0 - r);
        }
        Some(rest)
    }
}

impl LightBasis {
    /// The solution for the scene as it is now from a stored reflectance series: when the
    /// only change of reflectance since the basis is one series' material, now of constant,
    /// purely diffuse colour, and every light is at its stored emission times one common
    /// factor. No distribution and no link table; an error says why the series do not apply.
    /// Also gives the series used.
    pub fn relit_from_series(
        &self,
        net: &Network,
        scene: &Scene,
        emission: &[Rgb],
        options: &DistributeOptions,
    ) -> Result<(Solution, &ReflectanceSeries), String> {
        let start = Instant::now();
        self.check_options(options)?;
        let surfaces = lit_surfaces(net, scene, emission, options);
        let materials = node_materials(net, scene);
        let series = self
            .series
            .iter()
            .filter(|s| {
                scene
                    .materials
                    .get(s.material as usize)
                    .is_some_and(|m| m.name == s.name)
            })
            .find(|s| {
                let blank = blanked(&surfaces, &materials, s.material as usize);
                reflectance_hash(net, scene, &blank) == s.others
            })
            .ok_or("no stored reflectance series covers this change of reflectances")?;
        let m = series.material as usize;
        let at_m: Vec<&Surface> = (surfaces.iter().zip(&materials))
            .filter(|(_, &mi)| mi == m)
            .map(|(s, _)| s)
            .collect();
        let Some(first) = at_m.first() else {
            return Err(format!(
                "material '{}' is on no node of the network",
                series.name
            ));
        };
        let rho = first.kd;
        if at_m.iter().any(|s| s.kd != rho || s.directional()) {
            return Err(format!(
                "material '{}' is no longer of one diffuse colour, which its reflectance \
                 series needs",
                series.name
            ));
        }
        // One factor for every light (the series holds the basis's lights together).
        let mut scale = None;
        for light in &self.lights {
            let (w, lacks) = light.weight(emission, options.light_scale);
            for c in (0..3).filter(|&c| light.emission[c] > 0.0) {
                if lacks || scale.is_some_and(|k| k != w[c]) {
                    return Err(
                        "light strengths changed unevenly, which a reflectance series \
                                does not cover"
                            .into(),
                    );
                }
                scale = Some(w[c]);
            }
        }
        let scale = scale.unwrap_or(0.0);
        self.check_emitters(net, scene, emission)?;
        let emitted: Vec<[f64; 3]> = self.lights.iter().map(|l| l.balance[0]).collect();
        let emitted = [0, 1, 2].map(|c| emitted.iter().map(|e| e[c]).sum::<f64>());
        let limit = SERIES_REST * options.tolerance as f64;
        let rest = series
            .rest(rho)
            .filter(|rest| (0..3).all(|c| rest[c] <= limit * emitted[c]))
            .ok_or_else(|| {
                format!(
                    "the reflectance series of '{}' does not converge to the tolerance at its \
                     new colour",
                    series.name
                )
            })?;
        let nodes = net.nodes();
        let power = |n: usize| {
            let p = |c: usize| rho[c].powi(n as i32) * scale;
            Rgb::new(p(0), p(1), p(2))
        };
        let mut diffuse = vec![Rgb::ZERO; nodes];
        let mut direct = vec![Rgb::ZERO; nodes];
        let mut stats = DistributeStats::default();
        for (n, term) in series.terms.iter().enumerate() {
            let k = power(n);
            diffuse
                .par_iter_mut()
                .zip(term.diffuse.par_iter())
                .for_each(|(o, v)| *o += k * *v);
            direct
                .par_iter_mut()
                .zip(term.direct.par_iter())
                .for_each(|(o, v)| *o += k * *v);
            for c in 0..3 {
                stats.escaped[c] += term.escaped[c] * k[c] as f64;
            }
        }
        // The balance: emitted = escaped + absorbed + what the series leaves out.
        for c in 0..3 {
            stats.emitted[c] = emitted[c] * scale as f64;
            stats.unshot[c] = rest[c] * scale as f64;
            stats.absorbed[c] = stats.emitted[c] - stats.escaped[c] - stats.unshot[c];
        }
        stats.seconds = start.elapsed().as_secs_f64();
        let solution = Solution {
            surfaces,
            diffuse,
            direct,
            dir_index: self.dir_index.clone(),
            directional: Vec::new(),
            incoming: Vec::new(),
            dir_rows: self.dir_rows.clone(),
            stats,
            light_scale: options.light_scale,
        };
        Ok((solution, series))
    }
}
