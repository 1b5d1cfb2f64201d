//! pbrt's animated transforms as raylink's moving shapes: `ActiveTransform` keeps a start and
//! an end transform, `TransformTimes` says when they hold, and the camera's
//! `shutteropen`/`shutterclose` when the film is exposed. A shape whose transforms at shutter
//! open and close differ gets its geometry at close as its `motion`; its vertices move in a
//! straight line between the two (pbrt interpolates rotations along an arc).

use super::builder::Builder;
use super::shapes::{swaps_handedness, uniform_scale};
use super::Loc;
use crate::math::Vec3;
use crate::scene::{Geometry, QuadMesh, Sphere, TriangleMesh};
use glam::{DMat3, DMat4};

/// When the start and end transforms hold, and when the shutter opens and closes (scene
/// time).
#[derive(Clone, Copy, Debug)]
pub(super) struct Timing {
    pub(super) transform: (f64, f64),
    pub(super) shutter: (f64, f64),
}

impl Default for Timing {
    fn default() -> Self {
        Timing {
            transform: (0.0, 1.0),
            shutter: (0.0, 1.0),
        }
    }
}

impl Timing {
    /// How far from the start transform to the end one the motion is at scene time `t`
    /// (clamped: before the start time the start transform holds, after the end the end).
    fn progress(&self, t: f64) -> f64 {
        let (t0, t1) = self.transform;
        if t1 <= t0 {
            return if t < t1 { 0.0 } else { 1.0 };
        }
        ((t - t0) / (t1 - t0)).clamp(0.0, 1.0)
    }

    /// The progress at shutter open and at close, and whether the motion is linear over the
    /// shutter (it is not when the shutter reaches beyond the transform times).
    fn over_shutter(&self) -> (f64, f64, bool) {
        let (open, close) = self.shutter;
        let (t0, t1) = self.transform;
        let linear = (t1 <= t0) || (open >= t0 && close <= t1) || close <= t0 || open >= t1;
        (self.progress(open), self.progress(close), linear)
    }
}

/// `m` linearly towards `n` by `u`.
fn mix(m: &DMat4, n: &DMat4, u: f64) -> DMat4 {
    if u == 0.0 {
        *m
    } else if u == 1.0 {
        *n
    } else {
        *m + (*n - *m) * u
    }
}

/// `geometry` moved by the world-space transform `rel`; None for what a straight-line motion
/// cannot show (a mirror, or a sphere scaled unevenly).
fn moved(geometry: &Geometry, rel: &DMat4) -> Option<Geometry> {
    if swaps_handedness(rel) {
        return None;
    }
    let point = |p: &Vec3| rel.transform_point3(p.as_dvec3()).as_vec3();
    let nm = DMat3::from_mat4(*rel).inverse().transpose();
    let normal = |n: &Vec3| (nm * n.as_dvec3()).normalize_or_zero().as_vec3();
    Some(match geometry {
        Geometry::Sphere(Sphere { center, radius }) => Geometry::Sphere(Sphere {
            center: point(center),
            radius: (*radius as f64 * uniform_scale(rel)?) as f32,
        }),
        Geometry::Triangles(m) => Geometry::Triangles(TriangleMesh {
            positions: m.positions.iter().map(point).collect(),
            normals: m.normals.as_ref().map(|ns| ns.iter().map(normal).collect()),
            ..m.clone()
        }),
        Geometry::Quads(q) => Geometry::Quads(QuadMesh {
            positions: q.positions.iter().map(point).collect(),
            indices: q.indices.clone(),
        }),
    })
}

impl Builder {
    /// The geometries a shape statement made with transform `start` (`end`: the shape's
    /// transform at the end time), each with its geometry at shutter close when it moves.
    /// Geometry at open is the given one unless the shutter opens after the start time.
    pub(super) fn moving(
        &mut self,
        loc: &Loc,
        st: &str,
        geometries: Vec<Geometry>,
        (start, end): (DMat4, DMat4),
    ) -> Vec<(Geometry, Option<Geometry>)> {
        if start == end {
            return geometries.into_iter().map(|g| (g, None)).collect();
        }
        let (u_open, u_close, linear) = self.timing.over_shutter();
        if !linear {
            self.warn(
                loc,
                "the shutter reaches beyond TransformTimes: the motion is spread evenly over \
                 the whole shutter",
            );
        }
        let inverse = start.inverse();
        let open = mix(&start, &end, u_open) * inverse;
        let close = mix(&start, &end, u_close) * inverse;
        let mut out = Vec::with_capacity(geometries.len());
        for g in geometries {
            let at_open = if u_open == 0.0 {
                Some(g.clone())
            } else {
                moved(&g, &open)
            };
            match (at_open, moved(&g, &close)) {
                (Some(a), Some(b)) if a != b => out.push((a, Some(b))),
                (Some(a), Some(_)) => out.push((a, None)),
                _ => {
                    self.warn(
                        loc,
                        format!(
                            "{st}: a motion that mirrors, or scales a sphere unevenly, is not \
                             supported; the shape stays still"
                        ),
                    );
                    out.push((g, None));
                }
            }
        }
        out
    }
}
