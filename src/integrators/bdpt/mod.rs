//! Bidirectional path tracing (Veach & Guibas; Lafortune & Willems): a camera subpath and a
//! light subpath are built for every pixel sample, and every pair of their prefixes is
//! connected (s light vertices and t camera vertices), including s = 0 (the camera path hits
//! an emitter) and t = 1 (a light vertex connected to the camera and splatted, as in light
//! tracing). The strategies are combined by multiple importance sampling with the power
//! heuristic, computed from the forward and reverse area densities of every vertex as in
//! pbrt. Lights at infinity (the background and directional lights) are vertices known by
//! their direction, as in pbrt-v4: a light subpath starts on the disk of the scene's
//! bounding sphere facing its direction, a camera subpath that leaves the scene ends at the
//! background, and the densities towards such a vertex stay in solid angle.
//!
//! In a scene with media the subpaths fly through them as the volumetric path tracer's
//! paths do (delta tracking by a hero channel, medium boundaries crossed without a vertex),
//! scatter at points in media as at surfaces, and every connection carries its
//! transmittance by ratio tracking; each strategy's estimate is divided by the average over
//! the channels of the densities of its whole path, so chromatic media stay unbiased.

mod mis;
mod vertex;
mod walk;

use super::camera_connection::{camera_pdf_dir, lens_sample, project_to_camera};
use super::light::refuse_orthographic;
use super::volumetric::{
    average, hero_channel, positive, transmittance, transmittance_to_infinity, Throughput,
};
use super::volumetric_light::{arrive_from_infinity, medium_at};
use crate::bsdf::Transport;
use crate::math::sobol::Sampler;
use crate::math::spawn::Spot;
use crate::math::warp::cosine_hemisphere;
use crate::math::{frame, Ray, Rgb, Rng, Vec2, Vec3};
use crate::scene::camera::CameraBasis;
use crate::scene::lights::Emitter;
use crate::scene::Scene;
use crate::settings::TechniqueKind;
use crate::transport::settings::{
    MonteCarloSettings, TechniqueInfo, COMMON, MONTE_CARLO, SPECTRAL,
};
use crate::transport::spectral::{Colours, RgbColours, Wavelengths};
use crate::transport::technique::{Lifecycle, SampledTechnique};
use crate::transport::{Context, MonteCarlo, RayStats, Splat};
use mis::Connection;
use std::f32::consts::PI;
use vertex::{Kind, Vertex};
use walk::{random_walk, Media, WalkStart};

/// Bidirectional path tracing, as the technique list shows it.
pub(crate) const TECHNIQUE: TechniqueInfo = TechniqueInfo {
    kind: TechniqueKind::Bdpt,
    summary: "Bidirectional path tracing, all strategies combined by multiple importance \
              sampling.",
    settings: &[COMMON, MONTE_CARLO, SPECTRAL],
    pbrt: &["bdpt"],
    progressive: true,
    renders_parts: false,
    follows_time: true,
    media: true,
};

