//! Lights: point, spot, goniometric and directional lights given in the scene, and area
//! lights made from emissive shapes.

use super::environment::equal_area_sphere_to_square;
use super::{Geometry, Material, Scene, Shape};
use crate::image::Image;
use crate::math::{Mat3, Rgb, Vec2, Vec3};
use std::path::PathBuf;
use std::sync::Arc;

#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Radiant intensity `intensity` (W/sr) from a point; irradiance falls off as 1/r².
    Point { position: Vec3, intensity: Rgb },
    /// Parallel light travelling along `direction`, with irradiance `irradiance` on a surface
    /// facing it.
    Directional { direction: Vec3, irradiance: Rgb },
    /// pbrt-v4's spot light: intensity `intensity`·falloff(cos θ) (W/sr) from a point, with θ
    /// the angle to `direction`; no light beyond `cone_angle` (degrees from the axis), full
    /// intensity within `cone_angle` − `cone_delta`, a smooth step between (see
    /// [`spot_falloff`]).
    Spot {
        position: Vec3,
        direction: Vec3,
        intensity: Rgb,
        cone_angle: f32,
        cone_delta: f32,
    },
    /// pbrt-v4's goniometric light: intensity `intensity` (W/sr) from a point, times the
    /// value its image shows towards each direction ([`GoniometricMap`]).
    Goniometric {
        position: Vec3,
        intensity: Rgb,
        map: Arc<GoniometricMap>,
    },
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

