//! Light tracing through participating media: light paths leave the emitters in the medium
//! around them, fly through media by delta tracking (as the volumetric path tracer's camera
//! paths do, with the same spectral MIS over a hero channel), scatter at surfaces and in
//! media, and every scattering point is connected to the camera with the transmittance of
//! the connection estimated by ratio tracking through medium boundaries.

use super::camera_connection::{lens_sample, project_to_camera};
use super::volumetric::{
    average, cross, fly, hero_channel, medium_after, positive, russian_roulette, transmittance,
    transmittance_to_infinity, Flight, Lengths, Throughput, MAX_CROSSINGS,
};
use crate::bsdf::{phase, Transport};
use crate::math::sobol::Sampler;
use crate::math::spawn::Spot;
use crate::math::{Ray, Rgb, Vec2, Vec3};
use crate::scene::camera::CameraBasis;
use crate::scene::lights::EmissionSample;
use crate::scene::lights::Emitter;
use crate::scene::media::{MediumInterface, MediumModel};
use crate::scene::Scene;
use crate::transport::spectral::Colours;
use crate::transport::{Context, RayStats, Splat};

/// Whether light tracing renders `scene`'s media: not media that emit (light paths do not
/// start in a volume).
pub(crate) fn check_scene(scene: &Scene) -> Result<(), String> {
    match scene.media.iter().find(|m| m.model().emits()) {
        Some(m) => Err(format!(
            "the light integrator does not render media that emit, and the medium \"{}\" \
             does: render it with the path, bdpt, vcm or sppm integrator",
            m.name
        )),
        None => Ok(()),
    }
}

/// Light from infinity that starts a light path at `start` (outside every shape) in
/// `medium` first crosses whatever of the medium lies beyond `start`: a grid beyond it moves
/// the start back past the grid; a medium without end lets through only the channels it
/// does not attenuate (weighted as a free flight that met no collision). `None` when no
/// light arrives in the hero channel.
pub(super) fn arrive_from_infinity(
    medium: &dyn MediumModel,
    start: Vec3,
    dir: Vec3,
    (hero, path): (usize, &mut Throughput),
) -> Option<Vec3> {
    let back = Spot::exact(start).spawn(-dir);
    let (mut far, mut endless) = (0.0f32, Rgb::ZERO);
    medium.segments(&back, f32::INFINITY, &mut |s| {
        if s.sigma_maj.max_element() > 0.0 {
            if s.t1.is_finite() {
                far = far.max(s.t1);
            } else {
                endless += s.sigma_maj;
            }
        }
        true
    });
    if endless != Rgb::ZERO {
        let through = Rgb::new(
            f32::from(endless.x == 0.0),
            f32::from(endless.y == 0.0),
            f32::from(endless.z == 0.0),
        );
        if through[hero] == 0.0 {
            return None;
        }
        path.beta *= through;
        path.r_u *= through;
        path.r_l *= through;
    }
    Some(start - dir * far)
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
        // The surface `p` lies on (an area light's) ends the segment: were it crossed, the
        // next segment would find it again, to the last crossing allowed.
        if (sp.p - p).abs().max_element() <= 1e-4 * p.abs().max_element().max(1.0) {
            return medium;
        }
        medium = medium_after(ctx, &sp, ray.dir, medium);
        from = sp.spot();
    }
    medium
}

/// The medium around a light's emission sample: on each side of an emitter that bounds
/// media, its shape's interface (found with the surface's own normal: a two-sided light's
/// sample gives the normal of the side it emits to); elsewhere the camera's medium carried
/// to it.
#[derive(Clone, Copy, Debug)]
pub(super) struct LightMedium {
    interface: Option<(MediumInterface, Vec3)>,
    /// The medium around a light that bounds none.
    pub around: Option<u32>,
}

impl LightMedium {
    /// The media around the emission sample `es`, drawn with `u_pos`.
    pub(super) fn of(
        ctx: &Context,
        es: &EmissionSample,
        u_pos: Vec2,
        time: f32,
        stats: &mut RayStats,
    ) -> LightMedium {
        let interface = match &ctx.lights.emitters[es.light] {
            Emitter::Area(a) => ctx.scene.shapes[a.shape]
                .media
                .map(|i| (i, a.sample(u_pos).n)),
            _ => None,
        };
        let around = match interface {
            Some(_) => None,
            None => medium_at(ctx, es.p, time, stats),
        };
        LightMedium { interface, around }
    }

    /// The medium a ray leaving the light along `w` starts in.
    pub(super) fn towards(&self, w: Vec3) -> Option<u32> {
        self.interface.map_or(self.around, |(i, n)| i.towards(w, n))
    }
}

/// What a scattering point gives the film: its connection to the camera, through media,
/// splatted with the path's throughput `path` (over the channels' densities) times `f`,
/// which gives the scattering towards the camera's direction; the values the path carries
/// are as `colours` gives them.
#[allow(clippy::too_many_arguments)]
fn splat_to_camera(
    ctx: &Context,
    camera: &CameraBasis,
    (at, time): (&Spot, f32),
    medium_towards: &dyn Fn(Vec3) -> Option<u32>,
    f: &dyn Fn(Vec3) -> Rgb,
    (path, hero, colours): (&Throughput, usize, &impl Colours),
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
    let (from, hero) = ((*at, time), (hero, colours));
    let Some((t, _, r_l)) = transmittance(ctx, from, medium, &lens, hero, &mut rng, stats) else {
        return;
    };
    // One strategy: the connection's collisions drawn by the majorant (as a light sample's).
    let density = average(path.r_u * r_l);
    if positive(density) {
        splats.push(Splat {
            x: c.x,
            y: c.y,
            value: colours.output(path.beta * f * t * (c.importance / density)),
        });
    }
}

