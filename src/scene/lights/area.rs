//! Area lights: emissive shapes, sampled uniformly by area (spheres by the cone they
//! subtend), their emission constant or varying by texture.

use super::{DirectionCone, EmissionSample, LightBounds, LightModel, LightSample, World};
use crate::math::spawn::{gamma, plane_test_error, Spot};
use crate::math::warp::{cosine_hemisphere, uniform_cone, uniform_cone_pdf};
use crate::math::{frame, luminance, Rgb, Vec2, Vec3};
use crate::scene::alpha::Alpha;
use crate::scene::shapes::sphere_uv;
use crate::scene::texture::Texture;
use crate::scene::{Material, Primitives, Scene, Shape, UvMap};
use crate::spectrum::BlackbodyEmission;
use std::f32::consts::PI;
use std::sync::Arc;

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
    /// What makes the emission vary over the surface, if anything.
    varying: Option<Arc<Varying>>,
    /// The material's blackbody spectrum, if it has one.
    spectrum: Option<BlackbodyEmission>,
}

/// An emission texture and the shape's cut-out, with what finds a sampled point's uv.
#[derive(Debug)]
struct Varying {
    texture: Option<Texture>,
    alpha: Option<Alpha>,
    /// For each light triangle, how its points map to the shape's uv.
    uv_maps: Vec<UvMap>,
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
    /// What the backends' test of a ray leaving the triangle rounds to (the longest edge
    /// bounds the distance from any of its points to a vertex).
    test_error: Vec3,
}

/// A point on a light with its unit normal (the side that emits) and, when the light's
/// emission varies, its surface (u, v) (zero otherwise).
#[derive(Clone, Copy, Debug)]
pub struct LightPoint {
    pub p: Vec3,
    /// A conservative bound of `p`'s rounding error along each axis.
    pub error: Vec3,
    pub n: Vec3,
    pub uv: Vec2,
}

