//! The intersection interface. Integrators query the scene through [`Accel`] and never see
//! which backend answers.

pub mod bvh;
mod cutout;
#[cfg(feature = "embree")]
pub mod embree;
mod hit_point;

use crate::control::Control;
use crate::math::spawn::Spot;
use crate::math::{Ray, Vec3};
use crate::scene::{Geometry, Instance, Primitives, Scene, Shape, SurfacePoint, TriangleMesh};

/// The closest hit along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Barycentric coordinates of the hit (triangles: weights of vertices 1 and 2).
    pub u: f32,
    pub v: f32,
    /// Unnormalised geometric normal in world space, oriented by the primitive's winding:
    /// (v1 − v0) × (v2 − v0) for triangles, outward for spheres (for an instance, that of
    /// its prototype carried to world space by the inverse transpose).
    pub ng: Vec3,
    /// Index of the shape in `Scene::shapes`, or in the instance's prototype.
    pub geom_id: u32,
    /// Index of the primitive within the shape.
    pub prim_id: u32,
    /// The instance hit (index into `Scene::instances`), `None` for the scene's own shapes.
    pub instance: Option<u32>,
}

impl Hit {
    /// Completes the intersection: position, normals and uv of the hit primitive of
    /// `scene` (the one the structure was built from).
    pub fn surface_point(&self, scene: &Scene, ray: &Ray) -> SurfacePoint {
        let (shape, instance) = self.shape(scene);
        let (hit, local, hit_point::Located { p, error }) = self.locate(shape, instance, ray);
        let ng = hit.ng.normalize();
        // Shading normals and uvs come from the shape in its own space, and a moving shape
        // is shaded as it is at the ray's time (instanced shapes do not move).
        let to_world = |n: Vec3| instance.map_or(n, |i| i.normal_to_world(n).normalize_or_zero());
        let sphere = shape.sphere_at(ray.time);
        let ns = match shape.geometry.primitives() {
            Primitives::Sphere { .. } => match instance {
                None => (p - sphere.map_or(p, |s| s.0)).normalize(),
                Some(_) => on_side(to_world(local - sphere.map_or(local, |s| s.0)), ng),
            },
            Primitives::Triangles(mesh) => match &mesh.normals {
                Some(n) => {
                    let [a, b, c] = mesh.indices[hit.prim_id as usize].map(|i| i as usize);
                    let w = Vec3::new(1.0 - hit.u - hit.v, hit.u, hit.v);
                    let mut n = n[a] * w.x + n[b] * w.y + n[c] * w.z;
                    if let Some(Primitives::Triangles(TriangleMesh {
                        normals: Some(n1), ..
                    })) = shape.motion.as_ref().map(Geometry::primitives)
                    {
                        let m = n1[a] * w.x + n1[b] * w.y + n1[c] * w.z;
                        n = crate::scene::lerp(n, m, ray.time);
                    }
                    on_side(to_world(n.normalize_or_zero()), ng)
                }
                None => ng,
            },
            Primitives::Quads(_) => ng,
        };
        let uv = match sphere {
            Some((center, _)) => crate::scene::sphere_uv((local - center).normalize()),
            None => shape.geometry.hit_uv(hit.prim_id, hit.u, hit.v, local),
        };
        SurfacePoint {
            p,
            error,
            ng,
            ns,
            uv,
            t: hit.t,
            shape: hit.geom_id as usize,
            instance: hit.instance,
            material: shape.material,
            time: ray.time,
        }
    }
}

impl Hit {
    /// The hit shape, and the instance placing it (None for the scene's own shapes).
    fn shape<'a>(&self, scene: &'a Scene) -> (&'a Shape, Option<&'a Instance>) {
        match self.instance {
            None => (&scene.shapes[self.geom_id as usize], None),
            Some(i) => {
                let instance = &scene.instances[i as usize];
                let prototype = &scene.prototypes[instance.prototype as usize];
                (&prototype.shapes[self.geom_id as usize], Some(instance))
            }
        }
    }

    /// The hit recomputed on its primitive by raylink's own tests (the same for either
    /// backend's hit), its point in the shape's own space, and in world space with the
    /// bound of its error that rays leaving it are offset by.
    fn locate(
        &self,
        shape: &Shape,
        instance: Option<&Instance>,
        ray: &Ray,
    ) -> (Hit, Vec3, hit_point::Located) {
        let (org, dir) = match instance {
            None => (ray.origin, ray.dir),
            Some(i) => (
                i.point_to_object(ray.origin),
                i.to_object().transform_vector3(ray.dir),
            ),
        };
        let refined = hit_point::locate(shape, self, org, dir, ray.time);
        let local = refined.at.p;
        let mut hit = Hit {
            u: refined.u,
            v: refined.v,
            ..*self
        };
        if let Some(ng) = refined.ng {
            hit.ng = instance.map_or(ng, |i| i.normal_to_world(ng));
        }
        let world = match instance {
            None => refined.at,
            Some(i) => hit_point::placed(i, refined.at),
        };
        (hit, local, world)
    }

    /// Where rays leave the hit point: the point, its error bound and the unit geometric
    /// normal, without the shading a [`SurfacePoint`] carries.
    pub fn spot(&self, scene: &Scene, ray: &Ray) -> Spot {
        let (shape, instance) = self.shape(scene);
        let (hit, _, at) = self.locate(shape, instance, ray);
        Spot {
            p: at.p,
            error: at.error,
            n: hit.ng.normalize(),
        }
    }
}

