//! Shapes: every kind is a type of its own in a file of this folder implementing
//! [`ShapeModel`] (`sphere.rs`, `triangles.rs`, `quads.rs`), listed in [`Geometry`]. A
//! shape gives the intersection backends its [`Primitives`]; what techniques ask of it
//! (bounds, area, the triangles light sampling draws from, the uv and tangents of a hit)
//! is in its own file.

mod quads;
mod sphere;
mod tangents;
mod triangles;

pub use quads::QuadMesh;
pub use sphere::{sphere_uv, Sphere};
pub use tangents::Tangents;
pub use triangles::TriangleMesh;

use super::alpha::Alpha;
use crate::math::spawn::Spot;
use crate::math::{Ray, Vec2, Vec3};

/// A piece of geometry and the material it is made of.
#[derive(Clone, Debug, PartialEq)]
pub struct Shape {
    pub geometry: Geometry,
    /// Index into `Scene::materials`.
    pub material: usize,
    /// Where the surface is present (None: everywhere). Rays pass through cut-out parts.
    pub alpha: Option<Alpha>,
    /// The geometry at shutter close, for a shape that moves during the exposure (None: it
    /// stays still). Same kind and topology as `geometry`; between the two, vertices (a
    /// sphere's centre and radius) move linearly with the ray's time.
    pub motion: Option<Geometry>,
    /// The media on either side of the surface, for a shape that bounds a medium (None:
    /// rays crossing it stay in the medium they travel in).
    pub media: Option<crate::scene::media::MediumInterface>,
}

impl Shape {
    /// Whether the shape moves during the exposure (readers give a `motion` only to shapes
    /// whose geometry at close differs).
    pub fn moves(&self) -> bool {
        self.motion.is_some()
    }

    /// A sphere's centre and radius at shutter time `time` (in \[0, 1\]).
    pub(crate) fn sphere_at(&self, time: f32) -> Option<(Vec3, f32)> {
        let Geometry::Sphere(Sphere { center, radius }) = self.geometry else {
            return None;
        };
        match self.motion {
            Some(Geometry::Sphere(Sphere {
                center: c1,
                radius: r1,
            })) => Some((lerp(center, c1, time), radius + (r1 - radius) * time)),
            _ => Some((center, radius)),
        }
    }

    /// The box around the shape over the whole exposure.
    pub(crate) fn bounds_over_shutter(&self) -> (Vec3, Vec3) {
        let (lo, hi) = self.geometry.bounds();
        match &self.motion {
            Some(end) => {
                let (lo1, hi1) = end.bounds();
                (lo.min(lo1), hi.max(hi1))
            }
            None => (lo, hi),
        }
    }

    /// Whether `motion`, if any, has the kind and topology of `geometry` (what the
    /// intersection backends need to move one into the other).
    pub(crate) fn motion_matches(&self) -> bool {
        match &self.motion {
            None => true,
            Some(end) => self.geometry.model().same_topology(end),
        }
    }
}

/// `a` moved linearly towards `b` by `t`; exactly `a` when `b == a`, so still vertices stay
/// put at every time.
pub fn lerp(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    a + (b - a) * t
}

/// The kinds of shape, each a type of its own in a file of this folder.
#[derive(Clone, Debug, PartialEq)]
pub enum Geometry {
    Sphere(Sphere),
    Triangles(TriangleMesh),
    Quads(QuadMesh),
}

/// Calls `$call` on the kind's type, statically (hits ask for their shape's primitives and
/// uv on the hot path).
macro_rules! each_kind {
    ($g:expr, $s:ident => $call:expr) => {
        match $g {
            Geometry::Sphere($s) => $call,
            Geometry::Triangles($s) => $call,
            Geometry::Quads($s) => $call,
        }
    };
}

impl Geometry {
    /// The kind's interface.
    pub fn model(&self) -> &dyn ShapeModel {
        each_kind!(self, s => s as &dyn ShapeModel)
    }

