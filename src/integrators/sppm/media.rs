//! SPPM through participating media (volumetric photon mapping, Jensen & Christensen 1998,
//! made progressive as Knaus & Zwicker 2011 do). Used only for scenes that have media; the
//! walks of scenes without media are `visible::trace` and `PhotonPass::photon`.
//!
//! Both walks fly through media as the volumetric path tracer does (delta tracking against
//! the majorant by a hero channel, the spectral MIS over channels in the ratios `r_u`, `r_l`;
//! medium boundaries crossed without a bounce) and take its helpers. A camera path stops at
//! its first scattering vertex, on a diffuse surface or in a medium: after next-event
//! estimation there it leaves a visible point (a surface's BSDF or the medium's phase
//! function) and takes one more flight, whose emitter, if it reaches one, completes the
//! direct light's MIS. A photon deposits at every scattering vertex after its first: at a
//! surface to the surface visible points whose radius holds it, in a medium to the medium
//! visible points whose sphere holds it. Both weigh by their own path's channel densities:
//! the camera path's throughput is β / avg(r_u), and a photon's power β / avg(r_u) of its
//! own hero channel's ratios.
//!
//! Neither walk gathers the emission of media: photons leave only the lights, so the
//! camera pass traces the media's light as paths of its own (`visible::CameraPass`).

use super::grid::HashGrid;
use super::visible::{CameraPath, VisiblePoint};
use crate::bsdf::{phase, Transport};
use crate::integrators::light::emission_start;
use crate::integrators::volumetric::{
    average, cross, fly, hero_channel, medium_after, positive, russian_roulette, sample_light,
    Flight, Scatterer, Throughput, MAX_CROSSINGS,
};
use crate::integrators::volumetric_light::{arrive_from_infinity, LightMedium};
use crate::math::sobol::Sampler;
use crate::math::spawn::Spot;
use crate::math::{Ray, Rgb, Vec3};
use crate::transport::spectral::RgbColours;
use crate::transport::{Context, RayStats};

/// Where a camera path scattered in a medium: the photons scattering within the pixel's
/// sphere around `p` are weighed by the phase function (asymmetry `g`) towards `wo` and by
/// `beta`, the path's throughput over the scattering coefficient σs at `p` (photons scatter
/// at a rate of σs times the fluence: their density in a ball is σs times the radiance's).
#[derive(Clone, Copy, Debug)]
pub(super) struct VolumePoint {
    pub p: Vec3,
    pub wo: Vec3,
    pub g: f32,
    pub beta: Rgb,
}

impl VolumePoint {
    /// What a photon carrying `power` and arriving from `wi` (pointing back where it came
    /// from) adds to the pixel: β_vp · p(wo, wi) · power.
    pub fn weigh(&self, wi: Vec3, power: Rgb) -> Rgb {
        self.beta * phase::hg(self.wo, wi, self.g) * power
    }
}

/// A flight through `medium` along `ray` up to `t_max`, its first collision by the next two
/// dimensions of `sampler`.
fn flight(
    ctx: &Context,
    medium: u32,
    ray: &Ray,
    t_max: f32,
    hero: usize,
    path: &mut Throughput,
    sampler: &mut Sampler,
) -> Flight {
    let model = ctx.scene.media[medium as usize].model();
    fly(model, ray, t_max, (hero, sampler), path, &mut |_, _| {})
}

