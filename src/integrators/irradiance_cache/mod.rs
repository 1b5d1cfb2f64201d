//! Irradiance caching (Ward, Rubinstein & Clear, "A Ray Tracing Solution for Diffuse
//! Interreflection", 1988).
//!
//! Radiance leaving a surface toward the eye is L = Le + direct + specular + ρ/π·E, where the
//! direct term comes from next-event estimation (one light sample per shading point, as in the
//! path tracer, without MIS: emitters reached by other rays are not counted), specular paths
//! (mirrors, glass) are followed by sampling the BSDF's delta lobes, and E, the *indirect*
//! irradiance, comes from the cache:
//!
//! - **Primary method** ([`primary`]): n strata in sin²θ by 2n strata in φ, one jittered ray
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
//! **Determinism.** The cache is filled by an *overture* on one thread: it traces exactly
//! the camera rays of the final render (same sampler keys and filter offsets), pixel by pixel
//! in scanline order and sample by sample, with their specular continuations, but without
//! the direct lighting of the first surfaces; every primary value it computes (at all levels)
//! is inserted. The final render, on all threads, then reads the cache only: since the
//! overture looked up every first-level point the render will, first-level lookups find S
//! non-empty; a lookup that still finds S empty (a specular path that took another lobe)
//! computes a primary value for that point and uses it without storing it (counted as
//! `misses`). Primary values draw their random numbers from a stream keyed by
//! (seed, position, level), so every value depends only on the cache contents and the point:
//! the image is the same for any thread count. A cache loaded from a file is used as the
//! starting contents of the overture.

pub mod file;
pub mod octree;
pub mod record;

use super::path::sample_direct;
use super::{Context, MonteCarlo, RayStats, Splat};
use crate::bsdf::{Bsdf, Transport};
use crate::image::filter::FilterSampler;
use crate::math::sobol::Sampler;
use crate::math::warp::power_heuristic;
use crate::math::{offset_origin, Ray, Rgb, Rng, Vec2, Vec3};
use crate::render::progressive::ProgressiveOptions;
use crate::scene::camera::CameraBasis;
use crate::scene::{Scene, SurfacePoint};
use octree::Octree;
use record::Record;
use std::f32::consts::{FRAC_1_PI, PI};
use std::sync::atomic::{AtomicU64, Ordering};

/// The paper's suggestion for a is 0.1–0.2.
pub const DEFAULT_ACCURACY: f32 = 0.15;
pub const DEFAULT_SAMPLES: u32 = 512;
pub const DEFAULT_BOUNCES: u32 = 4;
pub const DEFAULT_AR: f32 = 64.0;
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
}

impl Default for IcOptions {
    fn default() -> Self {
        IcOptions {
            bounces: DEFAULT_BOUNCES,
            accuracy: DEFAULT_ACCURACY,
            samples: DEFAULT_SAMPLES,
            ar: DEFAULT_AR,
            ambient: Rgb::ZERO,
        }
    }
}

