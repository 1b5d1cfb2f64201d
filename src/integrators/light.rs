//! Light tracing: the shooting estimator, which solves the potential (importance) equation's
//! adjoint problem (Dutré, Lafortune & Willems). Paths start on the lights, chosen by power,
//! and every vertex is connected to the camera (the pinhole or a point of a thin lens) through
//! the camera's importance W_e; each connection is splatted onto the film where it lands. One light path is traced per
//! pixel sample, so a render with N samples per pixel traces N·width·height light paths.

use super::camera_connection::{connect_to_camera, lens_sample};
use super::path::russian_roulette;
use crate::bsdf::{Bsdf, Transport};
use crate::error::{Error, Result};
use crate::math::sobol::Sampler;
use crate::math::{Ray, Rgb, Vec3};
use crate::scene::camera::CameraBasis;
use crate::scene::lights::{EmissionSample, Emitter};
use crate::scene::Scene;
use crate::scene::SurfacePoint;
use crate::settings::TechniqueKind;
use crate::transport::settings::{
    MonteCarloSettings, TechniqueInfo, COMMON, MONTE_CARLO, SPECTRAL,
};
use crate::transport::spectral::{Colours, RgbColours, Wavelengths};
use crate::transport::technique::{Lifecycle, SampledTechnique};
use crate::transport::{Context, MonteCarlo, RayStats, Splat};

/// The light tracer, as the technique list shows it.
pub(crate) const TECHNIQUE: TechniqueInfo = TechniqueInfo {
    kind: TechniqueKind::Light,
    summary: "Light (particle) tracing: paths from the lights, connected to the camera.",
    settings: &[COMMON, MONTE_CARLO, SPECTRAL],
    pbrt: &["lighttracer"],
    progressive: true,
    renders_parts: false,
    follows_time: true,
    media: true,
};

/// The technique for `scene`: nothing to prepare, sample passes.
pub(crate) fn lifecycle(mc: &MonteCarloSettings, scene: &Scene) -> Result<Box<dyn Lifecycle>> {
    refuse_orthographic(scene, "light")?;
    super::volumetric_light::check_scene(scene).map_err(|e| Error::input(&scene.source, e))?;
    Ok(Box::new(SampledTechnique {
        integrator: LightTracer::new(LightOptions {
            max_depth: mc.max_depth,
            spectral: mc.spectral,
        }),
        settings: *mc,
    }))
}

