//! Polygons and their patches. Every triangle pair that forms a planar parallelogram (the
//! usual two-triangle quad of meshes) and every parallelogram quad is one polygon; other
//! triangles and quads are triangles. A polygon is cut into a grid of n_s × n_t patches over
//! the parallelogram o + s·e1 + t·e2 (s, t in [0, 1]); a triangle keeps the cells of that grid
//! that touch it (s + t < 1). The cell size is at most `patch_size` (unit-cube units) along
//! each edge, so that (with patch_size = h) a patch projects onto about one intercept cell per
//! slope, as in the paper.
//!
//! Each patch has two *sides* (front: the polygon's winding normal, back): a side is a node of
//! the network only when some link reaches it, so closed rooms pay only for their inner faces.

use super::ray_space::RaySpace;
use crate::math::Vec3;
use crate::scene::{Primitives, Scene};

#[derive(Clone, Debug, PartialEq)]
pub struct Polygon {
    pub shape: u32,
    /// Corners in the unit cube (3 or 4, in winding order; a parallelogram has 4).
    pub corners: Vec<Vec3>,
    pub o: Vec3,
    pub e1: Vec3,
    pub e2: Vec3,
    /// Unit normal (winding), unit-cube space (the same direction as in world space).
    pub n: Vec3,
    /// Dual basis: s = d1·(p − o), t = d2·(p − o).
    pub d1: Vec3,
    pub d2: Vec3,
    pub triangle: bool,
    /// A sphere (unit-cube centre and radius): cells over (φ/2π, θ/π), the normal radial;
    /// only the Embree builder can find its links.
    pub sphere: Option<(Vec3, f32)>,
    pub ns: u32,
    pub nt: u32,
    /// Index of the polygon's first cell; cell (i, j) is first_cell + i·nt + j.
    pub first_cell: u32,
}

impl Polygon {
    fn new(shape: u32, corners: Vec<Vec3>, triangle: bool, patch_size: f32, first: u32) -> Self {
        let o = corners[0];
        let e1 = corners[1] - o;
        let e2 = if triangle {
            corners[2] - o
        } else {
            corners[3] - o
        };
        let n = e1.cross(e2).normalize_or_zero();
        let a = e2.cross(n);
        let b = n.cross(e1);
        let d1 = a / e1.dot(a);
        let d2 = b / e2.dot(b);
        let cells = |e: Vec3| ((e.length() / patch_size).ceil() as u32).clamp(1, 1 << 12);
        Polygon {
            shape,
            corners,
            o,
            e1,
            e2,
            n,
            d1,
            d2,
            triangle,
            sphere: None,
            ns: cells(e1),
            nt: cells(e2),
            first_cell: first,
        }
    }

    pub fn cells(&self) -> u32 {
        self.ns * self.nt
    }

    /// A sphere's cells: a lat-long grid with edges of about `patch_size`.
    fn sphere(shape: u32, centre: Vec3, radius: f32, patch_size: f32, first: u32) -> Self {
        let cells = |l: f32| ((l / patch_size).ceil() as u32).clamp(1, 1 << 12);
        Polygon {
            shape,
            corners: Vec::new(),
            o: centre,
            e1: Vec3::ZERO,
            e2: Vec3::ZERO,
            n: Vec3::ZERO,
            d1: Vec3::ZERO,
            d2: Vec3::ZERO,
            triangle: false,
            sphere: Some((centre, radius)),
            ns: cells(std::f32::consts::TAU * radius),
            nt: cells(std::f32::consts::PI * radius),
            first_cell: first,
        }
    }

    /// (s, t) of a point of the polygon's plane (of a sphere: φ/2π, θ/π).
    #[inline]
    pub fn st(&self, p: Vec3) -> (f32, f32) {
        if let Some((c, _)) = self.sphere {
            let d = (p - c).normalize_or_zero();
            let phi = d.z.atan2(d.x).rem_euclid(std::f32::consts::TAU);
            let theta = d.y.clamp(-1.0, 1.0).acos();
            return (phi / std::f32::consts::TAU, theta / std::f32::consts::PI);
        }
        let q = p - self.o;
        (self.d1.dot(q), self.d2.dot(q))
    }

    /// The point at (s, t).
    pub fn point(&self, s: f32, t: f32) -> Vec3 {
        if let Some((c, r)) = self.sphere {
            let (phi, theta) = (s * std::f32::consts::TAU, t * std::f32::consts::PI);
            return c + r * Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
        }
        self.o + s * self.e1 + t * self.e2
    }

    /// The front normal at a point of the surface.
    #[inline]
    pub fn normal_at(&self, p: Vec3) -> Vec3 {
        match self.sphere {
            Some((c, _)) => (p - c).normalize_or_zero(),
            None => self.n,
        }
    }

    /// The centre of a cell, (s, t).
    pub fn cell_centre(&self, cell: u32) -> (f32, f32) {
        let local = cell - self.first_cell;
        (
            ((local / self.nt) as f32 + 0.5) / self.ns as f32,
            ((local % self.nt) as f32 + 0.5) / self.nt as f32,
        )
    }

