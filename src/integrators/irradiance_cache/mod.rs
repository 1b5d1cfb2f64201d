//! Irradiance caching (Ward, Rubinstein & Clear, "A Ray Tracing Solution for Diffuse
//! Interreflection", 1988).
//!
//! Radiance leaving a surface toward the eye is L = Le + direct + specular + glossy + ρ/π·E,
//! where the direct term combines one light sample and one BSDF sample by multiple importance
//! sampling (emitters reached by any other ray are not counted), specular paths (mirrors,
//! glass) are followed by sampling the BSDF's delta lobes, the glossy term is the GGX lobe's
//! share of that same BSDF sample's ray, weighted f_glossy·cosθ/pdf and shaded without
//! emission one level deeper (one ray per shading point, as a path tracer takes; the pixel's
//! samples average it), and E, the *indirect* irradiance of the diffuse lobe, comes from the
//! cache:
//!
//! - **Primary method** (`primary`): n strata in sin²θ by 2n strata in φ, one jittered ray
//!   each: θ_j = asin(√((j + X)/n)), φ_k = π(k + Y)/n for j < n, k < 2n (eq. 2 with
//!   0-based indices). Uniform sin²θ is the cosine-weighted density cosθ/π, so the estimator
//!   of ∫ L cosθ dω is (π / 2n²) Σ L — exactly eq. 2. L is the radiance leaving the surface
//!   hit, *without* its emission (light sources are handled by direct lighting), computed with
//!   the next bounce level's cache. R is the harmonic mean of the hit distances (rays that
//!   leave the scene count 1/d = 0), clamped to [side/ar, side/2] (side: the scene cube).
//! - **Secondary method** ([`record`], [`octree`]): weighted average over S = {w_i > 1/a,
//!   d_i ≥ 0}; a new primary value when S is empty.
//! - **Bounces** (section 3.4): one octree per level 0..ab; level k uses a·1.4^k and
//!   samples/2^k rays; at level ab, E is the constant `ambient` irradiance.
//!
//! **Determinism.** The cache is filled by an *overture* that traces exactly the camera rays
//! of the final render (same sampler keys and filter offsets), with their specular
//! continuations but without the direct lighting of the first surfaces, and stores every
//! primary value it computes (at all levels). It runs in phases (see `overture_schedule`):
//! coarse to fine over the image, each phase a set of image tiles that run in parallel, each
//! tile looking values up in the cache as it stood before the phase plus the tile's own new
//! values; after the phase the tiles' values are added in tile order. The schedule depends
//! only on the image size and sample count, so the cache is the same for any thread count.
//! The final render then reads the cache only: since the overture looked up every
//! first-level point the render will, first-level lookups find S non-empty; a lookup that
//! still finds S empty (a specular path that took another lobe) computes a primary value for
//! that point and uses it without storing it (counted as `misses`). Primary values draw
//! their random numbers from a stream keyed by (seed, position, level), so every value
//! depends only on the cache contents and the point. A cache loaded from a file is the
//! starting contents of the overture.

pub mod file;
pub mod gradients;
pub mod octree;
pub mod record;
pub(crate) mod technique;

use super::path::sample_direct;
use crate::bsdf::Transport;
use crate::control::{CancelToken, Control};
use crate::error::{Error, Result};
use crate::image::Image;
use crate::math::sobol::Sampler;
use crate::math::spawn::Spot;
use crate::math::warp::power_heuristic;
use crate::math::{Ray, Rgb, Rng, Vec2, Vec3};
use crate::scene::camera::CameraBasis;
use crate::scene::{Scene, SurfacePoint};
use crate::transport::camera_sample::{camera_sample, view_basis, PixelJitter};
use crate::transport::driver::drive;
use crate::transport::ProgressiveOptions;
use crate::transport::{Context, MonteCarlo, RayStats, Splat};
use gradients::{Gradients, HemisphereSample};
use octree::Octree;
use record::{Record, WeightedSum};
use std::f32::consts::{FRAC_1_PI, PI};
use std::sync::atomic::{AtomicU64, Ordering};

