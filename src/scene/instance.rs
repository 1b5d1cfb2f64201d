//! Object instancing: an object's shapes stored once, in their own space, and placed any
//! number of times by a transform. The intersection structures hold one copy of each
//! object (an Embree instance, a second BVH level), so memory grows with the objects, not
//! with their placements.

use super::shapes::Tangents;
use super::{Scene, Shape, SurfacePoint};
use crate::math::Vec3;
use glam::{Affine3A, DMat4, Mat3A, Vec3A};
use std::sync::Arc;

/// Shapes defined once (`ObjectBegin` in pbrt, `[[objects]]` in TOML), in object space.
/// They are opaque and do not emit: the readers place shapes with an alpha or an emitting
/// material as world-space copies, which light sampling and the cut-out tests need.
#[derive(Clone, Debug, PartialEq)]
pub struct Prototype {
    /// The object's name in the scene file (for messages).
    pub name: String,
    pub shapes: Vec<Shape>,
}

/// One placement of a prototype.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// Index into `Scene::prototypes`.
    pub prototype: u32,
    /// The placement as given (object to world), kept in double precision for copies.
    pub matrix: DMat4,
    to_world: Affine3A,
    to_object: Affine3A,
}

impl Instance {
    /// A placement of prototype `prototype` by the affine `matrix` (object to world);
    /// `None` if the matrix is singular or not finite in single precision.
    pub fn new(prototype: u32, matrix: DMat4) -> Option<Instance> {
        let to_world = Affine3A::from_mat4(matrix.as_mat4());
        let det = to_world.matrix3.determinant();
        if !(det.is_finite() && det != 0.0 && to_world.is_finite()) {
            return None;
        }
        let to_object = to_world.inverse();
        to_object.is_finite().then_some(Instance {
            prototype,
            matrix,
            to_world,
            to_object,
        })
    }

    /// World to object space, as the intersection structures transform rays.
    pub fn to_object(&self) -> &Affine3A {
        &self.to_object
    }

    /// Object to world space.
    pub fn to_world(&self) -> &Affine3A {
        &self.to_world
    }

    /// A direction or tangent from object to world space.
    pub(crate) fn vector_to_world(&self, v: Vec3) -> Vec3 {
        Vec3::from(self.to_world.transform_vector3a(Vec3A::from(v)))
    }

    /// A normal from object to world space (by the inverse transpose, unnormalised). A
    /// mirroring placement keeps each face's side: the normal follows the transform, as
    /// the readers keep it when they copy a mirrored shape into world space.
    pub(crate) fn normal_to_world(&self, n: Vec3) -> Vec3 {
        let m: Mat3A = self.to_object.matrix3.transpose();
        Vec3::from(m * Vec3A::from(n))
    }

    /// A point from world to object space.
    pub(crate) fn point_to_object(&self, p: Vec3) -> Vec3 {
        Vec3::from(self.to_object.transform_point3a(Vec3A::from(p)))
    }

    /// The world-space box around a box in object space (its eight corners placed).
    pub(crate) fn world_bounds(&self, (lo, hi): (Vec3, Vec3)) -> (Vec3, Vec3) {
        (0..8).fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(a, b), i| {
                let corner = Vec3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                );
                let p = Vec3::from(self.to_world.transform_point3a(Vec3A::from(corner)));
                (a.min(p), b.max(p))
            },
        )
    }
}

impl Prototype {
    /// The box around the prototype's shapes in object space (inverted when empty).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.shapes.iter().map(|s| s.geometry.bounds()).fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), (a, b)| (lo.min(a), hi.max(b)),
        )
    }

    /// Triangles (a quad counts as two) and spheres of one copy.
    pub fn primitive_count(&self) -> usize {
        self.shapes
            .iter()
            .map(|s| s.geometry.primitive_count())
            .sum()
    }
}

/// A placed object's shape: what a hit on an instance refers to.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlacedShape<'a> {
    pub shape: &'a Shape,
    /// The placement, `None` for a shape of the scene itself (in world space).
    pub instance: Option<&'a Instance>,
}

