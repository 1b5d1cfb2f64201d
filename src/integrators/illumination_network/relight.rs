//! Relighting by superposition. Light transport over a network is linear in the emission and
//! the colour channels never mix (every reflectance map multiplies a channel by its own
//! coefficient), so the solution for emissions E'_m of the emissive materials m is
//!
//! ```text
//! solution(E') = Σ_m (E'_m / E_m) ⊙ solution_m,
//! ```
//!
//! per channel, where solution_m is the converged network lit by material m alone at its
//! emission E_m. A *light basis* stores one solution per emissive material (for the nodes'
//! reflectances at the time it was computed, identified by a hash); relighting with other
//! light strengths then runs no distribution at all and does not need the link table (the
//! network file stores the basis before the links, so it is not even read). A change of
//! reflectance invalidates the basis: the distribution runs again.
//!
//! Each basis solution converges to the tolerance relative to its own emitted flux, so the
//! sum converges to the tolerance relative to the total. Scaling every light by a power of
//! two scales the result exactly.
//!
//! **Reflectance series.** A new colour for one diffuse material m is not linear, but it is
//! a power series (after Ben-Artzi et al. 2008, who expand an image in the coefficients of
//! edited BRDFs). Per channel, with m's nodes at a constant kd = ρ, R' the other nodes'
//! reflectances, P the projector on m's nodes and A = W⁻¹K the links' transport, the total
//! radiance y = E + (R' + ρP) A y is
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

use super::distribute::{self, DistributeOptions, DistributeStats, Solution, Surface};
use super::Network;
use crate::binary_file::{fnv1a, Reader};
use crate::math::Rgb;
use crate::scene::Scene;
use rayon::prelude::*;
use std::time::Instant;

/// One emissive material's solution.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BasisLight {
    /// Index into the scene's materials, and the material's name (checked on use).
    pub material: u32,
    pub name: String,
    /// The emission the solution was computed with.
    pub emission: Rgb,
    pub sweeps: u32,
    /// emitted, escaped, absorbed, unshot (flux, per channel).
    pub balance: [[f64; 3]; 4],
    pub diffuse: Vec<Rgb>,
    pub direct: Vec<Rgb>,
    pub directional: Vec<Rgb>,
    pub incoming: Vec<Rgb>,
}

impl BasisLight {
    /// Whether the scene's material at the light's index still has its name.
    fn names_its_material(&self, scene: &Scene) -> bool {
        scene
            .materials
            .get(self.material as usize)
            .is_some_and(|m| m.name == self.name)
    }

    /// The light's weight per channel for its material's `emission` (indexed as the scene's
    /// materials) times `light_scale`, and whether that emits a channel the light lacks (its
    /// weight there is 0).
    fn weight(&self, emission: &[Rgb], light_scale: f32) -> (Rgb, bool) {
        let new = emission[self.material as usize] * light_scale;
        let (mut w, mut lacks) = (Rgb::ZERO, false);
        for c in 0..3 {
            if self.emission[c] > 0.0 {
                w[c] = new[c] / self.emission[c];
            } else {
                lacks |= new[c] != 0.0;
            }
        }
        (w, lacks)
    }
}

/// The nodes' surfaces lit by `emission` (indexed as the scene's materials) times the
/// options' light scale.
fn lit_surfaces(
    net: &Network,
    scene: &Scene,
    emission: &[Rgb],
    options: &DistributeOptions,
) -> Vec<Surface> {
    let lit: Vec<Rgb> = emission.iter().map(|e| *e * options.light_scale).collect();
    distribute::surfaces_with(net, scene, &lit)
}

/// Per-material solutions for one set of reflectances.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightBasis {
    /// [`reflectance_hash`] of the nodes' surfaces the basis was computed for.
    pub reflectance: u64,
    pub tolerance: f32,
    pub max_sweeps: u32,
    /// 0 sweeps, 1 shoot.
    pub order: u32,
    /// Directional node of each node or [`super::NONE`], and their link rows.
    pub dir_index: Vec<u32>,
    pub dir_rows: Vec<u32>,
    pub lights: Vec<BasisLight>,
    /// Seconds taken by the distributions that made the basis.
    pub seconds: f64,
    /// Reflectance series of materials whose colour may change ([`ReflectanceSeries`]).
    pub series: Vec<ReflectanceSeries>,
}

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

fn order_code(o: distribute::Order) -> u32 {
    match o {
        distribute::Order::Sweeps => 0,
        distribute::Order::Shoot => 1,
        distribute::Order::ConjugateGradients => 2,
    }
}

