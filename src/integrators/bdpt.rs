//! Bidirectional path tracing (Veach & Guibas; Lafortune & Willems): a camera subpath and a
//! light subpath are built for every pixel sample, and every pair of their prefixes is
//! connected (s light vertices and t camera vertices), including s = 0 (the camera path hits
//! an emitter) and t = 1 (a light vertex connected to the camera and splatted, as in light
//! tracing). The strategies are combined by multiple importance sampling with the power
//! heuristic, computed from the forward and reverse area densities of every vertex as in
//! pbrt. Finite emitters only (area and point lights): directional lights and the
//! background have no position to start a subpath from, and are left to the path tracer.

use super::camera_connection::{connect_to_camera, lens_sample};
use super::light::refuse_orthographic;
use super::path::russian_roulette;
use crate::bsdf::{Bsdf, Transport};
use crate::error::Error;
use crate::math::sobol::Sampler;
use crate::math::spawn::Spot;
use crate::math::warp::cosine_hemisphere;
use crate::math::{frame, Ray, Rgb, Vec2, Vec3};
use crate::scene::camera::CameraBasis;
use crate::scene::lights::Emitter;
use crate::scene::Scene;
use crate::settings::TechniqueKind;
use crate::transport::settings::{MonteCarloSettings, TechniqueInfo, COMMON, MONTE_CARLO};
use crate::transport::technique::{Lifecycle, SampledTechnique};
use crate::transport::{Context, MonteCarlo, RayStats, Splat};
use std::f32::consts::PI;

/// Bidirectional path tracing, as the technique list shows it.
pub(crate) const TECHNIQUE: TechniqueInfo = TechniqueInfo {
    kind: TechniqueKind::Bdpt,
    summary: "Bidirectional path tracing, all strategies combined by multiple importance \
              sampling.",
    settings: &[COMMON, MONTE_CARLO],
    pbrt: &["bdpt"],
    progressive: true,
    renders_parts: false,
    follows_time: true,
    media: false,
};

/// The technique for `scene` (finite emitters only): nothing to prepare, sample passes.
pub(crate) fn lifecycle(
    mc: &MonteCarloSettings,
    scene: &Scene,
) -> crate::error::Result<Box<dyn Lifecycle>> {
    refuse_orthographic(scene, "bdpt")?;
    Bdpt::check_scene(scene).map_err(|e| Error::input(&scene.source, e))?;
    Ok(Box::new(SampledTechnique {
        integrator: Bdpt::new(BdptOptions {
            max_depth: mc.max_depth,
        }),
        settings: *mc,
    }))
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BdptOptions {
    /// Maximum number of bounces of a full path.
    pub max_depth: u32,
}

pub struct Bdpt {
    options: BdptOptions,
}

impl Bdpt {
    pub fn new(options: BdptOptions) -> Self {
        Bdpt { options }
    }

    /// Whether BDPT can render a scene: it needs every emitter to have a position.
    pub fn check_scene(scene: &Scene) -> Result<(), String> {
        if !scene
            .lights
            .iter()
            .all(|l| l.model().point_source().is_some())
            || scene.background.max_element() > 0.0
            || scene.environment.is_some()
        {
            return Err(
                "the bdpt integrator supports area, point, spot and goniometric lights only; this \
                 scene has a directional light or a background: render it with the path \
                 integrator"
                    .into(),
            );
        }
        Ok(())
    }
}

/// The largest f32 below 1.
const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Camera,
    /// A light subpath's first vertex: emitter index, and whether it is a point light.
    Light {
        light: usize,
        point: bool,
    },
    Surface,
}

#[derive(Clone, Copy, Debug)]
struct Vertex<'a> {
    kind: Kind,
    p: Vec3,
    /// A bound of `p`'s rounding error (zero for the camera and point lights).
    error: Vec3,
    /// Geometric normal (zero for the camera and point lights).
    n: Vec3,
    bsdf: Option<Bsdf<'a>>,
    /// Emitted radiance of the surface (for s = 0), with its emitter index.
    emission: Rgb,
    light: Option<usize>,
    beta: Rgb,
    /// Scattered by a delta lobe.
    delta: bool,
    pdf_fwd: f32,
    pdf_rev: f32,
}

