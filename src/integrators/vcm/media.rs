//! What vertex connection and merging does in a scene with participating media: a subpath's
//! segment to its next vertex (a free flight by delta tracking, medium boundaries crossed
//! without a vertex, the medium's emission gathered on the way), the scatterer at a vertex
//! (a surface's BSDF or a medium's phase function), and the segment between two vertices
//! (its transmittance by ratio tracking) — the volumetric path tracer's pieces, in
//! `integrators::volumetric`.
//!
//! Every segment also gives its *grey transmittance* T̃ = exp(−τ̄), τ̄ the majorant's
//! optical depth along it averaged over the channels: the transmittance the weights use in
//! every strategy's density (see the module doc of `vcm`). It is a function of the
//! segment alone, the same whichever subpath sampled the segment or connected across it.

use super::mis::{Subpath, Weights};
use crate::bsdf::{phase, Bsdf, LambertianFrom, Transport};
use crate::integrators::volumetric::{
    average, cross, emission_at, fly, grey_depth, positive, transmittance_and_depth, Flight,
    Throughput, MAX_CROSSINGS,
};
use crate::math::sobol::Sampler;
use crate::math::spawn::Spot;
use crate::math::{Ray, Rgb, Rng, Vec3};
use crate::scene::media::MediumInterface;
use crate::scene::SurfacePoint;
use crate::transport::spectral::RgbColours;
use crate::transport::{Context, RayStats};

/// A grey transmittance from an optical depth, kept above a floor so that the weights'
/// quotients stay finite.
pub(super) fn grey(depth: f32) -> f32 {
    (-depth).exp().max(1e-20)
}

/// A subpath's spectral sampling in a scene with media: the channel whose coefficients
/// draw its free flights and the stream of its connections' ratio tracking.
pub(super) struct Spectral {
    pub hero: usize,
    pub rng: Rng,
}

/// What scatters at a vertex.
#[derive(Clone, Copy, Debug)]
pub(super) enum Scatter<'a> {
    Surface(Bsdf<'a>),
    /// A point in a medium, with its Henyey–Greenstein asymmetry.
    Medium {
        g: f32,
    },
}

impl Scatter<'_> {
    /// The scatterer seen from `wo` if it is a Lambertian surface.
    #[inline(always)]
    pub fn lambertian_from(&self, wo: Vec3) -> Option<LambertianFrom> {
        match self {
            Scatter::Surface(b) => LambertianFrom::of(b, wo),
            Scatter::Medium { .. } => None,
        }
    }

    /// f·|cos| from `wo` to `wi` (a phase function's value, which has no cosine), the
    /// solid-angle density of sampling `wi` from `wo` and the reverse one (of `wo` from
    /// `wi`), the directions taken to the shading frame once.
    #[inline(always)]
    pub fn eval_and_pdfs(&self, wo: Vec3, wi: Vec3, mode: Transport) -> (Rgb, f32, f32) {
        match self {
            Scatter::Surface(b) => b.eval_and_pdfs(wo, wi, mode),
            Scatter::Medium { g } => {
                let p = phase::hg(wo, wi, *g);
                (Rgb::splat(p), p, p)
            }
        }
    }

    /// |cos| between unit `w` and the geometric normal `n` (1 in a medium: a point's
    /// density over volume has no cosine).
    pub fn cos(&self, n: Vec3, w: Vec3) -> f32 {
        match self {
            Scatter::Surface(_) => n.dot(w).abs(),
            Scatter::Medium { .. } => 1.0,
        }
    }

    /// Whether the techniques at a vertex apply: not at a purely specular surface.
    pub fn connectible(&self) -> bool {
        match self {
            Scatter::Surface(b) => b.has_non_delta(),
            Scatter::Medium { .. } => true,
        }
    }

    /// Whether merges happen at the vertex: at surfaces only.
    pub fn mergeable(&self) -> bool {
        matches!(self, Scatter::Surface(_))
    }
}

/// What a subpath scattered at a vertex: the vertex's point and scatterer, the surface
/// point when it is on a surface, the media around it and the direction it was reached
/// from (`wo`, pointing back).
pub(super) struct Leaving<'s, 'a> {
    pub at: Spot,
    pub scatter: &'s Scatter<'a>,
    pub sp: Option<&'s SurfacePoint>,
    pub around: Around,
    pub wo: Vec3,
}

/// The ray a subpath leaves the vertex `v` along, drawn from its BSDF for `mode` or its
/// phase function, with `path` updated (`Subpath::bounce`, `Subpath::bounce_in_medium`) and
/// `medium` set to the one the ray starts in; `None` where the subpath ends.
pub(super) fn leave(
    path: &mut Subpath,
    w: &Weights,
    v: Leaving,
    (mode, media): (Transport, bool),
    medium: &mut Option<u32>,
    sampler: &mut Sampler,
) -> Option<Ray> {
    match (v.scatter, v.sp) {
        (Scatter::Surface(bsdf), Some(sp)) => {
            let wi = path.bounce(w, (bsdf, v.wo, v.at.n), (mode, media), sampler)?;
            if media {
                *medium = v.around.towards(wi, v.at.n);
            }
            Some(sp.spawn(wi))
        }
        (Scatter::Medium { g }, _) => path
            .bounce_in_medium(w, (*g, v.wo), sampler)
            .map(|wi| v.at.spawn(wi)),
        _ => None,
    }
}

