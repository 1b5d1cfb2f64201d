//! The light basis: one converged solution per emissive material, and their superposition
//! for new light strengths (the module docs of `relight` give the reasoning).

use super::ReflectanceSeries;
use crate::binary_file::fnv1a;
use crate::integrators::illumination_network::distribute::{
    self, DistributeOptions, DistributeStats, Solution, Surface,
};
use crate::integrators::illumination_network::{Network, NONE};
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
    pub(super) fn weight(&self, emission: &[Rgb], light_scale: f32) -> (Rgb, bool) {
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
pub(super) fn lit_surfaces(
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
    /// Directional node of each node or [`NONE`], and their link rows.
    pub dir_index: Vec<u32>,
    pub dir_rows: Vec<u32>,
    pub lights: Vec<BasisLight>,
    /// Seconds taken by the distributions that made the basis.
    pub seconds: f64,
    /// Reflectance series of materials whose colour may change ([`ReflectanceSeries`]).
    pub series: Vec<ReflectanceSeries>,
}

fn order_code(o: distribute::Order) -> u32 {
    match o {
        distribute::Order::Sweeps => 0,
        distribute::Order::Shoot => 1,
        distribute::Order::ConjugateGradients => 2,
    }
}

/// A hash of everything a solution depends on besides the emission: each node's material
/// and its (kd, ks, kt, α), optics and a mix's other part, and whether it is an emitter's
/// front.
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
        let o = &s.optics;
        let conductor = o.conductor.map_or([0.0; 6], |c| {
            [c.eta.x, c.eta.y, c.eta.z, c.k.x, c.k.y, c.k.z]
        });
        for v in [o.specular.x, o.specular.y, o.specular.z, o.ior]
            .into_iter()
            .chain(conductor)
        {
            bytes.extend_from_slice(&v.to_bits().to_le_bytes());
        }
        bytes.extend([u8::from(o.fresnel), u8::from(o.thin)]);
        if let Some(t) = &o.brdf {
            bytes.extend_from_slice(&t.digest().to_le_bytes());
        }
        if s.kdt != Rgb::ZERO {
            for c in 0..3 {
                bytes.extend_from_slice(&s.kdt[c].to_bits().to_le_bytes());
            }
        }
        if let Some(b) = &s.blend {
            let other = b.other.lobe_key();
            for v in std::iter::once(b.amount.to_bits()).chain(other) {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
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

impl LightBasis {
    /// One distribution per emissive material, each lit by that material alone at
    /// `emission` (indexed as the scene's materials). A cancelled `run` stops it early (the
    /// basis is then incomplete: the caller checks the token).
    pub fn compute(
        net: &Network,
        scene: &Scene,
        emission: &[Rgb],
        options: &DistributeOptions,
        run: distribute::Run,
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
            if run.cancel.is_some_and(|c| c.is_cancelled()) {
                break;
            }
            let mut only = unlit.clone();
            only[m as usize] = emission[m as usize];
            let surfaces = distribute::surfaces_with(net, scene, &only);
            let sol = distribute::distribute_surfaces(net, surfaces, options, run);
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
                    basis.dir_index.push(NONE);
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
        (options, run): (&DistributeOptions, distribute::Run),
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
        let series = ReflectanceSeries::compute(net, scene, &emission, (options, run), m)?;
        self.seconds += start.elapsed().as_secs_f64();
        self.series.retain(|s| s.material != m as u32);
        self.series.push(series);
        Ok(())
    }

    /// Every material that emits now has a solution in the basis.
    pub(super) fn check_emitters(
        &self,
        net: &Network,
        scene: &Scene,
        emission: &[Rgb],
    ) -> Result<(), String> {
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

    pub(super) fn check_options(&self, options: &DistributeOptions) -> Result<(), String> {
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
        run: distribute::Run,
    ) -> Solution {
        match self.guess(net, scene, emission, options) {
            // The guess's surfaces are the scene's, lit by `emission`.
            Some(mut guess) => {
                let surfaces = std::mem::take(&mut guess.surfaces);
                distribute::distribute_from(net, surfaces, options, run, Some(&guess))
            }
            None => {
                let surfaces = lit_surfaces(net, scene, emission, options);
                distribute::distribute_from(net, surfaces, options, run, None)
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
}
