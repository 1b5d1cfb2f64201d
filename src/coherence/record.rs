//! Recording a pixel block's ray segments without the integrators knowing: a wrapper around
//! the intersection backend that answers every query through the real backend and records
//! the segment it covered (origin to hit, or to the end of the ray), in either form.
//!
//! - Tables: the segment is walked through the grid; the voxels are first gathered in a
//!   small bit set private to the task (it stays in the cache, and the rays of one block
//!   cross mostly the same voxels), then set in the shared voxel tables once per voxel when
//!   the task ends.
//! - Segments: the segment, clipped to the box around the recording voxels and quantised
//!   (segments.rs), is pushed to the thread's buffer, made as large as the thread's last
//!   task needed; the block takes the lists when the task ends, shrunk in place (no copy:
//!   frame 0 writes every record once).
//!
//! Every query of a retraced block is also kept with its answer ([`Query`]): when the block
//! is retraced again, a ray that is the same as one of its last trace and crosses no changed
//! voxel up to its hit gets that answer again without a query (section 3.3.3 of the paper
//! for camera rays: no intersection work in unchanged voxels before the stored hit; with
//! Embree, which cannot start a traversal part-way, the whole query goes). Reflection,
//! refraction and shadow rays are answered the same way: a pixel is retraced because one
//! of its rays crossed a changed voxel, and the others of its ray tree come out the same.
//! A sample whose every query holds is not even shaded again (answers.rs).

mod answers;

use super::grid::ActiveVoxels;
use super::segments::{Point16, Quantiser, Segment};
use super::tables::{Table, VoxelTables};
use crate::accel::{Accel, Hit};
use crate::math::{Ray, Vec3};
use crate::scene::{Light, Scene};
pub(super) use answers::Replaying;
use answers::{Kind, Query};
pub use answers::{Recorded, Reuse};
use glam::Vec3A;
use std::cell::{Cell, RefCell};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;

thread_local! {
    /// The last blocked shadow ray recorded on this thread and its nearest hit, and the
    /// recorder that made it (by serial number; 0: none). A task runs on one thread, its
    /// queries in order, so no lock is needed. The owner is kept apart so that a closest-hit
    /// query checks one word, not the whole entry.
    static LAST: Cell<Option<(Ray, Option<Hit>)>> = const { Cell::new(None) };
    static LAST_OWNER: Cell<u64> = const { Cell::new(0) };
    /// What the recorder that owns this thread's buffer recorded (by serial number; 0:
    /// none): a push without a lock. A recorder used on another thread, or while another
    /// owns the buffer, falls back to its own locked list.
    static LOCAL: RefCell<(u64, Recorded)> = const { RefCell::new((0, Recorded::new())) };
}

/// How many stored camera rays a camera ray looks ahead of the last one matched (the rays
/// of a retraced block come in the same order, but for pixels whose sampling changed), and
/// how many stored queries another ray looks ahead of the last one matched, within the
/// ray tree of the last camera ray matched (a ray that changed leaves its old subtree
/// unmatched behind it).
const LOOKAHEAD: usize = 16;
const TREE_LOOKAHEAD: usize = 32;

/// The cursor before a task's first camera ray.
const UNSYNCED: usize = usize::MAX;

/// Serial numbers of recorders (0 is nobody).
static SERIAL: AtomicU64 = AtomicU64::new(1);

