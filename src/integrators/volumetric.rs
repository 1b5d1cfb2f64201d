//! The path tracer through participating media (pbrt-v4's `VolPathIntegrator`): free
//! flights by delta tracking against each medium's majorant, next-event estimation through
//! media and medium boundaries with ratio tracking, and emission inside media.
//!
//! Chromatic media (coefficients that differ by channel) are handled without bias by
//! spectral multiple importance sampling in RGB: each path draws its distances by one
//! channel, its hero, chosen at random, and every estimate is divided by the average over
//! the three channels of the densities with which they would have drawn the same path. The
//! ratios `r_u` (the path's densities, each channel's over the hero's) and `r_l` (the same
//! path's densities had its last vertex been a light sample) carry those averages, as in
//! pbrt-v4, and also give the balance heuristic between light and BSDF sampling.

use crate::bsdf::{phase, Bsdf, Transport};
use crate::math::sobol::Sampler;
use crate::math::spawn::Spot;
use crate::math::{Ray, Rgb, Rng, Vec3};
use crate::scene::media::tracking::{sample_majorant, sample_majorant_from, Collision, Uniforms};
use crate::scene::media::MediumModel;
use crate::scene::SurfacePoint;
use crate::transport::spectral::Colours;
use crate::transport::{Context, RayStats};

/// Surfaces a ray may cross without scattering (medium boundaries) before it is given up:
/// a bound that only a malformed scene reaches.
pub(super) const MAX_CROSSINGS: u32 = 256;

/// Whether `x` is a number above 0 (not NaN).
pub(super) fn positive(x: f32) -> bool {
    x > 0.0
}

pub(super) fn average(v: Rgb) -> f32 {
    (v.x + v.y + v.z) / 3.0
}

/// Where a path scatters: a surface's BSDF or a medium's phase function.
pub(super) enum Scatterer<'a> {
    Surface(&'a Bsdf<'a>),
    Medium { g: f32 },
}

impl Scatterer<'_> {
    /// f·|cos| (a phase function has no cosine) and the density of sampling `wi`.
    pub(super) fn eval(&self, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        match self {
            Scatterer::Surface(bsdf) => bsdf.eval_and_pdf(wo, wi, Transport::Radiance),
            Scatterer::Medium { g } => {
                let p = phase::hg(wo, wi, *g);
                (Rgb::splat(p), p)
            }
        }
    }
}

/// The channel whose coefficients draw a path's free flights, chosen uniformly: the spectral
/// MIS over channels counts on each being the hero a third of the time.
pub(super) fn hero_channel(sampler: &mut Sampler) -> usize {
    ((sampler.next_1d() * 3.0) as usize).min(2)
}

/// The ray going on through a medium boundary at `sp` unchanged, and the medium it enters.
pub(super) fn cross(
    ctx: &Context,
    sp: &SurfacePoint,
    ray: &Ray,
    medium: Option<u32>,
) -> (Ray, Option<u32>) {
    (sp.spawn(ray.dir), medium_after(ctx, sp, ray.dir, medium))
}

/// The medium a ray leaving surface point `sp` along `w` travels in, coming from `current`.
pub(super) fn medium_after(
    ctx: &Context,
    sp: &SurfacePoint,
    w: Vec3,
    current: Option<u32>,
) -> Option<u32> {
    match ctx.scene.placed_shape(sp).shape.media {
        Some(interface) => interface.towards(w, sp.ng),
        None => current,
    }
}

/// How long paths are: at most `max_depth` bounces, Russian roulette from `rr_start` on.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Lengths {
    pub max_depth: u32,
    pub rr_start: u32,
}

/// What light a path estimate gathers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Gathered {
    /// All of it: lights, emitting surfaces, the background and emitting media.
    All,
    /// Only what emitting media send (the rest found by other means: SPPM's photons leave
    /// the lights alone, so it traces the media's light as paths).
    MediaEmission,
}

/// One path's estimate of the radiance along `camera_ray`, with the scene's colours (and
/// its media's) as `colours` gives them.
pub(crate) fn radiance<C: Colours>(
    ctx: &Context,
    camera_ray: &Ray,
    lengths: Lengths,
    sampler: &mut Sampler,
    stats: &mut RayStats,
    colours: &mut C,
) -> Rgb {
    gathering(
        ctx,
        camera_ray,
        (lengths, Gathered::All),
        sampler,
        stats,
        colours,
    )
}