    /// The cell containing (s, t), clamped into the grid.
    #[inline]
    pub fn cell_at(&self, s: f32, t: f32) -> u32 {
        let i = ((s * self.ns as f32) as i32).clamp(0, self.ns as i32 - 1) as u32;
        let j = ((t * self.nt as f32) as i32).clamp(0, self.nt as i32 - 1) as u32;
        self.first_cell + i * self.nt + j
    }

    /// Area of the polygon (unit-cube units).
    #[cfg(test)]
    pub fn area(&self) -> f32 {
        if let Some((_, r)) = self.sphere {
            return 4.0 * std::f32::consts::PI * r * r;
        }
        let a = self.e1.cross(self.e2).length();
        if self.triangle {
            0.5 * a
        } else {
            a
        }
    }
}

/// The scene's polygons and the map from (shape, primitive) to polygon.
#[derive(Clone, Debug, PartialEq)]
pub struct Patches {
    pub polygons: Vec<Polygon>,
    /// For each shape, the polygon of each primitive (as the intersection backend numbers them).
    pub prim_polygon: Vec<Vec<u32>>,
    pub cells: u32,
    pub patch_size: f32,
}

/// Whether ABCD (in order) is a parallelogram: A + C = B + D up to rounding.
fn parallelogram(q: [Vec3; 4]) -> bool {
    let size = (q[2] - q[0]).length().max((q[3] - q[1]).length());
    let n1 = (q[1] - q[0]).cross(q[2] - q[0]);
    let n2 = (q[2] - q[0]).cross(q[3] - q[0]);
    ((q[0] + q[2]) - (q[1] + q[3])).length() <= 1e-5 * size && n1.dot(n2) > 0.0
}

/// The quad ABCD when triangles t0 and t1 share an edge A–C with t0 = (A, B, C) and
/// t1 = (A, C, D) up to rotation (same winding).
fn merge(t0: [u32; 3], t1: [u32; 3]) -> Option<[u32; 4]> {
    for r in 0..3 {
        let (a, b, c) = (t0[r], t0[(r + 1) % 3], t0[(r + 2) % 3]);
        for k in 0..3 {
            if t1[k] == a && t1[(k + 1) % 3] == c {
                return Some([a, b, c, t1[(k + 2) % 3]]);
            }
        }
    }
    None
}

impl Patches {
    /// Cuts the scene's polygons (and spheres) into patches.
    pub fn new(scene: &Scene, space: &RaySpace, patch_size: f32) -> Result<Patches, String> {
        if scene.has_instances() {
            return Err("the network needs world-space shapes: flatten the instances first".into());
        }
        let mut polygons = Vec::new();
        let mut prim_polygon = Vec::new();
        // Cells are numbered once every polygon exists.
        let push = |polygons: &mut Vec<Polygon>, shape, corners: Vec<Vec3>, tri| {
            polygons.push(Polygon::new(shape, corners, tri, patch_size, 0));
            polygons.len() as u32 - 1
        };
        for (si, shape) in scene.shapes.iter().enumerate() {
            let si = si as u32;
            let mut map = Vec::new();
            match shape.geometry.primitives() {
                Primitives::Sphere { center, radius } => {
                    let p = Polygon::sphere(
                        si,
                        space.to_unit(center),
                        radius / space.scale,
                        patch_size,
                        0,
                    );
                    polygons.push(p);
                    map.push(polygons.len() as u32 - 1);
                }
                Primitives::Triangles(m) => {
                    let pos = |i: u32| space.to_unit(m.positions[i as usize]);
                    let mut i = 0;
                    while i < m.indices.len() {
                        let t0 = m.indices[i];
                        let quad = (i + 1 < m.indices.len())
                            .then(|| merge(t0, m.indices[i + 1]))
                            .flatten()
                            .map(|q| q.map(pos))
                            .filter(|q| parallelogram(*q));
                        if let Some(q) = quad {
                            let id = push(&mut polygons, si, q.to_vec(), false);
                            map.extend([id, id]);
                            i += 2;
                        } else {
                            let id = push(&mut polygons, si, t0.map(pos).to_vec(), true);
                            map.push(id);
                            i += 1;
                        }
                    }
                }
                Primitives::Quads(q) => {
                    for k in 0..q.indices.len() {
                        let c = q.quad(k).map(|p| space.to_unit(p));
                        // A planar quad that is not a parallelogram keeps its four corners
                        // for scan conversion; its cells are those of the parallelogram on
                        // its first and last edges (points beyond clamp to the edge cells).
                        let id = push(&mut polygons, si, c.to_vec(), false);
                        map.push(id);
                    }
                }
            }
            prim_polygon.push(map);
        }
        // Degenerate polygons (zero area) take part in nothing.
        for p in polygons.iter_mut().filter(|p| p.sphere.is_none()) {
            if !p.n.is_finite() || p.n == Vec3::ZERO {
                p.n = Vec3::ZERO;
            }
        }
        let mut first = 0u32;
        for p in &mut polygons {
            p.first_cell = first;
            // Side keys (cell·2 + side) are 32-bit.
            first = first
                .checked_add(p.cells())
                .filter(|&n| n < u32::MAX / 2 - 1)
                .ok_or("too many patches for 32-bit indices: give a larger patch_size")?;
        }
        Ok(Patches {
            polygons,
            prim_polygon,
            cells: first,
            patch_size,
        })
    }

