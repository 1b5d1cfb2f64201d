//! The intersection interface. Integrators query the scene through [`Accel`] and never see
//! which backend answers.

pub mod bvh;
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

/// Which intersection backend to build (`--accel` on the command line).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum Backend {
    /// The system Embree.
    #[default]
    Embree,
    /// obvhs's compressed wide BVH, pure Rust.
    Bvh,
}

impl Backend {
    pub const ALL: [Backend; 2] = [Backend::Embree, Backend::Bvh];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Embree => "embree",
            Backend::Bvh => "bvh",
        }
    }
}

impl std::fmt::Display for Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Builds the acceleration structure for a scene's shapes; shape `i` gets geometry id `i`.
pub fn build(scene: &Scene, backend: Backend) -> crate::Result<Box<dyn Accel>> {
    match backend {
        Backend::Embree => Ok(Box::new(embree::EmbreeAccel::build(scene)?)),
        Backend::Bvh => Ok(Box::new(bvh::BvhAccel::build(scene)?)),
    }
}