/// The paper's suggestion for a is 0.1–0.2.
pub const DEFAULT_ACCURACY: f32 = 0.15;
pub const DEFAULT_SAMPLES: u32 = 512;
pub const DEFAULT_BOUNCES: u32 = 4;
pub const DEFAULT_AR: f32 = 64.0;
/// Irradiance gradients are on unless turned off.
pub const DEFAULT_GRADIENTS: bool = true;
/// Specular bounces followed from one diffuse level.
const MAX_SPECULAR_DEPTH: u32 = 8;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IcOptions {
    /// Diffuse bounces with a value set each (Radiance's -ab).
    pub bounces: u32,
    /// Accuracy a of the first level (Radiance's -aa).
    pub accuracy: f32,
    /// Rays per primary value at the first level, 2n² (Radiance's -ad).
    pub samples: u32,
    /// R is at least the scene cube's side / ar (Radiance's -ar).
    pub ar: f32,
    /// Irradiance used beyond the last level.
    pub ambient: Rgb,
    /// Compute Ward & Heckbert's irradiance gradients and extrapolate values by them.
    pub gradients: bool,
}

impl Default for IcOptions {
    fn default() -> Self {
        IcOptions {
            bounces: DEFAULT_BOUNCES,
            accuracy: DEFAULT_ACCURACY,
            samples: DEFAULT_SAMPLES,
            ar: DEFAULT_AR,
            ambient: Rgb::ZERO,
            gradients: DEFAULT_GRADIENTS,
        }
    }
}

impl IcOptions {
    pub fn validate(&self) -> Result<()> {
        if !(self.accuracy > 0.0 && self.accuracy.is_finite()) {
            return Err(Error::setting(
                "ic_accuracy",
                format!("must be positive, got {}", self.accuracy),
            ));
        }
        if self.samples < 2 {
            return Err(Error::setting(
                "ic_samples",
                format!("must be at least 2, got {}", self.samples),
            ));
        }
        if self.bounces > 32 {
            return Err(Error::setting(
                "ab",
                format!("must be at most 32, got {}", self.bounces),
            ));
        }
        if !(self.ar > 0.0 && self.ar.is_finite()) {
            return Err(Error::setting(
                "ar",
                format!("must be positive, got {}", self.ar),
            ));
        }
        Ok(())
    }

    /// a at a level: 40% more per bounce.
    pub fn accuracy_at(&self, level: u32) -> f32 {
        self.accuracy * 1.4f32.powi(level as i32)
    }

    /// n (strata in θ) at a level: the sample count halves per bounce.
    pub fn strata_at(&self, level: u32) -> u32 {
        let total = (self.samples >> level.min(31)).max(2) as f32;
        ((total / 2.0).sqrt().round() as u32).max(1)
    }
}

/// The cached values: one octree per bounce level.
#[derive(Clone, Debug)]
pub struct Cache {
    pub levels: Vec<Octree>,
}

impl Cache {
    /// An empty cache over the scene's cube.
    pub fn new(scene: &Scene, options: &IcOptions) -> Cache {
        let (center, side) = scene_cube(scene);
        Cache {
            levels: (0..options.bounces)
                .map(|l| Octree::new(center, side, options.accuracy_at(l)))
                .collect(),
        }
    }

    pub fn len(&self) -> usize {
        self.levels.iter().map(|l| l.len()).sum()
    }

    /// An empty cache over the same cube with the same accuracies.
    fn empty_like(&self) -> Cache {
        Cache {
            levels: self
                .levels
                .iter()
                .map(|l| {
                    let (center, side) = l.root();
                    Octree::new(center, side, l.accuracy())
                })
                .collect(),
        }
    }

    /// Adds another cache's values (over the same cube), level by level, in their order.
    fn absorb(&mut self, other: Cache) {
        for (mine, theirs) in self.levels.iter_mut().zip(other.levels) {
            for rec in theirs.records() {
                mine.insert(*rec);
            }
        }
    }
}

/// The side of an overture tile in pixels.
const TILE: u32 = 32;
/// The first wave's pixel spacing.
const COARSEST_STRIDE: u32 = 16;

/// The camera samples (x, y, sample index) of one overture task: the pixels of a rectangle
/// whose coordinates are multiples of `stride`, samples 0..spp of each.
#[derive(Clone, Copy, Debug)]
struct Chunk {
    x: (u32, u32),
    y: (u32, u32),
    stride: u32,
    spp: u32,
}