    /// The shape as the intersection backends hold it.
    #[inline]
    pub fn primitives(&self) -> Primitives<'_> {
        each_kind!(self, s => s.primitives())
    }

    /// The axis-aligned box around the shape (inverted, lo > hi, for a mesh without
    /// vertices).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        each_kind!(self, s => s.bounds())
    }

    /// Surface area.
    pub fn area(&self) -> f32 {
        each_kind!(self, s => s.area())
    }

    /// Primitives the backends hold for it (a quad counts as two triangles).
    pub fn primitive_count(&self) -> usize {
        each_kind!(self, s => s.primitive_count())
    }

    /// The shape as world-space triangles (none for a shape without a tessellation).
    pub fn triangles(&self) -> Vec<[Vec3; 3]> {
        each_kind!(self, s => s.triangles())
    }

    /// The surface (u, v) of a hit at `p` on primitive `prim_id`, whose barycentric (or,
    /// for quads, bilinear) coordinates are `u`, `v`.
    #[inline]
    pub fn hit_uv(&self, prim_id: u32, u: f32, v: f32, p: Vec3) -> Vec2 {
        each_kind!(self, s => s.hit_uv(prim_id, u, v, p))
    }

    /// The derivatives of position and normal in (u, v) at point `p` of primitive `prim`,
    /// hit at barycentric (`u`, `v`), with unit geometric normal `ng`.
    pub fn tangents(&self, prim: usize, u: f32, v: f32, p: Vec3, ng: Vec3) -> Tangents {
        each_kind!(self, s => s.tangents(prim, u, v, p, ng))
    }
}

/// What every kind of shape gives: its form for the intersection backends, and what the
/// techniques and readers ask of a shape. A new kind is one file with a type implementing
/// this, a variant of [`Geometry`] and its line in `each_kind!`, and its readers.
pub trait ShapeModel {
    /// The shape as the intersection backends hold it (the primitive forms both backends
    /// intersect natively; a kind that has none of its own gives a tessellation).
    fn primitives(&self) -> Primitives<'_>;

    /// The axis-aligned box around the shape.
    fn bounds(&self) -> (Vec3, Vec3);

    /// Surface area.
    fn area(&self) -> f32;

    /// Primitives the backends hold for it.
    fn primitive_count(&self) -> usize;

    /// The shape as world-space triangles, in the order light sampling takes them (none
    /// for a shape sampled another way: a sphere, by the cone it subtends).
    fn triangles(&self) -> Vec<[Vec3; 3]>;

    /// How the points of each of [`triangles`](Self::triangles) map to the surface's
    /// (u, v), as hits on the shape give them.
    fn uv_maps(&self) -> Vec<UvMap>;

    /// The surface (u, v) of a hit at `p` on primitive `prim_id` with barycentric (or
    /// bilinear) coordinates `u`, `v`.
    fn hit_uv(&self, prim_id: u32, u: f32, v: f32, p: Vec3) -> Vec2;

    /// The derivatives of position and normal in (u, v) at a hit (normal and bump maps).
    fn tangents(&self, prim: usize, u: f32, v: f32, p: Vec3, ng: Vec3) -> Tangents;

    /// Whether `end` (the shape at shutter close) has this shape's kind and topology, so
    /// that the backends can move one into the other.
    fn same_topology(&self, end: &Geometry) -> bool;
}

