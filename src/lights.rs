//! Light sampling for the Monte Carlo integrators: every emitter of a scene (area lights,
//! point, spot and directional lights, and the constant background as an infinite light) behind one
//! interface. Emitters are chosen in proportion to their power. Two kinds of sampling:
//! towards a point being shaded (`sample_li`, next-event estimation, with `pdf_li` for
//! multiple importance sampling), and emission of a light path (`sample_le`, with `pdf_le`).

use crate::math::spawn::Spot;
use crate::math::warp::{
    concentric_disk, cosine_hemisphere, uniform_cone, uniform_cone_pdf, uniform_sphere,
    UNIFORM_SPHERE_PDF,
};
use crate::math::{frame, luminance, Rgb, Vec2, Vec3};
use crate::scene::environment::equal_area_square_to_sphere;
use crate::scene::light::{
    spot_cosines, spot_falloff, spot_solid_angle, AreaLight, GoniometricMap,
};
use crate::scene::{Environment, Light, Scene};
use std::f32::consts::PI;
use std::sync::Arc;

/// The largest f32 below 1.
const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

#[derive(Clone, Debug)]
pub enum Emitter {
    Area(AreaLight),
    Point {
        position: Vec3,
        intensity: Rgb,
    },
    /// pbrt-v4's spot light (see [`crate::scene::light::spot_falloff`]).
    Spot {
        position: Vec3,
        direction: Vec3,
        intensity: Rgb,
        cos_start: f32,
        cos_end: f32,
    },
    /// A point light whose intensity varies as its map shows.
    Goniometric {
        position: Vec3,
        intensity: Rgb,
        map: Arc<GoniometricMap>,
    },
    /// Light travelling along `direction` (unit).
    Directional {
        direction: Vec3,
        irradiance: Rgb,
    },
    /// Radiance arriving from every direction not blocked by the scene: a constant, or an
    /// environment map.
    Background {
        radiance: Rgb,
        map: Option<Arc<EnvironmentSampler>>,
    },
}

/// An environment map prepared for importance sampling. Its equal-area parameterisation
/// makes every texel the same solid angle (4π / texels), so choosing texels in proportion to
/// luminance and a point uniformly inside gives a piecewise-constant density over directions.
#[derive(Debug)]
pub struct EnvironmentSampler {
    pub env: Arc<Environment>,
    cdf: Vec<f32>,
    total: f32,
    /// Mean radiance over directions.
    pub mean: Rgb,
}

impl EnvironmentSampler {
    fn new(env: Arc<Environment>) -> Self {
        let mut total = 0.0f64;
        let mut sum = Rgb::ZERO;
        let cdf = env
            .image
            .pixels
            .iter()
            .map(|p| {
                let v = p.max(Rgb::ZERO) * env.scale;
                sum += v;
                // A floor keeps every direction possible, so MIS never meets a zero density.
                total += (luminance(v) + 1e-4) as f64;
                total as f32
            })
            .collect();
        let n = env.image.pixels.len().max(1) as f32;
        EnvironmentSampler {
            cdf,
            total: total as f32,
            mean: sum / n,
            env,
        }
    }

    fn texel_weight(&self, i: usize) -> f32 {
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        self.cdf[i] - lo
    }

    /// A direction and its solid-angle density.
    fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let target = u.x * self.total;
        let i = self
            .cdf
            .partition_point(|&c| c <= target)
            .min(self.cdf.len() - 1);
        let n = self.env.image.width;
        let (x, y) = ((i as u32 % n) as f32, (i as u32 / n) as f32);
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let fx = ((target - lo) / self.texel_weight(i).max(f32::MIN_POSITIVE)).clamp(0.0, 0.999);
        let p = Vec2::new((x + fx) / n as f32, (y + u.y) / n as f32);
        let dir = (self.env.transform * equal_area_square_to_sphere(p)).normalize();
        (dir, self.pdf_texel(i))
    }

    fn pdf_texel(&self, i: usize) -> f32 {
        let texels = self.cdf.len() as f32;
        self.texel_weight(i) / self.total * texels / (4.0 * PI)
    }

    fn pdf(&self, dir: Vec3) -> f32 {
        self.env.texel(dir).map_or(0.0, |i| self.pdf_texel(i))
    }
}