impl Chunk {
    /// In scanline order, samples innermost.
    fn samples(self) -> impl Iterator<Item = (u32, u32, u32)> {
        let Chunk { x, y, stride, spp } = self;
        let first = move |lo: u32| lo.div_ceil(stride) * stride;
        (first(y.0)..y.1)
            .step_by(stride as usize)
            .flat_map(move |py| {
                (first(x.0)..x.1)
                    .step_by(stride as usize)
                    .flat_map(move |px| (0..spp).map(move |i| (px, py, i)))
            })
    }
}

/// The overture's schedule: a list of phases, each a list of chunks that run in parallel
/// against the cache as it stood before the phase; their new values are added in chunk
/// order after it. The schedule depends only on the image size and sample count, never on
/// the number of threads, so neither does the cache.
///
/// It goes from coarse to fine, as Radiance's rpict overture does: first one chunk over every
/// 16th pixel (one sample each), which computes the values the whole image shares (most of
/// the deeper bounce levels); then every 8th, 4th, 2nd pixel with one sample, then every
/// sample of the final render. Each of these waves splits the image into 32×32 tiles and
/// runs them in four phases, a 2×2 checkerboard, so that tiles running together are never
/// neighbours: two chunks compute a value for the same place only when both see it, which
/// for first-level values happens only across depth discontinuities and mirrors.
fn overture_schedule(width: u32, height: u32, spp: u32) -> Vec<Vec<Chunk>> {
    let mut phases = vec![vec![Chunk {
        x: (0, width),
        y: (0, height),
        stride: COARSEST_STRIDE,
        spp: 1,
    }]];
    let mut stride = COARSEST_STRIDE / 2;
    while stride >= 1 {
        let spp = if stride == 1 { spp } else { 1 };
        for colour in 0..4 {
            let tiles = (0..height.div_ceil(TILE))
                .flat_map(|ty| (0..width.div_ceil(TILE)).map(move |tx| (tx, ty)));
            let phase: Vec<Chunk> = tiles
                .filter(|&(tx, ty)| (tx % 2) + 2 * (ty % 2) == colour)
                .map(|(tx, ty)| Chunk {
                    x: (tx * TILE, ((tx + 1) * TILE).min(width)),
                    y: (ty * TILE, ((ty + 1) * TILE).min(height)),
                    stride,
                    spp,
                })
                .collect();
            if !phase.is_empty() {
                phases.push(phase);
            }
        }
        stride /= 2;
    }
    phases
}

/// The global cube: the scene's bounding box made cubic, enlarged by 1%.
pub fn scene_cube(scene: &Scene) -> (Vec3, f32) {
    match scene.bounds() {
        Some((lo, hi)) => {
            let side = (hi - lo).max_element().max(1e-3) * 1.01;
            (0.5 * (lo + hi), side)
        }
        None => (Vec3::ZERO, 1.0),
    }
}

/// Where values come from during one walk.
enum Store<'a> {
    /// Read-only (the final render): a value computed for an empty S is used, not stored.
    Frozen(&'a Cache),
    /// One overture chunk: looks values up in the shared cache as it stood at the start of
    /// the wave and in the chunk's own new values, and stores what it computes in the latter.
    Overlay {
        base: &'a Cache,
        local: &'a mut Cache,
    },
}

/// One camera sample's walk through the scene and the cache: what its every shading point
/// reads (the scene, the parameters, the values) and updates (counts), passed down as one
/// value.
struct Walk<'a> {
    ctx: &'a Context<'a>,
    params: &'a Params,
    store: Store<'a>,
    /// Primary values computed.
    primaries: u64,
    stats: &'a mut RayStats,
    /// The overture: no direct lighting on camera-level surfaces (only the cache matters).
    overture: bool,
    /// The overture's cancel token: once set, values stop being computed (the overture
    /// then returns nothing, so what a cut-short value holds is never used).
    cancel: Option<&'a CancelToken>,
}

impl Walk<'_> {
    /// The secondary method at `level`, over every value this walk can see.
    fn interpolate(&self, level: usize, p: Vec3, n: Vec3) -> Option<Rgb> {
        match &self.store {
            Store::Frozen(c) => c.levels[level].interpolate(p, n),
            Store::Overlay { base, local } => {
                let mut sum = WeightedSum::default();
                base.levels[level].accumulate(p, n, &mut sum);
                local.levels[level].accumulate(p, n, &mut sum);
                sum.average()
            }
        }
    }
}

/// Memory a cached value takes with its share of the octree (estimated generously).
const BYTES_PER_VALUE: u64 = 96;

