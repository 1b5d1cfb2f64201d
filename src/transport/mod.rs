//! The transport layer: what every light-transport technique is written against, below
//! both the techniques (`crate::integrators`) and the render loops that run them
//! (`crate::render`). It holds the sampling context ([`Context`]: the scene, the
//! intersection backend, never named, and the lights), the two per-sample interfaces
//! ([`Integrator`] for one value per pixel sample, [`MonteCarlo`] for progressive passes
//! with splats), the technique lifecycle (`technique`), the view (image size, tiles, the
//! Monte Carlo view), how camera samples are placed in a pixel (`camera_sample`), the pixel
//! sampling of Whitted's integrator and the network, and the one tile driver (`driver`).
//! Nothing here imports a technique or the render loops.

pub(crate) mod camera_sample;
pub(crate) mod driver;
pub(crate) mod light_passes;
pub(crate) mod passes;
mod pixel_sampling;
pub(crate) mod settings;
pub mod spectral;
pub(crate) mod technique;
mod view;

pub use pixel_sampling::{PixelSampling, PIXELS};
pub use view::{tiles, tiles_in, Tile, TILE_SIZE};
pub(crate) use view::{ProgressiveOptions, View};

use crate::accel::Accel;
use crate::math::sobol::Sampler;
use crate::math::{Ray, Rgb, Rng};
use crate::scene::camera::CameraBasis;
use crate::scene::lights::AreaLight;
use crate::scene::lights::{LightSet, SelectionKind};
use crate::scene::{Scene, SurfacePoint};

/// What integrators render with.
pub struct Context<'a> {
    pub scene: &'a Scene,
    accel: &'a dyn Accel,
    pub area_lights: Vec<AreaLight>,
    /// Every emitter, for the Monte Carlo integrators.
    pub lights: LightSet,
    /// Whether some material is a mix (resolved at each hit).
    mixes: bool,
    /// Whether some material has a normal or bump map (applied at each hit).
    details: bool,
}

impl<'a> Context<'a> {
    pub fn new(scene: &'a Scene, accel: &'a dyn Accel) -> Self {
        Context::with_light_selection(scene, accel, SelectionKind::Tree)
    }

    /// As [`Context::new`], next-event estimation choosing its lights by `selection`.
    pub fn with_light_selection(
        scene: &'a Scene,
        accel: &'a dyn Accel,
        selection: SelectionKind,
    ) -> Self {
        let area_lights = AreaLight::collect(scene);
        let lights = LightSet::with_selection(scene, &area_lights, selection);
        Context {
            scene,
            accel,
            area_lights,
            lights,
            mixes: scene.materials.iter().any(|m| m.mix().is_some()),
            details: scene.materials.iter().any(|m| m.normal_detail.is_some()),
        }
    }

    /// The same scene and lights, queried through another backend (for example one that
    /// observes the queries, as the animation renderer's recorder does).
    pub fn with_accel<'b>(&'b self, accel: &'b dyn Accel) -> Context<'b> {
        Context {
            scene: self.scene,
            accel,
            area_lights: self.area_lights.clone(),
            lights: self.lights.clone(),
            mixes: self.mixes,
            details: self.details,
        }
    }

    /// Whether the scene has participating media (techniques that render them take their
    /// volumetric paths then).
    pub fn has_media(&self) -> bool {
        !self.scene.media.is_empty()
    }

    /// The closest surface along the ray.
    pub fn intersect(&self, ray: &Ray, stats: &mut RayStats) -> Option<SurfacePoint> {
        stats.closest += 1;
        let hit = self.accel.intersect(ray)?;
        Some(self.complete(&hit, ray))
    }

    /// The surface point of a hit, with a mixed material resolved to the one chosen there
    /// and the shading normal turned by the material's normal or bump map.
    #[inline]
    fn complete(&self, hit: &crate::accel::Hit, ray: &Ray) -> SurfacePoint {
        let mut sp = hit.surface_point(self.scene, ray);
        if self.mixes {
            sp.material = self
                .scene
                .material_at(sp.material, sp.p, sp.uv, sp.ng, -ray.dir);
        }
        if self.details {
            if let Some(detail) = &self.scene.materials[sp.material].normal_detail {
                let d =
                    self.scene
                        .placed_shape(&sp)
                        .tangents(hit.prim_id as usize, hit.u, hit.v, &sp);
                sp.ns = detail.shading_normal(sp.ns, sp.ng, sp.p, sp.uv, &d);
            }
        }
        sp
    }

    /// The closest surface along ray `depth` of a path: [`intersect`](Self::intersect),
    /// but the camera ray (depth 0) goes through [`Accel::intersect_camera`] (the backend
    /// may know its hit from an earlier frame).
    pub fn intersect_at_depth(
        &self,
        ray: &Ray,
        depth: u32,
        stats: &mut RayStats,
    ) -> Option<SurfacePoint> {
        if depth > 0 {
            return self.intersect(ray, stats);
        }
        stats.closest += 1;
        let hit = self.accel.intersect_camera(ray)?;
        Some(self.complete(&hit, ray))
    }

    /// The closest hit along the ray as the backend reports it (shape and primitive), for
    /// techniques that keep their own tables per primitive.
    pub fn intersect_hit(&self, ray: &Ray, stats: &mut RayStats) -> Option<crate::accel::Hit> {
        stats.closest += 1;
        self.accel.intersect(ray)
    }