/// A shape as the intersection backends hold it: the primitive forms both backends
/// intersect natively (Embree's sphere points, triangles and quads; the BVH's own tests).
#[derive(Clone, Copy, Debug)]
pub enum Primitives<'a> {
    Sphere { center: Vec3, radius: f32 },
    Triangles(&'a TriangleMesh),
    Quads(&'a QuadMesh),
}

/// How the points of a light triangle map to surface (u, v), as the hits on the shape do.
#[derive(Clone, Copy, Debug)]
pub enum UvMap {
    /// The uvs at the triangle's vertices, interpolated.
    Linear([Vec2; 3]),
    /// A quad (v0, v1, v2, v3) with Embree's parameterisation: barycentrics of (v0, v1, v3),
    /// or mirrored ones of (v2, v3, v1) beyond its diagonal.
    Quad([Vec3; 4]),
}

impl UvMap {
    /// The uv of the point with barycentrics (`b1`, `b2`) on the triangle, at `p`.
    pub fn uv(&self, b1: f32, b2: f32, p: Vec3) -> Vec2 {
        match *self {
            UvMap::Linear([a, b, c]) => a * (1.0 - b1 - b2) + b * b1 + c * b2,
            UvMap::Quad([v0, v1, v2, v3]) => {
                let (u, v) = barycentrics(p, v0, v1, v3);
                if u + v <= 1.0 {
                    Vec2::new(u, v)
                } else {
                    let (u, v) = barycentrics(p, v2, v3, v1);
                    Vec2::new(1.0 - u, 1.0 - v)
                }
            }
        }
    }
}

/// Barycentrics (towards `b`, towards `c`) of `p` in the plane of triangle (`a`, `b`, `c`).
fn barycentrics(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> (f32, f32) {
    let (e1, e2, d) = (b - a, c - a, p - a);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    let det = d11 * d22 - d12 * d12;
    if det == 0.0 {
        return (0.0, 0.0);
    }
    ((d22 * d1 - d12 * d2) / det, (d11 * d2 - d12 * d1) / det)
}

/// Where a ray met a surface, with what shading needs.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    /// The point, recomputed on the primitive.
    pub p: Vec3,
    /// A conservative bound of `p`'s floating-point error along each axis: rays leave the
    /// point from just outside it (see [`crate::math::spawn`]).
    pub error: Vec3,
    /// Unit geometric normal, as the geometry is oriented (not flipped towards the ray).
    pub ng: Vec3,
    /// Unit shading normal (interpolated for meshes with normals), on the same side as `ng`.
    pub ns: Vec3,
    pub uv: Vec2,
    pub t: f32,
    /// Index of the shape in `Scene::shapes`, or for a hit on an instance, in its
    /// prototype's shapes.
    pub shape: usize,
    /// The instance hit (index into `Scene::instances`), `None` for the scene's own shapes.
    pub instance: Option<u32>,
    pub material: usize,
    /// The shutter time of the ray that met it: rays leaving the point travel then too.
    pub time: f32,
}

impl SurfacePoint {
    /// Where rays leave the point: the point, its error and its geometric normal.
    pub fn spot(&self) -> Spot {
        Spot {
            p: self.p,
            error: self.error,
            n: self.ng,
        }
    }

    /// A ray leaving the surface along `dir`, at the point's shutter time.
    pub fn spawn(&self, dir: Vec3) -> Ray {
        self.spot().spawn(dir).at_time(self.time)
    }

    /// The segment from the surface to `to` (a shadow ray or a connection), at the point's
    /// shutter time; neither end's surface occludes it.
    pub fn spawn_to(&self, to: &Spot) -> Ray {
        self.spot().spawn_to(to).at_time(self.time)
    }

    /// The index of the shape in `Scene::shapes`, `None` for a point on an instance (whose
    /// shapes neither emit nor can be named in a set).
    pub(crate) fn world_shape(&self) -> Option<usize> {
        self.instance.is_none().then_some(self.shape)
    }
}

/// The box around `positions` (inverted, lo > hi, for none).
fn bounds_of(positions: &[Vec3]) -> (Vec3, Vec3) {
    positions.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    )
}