/// Where a recorder puts what it records.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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
    /// Segments: the lattice their points are kept on.
    quantiser: Quantiser,
    /// Tables: voxels crossed by rays looking for surfaces, and by shadow rays (one bit per
    /// voxel).
    surface: Vec<AtomicU64>,
    shadow: Vec<AtomicU64>,
    /// This recorder's serial number, and its lists when the thread's are taken.
    serial: u64,
    spill: Mutex<Recorded>,
    /// The shapes' fingerprints in this frame, if queries are kept with their answers (a
    /// kept hit names its shape by fingerprint).
    shape_keys: Option<&'a [u64]>,
    /// Stored answers to reuse, where their camera rays are among them, the next camera
    /// ray expected (in `cameras`), the next query expected and the end of its camera ray's
    /// tree (in `reuse.previous`).
    reuse: Option<Reuse<'a>>,
    cameras: Vec<u32>,
    /// Per entry of `cameras`, its sample in `reuse.shaded` (`u32::MAX`: none).
    samples: Vec<u32>,
    /// The last camera query kept, in the lists (`usize::MAX`: none since its sample).
    last_camera: AtomicUsize,
    samples_reused: AtomicU64,
    cursor: AtomicUsize,
    tree: AtomicUsize,
    tree_end: AtomicUsize,
    camera_reused: AtomicU64,
    camera_rays: AtomicU64,
    others_reused: AtomicU64,
    hit: AtomicBool,
    /// Whether a blocked shadow ray is recorded only up to its nearest blocker, which takes
    /// one more query (the Whitted integrator asks for that hit anyway) instead of up to
    /// the light.
    nearest_blocker: bool,
    /// The point lights shadow rays went to (see [`Recorded::lights`]).
    lights: AtomicU64,
    /// The scene's point lights: their bit in `lights` and their position; all their bits.
    point_lights: Vec<(u64, Vec3A)>,
    point_bits: u64,
    /// The shared lists' slots: one per point light (in the order of `point_lights`; a
    /// shadow segment that ends at one's lattice point is kept by its start in its list),
    /// then the camera's, whose segments start at the camera's exact position.
    slots: Vec<(Table, bool, Vec3, Point16)>,
    /// The box around the recording voxels (`None`: none record).
    bounds: Option<(Vec3A, Vec3A)>,
    /// The point lights' keys on the lattice, in the order of their slots, packed (a shadow
    /// segment's end is looked for among them).
    light_keys: Vec<u64>,
}

/// A lattice point in one word, to compare at once.
#[inline(always)]
fn packed(p: Point16) -> u64 {
    p[0] as u64 | (p[1] as u64) << 16 | (p[2] as u64) << 32
}

fn mark(set: &[AtomicU64], v: usize) {
    let (word, bit) = (&set[v / 64], 1u64 << (v % 64));
    // Only this task writes the set (atomics because `Accel` is shared by reference).
    if word.load(Ordering::Relaxed) & bit == 0 {
        word.store(word.load(Ordering::Relaxed) | bit, Ordering::Relaxed);
    }
}

