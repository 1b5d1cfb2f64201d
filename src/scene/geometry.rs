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
}

impl Shape {
    /// Whether the shape moves during the exposure (readers give a `motion` only to shapes
    /// whose geometry at close differs).
    pub fn moves(&self) -> bool {
        self.motion.is_some()
    }

    /// A sphere's centre and radius at shutter time `time` (in \[0, 1\]).
    pub fn sphere_at(&self, time: f32) -> Option<(Vec3, f32)> {
        let Geometry::Sphere { center, radius } = self.geometry else {
            return None;
        };
        match self.motion {
            Some(Geometry::Sphere {
                center: c1,
                radius: r1,
            }) => Some((lerp(center, c1, time), radius + (r1 - radius) * time)),
            _ => Some((center, radius)),
        }
    }

    /// The box around the shape over the whole exposure.
    pub fn bounds_over_shutter(&self) -> (Vec3, Vec3) {
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
    pub fn motion_matches(&self) -> bool {
        match (&self.geometry, &self.motion) {
            (_, None) => true,
            (Geometry::Sphere { .. }, Some(Geometry::Sphere { .. })) => true,
            (Geometry::Triangles(a), Some(Geometry::Triangles(b))) => {
                a.positions.len() == b.positions.len() && a.indices == b.indices
            }
            (Geometry::Quads(a), Some(Geometry::Quads(b))) => {
                a.positions.len() == b.positions.len() && a.indices == b.indices
            }
            _ => false,
        }
    }
}

/// `a` moved linearly towards `b` by `t`; exactly `a` when `b == a`, so still vertices stay
/// put at every time.
pub fn lerp(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    a + (b - a) * t
}

#[derive(Clone, Debug, PartialEq)]
pub enum Geometry {
    Sphere { center: Vec3, radius: f32 },
    Triangles(TriangleMesh),
    Quads(QuadMesh),
}

/// An indexed triangle mesh in world space; normals and uvs, when present, are per vertex.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleMesh {
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    pub indices: Vec<[u32; 3]>,
}

/// Planar quads (each quad's four vertices lie in a plane), in world space.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct QuadMesh {
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 4]>,
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

impl QuadMesh {
    pub fn quad(&self, i: usize) -> [Vec3; 4] {
        self.indices[i].map(|k| self.positions[k as usize])
    }
}

impl Geometry {
    /// The shape as world-space triangles (spheres excluded: they have none).
    pub fn triangles(&self) -> Vec<[Vec3; 3]> {
        match self {
            Geometry::Sphere { .. } => Vec::new(),
            Geometry::Triangles(m) => (0..m.indices.len()).map(|i| m.triangle(i)).collect(),
            Geometry::Quads(q) => (0..q.indices.len())
                .flat_map(|i| {
                    let [a, b, c, d] = q.quad(i);
                    [[a, b, c], [a, c, d]]
                })
                .collect(),
        }
    }

    /// The axis-aligned box around the shape (inverted, lo > hi, for a mesh without
    /// vertices).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match self {
            Geometry::Sphere { center, radius } => (*center - *radius, *center + *radius),
            Geometry::Triangles(TriangleMesh { positions, .. })
            | Geometry::Quads(QuadMesh { positions, .. }) => positions.iter().fold(
                (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                |(lo, hi), p| (lo.min(*p), hi.max(*p)),
            ),
        }
    }

    /// The surface (u, v) of a hit at `p` on primitive `prim_id`, whose barycentric (or, for
    /// quads, bilinear) coordinates are `u`, `v`: spheres map latitude and longitude, meshes
    /// interpolate their uvs (or give u, v themselves without them).
    pub fn hit_uv(&self, prim_id: u32, u: f32, v: f32, p: Vec3) -> Vec2 {
        match self {
            Geometry::Sphere { center, .. } => sphere_uv((p - *center).normalize()),
            Geometry::Triangles(mesh) => match &mesh.uvs {
                Some(t) => {
                    let [a, b, c] = mesh.indices[prim_id as usize].map(|i| i as usize);
                    t[a] * (1.0 - u - v) + t[b] * u + t[c] * v
                }
                None => Vec2::new(u, v),
            },
            Geometry::Quads(_) => Vec2::new(u, v),
        }
    }

    /// Surface area.
    pub fn area(&self) -> f32 {
        match self {
            Geometry::Sphere { radius, .. } => 4.0 * std::f32::consts::PI * radius * radius,
            _ => self
                .triangles()
                .iter()
                .map(|[a, b, c]| 0.5 * (*b - *a).cross(*c - *a).length())
                .sum(),
        }
    }
}

/// The uv of a point on a sphere whose outward unit normal is `n`.
pub fn sphere_uv(n: Vec3) -> Vec2 {
    Vec2::new(
        0.5 + n.z.atan2(n.x) / std::f32::consts::TAU,
        n.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI,
    )
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
    pub fn world_shape(&self) -> Option<usize> {
        self.instance.is_none().then_some(self.shape)
    }
}
