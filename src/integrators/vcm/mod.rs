//! Vertex connection and merging (Georgiev, Křivánek, Davidovič & Slusallek 2012): every
//! technique of bidirectional path tracing (emission hit, next-event estimation,
//! connections between a camera and a light subpath, light subpaths connected to the
//! camera) and of photon mapping (a camera vertex merged with the light vertices within a
//! radius) combined by one multiple importance sampling scheme, so that caustics seen
//! directly or through glass converge as photon mapping makes them, and everything else as
//! bidirectional tracing does.
//!
//! Each sample index is an iteration: light subpaths (one per pixel, one in 32 pixels in a
//! scene without smooth surfaces or media, or the `photons_per_iteration` setting),
//! traced first over the whole image (`light_pass`), a hash grid over their vertices, then
//! one camera subpath per pixel (`camera_path`). The merge radius shrinks from iteration
//! to iteration, r_i = r₀ · i^((α−1)/2) with α = 3/4, so the merges' bias vanishes as the
//! iterations go on while their variance stays bounded. The weights are SmallVCM's
//! recursive ones with the balance heuristic (`mis`). Up to four iterations whose light
//! vertices take little are prepared together, and their camera samples run as one stream
//! of tiles (the threads do not wait for each other at every iteration's end; the passes
//! and pixels are the same).
//!
//! In a scene with participating media (`media`) the subpaths fly through them as the
//! bidirectional tracer's do: free flights by delta tracking with a hero channel drawn per
//! subpath, medium boundaries crossed without a vertex, vertices at scattering points in
//! media with the phase function in place of a BSDF, and every connection (to the camera,
//! to a light point, between the subpaths) carrying its transmittance by ratio tracking.
//! The emission of media has one strategy, the camera subpath meeting it (weight 1).
//! Merges happen at surfaces only: a vertex in a medium connects but does not merge, and
//! its merge terms drop out of the weights (UPBP's surface photon mapping).
//!
//! The weights include the distance sampling of every segment a strategy samples: the
//! density of a vertex reached through media carries the segment's transmittance, which
//! the recursive quantities take as they take the squared distance (`d_vcm` is divided by
//! it on arrival, and a connection's reverse densities across its segment are multiplied
//! by it; a medium's σs at a vertex appears in every strategy alike and cancels). That
//! transmittance is *grey*, exp(−τ̄) with τ̄ the majorant's optical depth averaged over the
//! channels: a function of the segment alone, the same for every strategy and every hero,
//! so the weights sum to one over the strategies of any path (exactly the transmittance of
//! a grey homogeneous medium, an approximation of it elsewhere that costs only variance).
//! Weights from the hero's own densities would not do: they depend on the hero, and after
//! the average over the channels no longer sum to one. The channels are weighted by
//! spectral MIS per subpath: each subpath's estimate is divided by the average of its
//! channel density ratios (`r_u`), a connection's with the segment's ratio-tracking ratios
//! folded into the camera subpath's (light subpaths and camera subpaths draw their heroes
//! independently, so the two averages stay separate).
//!
//! The render loop takes one sample a pass (`MonteCarlo::iterative`), so an image is
//! progressive, resumable and the same bits for any thread count, as the other Monte Carlo
//! techniques'.

mod camera_path;
mod light_pass;
mod lights;
mod media;
mod mis;

use crate::error::{Error, Result};
use crate::integrators::light::refuse_orthographic;
use crate::integrators::sppm::HashGrid;
use crate::integrators::sppm::{check_photon_settings, default_radius, SPPM};
use crate::math::sobol::Sampler;
use crate::math::{Ray, Rgb};
use crate::scene::camera::CameraBasis;
use crate::scene::Scene;
use crate::settings::{Settings, TechniqueKind};
use crate::transport::settings::{MonteCarloSettings, TechniqueInfo, COMMON, MONTE_CARLO};
use crate::transport::technique::{Lifecycle, SampledTechnique};
use crate::transport::{
    Context, IterationSamples, IterationStart, IterationWork, MonteCarlo, RayStats, Splat,
};
use camera_path::Iteration;
use light_pass::LightPass;
use mis::Weights;

