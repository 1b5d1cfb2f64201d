//! A point light: radiant intensity I (W/sr) from a point in every direction; irradiance
//! falls off as 1/r².

use super::{EmissionSample, Illumination, LightModel, LightSample, World};
use crate::math::warp::{uniform_sphere, UNIFORM_SPHERE_PDF};
use crate::math::{luminance, Rgb, Vec2, Vec3};
use std::f32::consts::PI;

#[derive(Clone, Debug, PartialEq)]
pub struct PointLight {
    pub position: Vec3,
    /// Radiant intensity (W/sr).
    pub intensity: Rgb,
}

impl LightModel for PointLight {
    fn power(&self, _world: &World) -> f32 {
        4.0 * PI * luminance(self.intensity)
    }

    fn sample_li(&self, p: Vec3, _u: Vec2, choice: f32, _world: &World) -> Option<LightSample> {
        let d = self.position - p;
        let dist2 = d.length_squared();
        Some(LightSample::point_source(
            self.position,
            self.intensity / dist2,
            d / dist2.sqrt(),
            choice,
        ))
    }

    fn pdf_li(&self, _p: Vec3, _q: Vec3, _n: Vec3, _choice: f32) -> f32 {
        0.0
    }

    fn sample_le(
        &self,
        _u_pos: Vec2,
        u_dir: Vec2,
        choice: f32,
        _world: &World,
        light: usize,
    ) -> Option<EmissionSample> {
        let (dir, pdf_dir) = self.emission_direction(u_dir);
        Some(EmissionSample {
            p: self.position,
            error: Vec3::ZERO,
            n: Vec3::ZERO,
            dir,
            radiance: self.intensity,
            pdf_pos: choice,
            pdf_dir,
            delta_pos: true,
            delta_dir: false,
            light,
        })
    }

    fn is_infinite(&self) -> bool {
        false
    }

    fn point_source(&self) -> Option<(Vec3, Rgb)> {
        Some((self.position, self.intensity))
    }

    fn intensity_towards(&self, _w: Vec3) -> Rgb {
        self.intensity
    }

    fn emission_direction(&self, u: Vec2) -> (Vec3, f32) {
        (uniform_sphere(u), UNIFORM_SPHERE_PDF)
    }

    fn pdf_emission_direction(&self, _w: Vec3) -> f32 {
        UNIFORM_SPHERE_PDF
    }

    fn illuminate(&self, p: Vec3) -> Option<Illumination> {
        let to = self.position - p;
        let d2 = to.length_squared();
        Some(Illumination {
            wi: to / d2.sqrt(),
            irradiance: self.intensity / d2,
            position: Some(self.position),
        })
    }
}
