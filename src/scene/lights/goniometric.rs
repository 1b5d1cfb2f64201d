//! pbrt-v4's goniometric light: intensity I (W/sr) from a point, times the value its image
//! shows towards each direction ([`GoniometricMap`]).

use super::{EmissionSample, Illumination, LightModel, LightSample, World};
use crate::image::Image;
use crate::math::warp::{uniform_sphere, UNIFORM_SPHERE_PDF};
use crate::math::{luminance, Mat3, Rgb, Vec2, Vec3};
use crate::scene::environment::equal_area_sphere_to_square;
use std::f32::consts::PI;
use std::path::PathBuf;
use std::sync::Arc;

#[derive(Clone, Debug, PartialEq)]
pub struct GoniometricLight {
    pub position: Vec3,
    pub intensity: Rgb,
    pub map: Arc<GoniometricMap>,
}

impl LightModel for GoniometricLight {
    fn power(&self, _world: &World) -> f32 {
        4.0 * PI * self.map.mean() * luminance(self.intensity)
    }

    fn sample_li(&self, p: Vec3, _u: Vec2, choice: f32, _world: &World) -> Option<LightSample> {
        let d = self.position - p;
        let dist2 = d.length_squared();
        let wi = d / dist2.sqrt();
        let intensity = self.intensity_towards(-wi);
        if intensity == Rgb::ZERO {
            return None;
        }
        Some(LightSample::point_source(
            self.position,
            intensity / dist2,
            wi,
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
            radiance: self.intensity_towards(dir),
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

    fn intensity_towards(&self, w: Vec3) -> Rgb {
        self.intensity * self.map.value(w)
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
        let wi = to / d2.sqrt();
        let value = self.map.value(-wi);
        if value == 0.0 {
            return None;
        }
        Some(Illumination {
            wi,
            irradiance: self.intensity * value / d2,
            position: Some(self.position),
        })
    }
}

/// A goniometric light's distribution: a square image in the equal-area octahedral mapping
/// (as pbrt-v4's), its channels averaged, looked up at the nearest texel. Its frame is
/// pbrt-v4's: the light's +y is the map's pole (+z of the mapping).
#[derive(Clone, Debug, PartialEq)]
pub struct GoniometricMap {
    /// The image file as the scene names it.
    pub file: PathBuf,
    /// The light's frame: its directions to the world's.
    pub transform: Mat3,
    world_to_map: Mat3,
    size: u32,
    values: Vec<f32>,
    mean: f32,
}

impl GoniometricMap {
    /// The map of `image` (square) in the frame `transform` (invertible).
    pub fn new(file: PathBuf, image: &Image, transform: Mat3) -> Result<GoniometricMap, String> {
        if image.width != image.height || image.width == 0 {
            return Err(format!(
                "a goniometric image must be square (the equal-area mapping), got {}x{}",
                image.width, image.height
            ));
        }
        if transform.determinant().abs() < 1e-12 || !transform.is_finite() {
            return Err("the light's transform must be invertible".into());
        }
        let values: Vec<f32> = image
            .pixels
            .iter()
            .map(|p| p.max(Rgb::ZERO).element_sum() / 3.0)
            .collect();
        let mean = values.iter().map(|&v| f64::from(v)).sum::<f64>() / values.len() as f64;
        // pbrt-v4 swaps y and z: the light's y is the mapping's pole.
        let swap = Mat3::from_cols(Vec3::X, Vec3::Z, Vec3::Y);
        Ok(GoniometricMap {
            file,
            transform,
            world_to_map: swap * transform.inverse(),
            size: image.width,
            values,
            mean: mean as f32,
        })
    }

    /// The image's value towards world direction `w`.
    pub fn value(&self, w: Vec3) -> f32 {
        let d = (self.world_to_map * w).normalize_or_zero();
        if d == Vec3::ZERO {
            return 0.0;
        }
        let uv = equal_area_sphere_to_square(d);
        let n = self.size;
        let x = ((uv.x * n as f32) as u32).min(n - 1);
        let y = ((uv.y * n as f32) as u32).min(n - 1);
        self.values[(y * n + x) as usize]
    }

    /// The mean value over all directions (texels cover equal solid angles): the light's
    /// power is 4π · mean · intensity.
    pub fn mean(&self) -> f32 {
        self.mean
    }
}
