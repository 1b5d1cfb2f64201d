//! Light tracing through participating media: light paths leave the emitters in the medium
//! around them, fly through media by delta tracking (as the volumetric path tracer's camera
//! paths do, with the same spectral MIS over a hero channel), scatter at surfaces and in
//! media, and every scattering point is connected to the camera with the transmittance of
//! the connection estimated by ratio tracking through medium boundaries.

use super::camera_connection::{lens_sample, project_to_camera};
use super::volumetric::{
    average, cross, fly, hero_channel, medium_after, positive, russian_roulette, transmittance,
    Flight, Lengths, Throughput, MAX_CROSSINGS,
};
use crate::bsdf::{phase, Transport};
use crate::math::sobol::Sampler;
use crate::math::spawn::Spot;
use crate::math::{Ray, Rgb, Vec3};
use crate::scene::camera::CameraBasis;
use crate::scene::lights::Emitter;
use crate::scene::Scene;
use crate::transport::{Context, RayStats, Splat};

/// Whether light tracing renders `scene`'s media: not media that emit (light paths cannot
/// start in a volume), lights at infinity (their light would have to cross a medium without
/// end), nor emitters that bound a medium.
pub(crate) fn check_scene(scene: &Scene) -> Result<(), String> {
    if scene.media.is_empty() {
        return Ok(());
    }
    let emitting_medium = scene.media.iter().find(|m| m.model().emits());
    let at_infinity = scene
        .lights
        .iter()
        .any(|l| l.model().point_source().is_none())
        || scene.background.max_element() > 0.0
        || scene.environment.is_some();
    let bounding_emitter = scene
        .shapes
        .iter()
        .any(|s| s.media.is_some() && scene.materials[s.material].is_emissive());
    let why = match (emitting_medium, at_infinity, bounding_emitter) {
        (Some(m), _, _) => format!("the medium \"{}\" emits", m.name),
        (None, true, _) => "it has a light at infinity (a background, an environment map or a \
                            directional light)"
            .to_string(),
        (None, false, true) => "an emitting shape bounds a medium".to_string(),
        (None, false, false) => return Ok(()),
    };
    Err(format!(
        "the light integrator renders media lit by area, point, spot, goniometric and \
         projection lights; in this scene {why}: render it with the path integrator"
    ))
}

/// The medium at point `p` (off every medium boundary): the camera's, carried along the
/// segment from the camera to `p` through the boundaries it crosses.
pub(super) fn medium_at(ctx: &Context, p: Vec3, time: f32, stats: &mut RayStats) -> Option<u32> {
    let mut medium = ctx.scene.camera_medium;
    let mut from = Spot::exact(ctx.scene.camera.position);
    let to = Spot::exact(p);
    for _ in 0..MAX_CROSSINGS {
        let ray = from.spawn_to(&to).at_time(time);
        let Some(sp) = ctx.intersect(&ray, stats) else {
            return medium;
        };
        medium = medium_after(ctx, &sp, ray.dir, medium);
        from = sp.spot();
    }
    medium
}

/// What a scattering point gives the film: its connection to the camera, through media,
/// splatted with the path's throughput `path` (over the channels' densities) times `f`,
/// which gives the scattering towards the camera's direction.
#[allow(clippy::too_many_arguments)]
fn splat_to_camera(
    ctx: &Context,
    camera: &CameraBasis,
    (at, time): (&Spot, f32),
    medium_towards: &dyn Fn(Vec3) -> Option<u32>,
    f: &dyn Fn(Vec3) -> Rgb,
    (path, hero): (&Throughput, usize),
    sampler: &mut Sampler,
    stats: &mut RayStats,
    splats: &mut Vec<Splat>,
) {
    let lens = lens_sample(camera, sampler);
    let mut rng = sampler.stream();
    let Some(c) = project_to_camera(camera, lens, at.p) else {
        return;
    };
    let f = f(c.dir);
    if f == Rgb::ZERO {
        return;
    }
    let lens = Spot::exact(lens);
    let medium = medium_towards(c.dir);
    let Some((t, _, r_l)) = transmittance(ctx, (*at, time), medium, &lens, hero, &mut rng, stats)
    else {
        return;
    };
    // One strategy: the connection's collisions drawn by the majorant (as a light sample's).
    let density = average(path.r_u * r_l);
    if positive(density) {
        splats.push(Splat {
            x: c.x,
            y: c.y,
            value: path.beta * f * t * (c.importance / density),
        });
    }
}

