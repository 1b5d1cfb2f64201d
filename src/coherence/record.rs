//! Recording a pixel block's ray segments without the integrators knowing: a wrapper around
//! the intersection backend that answers every query through the real backend and records
//! the segment it covered (origin to hit, or to the end of the ray), in either form.
//!
//! - Tables: the segment is walked through the grid; the voxels are first gathered in a
//!   small bit set private to the task (it stays in the cache, and the rays of one block
//!   cross mostly the same voxels), then set in the shared voxel tables once per voxel when
//!   the task ends.
//! - Segments: the segment, clipped to the box around the recording voxels, is copied into
//!   the thread's buffer; the block keeps an exact-size copy when the task ends.

use super::grid::ActiveVoxels;
use super::segments::BlockSegments;
use super::tables::{Table, VoxelTables};
use crate::accel::{Accel, Hit};
use crate::math::{Ray, Vec3};
use crate::scene::Scene;
use std::cell::{Cell, RefCell};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;

thread_local! {
    /// The last blocked shadow ray recorded on this thread and its nearest hit, and the
    /// recorder that made it (by serial number; 0: none). A task runs on one thread, its
    /// queries in order, so no lock is needed. The owner is kept apart so that a closest-hit
    /// query checks one word, not the whole entry.
    static LAST: Cell<Option<(Ray, Option<Hit>)>> = const { Cell::new(None) };
    static LAST_OWNER: Cell<u64> = const { Cell::new(0) };
    /// The segments of the recorder that owns this thread's buffer (by serial number; 0:
    /// none): a push without a lock. A recorder used on another thread, or while another
    /// owns the buffer, falls back to its own locked list.
    static LOCAL: RefCell<(u64, BlockSegments)> = const { RefCell::new((0, BlockSegments::new())) };
}

/// Serial numbers of recorders (0 is nobody).
static SERIAL: AtomicU64 = AtomicU64::new(1);

/// Where a recorder puts what it records.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Records {
    /// Walk every segment through the grid as it is traced and set the block's bit in the
    /// voxels' tables (the paper's form).
    Tables,
    /// Keep the block's segments; a frame walks them through the voxels that changed
    /// (segments.rs).
    Segments,
}

pub struct RecordingAccel<'a> {
    inner: &'a dyn Accel,
    scene: &'a Scene,
    voxels: &'a ActiveVoxels,
    records: Records,
    /// Tables: voxels crossed by rays looking for surfaces, and by shadow rays (one bit per
    /// voxel).
    surface: Vec<AtomicU64>,
    shadow: Vec<AtomicU64>,
    /// Segments: this recorder's serial number, and its list when the thread's is taken.
    serial: u64,
    spill: Mutex<BlockSegments>,
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
        records: Records,
    ) -> RecordingAccel<'a> {
        let words = match records {
            Records::Tables => voxels.fine.len().div_ceil(64),
            Records::Segments => 0,
        };
        let zeros = || (0..words).map(|_| AtomicU64::new(0)).collect();
        let serial = SERIAL.fetch_add(1, Ordering::Relaxed);
        if records == Records::Segments {
            LOCAL.with_borrow_mut(|(owner, list)| {
                if *owner == 0 {
                    *owner = serial;
                    list.clear();
                }
            });
        }
        RecordingAccel {
            inner,
            scene,
            voxels,
            records,
            surface: zeros(),
            shadow: zeros(),
            serial,
            spill: Mutex::new(BlockSegments::new()),
            hit: AtomicBool::new(false),
            nearest_blocker,
        }
    }

    /// Records the segment `origin + t·dir`, `t ∈ [t0, t1]`.
    #[inline]
    fn record(&self, table: Table, origin: Vec3, dir: Vec3, t0: f32, t1: f32) {
        // Each form in a function of its own: the walk inlined here made the common path
        // of the segments spill registers.
        match self.records {
            Records::Tables => self.walk(table, origin, dir, t0, t1),
            Records::Segments => self.keep(table, origin, dir, t0, t1),
        }
    }

    #[inline(never)]
    fn walk(&self, table: Table, origin: Vec3, dir: Vec3, t0: f32, t1: f32) {
        let set = match table {
            Table::Surface => &self.surface,
            Table::Shadow => &self.shadow,
        };
        self.voxels.walk(origin, dir, t0, t1, |v| mark(set, v));
    }

    #[inline(never)]
    fn keep(&self, table: Table, origin: Vec3, dir: Vec3, t0: f32, t1: f32) {
        let Some(s) = self.voxels.clip_segment(origin, dir, t0, t1) else {
            return;
        };
        let local = LOCAL.with_borrow_mut(|(owner, list)| {
            let mine = *owner == self.serial;
            if mine {
                list.push(table, s);
            }
            mine
        });
        if !local {
            let mut spill = self.spill.lock().unwrap_or_else(|e| e.into_inner());
            spill.push(table, s);
        }
    }

    /// The segments recorded (sealed), and whether any ray found a surface (segment records).
    pub fn finish(self) -> (BlockSegments, bool) {
        // The thread's buffer keeps its (warm) memory for the next task; the block keeps an
        // exact copy.
        let mut list = LOCAL.with_borrow_mut(|(owner, list)| {
            if *owner == self.serial {
                *owner = 0;
                list.clone()
            } else {
                BlockSegments::new()
            }
        });
        let spill = self.spill.into_inner().unwrap_or_else(|e| e.into_inner());
        if !spill.is_empty() {
            list.append(spill);
        }
        // Here, while the segments are in this thread's cache, not when the block is stored.
        list.seal();
        (list, self.hit.load(Ordering::Relaxed))
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
        // The same query gives the same answer: reuse the one `occluded` just made. Its
        // segment is then already in the shadow set, at least up to this hit; the shadow
        // table is read whenever the surface table is, so it needs no second walk.
        if LAST_OWNER.get() == self.serial {
            LAST_OWNER.set(0);
            if let Some((r, hit)) = LAST.take() {
                if same_ray(&r, ray) {
                    if hit.is_some() {
                        self.hit.store(true, Ordering::Relaxed);
                    }
                    return hit;
                }
            }
        }
        let hit = self.inner.intersect(ray);
        let end = hit.map_or(ray.tmax, |h| h.t);
        if hit.is_some() {
            self.hit.store(true, Ordering::Relaxed);
        }
        self.record(Table::Surface, ray.origin, ray.dir, ray.tmin, end);
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
            LAST.set(Some((*ray, hit)));
            LAST_OWNER.set(self.serial);
        }
        self.record(Table::Shadow, ray.origin, ray.dir, ray.tmin, end);
        blocked
    }
}
