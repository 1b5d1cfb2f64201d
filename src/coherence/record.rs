//! Recording the voxels a pixel block's rays cross without the integrators knowing: a wrapper
//! around the intersection backend that answers every query through the real backend and
//! walks the segment it covered (origin to hit, or to the end of the ray) through the grid.
//!
//! The voxels are first gathered in a small bit set private to the task (it stays in the
//! cache, and the rays of one block cross mostly the same voxels), then set in the shared
//! voxel tables once per voxel when the task ends.

use super::grid::ActiveVoxels;
use super::tables::{Table, VoxelTables};
use crate::accel::{Accel, Hit};
use crate::math::Ray;
use crate::scene::Scene;
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

thread_local! {
    /// The last blocked shadow ray recorded on this thread, its nearest hit, and the
    /// recorder that made it (by address). A task runs on one thread, its queries in order,
    /// so no lock is needed.
    static LAST: Cell<Option<(usize, Ray, Option<Hit>)>> = const { Cell::new(None) };
}

pub struct RecordingAccel<'a> {
    inner: &'a dyn Accel,
    scene: &'a Scene,
    voxels: &'a ActiveVoxels,
    /// Voxels crossed by rays looking for surfaces, and by shadow rays (one bit per voxel).
    surface: Vec<AtomicU64>,
    shadow: Vec<AtomicU64>,
    hit: AtomicBool,
    /// Whether a blocked shadow ray is recorded only up to its nearest blocker, which takes
    /// one more query (the Whitted integrator asks for that hit anyway) instead of up to
    /// the light.
    nearest_blocker: bool,
}

fn mark(set: &[AtomicU64], v: usize) {
    let (word, bit) = (&set[v / 64], 1u64 << (v % 64));
    // Only this task writes the set (atomics because `Accel` is shared by reference).
    if word.load(Ordering::Relaxed) & bit == 0 {
        word.store(word.load(Ordering::Relaxed) | bit, Ordering::Relaxed);
    }
}

impl<'a> RecordingAccel<'a> {
    /// `nearest_blocker`: record a blocked shadow ray only up to its nearest opaque blocker,
    /// which takes one more query: worth it for the Whitted integrator, which asks for that
    /// hit next anyway (and gets it from here); the path tracer does not, and a recorded
    /// segment to the light costs it less than the query (measured: docs/animation.md).
    pub fn new(
        inner: &'a dyn Accel,
        scene: &'a Scene,
        voxels: &'a ActiveVoxels,
        nearest_blocker: bool,
    ) -> RecordingAccel<'a> {
        // Nothing cached by an earlier task (perhaps of another frame) may be reused.
        LAST.set(None);
        let words = voxels.fine.len().div_ceil(64);
        let zeros = || (0..words).map(|_| AtomicU64::new(0)).collect();
        RecordingAccel {
            inner,
            scene,
            voxels,
            surface: zeros(),
            shadow: zeros(),
            hit: AtomicBool::new(false),
            nearest_blocker,
        }
    }

    fn id(&self) -> usize {
        self as *const Self as usize
    }

    /// Sets `block`'s bit in the tables of every voxel recorded.
    pub fn flush(self, tables: &VoxelTables, block: usize) {
        for (table, set) in [
            (Table::Surface, &self.surface),
            (Table::Shadow, &self.shadow),
        ] {
            for (i, w) in set.iter().enumerate() {
                let mut w = w.load(Ordering::Relaxed);
                while w != 0 {
                    tables.set(table, i * 64 + w.trailing_zeros() as usize, block);
                    w &= w - 1;
                }
            }
        }
        if self.hit.load(Ordering::Relaxed) {
            tables.set_hit(block);
        }
    }
}

fn same_ray(a: &Ray, b: &Ray) -> bool {
    let bits = |r: &Ray| {
        (
            r.origin.to_array().map(f32::to_bits),
            r.dir.to_array().map(f32::to_bits),
            r.tmin.to_bits(),
            r.tmax.to_bits(),
        )
    };
    bits(a) == bits(b)
}

impl Accel for RecordingAccel<'_> {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let cached = LAST.take();
        // The same query gives the same answer: reuse the one `occluded` just made. Its
        // segment is then already in the shadow set, at least up to this hit; the shadow
        // table is read whenever the surface table is, so it needs no second walk.
        let hit = match cached {
            Some((id, r, hit)) if id == self.id() && same_ray(&r, ray) => {
                if hit.is_some() {
                    self.hit.store(true, Ordering::Relaxed);
                }
                return hit;
            }
            _ => self.inner.intersect(ray),
        };
        let end = hit.map_or(ray.tmax, |h| h.t);
        if hit.is_some() {
            self.hit.store(true, Ordering::Relaxed);
        }
        self.voxels.walk(ray.origin, ray.dir, ray.tmin, end, |v| {
            mark(&self.surface, v)
        });
        hit
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let blocked = self.inner.occluded(ray);
        // An unblocked segment is recorded to the light: anything that moves into it must
        // be seen. A blocked one only up to the nearest blocker when that is opaque: while
        // the blocker stays, nothing beyond it can change the answer (and if it moves, its
        // voxels change). Behind a transmissive blocker the light still counts, so the
        // whole segment is kept; without `nearest_blocker`, it always is.
        let mut end = ray.tmax;
        if blocked && self.nearest_blocker {
            let hit = self.inner.intersect(ray);
            if let Some(h) = hit {
                let shape = &self.scene.shapes[h.geom_id as usize];
                if !self.scene.materials[shape.material].is_transmissive() {
                    end = h.t;
                }
            }
            // The Whitted integrator asks for this hit next: keep it.
            LAST.set(Some((self.id(), *ray, hit)));
        }
        self.voxels.walk(ray.origin, ray.dir, ray.tmin, end, |v| {
            mark(&self.shadow, v)
        });
        blocked
    }
}
