//! The position of a hit recomputed on its primitive, with a conservative bound of its
//! floating-point error (pbrt-v4's `Point3fi` of an intersection): barycentric interpolation
//! on triangles and quads, a projection onto the surface for spheres. Unlike `o + t·d`, whose
//! error grows with the distance travelled, these points lie on the surface within a few ulps
//! of their own coordinates, so rays spawned from them need only a tiny offset.

use super::bvh::{sphere_point, triangle_weights};
use super::Hit;
use crate::math::spawn::{gamma, plane_test_error};
use crate::math::Vec3;
use crate::scene::{lerp, Geometry, Instance, Primitives, Shape};
use glam::Vec3A;

const SPHERE_TEST_ROUNDINGS: u32 = 8;

/// Where a hit lies in its shape's own space, and the error bound of that position.
pub(super) struct Located {
    pub p: Vec3,
    pub error: Vec3,
}

/// A backend's hit recomputed by raylink's own primitive tests (the BVH backend's), in the
/// shape's space: both backends' hits then give the same point, uv and normal bit for bit,
/// so the rays leaving them (and the alpha tests those rays meet) are the same too.
pub(super) struct Refined {
    pub at: Located,
    pub u: f32,
    pub v: f32,
    /// The unnormalised geometric normal in the shape's space, None where the recomputation
    /// degenerates and the backend's stands.
    pub ng: Option<Vec3>,
}

/// The hit point on `shape` (in the shape's space: object space for an instance's shape,
/// where `org` and `dir` are the ray), from the hit's primitive and barycentrics.
pub(super) fn locate(shape: &Shape, hit: &Hit, org: Vec3, dir: Vec3, time: f32) -> Refined {
    if let Some((center, radius)) = shape.sphere_at(time) {
        let (t, ng) = match sphere_point(center, radius, org, dir, hit.t) {
            Some((t, ng)) => (t, Some(ng)),
            None => (hit.t, None),
        };
        let at = on_sphere(shape, center, radius, org + dir * t);
        return Refined {
            at,
            u: hit.u,
            v: hit.v,
            ng,
        };
    }
    let (u, v) = (hit.u, hit.v);
    let prim = hit.prim_id as usize;
    // The vertices of the hit triangle (for quads, the half Embree splits it into).
    let (corners, second_half) = match shape.geometry.primitives() {
        Primitives::Triangles(m) => (m.indices[prim].map(|i| i as usize), false),
        Primitives::Quads(q) => {
            let [a, b, c, d] = q.indices[prim].map(|i| i as usize);
            if u + v <= 1.0 {
                ([a, b, d], false)
            } else {
                ([c, d, b], true)
            }
        }
        Primitives::Sphere { .. } => unreachable!("spheres are handled above"),
    };
    let positions = |g: &Geometry| match g.primitives() {
        Primitives::Triangles(m) => corners.map(|i| m.positions[i]),
        Primitives::Quads(q) => corners.map(|i| q.positions[i]),
        Primitives::Sphere { .. } => unreachable!("motion has the shape's kind"),
    };
    let start = positions(&shape.geometry);
    let (vertices, vertex_error) = match &shape.motion {
        None => (start, None),
        Some(end) => {
            let end = positions(end);
            // The backends interpolate moving vertices in their own order of operations:
            // each vertex is known to within the rounding of either interpolation.
            let moved = std::array::from_fn(|i| lerp(start[i], end[i], time));
            let error = std::array::from_fn(|i| (start[i].abs() + end[i].abs()) * gamma(6));
            (moved, Some(error))
        }
    };
    let (b1, b2, ng) = triangle_weights(vertices, org, dir);
    let at = on_triangle(vertices, vertex_error, b1, b2);
    // The second half of a quad, (v2, v3, v1), has the quad's coordinates mirrored.
    let (u, v) = if second_half {
        (1.0 - b1, 1.0 - b2)
    } else {
        (b1, b2)
    };
    let ng = (ng != Vec3::ZERO && ng.is_finite()).then_some(ng);
    Refined { at, u, v, ng }
}

/// The point of weights `b1`, `b2` on the triangle of `vertices` (known to within
/// `vertex_error` each, for moving shapes), with its error bound: the interpolation's
/// rounding, and what the backends' plane test rounds to when a ray leaves it.
#[inline]
fn on_triangle(vertices: [Vec3; 3], vertex_error: Option<[Vec3; 3]>, b1: f32, b2: f32) -> Located {
    let [v0, v1, v2] = vertices.map(Vec3A::from);
    let w0 = 1.0 - b1 - b2;
    let (a, b, c) = (v0 * w0, v1 * b1, v2 * b2);
    let p = a + b + c;
    let mut error = Vec3::from(a.abs() + b.abs() + c.abs()) * gamma(7);
    if let Some(vertex_error) = vertex_error {
        for (e, w) in vertex_error.into_iter().zip([w0, b1, b2]) {
            error += e * w.abs();
        }
    }
    let reach = (v0 - p).abs().max((v1 - p).abs()).max((v2 - p).abs());
    Located {
        p: Vec3::from(p),
        error: error + plane_test_error(reach.max_element()),
    }
}

/// The point of a sphere in direction `guess − center`, projected onto its surface
/// (pbrt-v4's reprojection), with its error bound.
fn on_sphere(shape: &Shape, center: Vec3, radius: f32, guess: Vec3) -> Located {
    let d = guess - center;
    let len = d.length();
    let q = if len > 0.0 {
        d * (radius / len)
    } else {
        Vec3::new(0.0, radius, 0.0)
    };
    let p = center + q;
    // Projection (γ5 of q, as pbrt-v4), then the addition of the centre; and the backends'
    // own quadratic (Embree's point-sphere test), whose roots round to ulps of the radius.
    let mut error = q.abs() * gamma(6)
        + center.abs() * gamma(2)
        + Vec3::splat(radius.abs() * gamma(SPHERE_TEST_ROUNDINGS));
    if let Some(Primitives::Sphere {
        center: c1,
        radius: r1,
    }) = shape.motion.as_ref().map(Geometry::primitives)
    {
        // A moving sphere's centre and radius are interpolated by each backend its own way.
        let Primitives::Sphere {
            center: c0,
            radius: r0,
        } = shape.geometry.primitives()
        else {
            unreachable!("a sphere's motion is a sphere")
        };
        error += (c0.abs() + c1.abs() + Vec3::splat(r0.abs() + r1.abs())) * gamma(6);
    }
    Located { p, error }
}

/// A point of an instance's shape placed in world space, with its error bound: the rounding
/// of the placement (pbrt-v4's transform of a `Point3fi`), and that of the intersection
/// structures' own world-to-object transform of rays that will leave from it.
pub(super) fn placed(instance: &Instance, at: Located) -> Located {
    let m = instance.to_world();
    let abs_m = m.matrix3.abs();
    let p = m.transform_point3(at.p);
    let rounding = abs_m * at.p.abs() + Vec3::from(m.translation).abs();
    let mut error = abs_m * at.error * (1.0 + gamma(3)) + rounding * gamma(3);
    let inv = instance.to_object();
    let back = inv.matrix3.abs() * p.abs() + Vec3::from(inv.translation).abs();
    error += abs_m * back * gamma(3);
    Located { p, error }
}
