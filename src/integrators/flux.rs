//! The flux arriving at a set of surfaces S, the measurement at the centre of Dutré,
//! Lafortune & Willems's framework: Φ(S) = ⟨L, W_e⟩ = ⟨L_e, W⟩, where W_e is 1 on the
//! points and directions of S. Estimated two ways, as the paper's two adjoint equations
//! suggest:
//! - **gathering** (the rendering equation): points of S chosen uniformly by area, a
//!   direction on either side by the cosine, and the radiance arriving along it estimated by
//!   the path tracer (point and directional lights, which no ray can hit, by a shadow ray);
//! - **shooting** (the potential equation): particles leave the lights with their power and
//!   follow the light tracer's walk; every arrival at a surface of S adds the power it
//!   carries.
//!
//! Both are unbiased for the same quantity, up to the same number of bounces, so their
//! agreement within their standard errors checks the whole transport (BSDFs in both
//! transport modes, emission, light sampling) for any S, not only the pixels of a camera.

use super::light::walk;
use super::path::{PathOptions, PathTracer, MAX_DEPTH_LIMIT};
use crate::accel::{self, Backend};
use crate::control::Control;
use crate::error::{Error, Result};
use crate::math::sobol::Sampler;
use crate::math::warp::{cosine_hemisphere, power_heuristic};
use crate::math::{frame, Ray, Rgb, Vec3};
use crate::scene::camera::CameraBasis;
use crate::scene::lights::AreaLight;
use crate::scene::Scene;
use crate::transport::spectral::RgbColours;
use crate::transport::{Context, MonteCarlo, RayStats};
use rayon::prelude::*;

/// Independently scrambled batches the paths are split into; the spread of their means gives
/// the standard error.
const BATCHES: u64 = 64;

/// Most paths one estimate traces.
pub const MAX_PATHS: u64 = 1 << 40;

/// How the flux is estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Estimator {
    /// From the surfaces: the radiance arriving at them, by path tracing.
    Gathering,
    /// From the lights: the power of the particles that reach them, by light tracing.
    Shooting,
}

/// The flux arriving at `surfaces` (from either side), by `estimator`.
#[derive(Clone, Debug, PartialEq)]
pub struct FluxJob {
    /// The surfaces S: indices into `Scene::shapes`.
    pub surfaces: Vec<usize>,
    pub estimator: Estimator,
    /// Bounces light may take before it arrives at S (0: straight from the lights).
    pub max_depth: u32,
    /// Paths traced: from S when gathering, from the lights when shooting.
    pub paths: u64,
    /// The estimate is a function of (scene, job, seed), whatever the thread count.
    pub seed: u64,
    /// Worker threads; `None` uses every core.
    pub threads: Option<usize>,
    pub accel: Backend,
}

/// An estimate of the flux (W per channel) and its standard error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Flux {
    pub flux: Rgb,
    pub standard_error: Rgb,
    pub paths: u64,
    pub rays: RayStats,
}