/// One light path through a scene with media, splatted where its vertices land on the film.
pub(crate) fn trace(
    ctx: &Context,
    camera: &CameraBasis,
    camera_ray: &Ray,
    Lengths {
        max_depth,
        rr_start,
    }: Lengths,
    sampler: &mut Sampler,
    stats: &mut RayStats,
    splats: &mut Vec<Splat>,
) {
    let scene = ctx.scene;
    let lights = &ctx.lights;
    let time = camera_ray.time;
    let hero = hero_channel(sampler);
    let u_choose = sampler.next_2d();
    let u_pos = sampler.next_2d();
    let u_dir = sampler.next_2d();
    let Some(es) = lights.sample_le(u_choose.x, u_pos, u_dir) else {
        return;
    };
    // No emitter bounds a medium (`check_scene`): the medium around the light is the one at
    // its point.
    let mut medium = medium_at(ctx, es.p, time, stats);
    let start = Throughput {
        beta: Rgb::ONE,
        r_u: Rgb::ONE,
        r_l: Rgb::ONE,
    };
    // The light's own point seen by the camera (area lights: points cannot be hit by camera
    // rays).
    if let (Emitter::Area(a), false) = (&lights.emitters[es.light], es.delta_pos) {
        let emission = |dir: Vec3| es.radiance * (a.emitting_cos(dir.dot(es.n)) / es.pdf_pos);
        let around = medium;
        splat_to_camera(
            ctx,
            camera,
            (&es.spot(), time),
            &|_| around,
            &emission,
            (&start, hero),
            sampler,
            stats,
            splats,
        );
    }
    let cos0 = if es.delta_dir || es.delta_pos {
        1.0
    } else {
        es.n.dot(es.dir).abs()
    };
    let mut path = Throughput {
        beta: es.radiance * (cos0 / (es.pdf_pos * es.pdf_dir)),
        ..start
    };
    let mut ray = es.spot().spawn(es.dir).at_time(time);
    let mut depth = 0;
    let mut crossings = 0;
    loop {
        let hit = ctx.intersect(&ray, stats);
        if let Some(m) = medium {
            let model = scene.media[m as usize].model();
            let t_max = hit.as_ref().map_or(f32::INFINITY, |sp| sp.t);
            let mut rng = sampler.stream();
            match fly(
                model,
                &ray,
                t_max,
                (hero, &mut rng),
                &mut path,
                &mut |_, _| {},
            ) {
                Flight::Ended => return,
                Flight::Crossed => {}
                Flight::Scattered { p, g } => {
                    if depth >= max_depth {
                        return;
                    }
                    depth += 1;
                    let wo = -ray.dir.normalize();
                    let at = Spot::exact(p);
                    splat_to_camera(
                        ctx,
                        camera,
                        (&at, time),
                        &|_| medium,
                        &|wi| Rgb::splat(phase::hg(wo, wi, g)),
                        (&path, hero),
                        sampler,
                        stats,
                        splats,
                    );
                    let (wi, pdf) = phase::sample_hg(wo, g, sampler.next_2d());
                    if !positive(pdf) {
                        return;
                    }
                    ray = at.spawn(wi).at_time(time);
                    if !russian_roulette(&mut path.beta, path.r_u, depth >= rr_start, sampler) {
                        return;
                    }
                    continue;
                }
            }
        }
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
        depth += 1;
        let wo = -ray.dir;
        let bsdf = m.bsdf(&sp, wo);
        if bsdf.has_non_delta() {
            let current = medium;
            splat_to_camera(
                ctx,
                camera,
                (&sp.spot(), sp.time),
                &|w| medium_after(ctx, &sp, w, current),
                &|wi| bsdf.eval(wo, wi, Transport::Importance),
                (&path, hero),
                sampler,
                stats,
                splats,
            );
        }
        let u = sampler.next_1d();
        let Some(bs) = bsdf.sample(wo, u, sampler.next_2d(), Transport::Importance) else {
            return;
        };
        path.beta *= bs.weight;
        medium = medium_after(ctx, &sp, bs.wi, medium);
        ray = sp.spawn(bs.wi);
        if !russian_roulette(&mut path.beta, path.r_u, depth >= rr_start, sampler) {
            return;
        }
    }
}