/// [`radiance`], gathering what `gathered` says.
pub(crate) fn gathering<C: Colours>(
    ctx: &Context,
    camera_ray: &Ray,
    (
        Lengths {
            max_depth,
            rr_start,
        },
        gathered,
    ): (Lengths, Gathered),
    sampler: &mut Sampler,
    stats: &mut RayStats,
    colours: &mut C,
) -> Rgb {
    let all = gathered == Gathered::All;
    let scene = ctx.scene;
    let lights = &ctx.lights;
    let hero = hero_channel(sampler);
    let mut radiance = Rgb::ZERO;
    let mut beta = Rgb::ONE;
    let mut r_u = Rgb::ONE;
    let mut r_l = Rgb::ONE;
    let mut specular = true;
    let mut ray = *camera_ray;
    let mut medium = scene.camera_medium;
    let mut prev_p = ray.origin;
    let mut depth = 0;
    let mut crossings = 0;
    let mut first = true;
    loop {
        let hit = if first {
            ctx.intersect_at_depth(&ray, 0, stats)
        } else {
            ctx.intersect(&ray, stats)
        };
        first = false;
        if let Some(m) = medium {
            let model = scene.media[m as usize].model();
            let emits = model.emits() && depth < max_depth;
            let t_max = hit.as_ref().map_or(f32::INFINITY, |sp| sp.t);
            let mut path = Throughput { beta, r_u, r_l };
            let flight = colours.medium(model, |model| {
                fly(
                    model,
                    &ray,
                    t_max,
                    (hero, &mut *sampler),
                    &mut path,
                    &mut |c, path| {
                        if emits {
                            radiance += emission_at(c, path, hero);
                        }
                    },
                )
            });
            Throughput { beta, r_u, r_l } = path;
            let scatter = match flight {
                Flight::Ended => break,
                Flight::Scattered { p, g } => Some((p, g)),
                Flight::Crossed => None,
            };
            if let Some((p, g)) = scatter {
                if depth >= max_depth {
                    break;
                }
                depth += 1;
                let wo = -ray.dir.normalize();
                let at = Spot::exact(p);
                let scatterer = Scatterer::Medium { g };
                radiance += if !all {
                    Rgb::ZERO
                } else {
                    sample_light(
                        ctx,
                        &scatterer,
                        wo,
                        &at,
                        &|_| medium,
                        ray.time,
                        (beta, r_u, hero),
                        (sampler, &*colours),
                        stats,
                    )
                };
                let (wi, pdf) = phase::sample_hg(wo, g, sampler.next_2d());
                if !positive(pdf) {
                    break;
                }
                // The phase function's value is its density: beta keeps its value.
                r_l = r_u / pdf;
                specular = false;
                prev_p = p;
                ray = at.spawn(wi).at_time(ray.time);
                if !russian_roulette(&mut beta, r_u, depth >= rr_start, sampler) {
                    break;
                }
                continue;
            }
        }

        let Some(sp) = hit else {
            if let Some(bg) = lights.background_light().filter(|_| all) {
                let le = colours.emission(lights.background_radiance(ray.dir), || None);
                radiance += if specular {
                    beta * le / average(r_u)
                } else {
                    let p_l = lights.pdf_li(bg, prev_p, prev_p + ray.dir, Vec3::ZERO);
                    beta * le / average(r_u + r_l * p_l)
                };
            }
            break;
        };
        let m = &scene.materials[sp.material];
        let wo = -ray.dir;
        if all && m.emits_towards(wo, sp.ng) {
            let le = colours.emission(m.emission_at(sp.p, sp.uv, sp.ng), || m.emission_spectrum);
            radiance += match sp.world_shape().and_then(|s| lights.light_of_shape(s)) {
                Some(l) if !specular => {
                    let p_l = lights.pdf_li(l, prev_p, sp.p, sp.ng);
                    beta * le / average(r_u + r_l * p_l)
                }
                _ => beta * le / average(r_u),
            };
        }
        if m.is_interface() {
            // A medium's boundary: the ray goes on, into the medium on the far side.
            crossings += 1;
            if crossings > MAX_CROSSINGS {
                break;
            }
            (ray, medium) = cross(ctx, &sp, &ray, medium);
            continue;
        }
        if depth >= max_depth {
            break;
        }
        depth += 1;
        let bsdf = colours.bsdf(m.bsdf(&sp, wo));
        let wo = wo.normalize();
        if all && bsdf.has_non_delta() {
            let current = medium;
            radiance += sample_light(
                ctx,
                &Scatterer::Surface(&bsdf),
                wo,
                &sp.spot(),
                &|w| medium_after(ctx, &sp, w, current),
                sp.time,
                (beta, r_u, hero),
                (sampler, &*colours),
                stats,
            );
        } else {
            // The same dimensions whether or not a light is sampled.
            sampler.next_1d();
            sampler.next_2d();
            sampler.next_1d();
        }
        let u_lobe = sampler.next_1d();
        let Some(bs) = bsdf.sample(wo, u_lobe, sampler.next_2d(), Transport::Radiance) else {
            break;
        };
        beta *= bs.weight;
        r_l = r_u / bs.pdf;
        specular = bs.delta;
        prev_p = sp.p;
        medium = medium_after(ctx, &sp, bs.wi, medium);
        ray = sp.spawn(bs.wi);
        if !russian_roulette(&mut beta, r_u, depth >= rr_start, sampler) {
            break;
        }
    }
    radiance
}

