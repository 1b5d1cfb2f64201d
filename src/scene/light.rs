//! Lights: point and directional lights given in the scene, and area lights made from
//! emissive shapes.

use super::{Geometry, Scene};
use crate::math::{Rgb, Vec2, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Radiant intensity `intensity` (W/sr) from a point; irradiance falls off as 1/r².
    Point { position: Vec3, intensity: Rgb },
    /// Parallel light travelling along `direction`, with irradiance `irradiance` on a surface
    /// facing it.
    Directional { direction: Vec3, irradiance: Rgb },
}

/// An emissive shape, ready for sampling points on it uniformly by area.
#[derive(Clone, Debug)]
pub struct AreaLight {
    /// Index of the emissive shape in `Scene::shapes`.
    pub shape: usize,
    pub radiance: Rgb,
    pub area: f32,
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
        tris: Vec<[Vec3; 3]>,
        cdf: Vec<f32>,
    },
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
            .filter_map(|(i, s)| {
                let radiance = scene.materials[s.material].emission;
                let kind = match s.geometry {
                    Geometry::Sphere { center, radius } => AreaKind::Sphere { center, radius },
                    ref g => {
                        let tris = g.triangles();
                        let mut total = 0.0;
                        let cdf = tris
                            .iter()
                            .map(|[a, b, c]| {
                                total += 0.5 * (*b - *a).cross(*c - *a).length();
                                total
                            })
                            .collect();
                        AreaKind::Triangles { tris, cdf }
                    }
                };
                let area = s.geometry.area();
                (area > 0.0).then_some(AreaLight {
                    shape: i,
                    radiance,
                    area,
                    kind,
                })
            })
            .collect()
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
                let i = cdf.partition_point(|&c| c <= target).min(tris.len() - 1);
                // Reuse the leftover of u.x within the chosen triangle's interval.
                let lo = if i == 0 { 0.0 } else { cdf[i - 1] };
                let ux = ((target - lo) / (cdf[i] - lo).max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
                let [a, b, c] = tris[i];
                let su = ux.sqrt();
                let (b0, b1) = (1.0 - su, u.y * su);
                LightPoint {
                    p: a * b0 + b * b1 + c * (1.0 - b0 - b1),
                    n: (b - a).cross(c - a).normalize(),
                }
            }
        }
    }
}