/// Vertex connection and merging, as the technique list shows it.
pub(crate) const TECHNIQUE: TechniqueInfo = TechniqueInfo {
    kind: TechniqueKind::Vcm,
    summary: "Vertex connection and merging: bidirectional path tracing and photon mapping \
              combined by multiple importance sampling (caustics seen through glass).",
    settings: &[COMMON, MONTE_CARLO, SPPM],
    pbrt: &[],
    progressive: true,
    renders_parts: false,
    follows_time: false,
    media: true,
};

/// The radius exponent α: each iteration's merge radius is r₀ · i^((α−1)/2).
const ALPHA: f32 = 0.75;

/// The kept vertices of a light subpath the memory estimate assumes (on a diffuse box
/// with eight bounces they average about three).
const VERTICES_PER_PATH: u64 = 3;

/// Bytes a light vertex takes while an iteration holds it: the vertex, its ball and its
/// entries in the hash grid (up to eight cells), and its splat to the camera.
const BYTES_PER_VERTEX: u64 = (std::mem::size_of::<light_pass::LightVertex>()
    + std::mem::size_of::<(crate::math::Vec3, f32)>() * 2
    + 8 * std::mem::size_of::<(u64, u32)>()
    + std::mem::size_of::<Splat>()) as u64;

/// Light subpaths a pixel by default in a scene without smooth surfaces or media: one in
/// 32 pixels.
const DIFFUSE_PATHS_PER_PIXEL: f32 = 1.0 / 32.0;

/// The share of the image's mean luminance below which a connection's expected
/// contribution plays Russian roulette instead of always tracing its shadow ray: on the
/// Cornell box it leaves about a third of the rays untraced for 5% more squared error
/// (a sixteenth did as well at equal time, a quarter worse).
const CONNECTION_SHARE: f32 = 1.0 / 8.0;

/// The most iterations whose light subpaths are held at once (their camera samples run as
/// one stream of tiles).
const MOST_TOGETHER: u32 = 4;

/// The bytes of light vertices below which iterations are held together: small beside any
/// budget a render is given, since the memory budget counts them all.
const TOGETHER_BYTES: u64 = 16 << 20;

/// GGX roughness below which a specular or transmitting surface counts as smooth: light
/// it reflects or refracts onto a diffuse surface forms caustics that only merges find.
const SMOOTH_ROUGHNESS: f32 = 0.3;

/// Light subpaths a pixel when the setting is left out: one where the scene has a smooth
/// surface (a mirror, glass, water, polished metal: caustics, which the merges find and
/// which need many light vertices) or participating media; one in 32 pixels elsewhere.
/// There the light subpaths serve connections and light tracing alone, every camera
/// vertex still connects to a whole light subpath, and tracing one per pixel costs more
/// than it gives (on the Cornell box one in 16 reaches a given error in about a third of
/// the time, and one in 32 in 7% less than one in 16).
fn default_paths_per_pixel(scene: &Scene) -> f32 {
    if caustics_possible(scene) {
        1.0
    } else {
        DIFFUSE_PATHS_PER_PIXEL
    }
}

/// Whether some path of `scene` may escape connections: a smooth surface (specular or
/// transmitting below [`SMOOTH_ROUGHNESS`], or thin) or participating media. Elsewhere
/// every path has two neighbouring vertices a connection joins, merges add work and no
/// light, and VCM leaves them out unless a merge radius is given.
fn caustics_possible(scene: &Scene) -> bool {
    let smooth = scene
        .materials
        .iter()
        .filter(|m| !m.is_interface())
        .any(|m| {
            let c = m.approximation();
            let reflects = c.specular.max_element() > 0.0 || c.specular_map.is_some();
            let transmits = c.transmission.max_element() > 0.0;
            (reflects || transmits) && (c.thin || c.roughness < SMOOTH_ROUGHNESS)
        });
    smooth || !scene.media.is_empty()
}

/// VCM's settings besides the Monte Carlo ones, checked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VcmSettings {
    /// Initial merge radius; `None`: 1/200 of the scene's bounding-box diagonal.
    pub radius: Option<f32>,
    /// Light subpaths an iteration; `None`: the image's pixel count.
    pub light_paths: Option<u32>,
}

