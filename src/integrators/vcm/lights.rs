//! What vertex connection and merging asks of the lights: where a light subpath starts, a
//! light point for next-event estimation drawn from the same distribution (so that its
//! density does not depend on the receiver, as the recursive weights need), and the
//! densities of both for an emitter a camera subpath hits.

use crate::math::{Rgb, Vec2, Vec3};
use crate::scene::lights::{EmissionSample, Emitter};
use crate::transport::Context;
use std::f32::consts::PI;

/// A point (or, at infinity, a direction) of an emitter, with the densities the weights
/// need, each including the choice of the emitter.
#[derive(Clone, Copy, Debug)]
pub(super) struct LightPoint {
    /// Radiance leaving the point towards the receiver (a point light's intensity; a
    /// directional light's irradiance).
    pub radiance: Rgb,
    /// The density of next-event estimation choosing it: over area for finite lights (the
    /// choice alone for point lights), over solid angle at infinity.
    pub direct_pdf_a: f32,
    /// The density of a light subpath starting there and leaving towards the receiver
    /// (position times solid angle).
    pub emission_pdf_w: f32,
    /// |cos| at the light towards the receiver (1 for points and lights at infinity).
    pub cos_at_light: f32,
    /// A point light or a directional light: no subpath can hit it.
    pub delta: bool,
    pub finite: bool,
}

/// The light point of emission sample `es`, leaving along `es.dir`.
pub(super) fn of_emission(ctx: &Context, es: &EmissionSample) -> LightPoint {
    let finite = !ctx.lights.is_infinite(es.light);
    let delta = es.delta_pos || es.delta_dir;
    let pmf = ctx.lights.pmf(es.light);
    let (direct_pdf_a, cos_at_light) = if finite {
        let cos = if es.delta_pos {
            1.0
        } else {
            es.n.dot(es.dir).abs()
        };
        (es.pdf_pos, cos)
    } else {
        (pmf * es.pdf_dir, 1.0)
    };
    LightPoint {
        radiance: es.radiance,
        direct_pdf_a,
        emission_pdf_w: es.pdf_pos * es.pdf_dir,
        cos_at_light,
        delta,
        finite,
    }
}

/// A light point for next-event estimation at `p`: an emitter chosen by power and a point
/// of it as a light subpath would start, with the radiance and densities towards `p`.
/// Returns it with the unit direction from `p` to it, and its position (`None` at
/// infinity). `u_dir` is asked for an emission direction's numbers only by lights that
/// need one (not area lights), so that the sampler's dimensions are not spent for nothing.
pub(super) fn sample_towards(
    ctx: &Context,
    p: Vec3,
    u_choose: f32,
    u_pos: Vec2,
    u_dir: impl FnOnce() -> Vec2,
) -> Option<(LightPoint, Vec3, Option<crate::math::spawn::Spot>)> {
    let lights = &ctx.lights;
    let (i, _) = lights.choose(u_choose)?;
    let pmf = lights.pmf(i);
    let emitter = &lights.emitters[i];
    if let Emitter::Area(a) = emitter {
        // Only the point: a light subpath's direction from it is not needed here.
        let q = a.sample(u_pos);
        let to = q.p - p;
        let dist2 = to.length_squared();
        if dist2.is_nan() || dist2 <= 0.0 {
            return None;
        }
        let wi = to / dist2.sqrt();
        let cos = a.emitting_cos(q.n.dot(-wi));
        if cos <= 0.0 {
            return None;
        }
        let (direct_pdf_a, emission_pdf_w) = area_densities(ctx, i, cos)?;
        let lp = LightPoint {
            radiance: a.radiance_at(&q),
            direct_pdf_a,
            emission_pdf_w,
            cos_at_light: cos,
            delta: false,
            finite: true,
        };
        return Some((lp, wi, Some(q.spot())));
    }
    let es = emitter
        .model()
        .sample_le(u_pos, u_dir(), pmf, &lights.world, i)?;
    if lights.is_infinite(i) {
        if es.pdf_dir.is_nan() || es.pdf_dir <= 0.0 {
            return None;
        }
        return Some((of_emission(ctx, &es), -es.dir, None));
    }
    let to = es.p - p;
    let dist2 = to.length_squared();
    if dist2.is_nan() || dist2 <= 0.0 {
        return None;
    }
    let wi = to / dist2.sqrt();
    let e = emitter.model();
    let lp = LightPoint {
        radiance: e.intensity_towards(-wi),
        direct_pdf_a: es.pdf_pos,
        emission_pdf_w: es.pdf_pos * e.pdf_emission_direction(-wi),
        cos_at_light: 1.0,
        delta: true,
        finite: true,
    };
    Some((lp, wi, Some(es.spot())))
}

/// The densities of area light `light` at a point with geometric normal `n`, emitting
/// towards unit `w` with |cos| `cos` (already checked to emit): (direct, emission).
pub(super) fn area_densities(ctx: &Context, light: usize, cos: f32) -> Option<(f32, f32)> {
    match &ctx.lights.emitters[light] {
        Emitter::Area(a) => {
            let direct = ctx.lights.pmf(light) / a.area;
            let side = if a.two_sided { 0.5 } else { 1.0 };
            Some((direct, direct * side * cos / PI))
        }
        _ => None,
    }
}

/// The densities of the background `light` sending light along unit `travel`: (direct in
/// solid angle, emission over the scene's disk times solid angle).
pub(super) fn background_densities(ctx: &Context, light: usize, travel: Vec3) -> (f32, f32) {
    let lights = &ctx.lights;
    let direct = lights.pmf(light)
        * lights.emitters[light]
            .model()
            .pdf_emission_direction(travel);
    let r = lights.world.radius;
    (direct, direct / (PI * r * r))
}
