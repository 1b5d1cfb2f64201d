//! Walking a ray through a medium: tentative collisions drawn against the majorant of each
//! stretch (delta tracking's free flights), in one channel, the path's hero (pbrt-v4's
//! `SampleT_maj`). The caller decides at each collision whether it absorbs, scatters or is
//! a null collision that the ray passes through; what stays of the majorant transmittance
//! is returned for the rest.

use super::{MediumModel, MediumPoint};
use crate::math::{Ray, Rgb, Rng, Vec3};

/// One tentative collision: where it is, what the medium is there, the majorant there and
/// the majorant transmittance since the previous collision (or the start). Coefficients are
/// per unit of the ray's parameter (per unit length for a unit direction), as the majorant.
pub struct Collision {
    pub p: Vec3,
    pub t: f32,
    pub point: MediumPoint,
    pub sigma_maj: Rgb,
    pub t_maj: Rgb,
    /// A uniform number for the caller's choice at the collision.
    pub u: f32,
}

/// The uniform numbers a walk draws: the first ones `given` (from the pixel's sampler, so
/// that the first collision of a flight is stratified over the pixel's samples), the rest
/// from a stream.
pub struct Uniforms<'a> {
    pub given: &'a [f32],
    pub rng: &'a mut Rng,
}

impl Uniforms<'_> {
    fn next(&mut self) -> f32 {
        match self.given.split_first() {
            Some((&u, rest)) => {
                self.given = rest;
                u
            }
            None => self.rng.uniform(),
        }
    }
}

/// Draws collisions along `ray` (see [`sample_majorant_from`]), every uniform number from
/// `rng`.
pub fn sample_majorant(
    medium: &dyn MediumModel,
    ray: &Ray,
    t_max: f32,
    hero: usize,
    rng: &mut Rng,
    at: &mut dyn FnMut(&Collision) -> bool,
) -> Rgb {
    let u = &mut Uniforms { given: &[], rng };
    sample_majorant_from(medium, ray, t_max, hero, u, at)
}

/// Draws collisions along `ray` up to `t_max` (in units of the ray's length) in `medium`,
/// with free flights sampled by channel `hero`'s majorant, and calls `at` for each; stops
/// when `at` returns false (the transmittance returned is then 1). Returns the majorant
/// transmittance from the last collision to `t_max`.
pub fn sample_majorant_from(
    medium: &dyn MediumModel,
    ray: &Ray,
    t_max: f32,
    hero: usize,
    rng: &mut Uniforms,
    at: &mut dyn FnMut(&Collision) -> bool,
) -> Rgb {
    let mut t_maj = Rgb::ONE;
    let mut stopped = false;
    let length = ray.dir.length();
    medium.segments(ray, t_max, &mut |seg| {
        let exp = |v: Rgb| Rgb::new((-v.x).exp(), (-v.y).exp(), (-v.z).exp());
        // A stretch beyond every float (an endless ray in a medium) is bounded by f32::MAX.
        let span = |a: f32, b: f32| {
            let dt = b - a;
            if dt.is_finite() {
                dt
            } else {
                f32::MAX
            }
        };
        let sigma = seg.sigma_maj[hero];
        if sigma <= 0.0 {
            t_maj *= exp(seg.sigma_maj * span(seg.t0, seg.t1));
            return true;
        }
        let mut t0 = seg.t0;
        loop {
            let t = t0 - (1.0 - rng.next()).ln() / sigma;
            if t < seg.t1 {
                t_maj *= exp(seg.sigma_maj * (t - t0));
                let p = ray.origin + ray.dir * t;
                let c = Collision {
                    p,
                    t,
                    point: per_parameter(medium.at(p), length),
                    sigma_maj: seg.sigma_maj,
                    t_maj,
                    u: rng.next(),
                };
                if !at(&c) {
                    stopped = true;
                    return false;
                }
                t_maj = Rgb::ONE;
                t0 = t;
            } else {
                t_maj *= exp(seg.sigma_maj * span(t0, seg.t1));
                return true;
            }
        }
    });
    if stopped {
        Rgb::ONE
    } else {
        t_maj
    }
}

/// The medium's coefficients per unit of a ray's parameter, for a direction of `length`.
fn per_parameter(point: MediumPoint, length: f32) -> MediumPoint {
    MediumPoint {
        sigma_a: point.sigma_a * length,
        sigma_s: point.sigma_s * length,
        ..point
    }
}