/// The options with the scene-derived constants.
#[derive(Clone, Copy, Debug)]
struct Params {
    options: IcOptions,
    seed: u64,
    r_min: f32,
    r_max: f32,
}

/// Counts of one render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IcStats {
    /// Values in the cache before the overture (loaded from a file).
    pub loaded: u64,
    /// Primary values computed and stored by the overture (all levels).
    pub overture_primaries: u64,
    /// Rays the overture traced.
    pub overture_rays: u64,
}

/// The irradiance-caching integrator, with its cache filled.
pub struct IrradianceCache {
    params: Params,
    /// The view the overture traced.
    camera: CameraBasis,
    cache: Cache,
    pub stats: IcStats,
    /// Primary values computed (not stored) by the final render.
    misses: AtomicU64,
}

impl IrradianceCache {
    /// Runs the overture for the render `render` (size, samples, filter, seed) of the
    /// scene's camera, starting from `cache` (loaded from a file) or an empty cache.
    pub(crate) fn build(
        ctx: &Context,
        render: &ProgressiveOptions,
        options: IcOptions,
        cache: Option<Cache>,
        control: &Control,
    ) -> Result<IrradianceCache> {
        let seed = render.view.seed;
        let camera = view_basis(ctx.scene, render);
        let (_, side) = scene_cube(ctx.scene);
        let params = Params {
            options,
            seed,
            r_min: side / options.ar,
            r_max: side * 0.5,
        };
        let mut cache = cache.unwrap_or_else(|| Cache::new(ctx.scene, &options));
        let loaded = cache.len() as u64;
        if render.spp == 0 {
            // Nothing to trace (see `frozen`).
            return Ok(IrradianceCache {
                params,
                camera,
                cache,
                stats: IcStats {
                    loaded,
                    ..IcStats::default()
                },
                misses: AtomicU64::new(0),
            });
        }
        let jitter = PixelJitter::new(render.filter, render.reconstruction);
        let moving = ctx.scene.moves();
        let (mut primaries, mut rays) = (0, 0);
        let schedule = overture_schedule(render.view.width, render.view.height, render.spp);
        let parts = schedule.iter().map(|p| p.len() as u64).sum();
        let progress = control.phase("overture", Some(parts), "parts");
        for phase in schedule {
            // Each chunk sees the cache as it stood before the phase plus its own values;
            // the chunks' values are then added in chunk order. Nothing depends on which
            // thread ran what.
            let mut chunks: Vec<(Cache, u64, RayStats)> = Vec::with_capacity(phase.len());
            drive(
                &phase,
                render.view.threads,
                phase.len(),
                &control.cancel,
                |chunk| {
                    let mut local = cache.empty_like();
                    let mut stats = RayStats::default();
                    let mut walk = Walk {
                        ctx,
                        params: &params,
                        store: Store::Overlay {
                            base: &cache,
                            local: &mut local,
                        },
                        primaries: 0,
                        stats: &mut stats,
                        overture: true,
                        cancel: Some(&control.cancel),
                    };
                    for (x, y, i) in chunk.samples() {
                        if control.cancel.is_cancelled() {
                            break;
                        }
                        let (mut sampler, ray, _) =
                            camera_sample(&camera, seed, &jitter, moving, (x, y), i);
                        let mut rng = sample_rng(seed, &mut sampler);
                        walk.trace(&ray, 0, true, 0, &mut rng);
                    }
                    let n = walk.primaries;
                    (local, n, stats)
                },
                |_, chunk| {
                    chunks.push(chunk);
                    progress.advance(1);
                },
            );
            control.cancel.check("the irradiance-cache overture")?;
            for (local, n, stats) in chunks {
                cache.absorb(local);
                primaries += n;
                rays += stats.total();
            }
            // The cache grows phase by phase (each about twice the last at most).
            control.budget.check(
                "the irradiance cache",
                2 * cache.len() as u64 * BYTES_PER_VALUE,
            )?;
        }
        progress.end(&format!(
            "{} values ({loaded} loaded, {primaries} computed, {:.0} rays each); per bounce \
             level: {:?}",
            cache.len(),
            rays as f64 / primaries.max(1) as f64,
            cache.levels.iter().map(|l| l.len()).collect::<Vec<_>>()
        ));
        let overture_primaries = primaries;
        Ok(IrradianceCache {
            params,
            camera,
            cache,
            stats: IcStats {
                loaded,
                overture_primaries,
                overture_rays: rays,
            },
            misses: AtomicU64::new(0),
        })
    }