/// A path's throughput and its density ratios (pbrt-v4's β, r_u, r_l): each channel's
/// density of the path over the hero's, by unidirectional sampling (`r_u`) and had its last
/// vertex been a light sample (`r_l`).
#[derive(Clone, Copy, Debug)]
pub(super) struct Throughput {
    pub beta: Rgb,
    pub r_u: Rgb,
    pub r_l: Rgb,
}

/// The emission a path meets at a tentative collision `c` of its free flight, over its
/// channels' densities of reaching it (`path` as it arrives there, sampled by `hero`).
pub(super) fn emission_at(c: &Collision, path: &Throughput, hero: usize) -> Rgb {
    let pdf_hero = c.sigma_maj[hero] * c.t_maj[hero];
    let r_e = path.r_u * c.sigma_maj * c.t_maj / pdf_hero;
    let le = c.point.sigma_a * c.point.le;
    if average(r_e) > 0.0 && le != Rgb::ZERO {
        path.beta * c.t_maj / pdf_hero * le / average(r_e)
    } else {
        Rgb::ZERO
    }
}

/// How a free flight through a medium ended.
pub(super) enum Flight {
    /// Absorbed, or its throughput became zero: the path ends.
    Ended,
    /// Scattered at `p` by a phase function of asymmetry `g`.
    Scattered { p: Vec3, g: f32 },
    /// It reached the end of the ray (the surface hit, or nothing).
    Crossed,
}

/// One free flight along `ray` up to `t_max` in `medium` by delta tracking, sampled by the
/// `hero` channel: at each tentative collision, absorption, scattering or a null collision
/// by the hero's coefficients; `path` takes the weights, and `at` sees each collision first
/// (with the path as it arrives there), for the emission of the medium. The first collision
/// is stratified over the pixel's samples (the next two dimensions of `sampler`), the rest
/// drawn from the sample's stream.
pub(super) fn fly(
    medium: &dyn MediumModel,
    ray: &Ray,
    t_max: f32,
    (hero, sampler): (usize, &mut Sampler),
    path: &mut Throughput,
    at: &mut dyn FnMut(&Collision, &Throughput),
) -> Flight {
    let u = sampler.next_2d();
    let mut rng = sampler.stream();
    let rng = &mut Uniforms {
        given: &[u.x, u.y],
        rng: &mut rng,
    };
    let mut flight = Flight::Crossed;
    let t_maj = sample_majorant_from(medium, ray, t_max, hero, rng, &mut |c| {
        at(c, path);
        let p_absorb = c.point.sigma_a[hero] / c.sigma_maj[hero];
        let p_scatter = c.point.sigma_s[hero] / c.sigma_maj[hero];
        if c.u < p_absorb {
            flight = Flight::Ended;
            false
        } else if c.u < p_absorb + p_scatter {
            let pdf = c.t_maj[hero] * c.point.sigma_s[hero];
            path.beta *= c.t_maj * c.point.sigma_s / pdf;
            path.r_u *= c.t_maj * c.point.sigma_s / pdf;
            flight = Flight::Scattered {
                p: c.p,
                g: c.point.g,
            };
            false
        } else {
            let sigma_n = (c.sigma_maj - c.point.sigma_a - c.point.sigma_s).max(Rgb::ZERO);
            let pdf = c.t_maj[hero] * sigma_n[hero];
            if pdf <= 0.0 {
                path.beta = Rgb::ZERO;
            } else {
                path.beta *= c.t_maj * sigma_n / pdf;
                path.r_u *= c.t_maj * sigma_n / pdf;
                path.r_l *= c.t_maj * c.sigma_maj / pdf;
            }
            path.beta != Rgb::ZERO && path.r_u != Rgb::ZERO
        }
    });
    if matches!(flight, Flight::Crossed) {
        let t = t_maj[hero];
        if positive(t) {
            path.beta *= t_maj / t;
            path.r_u *= t_maj / t;
            path.r_l *= t_maj / t;
        } else {
            flight = Flight::Ended;
        }
    }
    if path.beta == Rgb::ZERO || path.r_u == Rgb::ZERO || !path.beta.is_finite() {
        return Flight::Ended;
    }
    flight
}

