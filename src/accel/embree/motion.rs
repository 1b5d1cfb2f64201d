//! Moving geometry for the Embree backend: a geometry with two time steps (its vertices at
//! shutter open and at shutter close), which Embree interpolates linearly at each ray's time
//! and bounds over the interval in its motion-blur BVH.

use super::{check_indices, fill_buffer, sys, GeometryId, Scene};
use crate::error::{Error, Result};
use crate::math::{Vec3, Vec4};
use crate::scene::{Primitives, Shape};

impl Scene {
    /// Adds `shape`, whose `motion` has `geometry`'s kind and topology, as a geometry with
    /// two time steps; returns its geometry id.
    pub fn attach_moving(&mut self, shape: &Shape) -> Result<GeometryId> {
        let Some(end) = &shape.motion else {
            return Err(Error::Embree("attach_moving needs a moving shape".into()));
        };
        if !shape.motion_matches() {
            return Err(Error::Embree(
                "a shape moves into a shape of another kind or topology".into(),
            ));
        }
        let floats3 = |p: &[Vec3]| p.iter().flat_map(|v| v.to_array()).collect::<Vec<f32>>();
        match (shape.geometry.primitives(), end.primitives()) {
            (
                Primitives::Sphere { center, radius },
                Primitives::Sphere {
                    center: c1,
                    radius: r1,
                },
            ) => {
                let steps = [center.extend(radius), c1.extend(r1)];
                if let Some(s) = steps.iter().find(|s| !s.is_finite() || s.w <= 0.0) {
                    return Err(Error::Embree(format!(
                        "invalid sphere {s}: needs finite values and a positive radius"
                    )));
                }
                let step = |s: &Vec4| s.to_array().to_vec();
                self.attach_steps(
                    sys::RTC_GEOMETRY_TYPE_SPHERE_POINT,
                    [&step(&steps[0]), &step(&steps[1])],
                    (sys::RTC_FORMAT_FLOAT4, 4),
                    None,
                )
            }
            (Primitives::Triangles(a), Primitives::Triangles(b)) => {
                check_indices(a.positions.len(), a.indices.iter().flatten())?;
                self.attach_steps(
                    sys::RTC_GEOMETRY_TYPE_TRIANGLE,
                    [&floats3(&a.positions), &floats3(&b.positions)],
                    (sys::RTC_FORMAT_FLOAT3, 3),
                    Some((a.indices.as_flattened(), sys::RTC_FORMAT_UINT3, 3)),
                )
            }
            (Primitives::Quads(a), Primitives::Quads(b)) => {
                check_indices(a.positions.len(), a.indices.iter().flatten())?;
                self.attach_steps(
                    sys::RTC_GEOMETRY_TYPE_QUAD,
                    [&floats3(&a.positions), &floats3(&b.positions)],
                    (sys::RTC_FORMAT_FLOAT3, 3),
                    Some((a.indices.as_flattened(), sys::RTC_FORMAT_UINT4, 4)),
                )
            }
            _ => unreachable!("motion_matches checked the kinds"),
        }
    }

    /// A geometry of `kind` with one vertex buffer per time step (`per_vertex` floats a
    /// vertex, in `format`) and, for meshes, an index buffer.
    fn attach_steps(
        &mut self,
        kind: sys::RTCGeometryType,
        steps: [&[f32]; 2],
        (format, per_vertex): (sys::RTCFormat, usize),
        indices: Option<(&[u32], sys::RTCFormat, usize)>,
    ) -> Result<GeometryId> {
        if steps.iter().any(|s| s.iter().any(|x| !x.is_finite())) {
            return Err(Error::Embree(
                "a moving shape's vertices are not finite".into(),
            ));
        }
        let geometry = self.new_geometry(kind)?;
        // SAFETY: `geometry` is live; both steps hold the same number of vertices (the
        // shapes' topologies match).
        unsafe {
            sys::rtcSetGeometryTimeStepCount(geometry, 2);
            for (slot, step) in steps.iter().enumerate() {
                let vertex = (
                    sys::RTC_BUFFER_TYPE_VERTEX,
                    slot as u32,
                    format,
                    4 * per_vertex,
                );
                fill_buffer(geometry, vertex, step);
            }
            if let Some((indices, index_format, per_prim)) = indices {
                let index = (sys::RTC_BUFFER_TYPE_INDEX, 0, index_format, 4 * per_prim);
                fill_buffer(geometry, index, indices);
            }
        }
        self.finish_geometry(geometry)
    }
}