/// Counts one (only the task's thread writes the counter: no atomic add needed).
fn bump(counter: &AtomicU64) {
    counter.store(counter.load(Ordering::Relaxed) + 1, Ordering::Relaxed);
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
        LOCAL.with_borrow_mut(|(owner, list)| {
            if *owner == 0 {
                *owner = serial;
                list.clear();
            }
        });
        let point_lights: Vec<(u64, Vec3A)> = scene
            .lights
            .iter()
            .enumerate()
            .filter_map(|(i, light)| match light {
                Light::Point(l) => Some((1u64 << i.min(63), l.position.into())),
                _ => None,
            })
            .collect();
        let quantiser = Quantiser::new(&voxels.fine);
        let camera = scene.camera.position;
        let slots: Vec<_> = (point_lights.iter())
            .map(|&(_, p)| quantiser.encode(p))
            .map(|e| (Table::Shadow, false, quantiser.decode(e), e))
            .chain([(
                Table::Surface,
                true,
                camera,
                quantiser.encode(camera.into()),
            )])
            .collect();
        RecordingAccel {
            inner,
            scene,
            voxels,
            records,
            quantiser,
            surface: zeros(),
            shadow: zeros(),
            serial,
            spill: Mutex::new(Recorded::new()),
            shape_keys: None,
            reuse: None,
            cameras: Vec::new(),
            samples: Vec::new(),
            last_camera: AtomicUsize::new(usize::MAX),
            samples_reused: AtomicU64::new(0),
            cursor: AtomicUsize::new(UNSYNCED),
            tree: AtomicUsize::new(UNSYNCED),
            tree_end: AtomicUsize::new(0),
            camera_reused: AtomicU64::new(0),
            camera_rays: AtomicU64::new(0),
            others_reused: AtomicU64::new(0),
            hit: AtomicBool::new(false),
            nearest_blocker,
            lights: AtomicU64::new(0),
            point_bits: point_lights.iter().fold(0, |m, l| m | l.0),
            point_lights,
            bounds: (voxels.bounds()).map(|(lo, hi)| (lo.into(), hi.into())),
            light_keys: slots[..slots.len() - 1]
                .iter()
                .map(|l| packed(l.3))
                .collect(),
            slots,
        }
    }

    /// Also records every query with its answer (`shape_keys`: the shapes' fingerprints in
    /// this frame), and answers them from `reuse` where nothing changed along them.
    pub fn with_camera(mut self, shape_keys: &'a [u64], reuse: Option<Reuse<'a>>) -> Self {
        self.shape_keys = Some(shape_keys);
        if let Some(r) = &reuse {
            self.cameras = (r.previous.iter().enumerate())
                .filter(|(_, q)| q.kind == Kind::Camera)
                .map(|(i, _)| i as u32)
                .collect();
            let mut shaded = r.shaded.iter().enumerate().peekable();
            self.samples = (self.cameras.iter())
                .map(|&at| {
                    while shaded.next_if(|(_, s)| s.at < at).is_some() {}
                    match shaded.peek() {
                        Some((k, s)) if s.at == at && r.shading => *k as u32,
                        _ => u32::MAX,
                    }
                })
                .collect();
        }
        self.reuse = reuse;
        self
    }

    /// Runs `f` on this recorder's lists: the thread's buffer if it owns it, else its own.
    #[inline]
    fn with_lists(&self, f: impl FnOnce(&mut Recorded)) {
        let mut f = Some(f);
        LOCAL.with_borrow_mut(|(owner, list)| {
            if *owner == self.serial {
                (f.take().expect("called once"))(list);
            }
        });
        if let Some(f) = f {
            f(&mut self.spill.lock().unwrap_or_else(|e| e.into_inner()));
        }
    }

    /// The stored query of camera ray `ray`: the same ray traced in the block's last trace
    /// (its tree's queries are looked for next).
    fn stored_camera(&self, ray: &Ray) -> Option<&Query> {
        let j = self.find_camera(ray)?;
        Some(self.sync_camera(j))
    }

    /// Where camera ray `ray` is in `cameras`, if it is among them (the cursor moved on
    /// only if not: [`sync_camera`](Self::sync_camera) moves it to a ray found).
    fn find_camera(&self, ray: &Ray) -> Option<usize> {
        let reuse = self.reuse.as_ref()?;
        let start = self.cursor.load(Ordering::Relaxed);
        // The task's first camera ray is looked for in the whole list: a block traced in
        // several tiles (one task each) has them one after the other in it.
        let range = match start {
            UNSYNCED => 0..self.cameras.len(),
            _ => start..(start + LOOKAHEAD).min(self.cameras.len()),
        };
        let found = range
            .into_iter()
            .find(|&j| same_ray(&reuse.previous[self.cameras[j] as usize].ray, ray));
        let Some(j) = found else {
            if start == UNSYNCED {
                self.cursor.store(0, Ordering::Relaxed);
            }
            // This camera ray is new: its tree too.
            self.tree.store(UNSYNCED, Ordering::Relaxed);
            return None;
        };
        Some(j)
    }

    /// Moves past camera ray `j` (of `cameras`), whose tree's queries are looked for next;
    /// its stored query.
    fn sync_camera(&self, j: usize) -> &Query {
        let reuse = self.reuse.as_ref().expect("found among the stored queries");
        self.cursor.store(j + 1, Ordering::Relaxed);
        let at = self.cameras[j] as usize;
        let end = self
            .cameras
            .get(j + 1)
            .map_or(reuse.previous.len(), |&p| p as usize);
        self.tree.store(at + 1, Ordering::Relaxed);
        self.tree_end.store(end, Ordering::Relaxed);
        &reuse.previous[at]
    }

    /// The range of camera ray `j`'s tree in the stored queries (the ray's own first).
    fn tree_of(&self, j: usize) -> std::ops::Range<usize> {
        let reuse = self.reuse.as_ref().expect("found among the stored queries");
        let end = (self.cameras.get(j + 1)).map_or(reuse.previous.len(), |&p| p as usize);
        self.cameras[j] as usize..end
    }

    /// The stored query of a ray of the current camera ray's tree, of one of `kinds`.
    fn stored_in_tree(&self, ray: &Ray, kinds: [Kind; 2]) -> Option<&Query> {
        let reuse = self.reuse.as_ref()?;
        let start = self.tree.load(Ordering::Relaxed);
        if start == UNSYNCED {
            return None;
        }
        let end = (start + TREE_LOOKAHEAD).min(self.tree_end.load(Ordering::Relaxed));
        let i = (start..end).find(|&i| {
            let q = &reuse.previous[i];
            kinds.contains(&q.kind) && same_ray(&q.ray, ray)
        })?;
        self.tree.store(i + 1, Ordering::Relaxed);
        Some(&reuse.previous[i])
    }

    /// Whether `stored`'s answer holds for its ray in this frame: its hit is on the same
    /// shape (by fingerprint) and it crosses no voxel where a surface changed up to that hit
    /// (or to its end, if it hit nothing).
    fn holds(&self, stored: &Query) -> bool {
        let (Some(reuse), Some(keys)) = (self.reuse.as_ref(), self.shape_keys) else {
            return false;
        };
        let ray = &stored.ray;
        let t1 = match stored.hit {
            Some(h) if keys.get(h.geom_id as usize) != Some(&stored.shape) => return false,
            Some(h) => h.t,
            None => ray.tmax,
        };
        !reuse.changed.crossed_by(ray.origin, ray.dir, ray.tmin, t1)
    }

    /// The stored hit of camera ray `ray`, if it can be reused.
    fn stored_hit(&self, ray: &Ray) -> Option<Option<Hit>> {
        let stored = self.stored_camera(ray)?;
        self.holds(stored).then_some(stored.hit)
    }

    /// Keeps a query with its answer, if queries are kept.
    #[inline]
    fn keep_query(&self, ray: &Ray, hit: Option<Hit>, kind: Kind) {
        let Some(keys) = self.shape_keys else {
            return;
        };
        let shape = hit.map_or(0, |h| keys[h.geom_id as usize]);
        self.with_lists(|list| {
            if kind == Kind::Camera {
                self.last_camera.store(list.camera.len(), Ordering::Relaxed);
            }
            list.camera.push(Query {
                ray: *ray,
                hit,
                shape,
                kind,
            })
        });
    }

    /// Notes a ray looking for a surface that got `hit`, and records its segment (to the hit,
    /// or to the end of the ray).
    fn record_surface(&self, ray: &Ray, hit: Option<Hit>) {
        let end = self.reached(ray, hit);
        self.record(Table::Surface, ray.origin, ray.dir, ray.tmin, end);
    }

    /// Notes whether a ray looking for a surface found one (`hit`); where its segment ends.
    #[inline]
    fn reached(&self, ray: &Ray, hit: Option<Hit>) -> f32 {
        if hit.is_some() {
            self.hit.store(true, Ordering::Relaxed);
        }
        hit.map_or(ray.tmax, |h| h.t)
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
        if let Some(s) = self.on_lattice(origin, dir, t0, t1) {
            self.with_lists(|list| list.segments.push(table, s));
        }
    }

    /// The segment `origin + t·dir`, `t ∈ [t0, t1]`, clipped to the recording box and
    /// quantised; `None` if it misses the box.
    #[inline(always)]
    fn on_lattice(&self, origin: Vec3, dir: Vec3, t0: f32, t1: f32) -> Option<Segment> {
        let [a, b] = self.voxels.clip_segment(origin, dir, t0, t1)?;
        Some([self.quantiser.encode(a), self.quantiser.encode(b)])
    }

    /// Records the shadow segment `origin + t·dir`, `t ∈ [t0, t1]`. With segments, one that
    /// is a segment towards a point (`whole`: t1 is the ray's end, at most 1) is kept to
    /// t = 1, the point itself: a little longer than traced (a conservative record), and
    /// when that point is a light's, by its start in the light's list (half the memory).
    #[inline(never)]
    fn keep_shadow(&self, origin: Vec3, dir: Vec3, t0: f32, t1: f32, whole: bool) {
        if self.records == Records::Tables || !whole || t1 > 1.0 {
            return self.record(Table::Shadow, origin, dir, t0, t1);
        }
        let Some(s) = self.on_lattice(origin, dir, t0, 1.0) else {
            return;
        };
        let end = packed(s[1]);
        let light = self.light_keys.iter().position(|&key| key == end);
        self.with_lists(|list| match light {
            Some(slot) => list.segments.push_shared(slot, self.slots[slot], s[0]),
            None => list.segments.push(Table::Shadow, s),
        });
    }

    /// Notes a camera ray that got `hit`, and records its segment as any ray looking for a
    /// surface, but by its end in the camera's list when it leaves from the camera's
    /// position (a pinhole; with segments).
    #[inline(never)]
    fn keep_camera(&self, ray: &Ray, hit: Option<Hit>) {
        let t1 = self.reached(ray, hit);
        let slot = self.slots.len() - 1;
        let camera = self.slots[slot].2;
        let from_camera = ray.origin.to_array() == camera.to_array() && ray.tmin == 0.0;
        if self.records == Records::Tables || !from_camera {
            return self.record(Table::Surface, ray.origin, ray.dir, ray.tmin, t1);
        }
        // Only the end is kept: a hit inside the recording box is its own clip (the camera
        // is often outside it, where the clip would take a slab test per ray).
        let end = Vec3A::from(ray.origin) + Vec3A::from(ray.dir) * t1;
        let inside = (self.bounds).is_some_and(|(lo, hi)| (end.cmpge(lo) & end.cmple(hi)).all());
        let end = match inside {
            true => Some(self.quantiser.encode(end)),
            false => (self.on_lattice(ray.origin, ray.dir, 0.0, t1)).map(|[_, end]| end),
        };
        if let Some(end) = end {
            self.with_lists(|list| list.segments.push_shared(slot, self.slots[slot], end));
        }
    }

    /// What was recorded: the segments (sealed), the stored answers, whether any ray found a
    /// surface, and the camera rays answered from stored hits.
    pub fn finish(self) -> Recorded {
        // The block takes the thread's lists, and their box is made while they are in this
        // thread's cache, not when the block is stored.
        let mut recorded = LOCAL.with_borrow_mut(|(owner, list)| {
            if *owner == self.serial {
                *owner = 0;
                list.take()
            } else {
                Recorded::new()
            }
        });
        let spill = self.spill.into_inner().unwrap_or_else(|e| e.into_inner());
        if !spill.segments.is_empty() || !spill.camera.is_empty() || !spill.shaded.is_empty() {
            recorded.append(spill);
            recorded.segments.seal();
        }
        recorded.hit = self.hit.load(Ordering::Relaxed);
        recorded.camera_reused = self.camera_reused.load(Ordering::Relaxed);
        recorded.camera_rays = self.camera_rays.load(Ordering::Relaxed);
        recorded.others_reused = self.others_reused.load(Ordering::Relaxed);
        recorded.samples_reused = self.samples_reused.load(Ordering::Relaxed);
        recorded.lights = self.lights.load(Ordering::Relaxed);
        recorded
    }

    /// Notes the point light a shadow segment goes to, if it goes to one: its end (t = 1 of
    /// a segment from a surface to a light) is the light's position. A light whose
    /// intensity alone changes is a change with no extent in space: the blocks whose shadow
    /// rays went to it are the ones it reaches.
    fn note_light(&self, ray: &Ray) {
        let seen = self.lights.load(Ordering::Relaxed);
        // Once every point light is noted (after a few shadow rays of a block), nothing to do.
        if seen & self.point_bits == self.point_bits {
            return;
        }
        // (Squared distances: no square root on every shadow ray.)
        let end = Vec3A::from(ray.origin + ray.dir);
        let near2 = 1e-8 * ray.dir.length_squared().max(1e-12);
        let mut now = seen;
        for &(bit, position) in &self.point_lights {
            if now & bit == 0 && end.distance_squared(position) <= near2 {
                now |= bit;
            }
        }
        if now != seen {
            self.lights.store(now, Ordering::Relaxed);
        }
    }

    /// Sets `block`'s bit in the tables of every voxel recorded.
    pub fn flush(&self, tables: &VoxelTables, block: usize) {
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
            r.time.to_bits(),
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
        let stored = self.stored_in_tree(ray, [Kind::Surface; 2]);
        let hit = match stored.filter(|q| self.holds(q)) {
            Some(q) => {
                bump(&self.others_reused);
                q.hit
            }
            None => self.inner.intersect(ray),
        };
        self.record_surface(ray, hit);
        self.keep_query(ray, hit, Kind::Surface);
        hit
    }

    fn intersect_camera(&self, ray: &Ray) -> Option<Hit> {
        if self.shape_keys.is_none() {
            let hit = self.inner.intersect(ray);
            self.keep_camera(ray, hit);
            return hit;
        }
        bump(&self.camera_rays);
        let hit = match self.stored_hit(ray) {
            Some(hit) => {
                bump(&self.camera_reused);
                hit
            }
            None => self.inner.intersect(ray),
        };
        // Recorded as any ray looking for a surface, and kept with its hit for next time.
        self.keep_camera(ray, hit);
        self.keep_query(ray, hit, Kind::Camera);
        hit
    }

    fn occluded(&self, ray: &Ray) -> bool {
        // A stored blocked ray holds while its nearest blocker is there and nothing changed
        // before it (or along the whole ray, without one); a clear one while nothing changed
        // along it.
        let stored = self.stored_in_tree(ray, [Kind::Blocked, Kind::Clear]);
        let (blocked, nearest) = match stored.filter(|q| self.holds(q)) {
            Some(q) => {
                bump(&self.others_reused);
                (q.kind == Kind::Blocked, Some(q.hit))
            }
            None => (self.inner.occluded(ray), None),
        };
        let kept = self.record_occlusion(ray, blocked, nearest);
        // The Whitted integrator asks for the nearest blocker next: keep it.
        if blocked && self.nearest_blocker {
            LAST.set(Some((*ray, kept)));
            LAST_OWNER.set(self.serial);
        }
        let kind = if blocked { Kind::Blocked } else { Kind::Clear };
        self.keep_query(ray, kept, kind);
        blocked
    }
}