/// Russian roulette once `on`, by the throughput over the path's average density ratio: the
/// path survives with that (at most 1) and is reweighted.
pub(super) fn russian_roulette(beta: &mut Rgb, r_u: Rgb, on: bool, sampler: &mut Sampler) -> bool {
    if !on {
        return true;
    }
    let u = sampler.next_1d();
    let q = (*beta / average(r_u)).max_element().min(1.0);
    if !positive(q - u) {
        return false;
    }
    *beta /= q;
    true
}

/// Next-event estimation from a scattering point `at` (a surface's, or one in a medium):
/// one light sample, its transmittance through media and medium boundaries by ratio
/// tracking, weighted against sampling the scatterer by the balance heuristic over the
/// path's channel densities. `start` gives the medium the shadow ray starts in, by its
/// direction; `path` is the throughput, its density ratios and its hero channel; the
/// light's colour and the media's are as `colours` gives them.
#[allow(clippy::too_many_arguments)]
pub(super) fn sample_light(
    ctx: &Context,
    scatterer: &Scatterer,
    wo: Vec3,
    at: &Spot,
    start: &dyn Fn(Vec3) -> Option<u32>,
    time: f32,
    (beta, r_path, hero): (Rgb, Rgb, usize),
    (sampler, colours): (&mut Sampler, &impl Colours),
    stats: &mut RayStats,
) -> Rgb {
    let u_choice = sampler.next_1d();
    let u_light = sampler.next_2d();
    let mut rng = sampler.stream();
    let Some(ls) = ctx.lights.sample_li(at.p, u_choice, u_light) else {
        return Rgb::ZERO;
    };
    if !positive(ls.pdf) {
        return Rgb::ZERO;
    }
    let (f, scatter_pdf) = scatterer.eval(wo, ls.wi);
    if f == Rgb::ZERO {
        return Rgb::ZERO;
    }
    let Some((t_ray, r_u, r_l)) = transmittance(
        ctx,
        (*at, time),
        start(ls.wi),
        &ls.spot(),
        (hero, colours),
        &mut rng,
        stats,
    ) else {
        return Rgb::ZERO;
    };
    let le = colours.emission(ls.radiance, || {
        ctx.lights.spectrum_chosen_at(at.p, u_choice)
    });
    let r_l = r_path * r_l * ls.pdf;
    let r_u = r_path * r_u * scatter_pdf;
    let denominator = if ls.delta {
        average(r_l)
    } else {
        average(r_l + r_u)
    };
    if !positive(denominator) {
        return Rgb::ZERO;
    }
    beta * f * t_ray * le / denominator
}

/// The transmittance from `from` (in `medium`) to `to`, through medium boundaries, by
/// ratio tracking with Russian roulette where it becomes small, and the segment's density
/// ratios (`T`, `r_u`, `r_l`), at shutter time `time`; `None` when a surface blocks it or
/// the roulette ends it.
pub(super) fn transmittance(
    ctx: &Context,
    from: (Spot, f32),
    medium: Option<u32>,
    to: &Spot,
    hero: (usize, &impl Colours),
    rng: &mut Rng,
    stats: &mut RayStats,
) -> Option<(Rgb, Rgb, Rgb)> {
    track(
        ctx,
        from,
        medium,
        Towards::Spot(to),
        (hero, rng),
        stats,
        None,
    )
}

/// As [`transmittance`] (to `to`, or along `to`'s direction to infinity), with the
/// segment's majorant optical depth averaged over the channels (see [`grey_depth`]) as a
/// fourth value.
pub(super) fn transmittance_and_depth(
    ctx: &Context,
    from: (Spot, f32),
    medium: Option<u32>,
    to: Result<&Spot, Vec3>,
    hero: (usize, &impl Colours),
    rng: &mut Rng,
    stats: &mut RayStats,
) -> Option<(Rgb, Rgb, Rgb, f32)> {
    let to = match to {
        Ok(spot) => Towards::Spot(spot),
        Err(dir) => Towards::Infinity(dir),
    };
    let mut depth = 0.0;
    let (t, r_u, r_l) = track(ctx, from, medium, to, (hero, rng), stats, Some(&mut depth))?;
    Some((t, r_u, r_l, depth))
}