/// The camera path along `camera_ray` through media: emission and direct light gathered on
/// the way, and its visible point, on a surface or in a medium.
pub(super) fn trace<'a>(
    ctx: &Context<'a>,
    camera_ray: &Ray,
    max_depth: u32,
    sampler: &mut Sampler,
    stats: &mut RayStats,
) -> CameraPath<'a> {
    let scene = ctx.scene;
    let lights = &ctx.lights;
    let hero = hero_channel(sampler);
    let mut ld = Rgb::ZERO;
    let mut visible = None;
    let mut in_medium = None;
    let mut path = Throughput {
        beta: Rgb::ONE,
        r_u: Rgb::ONE,
        r_l: Rgb::ONE,
    };
    let mut specular = true;
    let mut ray = *camera_ray;
    let mut medium = scene.camera_medium;
    let mut prev_p = ray.origin;
    let mut depth = 0;
    let mut crossings = 0;
    // Whether the visible point is left: the path then only looks for an emitter.
    let mut found = false;
    let mut first = true;
    loop {
        let hit = if first {
            ctx.intersect_at_depth(&ray, 0, stats)
        } else {
            ctx.intersect(&ray, stats)
        };
        first = false;
        if let Some(m) = medium {
            let t_max = hit.as_ref().map_or(f32::INFINITY, |sp| sp.t);
            match flight(ctx, m, &ray, t_max, hero, &mut path, sampler) {
                Flight::Ended => break,
                Flight::Crossed => {}
                Flight::Scattered { p, g } => {
                    if found || depth >= max_depth {
                        break;
                    }
                    depth += 1;
                    let wo = -ray.dir.normalize();
                    let at = Spot::exact(p);
                    ld += sample_light(
                        ctx,
                        &Scatterer::Medium { g },
                        wo,
                        &at,
                        &|_| medium,
                        ray.time,
                        (path.beta, path.r_u, hero),
                        (sampler, &RgbColours),
                        stats,
                    );
                    let sigma_s = scene.media[m as usize].model().at(p).sigma_s;
                    let per = |c: usize| match sigma_s[c] > 0.0 {
                        true => path.beta[c] / sigma_s[c],
                        false => 0.0,
                    };
                    in_medium = Some(VolumePoint {
                        p,
                        wo,
                        g,
                        beta: Rgb::new(per(0), per(1), per(2)) / average(path.r_u),
                    });
                    found = true;
                    let (wi, pdf) = phase::sample_hg(wo, g, sampler.next_2d());
                    if !positive(pdf) {
                        break;
                    }
                    path.r_l = path.r_u / pdf;
                    specular = false;
                    prev_p = p;
                    ray = at.spawn(wi).at_time(ray.time);
                    continue;
                }
            }
        }
        let Some(sp) = hit else {
            if let Some(bg) = lights.background_light() {
                let le = lights.background_radiance(ray.dir);
                ld += if specular {
                    path.beta * le / average(path.r_u)
                } else {
                    let p_l = lights.pdf_li(bg, prev_p, prev_p + ray.dir, Vec3::ZERO);
                    path.beta * le / average(path.r_u + path.r_l * p_l)
                };
            }
            break;
        };
        let m = &scene.materials[sp.material];
        let wo = -ray.dir;
        if m.emits_towards(wo, sp.ng) {
            let le = m.emission_at(sp.p, sp.uv, sp.ng);
            ld += match sp.world_shape().and_then(|s| lights.light_of_shape(s)) {
                Some(l) if !specular => {
                    let p_l = lights.pdf_li(l, prev_p, sp.p, sp.ng);
                    path.beta * le / average(path.r_u + path.r_l * p_l)
                }
                _ => path.beta * le / average(path.r_u),
            };
        }
        if m.is_interface() {
            crossings += 1;
            if crossings > MAX_CROSSINGS {
                break;
            }
            (ray, medium) = cross(ctx, &sp, &ray, medium);
            continue;
        }
        if found || depth >= max_depth {
            break;
        }
        depth += 1;
        let bsdf = m.bsdf(&sp, wo);
        let wo = wo.normalize();
        if bsdf.has_non_delta() {
            let current = medium;
            ld += sample_light(
                ctx,
                &Scatterer::Surface(&bsdf),
                wo,
                &sp.spot(),
                &|w| medium_after(ctx, &sp, w, current),
                sp.time,
                (path.beta, path.r_u, hero),
                (sampler, &RgbColours),
                stats,
            );
        }
        if bsdf.has_diffuse() || (bsdf.has_non_delta() && depth == max_depth) {
            visible = Some(VisiblePoint {
                p: sp.p,
                wo,
                bsdf,
                beta: path.beta / average(path.r_u),
            });
            found = true;
        }
        let u_lobe = sampler.next_1d();
        let Some(bs) = bsdf.sample(wo, u_lobe, sampler.next_2d(), Transport::Radiance) else {
            break;
        };
        path.beta *= bs.weight;
        path.r_l = path.r_u / bs.pdf;
        specular = bs.delta;
        prev_p = sp.p;
        medium = medium_after(ctx, &sp, bs.wi, medium);
        ray = sp.spawn(bs.wi);
        if !found && !russian_roulette(&mut path.beta, path.r_u, true, sampler) {
            break;
        }
    }
    let visible = visible.filter(|v: &VisiblePoint| v.beta.is_finite() && v.p.is_finite());
    let in_medium = in_medium.filter(|v: &VolumePoint| v.beta.is_finite() && v.p.is_finite());
    CameraPath {
        ld: if ld.is_finite() { ld } else { Rgb::ZERO },
        visible,
        in_medium,
    }
}

/// The visible points photons deposit to: on surfaces (`surface`, indices from 0) and in
/// media (`medium`, indices from `surface.len()`), each with its grid.
pub(super) struct Targets<'p, 'a> {
    pub surface_grid: &'p HashGrid,
    pub surface: &'p [VisiblePoint<'a>],
    pub medium_grid: &'p HashGrid,
    pub medium: &'p [VolumePoint],
}

