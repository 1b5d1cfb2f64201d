//! Environment maps: radiance arriving from infinitely far away, stored as an image in
//! pbrt-v4's equal-area octahedral ("square–sphere") parameterisation (Clarberg 2008).
//! Integrators use [`Environment::eval`] for rays that leave the scene.

use crate::image::Image;
use crate::math::{Mat3, Rgb, Vec2, Vec3};
use std::path::{Path, PathBuf};

#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    /// Linear RGB radiance; square, row 0 at the top (pbrt's layout).
    pub image: Image,
    /// The file as the scene names it.
    pub file: PathBuf,
    /// Light space to world space (pbrt's CTM at the `LightSource`; linear part).
    pub transform: Mat3,
    /// Multiplies every value.
    pub scale: Rgb,
    world_to_light: Mat3,
}

impl Environment {
    /// Checks the map: square, invertible transform, finite scale.
    pub fn new(
        image: Image,
        file: PathBuf,
        transform: Mat3,
        scale: Rgb,
    ) -> Result<Environment, String> {
        if image.width != image.height || image.width == 0 {
            return Err(format!(
                "an environment map must be a square image in the equal-area octahedral \
                 mapping, got {}x{}",
                image.width, image.height
            ));
        }
        let det = transform.determinant();
        if !det.is_finite() || det.abs() < 1e-12 {
            return Err(format!(
                "the environment's transform is singular (determinant {det})"
            ));
        }
        if !scale.is_finite() || scale.min_element() < 0.0 {
            return Err(format!(
                "scale must be finite and not negative, got {scale}"
            ));
        }
        Ok(Environment {
            image,
            file,
            transform,
            scale,
            world_to_light: transform.inverse(),
        })
    }

    /// Reads the image file at `path` (the resolved `file`).
    pub fn load(
        path: &Path,
        file: PathBuf,
        transform: Mat3,
        scale: Rgb,
    ) -> crate::Result<Environment> {
        let (image, _) = crate::image::output::read_image(path)?;
        Environment::new(image, file, transform, scale).map_err(|m| crate::Error::input(path, m))
    }

    /// Radiance seen by a ray that leaves the scene travelling in direction `dir`.
    pub fn eval(&self, dir: Vec3) -> Rgb {
        match self.texel(dir) {
            Some(i) => self.image.pixels[i].max(Rgb::ZERO) * self.scale,
            None => Rgb::ZERO,
        }
    }

    /// Index of the texel (nearest, as pbrt-v4's ImageInfiniteLight) seen along `dir`.
    pub fn texel(&self, dir: Vec3) -> Option<usize> {
        let w = (self.world_to_light * dir).normalize_or_zero();
        if w == Vec3::ZERO {
            return None;
        }
        let uv = equal_area_sphere_to_square(w);
        let n = self.image.width;
        let x = ((uv.x * n as f32) as u32).min(n - 1);
        let y = ((uv.y * n as f32) as u32).min(n - 1);
        Some((y * n + x) as usize)
    }
}

/// The unit direction `d` as a point of \[0,1\]² in the equal-area octahedral mapping.
pub fn equal_area_sphere_to_square(d: Vec3) -> Vec2 {
    let (x, y, z) = (d.x.abs(), d.y.abs(), d.z.abs());
    let r = (1.0 - z).max(0.0).sqrt();
    let a = x.max(y);
    let b = if a == 0.0 { 0.0 } else { x.min(y) / a };
    let mut phi = b.atan() * std::f32::consts::FRAC_2_PI;
    if x < y {
        phi = 1.0 - phi;
    }
    let mut v = phi * r;
    let mut u = r - v;
    if d.z < 0.0 {
        std::mem::swap(&mut u, &mut v);
        u = 1.0 - u;
        v = 1.0 - v;
    }
    u = u.copysign(d.x);
    v = v.copysign(d.y);
    Vec2::new((u + 1.0) * 0.5, (v + 1.0) * 0.5)
}

/// The inverse of [`equal_area_sphere_to_square`].
pub fn equal_area_square_to_sphere(p: Vec2) -> Vec3 {
    let (u, v) = (2.0 * p.x - 1.0, 2.0 * p.y - 1.0);
    let (up, vp) = (u.abs(), v.abs());
    let signed = 1.0 - (up + vp);
    let r = 1.0 - signed.abs();
    let phi = if r == 0.0 { 1.0 } else { (vp - up) / r + 1.0 } * std::f32::consts::FRAC_PI_4;
    let z = (1.0 - r * r).copysign(signed);
    let s = r * (2.0 - r * r).max(0.0).sqrt();
    Vec3::new(phi.cos().copysign(u) * s, phi.sin().copysign(v) * s, z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mapping_round_trips_and_matches_known_points() {
        // +z is the centre of the square, -z its corners, the equator the inner diamond.
        assert!((equal_area_sphere_to_square(Vec3::Z) - Vec2::splat(0.5)).length() < 1e-6);
        let c = equal_area_sphere_to_square(Vec3::NEG_Z);
        assert!(c.x == 0.0 || c.x == 1.0, "{c}");
        assert!((equal_area_sphere_to_square(Vec3::X) - Vec2::new(1.0, 0.5)).length() < 1e-6);
        assert!((equal_area_sphere_to_square(Vec3::Y) - Vec2::new(0.5, 1.0)).length() < 1e-6);
        let mut rng = crate::math::Rng::for_key(3, &[]);
        for _ in 0..1000 {
            let p = Vec2::new(rng.uniform(), rng.uniform());
            let d = equal_area_square_to_sphere(p);
            assert!((d.length() - 1.0).abs() < 1e-4);
            let q = equal_area_sphere_to_square(d);
            assert!((p - q).length() < 1e-3, "{p} -> {d} -> {q}");
        }
    }

    #[test]
    fn eval_reads_the_texel_of_the_direction_through_the_transform() {
        let mut image = Image::new(4, 4);
        // The texel holding +x (u = 1, v = 0.5 -> column 3, row 2).
        image.set(3, 2, Rgb::new(1.0, 2.0, 3.0));
        let env =
            Environment::new(image.clone(), "e.exr".into(), Mat3::IDENTITY, Rgb::ONE).unwrap();
        assert_eq!(env.eval(Vec3::X), Rgb::new(1.0, 2.0, 3.0));
        assert_eq!(env.eval(Vec3::NEG_X), Rgb::ZERO);
        // Rotating the light 90 degrees about z moves light-space +x to world +y.
        let rot = Mat3::from_rotation_z(std::f32::consts::FRAC_PI_2);
        let env = Environment::new(image, "e.exr".into(), rot, Rgb::splat(2.0)).unwrap();
        assert_eq!(env.eval(Vec3::Y), Rgb::new(2.0, 4.0, 6.0));
        assert!(Environment::new(Image::new(4, 2), "e".into(), Mat3::IDENTITY, Rgb::ONE).is_err());
    }
}