impl Emitter {
    /// Intensity of a point or spot light towards the unit direction `w` (zero for others).
    pub fn intensity_towards(&self, w: Vec3) -> Rgb {
        match *self {
            Emitter::Point { intensity, .. } => intensity,
            Emitter::Spot {
                direction,
                intensity,
                cos_start,
                cos_end,
                ..
            } => intensity * spot_falloff(w.dot(direction), cos_start, cos_end),
            Emitter::Goniometric {
                intensity, ref map, ..
            } => intensity * map.value(w),
            _ => Rgb::ZERO,
        }
    }

    /// Solid-angle density with which [`LightSet::sample_le`] emits a point or spot light's
    /// path along `w`.
    pub fn pdf_dir_point(&self, w: Vec3) -> f32 {
        match *self {
            Emitter::Spot {
                direction, cos_end, ..
            } => {
                if w.dot(direction) >= cos_end {
                    uniform_cone_pdf(cos_end)
                } else {
                    0.0
                }
            }
            _ => UNIFORM_SPHERE_PDF,
        }
    }
}

/// A sample of incident light at a shaded point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Radiance arriving along `-wi` (for delta lights, the irradiance-like equivalent).
    pub radiance: Rgb,
    /// Unit direction from the shaded point to the light.
    pub wi: Vec3,
    /// The point on the light (for area and point lights) or a point far away along `wi`.
    pub p: Vec3,
    /// A bound of `p`'s rounding error along each axis (zero off surfaces).
    pub error: Vec3,
    /// The light's unit normal at `p` (zero where there is no surface).
    pub n: Vec3,
    /// Density in solid angle at the shaded point, including the choice of emitter; for delta
    /// lights the choice probability.
    pub pdf: f32,
    pub delta: bool,
}

impl LightSample {
    /// Where the shadow ray towards the light ends.
    pub fn spot(&self) -> Spot {
        Spot {
            p: self.p,
            error: self.error,
            n: self.n,
        }
    }
}

/// The start of a light path.
#[derive(Clone, Copy, Debug)]
pub struct EmissionSample {
    pub p: Vec3,
    /// A bound of `p`'s rounding error along each axis (zero off surfaces).
    pub error: Vec3,
    /// Surface normal at `p` (zero for point lights and for infinite lights the direction).
    pub n: Vec3,
    pub dir: Vec3,
    pub radiance: Rgb,
    /// Area density of `p` (including the choice of emitter); for a point light, the choice
    /// probability.
    pub pdf_pos: f32,
    /// Solid-angle density of `dir`; for a directional light 1.
    pub pdf_dir: f32,
    /// `p` is a single point (point lights).
    pub delta_pos: bool,
    /// `dir` is a single direction (directional lights).
    pub delta_dir: bool,
    /// Index of the emitter.
    pub light: usize,
}

impl EmissionSample {
    /// Where the light path leaves: the point, its error and its normal (for points off
    /// every surface, the error is zero and the point is not moved).
    pub fn spot(&self) -> Spot {
        Spot {
            p: self.p,
            error: self.error,
            n: self.n,
        }
    }
}

#[derive(Clone)]
pub struct LightSet {
    pub emitters: Vec<Emitter>,
    /// Probability of choosing each emitter, and their cumulative sums.
    pmf: Vec<f32>,
    cdf: Vec<f32>,
    /// For each scene shape, its emitter index if it is an area light.
    shape_light: Vec<Option<u32>>,
    background: Option<usize>,
    /// A sphere bounding the scene: infinite and directional lights emit from its disk.
    pub center: Vec3,
    pub radius: f32,
}