/// The optical depth of `medium`'s majorant along `ray` up to `t_end`, averaged over the
/// channels: a function of the segment alone (no random numbers), the exact optical depth
/// of a grey homogeneous medium.
pub(super) fn grey_depth(medium: &dyn MediumModel, ray: &Ray, t_end: f32) -> f32 {
    let mut depth = 0.0f32;
    medium.segments(ray, t_end, &mut |s| {
        let sigma = average(s.sigma_maj);
        if sigma > 0.0 {
            depth += sigma * (s.t1.min(t_end) - s.t0.max(0.0)).max(0.0);
        }
        true
    });
    depth
}

/// As [`transmittance`], from `from` along `dir` to infinity (what reaches a point of light
/// from infinity, such as the background, through the media on the way).
pub(super) fn transmittance_to_infinity(
    ctx: &Context,
    from: (Spot, f32),
    medium: Option<u32>,
    dir: Vec3,
    hero: (usize, &impl Colours),
    rng: &mut Rng,
    stats: &mut RayStats,
) -> Option<(Rgb, Rgb, Rgb)> {
    track(
        ctx,
        from,
        medium,
        Towards::Infinity(dir),
        (hero, rng),
        stats,
        None,
    )
}

/// Where a transmittance is tracked to.
#[derive(Clone, Copy)]
enum Towards<'a> {
    Spot(&'a Spot),
    Infinity(Vec3),
}

#[allow(clippy::too_many_arguments)]
fn track(
    ctx: &Context,
    (mut from, time): (Spot, f32),
    mut medium: Option<u32>,
    to: Towards,
    ((hero, colours), rng): ((usize, &impl Colours), &mut Rng),
    stats: &mut RayStats,
    mut depth: Option<&mut f32>,
) -> Option<(Rgb, Rgb, Rgb)> {
    let (mut t_ray, mut r_u, mut r_l) = (Rgb::ONE, Rgb::ONE, Rgb::ONE);
    for _ in 0..MAX_CROSSINGS {
        let (ray, t_far) = match to {
            Towards::Spot(to) => (from.spawn_to(to), 1.0),
            Towards::Infinity(dir) => (from.spawn(dir), f32::INFINITY),
        };
        let ray = ray.at_time(time);
        stats.shadow += 1;
        let hit = ctx.intersect(&ray, &mut RayStats::default());
        if let Some(sp) = &hit {
            if !ctx.scene.materials[sp.material].is_interface() {
                return None;
            }
        }
        if let Some(m) = medium {
            let t_end = hit.as_ref().map_or(t_far, |sp| sp.t);
            let model = ctx.scene.media[m as usize].model();
            let t_maj = colours.medium(model, |model| {
                if let Some(depth) = depth.as_deref_mut() {
                    *depth += grey_depth(model, &ray, t_end);
                }
                sample_majorant(model, &ray, t_end, hero, rng, &mut |c| {
                    let sigma_n = (c.sigma_maj - c.point.sigma_a - c.point.sigma_s).max(Rgb::ZERO);
                    let pdf = c.t_maj[hero] * c.sigma_maj[hero];
                    t_ray *= c.t_maj * sigma_n / pdf;
                    r_l *= c.t_maj * c.sigma_maj / pdf;
                    r_u *= c.t_maj * sigma_n / pdf;
                    let estimate = t_ray / average(r_l + r_u);
                    if estimate.max_element() < 0.05 {
                        if c.u < 0.75 {
                            t_ray = Rgb::ZERO;
                        } else {
                            t_ray /= 0.25;
                        }
                    }
                    t_ray != Rgb::ZERO
                })
            });
            let t = t_maj[hero];
            if t_ray == Rgb::ZERO || !positive(t) {
                return None;
            }
            t_ray *= t_maj / t;
            r_l *= t_maj / t;
            r_u *= t_maj / t;
        }
        let Some(sp) = hit else {
            return t_ray.is_finite().then_some((t_ray, r_u, r_l));
        };
        medium = medium_after(ctx, &sp, ray.dir, medium);
        from = sp.spot();
    }
    None
}