/// The total area of `triangles`.
fn area_of(triangles: &[[Vec3; 3]]) -> f32 {
    triangles
        .iter()
        .map(|[a, b, c]| 0.5 * (*b - *a).cross(*c - *a).length())
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kinds() -> Vec<Geometry> {
        vec![
            Geometry::Sphere(Sphere {
                center: Vec3::new(1.0, 2.0, 3.0),
                radius: 0.5,
            }),
            Geometry::Triangles(TriangleMesh {
                positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.5)],
                normals: None,
                uvs: Some(vec![
                    Vec2::new(0.1, 0.2),
                    Vec2::new(0.9, 0.3),
                    Vec2::new(0.2, 0.8),
                    Vec2::new(0.7, 0.7),
                ]),
                indices: vec![[0, 1, 2], [1, 3, 2]],
            }),
            // A parallelogram, so that the bilinear (u, v) is affine in the point.
            Geometry::Quads(QuadMesh {
                positions: vec![
                    Vec3::ZERO,
                    Vec3::new(2.0, 0.0, 0.0),
                    Vec3::new(3.0, 1.0, 0.0),
                    Vec3::new(1.0, 1.0, 0.0),
                ],
                indices: vec![[0, 1, 2, 3]],
            }),
        ]
    }

    /// What light sampling takes of a shape agrees with what its hits give: a uv map per
    /// light triangle, the triangles' areas summing to the shape's, and a point sampled on a
    /// light triangle getting the uv a hit there gets.
    #[test]
    fn light_triangles_agree_with_the_hits() {
        for g in kinds() {
            let m = g.model();
            let tris = m.triangles();
            assert_eq!(m.uv_maps().len(), tris.len(), "{g:?}");
            let (lo, hi) = m.bounds();
            match g.primitives() {
                Primitives::Sphere { center, radius } => {
                    assert!((m.area() - 4.0 * std::f32::consts::PI * radius * radius).abs() < 1e-5);
                    assert_eq!((lo, hi), (center - radius, center + radius));
                    continue;
                }
                Primitives::Triangles(mesh) => {
                    assert_eq!(m.primitive_count(), mesh.indices.len());
                    // Hit coordinates are the barycentrics of vertices 1 and 2.
                    for (i, map) in m.uv_maps().iter().enumerate() {
                        for (b1, b2) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.25, 0.5)] {
                            let [a, b, c] = tris[i];
                            let p = a * (1.0 - b1 - b2) + b * b1 + c * b2;
                            let want = m.hit_uv(i as u32, b1, b2, p);
                            assert!((map.uv(b1, b2, p) - want).length() < 1e-6);
                        }
                    }
                }
                Primitives::Quads(q) => {
                    assert_eq!(m.primitive_count(), 2 * q.indices.len());
                    let [v0, v1, _, v3] = q.quad(0);
                    for (u, v) in [(0.2, 0.3), (0.9, 0.8), (0.5, 0.5)] {
                        let p = v0 + (v1 - v0) * u + (v3 - v0) * v;
                        let want = m.hit_uv(0, u, v, p);
                        for map in m.uv_maps() {
                            assert!((map.uv(0.0, 0.0, p) - want).length() < 1e-5, "{u} {v}");
                        }
                    }
                }
            }
            let sum: f32 = tris
                .iter()
                .map(|[a, b, c]| 0.5 * (*b - *a).cross(*c - *a).length())
                .sum();
            assert!((m.area() - sum).abs() < 1e-6 * sum.max(1.0), "{g:?}");
            for p in tris.iter().flatten() {
                assert!(p.cmpge(lo).all() && p.cmple(hi).all());
            }
        }
    }

    /// A shape moves only into one of its own kind and topology.
    #[test]
    fn motion_needs_the_same_kind_and_topology() {
        let all = kinds();
        for (i, a) in all.iter().enumerate() {
            for (j, b) in all.iter().enumerate() {
                assert_eq!(a.model().same_topology(b), i == j);
            }
        }
        let Geometry::Triangles(mut fewer) = all[1].clone() else {
            unreachable!()
        };
        fewer.indices.pop();
        assert!(!all[1].model().same_topology(&Geometry::Triangles(fewer)));
    }
}