/// Light paths reach the camera by connecting to it, which an orthographic camera's
/// importance (a delta in direction) does not allow; pbrt-v4 refuses it too.
pub(crate) fn refuse_orthographic(scene: &Scene, integrator: &str) -> Result<()> {
    if matches!(
        scene.camera.projection,
        crate::scene::Projection::Orthographic { .. }
    ) {
        return Err(Error::input(
            &scene.source,
            format!(
                "the {integrator} integrator cannot connect light paths to an orthographic camera (projection = \"orthographic\"): use a perspective camera or the path integrator"
            ),
        ));
    }
    Ok(())
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightOptions {
    /// Maximum number of bounces, counted as for the path tracer (a path of the same length
    /// from the camera would bounce this often).
    pub max_depth: u32,
    /// Light at sampled wavelengths, not RGB (surfaces only).
    pub spectral: bool,
}

pub struct LightTracer {
    options: LightOptions,
}

impl LightTracer {
    pub fn new(options: LightOptions) -> Self {
        LightTracer { options }
    }
}

impl MonteCarlo for LightTracer {
    fn sample(
        &self,
        ctx: &Context,
        camera: &CameraBasis,
        camera_ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        splats: &mut Vec<Splat>,
    ) -> Rgb {
        if ctx.has_media() {
            let lengths = super::volumetric::Lengths {
                max_depth: self.options.max_depth,
                rr_start: super::path::RR_START_DEPTH,
            };
            use super::volumetric_light::trace;
            if self.options.spectral {
                let mut lambda = Wavelengths::sample(sampler.next_1d());
                let c = &mut lambda;
                return trace(ctx, camera, camera_ray, lengths, sampler, stats, splats, c);
            }
            let c = &mut RgbColours;
            return trace(ctx, camera, camera_ray, lengths, sampler, stats, splats, c);
        }
        if self.options.spectral {
            let mut lambda = Wavelengths::sample(sampler.next_1d());
            return self.trace(ctx, camera, camera_ray, sampler, stats, splats, &mut lambda);
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

impl LightTracer {
    /// One light path (surfaces only) with the scene's colours as `colours` gives them; its
    /// splats and the background the camera ray sees are in the film's RGB.
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
        let lights = &ctx.lights;
        // The background seen directly cannot be reached from the lights' side: the camera
        // ray supplies it.
        let mut direct = Rgb::ZERO;
        if lights.background_light().is_some() && ctx.intersect(camera_ray, stats).is_none() {
            let le = colours.emission(lights.background_radiance(camera_ray.dir), || None);
            direct = colours.output(le);
        }
        let u_choose = sampler.next_2d();
        let u_pos = sampler.next_2d();
        let u_dir = sampler.next_2d();
        let Some(mut es) = lights.sample_le(u_choose.x, u_pos, u_dir) else {
            return direct;
        };
        es.radiance = colours.emission(es.radiance, || lights.spectrum(es.light));
        // The light's own point seen by the camera (area lights only: points, directions and
        // the background cannot be hit by camera rays either).
        if !es.delta_pos && !es.delta_dir && es.n != Vec3::ZERO && !ctx.lights.is_infinite(es.light)
        {
            let lens = lens_sample(camera, sampler);
            if let Some(c) =
                connect_to_camera(ctx, camera, lens, &es.spot(), camera_ray.time, stats)
            {
                // A two-sided light is seen from either side, whichever side it emitted to.
                let cos_l = match &ctx.lights.emitters[es.light] {
                    Emitter::Area(a) => a.emitting_cos(c.dir.dot(es.n)),
                    _ => c.dir.dot(es.n),
                };
                if cos_l > 0.0 {
                    splats.push(Splat {
                        x: c.x,
                        y: c.y,
                        value: colours.output(es.radiance * (cos_l * c.importance / es.pdf_pos)),
                    });
                }
            }
        }
        walk(
            ctx,
            &es,
            self.options.max_depth,
            camera_ray.time,
            sampler,
            stats,
            colours,
            |sp, bsdf, wo, beta, stats, sampler, colours| {
                if !bsdf.has_non_delta() {
                    return;
                }
                let lens = lens_sample(camera, sampler);
                if let Some(c) = connect_to_camera(ctx, camera, lens, &sp.spot(), sp.time, stats) {
                    let f = bsdf.eval(wo, c.dir, Transport::Importance);
                    if f != Rgb::ZERO {
                        splats.push(Splat {
                            x: c.x,
                            y: c.y,
                            value: colours.output(beta * f * c.importance),
                        });
                    }
                }
            },
        );
        direct
    }
}

/// The power a light path that starts with the emission sample `es` carries (radiance
/// times the cosine at the light over the densities of its position and direction) and its
/// first ray. A light at infinity starts on the scene's bounding disk, its cosine folded
/// into the disk's density.
pub(crate) fn emission_start(ctx: &Context, es: &EmissionSample, time: f32) -> (Rgb, Ray) {
    let at_infinity = ctx.lights.is_infinite(es.light);
    let cos0 = if es.delta_dir || es.delta_pos || at_infinity {
        1.0
    } else {
        es.n.dot(es.dir).abs()
    };
    let beta = es.radiance * (cos0 / (es.pdf_pos * es.pdf_dir));
    // Points off every surface (point lights, the disk of a distant light) have no error.
    let ray = es.spot().spawn(es.dir).at_time(time);
    (beta, ray)
}

/// Follows the light path that starts with the emission sample `es` over at most
/// `max_depth` surfaces: at each surface it reaches, calls `vertex(surface, bsdf, wo,
/// beta, stats, sampler, colours)` with the power `beta` the path carries there (radiance
/// over the densities of its start and bounces), then continues by sampling the BSDF for
/// importance transport, with Russian roulette. The BSDFs' colours are as `colours` gives
/// them; `es` carries its radiance as the path does.
#[allow(clippy::too_many_arguments)]
pub(crate) fn walk<C: Colours>(
    ctx: &Context,
    es: &EmissionSample,
    max_depth: u32,
    time: f32,
    sampler: &mut Sampler,
    stats: &mut RayStats,
    colours: &mut C,
    mut vertex: impl FnMut(&SurfacePoint, &Bsdf, Vec3, Rgb, &mut RayStats, &mut Sampler, &C),
) {
    let (mut beta, mut ray) = emission_start(ctx, es, time);
    let mut depth = 0;
    while depth < max_depth {
        let Some(sp) = ctx.intersect(&ray, stats) else {
            break;
        };
        depth += 1;
        let m = &ctx.scene.materials[sp.material];
        let wo = -ray.dir;
        let bsdf = colours.bsdf(m.bsdf(&sp, wo));
        vertex(&sp, &bsdf, wo, beta, stats, sampler, colours);
        let u = sampler.next_1d();
        let Some(bs) = bsdf.sample(wo, u, sampler.next_2d(), Transport::Importance) else {
            break;
        };
        beta *= bs.weight;
        ray = sp.spawn(bs.wi);
        if !russian_roulette(&mut beta, depth, sampler) {
            break;
        }
    }
}
