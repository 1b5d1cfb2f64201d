//! SPPM's camera pass: one camera path per pixel and iteration, followed through perfectly
//! specular (and, before the last bounce, glossy) surfaces to the first diffuse one, where
//! it leaves a visible point for the photons to find. On the way it gathers what the
//! photons do not bring: emission seen directly or through specular bounces, and direct
//! light (next-event estimation with the BSDF-sampled direction, combined by multiple
//! importance sampling as the path tracer combines them), as pbrt-v4's `SPPMIntegrator`.

use super::media::{self, VolumePoint};
use crate::bsdf::{Bsdf, Transport};
use crate::control::CancelToken;
use crate::integrators::path::{emitted, escaped, sample_direct, RR_START_DEPTH};
use crate::integrators::volumetric::{gathering, Gathered, Lengths};
use crate::math::sobol::Sampler;
use crate::math::{Ray, Rgb, Vec3};
use crate::scene::camera::CameraBasis;
use crate::scene::Scene;
use crate::transport::camera_sample::{camera_sample, PixelJitter};
use crate::transport::spectral::RgbColours;
use crate::transport::{Context, RayStats};
use rayon::prelude::*;

/// Where a camera path met its first diffuse surface: the photons arriving within the
/// pixel's radius of `p` are weighed by `bsdf` towards `wo` and by the path's throughput.
#[derive(Clone, Copy, Debug)]
pub(super) struct VisiblePoint<'a> {
    pub p: Vec3,
    pub wo: Vec3,
    pub bsdf: Bsdf<'a>,
    pub beta: Rgb,
}

impl VisiblePoint<'_> {
    /// What a photon carrying `power` and arriving along `wi` (pointing away from the
    /// surface) adds to the pixel: β_vp · f(wo, wi) · power, f without the cosine (the
    /// photon's power already counts the area it lands on).
    pub fn weigh(&self, wi: Vec3, power: Rgb) -> Rgb {
        let cos = wi.dot(self.bsdf.shading_normal()).abs();
        if cos == 0.0 {
            return Rgb::ZERO;
        }
        let f = self.bsdf.eval(self.wo, wi, Transport::Radiance) / cos;
        self.beta * f * power
    }
}

/// A pixel's camera path in one iteration.
pub(super) struct CameraPath<'a> {
    /// Emission and direct light gathered along it.
    pub ld: Rgb,
    pub visible: Option<VisiblePoint<'a>>,
    /// Its visible point in a medium (scenes with media only; at most one of the two).
    pub in_medium: Option<VolumePoint>,
}

/// What the camera pass needs besides the scene.
pub(super) struct CameraPass<'c> {
    pub camera: &'c CameraBasis,
    pub jitter: &'c PixelJitter,
    pub seed: u64,
    pub max_depth: u32,
    pub size: (u32, u32),
    /// Whether a medium emits: photons leave the lights alone, so the light media emit is
    /// traced as paths from the camera (its own estimate, added to what the pixel gathers).
    pub media_glow: bool,
}

impl CameraPass<'_> {
    /// Every pixel's camera path of `iteration`, row-major, and the rays traced; `None` if
    /// cancelled. Rows run in parallel; each path draws from the stream of (seed, pixel,
    /// iteration) alone.
    pub fn run<'a>(
        &self,
        ctx: &Context<'a>,
        iteration: u32,
        cancel: &CancelToken,
    ) -> Option<(Vec<CameraPath<'a>>, RayStats)> {
        let (width, height) = self.size;
        let rows: Vec<Option<(Vec<CameraPath<'a>>, RayStats)>> = (0..height)
            .into_par_iter()
            .map(|y| {
                if cancel.is_cancelled() {
                    return None;
                }
                let mut stats = RayStats::default();
                let row = (0..width)
                    .map(|x| {
                        let (mut sampler, ray, _) = camera_sample(
                            self.camera,
                            self.seed,
                            self.jitter,
                            false,
                            (x, y),
                            iteration,
                        );
                        let mut path = if ctx.scene.media.is_empty() {
                            trace(ctx, &ray, self.max_depth, &mut sampler, &mut stats)
                        } else {
                            media::trace(ctx, &ray, self.max_depth, &mut sampler, &mut stats)
                        };
                        if self.media_glow {
                            let lengths = Lengths {
                                max_depth: self.max_depth,
                                rr_start: RR_START_DEPTH,
                            };
                            let glow = gathering(
                                ctx,
                                &ray,
                                (lengths, Gathered::MediaEmission),
                                &mut sampler,
                                &mut stats,
                                &mut RgbColours,
                            );
                            if glow.is_finite() {
                                path.ld += glow;
                            }
                        }
                        path
                    })
                    .collect();
                Some((row, stats))
            })
            .collect();
        let mut paths = Vec::with_capacity(width as usize * height as usize);
        let mut stats = RayStats::default();
        for row in rows {
            let (row, s) = row?;
            paths.extend(row);
            stats.add(&s);
        }
        Some((paths, stats))
    }
}

