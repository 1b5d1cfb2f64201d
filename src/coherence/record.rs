//! Recording the voxels a pixel block's rays cross without the integrators knowing: a wrapper
//! around the intersection backend that answers every query through the real backend and
//! walks the segment it covered (origin to hit, or to the end of the ray) through the grid,
//! setting the block's bit in each voxel's surface or shadow table.

use super::grid::Grid;
use super::tables::{Table, VoxelTables};
use crate::accel::{Accel, Hit};
use crate::math::Ray;

pub struct RecordingAccel<'a> {
    pub inner: &'a dyn Accel,
    pub grid: &'a Grid,
    pub tables: &'a VoxelTables,
    /// The block whose pixels are being traced.
    pub block: usize,
}

impl Accel for RecordingAccel<'_> {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let hit = self.inner.intersect(ray);
        let end = hit.map_or(ray.tmax, |h| h.t);
        if hit.is_some() {
            self.tables.set_hit(self.block);
        }
        self.grid.walk(ray.origin, ray.dir, ray.tmin, end, |v| {
            self.tables.set(Table::Surface, v, self.block)
        });
        hit
    }

    fn occluded(&self, ray: &Ray) -> bool {
        // Whether or not something blocks it, the whole segment to the light is recorded:
        // the blocker may move away, and anything that moves into the segment must be seen.
        let blocked = self.inner.occluded(ray);
        self.grid
            .walk(ray.origin, ray.dir, ray.tmin, ray.tmax, |v| {
                self.tables.set(Table::Shadow, v, self.block)
            });
        blocked
    }
}