    /// The sides that face out of the scene, as a bit set over side keys (bit k % 64 of word
    /// k / 64): those of a polygon lying in a face of the scene's bounding box, facing out
    /// of the box. Every line leaving such a side goes where nothing is, so the side never
    /// links and is never a node (a room's walls seen from outside). The test is exact: the
    /// polygon's corners equal the box's bound, as computed from the same corners.
    pub fn outer_sides(&self) -> Vec<u64> {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for p in &self.polygons {
            match p.sphere {
                Some((c, r)) => (lo, hi) = (lo.min(c - Vec3::splat(r)), hi.max(c + Vec3::splat(r))),
                None => {
                    for &c in &p.corners {
                        (lo, hi) = (lo.min(c), hi.max(c));
                    }
                }
            }
        }
        let keys = 2 * self.cells as usize;
        let mut outer = vec![0u64; keys.div_ceil(64)];
        for p in self.polygons.iter().filter(|p| p.n != Vec3::ZERO) {
            for axis in 0..3 {
                // The box's face at its low (high) bound faces −axis (+axis); side 0 faces
                // along the winding normal, side 1 against it.
                for (bound, out) in [(lo[axis], -1.0), (hi[axis], 1.0)] {
                    if p.n[axis] == 0.0 || p.corners.iter().any(|c| c[axis] != bound) {
                        continue;
                    }
                    let side = u32::from(p.n[axis] * out < 0.0);
                    for cell in p.first_cell..p.first_cell + p.cells() {
                        let k = (cell * 2 + side) as usize;
                        outer[k / 64] |= 1 << (k % 64);
                    }
                }
            }
        }
        outer
    }

    /// The polygon and cell of an intersection point (unit-cube space).
    pub fn locate(&self, shape: u32, prim: u32, p: Vec3) -> Option<(u32, u32)> {
        let poly = *self.prim_polygon.get(shape as usize)?.get(prim as usize)?;
        let pg = &self.polygons[poly as usize];
        let (s, t) = pg.st(p);
        Some((poly, pg.cell_at(s, t)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// An open room (no front wall) with a block on its floor and a poster flat on its left
    /// wall: the outer sides are exactly those of polygons in a face of the bounding box
    /// that face away from the room.
    #[test]
    fn outer_sides_are_the_bounding_box_faces_seen_from_outside() {
        let quad = |v: &str| {
            format!("[[shapes]]\ntype = \"quad\"\nmaterial = \"white\"\nvertices = {v}\n")
        };
        let mut text = String::from(
            "[camera]\nposition = [1, 1, 5]\nlook_at = [1, 1, 0]\n\
             [materials.white]\ndiffuse = 0.5\n",
        );
        for v in [
            "[[0, 0, 0], [0, 0, 2], [2, 0, 2], [2, 0, 0]]",
            "[[0, 2, 0], [2, 2, 0], [2, 2, 2], [0, 2, 2]]",
            "[[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0]]",
            "[[0, 0, 0], [0, 2, 0], [0, 2, 2], [0, 0, 2]]",
            "[[2, 0, 2], [2, 2, 2], [2, 2, 0], [2, 0, 0]]",
            // The poster, and the block's top and one of its sides.
            "[[0, 0.5, 0.5], [0, 1, 0.5], [0, 1, 1], [0, 0.5, 1]]",
            "[[0.5, 0.5, 0.5], [0.5, 0.5, 1], [1, 0.5, 1], [1, 0.5, 0.5]]",
            "[[0.5, 0, 0.5], [0.5, 0.5, 0.5], [0.5, 0.5, 1], [0.5, 0, 1]]",
        ] {
            text += &quad(v);
        }
        let scene = crate::scene::toml::from_str(&text, Path::new("room.toml")).unwrap();
        let space = RaySpace::new(4, 1.0 / 16.0, scene.bounds().unwrap());
        let patches = Patches::new(&scene, &space, 1.0 / 8.0).unwrap();
        let outer = patches.outer_sides();
        let room_centre = space.to_unit(Vec3::splat(1.0));
        let mut marked = 0;
        for (i, p) in patches.polygons.iter().enumerate() {
            let centre = p.corners.iter().copied().sum::<Vec3>() / p.corners.len() as f32;
            for side in 0..2 {
                let facing = if side == 0 { p.n } else { -p.n };
                // The walls, floor, ceiling and poster lie in the box's faces; the block
                // (polygons 6 and 7) does not.
                let expected = i < 6 && facing.dot(centre - room_centre) > 0.0;
                for cell in p.first_cell..p.first_cell + p.cells() {
                    let k = (cell * 2 + side) as usize;
                    assert_eq!(
                        outer[k / 64] >> (k % 64) & 1 == 1,
                        expected,
                        "polygon {i} side {side}"
                    );
                    marked += usize::from(expected);
                }
            }
        }
        assert!(marked > 100, "{marked} outer sides");
    }
}