/// Estimates the flux of `job` in `scene`.
pub fn estimate(scene: &Scene, job: &FluxJob, control: &Control) -> Result<Flux> {
    let surfaces = surfaces(scene, &job.surfaces)?;
    if !(BATCHES..=MAX_PATHS).contains(&job.paths) {
        return Err(Error::setting(
            "paths",
            format!(
                "must be between {BATCHES} and {MAX_PATHS}, got {}",
                job.paths
            ),
        ));
    }
    if job.max_depth > MAX_DEPTH_LIMIT {
        return Err(Error::setting(
            "max_depth",
            format!("must be at most {MAX_DEPTH_LIMIT}, got {}", job.max_depth),
        ));
    }
    let accel = accel::build(scene, job.accel, control)?;
    let ctx = Context::new(scene, accel.as_ref());
    let mut in_set = vec![false; scene.shapes.len()];
    for s in &surfaces {
        in_set[s.shape] = true;
    }
    let areas: Vec<f32> = surfaces.iter().map(|s| s.area).collect();
    let total_area: f32 = areas.iter().sum();
    let estimator = Paths {
        ctx: &ctx,
        job,
        surfaces: &surfaces,
        in_set: &in_set,
        areas: &areas,
        total_area,
        tracer: PathTracer::new(PathOptions {
            max_depth: job.max_depth,
        }),
        camera: scene.camera.basis(),
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(job.threads.unwrap_or(0))
        .build()
        .map_err(|e| Error::Invalid(format!("cannot start threads: {e}")))?;
    let phase = control.phase("flux", Some(job.paths), "paths");
    let batches: Vec<Option<([f64; 3], u64, RayStats)>> = pool.install(|| {
        (0..BATCHES)
            .into_par_iter()
            .map(|b| {
                let n = job.paths / BATCHES + u64::from(b < job.paths % BATCHES);
                let out = estimator.batch(b, n, control);
                phase.advance(n);
                out
            })
            .collect()
    });
    phase.end("");
    let Some(batches) = batches.into_iter().collect::<Option<Vec<_>>>() else {
        return Err(Error::Cancelled {
            stage: "the flux estimate".into(),
        });
    };
    let mut rays = RayStats::default();
    let mut sum = [0.0f64; 3];
    for (s, _, r) in &batches {
        rays.add(r);
        for c in 0..3 {
            sum[c] += s[c];
        }
    }
    let mean = sum.map(|s| s / job.paths as f64);
    // Batch means scattered about the mean, weighted by their sizes (which differ by one).
    let mut var = [0.0f64; 3];
    for (s, n, _) in &batches {
        for c in 0..3 {
            let d = s[c] / *n as f64 - mean[c];
            var[c] += d * d * *n as f64;
        }
    }
    let se = var.map(|v| (v / (job.paths as f64 * (BATCHES - 1) as f64)).sqrt());
    let rgb = |v: [f64; 3]| Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32);
    Ok(Flux {
        flux: rgb(mean),
        standard_error: rgb(se),
        paths: job.paths,
        rays,
    })
}

/// The surfaces of S, prepared for sampling by area; an error naming a bad one.
fn surfaces(scene: &Scene, indices: &[usize]) -> Result<Vec<AreaLight>> {
    if indices.is_empty() {
        return Err(Error::setting("surfaces", "name no surface"));
    }
    let mut out: Vec<AreaLight> = Vec::with_capacity(indices.len());
    for &i in indices {
        if i >= scene.shapes.len() {
            return Err(Error::setting(
                "surfaces",
                format!("name shape {i}, but the scene has {}", scene.shapes.len()),
            ));
        }
        if out.iter().any(|s| s.shape == i) {
            return Err(Error::setting("surfaces", format!("name shape {i} twice")));
        }
        let surface = AreaLight::surface(scene, i)
            .ok_or_else(|| Error::setting("surfaces", format!("shape {i} has no area")))?;
        out.push(surface);
    }
    Ok(out)
}

/// What every path of one estimate shares.
struct Paths<'a> {
    ctx: &'a Context<'a>,
    job: &'a FluxJob,
    surfaces: &'a [AreaLight],
    in_set: &'a [bool],
    areas: &'a [f32],
    total_area: f32,
    tracer: PathTracer,
    /// The scene's camera, which the path tracer takes but does not use.
    camera: CameraBasis,
}

