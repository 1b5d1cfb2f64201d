//! pbrt-v4's projection light: a point source that projects an image like a slide
//! projector. Towards a direction w (in the light's frame, looking down +z) it has intensity
//! `scale` × the image's colour where w meets the screen, a rectangle of the image's aspect
//! ratio spanning `fov` degrees across its shorter side; no light outside it.

use super::PointSource;
use crate::image::Image;
use crate::math::{luminance, Mat3, Rgb, Vec2, Vec3};
use std::path::PathBuf;

/// Directions closer to the screen's plane than this (light-space z) get no light, as in
/// pbrt-v4 (its near plane).
const HITHER: f32 = 1e-3;

#[derive(Clone, Debug, PartialEq)]
pub struct ProjectionLight {
    pub position: Vec3,
    pub scale: f32,
    /// Degrees across the screen's shorter side.
    pub fov: f32,
    /// The image file as the scene names it.
    pub file: PathBuf,
    /// The light's frame: its directions to the world's (pbrt's CTM; the image's rows run
    /// down −y, as pbrt-v4 flips it).
    pub frame: Mat3,
    light_from_world: Mat3,
    width: u32,
    height: u32,
    pixels: Vec<Rgb>,
    /// tan(fov / 2): the screen at z = 1 spans ±bounds × this.
    tan_half: f32,
    /// The screen's half extents in units of the shorter half side.
    bounds: Vec2,
    /// The screen's area on the plane z = 1 (pbrt-v4's A).
    area: f32,
    /// Σ luminance × the solid angle of each pixel: flux = scale × this.
    unit_flux: f32,
}

impl ProjectionLight {
    /// The light at `position` with frame `frame` (invertible) projecting `image` over
    /// `fov` degrees (in (0, 180)), times `scale`.
    pub fn new(
        position: Vec3,
        frame: Mat3,
        file: PathBuf,
        image: &Image,
        scale: f32,
        fov: f32,
    ) -> Result<ProjectionLight, String> {
        if image.width == 0 || image.height == 0 {
            return Err("the image is empty".into());
        }
        if !(fov > 0.0 && fov < 180.0) {
            return Err(format!("\"fov\" must be in (0, 180) degrees, got {fov}"));
        }
        if frame.determinant().abs() < 1e-12 || !frame.is_finite() {
            return Err("the light's transform must be invertible".into());
        }
        if image.pixels.iter().any(|p| !p.is_finite()) {
            return Err("the image has infinite or NaN pixels".into());
        }
        let flip = Mat3::from_diagonal(Vec3::new(1.0, -1.0, 1.0));
        let frame = frame * flip;
        let aspect = image.width as f32 / image.height as f32;
        let bounds = if aspect > 1.0 {
            Vec2::new(aspect, 1.0)
        } else {
            Vec2::new(1.0, 1.0 / aspect)
        };
        let tan_half = (0.5 * fov.to_radians()).tan();
        let mut light = ProjectionLight {
            position,
            scale,
            fov,
            file,
            frame,
            light_from_world: frame.inverse(),
            width: image.width,
            height: image.height,
            pixels: image.pixels.iter().map(|p| p.max(Rgb::ZERO)).collect(),
            tan_half,
            bounds,
            area: 4.0 * tan_half * tan_half * bounds.x * bounds.y,
            unit_flux: 0.0,
        };
        // Each pixel's solid angle exactly (pbrt-v4 takes cos³θ at its centre, which is off
        // by a few per cent for an image of a few pixels).
        let (w, h) = (f64::from(image.width), f64::from(image.height));
        let (hx, hy) = (
            f64::from(bounds.x * tan_half),
            f64::from(bounds.y * tan_half),
        );
        let mut sum = 0.0f64;
        for y in 0..image.height {
            for x in 0..image.width {
                let x0 = hx * (2.0 * f64::from(x) / w - 1.0);
                let x1 = hx * (2.0 * f64::from(x + 1) / w - 1.0);
                let y0 = hy * (2.0 * f64::from(y) / h - 1.0);
                let y1 = hy * (2.0 * f64::from(y + 1) / h - 1.0);
                let value = luminance(light.pixels[(y * image.width + x) as usize]);
                sum += f64::from(value) * rectangle_solid_angle(x0, x1, y0, y1);
            }
        }
        light.unit_flux = sum as f32;
        Ok(light)
    }

    /// The unit light-space direction through screen point `s` in [0, 1]² (x right, y
    /// down the image).
    fn screen_direction(&self, s: Vec2) -> Vec3 {
        let ps = (2.0 * s - Vec2::ONE) * self.bounds * self.tan_half;
        Vec3::new(ps.x, ps.y, 1.0).normalize()
    }

    /// Where light-space direction `wl` meets the screen, in [0, 1]²; `None` outside it.
    fn screen_point(&self, wl: Vec3) -> Option<Vec2> {
        if wl.z.is_nan() || wl.z < HITHER {
            return None;
        }
        let ps = Vec2::new(wl.x, wl.y) / (wl.z * self.tan_half);
        let s = (ps / self.bounds + Vec2::ONE) * 0.5;
        ((0.0..=1.0).contains(&s.x) && (0.0..=1.0).contains(&s.y)).then_some(s)
    }

    /// The image's colour at screen point `s` (nearest pixel).
    fn pixel(&self, s: Vec2) -> Rgb {
        let x = ((s.x * self.width as f32) as u32).min(self.width - 1);
        let y = ((s.y * self.height as f32) as u32).min(self.height - 1);
        self.pixels[(y * self.width + x) as usize]
    }

    /// The light rescaled by pbrt-v4's `power` parameter: it emits its scale × `power`
    /// (scale 1: `power`); unchanged when its image is black.
    pub fn with_power(self, power: f32) -> ProjectionLight {
        if self.unit_flux > 0.0 {
            ProjectionLight {
                scale: self.scale * power / self.unit_flux,
                ..self
            }
        } else {
            self
        }
    }
}

/// The solid angle of the rectangle [x0, x1] × [y0, y1] on the plane z = 1 seen from the
/// origin: F(x1, y1) − F(x0, y1) − F(x1, y0) + F(x0, y0), F(x, y) = atan(xy / √(1 + x² + y²)).
fn rectangle_solid_angle(x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    let f = |x: f64, y: f64| (x * y / (1.0 + x * x + y * y).sqrt()).atan();
    f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0)
}

impl PointSource for ProjectionLight {
    fn position(&self) -> Vec3 {
        self.position
    }

    fn intensity(&self, w: Vec3) -> Rgb {
        match self.screen_point(self.light_from_world * w) {
            Some(s) => self.pixel(s) * self.scale,
            None => Rgb::ZERO,
        }
    }

    fn base_intensity(&self) -> Rgb {
        Rgb::splat(self.scale)
    }

    fn flux(&self) -> f32 {
        self.scale * self.unit_flux
    }

    /// Uniform over the screen: density 1 / (A cos³θ) in solid angle.
    fn sample_direction(&self, u: Vec2) -> (Vec3, f32) {
        let wl = self.screen_direction(u);
        let dir = (self.frame * wl).normalize();
        (dir, 1.0 / (self.area * wl.z * wl.z * wl.z))
    }

    fn pdf_direction(&self, w: Vec3) -> f32 {
        let wl = (self.light_from_world * w).normalize();
        match self.screen_point(wl) {
            Some(_) => 1.0 / (self.area * wl.z * wl.z * wl.z),
            None => 0.0,
        }
    }
}
