//! Environment maps: radiance arriving from infinitely far away, stored as an image in
//! pbrt-v4's equal-area octahedral ("square–sphere") parameterisation (Clarberg 2008).
//! Integrators use [`Environment::eval`] for rays that leave the scene.
//!
//! A map is given either in that mapping (a square image) or as a latitude–longitude
//! ("equirectangular") image twice as wide as it is tall, which is converted on load to the
//! equal-area mapping ([`lat_long_to_equal_area`]); the shape tells which ([`Mapping::of`]).

use crate::image::Image;
use crate::math::{Mat3, Rgb, Vec2, Vec3};
use crate::scene::portal::Portal;
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::{PI, TAU};
use std::path::{Path, PathBuf};

#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    /// Linear RGB radiance in the equal-area octahedral mapping; square, row 0 at the top
    /// (pbrt's layout). A lat-long map is held here converted.
    pub image: Image,
    /// The file as the scene names it.
    pub file: PathBuf,
    /// Light space to world space (pbrt's CTM at the `LightSource`; linear part).
    pub transform: Mat3,
    /// Multiplies every value.
    pub scale: Rgb,
    /// The opening through which the map lights an interior, if the scene names one:
    /// next-event estimation from behind it samples only directions through it.
    pub portal: Option<Portal>,
    world_to_light: Mat3,
}

/// The widest lat-long map accepted: its W×W conversion holds 12 bytes a texel (12.9 GB at
/// this width), and texel indices stay within u32.
pub(crate) const MAX_LAT_LONG_WIDTH: u32 = 32768;

/// How an environment image maps to directions; told by its shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mapping {
    /// A square image in pbrt-v4's equal-area octahedral mapping, used as it is.
    EqualArea,
    /// A 2:1 latitude–longitude image (pbrt-v4's `imgtool makeequiarea` convention), converted
    /// to the equal-area mapping by [`lat_long_to_equal_area`].
    LatLong,
}

impl Mapping {
    /// The mapping of a `width`×`height` image: square → equal-area, 2:1 → lat-long; other
    /// shapes are refused with a sentence naming the accepted ones.
    pub fn of(width: u32, height: u32) -> Result<Mapping, String> {
        if width == height && width > 0 {
            Ok(Mapping::EqualArea)
        } else if height > 0 && width == 2 * height {
            if width > MAX_LAT_LONG_WIDTH {
                return Err(format!(
                    "a lat-long environment map may be at most {MAX_LAT_LONG_WIDTH} wide (it \
                     becomes a square of its width), got {width}x{height}; downsample it"
                ));
            }
            Ok(Mapping::LatLong)
        } else {
            Err(format!(
                "an environment map must be square (equal-area octahedral mapping) or 2:1 \
                 (latitude-longitude), got {width}x{height}"
            ))
        }
    }
}

impl Environment {
    /// Checks the map (a square or 2:1 image, see [`Mapping::of`]; a lat-long image is
    /// converted), the transform (invertible) and the scale (finite, not negative).
    pub fn new(
        image: Image,
        file: PathBuf,
        transform: Mat3,
        scale: Rgb,
    ) -> Result<Environment, String> {
        Ok(Self::with_mapping(image, file, transform, scale)?.0)
    }

    /// [`new`](Self::new), also telling which mapping the image was in.
    pub(crate) fn with_mapping(
        image: Image,
        file: PathBuf,
        transform: Mat3,
        scale: Rgb,
    ) -> Result<(Environment, Mapping), String> {
        let mapping = Mapping::of(image.width, image.height)?;
        let det = transform.determinant();
        if !transform.is_finite() || !det.is_finite() {
            return Err(format!(
                "the environment's transform overflows: it is not finite (determinant {det})"
            ));
        }
        if det.abs() < 1e-12 {
            return Err(format!(
                "the environment's transform is singular (determinant {det})"
            ));
        }
        if !scale.is_finite() || scale.min_element() < 0.0 {
            return Err(format!(
                "scale must be finite and not negative, got {scale}"
            ));
        }
        let image = match mapping {
            Mapping::EqualArea => image,
            Mapping::LatLong => lat_long_to_equal_area(image),
        };
        let env = Environment {
            image,
            file,
            transform,
            scale,
            portal: None,
            world_to_light: transform.inverse(),
        };
        Ok((env, mapping))
    }