impl LightPoint {
    /// Where shadow rays end and light paths start: the point, its error, its normal.
    pub fn spot(&self) -> Spot {
        Spot {
            p: self.p,
            error: self.error,
            n: self.n,
        }
    }
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
        let (kind, area) = match s.geometry.primitives() {
            Primitives::Sphere { center, radius } => {
                (AreaKind::Sphere { center, radius }, s.geometry.area())
            }
            _ => {
                let tris: Vec<LightTriangle> = s
                    .geometry
                    .triangles()
                    .into_iter()
                    .map(|[a, b, c]| {
                        let longest = (b - a).abs().max((c - a).abs()).max((c - b).abs());
                        LightTriangle {
                            a,
                            ab: b - a,
                            ac: c - a,
                            n: (b - a).cross(c - a).normalize_or_zero(),
                            test_error: plane_test_error(longest.max_element()),
                        }
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
        let varying = (material.emission_map.is_some() || s.alpha.is_some()).then(|| {
            Arc::new(Varying {
                texture: material.emission_map.clone(),
                alpha: s.alpha.clone(),
                uv_maps: s.geometry.model().uv_maps(),
            })
        });
        (area > 0.0).then_some(AreaLight {
            shape: i,
            radiance: material.emission,
            area,
            two_sided: material.two_sided_emission,
            kind,
            varying,
            spectrum: material.emission_spectrum,
        })
    }

    /// Whether the emitted radiance varies over the surface (a texture or a cut-out).
    pub fn varies(&self) -> bool {
        self.varying.is_some()
    }

    /// The radiance emitted at a point of the light: its texture's value there, times the
    /// shape's alpha (a cut-out part emits nothing; a half-present part, half on average, as
    /// hits on it are kept with probability alpha).
    pub fn radiance_at(&self, lp: &LightPoint) -> Rgb {
        let Some(v) = &self.varying else {
            return self.radiance;
        };
        let le = match &v.texture {
            Some(t) => t.eval(lp.p, lp.uv, lp.n).max(Rgb::ZERO),
            None => self.radiance,
        };
        match &v.alpha {
            // NaN counts as opaque, as for hits.
            Some(a) => {
                let a = a.value(lp.uv);
                if a.is_nan() {
                    le
                } else {
                    le * a.clamp(0.0, 1.0)
                }
            }
            None => le,
        }
    }

    /// The point of a sphere light in direction `n` (unit) from its centre, projected onto
    /// the sphere (also for points found other than by [`AreaLight::sample`]).
    pub fn sphere_point(&self, n: Vec3) -> LightPoint {
        let AreaKind::Sphere { center, radius } = self.kind else {
            unreachable!("sphere points are asked of sphere lights");
        };
        let uv = if self.varying.is_some() {
            sphere_uv(n)
        } else {
            Vec2::ZERO
        };
        let q = n * radius;
        LightPoint {
            p: center + q,
            // The rounding of a unit vector's length (γ8 of the radius in any direction),
            // then of adding the centre.
            error: Vec3::splat(radius.abs() * gamma(8)) + center.abs() * gamma(2),
            n,
            uv,
        }
    }

    /// The mean over the light's area of the radiance it emits, from a grid of points
    /// (the light's power, for choosing among lights, is proportional to it).
    pub fn mean_radiance(&self) -> Rgb {
        if self.varying.is_none() {
            return self.radiance;
        }
        const SIDE: u32 = 64;
        let mut sum = Rgb::ZERO;
        for j in 0..SIDE {
            for i in 0..SIDE {
                let u = Vec2::new(i as f32 + 0.5, j as f32 + 0.5) / SIDE as f32;
                sum += self.radiance_at(&self.sample(u));
            }
        }
        sum / (SIDE * SIDE) as f32
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
            AreaKind::Sphere { .. } => {
                let z = 1.0 - 2.0 * u.x;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = std::f32::consts::TAU * u.y;
                self.sphere_point(Vec3::new(r * phi.cos(), r * phi.sin(), z))
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
                let (along_b, along_c) = (t.ab * b1, t.ac * b2);
                let p = t.a + along_b + along_c;
                // Three roundings of the sum and one of each product, one of each edge; and
                // the backends' test of rays leaving it.
                let error = (t.a.abs() + along_b.abs() + along_c.abs()) * gamma(7) + t.test_error;
                let uv = self
                    .varying
                    .as_ref()
                    .map_or(Vec2::ZERO, |v| v.uv_maps[i].uv(b1, b2, p));
                LightPoint {
                    p,
                    error,
                    n: t.n,
                    uv,
                }
            }
        }
    }
}

/// The largest f32 below 1.
const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

impl LightModel for AreaLight {
    fn spectrum(&self) -> Option<BlackbodyEmission> {
        self.spectrum
    }

    fn power(&self, _world: &World) -> f32 {
        let sides = if self.two_sided { 2.0 } else { 1.0 };
        sides * PI * self.area * luminance(self.mean_radiance())
    }

    fn sample_li(&self, p: Vec3, u: Vec2, choice: f32, _world: &World) -> Option<LightSample> {
        let a = self;
        if let Some((c, r)) = a.sphere() {
            let to_c = c - p;
            let d2 = to_c.length_squared();
            if d2 > r * r * 1.0001 {
                // Outside: uniform over the cone the sphere subtends.
                let sin2 = r * r / d2;
                let cos_max = (1.0 - sin2).max(0.0).sqrt();
                let w = to_c / d2.sqrt();
                let (t, b) = frame(w);
                let l = uniform_cone(u, cos_max);
                let wi = (t * l.x + b * l.y + w * l.z).normalize();
                // The nearer intersection of the ray with the sphere.
                let tc = to_c.dot(wi);
                let disc = (r * r - (d2 - tc * tc)).max(0.0);
                let q = p + wi * (tc - disc.sqrt());
                // Projected onto the sphere: the ray's own point is far less exact.
                let lp = a.sphere_point((q - c).normalize());
                let radiance = a.radiance_at(&lp);
                if radiance == Rgb::ZERO {
                    return None;
                }
                return Some(LightSample {
                    radiance,
                    wi,
                    p: lp.p,
                    error: lp.error,
                    n: lp.n,
                    pdf: choice * uniform_cone_pdf(cos_max),
                    delta: false,
                });
            }
        }
        let lp = a.sample(u);
        let d = lp.p - p;
        let dist2 = d.length_squared();
        if dist2 == 0.0 {
            return None;
        }
        let wi = d / dist2.sqrt();
        let cos_l = a.emitting_cos(-wi.dot(lp.n));
        let radiance = a.radiance_at(&lp);
        if cos_l <= 0.0 || radiance == Rgb::ZERO {
            return None;
        }
        Some(LightSample {
            radiance,
            wi,
            p: lp.p,
            error: lp.error,
            n: lp.n,
            pdf: choice * dist2 / (cos_l * a.area),
            delta: false,
        })
    }

    fn pdf_li(&self, p: Vec3, q: Vec3, n: Vec3, choice: f32) -> f32 {
        let a = self;
        if let Some((c, r)) = a.sphere() {
            let d2 = (c - p).length_squared();
            if d2 > r * r * 1.0001 {
                let cos_max = (1.0 - r * r / d2).max(0.0).sqrt();
                return choice * uniform_cone_pdf(cos_max);
            }
        }
        let d = q - p;
        let dist2 = d.length_squared();
        let cos_l = a.emitting_cos(-(d / dist2.sqrt()).dot(n));
        if cos_l <= 0.0 {
            0.0
        } else {
            choice * dist2 / (cos_l * a.area)
        }
    }

    fn sample_le(
        &self,
        u_pos: Vec2,
        u_dir: Vec2,
        choice: f32,
        _world: &World,
        light: usize,
    ) -> Option<EmissionSample> {
        let a = self;
        let lp = a.sample(u_pos);
        // A two-sided light picks a side with half of u_dir.x (as pbrt-v4 does); `n` is
        // then the normal of that side.
        let (n, u_dir, side_pdf) = if !a.two_sided {
            (lp.n, u_dir, 1.0)
        } else if u_dir.x < 0.5 {
            (
                lp.n,
                Vec2::new((2.0 * u_dir.x).min(ONE_MINUS_EPS), u_dir.y),
                0.5,
            )
        } else {
            let ux = (2.0 * (u_dir.x - 0.5)).min(ONE_MINUS_EPS);
            (-lp.n, Vec2::new(ux, u_dir.y), 0.5)
        };
        let (t, b) = frame(n);
        let l = cosine_hemisphere(u_dir);
        Some(EmissionSample {
            p: lp.p,
            error: lp.error,
            n,
            dir: t * l.x + b * l.y + n * l.z,
            radiance: a.radiance_at(&lp),
            pdf_pos: choice / a.area,
            pdf_dir: side_pdf * l.z / PI,
            delta_pos: false,
            delta_dir: false,
            light,
        })
    }

    fn is_infinite(&self) -> bool {
        false
    }

    /// The shape's box, the cone of its triangles' normals (every direction for a sphere)
    /// and its power; light leaves up to 90° from the normals.
    fn bounds(&self, world: &World) -> Option<LightBounds> {
        let (lo, hi, normals) = match &self.kind {
            AreaKind::Sphere { center, radius } => (
                *center - Vec3::splat(radius.abs()),
                *center + Vec3::splat(radius.abs()),
                DirectionCone::SPHERE,
            ),
            AreaKind::Triangles { tris, .. } => {
                let first = tris.first()?;
                let mut lo = Vec3::splat(f32::INFINITY);
                let mut hi = Vec3::splat(f32::NEG_INFINITY);
                let mut normals = DirectionCone::of(first.n);
                for t in tris {
                    for v in [t.a, t.a + t.ab, t.a + t.ac] {
                        lo = lo.min(v);
                        hi = hi.max(v);
                    }
                    if normals.cos_theta > -1.0 && t.n != Vec3::ZERO {
                        normals = normals.union(DirectionCone::of(t.n));
                    }
                }
                (lo, hi, normals)
            }
        };
        Some(LightBounds {
            lo,
            hi,
            phi: self.power(world),
            normals,
            cos_theta_e: 0.0,
            two_sided: self.two_sided,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Camera, Geometry, Material, QuadMesh, Shape};

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
            media: Vec::new(),
            camera_medium: None,
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
                media: None,
                geometry: Geometry::Quads(QuadMesh {
                    positions,
                    indices: vec![[0, 1, 2, 3], [4, 5, 6, 7]],
                }),
                material: 0,
                alpha: None,
                motion: None,
            }],
            prototypes: Vec::new(),
            instances: Vec::new(),
            lights: vec![],
            ambient: Rgb::ZERO,
            background: Rgb::ZERO,
            settings: Default::default(),
            setting_sources: Vec::new(),
            output: None,
            color_space: None,
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

    /// Sampled points carry the uv a hit there would have: a mesh's interpolated uvs, and
    /// Embree's parameterisation of a quad that is not a parallelogram (both triangles).
    #[test]
    fn sampled_points_carry_the_uv_of_a_hit_there() {
        let textured = Material {
            emission: Rgb::ONE,
            emission_map: Some(Texture::Constant(Rgb::ONE)),
            ..Material::default()
        };
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        ];
        let mesh = Shape {
            media: None,
            geometry: Geometry::Triangles(crate::scene::TriangleMesh {
                uvs: Some(
                    positions
                        .iter()
                        .map(|p| Vec2::new(p.x, p.y) * 0.25)
                        .collect(),
                ),
                positions,
                normals: None,
                indices: vec![[0, 1, 2]],
            }),
            material: 0,
            alpha: None,
            motion: None,
        };
        // A trapezoid: v0 v1 v2 v3 with v2 nearer the y axis than a parallelogram's.
        let [v0, v1, v2, v3] = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::new(2.0, 2.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        ];
        let quad = Shape {
            media: None,
            geometry: Geometry::Quads(QuadMesh {
                positions: vec![v0, v1, v2, v3],
                indices: vec![[0, 1, 2, 3]],
            }),
            material: 0,
            alpha: None,
            motion: None,
        };
        let mesh = AreaLight::new(0, &mesh, &textured).unwrap();
        let quad = AreaLight::new(1, &quad, &textured).unwrap();
        let mut rng = crate::math::Rng::for_key(9, &[]);
        let (mut first, mut second) = (0, 0);
        for _ in 0..2000 {
            let u = Vec2::new(rng.uniform(), rng.uniform());
            let lp = mesh.sample(u);
            assert!((lp.uv - Vec2::new(lp.p.x, lp.p.y) * 0.25).length() < 1e-5);
            // Embree's quad: p = v0 + u(v1 − v0) + v(v3 − v0) below the diagonal v1–v3,
            // p = v2 + (1 − u)(v3 − v2) + (1 − v)(v1 − v2) above it.
            let lp = quad.sample(u);
            let (a, b) = (lp.uv.x, lp.uv.y);
            let p = if a + b <= 1.0 {
                first += 1;
                v0 + (v1 - v0) * a + (v3 - v0) * b
            } else {
                second += 1;
                v2 + (v3 - v2) * (1.0 - a) + (v1 - v2) * (1.0 - b)
            };
            assert!((p - lp.p).length() < 1e-4, "{p} against {}", lp.p);
        }
        assert!(first > 100 && second > 100);
    }
}
