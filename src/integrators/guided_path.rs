//! The path tracer with path guiding: at vertices whose BSDF has no delta lobe, the
//! continuation is drawn from the guide or from the BSDF (one-sample multiple importance
//! sampling with the mixture density α·p_guide + (1 − α)·p_bsdf), and next-event estimation
//! weighs its light samples against that mixture. When the pass learns, each such vertex
//! deposits the radiance that arrived along its continuation (everything the path gathered
//! after it, divided by the throughput up to it) over the density the direction was drawn
//! with, and each light sample deposits the light it saw over its own density.

use super::path::{emitted, escaped, russian_roulette, PathTracer};
use crate::bsdf::{Bsdf, Transport};
use crate::guiding::directional::DirTree;
use crate::guiding::{Guidance, GUIDE_FRACTION};
use crate::math::sobol::Sampler;
use crate::math::warp::power_heuristic;
use crate::math::{Ray, Rgb, Vec2, Vec3};
use crate::scene::SurfacePoint;
use crate::transport::{Context, RayStats};

/// A vertex that deposits once its path ends.
struct Vertex {
    slot: u32,
    /// The throughput up to and through the vertex (before Russian roulette).
    beta: Rgb,
    /// The radiance gathered after it, divided by `beta`.
    incident: Rgb,
    /// The density its continuation was drawn with.
    pdf: f32,
}

/// The density with which a guided vertex draws `wi`, given the BSDF's.
fn mixture_pdf(guide: Option<&DirTree>, bsdf_pdf: f32, wi: Vec3) -> f32 {
    match guide {
        Some(d) => GUIDE_FRACTION * d.pdf(wi) + (1.0 - GUIDE_FRACTION) * bsdf_pdf,
        None => bsdf_pdf,
    }
}

/// Adds `c` (gathered with the current throughput) to every earlier vertex's incident
/// radiance.
fn credit(vertices: &mut [Vertex], c: Rgb) {
    for v in vertices {
        let share = Rgb::new(
            if v.beta.x > 0.0 { c.x / v.beta.x } else { 0.0 },
            if v.beta.y > 0.0 { c.y / v.beta.y } else { 0.0 },
            if v.beta.z > 0.0 { c.z / v.beta.z } else { 0.0 },
        );
        v.incident += share;
    }
}

/// The deposit's energy of incident radiance `l` found with density `pdf`.
fn energy(l: Rgb, pdf: f32) -> Option<f32> {
    let e = (l.x + l.y + l.z) / (3.0 * pdf);
    (e.is_finite() && e >= 0.0).then_some(e)
}

/// Next-event estimation weighted against the mixture: f·L·w / pdf, and the light seen
/// (L·w, its direction and density) for a deposit.
#[allow(clippy::too_many_arguments)]
fn sample_direct(
    ctx: &Context,
    bsdf: &Bsdf,
    sp: &SurfacePoint,
    wo: Vec3,
    guide: Option<&DirTree>,
    u_choice: f32,
    u_light: Vec2,
    stats: &mut RayStats,
) -> (Rgb, Option<(Vec3, Rgb, f32)>) {
    let Some(ls) = ctx.lights.sample_li(sp.p, u_choice, u_light) else {
        return (Rgb::ZERO, None);
    };
    let (f, bsdf_pdf) = bsdf.eval_and_pdf(wo, ls.wi, Transport::Radiance);
    if f == Rgb::ZERO || ls.pdf <= 0.0 {
        return (Rgb::ZERO, None);
    }
    let shadow = sp.spawn_to(&ls.spot());
    if ctx.occluded(&shadow, stats) {
        return (Rgb::ZERO, None);
    }
    if ls.delta {
        return (f * ls.radiance / ls.pdf, None);
    }
    let w = power_heuristic(ls.pdf, mixture_pdf(guide, bsdf_pdf, ls.wi));
    (
        f * ls.radiance * (w / ls.pdf),
        Some((ls.wi, ls.radiance * w, ls.pdf)),
    )
}

