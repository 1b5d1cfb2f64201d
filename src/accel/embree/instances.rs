//! Embree instances: each prototype is its own committed Embree scene, placed in the
//! top-level scene by instance geometries that hold a transform, so its BVH and vertices are
//! stored once however often it is placed.

use super::{sys, GeometryId, Scene};
use crate::error::{Error, Result};
use glam::Affine3A;

impl Scene {
    /// Places the committed scene `prototype` by `to_world` (object to world); returns the
    /// instance geometry's id. Embree keeps its own reference to the prototype.
    pub fn attach_instance(
        &mut self,
        prototype: &Scene,
        to_world: &Affine3A,
    ) -> Result<GeometryId> {
        if !prototype.committed {
            return Err(Error::Embree(
                "an instance's prototype must be committed first".into(),
            ));
        }
        let m = to_world.matrix3;
        let t = to_world.translation;
        // RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR: the three columns of the linear part, then the
        // translation.
        let columns: [f32; 12] = [
            m.x_axis.x, m.x_axis.y, m.x_axis.z, m.y_axis.x, m.y_axis.y, m.y_axis.z, m.z_axis.x,
            m.z_axis.y, m.z_axis.z, t.x, t.y, t.z,
        ];
        let geometry = self.new_geometry(sys::RTC_GEOMETRY_TYPE_INSTANCE)?;
        // SAFETY: `geometry` and `prototype.raw` are live; Embree copies the 12 floats.
        unsafe {
            sys::rtcSetGeometryInstancedScene(geometry, prototype.raw);
            sys::rtcSetGeometryTransform(
                geometry,
                0,
                sys::RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR,
                columns.as_ptr() as *const std::ffi::c_void,
            );
        }
        self.finish_geometry(geometry)
    }
}
