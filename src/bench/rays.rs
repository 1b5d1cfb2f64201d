//! The bench's ray sets: camera rays through jittered pixel positions, and from the camera
//! rays' hit points shadow rays to the lights and cosine-distributed diffuse-bounce rays.
//! Generated once per scene, with Embree as the reference, and traced by every backend.

use crate::accel::Accel;
use crate::math::spawn::Spot;
use crate::math::{frame, Ray, Rng, Vec2, Vec3};
use crate::scene::lights::AreaLight;
use crate::scene::{Light, Scene};
use std::fmt;

/// What a ray set measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum RayKind {
    /// Primary rays from the camera, one per pixel: coherent closest-hit queries.
    Camera,
    /// Segments from camera hits to points on the lights: occlusion queries.
    Shadow,
    /// Cosine-distributed directions from camera hits: incoherent closest-hit queries.
    Diffuse,
}

impl RayKind {
    pub const ALL: [RayKind; 3] = [RayKind::Camera, RayKind::Shadow, RayKind::Diffuse];

    pub fn name(self) -> &'static str {
        match self {
            RayKind::Camera => "camera",
            RayKind::Shadow => "shadow",
            RayKind::Diffuse => "diffuse",
        }
    }

    /// Whether the kind is traced as an occlusion query (else as a closest-hit query).
    pub(crate) fn is_occlusion(self) -> bool {
        self == RayKind::Shadow
    }
}

impl fmt::Display for RayKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The three ray sets of a scene.
#[derive(Clone, Debug, Default)]
pub struct RaySets {
    pub camera: Vec<Ray>,
    pub shadow: Vec<Ray>,
    pub diffuse: Vec<Ray>,
}

impl RaySets {
    pub fn get(&self, kind: RayKind) -> &[Ray] {
        match kind {
            RayKind::Camera => &self.camera,
            RayKind::Shadow => &self.shadow,
            RayKind::Diffuse => &self.diffuse,
        }
    }
}

/// Generates the ray sets for a `width` × `height` view through the scene's camera, tracing
/// the camera rays with `reference` to find the hit points. Deterministic for a seed.
pub fn generate(
    scene: &Scene,
    reference: &dyn Accel,
    width: u32,
    height: u32,
    seed: u64,
) -> RaySets {
    let mut camera = scene.camera.clone();
    camera.width = width;
    camera.height = height;
    let basis = camera.basis();
    let area_lights = AreaLight::collect(scene);
    let fallback = fallback_light(scene);
    let mut sets = RaySets::default();
    for y in 0..height {
        for x in 0..width {
            let mut rng = Rng::for_key(seed, &[x as u64, y as u64]);
            let ray = basis.ray(x as f32 + rng.uniform(), y as f32 + rng.uniform());
            sets.camera.push(ray);
            let Some(hit) = reference.intersect(&ray) else {
                continue;
            };
            if hit.ng.normalize_or_zero() == Vec3::ZERO {
                continue;
            }
            let at = hit.spot(scene, &ray);
            let n = if at.n.dot(ray.dir) > 0.0 { -at.n } else { at.n };
            let target = light_point(scene, &area_lights, fallback, at.p, &mut rng);
            sets.shadow.push(at.spawn_to(&target));
            let dir = cosine_direction(n, Vec2::new(rng.uniform(), rng.uniform()));
            sets.diffuse.push(at.spawn(dir));
        }
    }
    sets
}

/// A point on a randomly chosen light: a uniform point on an area light, a point light's
/// position, or far along a directional light; `fallback` when the scene has no light.
fn light_point(
    scene: &Scene,
    area_lights: &[AreaLight],
    fallback: Vec3,
    p: Vec3,
    rng: &mut Rng,
) -> Spot {
    let count = area_lights.len() + scene.lights.len();
    if count == 0 {
        return Spot::exact(fallback);
    }
    let i = ((rng.uniform() * count as f32) as usize).min(count - 1);
    let u = Vec2::new(rng.uniform(), rng.uniform());
    match area_lights.get(i) {
        Some(light) => light.sample(u).spot(),
        None => Spot::exact(match &scene.lights[i - area_lights.len()] {
            Light::Directional(l) => p - l.direction.normalize() * 1e4,
            l => l.position().unwrap_or(p),
        }),
    }
}

/// A point above the scene's bounds, for scenes without lights.
fn fallback_light(scene: &Scene) -> Vec3 {
    match scene.bounds() {
        Some((lo, hi)) => {
            let c = (lo + hi) * 0.5;
            Vec3::new(c.x, hi.y + (hi - lo).length(), c.z)
        }
        None => Vec3::new(0.0, 10.0, 0.0),
    }
}

/// A direction in the hemisphere around unit `n`, with density cos θ / π (Malley's method).
pub(crate) fn cosine_direction(n: Vec3, u: Vec2) -> Vec3 {
    let r = u.x.sqrt();
    let phi = std::f32::consts::TAU * u.y;
    let (t, b) = frame(n);
    let z = (1.0 - u.x).max(0.0).sqrt();
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * z).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cosine_directions_have_mean_cosine_two_thirds() {
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let mut rng = Rng::for_key(3, &[]);
        let count = 100_000;
        let mut mean = 0.0f64;
        for _ in 0..count {
            let d = cosine_direction(n, Vec2::new(rng.uniform(), rng.uniform()));
            let c = d.dot(n);
            assert!(c >= -1e-6 && (d.length() - 1.0).abs() < 1e-5);
            mean += c as f64 / count as f64;
        }
        // E[cos θ] under the cos θ / π density is 2/3.
        assert!((mean - 2.0 / 3.0).abs() < 0.005, "mean {mean}");
    }
}
