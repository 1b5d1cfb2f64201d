//! pbrt-v4's goniometric light: intensity I (W/sr) from a point, times the value its image
//! shows towards each direction ([`GoniometricMap`]).

use super::PointSource;
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

impl PointSource for GoniometricLight {
    fn position(&self) -> Vec3 {
        self.position
    }

    fn intensity(&self, w: Vec3) -> Rgb {
        self.intensity * self.map.value(w)
    }

    fn base_intensity(&self) -> Rgb {
        self.intensity
    }

    fn flux(&self) -> f32 {
        4.0 * PI * self.map.mean() * luminance(self.intensity)
    }

    fn sample_direction(&self, u: Vec2) -> (Vec3, f32) {
        (uniform_sphere(u), UNIFORM_SPHERE_PDF)
    }

    fn pdf_direction(&self, _w: Vec3) -> f32 {
        UNIFORM_SPHERE_PDF
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
