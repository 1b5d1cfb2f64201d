//! The intersection interface. Integrators query the scene through [`Accel`] and never see
//! which backend answers.

pub mod embree;

use crate::math::{Ray, Vec3};
use crate::scene::Scene;

/// The closest hit along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Barycentric coordinates of the hit (triangles: weights of vertices 1 and 2).
    pub u: f32,
    pub v: f32,
    /// Unnormalised geometric normal, oriented by the primitive's winding:
    /// (v1 − v0) × (v2 − v0) for triangles, outward for spheres.
    pub ng: Vec3,
    /// Index of the shape in `Scene::shapes`.
    pub geom_id: u32,
    /// Index of the primitive within the shape.
    pub prim_id: u32,
}

/// Closest-hit and occlusion queries over a fixed scene. Implementations are thread-safe.
pub trait Accel: Send + Sync {
    /// The closest hit with `ray.tmin <= t <= ray.tmax`, if any.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;
    /// Whether anything lies along the ray within `[tmin, tmax]`.
    fn occluded(&self, ray: &Ray) -> bool;
}

/// Which intersection backend to build.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Backend {
    #[default]
    Embree,
}

/// Builds the acceleration structure for a scene's shapes; shape `i` gets geometry id `i`.
pub fn build(scene: &Scene, backend: Backend) -> crate::Result<Box<dyn Accel>> {
    match backend {
        Backend::Embree => Ok(Box::new(embree::EmbreeAccel::build(scene)?)),
    }
}