/// The media around a vertex: the one its subpath reached it in and, at a surface that
/// bounds media, its shape's interface.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Around {
    pub medium: Option<u32>,
    pub interface: Option<MediumInterface>,
}

impl Around {
    /// The medium a segment leaving the vertex (geometric normal `n`) along `w` starts in.
    pub fn towards(&self, w: Vec3, n: Vec3) -> Option<u32> {
        match self.interface {
            Some(i) => i.towards(w, n),
            None => self.medium,
        }
    }

    /// At surface point `sp`, reached in `medium`.
    pub fn surface(ctx: &Context, sp: &SurfacePoint, medium: Option<u32>) -> Around {
        Around {
            medium,
            interface: ctx.scene.placed_shape(sp).shape.media,
        }
    }
}

/// Where a subpath's next segment ends.
pub(super) enum Step {
    /// A surface that is not a medium boundary.
    Surface(SurfacePoint),
    /// A scattering point in a medium.
    Medium { p: Vec3, g: f32 },
    /// Nothing: the subpath left the scene.
    Escaped,
    /// Absorbed, or given up.
    Ended,
}

/// The segment from `ray`'s origin to the subpath's next vertex: without media the closest
/// surface; with them (`spectral`), free flights by the hero channel through the media on
/// the way, `medium` updated at each boundary crossed and `path`'s throughput and channel
/// ratios at each collision. `glow`: the emission of the media met, weighted as the one
/// strategy that finds it. Returns where it ends and its grey transmittance.
pub(super) fn advance(
    ctx: &Context,
    ray: &Ray,
    medium: &mut Option<u32>,
    spectral: Option<&Spectral>,
    path: &mut Subpath,
    (sampler, stats): (&mut Sampler, &mut RayStats),
    mut glow: Option<&mut Rgb>,
) -> (Step, f32) {
    let Some(spectral) = spectral else {
        return match ctx.intersect(ray, stats) {
            Some(sp) => (Step::Surface(sp), 1.0),
            None => (Step::Escaped, 1.0),
        };
    };
    let hero = spectral.hero;
    let mut ray = *ray;
    let mut depth = 0.0;
    for _ in 0..=MAX_CROSSINGS {
        let hit = ctx.intersect(&ray, stats);
        if let Some(m) = *medium {
            let model = ctx.scene.media[m as usize].model();
            let emits = glow.is_some() && model.emits();
            let t_max = hit.as_ref().map_or(f32::INFINITY, |sp| sp.t);
            let mut tp = Throughput {
                beta: path.beta,
                r_u: path.r_u,
                r_l: Rgb::ONE,
            };
            let mut emitted = Rgb::ZERO;
            let flight = fly(
                model,
                &ray,
                t_max,
                (hero, &mut *sampler),
                &mut tp,
                &mut |c, tp| {
                    if emits {
                        emitted += emission_at(c, tp, hero);
                    }
                },
            );
            if let Some(glow) = glow.as_deref_mut() {
                *glow += emitted;
            }
            (path.beta, path.r_u) = (tp.beta, tp.r_u);
            match flight {
                Flight::Ended => return (Step::Ended, 0.0),
                Flight::Scattered { p, g } => {
                    let t = (p - ray.origin).dot(ray.dir) / ray.dir.length_squared();
                    depth += grey_depth(model, &ray, t);
                    return (Step::Medium { p, g }, grey(depth));
                }
                Flight::Crossed => depth += grey_depth(model, &ray, t_max),
            }
        }
        let Some(sp) = hit else {
            return (Step::Escaped, grey(depth));
        };
        if !ctx.scene.materials[sp.material].is_interface() {
            return (Step::Surface(sp), grey(depth));
        }
        // A medium's boundary: no vertex, the ray goes on into the medium beyond.
        (ray, *medium) = cross(ctx, &sp, &ray, *medium);
    }
    (Step::Ended, 0.0)
}

/// Where a connection ends: a point, or infinitely far along a direction.
#[derive(Clone, Copy)]
pub(super) enum End<'s> {
    At(&'s Spot),
    Towards(Vec3),
}

/// The segment from `from` (starting in `medium`) to `to`, for a subpath with channel
/// ratios `r_u`: what passes (1 without media; through media the ratio-tracked
/// transmittance over the average of the channel densities of the subpath and the
/// segment) and its grey transmittance; `None` when something blocks it.
pub(super) fn link(
    ctx: &Context,
    (from, medium): (&Spot, Option<u32>),
    to: End,
    r_u: Rgb,
    spectral: Option<&mut Spectral>,
    stats: &mut RayStats,
) -> Option<(Rgb, f32)> {
    let Some(Spectral { hero, rng }) = spectral else {
        let blocked = match to {
            End::At(to) => ctx.occluded(&from.spawn_to(to), stats),
            End::Towards(dir) => ctx.intersect(&from.spawn(dir), stats).is_some(),
        };
        return (!blocked).then_some((Rgb::ONE, 1.0));
    };
    let to = match to {
        End::At(to) => Ok(to),
        End::Towards(dir) => Err(dir),
    };
    let (t, _, r_l, depth) = transmittance_and_depth(
        ctx,
        (*from, 0.0),
        medium,
        to,
        (*hero, &RgbColours),
        rng,
        stats,
    )?;
    let density = average(r_u * r_l);
    positive(density).then(|| (t / density, grey(depth)))
}