impl Paths<'_> {
    /// The sum of `n` path estimates of batch `b` (in f64), `n`, and the rays traced; `None`
    /// if cancelled.
    fn batch(&self, b: u64, n: u64, control: &Control) -> Option<([f64; 3], u64, RayStats)> {
        let mut stats = RayStats::default();
        let mut sum = [0.0f64; 3];
        let key = match self.job.estimator {
            Estimator::Gathering => 0x6761_7468,
            Estimator::Shooting => 0x7368_6f6f,
        };
        for i in 0..n {
            if i % 256 == 0 && control.cancel.is_cancelled() {
                return None;
            }
            // One scrambled sequence per block of 2^32 paths of a batch.
            let mut sampler = Sampler::new(self.job.seed, &[key, b, i >> 32], i as u32);
            let f = match self.job.estimator {
                Estimator::Gathering => self.gather(&mut sampler, &mut stats),
                Estimator::Shooting => self.shoot(&mut sampler, &mut stats),
            };
            if f.is_finite() {
                for c in 0..3 {
                    sum[c] += f[c] as f64;
                }
            }
        }
        Some((sum, n, stats))
    }

    /// One gathering estimate of A·∫ L_i(x, ω) |cos| dω over both sides of x, for x uniform
    /// over S: a light sample (next-event estimation) and a direction on a random side
    /// distributed by the cosine, whose radiance the path tracer estimates, combined by
    /// multiple importance sampling (the direction alone for point and directional lights,
    /// which it cannot hit, and the light sample alone for them).
    fn gather(&self, sampler: &mut Sampler, stats: &mut RayStats) -> Rgb {
        let lights = &self.ctx.lights;
        let u = sampler.next_2d();
        let target = u.x * self.total_area;
        let mut k = 0;
        let mut acc = self.areas[0];
        while acc <= target && k + 1 < self.areas.len() {
            k += 1;
            acc += self.areas[k];
        }
        let x = self.surfaces[k].sample(sampler.next_2d());
        // Directions on both sides, by the cosine: density |cos| / 2π.
        let pdf_dir = |cos: f32| cos.abs() * std::f32::consts::FRAC_1_PI * 0.5;
        let mut direct = Rgb::ZERO;
        let u_light = sampler.next_2d();
        let u_choice = sampler.next_1d();
        if let Some(ls) = lights.sample_li(x.p, u_choice, u_light) {
            let cos = ls.wi.dot(x.n);
            if ls.pdf > 0.0 && ls.radiance != Rgb::ZERO && cos != 0.0 {
                let shadow = x.spot().spawn_to(&ls.spot());
                if !self.ctx.occluded(&shadow, stats) {
                    let w = if ls.delta {
                        1.0
                    } else {
                        power_heuristic(ls.pdf, pdf_dir(cos))
                    };
                    direct = ls.radiance * (cos.abs() / ls.pdf * w);
                }
            }
        }
        let n = if u.y < 0.5 { x.n } else { -x.n };
        let (t, b) = frame(n);
        let d = cosine_hemisphere(sampler.next_2d());
        let dir = t * d.x + b * d.y + n * d.z;
        let ray = x.spot().spawn(dir);
        let arriving = self.tracer.sample(
            self.ctx,
            &self.camera,
            &ray,
            sampler,
            stats,
            &mut Vec::new(),
        );
        // The path tracer counts what the direction reaches first in full, as seen from a
        // camera; an emitter there takes its share of the light sample's weight instead.
        let first = self.emitted_first(&ray, x.p, pdf_dir(d.z), stats);
        (arriving * std::f32::consts::TAU + direct - first) * self.total_area
    }

    /// What the gathering estimate over-counts along `ray` from `x`: the radiance emitted by
    /// what it reaches first (an area light, or the background), times 2π and the light
    /// sample's share of the multiple-importance weight.
    fn emitted_first(&self, ray: &Ray, x: Vec3, pdf_dir: f32, stats: &mut RayStats) -> Rgb {
        let lights = &self.ctx.lights;
        let (le, pdf_light) = match self.ctx.intersect(ray, stats) {
            Some(sp) => {
                let m = &self.ctx.scene.materials[sp.material];
                let Some(l) = sp.world_shape().and_then(|s| lights.light_of_shape(s)) else {
                    return Rgb::ZERO;
                };
                if !m.emits_towards(-ray.dir, sp.ng) {
                    return Rgb::ZERO;
                }
                (
                    m.emission_at(sp.p, sp.uv, sp.ng),
                    lights.pdf_li(l, x, sp.p, sp.ng),
                )
            }
            None => match lights.background_light() {
                Some(bg) => (
                    lights.background_radiance(ray.dir),
                    lights.pdf_li(bg, x, x + ray.dir, Vec3::ZERO),
                ),
                None => return Rgb::ZERO,
            },
        };
        le * ((1.0 - power_heuristic(pdf_dir, pdf_light)) * std::f32::consts::TAU)
    }

    /// One shooting estimate: the power a particle carries into S, summed over its arrivals.
    fn shoot(&self, sampler: &mut Sampler, stats: &mut RayStats) -> Rgb {
        let u_choose = sampler.next_2d();
        let u_pos = sampler.next_2d();
        let u_dir = sampler.next_2d();
        let Some(es) = self.ctx.lights.sample_le(u_choose.x, u_pos, u_dir) else {
            return Rgb::ZERO;
        };
        let mut arrived = Rgb::ZERO;
        // Arrivals after at most `max_depth` bounces: `max_depth + 1` surfaces reached.
        walk(
            self.ctx,
            &es,
            self.job.max_depth + 1,
            0.0,
            sampler,
            stats,
            &mut RgbColours,
            |sp, _, _, beta, _, _, _| {
                if sp.world_shape().is_some_and(|s| self.in_set[s]) {
                    arrived += beta;
                }
            },
        );
        arrived
    }
}