/// The technique for `scene`: nothing to prepare, sample passes.
pub(crate) fn lifecycle(
    mc: &MonteCarloSettings,
    scene: &Scene,
) -> crate::error::Result<Box<dyn Lifecycle>> {
    refuse_orthographic(scene, "bdpt")?;
    Ok(Box::new(SampledTechnique {
        integrator: Bdpt::new(BdptOptions {
            max_depth: mc.max_depth,
            spectral: mc.spectral,
        }),
        settings: *mc,
    }))
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BdptOptions {
    /// Maximum number of bounces of a full path.
    pub max_depth: u32,
    /// Light at sampled wavelengths, not RGB (surfaces only).
    pub spectral: bool,
}

pub struct Bdpt {
    options: BdptOptions,
}

impl Bdpt {
    pub fn new(options: BdptOptions) -> Self {
        Bdpt { options }
    }
}

/// The largest f32 below 1.
const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

/// What the connections of a sample through media share: the hero channel its subpaths
/// flew by and the random numbers of the ratio tracking along connections.
struct Spectral {
    hero: usize,
    rng: Rng,
}

/// Where a connection ends: a point, or infinitely far along a direction.
#[derive(Clone, Copy)]
enum End<'s> {
    At(&'s Spot),
    Towards(Vec3),
}

/// What reaches `to` of the light leaving `from` (in `medium`) for a strategy whose
/// subpaths have the density ratios `r_path`: 1 for an unoccluded segment in a scene
/// without media; through media the ratio-tracked transmittance over the average of the
/// whole path's channel densities. `None` when something blocks the segment.
#[allow(clippy::too_many_arguments)]
fn link(
    ctx: &Context,
    (from, medium): (&Spot, Option<u32>),
    to: End,
    r_path: Rgb,
    time: f32,
    (spectral, colours): (&mut Option<Spectral>, &impl Colours),
    stats: &mut RayStats,
) -> Option<Rgb> {
    match (spectral, to) {
        (None, End::At(to)) => {
            (!ctx.occluded(&from.spawn_to(to).at_time(time), stats)).then_some(Rgb::ONE)
        }
        (None, End::Towards(dir)) => ctx
            .intersect(&from.spawn(dir).at_time(time), stats)
            .is_none()
            .then_some(Rgb::ONE),
        (Some(Spectral { hero, rng }), to) => {
            let from = (*from, time);
            let (t, _, r_l) = match to {
                End::At(to) => transmittance(ctx, from, medium, to, (*hero, colours), rng, stats),
                End::Towards(dir) => {
                    let hero = (*hero, colours);
                    transmittance_to_infinity(ctx, from, medium, dir, hero, rng, stats)
                }
            }?;
            let density = average(r_path * r_l);
            positive(density).then(|| t / density)
        }
    }
}

impl MonteCarlo for Bdpt {
    fn sample(
        &self,
        ctx: &Context,
        camera: &CameraBasis,
        camera_ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        splats: &mut Vec<Splat>,
    ) -> Rgb {
        if self.options.spectral {
            let mut lambda = Wavelengths::sample(sampler.next_1d());
            let v = self.trace(ctx, camera, camera_ray, sampler, stats, splats, &mut lambda);
            return lambda.output(v);
        }
        self.trace(
            ctx,
            camera,
            camera_ray,
            sampler,
            stats,
            splats,
            &mut RgbColours,
        )
    }
}

impl Bdpt {
    /// One sample's subpaths and connections with the scene's colours as `colours` gives
    /// them: the radiance the path carries, the splats in the film's RGB.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn trace<C: Colours>(
        &self,
        ctx: &Context,
        camera: &CameraBasis,
        camera_ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        splats: &mut Vec<Splat>,
        colours: &mut C,
    ) -> Rgb {
        let max_depth = self.options.max_depth;
        let time = camera_ray.time;
        let hero = ctx.has_media().then(|| hero_channel(sampler));
        let mut media = hero.map(|hero| Media {
            hero,
            medium: ctx.scene.camera_medium,
            gather_emission: true,
            max_depth,
            emitted: Rgb::ZERO,
        });
        // Camera subpath.
        let mut cam_path: Vec<Vertex> = Vec::with_capacity(max_depth as usize + 2);
        // The camera vertex is where the ray leaves: the pinhole or a point of the lens.
        let mut v0 = Vertex::new(Kind::Camera, Spot::exact(camera_ray.origin), Rgb::ONE);
        v0.medium = ctx.scene.camera_medium;
        cam_path.push(v0);
        let pdf_cam = camera_pdf_dir(camera, camera_ray.origin, camera_ray.dir);
        random_walk(
            ctx,
            WalkStart {
                ray: *camera_ray,
                beta: Rgb::ONE,
                r_u: Rgb::ONE,
                pdf: pdf_cam,
                max: max_depth + 1,
                mode: Transport::Radiance,
            },
            &mut cam_path,
            sampler,
            stats,
            media.as_mut(),
            colours,
        );
        // Emission inside media has the camera subpath as its only strategy.
        let mut radiance = media.as_ref().map_or(Rgb::ZERO, |m| m.emitted);
        let light_path = light_subpath(ctx, (time, max_depth), hero, sampler, stats, colours);
        let mut spectral = hero.map(|hero| Spectral {
            hero,
            rng: sampler.stream(),
        });

        for t in 1..=cam_path.len() {
            for s in 0..=light_path.len() {
                let depth = s as i64 + t as i64 - 2;
                // (s, t) = (1, 1), the light's own point splatted to the camera, is left out:
                // (0, 2), the camera ray hitting the light, renders visible lights alone
                // (both would need weights, and the first is by far the noisier).
                if depth < 0 || depth > max_depth as i64 || (s == 1 && t == 1) {
                    continue;
                }
                let connection = Connection {
                    light: &light_path,
                    camera: &cam_path,
                    s,
                    t,
                };
                match (s, t) {
                    (0, _) => {
                        // The camera path found an emitter, or left the scene.
                        let pt = &cam_path[t - 1];
                        if !pt.is_infinite() {
                            if pt.kind != Kind::Surface || pt.light.is_none() {
                                continue;
                            }
                            let to_prev = cam_path[t - 2].p - pt.p;
                            if pt.emitting_cos(ctx, to_prev) <= 0.0 {
                                continue;
                            }
                        }
                        let mut l = pt.beta * pt.emission;
                        if l == Rgb::ZERO {
                            continue;
                        }
                        if spectral.is_some() {
                            l /= average(pt.r_u);
                        }
                        radiance += l * connection.mis_weight(ctx, camera);
                    }
                    (_, 1) => {
                        // A light vertex seen by the camera: splatted.
                        let qs = &light_path[s - 1];
                        if !qs.connectible() {
                            continue;
                        }
                        // A lens point of its own (the pinhole draws nothing).
                        let lens = lens_sample(camera, sampler);
                        let Some(c) = project_to_camera(camera, lens, qs.p) else {
                            continue;
                        };
                        let Some(through) = link(
                            ctx,
                            (&qs.spot(), qs.medium_towards(c.dir)),
                            End::At(&Spot::exact(lens)),
                            qs.r_u,
                            time,
                            (&mut spectral, &*colours),
                            stats,
                        ) else {
                            continue;
                        };
                        let value = if s == 1 {
                            if qs.is_delta_light() {
                                continue;
                            }
                            let cos_l = qs.emitting_cos(ctx, c.dir);
                            if cos_l <= 0.0 {
                                continue;
                            }
                            qs.beta * (cos_l * c.importance)
                        } else {
                            let cam_v = Vertex::new(Kind::Camera, Spot::exact(lens), Rgb::ONE);
                            qs.beta
                                * qs.f(Some(&light_path[s - 2]), &cam_v, Transport::Importance)
                                * c.importance
                        };
                        if value == Rgb::ZERO {
                            continue;
                        }
                        let mut cam_only = cam_path.clone();
                        cam_only.truncate(1);
                        cam_only[0].p = lens;
                        let w = Connection {
                            camera: &cam_only,
                            ..connection
                        }
                        .mis_weight(ctx, camera);
                        splats.push(Splat {
                            x: c.x,
                            y: c.y,
                            value: colours.output(value * through * w),
                        });
                    }
                    (1, _) if light_path[0].is_infinite() => {
                        // Light from infinity along the light subpath's direction.
                        let (qs, pt) = (&light_path[0], &cam_path[t - 1]);
                        if !pt.connectible() {
                            continue;
                        }
                        let l = qs.beta * pt.f(Some(&cam_path[t - 2]), qs, Transport::Radiance);
                        if l == Rgb::ZERO {
                            continue;
                        }
                        let wdir = pt.dir_to(qs);
                        let Some(through) = link(
                            ctx,
                            (&pt.spot(), pt.medium_towards(wdir)),
                            End::Towards(wdir),
                            qs.r_u * pt.r_u,
                            time,
                            (&mut spectral, &*colours),
                            stats,
                        ) else {
                            continue;
                        };
                        radiance += l * pt.beta * through * connection.mis_weight(ctx, camera);
                    }
                    _ => {
                        let (qs, pt) = (&light_path[s - 1], &cam_path[t - 1]);
                        if !qs.connectible() || !pt.connectible() {
                            continue;
                        }
                        let pt_prev = &cam_path[t - 2];
                        let fp = pt.f(Some(pt_prev), qs, Transport::Radiance);
                        if fp == Rgb::ZERO {
                            continue;
                        }
                        let d = qs.p - pt.p;
                        let dist2 = d.length_squared();
                        let wdir = d / dist2.sqrt();
                        let fq = if s == 1 {
                            // Emission of the light vertex towards pt.
                            if let Kind::Light { light, point: true } = qs.kind {
                                let model = ctx.lights.emitters[light].model();
                                colours.emission(model.intensity_towards(-wdir), || {
                                    ctx.lights.spectrum(light)
                                })
                            } else {
                                let cos_l = qs.emitting_cos(ctx, -wdir);
                                if cos_l <= 0.0 {
                                    continue;
                                }
                                qs.emission * cos_l
                            }
                        } else {
                            qs.f(Some(&light_path[s - 2]), pt, Transport::Importance)
                        };
                        let beta_q = if s == 1 {
                            Rgb::splat(1.0 / qs.pdf_fwd)
                        } else {
                            qs.beta
                        };
                        let l = beta_q * fq * fp * pt.beta / dist2;
                        if l == Rgb::ZERO {
                            continue;
                        }
                        let Some(through) = link(
                            ctx,
                            (&pt.spot(), pt.medium_towards(wdir)),
                            End::At(&qs.spot()),
                            qs.r_u * pt.r_u,
                            time,
                            (&mut spectral, &*colours),
                            stats,
                        ) else {
                            continue;
                        };
                        radiance += l * through * connection.mis_weight(ctx, camera);
                    }
                }
            }
        }
        radiance
    }
}

