//! Light-transport techniques, one module each. They all see the scene through [`Context`]:
//! the scene description, the intersection backend (never named) and the area lights.

pub mod whitted;

use crate::accel::Accel;
use crate::math::{Ray, Rgb, Rng};
use crate::scene::light::AreaLight;
use crate::scene::{Scene, SurfacePoint};

/// What integrators render with.
pub struct Context<'a> {
    pub scene: &'a Scene,
    accel: &'a dyn Accel,
    pub area_lights: Vec<AreaLight>,
}

impl<'a> Context<'a> {
    pub fn new(scene: &'a Scene, accel: &'a dyn Accel) -> Self {
        Context {
            scene,
            accel,
            area_lights: AreaLight::collect(scene),
        }
    }

    /// The closest surface along the ray.
    pub fn intersect(&self, ray: &Ray, stats: &mut RayStats) -> Option<SurfacePoint> {
        stats.closest += 1;
        let hit = self.accel.intersect(ray)?;
        Some(SurfacePoint::from_hit(&self.scene.shapes, ray, &hit))
    }

    /// Whether anything blocks the ray segment.
    pub fn occluded(&self, ray: &Ray, stats: &mut RayStats) -> bool {
        stats.shadow += 1;
        self.accel.occluded(ray)
    }
}

/// Rays traced, by query kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayStats {
    pub closest: u64,
    pub shadow: u64,
}

impl RayStats {
    pub fn total(&self) -> u64 {
        self.closest + self.shadow
    }

    pub fn add(&mut self, other: &RayStats) {
        self.closest += other.closest;
        self.shadow += other.shadow;
    }
}

/// The value of one image sample: radiance along a camera ray, and what the ray saw first
/// (used by adaptive anti-aliasing to find silhouettes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub radiance: Rgb,
    /// Index of the first shape hit, or `u32::MAX` for the background.
    pub object: u32,
}

/// A technique that computes radiance along camera rays.
pub trait Integrator: Sync {
    /// `rng` is the random stream of this image sample, derived from (seed, sample position).
    fn radiance(&self, ctx: &Context, ray: &Ray, rng: &mut Rng, stats: &mut RayStats) -> Sample;
}