    /// The integrator over `cache` as it is, without an overture: for a cache that already
    /// holds the overture of this render's view (`raylink precompute`), so that a render of
    /// any part of the image reads exactly the values the whole render would have.
    pub(crate) fn frozen(
        ctx: &Context,
        render: &ProgressiveOptions,
        options: IcOptions,
        cache: Cache,
    ) -> Result<IrradianceCache> {
        let none = ProgressiveOptions {
            spp: 0,
            ..render.clone()
        };
        IrradianceCache::build(ctx, &none, options, Some(cache), &Control::default())
    }

    pub fn cache(&self) -> &Cache {
        &self.cache
    }

    /// Marks the first-level values the camera sees in `image` (the paper's figure 5b): each
    /// value's pixel becomes `colour`. Values hidden from the eye are left out.
    pub fn show_points(&self, ctx: &Context, image: &mut Image, colour: Rgb) -> usize {
        let Some(level) = self.cache.levels.first() else {
            return 0;
        };
        let mut stats = RayStats::default();
        let mut shown = 0;
        for rec in level.records() {
            let Some((x, y, _)) = self.camera.raster(rec.p) else {
                continue;
            };
            if !(x >= 0.0 && y >= 0.0 && x < image.width as f32 && y < image.height as f32) {
                continue;
            }
            // Seen if the first surface the eye meets towards it is the record's own: the hit
            // lies on the record's tangent plane within twice the hit's error bound (records
            // keep no bound of their own; the same surface nearby has one of the same size).
            let eye = Spot::exact(self.camera.origin);
            let Some(sp) = ctx.intersect(&eye.spawn(rec.p - eye.p), &mut stats) else {
                continue;
            };
            if (sp.p - rec.p).dot(rec.n).abs() > 2.0 * rec.n.abs().dot(sp.error) {
                continue;
            }
            image.set(x as u32, y as u32, colour);
            shown += 1;
        }
        shown
    }

    /// A walk that reads the finished cache and stores nothing (the final render's).
    fn reader<'a>(&'a self, ctx: &'a Context<'a>, stats: &'a mut RayStats) -> Walk<'a> {
        Walk {
            ctx,
            params: &self.params,
            store: Store::Frozen(&self.cache),
            primaries: 0,
            stats,
            overture: false,
            cancel: None,
        }
    }

    /// Primary values the final render computed without storing them (for tests).
    #[cfg(test)]
    pub fn misses(&self) -> u64 {
        self.misses.load(Ordering::Relaxed)
    }

    /// A new primary value at a surface point with normal `n` (level 0), as the cache would
    /// store it; for tests.
    #[cfg(test)]
    pub fn primary_value(&self, ctx: &Context, at: &Spot, n: Vec3) -> Record {
        let mut stats = RayStats::default();
        let mut walk = self.reader(ctx, &mut stats);
        walk.primary(at, n, n, 0)
    }

    /// The indirect irradiance the cache gives at a surface point with normal `n` (level 0),
    /// computing a primary value if S is empty; for tests.
    #[cfg(test)]
    pub fn irradiance(&self, ctx: &Context, at: &Spot, n: Vec3) -> Rgb {
        let mut stats = RayStats::default();
        let mut walk = self.reader(ctx, &mut stats);
        walk.indirect(at, n, n, 0)
    }
}

impl MonteCarlo for IrradianceCache {
    fn sample(
        &self,
        ctx: &Context,
        _camera: &CameraBasis,
        ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        _splats: &mut Vec<Splat>,
    ) -> Rgb {
        let mut rng = sample_rng(self.params.seed, sampler);
        let mut walk = self.reader(ctx, stats);
        let l = walk.trace(ray, 0, true, 0, &mut rng);
        if walk.primaries > 0 {
            self.misses.fetch_add(walk.primaries, Ordering::Relaxed);
        }
        l
    }
}

/// The random stream of one pixel sample, after its filter offset was drawn.
fn sample_rng(seed: u64, sampler: &mut Sampler) -> Rng {
    let u = sampler.next_2d();
    Rng::for_key(seed, &[u.x.to_bits() as u64, u.y.to_bits() as u64])
}