    /// Whether anything blocks the ray segment.
    pub fn occluded(&self, ray: &Ray, stats: &mut RayStats) -> bool {
        stats.shadow += 1;
        self.accel.occluded(ray)
    }
}

/// Rays traced, by query kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayStats {
    pub closest: u64,
    pub shadow: u64,
}

impl RayStats {
    pub fn total(&self) -> u64 {
        self.closest + self.shadow
    }

    pub fn add(&mut self, other: &RayStats) {
        self.closest += other.closest;
        self.shadow += other.shadow;
    }
}

/// The value of one image sample: radiance along a camera ray, and what the ray saw first
/// (used by adaptive anti-aliasing to find silhouettes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub radiance: Rgb,
    /// Index of the first shape hit, or `u32::MAX` for the background.
    pub object: u32,
}

/// A technique that computes radiance along camera rays.
pub trait Integrator: Sync {
    /// `rng` is the random stream of this image sample, derived from (seed, sample position).
    fn radiance(&self, ctx: &Context, ray: &Ray, rng: &mut Rng, stats: &mut RayStats) -> Sample;
}

/// A contribution that lands anywhere on the film (from a light path reaching the camera),
/// at raster position (`x`, `y`). `value` is the path's contribution to the measurement of a
/// pixel with a unit-integral filter centred there: the film spreads it with the filter and
/// divides by the number of paths.
#[derive(Clone, Copy, Debug)]
pub struct Splat {
    pub x: f32,
    pub y: f32,
    pub value: Rgb,
}

/// A Monte Carlo technique: one call per pixel sample.
pub trait MonteCarlo: Sync {
    /// The estimate of radiance along `ray` (the pixel's camera ray for this sample), and any
    /// contributions to other pixels pushed onto `splats`. `sampler` gives this sample's
    /// low-discrepancy values.
    fn sample(
        &self,
        ctx: &Context,
        camera: &CameraBasis,
        ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        splats: &mut Vec<Splat>,
    ) -> Rgb;

    /// Whether its samples are guided (path guiding): the render then learns a guide and
    /// calls [`sample_guided`](Self::sample_guided).
    fn guided(&self) -> bool {
        false
    }

    /// [`sample`](Self::sample) sampling directions from `guidance`'s guide too, and
    /// depositing what it finds there when the pass learns.
    #[allow(clippy::too_many_arguments)]
    fn sample_guided(
        &self,
        ctx: &Context,
        camera: &CameraBasis,
        ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        splats: &mut Vec<Splat>,
        _guidance: &mut crate::guiding::Guidance,
    ) -> Rgb {
        self.sample(ctx, camera, ray, sampler, stats, splats)
    }

    /// Whether each sample index first needs work over the whole image (vertex connection
    /// and merging's light subpaths and their photon grid): the render then takes one
    /// sample a pass and renders the passes through [`iterations`](Self::iterations).
    fn iterative(&self) -> bool {
        false
    }

    /// How many iterations' whole-image work may be held at once for an image of `size`:
    /// their camera samples then run as one stream of tiles, with no pause between the
    /// iterations (the passes and their pixels are the same).
    fn iterations_together(&self, _size: (u32, u32)) -> u32 {
        1
    }

    /// What the whole-image work held at once holds for an image of `size` (all of
    /// [`iterations_together`](Self::iterations_together)), and its bytes (estimated), for
    /// the memory budget; `None`: nothing worth counting.
    fn iteration_memory(&self, _size: (u32, u32)) -> Option<(String, u64)> {
        None
    }

    /// Does the whole-image work of sample indices `start.index..start.index + count` and
    /// calls `samples` once with what takes each index's camera samples (integrators sharing
    /// the work, in index order) and what each index's work itself gave the image
    /// ([`IterationWork`]). Returns `false`, without calling it, if cancelled. Called only
    /// when [`iterative`](Self::iterative), with `count` at most
    /// [`iterations_together`](Self::iterations_together).
    fn iterations(
        &self,
        _ctx: &Context,
        _start: &IterationStart,
        _count: u32,
        _samples: &mut IterationSamples,
    ) -> bool {
        false
    }

    /// [`sample`](Self::sample) (the same value, from the same sample values) with the
    /// sample's light passes added to `passes` (zeroed by the caller); `None` for a
    /// technique that has no light passes.
    fn sample_passes(
        &self,
        _ctx: &Context,
        _camera: &CameraBasis,
        _ray: &Ray,
        _sampler: &mut Sampler,
        _stats: &mut RayStats,
        _passes: &mut light_passes::PassSample,
    ) -> Option<Rgb> {
        None
    }
}

/// What takes the camera samples of iterations prepared together: the integrators taking
/// each one's samples, in index order, and what each one's own work gave the image.
pub type IterationSamples<'s> = dyn FnMut(&[&dyn MonteCarlo], Vec<IterationWork>) + 's;

/// What an iteration's whole-image work needs to know.
pub struct IterationStart<'c> {
    pub camera: &'c CameraBasis,
    pub seed: u64,
    /// The image's size.
    pub size: (u32, u32),
    /// The sample index (the iteration; the first, for several together).
    pub index: u32,
    /// The threads the render runs on (`None`: all).
    pub threads: Option<usize>,
    pub cancel: &'c crate::control::CancelToken,
}

/// What an iteration's whole-image work adds to the image besides its camera samples: the
/// light subpaths' splats (in a fixed order) and its rays.
#[derive(Default)]
pub struct IterationWork {
    pub splats: Vec<Splat>,
    pub rays: RayStats,
}