/// One photon's path through media: deposits (visible point, β_vp · f · power) pushed to
/// `deposits`.
pub(super) fn photon(
    ctx: &Context,
    to: &Targets,
    max_depth: u32,
    sampler: &mut Sampler,
    stats: &mut RayStats,
    deposits: &mut Vec<(u32, Rgb)>,
) {
    let scene = ctx.scene;
    let hero = hero_channel(sampler);
    let u_choose = sampler.next_2d();
    let u_pos = sampler.next_2d();
    let u_dir = sampler.next_2d();
    let Some(es) = ctx.lights.sample_le(u_choose.x, u_pos, u_dir) else {
        return;
    };
    let light_medium = LightMedium::of(ctx, &es, u_pos, 0.0, stats);
    let (beta, mut ray) = emission_start(ctx, &es, 0.0);
    let mut path = Throughput {
        beta,
        r_u: Rgb::ONE,
        r_l: Rgb::ONE,
    };
    if let (Some(m), true) = (light_medium.around, ctx.lights.is_infinite(es.light)) {
        let model = scene.media[m as usize].model();
        let Some(start) = arrive_from_infinity(model, es.p, es.dir, (hero, &mut path)) else {
            return;
        };
        ray = Spot::exact(start).spawn(es.dir).at_time(0.0);
    }
    let power = |path: &Throughput| path.beta / average(path.r_u);
    let mut last = power(&path).max_element();
    if !(last.is_finite() && last > 0.0) {
        return;
    }
    let mut medium = light_medium.towards(es.dir);
    let mut depth = 0;
    let mut crossings = 0;
    let offset = to.surface.len() as u32;
    loop {
        let hit = ctx.intersect(&ray, stats);
        let mut next = None;
        if let Some(m) = medium {
            let t_max = hit.as_ref().map_or(f32::INFINITY, |sp| sp.t);
            match flight(ctx, m, &ray, t_max, hero, &mut path, sampler) {
                Flight::Ended => return,
                Flight::Crossed => {}
                Flight::Scattered { p, g } => {
                    if depth >= max_depth {
                        return;
                    }
                    let wo = -ray.dir.normalize();
                    if depth > 0 {
                        let phi = power(&path);
                        to.medium_grid.query(p, |k| {
                            let v = to.medium[k].weigh(wo, phi);
                            if v.is_finite() && v != Rgb::ZERO {
                                deposits.push((offset + k as u32, v));
                            }
                        });
                    }
                    depth += 1;
                    let (wi, pdf) = phase::sample_hg(wo, g, sampler.next_2d());
                    if !positive(pdf) {
                        return;
                    }
                    // The phase function's value is its density: the power keeps its value.
                    next = Some(Spot::exact(p).spawn(wi).at_time(0.0));
                }
            }
        }
        if next.is_none() {
            let Some(sp) = hit else {
                return;
            };
            let m = &scene.materials[sp.material];
            if m.is_interface() {
                crossings += 1;
                if crossings > MAX_CROSSINGS {
                    return;
                }
                (ray, medium) = cross(ctx, &sp, &ray, medium);
                continue;
            }
            if depth >= max_depth {
                return;
            }
            let wo = -ray.dir;
            if depth > 0 {
                let phi = power(&path);
                to.surface_grid.query(sp.p, |k| {
                    let v = to.surface[k].weigh(wo, phi);
                    if v.is_finite() && v != Rgb::ZERO {
                        deposits.push((k as u32, v));
                    }
                });
            }
            depth += 1;
            let bsdf = m.bsdf(&sp, wo);
            let u_lobe = sampler.next_1d();
            let Some(bs) = bsdf.sample(wo, u_lobe, sampler.next_2d(), Transport::Importance) else {
                return;
            };
            path.beta *= bs.weight;
            medium = medium_after(ctx, &sp, bs.wi, medium);
            next = Some(sp.spawn(bs.wi));
        }
        // pbrt-v4's photon roulette over the whole step (flight and scattering): survive
        // with the ratio of the new power to the last vertex's (at most 1), reweighted.
        let now = power(&path).max_element();
        let survive = (now / last).min(1.0);
        if !positive(survive - sampler.next_1d()) {
            return;
        }
        path.beta /= survive;
        last = now / survive;
        if !(path.beta.is_finite() && last.is_finite() && last > 0.0) {
            return;
        }
        ray = next.expect("a step ends with the next ray");
    }
}