/// A hash of everything a solution depends on besides the emission: each node's material
/// and its (kd, ks, kt, α), and whether it is an emitter's front.
pub fn reflectance_hash(net: &Network, scene: &Scene, surfaces: &[Surface]) -> u64 {
    let mut bytes = Vec::with_capacity(surfaces.len() * 48);
    for (node, s) in surfaces.iter().enumerate() {
        let (material, side) = net.node_material(node as u32, scene);
        bytes.extend_from_slice(&(material as u32).to_le_bytes());
        bytes.extend_from_slice(&side.to_le_bytes());
        for v in [s.kd, s.ks, s.kt] {
            for c in 0..3 {
                bytes.extend_from_slice(&v[c].to_bits().to_le_bytes());
            }
        }
        bytes.extend_from_slice(&s.alpha.to_bits().to_le_bytes());
    }
    fnv1a(&bytes)
}

/// The emissive materials that emit from some node (front sides).
fn emitting_materials(net: &Network, scene: &Scene, emission: &[Rgb]) -> Vec<u32> {
    let mut used = vec![false; scene.materials.len()];
    for node in 0..net.nodes() as u32 {
        let (m, side) = net.node_material(node, scene);
        if side == 0 && emission[m].max_element() > 0.0 {
            used[m] = true;
        }
    }
    (0..used.len() as u32)
        .filter(|&m| used[m as usize])
        .collect()
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
                *s
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
                if t != super::ESCAPE {
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
        options: &DistributeOptions,
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
        let sol = distribute::distribute_surfaces(net, blank.clone(), options, Instant::now());
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
        while series.terms.len() < MAX_SERIES_TERMS
            && !series
                .rest(Rgb::ONE)
                .is_some_and(|rest| (0..3).all(|c| rest[c] <= limit * emitted[c]))
        {
            let sent = arriving(net, &materials, m, &y);
            series.sweeps += 1;
            let surfaces = (blank.iter().zip(&sent))
                .map(|(s, e)| Surface { emission: *e, ..*s })
                .collect();
            let sol = distribute::distribute_surfaces(net, surfaces, options, Instant::now());
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
    /// One distribution per emissive material, each lit by that material alone at
    /// `emission` (indexed as the scene's materials).
    pub fn compute(
        net: &Network,
        scene: &Scene,
        emission: &[Rgb],
        options: &DistributeOptions,
    ) -> LightBasis {
        let start = Instant::now();
        let unlit: Vec<Rgb> = vec![Rgb::ZERO; emission.len()];
        let dark = distribute::surfaces_with(net, scene, &unlit);
        let mut basis = LightBasis {
            reflectance: reflectance_hash(net, scene, &dark),
            tolerance: options.tolerance,
            max_sweeps: options.max_sweeps,
            order: order_code(options.order),
            ..LightBasis::default()
        };
        for m in emitting_materials(net, scene, emission) {
            let mut only = unlit.clone();
            only[m as usize] = emission[m as usize];
            let surfaces = distribute::surfaces_with(net, scene, &only);
            let sol = distribute::distribute_surfaces(net, surfaces, options, Instant::now());
            let st = &sol.stats;
            basis.dir_index = sol.dir_index;
            basis.dir_rows = sol.dir_rows;
            basis.lights.push(BasisLight {
                material: m,
                name: scene.materials[m as usize].name.clone(),
                emission: emission[m as usize],
                sweeps: st.sweeps,
                balance: [st.emitted, st.escaped, st.absorbed, st.unshot],
                diffuse: sol.diffuse,
                direct: sol.direct,
                directional: sol.directional,
                incoming: sol.incoming,
            });
        }
        if basis.lights.is_empty() {
            // Nothing emits: the directional nodes as the distribution would number them.
            let mut k = 0;
            for s in &dark {
                if s.directional() {
                    basis.dir_index.push(k);
                    k += 1;
                } else {
                    basis.dir_index.push(super::NONE);
                }
            }
            let directional = dark.iter().enumerate().filter(|(_, s)| s.directional());
            basis.dir_rows = net.rows_of(directional.map(|(node, _)| node as u32));
        }
        basis.seconds = start.elapsed().as_secs_f64();
        basis
    }

    /// Adds the reflectance series of the material named `name` ([`ReflectanceSeries`]), for
    /// the nodes' reflectances now and the basis's lights at their stored emission (which
    /// must be the scene's reflectances the basis was computed for).
    pub fn add_series(
        &mut self,
        net: &Network,
        scene: &Scene,
        options: &DistributeOptions,
        name: &str,
    ) -> Result<(), String> {
        let m = scene
            .materials
            .iter()
            .position(|m| m.name == name)
            .ok_or_else(|| format!("the scene has no material '{name}'"))?;
        let mut emission = vec![Rgb::ZERO; scene.materials.len()];
        for light in &self.lights {
            emission[light.material as usize] = light.emission;
        }
        let start = Instant::now();
        let series = ReflectanceSeries::compute(net, scene, &emission, options, m)?;
        self.seconds += start.elapsed().as_secs_f64();
        self.series.retain(|s| s.material != m as u32);
        self.series.push(series);
        Ok(())
    }

    /// The solution for the scene as it is now from a stored reflectance series: when the
    /// only change of reflectance since the basis is one series' material, now of constant,
    /// purely diffuse colour, and every light is at its stored emission times one common
    /// factor. No distribution and no link table; an error says why the series do not apply.
    /// Also gives the series used.
    pub fn from_series(
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

    /// Every material that emits now has a solution in the basis.
    fn check_emitters(&self, net: &Network, scene: &Scene, emission: &[Rgb]) -> Result<(), String> {
        for m in emitting_materials(net, scene, emission) {
            if !self.lights.iter().any(|l| l.material == m) {
                return Err(format!(
                    "material {} emits but is not in the stored light basis",
                    scene.materials[m as usize].name
                ));
            }
        }
        Ok(())
    }

    fn check_options(&self, options: &DistributeOptions) -> Result<(), String> {
        if self.tolerance != options.tolerance
            || self.max_sweeps != options.max_sweeps
            || self.order != order_code(options.order)
        {
            return Err(
                "the stored light basis was computed with other distribution options".into(),
            );
        }
        Ok(())
    }

    /// The solution for the scene's materials with emission `emission` (indexed as the
    /// scene's materials) times `light_scale`, or why the basis cannot give it.
    pub fn superpose(
        &self,
        net: &Network,
        scene: &Scene,
        emission: &[Rgb],
        options: &DistributeOptions,
    ) -> Result<Solution, String> {
        let start = Instant::now();
        self.check_options(options)?;
        let unlit: Vec<Rgb> = vec![Rgb::ZERO; emission.len()];
        let dark = distribute::surfaces_with(net, scene, &unlit);
        if reflectance_hash(net, scene, &dark) != self.reflectance {
            return Err("the stored light basis was computed for other reflectances".into());
        }
        // The weight of each basis light, per channel.
        let mut weights = Vec::with_capacity(self.lights.len());
        for light in &self.lights {
            if !light.names_its_material(scene) {
                return Err("the stored light basis names other materials".into());
            }
            let (w, lacks) = light.weight(emission, options.light_scale);
            if lacks {
                return Err(format!(
                    "material {} emits a colour the stored light basis lacks",
                    light.name
                ));
            }
            weights.push(w);
        }
        // Every emitter must be in the basis.
        self.check_emitters(net, scene, emission)?;
        Ok(self.combine(net, scene, emission, options, &weights, start))
    }

    /// A distribution for the scene's reflectances, whatever those of the basis, started
    /// from the basis (`LightBasis::guess`, [`distribute::distribute_from`]); cold if the
    /// basis is for a network of another size. `emission` as in [`LightBasis::superpose`].
    pub fn redistribute(
        &self,
        net: &Network,
        scene: &Scene,
        emission: &[Rgb],
        options: &DistributeOptions,
    ) -> Solution {
        let start = Instant::now();
        match self.guess(net, scene, emission, options) {
            // The guess's surfaces are the scene's, lit by `emission`.
            Some(mut guess) => {
                let surfaces = std::mem::take(&mut guess.surfaces);
                distribute::distribute_from(net, surfaces, options, start, Some(&guess))
            }
            None => {
                let surfaces = lit_surfaces(net, scene, emission, options);
                distribute::distribute_from(net, surfaces, options, start, None)
            }
        }
    }

    /// A starting point for a distribution with other reflectances
    /// ([`distribute::distribute_from`]): the basis superposed for `emission` (indexed as the
    /// scene's materials) times `options.light_scale`, whatever the reflectances, with the
    /// lights matched by material index and name (a light the basis lacks is left out; any
    /// guess gives the right solution, a close one in fewer sweeps). `None` if the basis is
    /// for a network of another size.
    fn guess(
        &self,
        net: &Network,
        scene: &Scene,
        emission: &[Rgb],
        options: &DistributeOptions,
    ) -> Option<Solution> {
        let nodes = net.nodes();
        if self.dir_index.len() != nodes || self.lights.iter().any(|l| l.diffuse.len() != nodes) {
            return None;
        }
        let weights = self
            .lights
            .iter()
            .map(|light| {
                if light.names_its_material(scene) {
                    light.weight(emission, options.light_scale).0
                } else {
                    Rgb::ZERO
                }
            })
            .collect::<Vec<_>>();
        Some(self.combine(net, scene, emission, options, &weights, Instant::now()))
    }

    /// Σ weight ⊙ solution over the basis lights.
    fn combine(
        &self,
        net: &Network,
        scene: &Scene,
        emission: &[Rgb],
        options: &DistributeOptions,
        weights: &[Rgb],
        start: Instant,
    ) -> Solution {
        let sum = |part: fn(&BasisLight) -> &Vec<Rgb>, len: usize| -> Vec<Rgb> {
            let mut out = vec![Rgb::ZERO; len];
            for (light, w) in self.lights.iter().zip(weights) {
                out.par_iter_mut()
                    .zip(part(light).par_iter())
                    .for_each(|(o, v)| *o += *w * *v);
            }
            out
        };
        let nodes = net.nodes();
        let dir_len = self.dir_rows.len();
        let mut stats = DistributeStats::default();
        for (light, w) in self.lights.iter().zip(weights) {
            stats.sweeps = stats.sweeps.max(light.sweeps);
            for (total, part) in [
                &mut stats.emitted,
                &mut stats.escaped,
                &mut stats.absorbed,
                &mut stats.unshot,
            ]
            .into_iter()
            .zip(&light.balance)
            {
                for c in 0..3 {
                    total[c] += part[c] * w[c] as f64;
                }
            }
        }
        let diffuse = sum(|l| &l.diffuse, nodes);
        let direct = sum(|l| &l.direct, nodes);
        let directional = sum(|l| &l.directional, dir_len);
        let incoming = sum(|l| &l.incoming, dir_len);
        // The surfaces as the distribution would have them (rendering reads their ks, kt, α).
        let surfaces = lit_surfaces(net, scene, emission, options);
        stats.seconds = start.elapsed().as_secs_f64();
        Solution {
            surfaces,
            diffuse,
            direct,
            dir_index: self.dir_index.clone(),
            directional,
            incoming,
            dir_rows: self.dir_rows.clone(),
            stats,
            // The emission the renderer shows directly is the scene's (already scaled per
            // light by the caller) times this.
            light_scale: options.light_scale,
        }
    }

    /// Bytes of the serialised basis.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::new();
        let u32s = |b: &mut Vec<u8>, v: &[u32]| {
            for x in v {
                b.extend_from_slice(&x.to_le_bytes());
            }
        };
        let rgbs = |b: &mut Vec<u8>, v: &[Rgb]| {
            for x in v {
                for c in 0..3 {
                    b.extend_from_slice(&x[c].to_le_bytes());
                }
            }
        };
        // A light's or a series' head ([`LightBasis::from_bytes`] reads it back).
        let named = |b: &mut Vec<u8>, material: u32, name: &str, sweeps: u32| {
            u32s(b, &[material, name.len() as u32, sweeps]);
            b.extend_from_slice(name.as_bytes());
        };
        b.extend_from_slice(&self.reflectance.to_le_bytes());
        b.extend_from_slice(&self.tolerance.to_le_bytes());
        b.extend_from_slice(&self.max_sweeps.to_le_bytes());
        b.extend_from_slice(&self.order.to_le_bytes());
        b.extend_from_slice(&self.seconds.to_le_bytes());
        u32s(
            &mut b,
            &[
                self.lights.len() as u32,
                self.dir_index.len() as u32,
                self.dir_rows.len() as u32,
            ],
        );
        u32s(&mut b, &self.dir_index);
        u32s(&mut b, &self.dir_rows);
        for l in &self.lights {
            named(&mut b, l.material, &l.name, l.sweeps);
            rgbs(&mut b, &[l.emission]);
            for v in l.balance.iter().flatten() {
                b.extend_from_slice(&v.to_le_bytes());
            }
            for part in [&l.diffuse, &l.direct, &l.directional, &l.incoming] {
                b.extend_from_slice(&(part.len() as u32).to_le_bytes());
                rgbs(&mut b, part);
            }
        }
        // The reflectance series follow the lights (a basis without them ends here, as
        // files written before them do).
        if !self.series.is_empty() {
            u32s(&mut b, &[self.series.len() as u32]);
        }
        for s in &self.series {
            named(&mut b, s.material, &s.name, s.sweeps);
            b.extend_from_slice(&s.others.to_le_bytes());
            u32s(&mut b, &[s.terms.len() as u32]);
            for t in &s.terms {
                for v in t.flux.iter().chain(&t.escaped) {
                    b.extend_from_slice(&v.to_le_bytes());
                }
                for part in [&t.diffuse, &t.direct] {
                    b.extend_from_slice(&(part.len() as u32).to_le_bytes());
                    rgbs(&mut b, part);
                }
            }
        }
        b
    }

    /// Parses [`LightBasis::to_bytes`] for a network of `nodes` nodes and `slots` slots.
    pub fn from_bytes(bytes: &[u8], nodes: usize, slots: usize) -> Option<LightBasis> {
        let mut r = Reader { rest: bytes };
        let mut basis = LightBasis {
            reflectance: r.u64()?,
            tolerance: r.f32()?,
            max_sweeps: r.u32()?,
            order: r.u32()?,
            seconds: f64::from_le_bytes(r.take::<8>()?),
            ..LightBasis::default()
        };
        let (n_lights, n_index, n_rows) = (r.u32()?, r.u32()? as usize, r.u32()? as usize);
        let u32s = |r: &mut Reader, n: usize| -> Option<Vec<u32>> {
            if r.rest.len() < 4 * n {
                return None;
            }
            let (a, rest) = r.rest.split_at(4 * n);
            r.rest = rest;
            Some(
                a.chunks_exact(4)
                    .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
                    .collect(),
            )
        };
        let rgbs = |r: &mut Reader, n: usize| -> Option<Vec<Rgb>> {
            if r.rest.len() < 12 * n {
                return None;
            }
            let (a, rest) = r.rest.split_at(12 * n);
            r.rest = rest;
            Some(
                a.par_chunks_exact(12)
                    .map(|c| {
                        let f = |i: usize| f32::from_le_bytes(c[i..i + 4].try_into().unwrap());
                        Rgb::new(f(0), f(4), f(8))
                    })
                    .collect(),
            )
        };
        // A light's or a series' head: its material, name and sweeps.
        let named = |r: &mut Reader| -> Option<(u32, String, u32)> {
            let (material, name_len, sweeps) = (r.u32()?, r.u32()? as usize, r.u32()?);
            if r.rest.len() < name_len {
                return None;
            }
            let (name, rest) = r.rest.split_at(name_len);
            r.rest = rest;
            Some((material, String::from_utf8(name.to_vec()).ok()?, sweeps))
        };
        basis.dir_index = u32s(&mut r, n_index)?;
        basis.dir_rows = u32s(&mut r, n_rows)?;
        let dir = basis
            .dir_index
            .iter()
            .filter(|&&k| k != super::NONE)
            .count();
        if n_index != nodes || n_rows != dir * slots {
            return None;
        }
        for _ in 0..n_lights {
            let (material, name, sweeps) = named(&mut r)?;
            let emission = rgbs(&mut r, 1)?[0];
            let mut balance = [[0.0; 3]; 4];
            for v in balance.iter_mut().flatten() {
                *v = f64::from_le_bytes(r.take::<8>()?);
            }
            let mut parts = Vec::new();
            for want in [nodes, nodes, n_rows, n_rows] {
                let n = r.u32()? as usize;
                if n != want {
                    return None;
                }
                parts.push(rgbs(&mut r, n)?);
            }
            let incoming = parts.pop()?;
            let directional = parts.pop()?;
            let direct = parts.pop()?;
            let diffuse = parts.pop()?;
            basis.lights.push(BasisLight {
                material,
                name,
                emission,
                sweeps,
                balance,
                diffuse,
                direct,
                directional,
                incoming,
            });
        }
        let n_series = if r.rest.is_empty() { 0 } else { r.u32()? };
        for _ in 0..n_series {
            let (material, name, sweeps) = named(&mut r)?;
            let others = r.u64()?;
            let n_terms = r.u32()? as usize;
            if n_terms == 0 || n_terms > MAX_SERIES_TERMS {
                return None;
            }
            let mut terms = Vec::with_capacity(n_terms);
            for n in 0..n_terms {
                let mut term = SeriesTerm::default();
                for v in term.flux.iter_mut().chain(&mut term.escaped) {
                    *v = f64::from_le_bytes(r.take::<8>()?);
                }
                // Every term has each node's radiance; terms 0 and 1 the direct light too.
                let direct_len = if n <= 1 { nodes } else { 0 };
                for (part, want) in [(&mut term.diffuse, nodes), (&mut term.direct, direct_len)] {
                    if r.u32()? as usize != want {
                        return None;
                    }
                    *part = rgbs(&mut r, want)?;
                }
                terms.push(term);
            }
            basis.series.push(ReflectanceSeries {
                material,
                name,
                others,
                sweeps,
                terms,
            });
        }
        r.rest.is_empty().then_some(basis)
    }
}