impl IcOptions {
    pub fn validate(&self) -> Result<(), String> {
        if !(self.accuracy > 0.0 && self.accuracy.is_finite()) {
            return Err(format!(
                "--ic-accuracy must be positive, got {}",
                self.accuracy
            ));
        }
        if self.samples < 2 {
            return Err(format!(
                "--ic-samples must be at least 2, got {}",
                self.samples
            ));
        }
        if self.bounces > 32 {
            return Err(format!("--ab must be at most 32, got {}", self.bounces));
        }
        if !(self.ar > 0.0 && self.ar.is_finite()) {
            return Err(format!("--ar must be positive, got {}", self.ar));
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

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
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

/// Where values come from during one walk: growing (the overture) or read-only.
enum Store<'a> {
    Grow(&'a mut Cache),
    Frozen(&'a Cache),
}

struct Walk<'a> {
    store: Store<'a>,
    /// Primary values computed.
    primaries: u64,
    stats: &'a mut RayStats,
    /// The overture: no direct lighting on camera-level surfaces (only the cache matters).
    overture: bool,
}

impl Walk<'_> {
    fn cache(&self) -> &Cache {
        match &self.store {
            Store::Grow(c) => c,
            Store::Frozen(c) => c,
        }
    }
}

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
    cache: Cache,
    pub stats: IcStats,
    /// Primary values computed (not stored) by the final render.
    misses: AtomicU64,
}

impl IrradianceCache {
    /// Runs the overture for the render `render` (size, samples, filter, seed) through
    /// `camera`, starting from `cache` (loaded from a file) or an empty cache.
    pub fn build(
        ctx: &Context,
        camera: &CameraBasis,
        render: &ProgressiveOptions,
        options: IcOptions,
        cache: Option<Cache>,
    ) -> IrradianceCache {
        let seed = render.seed;
        let (_, side) = scene_cube(ctx.scene);
        let params = Params {
            options,
            seed,
            r_min: side / options.ar,
            r_max: side * 0.5,
        };
        let mut cache = cache.unwrap_or_else(|| Cache::new(ctx.scene, &options));
        let loaded = cache.len() as u64;
        let mut rays = RayStats::default();
        let mut walk = Walk {
            store: Store::Grow(&mut cache),
            primaries: 0,
            stats: &mut rays,
            overture: true,
        };
        let filter = FilterSampler::new(render.filter);
        for y in 0..render.height {
            for x in 0..render.width {
                for i in 0..render.spp {
                    // As render::progressive and `sample` below draw them.
                    let mut sampler = Sampler::new(seed, &[x as u64, y as u64], i);
                    let offset = filter.sample(sampler.next_2d());
                    let ray = camera.ray(x as f32 + 0.5 + offset.x, y as f32 + 0.5 + offset.y);
                    let mut rng = sample_rng(seed, &mut sampler);
                    trace(ctx, &params, &mut walk, &ray, 0, true, 0, &mut rng);
                }
            }
        }
        let overture_primaries = walk.primaries;
        IrradianceCache {
            params,
            cache,
            stats: IcStats {
                loaded,
                overture_primaries,
                overture_rays: rays.total(),
            },
            misses: AtomicU64::new(0),
        }
    }

    pub fn cache(&self) -> &Cache {
        &self.cache
    }

    /// Primary values the final render computed without storing them.
    pub fn misses(&self) -> u64 {
        self.misses.load(Ordering::Relaxed)
    }