/// Unit shading normal `n` kept on the geometric side of `ng` (`ng` itself for a zero `n`).
fn on_side(n: Vec3, ng: Vec3) -> Vec3 {
    if n == Vec3::ZERO {
        ng
    } else if n.dot(ng) < 0.0 {
        -n
    } else {
        n
    }
}

/// Closest-hit and occlusion queries over a fixed scene. Implementations are thread-safe.
pub trait Accel: Send + Sync {
    /// The closest hit with `ray.tmin <= t <= ray.tmax`, if any.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;
    /// Whether anything lies along the ray within `[tmin, tmax]`.
    fn occluded(&self, ray: &Ray) -> bool;
    /// The closest hit of a camera ray: the same answer as [`intersect`](Self::intersect).
    /// The animation renderer's recorder may give it from the ray's hit in an earlier frame
    /// when nothing changed along it (Jevans's section 3.3.3).
    fn intersect_camera(&self, ray: &Ray) -> Option<Hit> {
        self.intersect(ray)
    }
}

/// How a [`DynamicAccel`] followed the scene to a new frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Update {
    /// Nothing moved.
    Unchanged,
    /// The vertices of this many shapes were updated in place (Embree: BVHs refitted).
    Refit(usize),
    /// The structure was built again.
    Rebuilt,
}

/// An intersection structure that follows a scene from one animation frame to the next.
pub trait DynamicAccel: Accel {
    /// Brings the structure to `scene`'s geometry (shape `i` is geometry `i`, as for [`build`]).
    fn update(&mut self, scene: &Scene) -> crate::error::Result<Update>;
}

#[cfg(feature = "embree")]
impl DynamicAccel for embree::EmbreeAccel {
    fn update(&mut self, scene: &Scene) -> crate::error::Result<Update> {
        embree::EmbreeAccel::update(self, scene)
    }
}

impl DynamicAccel for bvh::BvhAccel {
    fn update(&mut self, scene: &Scene) -> crate::error::Result<Update> {
        // A fresh PLOC build is fast, and keeps the tree as good as a new one.
        self.rebuild(scene)?;
        Ok(Update::Rebuilt)
    }
}

/// Builds an intersection structure for an animation: Embree as a dynamic scene whose moving
/// geometries are refitted per frame, the BVH rebuilt per frame.
pub fn build_dynamic(
    scene: &Scene,
    backend: Backend,
    control: &Control,
) -> crate::error::Result<Box<dyn DynamicAccel>> {
    check_memory(scene, control)?;
    scene.check_extent()?;
    match backend {
        #[cfg(feature = "embree")]
        Backend::Embree => Ok(Box::new(embree::EmbreeAccel::build_dynamic(
            scene,
            &control.cancel,
        )?)),
        #[cfg(not(feature = "embree"))]
        Backend::Embree => Err(Backend::missing_embree()),
        Backend::Bvh => Ok(Box::new(bvh::BvhAccel::build(scene)?)),
    }
}

/// The version of the Embree library in use, e.g. `"4.3.3"`; an error if it cannot be
/// loaded or this build of raylink has no Embree.
pub fn embree_version() -> crate::error::Result<String> {
    #[cfg(feature = "embree")]
    return embree::version();
    #[cfg(not(feature = "embree"))]
    Err(Backend::missing_embree())
}

/// Which intersection backend to build (`--accel` on the command line). The default is
/// Embree where raylink is built with it (the `embree` feature, on by default), else the BVH.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Backend {
    /// The system Embree. Without the `embree` feature, building it is an
    /// [`Error::Setting`](crate::error::Error::Setting) naming `accel`.
    #[cfg_attr(feature = "embree", default)]
    Embree,
    /// obvhs's compressed wide BVH, pure Rust.
    #[cfg_attr(not(feature = "embree"), default)]
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

    pub fn from_name(name: &str) -> Option<Backend> {
        Backend::ALL.into_iter().find(|b| b.name() == name)
    }

    /// Whether this build of raylink has the backend.
    pub fn available(self) -> bool {
        self == Backend::Bvh || cfg!(feature = "embree")
    }

    /// The error for the Embree backend in a build without it.
    #[cfg(not(feature = "embree"))]
    pub(crate) fn missing_embree() -> crate::error::Error {
        crate::error::Error::setting(
            "accel",
            "embree: this raylink was built without Embree (as the portable build is); use bvh",
        )
    }
}

impl std::fmt::Display for Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Builds the acceleration structure for a scene's shapes; shape `i` gets geometry id `i`.
/// The job's memory budget bounds it, and a cancel before the build stops it.
pub fn build(
    scene: &Scene,
    backend: Backend,
    control: &Control,
) -> crate::error::Result<Box<dyn Accel>> {
    check_memory(scene, control)?;
    scene.check_extent()?;
    match backend {
        #[cfg(feature = "embree")]
        Backend::Embree => Ok(Box::new(embree::EmbreeAccel::build_cancellable(
            scene,
            &control.cancel,
        )?)),
        #[cfg(not(feature = "embree"))]
        Backend::Embree => Err(Backend::missing_embree()),
        Backend::Bvh => Ok(Box::new(bvh::BvhAccel::build(scene)?)),
    }
}

/// Bytes per primitive the intersection structures take at most (Embree's BVH with its
/// build-time copies, or obvhs's CWBVH, plus the shading data kept beside them).
const BYTES_PER_PRIMITIVE: u64 = 256;

fn check_memory(scene: &Scene, control: &Control) -> crate::error::Result<()> {
    control.cancel.check("the intersection structure's build")?;
    control.budget.check(
        &format!(
            "{}: the intersection structures for {} primitives",
            scene.source.display(),
            scene.primitive_count()
        ),
        scene.primitive_count() as u64 * BYTES_PER_PRIMITIVE,
    )
}
