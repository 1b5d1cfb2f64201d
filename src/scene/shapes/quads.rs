//! Planar quads in world space (each quad's four vertices lie in a plane), as Embree
//! intersects them: two triangles, (v0, v1, v3) and (v2, v3, v1), with bilinear (u, v).

use super::{Geometry, Primitives, ShapeModel, Tangents, UvMap};
use crate::math::{Vec2, Vec3};

/// Planar quads (each quad's four vertices lie in a plane), in world space.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct QuadMesh {
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 4]>,
}

impl QuadMesh {
    pub fn quad(&self, i: usize) -> [Vec3; 4] {
        self.indices[i].map(|k| self.positions[k as usize])
    }
}

impl ShapeModel for QuadMesh {
    #[inline]
    fn primitives(&self) -> Primitives<'_> {
        Primitives::Quads(self)
    }

    fn bounds(&self) -> (Vec3, Vec3) {
        super::bounds_of(&self.positions)
    }

    fn area(&self) -> f32 {
        super::area_of(&self.triangles())
    }

    fn primitive_count(&self) -> usize {
        2 * self.indices.len()
    }

    fn triangles(&self) -> Vec<[Vec3; 3]> {
        (0..self.indices.len())
            .flat_map(|i| {
                let [a, b, c, d] = self.quad(i);
                [[a, b, c], [a, c, d]]
            })
            .collect()
    }

    fn uv_maps(&self) -> Vec<UvMap> {
        (0..self.indices.len())
            .flat_map(|i| [UvMap::Quad(self.quad(i)); 2])
            .collect()
    }

    #[inline]
    fn hit_uv(&self, _prim_id: u32, u: f32, v: f32, _p: Vec3) -> Vec2 {
        Vec2::new(u, v)
    }

    fn tangents(&self, prim: usize, u: f32, v: f32, _p: Vec3, ng: Vec3) -> Tangents {
        // Embree's quad parametrisation: p0 the origin, p1 − p0 along u, p3 − p0 along v
        // (bilinear across the quad).
        let [p0, p1, p2, p3] = self.quad(prim);
        let dpdu = (p1 - p0) * (1.0 - v) + (p2 - p3) * v;
        let dpdv = (p3 - p0) * (1.0 - u) + (p2 - p1) * u;
        if dpdu.cross(dpdv).length_squared() > 0.0 {
            Tangents {
                dpdu,
                dpdv,
                dndu: Vec3::ZERO,
                dndv: Vec3::ZERO,
            }
        } else {
            Tangents::around(ng)
        }
    }

    fn same_topology(&self, end: &Geometry) -> bool {
        matches!(end, Geometry::Quads(b)
            if self.positions.len() == b.positions.len() && self.indices == b.indices)
    }
}
