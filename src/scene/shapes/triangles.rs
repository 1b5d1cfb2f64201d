//! An indexed triangle mesh in world space, with optional per-vertex normals and uvs.

use super::{Geometry, Primitives, ShapeModel, Tangents, UvMap};
use crate::math::{Vec2, Vec3};

/// An indexed triangle mesh in world space; normals and uvs, when present, are per vertex.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleMesh {
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    pub indices: Vec<[u32; 3]>,
}

impl TriangleMesh {
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        let [a, b, c] = self.indices[i];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }
}

impl ShapeModel for TriangleMesh {
    #[inline]
    fn primitives(&self) -> Primitives<'_> {
        Primitives::Triangles(self)
    }

    fn bounds(&self) -> (Vec3, Vec3) {
        super::bounds_of(&self.positions)
    }

    fn area(&self) -> f32 {
        super::area_of(&self.triangles())
    }

    fn primitive_count(&self) -> usize {
        self.indices.len()
    }

    fn triangles(&self) -> Vec<[Vec3; 3]> {
        (0..self.indices.len()).map(|i| self.triangle(i)).collect()
    }

    fn uv_maps(&self) -> Vec<UvMap> {
        (0..self.indices.len())
            .map(|i| {
                let corners = [Vec2::ZERO, Vec2::X, Vec2::Y];
                UvMap::Linear(match &self.uvs {
                    Some(t) => self.indices[i].map(|k| t[k as usize]),
                    None => corners,
                })
            })
            .collect()
    }

    #[inline]
    fn hit_uv(&self, prim_id: u32, u: f32, v: f32, _p: Vec3) -> Vec2 {
        match &self.uvs {
            Some(t) => {
                let [a, b, c] = self.indices[prim_id as usize].map(|i| i as usize);
                t[a] * (1.0 - u - v) + t[b] * u + t[c] * v
            }
            None => Vec2::new(u, v),
        }
    }

    fn tangents(&self, prim: usize, _u: f32, _v: f32, _p: Vec3, ng: Vec3) -> Tangents {
        tangents_at(self, prim, ng)
    }

    fn same_topology(&self, end: &Geometry) -> bool {
        matches!(end, Geometry::Triangles(b)
            if self.positions.len() == b.positions.len() && self.indices == b.indices)
    }
}

fn tangents_at(mesh: &TriangleMesh, prim: usize, ng: Vec3) -> Tangents {
    let [a, b, c] = mesh.indices[prim].map(|i| i as usize);
    let [p0, p1, p2] = [a, b, c].map(|i| mesh.positions[i]);
    // Without texture coordinates, (u, v) are the barycentrics of vertices 1 and 2.
    let [uv0, uv1, uv2] = match &mesh.uvs {
        Some(t) => [t[a], t[b], t[c]],
        None => [Vec2::ZERO, Vec2::X, Vec2::Y],
    };
    let (duv02, duv12) = (uv0 - uv2, uv1 - uv2);
    let (dp02, dp12) = (p0 - p2, p1 - p2);
    let det = duv02.x * duv12.y - duv02.y * duv12.x;
    if det.abs() < 1e-12 {
        return Tangents::around(ng);
    }
    let inv = 1.0 / det;
    let dpdu = (dp02 * duv12.y - dp12 * duv02.y) * inv;
    let dpdv = (dp12 * duv02.x - dp02 * duv12.x) * inv;
    if !dpdu.cross(dpdv).is_finite() || dpdu.cross(dpdv).length_squared() == 0.0 {
        return Tangents::around(ng);
    }
    let (dndu, dndv) = match &mesh.normals {
        Some(n) => {
            let (dn02, dn12) = (n[a] - n[c], n[b] - n[c]);
            (
                (dn02 * duv12.y - dn12 * duv02.y) * inv,
                (dn12 * duv02.x - dn02 * duv12.x) * inv,
            )
        }
        None => (Vec3::ZERO, Vec3::ZERO),
    };
    Tangents {
        dpdu,
        dpdv,
        dndu,
        dndv,
    }
}