    /// Reads the image file at `path` (the resolved `file`).
    pub fn load(
        path: &Path,
        file: PathBuf,
        transform: Mat3,
        scale: Rgb,
    ) -> crate::error::Result<Environment> {
        let allowance = crate::input_file::Allowance::machine();
        Ok(Self::load_with_mapping(path, file, transform, scale, &allowance)?.0)
    }

    /// [`load`](Self::load) within what `allowance` leaves of the job's memory budget, also
    /// telling which mapping the file was in.
    pub(crate) fn load_with_mapping(
        path: &Path,
        file: PathBuf,
        transform: Mat3,
        scale: Rgb,
        allowance: &crate::input_file::Allowance,
    ) -> crate::error::Result<(Environment, Mapping)> {
        let (image, _) = crate::image::output::read_image_within(path, allowance)?;
        Environment::with_mapping(image, file, transform, scale)
            .map_err(|m| crate::error::Error::input(path, m))
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

/// Samples per side of each equal-area texel in [`lat_long_to_equal_area`].
pub const LAT_LONG_SUPERSAMPLING: u32 = 2;

/// The light-space unit direction of the point (`u`, `v`) ∈ \[0,1\]² of a lat-long image
/// (`u` across, `v` down): θ = π`v` from +z (the top row), φ = 2π`u` from +x towards +y
/// (pbrt-v4's `imgtool makeequiarea`, pbrt-v3's lat-long infinite light).
pub fn lat_long_to_direction(u: f64, v: f64) -> DVec3 {
    let (theta, phi) = (PI * v, TAU * u);
    DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

/// The inverse of [`lat_long_to_direction`], for a unit `d`: `u` in \[0,1), `v` in \[0,1\].
pub fn direction_to_lat_long(d: DVec3) -> (f64, f64) {
    let theta = d.z.clamp(-1.0, 1.0).acos();
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += TAU;
    }
    ((phi / TAU).min(1.0), theta / PI)
}

/// The lat-long coordinates (`u`, `v`) of the point (`x`, `y`) of the equal-area square:
/// `direction_to_lat_long(equal_area_square_to_sphere(..))` in closed form (one arcsine
/// instead of four trigonometric functions), in f64.
pub(crate) fn equal_area_square_to_lat_long(x: f64, y: f64) -> (f64, f64) {
    let (u, v) = (2.0 * x - 1.0, 2.0 * y - 1.0);
    let (up, vp) = (u.abs(), v.abs());
    let signed = 1.0 - (up + vp);
    let r = 1.0 - signed.abs();
    // The azimuth within the quadrant, then the quadrant from the signs of u and v (as
    // equal_area_square_to_sphere's copysigns: x follows u, y follows v).
    let psi = if r == 0.0 { 1.0 } else { (vp - up) / r + 1.0 } * std::f64::consts::FRAC_PI_4;
    let phi = match (u.is_sign_negative(), v.is_sign_negative()) {
        (false, false) => psi,
        (true, false) => PI - psi,
        (true, true) => PI + psi,
        (false, true) => TAU - psi,
    };
    // z = ±(1 − r²), so the angle from ±z is acos(1 − r²) = 2 asin(r / √2).
    let from_pole = 2.0 * (r * std::f64::consts::FRAC_1_SQRT_2).min(1.0).asin();
    let theta = if signed < 0.0 {
        PI - from_pole
    } else {
        from_pole
    };
    ((phi / TAU).min(1.0), theta / PI)
}

/// Converts a 2:1 lat-long image (W×H, W = 2H) to the equal-area octahedral mapping.
///
/// Resolution: a W×W square (W² = 2·W·H texels, twice the source). Nothing is lost: the
/// lat-long image's finest detail is its spacing of 2π/W radians (in θ everywhere, and in φ
/// at the equator; towards the poles only φ is finer), and the equal-area map's texels, of
/// solid angle 4π/W², are stretched by its distortion to at most 0.98 · 2π/W (at the middle
/// of the square's edges) and 0.8 · 2π/W on average in their longest direction.
///
/// Filter: each texel is the mean of [`LAT_LONG_SUPERSAMPLING`]² points on a regular grid
/// over it; as the mapping preserves area, the points stand for equal solid angles and the
/// mean is the texel's average radiance over its solid angle. Each point reads the lat-long
/// image bilinearly (φ wraps around, θ clamps at the poles). Near the poles the source rows
/// hold more texels across than the grid samples, so each row is first box-filtered along φ
/// over the arc one grid cell spans there (with 2×2 points, only rows within about 10° of a
/// pole change), so that no column is skipped. Arithmetic is in f64: a constant map
/// converts to exactly the same constant.
pub fn lat_long_to_equal_area(mut src: Image) -> Image {
    let (w, h) = (src.width as usize, src.height as usize);
    assert!(w == 2 * h && h > 0, "a lat-long image is 2:1, got {w}x{h}");
    let n = w;
    let k = LAT_LONG_SUPERSAMPLING as usize;
    prefilter_polar_rows(&mut src, k);
    let mut out = Image::new(n as u32, n as u32);
    let texel = |x: usize, y: usize| {
        let mut sum = DVec3::ZERO;
        for j in 0..k {
            for i in 0..k {
                let (u, v) = equal_area_square_to_lat_long(
                    ((x * k + i) as f64 + 0.5) / (n * k) as f64,
                    ((y * k + j) as f64 + 0.5) / (n * k) as f64,
                );
                sum += bilerp_lat_long(&src, u, v);
            }
        }
        (sum / (k * k) as f64).as_vec3()
    };
    // Bands of TILE rows, visited TILE columns at a time: a tile of the square covers a
    // compact patch of the lat-long image, which stays in the cache.
    const TILE: usize = 16;
    out.pixels
        .par_chunks_mut(n * TILE)
        .enumerate()
        .for_each(|(band, rows)| {
            let height = rows.len() / n;
            for x0 in (0..n).step_by(TILE) {
                for dy in 0..height {
                    for x in x0..(x0 + TILE).min(n) {
                        rows[dy * n + x] = texel(x, band * TILE + dy);
                    }
                }
            }
        });
    out
}

/// Box-filters the rows of a lat-long image along φ where they hold more texels than the
/// conversion's grid samples: at polar angle θ a grid cell spans about 2π/(W·k) radians,
/// 1/(k sin θ) texels of the row; rows where that is 3 or more are averaged over the odd
/// number of texels (2r + 1 ≤ 1/(k sin θ)) centred on each texel, wrapping around.
fn prefilter_polar_rows(img: &mut Image, k: usize) {
    let (w, h) = (img.width as usize, img.height as usize);
    let mut row = vec![DVec3::ZERO; w];
    for y in 0..h {
        let sin = (PI * (y as f64 + 0.5) / h as f64).sin();
        let span = 1.0 / (k as f64 * sin);
        let r = (((span - 1.0) / 2.0).floor().max(0.0) as usize).min((w - 1) / 2);
        if r == 0 {
            continue;
        }
        let pixels = &mut img.pixels[y * w..(y + 1) * w];
        for (d, p) in row.iter_mut().zip(pixels.iter()) {
            *d = p.as_dvec3();
        }
        let at = |x: isize| row[x.rem_euclid(w as isize) as usize];
        let mut sum: DVec3 = (-(r as isize)..=r as isize).map(at).sum();
        let count = (2 * r + 1) as f64;
        for (x, p) in pixels.iter_mut().enumerate() {
            *p = (sum / count).as_vec3();
            let x = x as isize;
            sum += at(x + r as isize + 1) - at(x - r as isize);
        }
    }
}

/// The lat-long image at (`u`, `v`) ∈ \[0,1\]², bilinearly between texel centres, `u`
/// wrapping around and `v` clamped to the centres of the first and last rows.
fn bilerp_lat_long(img: &Image, u: f64, v: f64) -> DVec3 {
    let (w, h) = (img.width as i64, img.height as i64);
    let (fx, fy) = (u * w as f64 - 0.5, v * h as f64 - 0.5);
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    // fx is in [-0.5, w - 0.5], so x0 and x0 + 1 wrap by at most one turn.
    let wrap = |x: i64| {
        if x < 0 {
            x + w
        } else if x >= w {
            x - w
        } else {
            x
        }
    };
    let texel = |x: i64, y: i64| img.pixels[(y.clamp(0, h - 1) * w + wrap(x)) as usize].as_dvec3();
    (texel(x0, y0) * (1.0 - tx) + texel(x0 + 1, y0) * tx) * (1.0 - ty)
        + (texel(x0, y0 + 1) * (1.0 - tx) + texel(x0 + 1, y0 + 1) * tx) * ty
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
        for (w, h) in [(4, 3), (3, 1), (0, 0), (8, 2)] {
            let err = Environment::new(Image::new(w, h), "e".into(), Mat3::IDENTITY, Rgb::ONE)
                .unwrap_err();
            assert!(err.contains("square") && err.contains("2:1"), "{err}");
        }
    }

    #[test]
    fn the_shape_tells_the_mapping() {
        assert_eq!(Mapping::of(16, 16), Ok(Mapping::EqualArea));
        assert_eq!(Mapping::of(1, 1), Ok(Mapping::EqualArea));
        assert_eq!(Mapping::of(32, 16), Ok(Mapping::LatLong));
        assert_eq!(Mapping::of(2, 1), Ok(Mapping::LatLong));
        assert!(Mapping::of(33, 16).is_err());
        assert!(Mapping::of(16, 32).is_err());
        assert!(Mapping::of(0, 0).is_err());
        assert_eq!(Mapping::of(32768, 16384), Ok(Mapping::LatLong));
        assert!(Mapping::of(32770, 16385)
            .unwrap_err()
            .contains("at most 32768"));
    }

    #[test]
    fn lat_long_coordinates_follow_pbrt_and_round_trip() {
        // Top row +z, bottom row -z; u = 0 is +x, u = 1/4 is +y, u = 1/2 is -x, u = 3/4 is -y.
        let close = |a: DVec3, b: DVec3| (a - b).length() < 1e-12;
        assert!(close(lat_long_to_direction(0.3, 0.0), DVec3::Z));
        assert!(close(lat_long_to_direction(0.3, 1.0), DVec3::NEG_Z));
        assert!(close(lat_long_to_direction(0.0, 0.5), DVec3::X));
        assert!(close(lat_long_to_direction(0.25, 0.5), DVec3::Y));
        assert!(close(lat_long_to_direction(0.5, 0.5), DVec3::NEG_X));
        assert!(close(lat_long_to_direction(0.75, 0.5), DVec3::NEG_Y));
        for (u, v) in [(0.1, 0.2), (0.6, 0.9), (0.99, 0.5), (0.0, 0.7)] {
            let (a, b) = direction_to_lat_long(lat_long_to_direction(u, v));
            assert!(
                (a - u).abs() < 1e-12 && (b - v).abs() < 1e-12,
                "{u} {v}: {a} {b}"
            );
        }
    }

    #[test]
    fn square_to_lat_long_agrees_with_the_direction() {
        let mut rng = crate::math::Rng::for_key(5, &[]);
        for _ in 0..10000 {
            let p = Vec2::new(rng.uniform(), rng.uniform());
            let d = equal_area_square_to_sphere(p).as_dvec3().normalize();
            let (u, v) = direction_to_lat_long(d);
            let want = lat_long_to_direction(u, v);
            let (u, v) = equal_area_square_to_lat_long(p.x as f64, p.y as f64);
            let got = lat_long_to_direction(u, v);
            assert!((got - want).length() < 1e-5, "{p}: {got} vs {want}");
        }
    }

    /// A constant lat-long map converts to exactly the same constant, W×W texels.
    #[test]
    fn a_constant_lat_long_map_converts_exactly() {
        for c in [Rgb::new(0.3, 1.7, 1e-3), Rgb::new(123.456, 0.1, 7.0)] {
            let mut src = Image::new(64, 32);
            src.pixels.fill(c);
            let out = lat_long_to_equal_area(src);
            assert_eq!((out.width, out.height), (64, 64));
            assert!(out.pixels.iter().all(|&p| p == c));
        }
    }

    /// One bright texel at (φ, θ) lands in the equal-area texels around the direction the
    /// convention gives, nowhere else, and keeps its energy (radiance × solid angle).
    #[test]
    fn a_bright_lat_long_texel_lands_at_its_direction() {
        let (w, h) = (128u32, 64u32);
        for (col, row) in [(20u32, 25u32), (100, 40), (70, 10), (5, 55)] {
            let mut src = Image::new(w, h);
            src.set(col, row, Rgb::new(1000.0, 500.0, 250.0));
            let out = lat_long_to_equal_area(src);
            let (u, v) = ((col as f64 + 0.5) / w as f64, (row as f64 + 0.5) / h as f64);
            let dir = lat_long_to_direction(u, v);
            let env = Environment::new(out.clone(), "e".into(), Mat3::IDENTITY, Rgb::ONE).unwrap();
            // The brightest converted texel is the one seen along `dir`.
            let brightest = (0..out.pixels.len())
                .max_by(|&a, &b| out.pixels[a].x.total_cmp(&out.pixels[b].x))
                .unwrap();
            assert_eq!(env.texel(dir.as_vec3()), Some(brightest), "({col}, {row})");
            // Mirrored or turned conventions would look elsewhere.
            for wrong in [
                DVec3::new(dir.x, -dir.y, dir.z),
                DVec3::new(-dir.x, -dir.y, dir.z),
                DVec3::new(dir.x, dir.y, -dir.z),
            ] {
                assert_eq!(
                    env.eval(wrong.as_vec3()),
                    Rgb::ZERO,
                    "({col}, {row}) {wrong}"
                );
            }
            // Every lit texel is within two source texels (2π/W each) of `dir`.
            let n = out.width;
            for (i, p) in out.pixels.iter().enumerate() {
                if p.x > 0.0 {
                    let (x, y) = (i as u32 % n, i as u32 / n);
                    let c = Vec2::new((x as f32 + 0.5) / n as f32, (y as f32 + 0.5) / n as f32);
                    let d = equal_area_square_to_sphere(c).as_dvec3();
                    let angle = d.dot(dir).clamp(-1.0, 1.0).acos();
                    assert!(angle < 2.0 * TAU / w as f64, "({col}, {row}): {angle}");
                }
            }
            // Energy: the source texel's solid angle, (2π/W)(cos θ0 − cos θ1), times its value.
            let (t0, t1) = (PI * row as f64 / h as f64, PI * (row + 1) as f64 / h as f64);
            let source = 1000.0 * (TAU / w as f64) * (t0.cos() - t1.cos());
            let converted: f64 =
                out.pixels.iter().map(|p| p.x as f64).sum::<f64>() * 4.0 * PI / (n * n) as f64;
            assert!(
                (converted / source - 1.0).abs() < 0.02,
                "({col}, {row}): {converted} vs {source}"
            );
        }
    }
}
