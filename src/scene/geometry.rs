use crate::accel::Hit;
use crate::math::{Ray, Vec2, Vec3};

/// A piece of geometry and the material it is made of.
#[derive(Clone, Debug, PartialEq)]
pub struct Shape {
    pub geometry: Geometry,
    /// Index into `Scene::materials`.
    pub material: usize,
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

/// Where a ray met a surface, with what shading needs.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub p: Vec3,
    /// Unit geometric normal, as the geometry is oriented (not flipped towards the ray).
    pub ng: Vec3,
    /// Unit shading normal (interpolated for meshes with normals), on the same side as `ng`.
    pub ns: Vec3,
    pub uv: Vec2,
    pub t: f32,
    /// Index of the shape in `Scene::shapes`.
    pub shape: usize,
    pub material: usize,
}

impl SurfacePoint {
    /// Completes an intersection: position, normals and uv for the hit primitive.
    pub fn from_hit(shapes: &[Shape], ray: &Ray, hit: &Hit) -> SurfacePoint {
        let shape = &shapes[hit.geom_id as usize];
        let p = ray.at(hit.t);
        let ng = hit.ng.normalize();
        let (ns, uv) = match &shape.geometry {
            Geometry::Sphere { center, .. } => {
                let n = (p - *center).normalize();
                let uv = Vec2::new(
                    0.5 + n.z.atan2(n.x) / std::f32::consts::TAU,
                    n.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI,
                );
                (n, uv)
            }
            Geometry::Triangles(mesh) => {
                let [a, b, c] = mesh.indices[hit.prim_id as usize].map(|i| i as usize);
                let w = Vec3::new(1.0 - hit.u - hit.v, hit.u, hit.v);
                let ns = match &mesh.normals {
                    Some(n) => {
                        let n = (n[a] * w.x + n[b] * w.y + n[c] * w.z).normalize_or_zero();
                        if n == Vec3::ZERO {
                            ng
                        } else if n.dot(ng) < 0.0 {
                            // Keep the shading normal on the geometric side.
                            -n
                        } else {
                            n
                        }
                    }
                    None => ng,
                };
                let uv = match &mesh.uvs {
                    Some(t) => t[a] * w.x + t[b] * w.y + t[c] * w.z,
                    None => Vec2::new(hit.u, hit.v),
                };
                (ns, uv)
            }
            Geometry::Quads(_) => (ng, Vec2::new(hit.u, hit.v)),
        };
        SurfacePoint {
            p,
            ng,
            ns,
            uv,
            t: hit.t,
            shape: hit.geom_id as usize,
            material: shape.material,
        }
    }
}