impl LightSet {
    pub fn new(scene: &Scene, area_lights: &[AreaLight]) -> LightSet {
        let (center, radius) = bounding_sphere(scene);
        let mut emitters: Vec<Emitter> = area_lights.iter().cloned().map(Emitter::Area).collect();
        for light in &scene.lights {
            emitters.push(match *light {
                Light::Point {
                    position,
                    intensity,
                } => Emitter::Point {
                    position,
                    intensity,
                },
                Light::Directional {
                    direction,
                    irradiance,
                } => Emitter::Directional {
                    direction: direction.normalize(),
                    irradiance,
                },
                Light::Goniometric {
                    position,
                    intensity,
                    ref map,
                } => Emitter::Goniometric {
                    position,
                    intensity,
                    map: map.clone(),
                },
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    cone_angle,
                    cone_delta,
                } => {
                    let (cos_start, cos_end) = spot_cosines(cone_angle, cone_delta);
                    Emitter::Spot {
                        position,
                        direction: direction.normalize(),
                        intensity,
                        cos_start,
                        cos_end,
                    }
                }
            });
        }
        let mut background = None;
        if let Some(env) = &scene.environment {
            background = Some(emitters.len());
            emitters.push(Emitter::Background {
                radiance: Rgb::ZERO,
                map: Some(Arc::new(EnvironmentSampler::new(env.clone()))),
            });
        } else if scene.background.max_element() > 0.0 {
            background = Some(emitters.len());
            emitters.push(Emitter::Background {
                radiance: scene.background,
                map: None,
            });
        }
        let power: Vec<f32> = emitters
            .iter()
            .map(|e| match e {
                Emitter::Area(a) => {
                    let sides = if a.two_sided { 2.0 } else { 1.0 };
                    sides * PI * a.area * luminance(a.mean_radiance())
                }
                Emitter::Point { intensity, .. } => 4.0 * PI * luminance(*intensity),
                Emitter::Spot {
                    intensity,
                    cos_start,
                    cos_end,
                    ..
                } => spot_solid_angle(*cos_start, *cos_end) * luminance(*intensity),
                Emitter::Goniometric { intensity, map, .. } => {
                    4.0 * PI * map.mean() * luminance(*intensity)
                }
                Emitter::Directional { irradiance, .. } => {
                    PI * radius * radius * luminance(*irradiance)
                }
                Emitter::Background { radiance, map } => {
                    let mean = map.as_ref().map_or(*radiance, |m| m.mean);
                    4.0 * PI * PI * radius * radius * luminance(mean)
                }
            })
            .map(|p| p.max(0.0))
            .collect();
        let total: f32 = power.iter().sum();
        let pmf: Vec<f32> = if total > 0.0 {
            power.iter().map(|p| p / total).collect()
        } else {
            vec![0.0; power.len()]
        };
        let mut acc = 0.0;
        let cdf = pmf
            .iter()
            .map(|p| {
                acc += p;
                acc
            })
            .collect();
        let mut shape_light = vec![None; scene.shapes.len()];
        for (i, e) in emitters.iter().enumerate() {
            if let Emitter::Area(a) = e {
                shape_light[a.shape] = Some(i as u32);
            }
        }
        LightSet {
            emitters,
            pmf,
            cdf,
            shape_light,
            background,
            center,
            radius,
        }
    }

    pub fn is_empty(&self) -> bool {
        !self.cdf.last().is_some_and(|&c| c > 0.0)
    }

    /// Probability of choosing emitter `i`.
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }

    /// The emitter index of an emissive shape.
    pub fn light_of_shape(&self, shape: usize) -> Option<usize> {
        self.shape_light[shape].map(|i| i as usize)
    }

    /// Whether emitter `i` is infinitely far away (directional or background).
    pub fn is_infinite(&self, i: usize) -> bool {
        matches!(
            self.emitters[i],
            Emitter::Directional { .. } | Emitter::Background { .. }
        )
    }

    pub fn background_light(&self) -> Option<usize> {
        self.background
    }

    /// Radiance of the background seen along a ray that leaves the scene in direction `dir`.
    pub fn background_radiance(&self, dir: Vec3) -> Rgb {
        match self.background.map(|i| &self.emitters[i]) {
            Some(Emitter::Background { radiance, map }) => match map {
                Some(m) => m.env.eval(dir),
                None => *radiance,
            },
            _ => Rgb::ZERO,
        }
    }

    /// Chooses an emitter by power; returns it and the leftover of `u`, rescaled to [0,1).
    pub fn choose(&self, u: f32) -> Option<(usize, f32)> {
        if self.is_empty() {
            return None;
        }
        let total = *self.cdf.last().unwrap();
        let target = u * total;
        let i = self
            .cdf
            .partition_point(|&c| c <= target)
            .min(self.cdf.len() - 1);
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let rest = ((target - lo) / self.pmf[i].max(f32::MIN_POSITIVE)).clamp(0.0, 0.999_999_9);
        (self.pmf[i] > 0.0).then_some((i, rest))
    }

    /// Samples light arriving at `p` (next-event estimation).
    pub fn sample_li(&self, p: Vec3, u_choose: f32, u: Vec2) -> Option<LightSample> {
        let (i, _) = self.choose(u_choose)?;
        let sel = self.pmf[i];
        match &self.emitters[i] {
            Emitter::Area(a) => {
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
                            pdf: sel * uniform_cone_pdf(cos_max),
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
                    pdf: sel * dist2 / (cos_l * a.area),
                    delta: false,
                })
            }
            Emitter::Point {
                position,
                intensity,
            } => {
                let d = *position - p;
                let dist2 = d.length_squared();
                Some(LightSample {
                    radiance: *intensity / dist2,
                    wi: d / dist2.sqrt(),
                    p: *position,
                    error: Vec3::ZERO,
                    n: Vec3::ZERO,
                    pdf: sel,
                    delta: true,
                })
            }
            e @ (Emitter::Spot { position, .. } | Emitter::Goniometric { position, .. }) => {
                let d = *position - p;
                let dist2 = d.length_squared();
                let wi = d / dist2.sqrt();
                let intensity = e.intensity_towards(-wi);
                if intensity == Rgb::ZERO {
                    return None;
                }
                Some(LightSample {
                    radiance: intensity / dist2,
                    wi,
                    p: *position,
                    error: Vec3::ZERO,
                    n: Vec3::ZERO,
                    pdf: sel,
                    delta: true,
                })
            }
            Emitter::Directional {
                direction,
                irradiance,
            } => Some(LightSample {
                radiance: *irradiance,
                wi: -*direction,
                p: p - *direction * (4.0 * self.radius + (p - self.center).length()),
                error: Vec3::ZERO,
                n: Vec3::ZERO,
                pdf: sel,
                delta: true,
            }),
            Emitter::Background { radiance, map } => {
                let (wi, pdf, radiance) = match map {
                    Some(m) => {
                        let (wi, pdf) = m.sample(u);
                        (wi, pdf, m.env.eval(wi))
                    }
                    None => (uniform_sphere(u), UNIFORM_SPHERE_PDF, *radiance),
                };
                Some(LightSample {
                    radiance,
                    wi,
                    p: p + wi * (4.0 * self.radius + (p - self.center).length()),
                    error: Vec3::ZERO,
                    n: Vec3::ZERO,
                    pdf: sel * pdf,
                    delta: false,
                })
            }
        }
    }

    /// Density (solid angle at `p`, with the choice of emitter) with which `sample_li` picks
    /// the point `q` with normal `n` on area light `i`.
    pub fn pdf_li(&self, i: usize, p: Vec3, q: Vec3, n: Vec3) -> f32 {
        let sel = self.pmf[i];
        match &self.emitters[i] {
            Emitter::Area(a) => {
                if let Some((c, r)) = a.sphere() {
                    let d2 = (c - p).length_squared();
                    if d2 > r * r * 1.0001 {
                        let cos_max = (1.0 - r * r / d2).max(0.0).sqrt();
                        return sel * uniform_cone_pdf(cos_max);
                    }
                }
                let d = q - p;
                let dist2 = d.length_squared();
                let cos_l = a.emitting_cos(-(d / dist2.sqrt()).dot(n));
                if cos_l <= 0.0 {
                    0.0
                } else {
                    sel * dist2 / (cos_l * a.area)
                }
            }
            Emitter::Background { map, .. } => {
                // For the background, `q - p` is the direction.
                sel * map
                    .as_ref()
                    .map_or(UNIFORM_SPHERE_PDF, |m| m.pdf((q - p).normalize()))
            }
            _ => 0.0,
        }
    }

    /// Starts a light path.
    pub fn sample_le(&self, u_choose: f32, u_pos: Vec2, u_dir: Vec2) -> Option<EmissionSample> {
        let (i, _) = self.choose(u_choose)?;
        let sel = self.pmf[i];
        let disk = |dir: Vec3| {
            // A point on the disk of the bounding sphere facing `dir`, upstream of the scene.
            let (t, b) = frame(dir);
            let d = concentric_disk(u_pos) * self.radius;
            self.center + t * d.x + b * d.y - dir * self.radius
        };
        let s = match &self.emitters[i] {
            Emitter::Area(a) => {
                let lp = a.sample(u_pos);
                // A two-sided light picks a side with half of u_dir.x (as pbrt-v4 does); `n`
                // is then the normal of that side.
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
                EmissionSample {
                    p: lp.p,
                    error: lp.error,
                    n,
                    dir: t * l.x + b * l.y + n * l.z,
                    radiance: a.radiance_at(&lp),
                    pdf_pos: sel / a.area,
                    pdf_dir: side_pdf * l.z / PI,
                    delta_pos: false,
                    delta_dir: false,
                    light: i,
                }
            }
            Emitter::Point {
                position,
                intensity,
            } => EmissionSample {
                p: *position,
                error: Vec3::ZERO,
                n: Vec3::ZERO,
                dir: uniform_sphere(u_dir),
                radiance: *intensity,
                pdf_pos: sel,
                pdf_dir: UNIFORM_SPHERE_PDF,
                delta_pos: true,
                delta_dir: false,
                light: i,
            },
            e @ Emitter::Goniometric { position, .. } => {
                let dir = uniform_sphere(u_dir);
                EmissionSample {
                    p: *position,
                    error: Vec3::ZERO,
                    n: Vec3::ZERO,
                    dir,
                    radiance: e.intensity_towards(dir),
                    pdf_pos: sel,
                    pdf_dir: UNIFORM_SPHERE_PDF,
                    delta_pos: true,
                    delta_dir: false,
                    light: i,
                }
            }
            e @ Emitter::Spot {
                position,
                direction,
                cos_end,
                ..
            } => {
                // Uniform over the cone, as pbrt-v4 does.
                let (t, b) = frame(*direction);
                let l = uniform_cone(u_dir, *cos_end);
                let dir = (t * l.x + b * l.y + *direction * l.z).normalize();
                EmissionSample {
                    p: *position,
                    error: Vec3::ZERO,
                    n: Vec3::ZERO,
                    dir,
                    radiance: e.intensity_towards(dir),
                    pdf_pos: sel,
                    pdf_dir: uniform_cone_pdf(*cos_end),
                    delta_pos: true,
                    delta_dir: false,
                    light: i,
                }
            }
            Emitter::Directional {
                direction,
                irradiance,
            } => EmissionSample {
                p: disk(*direction),
                error: Vec3::ZERO,
                n: *direction,
                dir: *direction,
                radiance: *irradiance,
                pdf_pos: sel / (PI * self.radius * self.radius),
                pdf_dir: 1.0,
                delta_pos: false,
                delta_dir: true,
                light: i,
            },
            Emitter::Background { radiance, map } => {
                let (to_light, pdf_dir, radiance) = match map {
                    Some(m) => {
                        let (w, pdf) = m.sample(u_dir);
                        (w, pdf, m.env.eval(w))
                    }
                    None => (uniform_sphere(u_dir), UNIFORM_SPHERE_PDF, *radiance),
                };
                let dir = -to_light;
                EmissionSample {
                    p: disk(dir),
                    error: Vec3::ZERO,
                    n: dir,
                    dir,
                    radiance,
                    pdf_pos: sel / (PI * self.radius * self.radius),
                    pdf_dir,
                    delta_pos: false,
                    delta_dir: false,
                    light: i,
                }
            }
        };
        (s.pdf_dir > 0.0).then_some(s)
    }
}

/// A sphere around every shape and the camera.
fn bounding_sphere(scene: &Scene) -> (Vec3, f32) {
    let eye = scene.camera.position;
    let (lo, hi) = scene
        .bounds()
        .map_or((eye, eye), |(lo, hi)| (lo.min(eye), hi.max(eye)));
    let center = 0.5 * (lo + hi);
    (center, (0.5 * (hi - lo).length()).max(1e-3))
}
