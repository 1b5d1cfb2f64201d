//! What the geometry kept costs against the job's memory budget, counted by the builder
//! before the memory is taken (see `limits.rs`): the shapes' data and their share of the
//! intersection structures, an object instance as the copies it becomes.

use super::builder::Builder;
use super::limits::place;
use super::shapes;
use super::Loc;
use crate::scene::{Geometry, Shape, Sphere};
use glam::DMat4;
use std::sync::OnceLock;

/// Bytes per primitive of the intersection structures, as `accel::build` assumes (Embree's
/// BVH with its build-time copies, or obvhs's CWBVH, and the shading data).
const ACCEL_BYTES_PER_PRIMITIVE: u64 = 256;

/// What geometry costs: the bytes of its data, and its primitives (each of which costs
/// [`ACCEL_BYTES_PER_PRIMITIVE`] more once the intersection structures are built). The TOML
/// reader counts its shapes with it too.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Cost {
    pub(crate) data: u64,
    pub(crate) primitives: u64,
}

impl Cost {
    pub(crate) fn of(g: &Geometry) -> Cost {
        let shape = std::mem::size_of::<Shape>() as u64;
        match g {
            Geometry::Sphere(Sphere { .. }) => Cost {
                data: shape,
                primitives: 1,
            },
            Geometry::Triangles(m) => Cost {
                data: shape
                    + 12 * m.positions.len() as u64
                    + m.normals.as_ref().map_or(0, |n| 12 * n.len() as u64)
                    + m.uvs.as_ref().map_or(0, |u| 8 * u.len() as u64)
                    + 12 * m.indices.len() as u64,
                primitives: m.indices.len() as u64,
            },
            Geometry::Quads(q) => Cost {
                data: shape + 12 * q.positions.len() as u64 + 16 * q.indices.len() as u64,
                primitives: 2 * q.indices.len() as u64,
            },
        }
    }

    /// The bytes in the scene and in the intersection structures.
    pub(crate) fn bytes(self) -> u64 {
        self.data
            .saturating_add(self.primitives.saturating_mul(ACCEL_BYTES_PER_PRIMITIVE))
    }

    pub(crate) fn add(self, other: Cost) -> Cost {
        Cost {
            data: self.data.saturating_add(other.data),
            primitives: self.primitives.saturating_add(other.primitives),
        }
    }

    fn times(self, n: u64) -> Cost {
        Cost {
            data: self.data.saturating_mul(n),
            primitives: self.primitives.saturating_mul(n),
        }
    }
}

/// What one sphere of an object costs in an instance that tessellates it.
fn tessellated_sphere_cost() -> Cost {
    static COST: OnceLock<Cost> = OnceLock::new();
    *COST.get_or_init(|| {
        shapes::unit_sphere(&DMat4::IDENTITY)
            .iter()
            .fold(Cost::default(), |c, g| c.add(Cost::of(g)))
    })
}

/// An object defined by `ObjectBegin`/`ObjectEnd`: the shapes an instance shares (stored
/// once, as a prototype, when first placed), the shapes each placement copies into world
/// space, and what one placement's copies cost, with their spheres kept as spheres (a
/// transform that scales uniformly) or tessellated (one that does not).
pub(super) struct Object {
    pub(super) shapes: Vec<Shape>,
    pub(super) shared: Vec<Shape>,
    /// The prototype made of `shared`, once placed.
    pub(super) prototype: Option<u32>,
    uniform: Cost,
    tessellated: Cost,
}

impl Object {
    /// The object of `shapes`, of which those for which `copied` holds are copied into
    /// world space at each placement.
    pub(super) fn new(shapes: Vec<Shape>, copied: impl Fn(&Shape) -> bool) -> Object {
        let (shapes, shared): (Vec<Shape>, Vec<Shape>) = shapes.into_iter().partition(copied);
        let spheres = shapes
            .iter()
            .filter(|s| matches!(s.geometry, Geometry::Sphere(Sphere { .. })))
            .count() as u64;
        let uniform = shapes
            .iter()
            .fold(Cost::default(), |c, s| c.add(Cost::of(&s.geometry)));
        let sphere = Cost::of(&Geometry::Sphere(Sphere {
            center: Default::default(),
            radius: 1.0,
        }));
        let tessellated = Cost {
            data: uniform.data - spheres * sphere.data,
            primitives: uniform.primitives - spheres * sphere.primitives,
        }
        .add(tessellated_sphere_cost().times(spheres));
        Object {
            shapes,
            shared,
            prototype: None,
            uniform,
            tessellated,
        }
    }

    /// The intersection structure's share of the prototype (its data is counted as read).
    pub(super) fn prototype_cost(&self) -> Cost {
        let data = self
            .shared
            .iter()
            .fold(Cost::default(), |c, s| c.add(Cost::of(&s.geometry)));
        Cost {
            data: 0,
            primitives: data.primitives,
        }
    }

    /// What one instance costs with its spheres tessellated or not.
    pub(super) fn instance_cost(&self, uniform_scale: bool) -> Cost {
        if uniform_scale {
            self.uniform
        } else {
            self.tessellated
        }
    }
}

impl Builder {
    /// Counts geometry about to be kept against the memory budget: `cost` in the world, or in
    /// an object definition (`in_world` false: no intersection structures are built for it).
    /// `what` names the statement in the message.
    pub(super) fn reserve(
        &mut self,
        loc: &Loc,
        what: &str,
        cost: Cost,
        in_world: bool,
    ) -> crate::error::Result<()> {
        let cost = if in_world {
            cost
        } else {
            Cost {
                data: cost.data,
                primitives: 0,
            }
        };
        let geometry = self.geometry.add(cost);
        let needed = geometry.bytes().saturating_add(self.held.open_files());
        self.budget.check(
            &format!(
                "{}: {what}: the scene's geometry ({} primitives so far) and its intersection \
                 structures",
                place(Some(loc), &self.source),
                geometry.primitives
            ),
            needed,
        )?;
        self.geometry = geometry;
        self.held.set_geometry(geometry.bytes());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::scene::TriangleMesh;

    #[test]
    fn costs_count_the_data_and_the_primitives() {
        let mesh = Geometry::Triangles(TriangleMesh {
            positions: vec![Vec3::ZERO; 4],
            normals: Some(vec![Vec3::Z; 4]),
            uvs: None,
            indices: vec![[0, 1, 2], [0, 2, 3]],
        });
        let c = Cost::of(&mesh);
        let shape = std::mem::size_of::<Shape>() as u64;
        assert_eq!(c.data, shape + 48 + 48 + 24);
        assert_eq!(c.primitives, 2);
        assert_eq!(c.bytes(), c.data + 512);
        let ball = Shape {
            media: None,
            geometry: Geometry::Sphere(Sphere {
                center: Vec3::ZERO,
                radius: 1.0,
            }),
            material: 0,
            alpha: None,
            motion: None,
        };
        let object = Object::new(vec![ball.clone(), ball], |_| true);
        assert_eq!(object.instance_cost(true).primitives, 2);
        let t = tessellated_sphere_cost();
        assert!(t.primitives > 1000, "{t:?}");
        assert_eq!(object.instance_cost(false), t.times(2));
    }
}