impl Vertex<'_> {
    fn new(kind: Kind, at: Spot, beta: Rgb) -> Self {
        Vertex {
            kind,
            p: at.p,
            error: at.error,
            n: at.n,
            bsdf: None,
            emission: Rgb::ZERO,
            light: None,
            beta,
            delta: false,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
        }
    }

    /// Where connections to the vertex start and end.
    fn spot(&self) -> Spot {
        Spot {
            p: self.p,
            error: self.error,
            n: self.n,
        }
    }

    fn connectible(&self) -> bool {
        match self.kind {
            Kind::Surface => self.bsdf.is_some_and(|b| b.has_non_delta()),
            _ => true,
        }
    }

    fn is_delta_light(&self) -> bool {
        matches!(self.kind, Kind::Light { point: true, .. })
    }

    /// Converts a solid-angle density at this vertex towards `next` into an area density at
    /// `next`.
    fn area_density(&self, pdf: f32, next: &Vertex) -> f32 {
        let d = next.p - self.p;
        let dist2 = d.length_squared();
        if dist2 == 0.0 {
            return 0.0;
        }
        let mut pdf = pdf / dist2;
        if next.n != Vec3::ZERO {
            pdf *= next.n.dot(d / dist2.sqrt()).abs();
        }
        pdf
    }

    /// Area density at `next` of sampling it from this vertex (reached from `prev`).
    fn pdf(
        &self,
        ctx: &Context,
        camera: &CameraBasis,
        prev: Option<&Vertex>,
        next: &Vertex,
    ) -> f32 {
        let w = (next.p - self.p).normalize();
        let pdf = match self.kind {
            Kind::Camera => camera_pdf_dir(camera, self.p, w),
            Kind::Light { .. } => return self.pdf_light(ctx, next),
            Kind::Surface => match (self.bsdf, prev) {
                (Some(b), Some(prev)) => b.pdf((prev.p - self.p).normalize(), w),
                _ => 0.0,
            },
        };
        self.area_density(pdf, next)
    }

    /// Area density at `next` of a light path leaving this emitter vertex towards it.
    fn pdf_light(&self, ctx: &Context, next: &Vertex) -> f32 {
        let w = (next.p - self.p).normalize();
        let pdf_dir = match self.kind {
            Kind::Light { light, point: true } => {
                ctx.lights.emitters[light].model().pdf_emission_direction(w)
            }
            _ => match self.area_light(ctx) {
                Some(a) if a.two_sided => 0.5 * w.dot(self.n).abs() / PI,
                _ => w.dot(self.n).max(0.0) / PI,
            },
        };
        self.area_density(pdf_dir, next)
    }

    /// The area light this vertex lies on (a light subpath's start or an emitter hit).
    fn area_light<'c>(&self, ctx: &'c Context) -> Option<&'c crate::scene::lights::AreaLight> {
        let light = match self.kind {
            Kind::Light { light, .. } => light,
            _ => self.light?,
        };
        match &ctx.lights.emitters[light] {
            Emitter::Area(a) => Some(a),
            _ => None,
        }
    }

    /// The emission cosine towards unit `w` from an area-light vertex: 0 behind a one-sided
    /// light, |cos| for a two-sided one.
    fn emitting_cos(&self, ctx: &Context, w: Vec3) -> f32 {
        let cos = w.dot(self.n);
        match self.area_light(ctx) {
            Some(a) => a.emitting_cos(cos),
            None => cos.max(0.0),
        }
    }

    /// Area density of choosing this emitter point when starting a light path.
    fn pdf_light_origin(&self, ctx: &Context) -> f32 {
        let light = match self.kind {
            Kind::Light { light, .. } => light,
            _ => match self.light {
                Some(l) => l,
                None => return 0.0,
            },
        };
        match &ctx.lights.emitters[light] {
            Emitter::Area(a) => ctx.lights.pmf(light) / a.area,
            e if e.model().point_source().is_some() => ctx.lights.pmf(light),
            _ => 0.0,
        }
    }

    /// f·|cos| towards `next` (the connection step), for a surface or light vertex.
    fn f(&self, prev: Option<&Vertex>, next: &Vertex, mode: Transport) -> Rgb {
        let w = (next.p - self.p).normalize();
        match (self.kind, self.bsdf, prev) {
            (Kind::Surface, Some(b), Some(prev)) => b.eval((prev.p - self.p).normalize(), w, mode),
            _ => Rgb::ZERO,
        }
    }
}

/// Density in solid angle of the camera generating a ray along `w` from the lens point
/// `lens`: uniform over the film at unit distance, 1 / (A_film cos³θ) (pbrt-v4's `PDF_We`;
/// the lens point's own density is the same for every strategy and cancels). Zero outside
/// the film.
fn camera_pdf_dir(camera: &CameraBasis, lens: Vec3, w: Vec3) -> f32 {
    match camera.raster_from(lens, lens + w) {
        Some((x, y, cos)) => {
            let (fw, fh) = camera.film_size();
            let m = camera.margin;
            if x < -m || y < -m || x >= fw + m || y >= fh + m {
                return 0.0;
            }
            1.0 / (camera.pixel_area() * fw * fh * cos * cos * cos)
        }
        None => 0.0,
    }
}

