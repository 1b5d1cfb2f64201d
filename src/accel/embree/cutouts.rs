//! Alpha cut-outs in Embree: a geometry with a [`Cutout`] gets filter functions that skip
//! the hits its alpha test rejects, in closest-hit and occlusion queries alike.

use super::super::cutout::Cutout;
use super::{sys, GeometryId, Scene};
use crate::error::{Error, Result};
use crate::math::Vec3;
use std::ffi::c_void;
use std::sync::Arc;

impl Scene {
    /// Runs `cutout` on every candidate hit on geometry `id`, in closest-hit and occlusion
    /// queries alike (Embree's intersection and occlusion filter functions); the hits it
    /// rejects are skipped and traversal goes on. Takes effect at the next commit.
    pub fn set_cutout(&mut self, id: GeometryId, cutout: Arc<Cutout>) -> Result<()> {
        if id >= self.next_id {
            return Err(Error::Embree(format!("no geometry {id} to filter")));
        }
        let user = Arc::as_ptr(&cutout) as *mut c_void;
        // SAFETY: the scene is live and `id` attached to it. The user pointer is a `Cutout`
        // kept alive in `self.cutouts` as long as the scene (the geometry goes with it);
        // the filter only reads it.
        unsafe {
            let geometry = sys::rtcGetGeometry(self.raw, id);
            self.device.check("finding a geometry")?;
            sys::rtcSetGeometryUserData(geometry, user);
            sys::rtcSetGeometryIntersectFilterFunction(geometry, Some(cutout_filter));
            sys::rtcSetGeometryOccludedFilterFunction(geometry, Some(cutout_filter));
            sys::rtcCommitGeometry(geometry);
        }
        self.device.check("setting a geometry's filter")?;
        self.cutouts.push(cutout);
        self.committed = false;
        Ok(())
    }
}

/// Embree's filter for a geometry with a [`Cutout`]: clears the valid flag of each hit the
/// alpha test rejects. It must not unwind into C: `keeps_hit` only reads and computes.
unsafe extern "C" fn cutout_filter(args: *const sys::RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes valid arguments: `valid` holds N flags, `ray` and `hit` N rays
    // and hits in SOA layout (each field an array of N 4-byte values, in the order of
    // `RTCRay` and `RTCHit`, the candidate distance in tfar), and the user pointer is the
    // `Cutout` that `Scene::set_cutout` registered.
    unsafe {
        let args = &*args;
        let n = args.N as usize;
        let cutout = &*(args.geometryUserPtr as *const Cutout);
        let ray = args.ray as *const f32;
        let hit = args.hit as *const f32;
        let ray_field = |field: usize, i: usize| *ray.add(field * n + i);
        let hit_field = |field: usize, i: usize| *hit.add(field * n + i);
        for i in 0..n {
            let valid = args.valid.add(i);
            if *valid == 0 {
                continue;
            }
            // RTCRay: org_x, org_y, org_z, tnear, dir_x, dir_y, dir_z, time, tfar, ...
            let origin = Vec3::new(ray_field(0, i), ray_field(1, i), ray_field(2, i));
            let dir = Vec3::new(ray_field(4, i), ray_field(5, i), ray_field(6, i));
            let t = ray_field(8, i);
            // RTCHit: Ng_x, Ng_y, Ng_z, u, v, primID, ...
            let (u, v) = (hit_field(3, i), hit_field(4, i));
            let prim_id = hit_field(5, i).to_bits();
            if !cutout.keeps_hit(origin, dir, t, prim_id, u, v) {
                *valid = 0;
            }
        }
    }
}
