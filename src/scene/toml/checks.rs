//! Checks of values and shapes, and transforms. Each check returns the message for
//! [`Ctx::fail`](super::diagnostics::Ctx::fail).

use super::super::{Geometry, Primitives, TriangleMesh, MAX_RESOLUTION};
use crate::math::{Mat3, Mat4, Rgb, Vec3};

pub(super) fn finite(v: f32) -> Result<f32, String> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("must be a finite number, got {v}"))
    }
}

pub(super) fn positive(v: f32) -> Result<f32, String> {
    finite(v)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(format!("must be positive, got {v}"))
    }
}

pub(super) fn non_negative(v: f32) -> Result<f32, String> {
    finite(v)?;
    if v >= 0.0 {
        Ok(v)
    } else {
        Err(format!("must not be negative, got {v}"))
    }
}

pub(super) fn finite3(v: Vec3) -> Result<Vec3, String> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("must be finite, got {v}"))
    }
}

pub(super) fn colour(v: Vec3) -> Result<Rgb, String> {
    finite3(v)?;
    if v.min_element() >= 0.0 {
        Ok(v)
    } else {
        Err(format!("must not be negative, got {v}"))
    }
}

pub(super) fn direction(v: Vec3) -> Result<Vec3, String> {
    finite3(v)?;
    if !v.length().is_finite() {
        return Err(format!(
            "its length overflows single precision, got {}",
            crate::scene::camera::show(v)
        ));
    }
    let n = v.normalize_or_zero();
    if n == Vec3::ZERO {
        Err(format!("must be a non-zero vector, got {v}"))
    } else {
        Ok(n)
    }
}

/// Largest image side accepted.
pub(super) fn resolution(v: u32) -> Result<u32, String> {
    if (1..=MAX_RESOLUTION).contains(&v) {
        Ok(v)
    } else {
        Err(format!("must be between 1 and {MAX_RESOLUTION}, got {v}"))
    }
}

// ------------------------------------------------------------------------------------------
// Geometry helpers.

/// An affine transform with the matrix for normals.
pub(super) struct Xform {
    pub(super) m: Mat4,
    normal: Mat3,
    /// True when the transform mirrors (negative determinant): triangle winding is reversed
    /// to keep faces oriented as before.
    pub(super) flips: bool,
}

impl Xform {
    pub(super) fn new(m: Mat4) -> Result<Xform, String> {
        let linear = Mat3::from_mat4(m);
        let det = linear.determinant();
        if !m.is_finite() || !det.is_finite() {
            return Err(format!(
                "overflows: the combined transform is not finite (determinant {det})"
            ));
        }
        if det.abs() < 1e-30 {
            return Err(format!("is singular (determinant {det})"));
        }
        Ok(Xform {
            m,
            normal: linear.inverse().transpose(),
            flips: det < 0.0,
        })
    }

    pub(super) fn point(&self, p: Vec3) -> Vec3 {
        self.m.transform_point3(p)
    }

    pub(super) fn normal(&self, n: Vec3) -> Vec3 {
        (self.normal * n).normalize_or_zero()
    }

    /// Moves a mesh's positions and (unit) normals; the caller reverses the winding when
    /// `flips`.
    pub(super) fn place(&self, positions: &mut [Vec3], normals: &mut Option<Vec<Vec3>>) {
        for p in positions {
            *p = self.point(*p);
        }
        for n in normals.iter_mut().flatten() {
            *n = self.normal(*n);
        }
    }

    /// A sphere's centre and radius moved by this transform, which must be a rotation (or
    /// mirror) times a uniform scale; else why it cannot be.
    pub(super) fn sphere(&self, center: Vec3, radius: f32) -> Result<(Vec3, f32), &'static str> {
        let scale = self.uniform_scale().ok_or(
            "a sphere cannot take a non-uniform scale or shear (it would be an ellipsoid)",
        )?;
        Ok((self.point(center), radius * scale))
    }

    /// Some(s) when the linear part is a rotation (or mirror) times the uniform scale s.
    pub(super) fn uniform_scale(&self) -> Option<f32> {
        let l = Mat3::from_mat4(self.m);
        let cols = [l.x_axis, l.y_axis, l.z_axis];
        let len = cols.map(Vec3::length);
        let mean = (len[0] + len[1] + len[2]) / 3.0;
        let tol = 1e-4 * mean;
        let equal = len.iter().all(|&x| (x - mean).abs() <= tol);
        let orthogonal = (cols[0].dot(cols[1]).abs() <= tol * mean)
            && (cols[0].dot(cols[2]).abs() <= tol * mean)
            && (cols[1].dot(cols[2]).abs() <= tol * mean);
        (equal && orthogonal).then_some(mean)
    }
}

