//! The random walks that make camera and light subpaths: surface scattering by BSDF
//! sampling and, in scenes with media, free flights by delta tracking (the volumetric path
//! tracer's, with its hero channel), scattering in media by the phase function, and medium
//! boundaries crossed without a vertex.

use super::vertex::{Kind, Vertex};
use crate::bsdf::{phase, Transport};
use crate::integrators::path::RR_START_DEPTH;
use crate::integrators::volumetric::{
    self, cross, emission_at, fly, medium_after, positive, Flight, Throughput, MAX_CROSSINGS,
};
use crate::math::sobol::Sampler;
use crate::math::spawn::Spot;
use crate::math::{Ray, Rgb, Vec3};
use crate::transport::spectral::Colours;
use crate::transport::{Context, RayStats};

/// Where a random walk starts: the ray leaving a subpath's last vertex, with throughput
/// `beta` (and channel density ratios `r_u`) and solid-angle density `pdf` for its direction
/// (from a point at infinity, the density over the plane it crosses); the walk adds at most
/// `max` more vertices, carrying `mode`.
pub(super) struct WalkStart {
    pub ray: Ray,
    pub beta: Rgb,
    pub r_u: Rgb,
    pub pdf: f32,
    pub max: u32,
    pub mode: Transport,
}

/// What a walk through a scene with media carries: the hero channel whose coefficients draw
/// the free flights, the medium the walk starts in, and, for camera walks, the emission of
/// media met on the way (which no light subpath can start from, so it has one strategy and
/// weight 1), gathered up to `max_depth` bounces.
pub(super) struct Media {
    pub hero: usize,
    pub medium: Option<u32>,
    pub gather_emission: bool,
    pub max_depth: u32,
    pub emitted: Rgb,
}