/// Where a random walk starts: the ray leaving a subpath's last vertex, with throughput
/// `beta` and solid-angle density `pdf` for its direction; the walk adds at most `max` more
/// vertices, carrying `mode`.
struct WalkStart {
    ray: Ray,
    beta: Rgb,
    pdf: f32,
    max: u32,
    mode: Transport,
}

/// Extends `path` by a random walk from `start`.
fn random_walk<'a>(
    ctx: &Context<'a>,
    start: WalkStart,
    path: &mut Vec<Vertex<'a>>,
    sampler: &mut Sampler,
    stats: &mut RayStats,
) {
    let WalkStart {
        mut ray,
        mut beta,
        mut pdf,
        max,
        mode,
    } = start;
    let mut bounces = 0;
    while bounces < max {
        let Some(sp) = ctx.intersect(&ray, stats) else {
            break;
        };
        let m = &ctx.scene.materials[sp.material];
        let wo = -ray.dir;
        let bsdf = m.bsdf(&sp, wo);
        let mut v = Vertex::new(Kind::Surface, sp.spot(), beta);
        v.bsdf = Some(bsdf);
        if m.is_emissive() {
            v.emission = m.emission_at(sp.p, sp.uv, sp.ng);
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
        beta *= bs.weight;
        let (cur, prev) = (path[n - 1], path[n - 2]);
        path[n - 2].pdf_rev = cur.area_density(pdf_rev, &prev);
        ray = sp.spawn(bs.wi);
        // Russian roulette keeps long subpaths rare; the MIS weights need not know about it
        // (they still sum to one over the strategies of a path).
        if beta == Rgb::ZERO || !russian_roulette(&mut beta, bounces, sampler) {
            break;
        }
    }
}

fn remap0(x: f32) -> f32 {
    if x != 0.0 {
        x
    } else {
        1.0
    }
}

/// The strategy (s, t): the path made of the light subpath's first `s` vertices connected to
/// the camera subpath's first `t`.
#[derive(Clone, Copy)]
struct Connection<'p, 'a> {
    light: &'p [Vertex<'a>],
    camera: &'p [Vertex<'a>],
    s: usize,
    t: usize,
}