/// pbrt-v4's spot falloff: SmoothStep(cos_end, cos_start, cos θ), 0 outside the cone, 1
/// inside the inner cone, a cubic Hermite step between.
pub fn spot_falloff(cos: f32, cos_start: f32, cos_end: f32) -> f32 {
    if cos_start == cos_end {
        return if cos < cos_end { 0.0 } else { 1.0 };
    }
    let t = ((cos - cos_end) / (cos_start - cos_end)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The spot light of pbrt-v4's `coneangle` and `conedelta` (degrees): (cos of the falloff's
/// start, cos of the cone's edge).
pub fn spot_cosines(cone_angle: f32, cone_delta: f32) -> (f32, f32) {
    (
        (cone_angle - cone_delta).to_radians().cos(),
        cone_angle.to_radians().cos(),
    )
}

/// The total power of a spot light per unit intensity: 2π((1 − cos_start) + (cos_start −
/// cos_end)/2), pbrt-v4's k_e (what `power` divides by).
pub fn spot_solid_angle(cos_start: f32, cos_end: f32) -> f32 {
    std::f32::consts::TAU * ((1.0 - cos_start) + 0.5 * (cos_start - cos_end))
}

/// An emissive shape, ready for sampling points on it uniformly by area.
#[derive(Clone, Debug)]
pub struct AreaLight {
    /// Index of the emissive shape in `Scene::shapes`.
    pub shape: usize,
    pub radiance: Rgb,
    pub area: f32,
    /// Emits on both sides (the material's `two_sided_emission`).
    pub two_sided: bool,
    kind: AreaKind,
}

#[derive(Clone, Debug)]
enum AreaKind {
    Sphere {
        center: Vec3,
        radius: f32,
    },
    /// Triangles with a cumulative area table for choosing one proportionally to its area.
    Triangles {
        tris: Vec<LightTriangle>,
        cdf: Vec<f32>,
    },
}

/// A triangle prepared for sampling: a vertex, two edges and the unit normal.
#[derive(Clone, Debug)]
struct LightTriangle {
    a: Vec3,
    ab: Vec3,
    ac: Vec3,
    n: Vec3,
}

/// A point on a light with its unit normal (the side that emits).
#[derive(Clone, Copy, Debug)]
pub struct LightPoint {
    pub p: Vec3,
    pub n: Vec3,
}

impl AreaLight {
    /// The area lights of a scene: one per shape whose material emits.
    pub fn collect(scene: &Scene) -> Vec<AreaLight> {
        scene
            .shapes
            .iter()
            .enumerate()
            .filter(|(_, s)| scene.materials[s.material].is_emissive())
            .filter_map(|(i, s)| AreaLight::new(i, s, &scene.materials[s.material]))
            .collect()
    }

    /// Shape `shape` of the scene as a surface to sample uniformly by area (with its
    /// material's emission, which may be zero); `None` for a shape without area.
    pub fn surface(scene: &Scene, shape: usize) -> Option<AreaLight> {
        let s = scene.shapes.get(shape)?;
        AreaLight::new(shape, s, &scene.materials[s.material])
    }

    fn new(i: usize, s: &Shape, material: &Material) -> Option<AreaLight> {
        let (kind, area) = match s.geometry {
            Geometry::Sphere { center, radius } => {
                (AreaKind::Sphere { center, radius }, s.geometry.area())
            }
            ref g => {
                let tris: Vec<LightTriangle> = g
                    .triangles()
                    .into_iter()
                    .map(|[a, b, c]| LightTriangle {
                        a,
                        ab: b - a,
                        ac: c - a,
                        n: (b - a).cross(c - a).normalize_or_zero(),
                    })
                    .collect();
                let mut total = 0.0;
                let cdf = tris
                    .iter()
                    .map(|t| {
                        total += 0.5 * t.ab.cross(t.ac).length();
                        total
                    })
                    .collect();
                (AreaKind::Triangles { tris, cdf }, total)
            }
        };
        (area > 0.0).then_some(AreaLight {
            shape: i,
            radiance: material.emission,
            area,
            two_sided: material.two_sided_emission,
            kind,
        })
    }

    /// The cosine factor of emission at a point whose normal makes cosine `cos` with the
    /// direction of emission: `cos` on the front, 0 behind, |cos| for a two-sided light.
    pub fn emitting_cos(&self, cos: f32) -> f32 {
        if self.two_sided {
            cos.abs()
        } else {
            cos.max(0.0)
        }
    }

    /// Centre and radius when the light is a sphere (which can be sampled by solid angle).
    pub fn sphere(&self) -> Option<(Vec3, f32)> {
        match self.kind {
            AreaKind::Sphere { center, radius } => Some((center, radius)),
            AreaKind::Triangles { .. } => None,
        }
    }

    /// A point uniformly distributed over the light's area for `u` uniform in [0,1)².
    pub fn sample(&self, u: Vec2) -> LightPoint {
        match &self.kind {
            AreaKind::Sphere { center, radius } => {
                let z = 1.0 - 2.0 * u.x;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = std::f32::consts::TAU * u.y;
                let n = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                LightPoint {
                    p: *center + n * *radius,
                    n,
                }
            }
            AreaKind::Triangles { tris, cdf } => {
                let total = *cdf.last().expect("area lights have triangles");
                let target = u.x * total;
                // Most emitters are a quad or a few triangles: a scan beats a binary search.
                let i = if cdf.len() <= 8 {
                    cdf.iter()
                        .position(|&c| c > target)
                        .unwrap_or(tris.len() - 1)
                } else {
                    cdf.partition_point(|&c| c <= target).min(tris.len() - 1)
                };
                // Reuse the leftover of u.x within the chosen triangle's interval.
                let lo = if i == 0 { 0.0 } else { cdf[i - 1] };
                let ux = ((target - lo) / (cdf[i] - lo).max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
                let t = &tris[i];
                // Uniform over the triangle (Shirley's square-root warp).
                let su = ux.sqrt();
                let (b1, b2) = (su * (1.0 - u.y), su * u.y);
                LightPoint {
                    p: t.a + t.ab * b1 + t.ac * b2,
                    n: t.n,
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Camera, Material, QuadMesh, Shape};

    /// Samples over an L-shaped emitter made of two quads of areas 2 and 1 land on it,
    /// uniformly: the sample mean is the area-weighted centroid.
    #[test]
    fn area_samples_are_uniform_over_the_shape() {
        let quad = |x0: f32, x1: f32| {
            [
                Vec3::new(x0, 0.0, 0.0),
                Vec3::new(x0, 0.0, 1.0),
                Vec3::new(x1, 0.0, 1.0),
                Vec3::new(x1, 0.0, 0.0),
            ]
        };
        let positions: Vec<Vec3> = quad(0.0, 2.0).into_iter().chain(quad(2.0, 3.0)).collect();
        let scene = Scene {
            source: "t".into(),
            camera: Camera {
                position: Vec3::Z,
                look_at: Vec3::ZERO,
                up: Vec3::Y,
                fov_deg: 45.0,
                width: 1,
                height: 1,
                projection: crate::scene::Projection::Pinhole,
            },
            materials: vec![Material {
                emission: Rgb::ONE,
                ..Material::default()
            }],
            shapes: vec![Shape {
                geometry: Geometry::Quads(QuadMesh {
                    positions,
                    indices: vec![[0, 1, 2, 3], [4, 5, 6, 7]],
                }),
                material: 0,
                alpha: None,
            }],
            prototypes: Vec::new(),
            instances: Vec::new(),
            lights: vec![],
            ambient: Rgb::ZERO,
            background: Rgb::ZERO,
            settings: Default::default(),
            setting_sources: Vec::new(),
            inputs: Vec::new(),
            environment: None,
            warnings: Vec::new(),
        };
        let lights = AreaLight::collect(&scene);
        assert_eq!(lights.len(), 1);
        assert!((lights[0].area - 3.0).abs() < 1e-6);
        let mut rng = crate::math::Rng::for_key(5, &[]);
        let n = 200_000;
        let mut mean = Vec3::ZERO;
        let mut right = 0;
        for _ in 0..n {
            let s = lights[0].sample(Vec2::new(rng.uniform(), rng.uniform()));
            assert!(
                s.p.y.abs() < 1e-6 && (0.0..=3.0).contains(&s.p.x) && (0.0..=1.0).contains(&s.p.z)
            );
            assert!((s.n - Vec3::Y).length() < 1e-6, "normal {}", s.n);
            mean += s.p / n as f32;
            right += (s.p.x > 2.0) as u32;
        }
        assert!(
            (mean - Vec3::new(1.5, 0.0, 0.5)).length() < 0.01,
            "mean {mean}"
        );
        assert!((right as f32 / n as f32 - 1.0 / 3.0).abs() < 0.005);
    }
}