/// Extends `path` by a random walk from `start`; `media` is `None` in a scene without media.
/// The vertices' BSDFs and emission are as `colours` gives them.
pub(super) fn random_walk<'a>(
    ctx: &Context<'a>,
    start: WalkStart,
    path: &mut Vec<Vertex<'a>>,
    sampler: &mut Sampler,
    stats: &mut RayStats,
    mut media: Option<&mut Media>,
    colours: &mut impl Colours,
) {
    let WalkStart {
        mut ray,
        beta,
        r_u,
        mut pdf,
        max,
        mode,
    } = start;
    let mut medium = media.as_ref().and_then(|m| m.medium);
    let mut tp = Throughput {
        beta,
        r_u,
        r_l: Rgb::ONE,
    };
    let mut bounces = 0;
    let mut crossings = 0;
    while bounces < max {
        let hit = ctx.intersect(&ray, stats);
        if let (Some(m), Some(media)) = (medium, media.as_deref_mut()) {
            let hero = media.hero;
            let model = ctx.scene.media[m as usize].model();
            let emits = media.gather_emission && model.emits() && bounces < media.max_depth;
            let t_max = hit.as_ref().map_or(f32::INFINITY, |sp| sp.t);
            let mut emitted = Rgb::ZERO;
            let flight = colours.medium(model, |model| {
                fly(
                    model,
                    &ray,
                    t_max,
                    (hero, &mut *sampler),
                    &mut tp,
                    &mut |c, path| {
                        if emits {
                            emitted += emission_at(c, path, hero);
                        }
                    },
                )
            });
            media.emitted += emitted;
            match flight {
                Flight::Ended => break,
                Flight::Crossed => {}
                Flight::Scattered { p, g } => {
                    let at = Spot::exact(p);
                    let mut v = Vertex::new(Kind::Medium { g }, at, tp.beta);
                    v.r_u = tp.r_u;
                    v.medium = medium;
                    let prev = path.last().expect("a walk starts from a vertex");
                    v.pdf_fwd = prev.area_density(pdf, &v);
                    path.push(v);
                    bounces += 1;
                    if bounces >= max {
                        break;
                    }
                    let wo = -ray.dir.normalize();
                    let (wi, pdf_phase) = phase::sample_hg(wo, g, sampler.next_2d());
                    if !positive(pdf_phase) {
                        break;
                    }
                    // The phase function is its own density, and symmetric: the throughput
                    // keeps its value and the reverse density is the forward one.
                    pdf = pdf_phase;
                    let n = path.len();
                    let (cur, prev) = (path[n - 1], path[n - 2]);
                    path[n - 2].pdf_rev = cur.area_density(pdf_phase, &prev);
                    ray = at.spawn(wi).at_time(ray.time);
                    if !russian_roulette(&mut tp, bounces, sampler) {
                        break;
                    }
                    continue;
                }
            }
        }
        let Some(sp) = hit else {
            if let (Transport::Radiance, Some(light)) = (mode, ctx.lights.background_light()) {
                // A camera subpath that leaves the scene ends at the background, at infinity.
                let dir = ray.dir.normalize();
                let at = Spot {
                    p: ray.origin + dir,
                    error: Vec3::ZERO,
                    n: -dir,
                };
                let kind = Kind::Infinite {
                    light: Some(light),
                    delta: false,
                };
                let mut v = Vertex::new(kind, at, tp.beta);
                v.emission = colours.emission(ctx.lights.background_radiance(dir), || None);
                v.r_u = tp.r_u;
                v.medium = medium;
                let prev = path.last().expect("a walk starts from a vertex");
                v.pdf_fwd = prev.area_density(pdf, &v);
                path.push(v);
            }
            break;
        };
        let m = &ctx.scene.materials[sp.material];
        if media.is_some() && m.is_interface() {
            // A medium's boundary: no vertex, the ray goes on into the medium beyond.
            crossings += 1;
            if crossings > MAX_CROSSINGS {
                break;
            }
            (ray, medium) = cross(ctx, &sp, &ray, medium);
            continue;
        }
        let wo = -ray.dir;
        let bsdf = colours.bsdf(m.bsdf(&sp, wo));
        let mut v = Vertex::new(Kind::Surface, sp.spot(), tp.beta);
        v.bsdf = Some(bsdf);
        v.r_u = tp.r_u;
        v.medium = medium;
        if media.is_some() {
            v.interface = ctx.scene.placed_shape(&sp).shape.media;
        }
        if m.is_emissive() {
            v.emission =
                colours.emission(m.emission_at(sp.p, sp.uv, sp.ng), || m.emission_spectrum);
            v.light = sp.world_shape().and_then(|s| ctx.lights.light_of_shape(s));
        }
        let prev = path.last().expect("a walk starts from a vertex");
        v.pdf_fwd = prev.area_density(pdf, &v);
        path.push(v);
        bounces += 1;
        if bounces >= max {
            break;
        }
        let u = sampler.next_2d();
        let Some(bs) = bsdf.sample(wo, u.x, sampler.next_2d(), mode) else {
            break;
        };
        let n = path.len();
        let mut pdf_rev = bsdf.pdf(bs.wi, wo);
        pdf = bs.pdf;
        if bs.delta {
            path[n - 1].delta = true;
            pdf = 0.0;
            pdf_rev = 0.0;
        }
        tp.beta *= bs.weight;
        let (cur, prev) = (path[n - 1], path[n - 2]);
        path[n - 2].pdf_rev = cur.area_density(pdf_rev, &prev);
        if media.is_some() {
            medium = medium_after(ctx, &sp, bs.wi, medium);
        }
        ray = sp.spawn(bs.wi);
        if tp.beta == Rgb::ZERO || !russian_roulette(&mut tp, bounces, sampler) {
            break;
        }
    }
}

/// Russian roulette from [`RR_START_DEPTH`] bounces on, by the throughput over the path's
/// average channel density ratio (the throughput alone without media). It keeps long
/// subpaths rare; the MIS weights need not know about it (they still sum to one over the
/// strategies of a path).
fn russian_roulette(tp: &mut Throughput, bounces: u32, sampler: &mut Sampler) -> bool {
    volumetric::russian_roulette(&mut tp.beta, tp.r_u, bounces >= RR_START_DEPTH, sampler)
}