/// One light path through a scene with media, splatted where its vertices land on the film;
/// returns what the camera ray itself gives its pixel (the background it sees through the
/// media on its way, which light paths cannot reach), in the film's RGB; the scene's colours
/// (and its media's) are as `colours` gives them.
#[allow(clippy::too_many_arguments)]
pub(crate) fn trace<C: Colours>(
    ctx: &Context,
    camera: &CameraBasis,
    camera_ray: &Ray,
    lengths: Lengths,
    sampler: &mut Sampler,
    stats: &mut RayStats,
    splats: &mut Vec<Splat>,
    colours: &mut C,
) -> Rgb {
    let scene = ctx.scene;
    let lights = &ctx.lights;
    let time = camera_ray.time;
    let hero = hero_channel(sampler);
    let mut direct = Rgb::ZERO;
    if lights.background_light().is_some() {
        let mut rng = sampler.stream();
        let from = (Spot::exact(camera_ray.origin), time);
        let medium = scene.camera_medium;
        let (dir, stats) = (camera_ray.dir, &mut *stats);
        let hero = (hero, &*colours);
        if let Some((t, _, r_l)) =
            transmittance_to_infinity(ctx, from, medium, dir, hero, &mut rng, stats)
        {
            // One strategy: the camera ray, its collisions drawn by the majorant.
            if positive(average(r_l)) {
                let le = colours.emission(lights.background_radiance(dir), || None);
                direct = colours.output(le * t / average(r_l));
            }
        }
    }
    light_path(
        ctx, camera, time, hero, lengths, sampler, stats, splats, colours,
    );
    direct
}

/// One light path, splatted where its vertices land on the film.
#[allow(clippy::too_many_arguments)]
fn light_path(
    ctx: &Context,
    camera: &CameraBasis,
    time: f32,
    hero: usize,
    Lengths {
        max_depth,
        rr_start,
    }: Lengths,
    sampler: &mut Sampler,
    stats: &mut RayStats,
    splats: &mut Vec<Splat>,
    colours: &mut impl Colours,
) {
    let scene = ctx.scene;
    let lights = &ctx.lights;
    let u_choose = sampler.next_2d();
    let u_pos = sampler.next_2d();
    let u_dir = sampler.next_2d();
    let Some(mut es) = lights.sample_le(u_choose.x, u_pos, u_dir) else {
        return;
    };
    es.radiance = colours.emission(es.radiance, || lights.spectrum(es.light));
    let at_infinity = lights.is_infinite(es.light);
    let light_medium = LightMedium::of(ctx, &es, u_pos, time, stats);
    let around = light_medium.around;
    let medium_towards = |w: Vec3| light_medium.towards(w);
    let mut path = Throughput {
        beta: Rgb::ONE,
        r_u: Rgb::ONE,
        r_l: Rgb::ONE,
    };
    let mut from = es.spot();
    if let (Some(m), true) = (around, at_infinity) {
        let model = scene.media[m as usize].model();
        let arrived = colours.medium(model, |model| {
            arrive_from_infinity(model, es.p, es.dir, (hero, &mut path))
        });
        let Some(start) = arrived else {
            return;
        };
        from = Spot::exact(start);
    }
    // The light's own point seen by the camera (area lights: points cannot be hit by camera
    // rays).
    if let (Emitter::Area(a), false) = (&lights.emitters[es.light], es.delta_pos) {
        let emission = |dir: Vec3| es.radiance * (a.emitting_cos(dir.dot(es.n)) / es.pdf_pos);
        splat_to_camera(
            ctx,
            camera,
            (&es.spot(), time),
            &medium_towards,
            &emission,
            (&path, hero, &*colours),
            sampler,
            stats,
            splats,
        );
    }
    let cos0 = if es.delta_dir || es.delta_pos || at_infinity {
        1.0
    } else {
        es.n.dot(es.dir).abs()
    };
    path.beta *= es.radiance * (cos0 / (es.pdf_pos * es.pdf_dir));
    let mut medium = medium_towards(es.dir);
    let mut ray = from.spawn(es.dir).at_time(time);
    let mut depth = 0;
    let mut crossings = 0;
    loop {
        let hit = ctx.intersect(&ray, stats);
        if let Some(m) = medium {
            let model = scene.media[m as usize].model();
            let t_max = hit.as_ref().map_or(f32::INFINITY, |sp| sp.t);
            let flight = colours.medium(model, |model| {
                fly(
                    model,
                    &ray,
                    t_max,
                    (hero, &mut *sampler),
                    &mut path,
                    &mut |_, _| {},
                )
            });
            match flight {
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
                        (&path, hero, &*colours),
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
        let bsdf = colours.bsdf(m.bsdf(&sp, wo));
        if bsdf.has_non_delta() {
            let current = medium;
            splat_to_camera(
                ctx,
                camera,
                (&sp.spot(), sp.time),
                &|w| medium_after(ctx, &sp, w, current),
                &|wi| bsdf.eval(wo, wi, Transport::Importance),
                (&path, hero, &*colours),
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