impl Walk<'_> {
    /// Radiance along `ray` at diffuse level `level`. `emission` says whether emitters seen
    /// count (camera rays and their specular continuations) or not (primary-method rays).
    fn trace(
        &mut self,
        ray: &Ray,
        level: u32,
        emission: bool,
        specular_depth: u32,
        rng: &mut Rng,
    ) -> Rgb {
        let ctx = self.ctx;
        match ctx.intersect(ray, self.stats) {
            Some(sp) => self.shade(ray, &sp, level, emission, specular_depth, rng),
            None if emission => ctx.lights.background_radiance(ray.dir),
            None => Rgb::ZERO,
        }
    }

    /// Radiance leaving `sp` back along `ray`.
    fn shade(
        &mut self,
        ray: &Ray,
        sp: &SurfacePoint,
        level: u32,
        emission: bool,
        specular_depth: u32,
        rng: &mut Rng,
    ) -> Rgb {
        let ctx = self.ctx;
        let m = &ctx.scene.materials[sp.material];
        let wo = -ray.dir.normalize();
        let mut l = Rgb::ZERO;
        if emission && m.emits_towards(wo, sp.ng) {
            l += m.emission_at(sp.p, sp.uv, sp.ng);
        }
        let bsdf = m.bsdf(sp, wo);
        let non_delta = bsdf.has_non_delta();
        let lights = &ctx.lights;
        // The overture skips direct light where it is not cached (but draws the same
        // numbers).
        let direct = !(self.overture && level == 0);
        if non_delta {
            // Direct light, light-sampling half of the MIS pair (the BSDF half is below).
            // (Light sampling alone, as Radiance does, saves a third of the rays of a primary
            // value but is far noisier where emitters are large and near, e.g. the furnace
            // test.)
            let u_choice = rng.uniform();
            let u_light = Vec2::new(rng.uniform(), rng.uniform());
            if direct {
                l += sample_direct(ctx, &bsdf, sp, wo, None, u_choice, u_light, self.stats);
            }
            // Indirect diffuse: ρ/π · E, through a coat as for light arriving evenly.
            let diffuse = m.approximation();
            let kd = diffuse.diffuse.eval(sp.p, sp.uv, sp.ng);
            let kdt = diffuse.diffuse_transmission.eval(sp.p, sp.uv, sp.ng);
            let n = bsdf.shading_normal();
            let ng = if sp.ng.dot(n) >= 0.0 { sp.ng } else { -sp.ng };
            if kd.max_element() > 0.0 {
                let e = self.indirect(&sp.spot(), n, ng, level);
                l += kd * (FRAC_1_PI * bsdf.diffuse_coat(wo)) * e;
            }
            // Diffuse transmission: kdt/π · the irradiance arriving on the other side.
            if kdt.max_element() > 0.0 {
                let e = self.indirect(&sp.spot(), -n, -ng, level);
                l += kdt * FRAC_1_PI * e;
            }
        }
        // One BSDF sample. A delta direction is a specular path, followed. A non-delta
        // direction completes the direct-light MIS pair (emitters only) and, on a glossy
        // surface, carries its glossy indirect light: the lobe's share f_glossy·cosθ/pdf of
        // the light leaving the surface hit without its emission, shaded one level deeper
        // (as a primary value's ray is). The cache holds only the diffuse part.
        let u_lobe = rng.uniform();
        let u = Vec2::new(rng.uniform(), rng.uniform());
        let Some(bs) = bsdf.sample(wo, u_lobe, u, Transport::Radiance) else {
            return l;
        };
        if bs.weight.max_element() <= 0.0 {
            return l;
        }
        let next = sp.spot().spawn(bs.wi);
        if bs.delta {
            if specular_depth < MAX_SPECULAR_DEPTH {
                l += bs.weight * self.trace(&next, level, emission, specular_depth + 1, rng);
            }
            return l;
        }
        let mis = direct && !lights.is_empty();
        // Beyond the last level, as for diffuse light, no glossy indirect light.
        let glossy = if bsdf.has_glossy() && level < self.params.options.bounces {
            bsdf.eval_glossy(wo, bs.wi, Transport::Radiance) / bs.pdf
        } else {
            Rgb::ZERO
        };
        let glossy = (glossy.max_element() > 0.0).then_some(glossy);
        if !mis && glossy.is_none() {
            return l;
        }
        match ctx.intersect(&next, self.stats) {
            Some(hit) => {
                if mis {
                    let hm = &ctx.scene.materials[hit.material];
                    if hm.emits_towards(-bs.wi, hit.ng) {
                        if let Some(li) = hit.world_shape().and_then(|s| lights.light_of_shape(s)) {
                            let w = power_heuristic(bs.pdf, lights.pdf_li(li, sp.p, hit.p, hit.ng));
                            l += bs.weight * hm.emission_at(hit.p, hit.uv, hit.ng) * w;
                        }
                    }
                }
                if let Some(weight) = glossy {
                    l += weight * self.shade(&next, &hit, level + 1, false, 0, rng);
                }
            }
            None => {
                if let Some(bg) = lights.background_light().filter(|_| mis) {
                    let w =
                        power_heuristic(bs.pdf, lights.pdf_li(bg, sp.p, sp.p + bs.wi, Vec3::ZERO));
                    l += bs.weight * lights.background_radiance(bs.wi) * w;
                }
            }
        }
        l
    }

    /// Indirect irradiance at level `level`: the cache (secondary method), else a new
    /// primary value (stored when the cache grows); the constant ambient value beyond the
    /// last level.
    fn indirect(&mut self, at: &Spot, n: Vec3, ng: Vec3, level: u32) -> Rgb {
        let params = self.params;
        let p = at.p;
        if level >= params.options.bounces {
            return params.options.ambient;
        }
        if let Some(e) = self.interpolate(level as usize, p, n) {
            return e;
        }
        let rec = self.primary(at, n, ng, level);
        self.primaries += 1;
        if let Store::Overlay { local, .. } = &mut self.store {
            local.levels[level as usize].insert(rec);
        }
        rec.e
    }

    /// The primary method (eq. 2): see the module documentation.
    fn primary(&mut self, at: &Spot, n: Vec3, ng: Vec3, level: u32) -> Record {
        let (ctx, params) = (self.ctx, self.params);
        let p = at.p;
        let strata = params.options.strata_at(level);
        let mut rng = Rng::for_key(
            params.seed,
            &[
                0x1c,
                p.x.to_bits() as u64,
                p.y.to_bits() as u64,
                p.z.to_bits() as u64,
                level as u64,
            ],
        );
        let (t, b) = crate::math::frame(n);
        let mut sum = Rgb::ZERO;
        let mut inv_d = 0.0f64;
        let gradients = params.options.gradients;
        let columns = 2 * strata as usize;
        let mut samples = Vec::with_capacity(if gradients {
            strata as usize * columns
        } else {
            0
        });
        for j in 0..strata {
            if self.cancel.is_some_and(CancelToken::is_cancelled) {
                break;
            }
            for k in 0..2 * strata {
                let sin2 = (j as f32 + rng.uniform()) / strata as f32;
                let (sin_t, cos_t) = (sin2.sqrt(), (1.0 - sin2).max(0.0).sqrt());
                let phi = PI * (k as f32 + rng.uniform()) / strata as f32;
                let dir =
                    (t * (sin_t * phi.cos()) + b * (sin_t * phi.sin()) + n * cos_t).normalize();
                let mut sample = HemisphereSample {
                    dir,
                    cos_theta: cos_t,
                    radiance: Rgb::ZERO,
                    distance: f32::INFINITY,
                };
                if dir.dot(ng) > 0.0 {
                    let ray = at.spawn(dir);
                    if let Some(sp) = ctx.intersect(&ray, self.stats) {
                        inv_d += 1.0 / (sp.t.max(1e-6) as f64);
                        sample.radiance = self.shade(&ray, &sp, level + 1, false, 0, &mut rng);
                        // The gradient divides by the nearer distance of two strata: no
                        // nearer than a value's smallest radius, or sample noise in corners
                        // turns into huge gradients.
                        sample.distance = sp.t.max(params.r_min);
                        sum += sample.radiance;
                    }
                }
                if gradients {
                    samples.push(sample);
                }
            }
        }
        let count = 2 * strata * strata;
        let e = sum * (PI / count as f32);
        let r = if inv_d > 0.0 {
            (count as f64 / inv_d) as f32
        } else {
            params.r_max
        };
        let mut grad = Gradients::default();
        if gradients && samples.len() == count as usize {
            grad = Gradients::from_samples(&samples, strata as usize, columns, n, (t, b));
            if !grad.is_finite() {
                grad = Gradients::default();
            }
        }
        Record {
            p,
            n,
            e,
            grad,
            r: r.clamp(params.r_min, params.r_max),
        }
    }
}
