//! A point light: radiant intensity I (W/sr) from a point in every direction; irradiance
//! falls off as 1/r².

use super::PointSource;
use crate::math::warp::{uniform_sphere, UNIFORM_SPHERE_PDF};
use crate::math::{luminance, Rgb, Vec2, Vec3};
use crate::spectrum::BlackbodyEmission;
use std::f32::consts::PI;

#[derive(Clone, Debug, PartialEq)]
pub struct PointLight {
    pub position: Vec3,
    /// Radiant intensity (W/sr).
    pub intensity: Rgb,
    /// A blackbody's spectrum, when `intensity` is its colour times the luminance.
    pub spectrum: Option<BlackbodyEmission>,
}

impl PointSource for PointLight {
    fn position(&self) -> Vec3 {
        self.position
    }

    fn blackbody(&self) -> Option<BlackbodyEmission> {
        self.spectrum
    }

    fn intensity(&self, _w: Vec3) -> Rgb {
        self.intensity
    }

    fn base_intensity(&self) -> Rgb {
        self.intensity
    }

    fn flux(&self) -> f32 {
        4.0 * PI * luminance(self.intensity)
    }

    fn sample_direction(&self, u: Vec2) -> (Vec3, f32) {
        (uniform_sphere(u), UNIFORM_SPHERE_PDF)
    }

    fn pdf_direction(&self, _w: Vec3) -> f32 {
        UNIFORM_SPHERE_PDF
    }
}