/// The camera path along `ray`: pbrt-v4's SPPM camera walk. A vertex with a diffuse lobe
/// (or a glossy one at the last bounce) becomes the visible point; the walk then takes one
/// more BSDF sample, whose emitter, if it hits one, completes the direct light's multiple
/// importance sampling.
fn trace<'a>(
    ctx: &Context<'a>,
    camera_ray: &Ray,
    max_depth: u32,
    sampler: &mut Sampler,
    stats: &mut RayStats,
) -> CameraPath<'a> {
    let scene: &'a Scene = ctx.scene;
    let mut ld = Rgb::ZERO;
    let mut visible = None;
    let mut beta = Rgb::ONE;
    let mut ray = *camera_ray;
    let mut bsdf_pdf = 0.0;
    let mut specular = true;
    let mut prev_p = ray.origin;
    let mut prev_facing = None;
    let mut depth = 0;
    loop {
        let Some(sp) = ctx.intersect_at_depth(&ray, depth, stats) else {
            let prev = (prev_p, prev_facing);
            ld += escaped(ctx, &ray, prev, beta, (bsdf_pdf, specular));
            break;
        };
        let m = &scene.materials[sp.material];
        let wo = -ray.dir;
        if m.emits_towards(wo, sp.ng) {
            ld += emitted(ctx, &sp, prev_p, beta, (bsdf_pdf, specular));
        }
        if depth == max_depth || visible.is_some() {
            break;
        }
        depth += 1;
        let bsdf = m.bsdf(&sp, wo);
        let u_choice = sampler.next_2d();
        let u_light = sampler.next_2d();
        let facing = bsdf.reflecting_side(wo);
        if bsdf.has_non_delta() {
            let (u, v) = (u_choice.x, u_light);
            ld += beta * sample_direct(ctx, &bsdf, &sp, wo, facing, u, v, stats);
        }
        if bsdf.has_diffuse() || (bsdf.has_non_delta() && depth == max_depth) {
            visible = Some(VisiblePoint {
                p: sp.p,
                wo,
                bsdf,
                beta,
            });
        }
        let u_dir = sampler.next_2d();
        let Some(bs) = bsdf.sample(wo, u_choice.y, u_dir, Transport::Radiance) else {
            break;
        };
        beta *= bs.weight;
        bsdf_pdf = bs.pdf;
        specular = bs.delta;
        prev_p = sp.p;
        prev_facing = facing;
        ray = sp.spawn(bs.wi);
        // pbrt-v4's camera-path roulette: a throughput below 1 survives with probability
        // max(β), at least 0.05.
        let b = beta.max_element();
        if b < 1.0 {
            let q = (1.0 - b).max(0.05);
            if sampler.next_1d() < q {
                break;
            }
            beta /= 1.0 - q;
        }
    }
    let visible = visible.filter(|v: &VisiblePoint| v.beta.is_finite() && v.p.is_finite());
    CameraPath {
        ld: if ld.is_finite() { ld } else { Rgb::ZERO },
        visible,
        in_medium: None,
    }
}