impl RecordingAccel<'_> {
    /// Records shadow ray `ray`, `blocked` or not, whose nearest blocker is `nearest` if
    /// known (else found here when needed); returns the nearest blocker kept with it.
    fn record_occlusion(
        &self,
        ray: &Ray,
        blocked: bool,
        nearest: Option<Option<Hit>>,
    ) -> Option<Hit> {
        if !self.point_lights.is_empty() {
            self.note_light(ray);
        }
        // An unblocked segment is recorded to the light: anything that moves into it must
        // be seen. A blocked one only up to the nearest blocker when that is opaque: while
        // the blocker stays, nothing beyond it can change the answer (and if it moves, its
        // voxels change). Behind a transmissive blocker the light still counts, so the
        // whole segment is kept; without `nearest_blocker`, it always is.
        let mut end = ray.tmax;
        let mut kept = None;
        if blocked && self.nearest_blocker {
            let hit = nearest.unwrap_or_else(|| self.inner.intersect(ray));
            kept = hit;
            if let Some(h) = hit {
                let shape = &self.scene.shapes[h.geom_id as usize];
                if !self.scene.may_transmit(shape.material) {
                    end = h.t;
                }
            }
        }
        self.keep_shadow(ray.origin, ray.dir, ray.tmin, end, end == ray.tmax);
        kept
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{self, Backend};
    use crate::coherence::grid::Grid;
    use crate::control::Control;
    use crate::scene::animation::Animation;
    use crate::tests::coherence_scenes::{animated, MOVING};
    use std::path::Path;

    /// A shadow ray to a point light is kept by its start in the light's list, reaching the
    /// light (not stopping short of it as traced); one stopped at an opaque blocker, and one
    /// that goes to no light, are kept whole, as traced. A camera ray from the camera is kept
    /// by its end in the camera's list; one from elsewhere whole.
    #[test]
    fn shared_ends_are_kept_once() {
        let scene = Animation::from_str(&animated("", MOVING), Path::new("t.toml"))
            .unwrap()
            .scene_at(0)
            .unwrap();
        let accel = accel::build(&scene, Backend::Embree, &Control::default()).unwrap();
        let light = match scene.lights[0] {
            Light::Point(ref l) => l.position,
            _ => unreachable!("the scene's light is a point light"),
        };
        let (lo, hi) = scene.bounds().unwrap();
        let voxels = ActiveVoxels::all(Grid::new(lo.min(light), hi.max(light), [8, 8, 8]));
        let q = Quantiser::new(&voxels.fine);
        let near = |a: Vec3, b: Vec3| (a - b).abs().max_element() <= q.error();
        let recorder =
            RecordingAccel::new(accel.as_ref(), &scene, &voxels, true, Records::Segments);
        // From the lit floor to the light, from below the floor to the light (the floor
        // blocks it), and from the floor to a point that is no light.
        let lit = Vec3::new(2.0, 1e-3, 2.0);
        let below = Vec3::new(2.0, -1.0, 2.0);
        assert!(!recorder.occluded(&Ray::segment(lit, light)));
        assert!(recorder.occluded(&Ray::segment(below, light)));
        recorder.occluded(&Ray::segment(lit, Vec3::new(3.0, 2.0, 1.0)));
        let recorded = recorder.finish();
        let s = &recorded.segments;
        assert_eq!(recorded.lights, 1);
        assert_eq!(s.shared.len(), 1);
        let l = &s.shared[0];
        assert_eq!(
            (l.table, l.start, l.others.len()),
            (Table::Shadow, false, 1)
        );
        assert!(near(l.point, light) && near(q.decode(l.others[0]), lit));
        // A camera ray is kept by its hit in the camera's list, from the camera itself.
        let camera = scene.camera.position;
        let down = Vec3::new(0.0, -1.4, -3.5);
        let recorder =
            RecordingAccel::new(accel.as_ref(), &scene, &voxels, true, Records::Segments);
        let hit = recorder.intersect_camera(&Ray::new(camera, down)).unwrap();
        let elsewhere = Ray::new(camera + Vec3::X * 0.01, down);
        recorder.intersect_camera(&elsewhere).unwrap();
        let c = recorder.finish().segments;
        // (Empty lists are dropped: the light's.)
        assert_eq!(c.shared.len(), 1);
        let l = &c.shared[0];
        assert_eq!(
            (l.table, l.start, l.others.len()),
            (Table::Surface, true, 1)
        );
        assert_eq!(l.point, camera);
        assert!(near(q.decode(l.others[0]), camera + down * hit.t));
        // (The ray from elsewhere is kept whole.)
        assert_eq!(c.surface.len(), 1);
        assert!(near(q.decode(c.surface[0][0]), elsewhere.origin));
        // The blocked one ends at the floor, the other at its end.
        assert_eq!(s.shadow.len(), 2);
        let floor = below + (light - below) * (1.0 / (light.y - below.y));
        assert!(
            near(q.decode(s.shadow[0][1]), floor),
            "{:?}",
            q.decode(s.shadow[0][1])
        );
        assert!(near(q.decode(s.shadow[1][1]), Vec3::new(3.0, 2.0, 1.0)));
    }
}