impl PathTracer {
    /// The guided estimate of radiance along `camera_ray` (surfaces only: scenes with media
    /// are traced unguided).
    pub(crate) fn radiance_guided(
        &self,
        ctx: &Context,
        camera_ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        guidance: &mut Guidance,
    ) -> Rgb {
        let guide = guidance.guide;
        let learns = guidance.deposits.is_some();
        let mut vertices: Vec<Vertex> = Vec::new();
        let mut radiance = Rgb::ZERO;
        let mut beta = Rgb::ONE;
        let mut ray = *camera_ray;
        let mut scatter_pdf = 0.0;
        let mut specular = true;
        let mut prev_p = ray.origin;
        let mut depth = 0;
        loop {
            let Some(sp) = ctx.intersect_at_depth(&ray, depth, stats) else {
                // Without a background this is zero, and crediting zero changes nothing.
                let c = escaped(ctx, &ray, (prev_p, None), beta, (scatter_pdf, specular));
                radiance += c;
                credit(&mut vertices, c);
                break;
            };
            let m = &ctx.scene.materials[sp.material];
            let wo = -ray.dir;
            if m.emits_towards(wo, sp.ng) {
                let c = emitted(ctx, &sp, prev_p, beta, (scatter_pdf, specular));
                radiance += c;
                credit(&mut vertices, c);
            }
            if depth == self.max_depth() {
                break;
            }
            depth += 1;
            let bsdf = m.bsdf(&sp, wo);
            // The spatial leaf, where the guide may be used; and its distribution, if any.
            let leaf = bsdf
                .guidable()
                .then(|| guide.leaf(sp.p, bsdf.shading_normal()));
            let dist = leaf.and_then(|l| guide.distribution(l));
            let u_choice = sampler.next_2d();
            let u_light = sampler.next_2d();
            if bsdf.has_non_delta() {
                let (c, seen) =
                    sample_direct(ctx, &bsdf, &sp, wo, dist, u_choice.x, u_light, stats);
                radiance += beta * c;
                credit(&mut vertices, beta * c);
                if let (Some(deposits), Some(l), Some((wi, li, pdf))) =
                    (guidance.deposits.as_mut(), leaf, seen)
                {
                    if let Some(e) = energy(li, pdf) {
                        deposits.push((guide.slot(l, wi), e));
                    }
                }
            }
            let u_dir = sampler.next_2d();
            let (wi, weight, pdf, delta) = match dist {
                Some(d) => {
                    let wi = if sampler.next_1d() < GUIDE_FRACTION {
                        d.sample(u_dir)
                    } else {
                        match bsdf.sample(wo, u_choice.y, u_dir, Transport::Radiance) {
                            Some(bs) => bs.wi,
                            None => break,
                        }
                    };
                    let (f, bsdf_pdf) = bsdf.eval_and_pdf(wo, wi, Transport::Radiance);
                    let pdf = mixture_pdf(Some(d), bsdf_pdf, wi);
                    if f == Rgb::ZERO || pdf <= 0.0 {
                        break;
                    }
                    (wi, f / pdf, pdf, false)
                }
                None => match bsdf.sample(wo, u_choice.y, u_dir, Transport::Radiance) {
                    Some(bs) => (bs.wi, bs.weight, bs.pdf, bs.delta),
                    None => break,
                },
            };
            beta *= weight;
            if let (true, Some(l)) = (learns, leaf) {
                vertices.push(Vertex {
                    slot: guide.slot(l, wi),
                    beta,
                    incident: Rgb::ZERO,
                    pdf,
                });
            }
            scatter_pdf = pdf;
            specular = delta;
            prev_p = sp.p;
            ray = sp.spawn(wi);
            if !russian_roulette(&mut beta, depth, sampler) {
                break;
            }
        }
        if let Some(deposits) = guidance.deposits.as_mut() {
            for v in &vertices {
                if let Some(e) = energy(v.incident, v.pdf) {
                    deposits.push((v.slot, e));
                }
            }
        }
        radiance
    }
}
