//! A directional light: parallel light travelling along one direction, with irradiance E on
//! a surface facing it (the sun, far away).

use super::{EmissionSample, Illumination, LightModel, LightSample, World};
use crate::math::warp::concentric_disk;
use crate::math::{frame, luminance, Rgb, Vec2, Vec3};
use crate::spectrum::BlackbodyEmission;
use std::f32::consts::PI;

#[derive(Clone, Debug, PartialEq)]
pub struct DirectionalLight {
    /// The direction light travels, as the scene gives it.
    pub direction: Vec3,
    pub irradiance: Rgb,
    /// A blackbody's spectrum, when `irradiance` is its colour times the luminance.
    pub spectrum: Option<BlackbodyEmission>,
    /// `direction`, unit length.
    unit: Vec3,
}

impl DirectionalLight {
    pub fn new(direction: Vec3, irradiance: Rgb) -> DirectionalLight {
        DirectionalLight {
            direction,
            irradiance,
            spectrum: None,
            unit: direction.normalize(),
        }
    }
}

/// A point on the disk of the bounding sphere facing `dir`, upstream of the scene, from
/// `u` (where infinite lights start their light paths).
pub(super) fn world_disk(world: &World, dir: Vec3, u: Vec2) -> Vec3 {
    let (t, b) = frame(dir);
    let d = concentric_disk(u) * world.radius;
    world.center + t * d.x + b * d.y - dir * world.radius
}

impl LightModel for DirectionalLight {
    fn spectrum(&self) -> Option<BlackbodyEmission> {
        self.spectrum
    }

    fn power(&self, world: &World) -> f32 {
        PI * world.radius * world.radius * luminance(self.irradiance)
    }

    fn sample_li(&self, p: Vec3, _u: Vec2, choice: f32, world: &World) -> Option<LightSample> {
        let direction = self.unit;
        let far = p - direction * (4.0 * world.radius + (p - world.center).length());
        Some(LightSample::delta(self.irradiance, -direction, far, choice))
    }

    fn pdf_li(&self, _p: Vec3, _q: Vec3, _n: Vec3, _choice: f32) -> f32 {
        0.0
    }

    fn sample_le(
        &self,
        u_pos: Vec2,
        _u_dir: Vec2,
        choice: f32,
        world: &World,
        light: usize,
    ) -> Option<EmissionSample> {
        let direction = self.unit;
        Some(EmissionSample {
            p: world_disk(world, direction, u_pos),
            error: Vec3::ZERO,
            n: direction,
            dir: direction,
            radiance: self.irradiance,
            pdf_pos: choice / (PI * world.radius * world.radius),
            pdf_dir: 1.0,
            delta_pos: false,
            delta_dir: true,
            light,
        })
    }

    fn is_infinite(&self) -> bool {
        true
    }

    fn illuminate(&self, _p: Vec3) -> Option<Illumination> {
        Some(Illumination {
            wi: -self.unit,
            irradiance: self.irradiance,
            position: None,
        })
    }
}