/// The light subpath of one sample: a point on an emitter chosen by power, then a random
/// walk from it (through media by the `hero` channel, in a scene with media).
fn light_subpath<'a>(
    ctx: &Context<'a>,
    (time, max_depth): (f32, u32),
    hero: Option<usize>,
    sampler: &mut Sampler,
    stats: &mut RayStats,
    colours: &mut impl Colours,
) -> Vec<Vertex<'a>> {
    let mut light_path: Vec<Vertex> = Vec::with_capacity(max_depth as usize + 1);
    let u_choose = sampler.next_2d();
    let u_pos = sampler.next_2d();
    let u_dir = sampler.next_2d();
    let lights = &ctx.lights;
    if let Some((i, _)) = lights
        .choose(u_choose.x)
        .filter(|&(i, _)| lights.is_infinite(i))
    {
        let start = InfiniteStart {
            light: i,
            u_pos,
            u_dir,
            time,
            max_depth,
            hero,
        };
        infinite_light_subpath(ctx, start, &mut light_path, (sampler, stats), colours);
        return light_path;
    }
    let Some((light, at, pdf_pos, point, le)) = sample_light_point(ctx, u_choose.x, u_pos) else {
        return light_path;
    };
    let le = colours.emission(le, || ctx.lights.spectrum(light));
    let n = at.n;
    let mut v0 = Vertex::new(Kind::Light { light, point }, at, le / pdf_pos);
    v0.pdf_fwd = pdf_pos;
    v0.emission = le;
    let (dir, pdf_dir, cos) = if point {
        // Point lights emit over the sphere, spot lights over their cone.
        let (d, pdf) = ctx.lights.emitters[light].model().emission_direction(u_dir);
        (d, pdf, 1.0)
    } else {
        // A two-sided light picks a side with half of u_dir.x, as pbrt-v4 does.
        let two_sided = v0.area_light(ctx).is_some_and(|a| a.two_sided);
        let (side, u_dir, side_pdf) = if !two_sided {
            (n, u_dir, 1.0)
        } else if u_dir.x < 0.5 {
            (
                n,
                Vec2::new((2.0 * u_dir.x).min(ONE_MINUS_EPS), u_dir.y),
                0.5,
            )
        } else {
            let ux = (2.0 * (u_dir.x - 0.5)).min(ONE_MINUS_EPS);
            (-n, Vec2::new(ux, u_dir.y), 0.5)
        };
        let (t, b) = frame(side);
        let l = cosine_hemisphere(u_dir);
        (t * l.x + b * l.y + side * l.z, side_pdf * l.z / PI, l.z)
    };
    if hero.is_some() {
        // The medium around the emitter: its shape's, if it bounds media, or the one the
        // camera's medium becomes on the way to it.
        v0.interface = v0
            .area_light(ctx)
            .and_then(|a| ctx.scene.shapes[a.shape].media);
        if v0.interface.is_none() {
            v0.medium = medium_at(ctx, at.p, time, stats);
        }
    }
    light_path.push(v0);
    if pdf_dir > 0.0 {
        // A spot light's intensity falls off towards the edge of its cone.
        let le_dir = if point {
            colours.emission(
                ctx.lights.emitters[light].model().intensity_towards(dir),
                || ctx.lights.spectrum(light),
            )
        } else {
            le
        };
        let mut media = hero.map(|hero| Media {
            hero,
            medium: v0.medium_towards(dir),
            gather_emission: false,
            max_depth,
            emitted: Rgb::ZERO,
        });
        random_walk(
            ctx,
            WalkStart {
                ray: at.spawn(dir).at_time(time),
                beta: le_dir * (cos / (pdf_pos * pdf_dir)),
                r_u: Rgb::ONE,
                pdf: pdf_dir,
                max: max_depth,
                mode: Transport::Importance,
            },
            &mut light_path,
            sampler,
            stats,
            media.as_mut(),
            colours,
        );
    }
    light_path
}

