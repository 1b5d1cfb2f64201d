//! Vertex connection and merging (Georgiev, Křivánek, Davidovič & Slusallek 2012): every
//! technique of bidirectional path tracing (emission hit, next-event estimation,
//! connections between a camera and a light subpath, light subpaths connected to the
//! camera) and of photon mapping (a camera vertex merged with the light vertices within a
//! radius) combined by one multiple importance sampling scheme, so that caustics seen
//! directly or through glass converge as photon mapping makes them, and everything else as
//! bidirectional tracing does.
//!
//! Each sample index is an iteration: light subpaths (one per pixel, or the
//! `photons_per_iteration` setting), traced first over the whole image (`light_pass`), a hash grid over their vertices, then one camera subpath
//! per pixel (`camera_path`). The merge radius shrinks from iteration to iteration,
//! r_i = r₀ · i^((α−1)/2) with α = 3/4, so the merges' bias vanishes as the iterations go on
//! while their variance stays bounded. The weights are SmallVCM's recursive ones with the
//! balance heuristic (`mis`).
//!
//! The render loop takes one sample a pass (`MonteCarlo::iterative`), so an image is
//! progressive, resumable and the same bits for any thread count, as the other Monte Carlo
//! techniques'.

mod camera_path;
mod light_pass;
mod lights;
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
use crate::transport::{Context, IterationStart, IterationWork, MonteCarlo, RayStats, Splat};
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
    media: false,
};

/// The radius exponent α: each iteration's merge radius is r₀ · i^((α−1)/2).
const ALPHA: f32 = 0.75;

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
        },
        settings: *mc,
    }))
}

/// Vertex connection and merging.
pub struct Vcm {
    max_depth: u32,
    /// The first iteration's merge radius.
    radius: f32,
    /// Light subpaths an iteration (`None`: one per pixel).
    light_paths: Option<u32>,
}

impl Vcm {
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

    fn iteration(
        &self,
        ctx: &Context,
        start: &IterationStart,
        samples: &mut dyn FnMut(&dyn MonteCarlo, IterationWork),
    ) -> bool {
        let pixels = start.size.0 as usize * start.size.1 as usize;
        let count = self.light_paths.map_or(pixels, |n| n as usize);
        let radius = self.radius_at(start.index);
        let weights = Weights::new(radius, count as f32);
        // Full paths have at most max_depth bounces: max_depth + 1 segments.
        let max_len = self.max_depth + 1;
        let pass = LightPass {
            weights: &weights,
            max_len,
            count,
            pixels_per_path: pixels as f32 / count as f32,
        };
        let Some((paths, work)) = pass.run(ctx, start, start.threads) else {
            return false;
        };
        let balls: Vec<_> = paths.vertices.iter().map(|v| (v.at.p, radius)).collect();
        let grid = HashGrid::build(&balls);
        drop(balls);
        let iteration = Iteration {
            paths,
            grid,
            weights,
            max_len,
            paths_per_pixel: count as f32 / pixels as f32,
        };
        samples(&iteration, work);
        true
    }
}
