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
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;

pub struct RecordingAccel<'a> {
    inner: &'a dyn Accel,
    scene: &'a Scene,
    voxels: &'a ActiveVoxels,
    /// The last blocked shadow ray and its nearest hit.
    last: Mutex<Option<(Ray, Option<Hit>)>>,
    has_last: AtomicBool,
    /// Voxels crossed by rays looking for surfaces, and by shadow rays (one bit per voxel).
    surface: Vec<AtomicU64>,
    shadow: Vec<AtomicU64>,
    hit: AtomicBool,
}

fn mark(set: &[AtomicU64], v: usize) {
    let (word, bit) = (&set[v / 64], 1u64 << (v % 64));
    // Only this task writes the set (atomics because `Accel` is shared by reference).
    if word.load(Ordering::Relaxed) & bit == 0 {
        word.store(word.load(Ordering::Relaxed) | bit, Ordering::Relaxed);
    }
}

impl<'a> RecordingAccel<'a> {
    pub fn new(
        inner: &'a dyn Accel,
        scene: &'a Scene,
        voxels: &'a ActiveVoxels,
    ) -> RecordingAccel<'a> {
        let words = voxels.fine.len().div_ceil(64);
        let zeros = || (0..words).map(|_| AtomicU64::new(0)).collect();
        RecordingAccel {
            inner,
            scene,
            voxels,
            last: Mutex::new(None),
            has_last: AtomicBool::new(false),
            surface: zeros(),
            shadow: zeros(),
            hit: AtomicBool::new(false),
        }
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
        // Most queries follow no blocked shadow ray: skip the lock (and any read-modify-
        // write) for them. Only this task uses the recorder.
        let cached = if self.has_last.load(Ordering::Relaxed) {
            self.has_last.store(false, Ordering::Relaxed);
            self.last.lock().unwrap_or_else(|e| e.into_inner()).take()
        } else {
            None
        };
        // The same query gives the same answer: reuse the one `occluded` just made. Its
        // segment is then already in the shadow set, at least up to this hit; the shadow
        // table is read whenever the surface table is, so it needs no second walk.
        let hit = match cached {
            Some((r, hit)) if same_ray(&r, ray) => {
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
        // whole segment is kept.
        let mut end = ray.tmax;
        if blocked {
            let hit = self.inner.intersect(ray);
            if let Some(h) = hit {
                let shape = &self.scene.shapes[h.geom_id as usize];
                if !self.scene.materials[shape.material].is_transmissive() {
                    end = h.t;
                }
            }
            // The Whitted integrator asks for this hit next: keep it.
            *self.last.lock().unwrap_or_else(|e| e.into_inner()) = Some((*ray, hit));
            self.has_last.store(true, Ordering::Relaxed);
        }
        self.voxels.walk(ray.origin, ray.dir, ray.tmin, end, |v| {
            mark(&self.shadow, v)
        });
        blocked
    }
}
