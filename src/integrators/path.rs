//! Path tracing: the gathering estimator of the rendering equation (Dutré, Lafortune &
//! Willems). Paths start at the camera; at every non-specular vertex, next-event estimation
//! samples a light, and the BSDF-sampled continuation may also hit an emitter: the two
//! strategies are combined by multiple importance sampling with the power heuristic.
//! Russian roulette ends paths whose throughput has become small.

use crate::bsdf::{Bsdf, Transport};
use crate::error::{Error, Result};
use crate::math::sobol::Sampler;
use crate::math::warp::power_heuristic;
use crate::math::{Ray, Rgb, Vec2, Vec3};
use crate::scene::camera::CameraBasis;
use crate::scene::SurfacePoint;
use crate::settings::TechniqueKind;
use crate::transport::light_passes::PassSample;
use crate::transport::settings::{
    MonteCarloSettings, TechniqueInfo, ADAPTIVE, COMMON, GUIDING, MONTE_CARLO, SPECTRAL,
};
use crate::transport::spectral::{Colours, RgbColours, Wavelengths};
use crate::transport::technique::{Lifecycle, SampledTechnique};
use crate::transport::{Context, MonteCarlo, RayStats, Splat};

use super::light_passes::{NoPasses, Passes, Record};

/// Default number of bounces (pbrt's convention: 1 is direct lighting only).
pub const DEFAULT_MAX_DEPTH: u32 = 8;
/// Largest accepted --max-depth.
pub const MAX_DEPTH_LIMIT: u32 = 1024;

/// The path tracer, as the technique list shows it.
pub(crate) const TECHNIQUE: TechniqueInfo = TechniqueInfo {
    kind: TechniqueKind::Path,
    summary: "Path tracing with next-event estimation and multiple importance sampling.",
    settings: &[COMMON, MONTE_CARLO, ADAPTIVE, GUIDING, SPECTRAL],
    pbrt: &["path", "volpath", "simplepath"],
    progressive: true,
    renders_parts: true,
    follows_time: true,
    media: true,
};

/// The technique: nothing to prepare, sample passes.
pub(crate) fn lifecycle(mc: &MonteCarloSettings) -> Result<Box<dyn Lifecycle>> {
    if mc.spectral && mc.guiding {
        return Err(Error::setting(
            "spectral",
            "does not apply with path guiding",
        ));
    }
    Ok(Box::new(SampledTechnique {
        integrator: PathTracer::new(PathOptions {
            max_depth: mc.max_depth,
        })
        .with_guiding(mc.guiding)
        .with_spectral(mc.spectral),
        settings: *mc,
    }))
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathOptions {
    /// Maximum number of bounces.
    pub max_depth: u32,
}

impl Default for PathOptions {
    fn default() -> Self {
        PathOptions {
            max_depth: DEFAULT_MAX_DEPTH,
        }
    }
}

pub struct PathTracer {
    options: PathOptions,
    /// Path guiding (surfaces only).
    guiding: bool,
    /// Light at sampled wavelengths, not RGB (surfaces only).
    spectral: bool,
}

impl PathTracer {
    pub fn new(options: PathOptions) -> Self {
        PathTracer {
            options,
            guiding: false,
            spectral: false,
        }
    }

    /// The same tracer, in spectral mode or RGB.
    pub fn with_spectral(self, spectral: bool) -> Self {
        PathTracer { spectral, ..self }
    }

    /// The same tracer, with path guiding on or off.
    pub fn with_guiding(self, guiding: bool) -> Self {
        PathTracer { guiding, ..self }
    }

    pub(crate) fn max_depth(&self) -> u32 {
        self.options.max_depth
    }
}

/// Bounces before Russian roulette starts (Mitsuba's default). Starting at 2, as pbrt does,
/// traces a third fewer rays on the Cornell box but doubles the variance at equal samples.
pub const RR_START_DEPTH: u32 = 5;

/// Russian roulette from [`RR_START_DEPTH`] bounces on: the path survives with probability
/// max(β) (at most 1) and is reweighted to stay unbiased.
pub(crate) fn russian_roulette(beta: &mut Rgb, depth: u32, sampler: &mut Sampler) -> bool {
    if depth < RR_START_DEPTH {
        return true;
    }
    let u = sampler.next_1d();
    let q = beta.max_element().min(1.0);
    if u >= q {
        return false;
    }
    *beta /= q;
    true
}

/// Next-event estimation at a non-specular vertex: one light sample, tested for shadow and
/// weighted against BSDF sampling by the power heuristic; returns f·L·w / pdf. `facing`:
/// the BSDF's reflecting side (`Bsdf::reflecting_side`), to weigh the background's
/// directions by their cosine; the path's [`escaped`] must be given the same.
#[allow(clippy::too_many_arguments)]
pub(crate) fn sample_direct(
    ctx: &Context,
    bsdf: &Bsdf,
    sp: &SurfacePoint,
    wo: Vec3,
    facing: Option<Vec3>,
    u_choice: f32,
    u_light: Vec2,
    stats: &mut RayStats,
) -> Rgb {
    let u = (u_choice, u_light);
    sample_direct_towards(ctx, bsdf, sp, wo, facing, u, stats, &RgbColours).0
}

/// [`sample_direct`] and the direction of the light sample (zero if none was drawn).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn sample_direct_towards(
    ctx: &Context,
    bsdf: &Bsdf,
    sp: &SurfacePoint,
    wo: Vec3,
    facing: Option<Vec3>,
    (u_choice, u_light): (f32, Vec2),
    stats: &mut RayStats,
    colours: &impl Colours,
) -> (Rgb, Vec3) {
    let Some(ls) = ctx.lights.sample_li_facing(sp.p, facing, u_choice, u_light) else {
        return (Rgb::ZERO, Vec3::ZERO);
    };
    let (f, bsdf_pdf) = bsdf.eval_and_pdf(wo, ls.wi, Transport::Radiance);
    if f == Rgb::ZERO || ls.pdf <= 0.0 {
        return (Rgb::ZERO, ls.wi);
    }
    let shadow = sp.spawn_to(&ls.spot());
    if ctx.occluded(&shadow, stats) {
        return (Rgb::ZERO, ls.wi);
    }
    let w = if ls.delta {
        1.0
    } else {
        power_heuristic(ls.pdf, bsdf_pdf)
    };
    let le = colours.emission(ls.radiance, || {
        ctx.lights.spectrum_chosen_at(sp.p, u_choice)
    });
    (f * le * (w / ls.pdf), ls.wi)
}