impl VcmSettings {
    /// From the parameter set (the `sppm_radius` and `photons_per_iteration` settings),
    /// checked.
    pub(crate) fn from_settings(s: &Settings) -> Result<VcmSettings> {
        check_photon_settings(s)?;
        Ok(VcmSettings {
            radius: s.sppm_radius,
            light_paths: s.photons_per_iteration,
        })
    }

    /// What of them changes pixels, for a job's settings key.
    pub(crate) fn key(&self) -> String {
        let opt = |v: Option<String>| v.unwrap_or_else(|| "default".into());
        format!(
            " sppm_radius={} photons_per_iteration={}",
            opt(self.radius.map(|r| r.to_string())),
            opt(self.light_paths.map(|p| p.to_string()))
        )
    }
}

/// The technique for `scene`.
pub(crate) fn lifecycle(
    mc: &MonteCarloSettings,
    vcm: &VcmSettings,
    scene: &Scene,
) -> Result<Box<dyn Lifecycle>> {
    refuse_orthographic(scene, "vcm")?;
    if mc.guiding {
        return Err(Error::setting(
            "guiding",
            "applies to the path tracer, not the vcm integrator",
        ));
    }
    if mc.adaptive.is_some() {
        return Err(Error::setting(
            "adaptive",
            "does not apply to the vcm integrator (each sample is an iteration over the \
             whole image)",
        ));
    }
    Ok(Box::new(SampledTechnique {
        integrator: Vcm {
            max_depth: mc.max_depth,
            radius: vcm.radius.unwrap_or_else(|| default_radius(scene)),
            light_paths: vcm.light_paths,
            default_paths_per_pixel: default_paths_per_pixel(scene),
            merges: vcm.radius.is_some() || caustics_possible(scene),
        },
        settings: *mc,
    }))
}

/// Vertex connection and merging.
pub struct Vcm {
    max_depth: u32,
    /// The first iteration's merge radius.
    radius: f32,
    /// Light subpaths an iteration (`None`: `default_paths_per_pixel` of the pixels).
    light_paths: Option<u32>,
    /// Light subpaths a pixel when `light_paths` is not set.
    default_paths_per_pixel: f32,
    /// Whether camera vertices merge with light vertices ([`caustics_possible`], or a
    /// radius given).
    merges: bool,
}

impl Vcm {
    /// Light subpaths an iteration for an image of `pixels`.
    fn light_paths_for(&self, pixels: u64) -> u64 {
        match self.light_paths {
            Some(n) => u64::from(n),
            None => ((pixels as f64 * self.default_paths_per_pixel as f64).ceil() as u64).max(1),
        }
    }

    /// The merge radius of iteration `index` (from 0).
    fn radius_at(&self, index: u32) -> f32 {
        let i = index as f32 + 1.0;
        (self.radius * i.powf(0.5 * (ALPHA - 1.0))).max(1e-7)
    }
}

impl MonteCarlo for Vcm {
    /// Never called: every sample is taken through [`iteration`](Self::iteration).
    fn sample(
        &self,
        _ctx: &Context,
        _camera: &CameraBasis,
        _ray: &Ray,
        _sampler: &mut Sampler,
        _stats: &mut RayStats,
        _splats: &mut Vec<Splat>,
    ) -> Rgb {
        Rgb::ZERO
    }

    fn iterative(&self) -> bool {
        true
    }

    /// Iterations whose light vertices together stay within [`TOGETHER_BYTES`], up to
    /// [`MOST_TOGETHER`]: a small image's iterations are too short for the threads to end
    /// each at once.
    fn iterations_together(&self, size: (u32, u32)) -> u32 {
        let one = self.iteration_bytes(size).max(1);
        (TOGETHER_BYTES / one).clamp(1, u64::from(MOST_TOGETHER)) as u32
    }