    /// The indirect irradiance the cache gives at a surface point with normal `n` (level 0),
    /// computing a primary value if S is empty; for tests.
    pub fn irradiance(&self, ctx: &Context, p: Vec3, n: Vec3) -> Rgb {
        let mut stats = RayStats::default();
        let mut walk = Walk {
            store: Store::Frozen(&self.cache),
            primaries: 0,
            stats: &mut stats,
            overture: false,
        };
        indirect(ctx, &self.params, &mut walk, p, n, n, 0)
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
        let mut walk = Walk {
            store: Store::Frozen(&self.cache),
            primaries: 0,
            stats,
            overture: false,
        };
        let l = trace(ctx, &self.params, &mut walk, ray, 0, true, 0, &mut rng);
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

/// Radiance along `ray` at diffuse level `level`. `emission` says whether emitters seen
/// count (camera rays and their specular continuations) or not (primary-method rays).
#[allow(clippy::too_many_arguments)]
fn trace(
    ctx: &Context,
    params: &Params,
    walk: &mut Walk,
    ray: &Ray,
    level: u32,
    emission: bool,
    specular_depth: u32,
    rng: &mut Rng,
) -> Rgb {
    match ctx.intersect(ray, walk.stats) {
        Some(sp) => shade(
            ctx,
            params,
            walk,
            ray,
            &sp,
            level,
            emission,
            specular_depth,
            rng,
        ),
        None if emission => ctx.lights.background_radiance(ray.dir),
        None => Rgb::ZERO,
    }
}

/// Radiance leaving `sp` back along `ray`.
#[allow(clippy::too_many_arguments)]
fn shade(
    ctx: &Context,
    params: &Params,
    walk: &mut Walk,
    ray: &Ray,
    sp: &SurfacePoint,
    level: u32,
    emission: bool,
    specular_depth: u32,
    rng: &mut Rng,
) -> Rgb {
    let m = &ctx.scene.materials[sp.material];
    let wo = -ray.dir.normalize();
    let mut l = Rgb::ZERO;
    if emission && m.is_emissive() && wo.dot(sp.ng) > 0.0 {
        l += m.emission;
    }
    let bsdf = Bsdf::new(m, sp, wo);
    let non_delta = bsdf.has_non_delta();
    let lights = &ctx.lights;
    // The overture skips direct light where it is not cached (but draws the same numbers).
    let direct = !(walk.overture && level == 0);
    if non_delta {
        // Direct light, light-sampling half of the MIS pair (the BSDF half is below).
        let u_choice = rng.uniform();
        let u_light = Vec2::new(rng.uniform(), rng.uniform());
        if direct {
            l += sample_direct(ctx, &bsdf, sp, wo, u_choice, u_light, walk.stats);
        }
        // Indirect diffuse: ρ/π · E.
        let kd = m.diffuse.eval(sp.p, sp.uv);
        if kd.max_element() > 0.0 {
            let n = bsdf.shading_normal();
            let ng = if sp.ng.dot(n) >= 0.0 { sp.ng } else { -sp.ng };
            let e = indirect(ctx, params, walk, sp.p, n, ng, level);
            l += kd * FRAC_1_PI * e;
        }
    }
    // One BSDF sample: a non-delta direction completes the direct-light MIS pair (emitters
    // only: the indirect part is the cache's); a delta direction is a specular path,
    // followed.
    let u_lobe = rng.uniform();
    let u = Vec2::new(rng.uniform(), rng.uniform());
    let Some(bs) = bsdf.sample(wo, u_lobe, u, Transport::Radiance) else {
        return l;
    };
    if bs.weight.max_element() <= 0.0 {
        return l;
    }
    let next = Ray::new(offset_origin(sp.p, sp.ng, bs.wi), bs.wi);
    if bs.delta {
        if specular_depth < MAX_SPECULAR_DEPTH {
            l += bs.weight
                * trace(
                    ctx,
                    params,
                    walk,
                    &next,
                    level,
                    emission,
                    specular_depth + 1,
                    rng,
                );
        }
    } else if direct && !lights.is_empty() {
        match ctx.intersect(&next, walk.stats) {
            Some(hit) => {
                let hm = &ctx.scene.materials[hit.material];
                if hm.is_emissive() && bs.wi.dot(hit.ng) < 0.0 {
                    if let Some(li) = lights.light_of_shape(hit.shape) {
                        let w = power_heuristic(bs.pdf, lights.pdf_li(li, sp.p, hit.p, hit.ng));
                        l += bs.weight * hm.emission * w;
                    }
                }
            }
            None => {
                if let Some(bg) = lights.background_light() {
                    let w =
                        power_heuristic(bs.pdf, lights.pdf_li(bg, sp.p, sp.p + bs.wi, Vec3::ZERO));
                    l += bs.weight * lights.background_radiance(bs.wi) * w;
                }
            }
        }
    }
    l
}

/// Indirect irradiance at level `level`: the cache (secondary method), else a new primary
/// value (stored when the cache grows); the constant ambient value beyond the last level.
fn indirect(
    ctx: &Context,
    params: &Params,
    walk: &mut Walk,
    p: Vec3,
    n: Vec3,
    ng: Vec3,
    level: u32,
) -> Rgb {
    if level >= params.options.bounces {
        return params.options.ambient;
    }
    if let Some(e) = walk.cache().levels[level as usize].interpolate(p, n) {
        return e;
    }
    let rec = primary(ctx, params, walk, p, n, ng, level);
    walk.primaries += 1;
    if let Store::Grow(cache) = &mut walk.store {
        cache.levels[level as usize].insert(rec);
    }
    rec.e
}

/// The primary method (eq. 2): see the module documentation.
fn primary(
    ctx: &Context,
    params: &Params,
    walk: &mut Walk,
    p: Vec3,
    n: Vec3,
    ng: Vec3,
    level: u32,
) -> Record {
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
    for j in 0..strata {
        for k in 0..2 * strata {
            let sin2 = (j as f32 + rng.uniform()) / strata as f32;
            let (sin_t, cos_t) = (sin2.sqrt(), (1.0 - sin2).max(0.0).sqrt());
            let phi = PI * (k as f32 + rng.uniform()) / strata as f32;
            let dir = (t * (sin_t * phi.cos()) + b * (sin_t * phi.sin()) + n * cos_t).normalize();
            if dir.dot(ng) <= 0.0 {
                continue;
            }
            let ray = Ray::new(offset_origin(p, ng, dir), dir);
            if let Some(sp) = ctx.intersect(&ray, walk.stats) {
                inv_d += 1.0 / (sp.t.max(1e-6) as f64);
                sum += shade(ctx, params, walk, &ray, &sp, level + 1, false, 0, &mut rng);
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
    Record {
        p,
        n,
        e,
        r: r.clamp(params.r_min, params.r_max),
    }
}