impl Connection<'_, '_> {
    /// The multiple importance sampling weight of the strategy for the path made of
    /// `light[..s]` and `camera[..t]`, with `sampled` replacing the connection vertex that
    /// strategy sampled anew (the camera for t = 1).
    fn mis_weight(&self, ctx: &Context, camera_basis: &CameraBasis) -> f32 {
        let Connection {
            light,
            camera,
            s,
            t,
        } = *self;
        if s + t == 2 {
            return 1.0;
        }
        let mut lv: Vec<Vertex> = light[..s].to_vec();
        let mut cv: Vec<Vertex> = camera[..t].to_vec();
        // The connection vertices are connected, so not delta for this strategy.
        if s > 0 {
            lv[s - 1].delta = false;
        }
        if t > 0 {
            cv[t - 1].delta = false;
        }
        // Reverse densities of the connection vertices and their predecessors.
        if t > 0 {
            let pt = cv[t - 1];
            let pt_minus = if t > 1 { Some(cv[t - 2]) } else { None };
            cv[t - 1].pdf_rev = if s > 0 {
                let qs_minus = if s > 1 { Some(&lv[s - 2]) } else { None };
                lv[s - 1].pdf(ctx, camera_basis, qs_minus, &pt)
            } else {
                pt.pdf_light_origin(ctx)
            };
            if let Some(ptm) = pt_minus {
                cv[t - 2].pdf_rev = if s > 0 {
                    pt.pdf(ctx, camera_basis, Some(&lv[s - 1]), &ptm)
                } else {
                    pt.pdf_light(ctx, &ptm)
                };
            }
        }
        if s > 0 {
            let qs = lv[s - 1];
            let pt = cv[t - 1];
            let pt_minus = if t > 1 { Some(&cv[t - 2]) } else { None };
            lv[s - 1].pdf_rev = pt.pdf(ctx, camera_basis, pt_minus, &qs);
            if s > 1 {
                let qsm = lv[s - 2];
                lv[s - 2].pdf_rev = qs.pdf(ctx, camera_basis, Some(&pt), &qsm);
            }
        }
        let mut sum = 0.0f32;
        let mut r = 1.0f32;
        for i in (1..t).rev() {
            r *= remap0(cv[i].pdf_rev) / remap0(cv[i].pdf_fwd);
            if !cv[i].delta && !cv[i - 1].delta {
                sum += r * r;
            }
        }
        r = 1.0;
        for i in (0..s).rev() {
            r *= remap0(lv[i].pdf_rev) / remap0(lv[i].pdf_fwd);
            let delta_before = if i > 0 {
                lv[i - 1].delta
            } else {
                lv[0].is_delta_light()
            };
            if !lv[i].delta && !delta_before {
                sum += r * r;
            }
        }
        1.0 / (1.0 + sum)
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
        let max_depth = self.options.max_depth;
        // Camera subpath.
        let mut cam_path: Vec<Vertex> = Vec::with_capacity(max_depth as usize + 2);
        // The camera vertex is where the ray leaves: the pinhole or a point of the lens.
        cam_path.push(Vertex::new(
            Kind::Camera,
            Spot::exact(camera_ray.origin),
            Rgb::ONE,
        ));
        let pdf_cam = camera_pdf_dir(camera, camera_ray.origin, camera_ray.dir);
        random_walk(
            ctx,
            WalkStart {
                ray: *camera_ray,
                beta: Rgb::ONE,
                pdf: pdf_cam,
                max: max_depth + 1,
                mode: Transport::Radiance,
            },
            &mut cam_path,
            sampler,
            stats,
        );
        // Light subpath.
        let mut light_path: Vec<Vertex> = Vec::with_capacity(max_depth as usize + 1);
        let u_choose = sampler.next_2d();
        let u_pos = sampler.next_2d();
        let u_dir = sampler.next_2d();
        if let Some((light, at, pdf_pos, point, le)) = sample_light_point(ctx, u_choose.x, u_pos) {
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
            light_path.push(v0);
            if pdf_dir > 0.0 {
                // A spot light's intensity falls off towards the edge of its cone.
                let le_dir = if point {
                    ctx.lights.emitters[light].model().intensity_towards(dir)
                } else {
                    le
                };
                random_walk(
                    ctx,
                    WalkStart {
                        ray: at.spawn(dir).at_time(camera_ray.time),
                        beta: le_dir * (cos / (pdf_pos * pdf_dir)),
                        pdf: pdf_dir,
                        max: max_depth,
                        mode: Transport::Importance,
                    },
                    &mut light_path,
                    sampler,
                    stats,
                );
            }
        }

        let mut radiance = Rgb::ZERO;
        for t in 1..=cam_path.len() {
            for s in 0..=light_path.len() {
                let depth = s as i64 + t as i64 - 2;
                // (s, t) = (1, 1), the light's own point splatted to the camera, is left out:
                // (0, 2), the camera ray hitting the light, renders visible lights alone
                // (both would need weights, and the first is by far the noisier).
                if depth < 0 || depth > max_depth as i64 || (s == 1 && t == 1) {
                    continue;
                }
                match (s, t) {
                    (0, _) => {
                        // The camera path found an emitter.
                        let pt = &cam_path[t - 1];
                        if pt.kind != Kind::Surface || pt.light.is_none() {
                            continue;
                        }
                        let to_prev = cam_path[t - 2].p - pt.p;
                        if pt.emitting_cos(ctx, to_prev) <= 0.0 {
                            continue;
                        }
                        let l = pt.beta * pt.emission;
                        if l == Rgb::ZERO {
                            continue;
                        }
                        let w = Connection {
                            light: &light_path,
                            camera: &cam_path,
                            s: 0,
                            t,
                        }
                        .mis_weight(ctx, camera);
                        radiance += l * w;
                    }
                    (_, 1) => {
                        // A light vertex seen by the camera: splatted.
                        let qs = &light_path[s - 1];
                        if !qs.connectible() {
                            continue;
                        }
                        // A lens point of its own (the pinhole draws nothing).
                        let lens = lens_sample(camera, sampler);
                        let Some(c) = connect_to_camera(
                            ctx,
                            camera,
                            lens,
                            &qs.spot(),
                            camera_ray.time,
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
                            light: &light_path,
                            camera: &cam_only,
                            s,
                            t: 1,
                        }
                        .mis_weight(ctx, camera);
                        splats.push(Splat {
                            x: c.x,
                            y: c.y,
                            value: value * w,
                        });
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
                                ctx.lights.emitters[light].model().intensity_towards(-wdir)
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
                        let segment = pt.spot().spawn_to(&qs.spot());
                        if ctx.occluded(&segment.at_time(camera_ray.time), stats) {
                            continue;
                        }
                        let w = Connection {
                            light: &light_path,
                            camera: &cam_path,
                            s,
                            t,
                        }
                        .mis_weight(ctx, camera);
                        radiance += l * w;
                    }
                }
            }
        }
        radiance
    }
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