/// What a path that left the scene along `ray` (from `prev_p`, whose next-event estimation
/// was given `prev_facing`) brings back from the background with throughput `beta`,
/// weighted against light sampling by the density the direction was drawn with (`pdf`, and
/// `specular`: a delta lobe, no MIS).
pub(crate) fn escaped(
    ctx: &Context,
    ray: &Ray,
    prev: (Vec3, Option<Vec3>),
    beta: Rgb,
    sampled: (f32, bool),
) -> Rgb {
    escaped_in(ctx, ray, prev, beta, sampled, &RgbColours)
}

/// [`escaped`] with the background's colour as `colours` gives it.
#[inline(always)]
fn escaped_in(
    ctx: &Context,
    ray: &Ray,
    (prev_p, prev_facing): (Vec3, Option<Vec3>),
    beta: Rgb,
    (pdf, specular): (f32, bool),
    colours: &impl Colours,
) -> Rgb {
    let lights = &ctx.lights;
    let Some(bg) = lights.background_light() else {
        return Rgb::ZERO;
    };
    let le = colours.emission(lights.background_radiance(ray.dir), || None);
    let w = if specular {
        1.0
    } else {
        let to = prev_p + ray.dir;
        power_heuristic(
            pdf,
            lights.pdf_li_facing(bg, prev_p, prev_facing, to, Vec3::ZERO),
        )
    };
    beta * le * w
}

/// The emission of the emitting surface `sp` reached from `prev_p` with throughput `beta`,
/// weighted against light sampling as [`escaped`] weighs the background.
pub(crate) fn emitted(
    ctx: &Context,
    sp: &SurfacePoint,
    prev_p: Vec3,
    beta: Rgb,
    sampled: (f32, bool),
) -> Rgb {
    emitted_in(ctx, sp, prev_p, beta, sampled, &RgbColours)
}

/// [`emitted`] with the emission's colour as `colours` gives it.
#[inline(always)]
fn emitted_in(
    ctx: &Context,
    sp: &SurfacePoint,
    prev_p: Vec3,
    beta: Rgb,
    (pdf, specular): (f32, bool),
    colours: &impl Colours,
) -> Rgb {
    let lights = &ctx.lights;
    let w = match sp.world_shape().and_then(|s| lights.light_of_shape(s)) {
        Some(l) if !specular => power_heuristic(pdf, lights.pdf_li(l, prev_p, sp.p, sp.ng)),
        _ => 1.0,
    };
    let m = &ctx.scene.materials[sp.material];
    let le = colours.emission(m.emission_at(sp.p, sp.uv, sp.ng), || m.emission_spectrum);
    beta * le * w
}

impl MonteCarlo for PathTracer {
    fn guided(&self) -> bool {
        self.guiding
    }

    fn sample_guided(
        &self,
        ctx: &Context,
        camera: &CameraBasis,
        ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        splats: &mut Vec<Splat>,
        guidance: &mut crate::guiding::Guidance,
    ) -> Rgb {
        // The guide covers surfaces: in media the volumetric tracer goes unguided.
        if ctx.has_media() {
            return self.sample(ctx, camera, ray, sampler, stats, splats);
        }
        self.radiance_guided(ctx, ray, sampler, stats, guidance)
    }