/// A 4x4 affine matrix written as rows.
pub(super) fn matrix(rows: &[Vec<f32>]) -> Result<Mat4, String> {
    if rows.len() != 4 || rows.iter().any(|r| r.len() != 4) {
        return Err("must be 4 rows of 4 numbers".into());
    }
    let mut a = [[0.0f32; 4]; 4];
    for (i, row) in rows.iter().enumerate() {
        for (j, &x) in row.iter().enumerate() {
            a[i][j] = finite(x)?;
        }
    }
    if a[3] != [0.0, 0.0, 0.0, 1.0] {
        return Err(format!(
            "must be affine: the last row must be [0, 0, 0, 1], got {:?}",
            a[3]
        ));
    }
    // glam takes columns; the file gives rows.
    Ok(Mat4::from_cols_array_2d(&a).transpose())
}

fn triangle_area(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    0.5 * (b - a).cross(c - a).length()
}

/// Newell's normal of a polygon: its length is twice the polygon's area.
fn newell(vs: &[Vec3]) -> Vec3 {
    // Relative to the centroid, for precision away from the origin.
    let c = vs.iter().copied().sum::<Vec3>() / vs.len().max(1) as f32;
    let mut n = Vec3::ZERO;
    for (i, &a) in vs.iter().enumerate() {
        let b = vs[(i + 1) % vs.len()];
        n += (a - c).cross(b - c);
    }
    n
}

/// Checks that the vertices form a planar, convex polygon with area; returns its unit normal
/// (following the vertex order).
pub(super) fn planar_convex(vs: &[Vec3], what: &str) -> Result<Vec3, String> {
    let n = newell(vs);
    // The bounding box's diagonal stands for the size.
    let lo = vs.iter().copied().fold(Vec3::splat(f32::MAX), Vec3::min);
    let hi = vs.iter().copied().fold(Vec3::splat(f32::MIN), Vec3::max);
    let size = (hi - lo).length();
    if !size.is_finite() {
        return Err("the vertices must be finite after the transform".into());
    }
    if size == 0.0 || n.length() <= 1e-10 * size * size {
        return Err(format!("the {what} has zero area"));
    }
    let n = n.normalize();
    let centre = vs.iter().copied().sum::<Vec3>() / vs.len() as f32;
    for (i, v) in vs.iter().enumerate() {
        let off = (*v - centre).dot(n).abs();
        if off > 1e-4 * size {
            return Err(format!(
                "the {what} is not planar: vertex {i} is {off} away from its mean plane"
            ));
        }
    }
    for i in 0..vs.len() {
        let (a, b, c) = (vs[i], vs[(i + 1) % vs.len()], vs[(i + 2) % vs.len()]);
        if (b - a).cross(c - b).dot(n) < -1e-6 * size * size {
            return Err(format!(
                "the {what} is not convex (at vertex {})",
                (i + 1) % vs.len()
            ));
        }
    }
    Ok(n)
}

pub(super) fn geometry_is_finite(g: &Geometry) -> bool {
    match g.primitives() {
        Primitives::Sphere { center, radius } => center.is_finite() && radius.is_finite(),
        Primitives::Triangles(m) => m.positions.iter().all(|p| p.is_finite()),
        Primitives::Quads(q) => q.positions.iter().all(|p| p.is_finite()),
    }
}

/// A mesh must have at least one triangle with area.
pub(super) fn check_area(mesh: &TriangleMesh) -> Result<(), String> {
    let any = mesh.indices.iter().any(|t| {
        let [a, b, c] = t.map(|k| {
            mesh.positions
                .get(k as usize)
                .copied()
                .unwrap_or(Vec3::ZERO)
        });
        triangle_area(a, b, c) > 0.0
    });
    if any {
        Ok(())
    } else {
        Err(format!(
            "all {} triangles are degenerate (zero area)",
            mesh.indices.len()
        ))
    }
}