impl PlacedShape<'_> {
    /// ∂p/∂u, ∂p/∂v, ∂n/∂u, ∂n/∂v in world space at `sp`, the point of primitive `prim` hit
    /// at barycentric (`u`, `v`): computed on the shape in its own space, then placed.
    pub fn tangents(&self, prim: usize, u: f32, v: f32, sp: &SurfacePoint) -> Tangents {
        let geometry = &self.shape.geometry;
        let Some(i) = self.instance else {
            return geometry.tangents(prim, u, v, sp.p, sp.ng);
        };
        let ng = Vec3::from(i.to_world.matrix3.transpose() * Vec3A::from(sp.ng)).normalize();
        let t = geometry.tangents(prim, u, v, i.point_to_object(sp.p), ng);
        Tangents {
            dpdu: i.vector_to_world(t.dpdu),
            dpdv: i.vector_to_world(t.dpdv),
            dndu: i.normal_to_world(t.dndu),
            dndv: i.normal_to_world(t.dndv),
        }
    }
}

impl Scene {
    /// The shape a surface point lies on, and its placement if it is an instance's.
    pub(crate) fn placed_shape(&self, sp: &SurfacePoint) -> PlacedShape<'_> {
        match sp.instance {
            None => PlacedShape {
                shape: &self.shapes[sp.shape],
                instance: None,
            },
            Some(i) => {
                let instance = &self.instances[i as usize];
                PlacedShape {
                    shape: &self.prototypes[instance.prototype as usize].shapes[sp.shape],
                    instance: Some(instance),
                }
            }
        }
    }

    /// The scene with every instance replaced by world-space copies of its prototype's
    /// shapes, for the techniques that keep tables per world-space shape (the illumination
    /// network, the animation renderer).
    pub fn flattened(&self) -> Scene {
        let mut flat = self.clone();
        flat.flatten_instances();
        flat
    }

    /// [`flattened`](Self::flattened), in place.
    pub(crate) fn flatten_instances(&mut self) {
        let instances = std::mem::take(&mut self.instances);
        let prototypes = std::mem::take(&mut self.prototypes);
        for instance in &instances {
            for shape in &prototypes[instance.prototype as usize].shapes {
                self.shapes
                    .extend(super::pbrt::placed_copies(shape, &instance.matrix));
            }
        }
    }

    /// An id for the object `sp` lies on (Whitted's anti-aliasing compares them).
    pub(crate) fn object_id(&self, sp: &SurfacePoint) -> u32 {
        object_id(sp.instance, sp.shape)
    }

    /// Whether the scene places objects by instances.
    pub fn has_instances(&self) -> bool {
        !self.instances.is_empty()
    }
}

/// An id for shape `shape` of the scene (`instance` None) or of instance `instance`'s
/// prototype: a world shape's index, below 2³¹; an instance's shape gets a hash of the pair
/// with the top bit set (two pairs rarely share one, and then only miss a subdivision).
pub(crate) fn object_id(instance: Option<u32>, shape: usize) -> u32 {
    match instance {
        None => shape as u32,
        Some(k) => {
            let mut z = (u64::from(k) << 32 | shape as u64).wrapping_add(0x9e37_79b9_7f4a_7c15);
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            0x8000_0000 | ((z ^ (z >> 31)) as u32 & 0x7fff_ffff)
        }
    }
}

impl Instance {
    /// The largest factor by which the placement stretches a length.
    pub(crate) fn max_stretch(&self) -> f32 {
        let m = self.to_world.matrix3;
        // The Frobenius norm bounds the largest singular value.
        (m.x_axis.length_squared() + m.y_axis.length_squared() + m.z_axis.length_squared()).sqrt()
    }
}

/// Shared prototypes: a scene's `prototypes` are reference-counted so that copies of the
/// scene (animation frames, relit scenes) do not copy the objects' geometry.
pub(crate) type Prototypes = Vec<Arc<Prototype>>;