    fn sample(
        &self,
        ctx: &Context,
        _camera: &CameraBasis,
        camera_ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        _splats: &mut Vec<Splat>,
    ) -> Rgb {
        if ctx.has_media() {
            let lengths = super::volumetric::Lengths {
                max_depth: self.options.max_depth,
                rr_start: RR_START_DEPTH,
            };
            use super::volumetric::radiance;
            if self.spectral {
                let mut lambda = Wavelengths::sample(sampler.next_1d());
                let v = radiance(ctx, camera_ray, lengths, sampler, stats, &mut lambda);
                return lambda.output(v);
            }
            return radiance(ctx, camera_ray, lengths, sampler, stats, &mut RgbColours);
        }
        if self.spectral {
            let mut lambda = Wavelengths::sample(sampler.next_1d());
            let v = self.trace(ctx, camera_ray, sampler, stats, &mut NoPasses, &mut lambda);
            return lambda.output(v);
        }
        self.trace(
            ctx,
            camera_ray,
            sampler,
            stats,
            &mut NoPasses,
            &mut RgbColours,
        )
    }

    fn sample_passes(
        &self,
        ctx: &Context,
        _camera: &CameraBasis,
        camera_ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        passes: &mut PassSample,
    ) -> Option<Rgb> {
        // The light passes follow surfaces: the volumetric tracer has none.
        if ctx.has_media() {
            return None;
        }
        let mut passes = Passes::new(passes);
        Some(self.trace(
            ctx,
            camera_ray,
            sampler,
            stats,
            &mut passes,
            &mut RgbColours,
        ))
    }
}

impl PathTracer {
    /// The path of one camera sample (surfaces only), telling `record` what it adds, with
    /// the scene's colours as `colours` gives them.
    #[inline(always)]
    fn trace<R: Record, C: Colours>(
        &self,
        ctx: &Context,
        camera_ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        record: &mut R,
        colours: &mut C,
    ) -> Rgb {
        let mut radiance = Rgb::ZERO;
        let mut beta = Rgb::ONE;
        let mut ray = *camera_ray;
        // Density of the last BSDF sample, and whether it was a delta lobe (no MIS then).
        let mut bsdf_pdf = 0.0;
        let mut specular = true;
        let mut prev_p = ray.origin;
        let mut prev_facing = None;
        let mut depth = 0;
        let lights = &ctx.lights;
        loop {
            let Some(sp) = ctx.intersect_at_depth(&ray, depth, stats) else {
                let prev = (prev_p, prev_facing);
                let c = escaped_in(ctx, &ray, prev, beta, (bsdf_pdf, specular), colours);
                radiance += c;
                record.emission(depth, true, c, || lights.background_light());
                break;
            };
            let m = &ctx.scene.materials[sp.material];
            let wo = -ray.dir;
            if m.emits_towards(wo, sp.ng) {
                let c = emitted_in(ctx, &sp, prev_p, beta, (bsdf_pdf, specular), colours);
                radiance += c;
                let light = || sp.world_shape().and_then(|s| lights.light_of_shape(s));
                record.emission(depth, false, c, light);
            }
            if depth == self.options.max_depth {
                if R::ACTIVE && depth == 0 {
                    record.first_surface(&m.bsdf(&sp, wo));
                }
                break;
            }
            let vertex = depth;
            depth += 1;
            let bsdf = colours.bsdf(m.bsdf(&sp, wo));
            if vertex == 0 {
                record.first_surface(&bsdf);
            }
            let u_choice = sampler.next_2d();
            let u_light = sampler.next_2d();
            let facing = bsdf.reflecting_side(wo);
            if bsdf.has_non_delta() {
                let (u, v) = (u_choice.x, u_light);
                let (d, wi) =
                    sample_direct_towards(ctx, &bsdf, &sp, wo, facing, (u, v), stats, colours);
                let c = beta * d;
                radiance += c;
                let light = || lights.choose_at(sp.p, u).map(|(i, _)| i);
                record.direct(vertex, c, &bsdf, (wo, wi), light);
            }
            let u_dir = sampler.next_2d();
            let Some(bs) = bsdf.sample(wo, u_choice.y, u_dir, Transport::Radiance) else {
                break;
            };
            record.scattered(vertex, &bsdf, wo, &bs);
            beta *= bs.weight;
            bsdf_pdf = bs.pdf;
            specular = bs.delta;
            prev_p = sp.p;
            prev_facing = facing;
            ray = sp.spawn(bs.wi);
            if !russian_roulette(&mut beta, depth, sampler) {
                break;
            }
        }
        radiance
    }
}