    /// The light vertices of the iterations held at once, with their grids and splats:
    /// estimated at [`VERTICES_PER_PATH`] a light subpath (fewer where the paths are
    /// shorter).
    fn iteration_memory(&self, size: (u32, u32)) -> Option<(String, u64)> {
        let count = self.light_paths_for(size.0 as u64 * size.1 as u64);
        let together = self.iterations_together(size);
        let what = match together {
            1 => format!("VCM's light vertices ({count} light subpaths an iteration)"),
            n => format!(
                "VCM's light vertices ({count} light subpaths an iteration, {n} iterations \
                 at once)"
            ),
        };
        Some((
            what,
            self.iteration_bytes(size)
                .saturating_mul(u64::from(together)),
        ))
    }

    fn iterations(
        &self,
        ctx: &Context,
        start: &IterationStart,
        count: u32,
        samples: &mut IterationSamples,
    ) -> bool {
        let mut iterations = Vec::with_capacity(count as usize);
        let mut works = Vec::with_capacity(count as usize);
        for index in start.index..start.index + count {
            let start = IterationStart { index, ..*start };
            let Some((iteration, work)) = self.iteration(ctx, &start) else {
                return false;
            };
            iterations.push(iteration);
            works.push(work);
        }
        let its: Vec<&dyn MonteCarlo> = iterations.iter().map(|i| i as &dyn MonteCarlo).collect();
        samples(&its, works);
        true
    }
}

impl Vcm {
    /// The bytes one iteration's light vertices take (estimated).
    fn iteration_bytes(&self, (width, height): (u32, u32)) -> u64 {
        let count = self.light_paths_for(width as u64 * height as u64);
        let per_path = (self.max_depth as u64).clamp(1, VERTICES_PER_PATH);
        count
            .saturating_mul(per_path)
            .saturating_mul(BYTES_PER_VERTEX)
            .saturating_add(count.saturating_mul(4))
    }

    /// The light subpaths of iteration `start.index`, the grid over their vertices, and what
    /// the subpaths splat; `None` if cancelled.
    fn iteration<'a>(
        &self,
        ctx: &Context<'a>,
        start: &IterationStart,
    ) -> Option<(Iteration<'a>, IterationWork)> {
        let pixels = start.size.0 as usize * start.size.1 as usize;
        let count = self.light_paths_for(pixels as u64) as usize;
        let radius = self.radius_at(start.index);
        let weights = Weights::new(radius, count as f32, self.merges);
        // Full paths have at most max_depth bounces: max_depth + 1 segments.
        let max_len = self.max_depth + 1;
        let pass = LightPass {
            weights: &weights,
            max_len,
            count,
            pixels_per_path: pixels as f32 / count as f32,
        };
        let (paths, work) = pass.run(ctx, start, start.threads)?;
        let balls: Vec<_> = match self.merges {
            true => paths.vertices.iter().map(|v| (v.at.p, radius)).collect(),
            false => Vec::new(),
        };
        let grid = HashGrid::build(&balls);
        drop(balls);
        let connection_threshold = paths.image_mean * CONNECTION_SHARE;
        let iteration = Iteration {
            connection_threshold,
            paths,
            grid,
            weights,
            max_len,
            paths_per_pixel: count as f32 / pixels as f32,
            merges: self.merges,
        };
        Some((iteration, work))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn scene(path: &str) -> Scene {
        Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join(path)).unwrap()
    }

    /// Merges are left out where every surface is diffuse or rough and there are no media;
    /// a mirror, glass, water or a medium brings them back.
    #[test]
    fn merges_only_where_a_path_may_escape_connections() {
        assert!(!caustics_possible(&scene("scenes/cornell-box.toml")));
        assert!(caustics_possible(&scene("scenes/cornell-spheres.toml")));
        assert!(caustics_possible(&scene("scenes/pool-caustics.toml")));
        assert!(caustics_possible(&scene("tests/scenes/media-box.toml")));
    }

    /// Without merges the weights are bidirectional tracing's: no merge term anywhere.
    #[test]
    fn without_merges_no_weight_goes_to_them() {
        let (with, without) = (
            Weights::new(0.1, 576.0, true),
            Weights::new(0.1, 576.0, false),
        );
        assert!(with.vm > 0.0 && without.vm == 0.0);
        assert_eq!(with.vc, without.vc);
    }
}