/// The start of a light subpath at an emitter at infinity (`light`, already chosen).
struct InfiniteStart {
    light: usize,
    u_pos: Vec2,
    u_dir: Vec2,
    time: f32,
    max_depth: u32,
    hero: Option<usize>,
}

/// A light subpath from the background or a directional light (pbrt-v4's infinite-light
/// vertices): a direction by the light's own sampling, and a start on the disk of the
/// scene's bounding sphere facing it. The first vertex keeps what the s = 1 strategy
/// needs, the light along its direction over the density of choosing it; the walk carries
/// the radiance over the densities of the direction and of the point on the disk.
fn infinite_light_subpath<'a>(
    ctx: &Context<'a>,
    start: InfiniteStart,
    light_path: &mut Vec<Vertex<'a>>,
    (sampler, stats): (&mut Sampler, &mut RayStats),
    colours: &mut impl Colours,
) {
    let lights = &ctx.lights;
    let InfiniteStart {
        light,
        u_pos,
        u_dir,
        time,
        max_depth,
        hero,
    } = start;
    let model = lights.emitters[light].model();
    let pmf = lights.pmf(light);
    let Some(mut es) = model.sample_le(u_pos, u_dir, pmf, &lights.world, light) else {
        return;
    };
    es.radiance = colours.emission(es.radiance, || lights.spectrum(light));
    if !(es.pdf_dir > 0.0 && es.pdf_pos > 0.0) {
        return;
    }
    let kind = Kind::Infinite {
        light: Some(light),
        delta: es.delta_dir,
    };
    let at = Spot {
        p: es.p,
        error: Vec3::ZERO,
        n: es.dir,
    };
    let mut v0 = Vertex::new(kind, at, es.radiance / (pmf * es.pdf_dir));
    v0.emission = es.radiance;
    v0.pdf_fwd = v0.pdf_light_origin(ctx);
    let mut from = at;
    let mut r_u = Rgb::ONE;
    let mut beta = es.radiance / (es.pdf_pos * es.pdf_dir);
    if let Some(hero) = hero {
        v0.medium = medium_at(ctx, es.p, time, stats);
        if let Some(m) = v0.medium {
            // Light from infinity first crosses what of the medium lies beyond the disk.
            let model = ctx.scene.media[m as usize].model();
            let mut tp = Throughput {
                beta,
                r_u,
                r_l: Rgb::ONE,
            };
            let arrived = colours.medium(model, |model| {
                arrive_from_infinity(model, es.p, es.dir, (hero, &mut tp))
            });
            let Some(p) = arrived else {
                light_path.push(v0);
                return;
            };
            (beta, r_u, from) = (tp.beta, tp.r_u, Spot::exact(p));
        }
    }
    light_path.push(v0);
    let mut media = hero.map(|hero| Media {
        hero,
        medium: v0.medium,
        gather_emission: false,
        max_depth,
        emitted: Rgb::ZERO,
    });
    let r = lights.world.radius;
    random_walk(
        ctx,
        WalkStart {
            ray: from.spawn(es.dir).at_time(time),
            beta,
            r_u,
            pdf: 1.0 / (PI * r * r),
            max: max_depth,
            mode: Transport::Importance,
        },
        light_path,
        sampler,
        stats,
        media.as_mut(),
        colours,
    );
}

/// A point on a finite emitter chosen by power: (emitter, point with its error and normal,
/// area density with the choice, is a point light, emitted radiance or intensity).
fn sample_light_point(
    ctx: &Context,
    u_choose: f32,
    u: crate::math::Vec2,
) -> Option<(usize, Spot, f32, bool, Rgb)> {
    let (i, _) = ctx.lights.choose(u_choose)?;
    let sel = ctx.lights.pmf(i);
    match &ctx.lights.emitters[i] {
        Emitter::Area(a) => {
            let lp = a.sample(u);
            Some((i, lp.spot(), sel / a.area, false, a.radiance_at(&lp)))
        }
        e => e
            .model()
            .point_source()
            .map(|(position, intensity)| (i, Spot::exact(position), sel, true, intensity)),
    }
}
