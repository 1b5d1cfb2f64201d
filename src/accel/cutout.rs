//! The alpha test both backends run inside traversal: a shape with an alpha gets a
//! [`Cutout`], asked about each candidate hit on the shape, so that closest-hit and
//! occlusion queries both pass through the cut-out parts and go on to what lies behind.

use crate::math::{Ray, Vec3};
#[cfg(feature = "embree")]
use crate::scene::Scene;
use crate::scene::{Alpha, Geometry, Shape};

/// What the alpha test of one shape needs: its alpha, and its geometry for the hit's uv.
#[derive(Debug)]
pub struct Cutout {
    geom_id: u32,
    alpha: Alpha,
    /// The shape's geometry (a copy: the accel outlives the scene it was built from).
    geometry: Geometry,
}

impl Cutout {
    /// The cut-outs of a scene's shapes, indexed by shape (None for opaque shapes).
    #[cfg(feature = "embree")]
    pub fn of_scene(scene: &Scene) -> Vec<Option<Cutout>> {
        Cutout::of_shapes(&scene.shapes)
    }

    /// The cut-outs of `shapes`, indexed by shape (None for opaque shapes).
    pub fn of_shapes(shapes: &[Shape]) -> Vec<Option<Cutout>> {
        shapes
            .iter()
            .enumerate()
            .map(|(i, shape)| {
                shape.alpha.as_ref().map(|alpha| Cutout {
                    geom_id: i as u32,
                    alpha: alpha.clone(),
                    geometry: shape.geometry.clone(),
                })
            })
            .collect()
    }

    /// Whether a hit at distance `t` on primitive `prim_id` (at `u`, `v`, as [`super::Hit`]
    /// has them) stops `ray` from `origin` along `dir`.
    pub fn keeps_hit(&self, origin: Vec3, dir: Vec3, t: f32, prim_id: u32, u: f32, v: f32) -> bool {
        let ray = Ray {
            origin,
            dir,
            tmin: 0.0,
            tmax: t,
            time: 0.0,
        };
        let uv = self.geometry.hit_uv(prim_id, u, v, ray.at(t));
        self.alpha.keeps_hit(uv, origin, dir, self.geom_id, prim_id)
    }
}
