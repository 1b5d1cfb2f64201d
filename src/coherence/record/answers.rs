//! What a retraced block keeps of its last trace: every query with its answer, and the
//! value of every camera ray's sample; and how a sample whose every answer holds again is
//! given back without shading it (the same answers, the same shapes and lights, the same
//! random stream: the same value).

use super::{bump, same_ray, RecordingAccel, UNSYNCED};
use crate::accel::Hit;
use crate::coherence::grid::ActiveVoxels;
use crate::coherence::segments::BlockSegments;
use crate::math::{Ray, Rgb, Rng};
use crate::transport::{Context, Integrator, RayStats, Sample};
use std::sync::atomic::Ordering;

/// A query and its answer, as recorded: `shape` is the fingerprint of the shape hit
/// (`FrameSummary::keys`), which must still be at that index for the hit to be reused.
/// For a shadow ray, `hit` is its nearest blocker, if it looked for one.
#[derive(Clone, Copy, Debug)]
pub struct Query {
    pub(super) ray: Ray,
    pub(super) hit: Option<Hit>,
    pub(super) shape: u64,
    pub(super) kind: Kind,
}

/// Which query a [`Query`] answered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    /// A camera ray's closest hit.
    Camera,
    /// Another ray's closest hit.
    Surface,
    /// A shadow ray, blocked or not.
    Blocked,
    Clear,
}

/// The value of a camera ray's sample in a block's last trace, and the rays its tree
/// traced: `at` is the camera ray's query in the block's list. When every query of that
/// tree holds again, the sample is the same (section 3.3.3 taken to the shading: the same
/// answers, the same shape data and lights, the same random stream) and is not shaded
/// again.
#[derive(Clone, Copy, Debug)]
pub struct Shaded {
    pub(super) at: u32,
    object: u32,
    radiance: Rgb,
    closest: u32,
    shadow: u32,
}

/// What a recorder's task recorded.
#[derive(Clone, Debug, Default)]
pub struct Recorded {
    /// Segment records (empty with tables).
    pub segments: BlockSegments,
    /// The queries and their answers, in the order traced.
    pub camera: Vec<Query>,
    /// The samples of the camera rays among them (in the same order).
    pub shaded: Vec<Shaded>,
    /// Whether any ray found a surface.
    pub hit: bool,
    /// Camera rays answered from an earlier hit, and camera rays.
    pub camera_reused: u64,
    pub camera_rays: u64,
    /// Other queries (reflection, refraction, shadow rays) answered from an earlier trace.
    pub others_reused: u64,
    /// Samples not shaded again (their trees' answers all held).
    pub samples_reused: u64,
    /// The point lights the shadow rays went to: bit `i` for the scene's light `i`, the top
    /// bit for every light from 63 on.
    pub lights: u64,
}

impl Recorded {
    pub(super) const fn new() -> Recorded {
        Recorded {
            segments: BlockSegments::new(),
            camera: Vec::new(),
            shaded: Vec::new(),
            hit: false,
            camera_reused: 0,
            camera_rays: 0,
            others_reused: 0,
            samples_reused: 0,
            lights: 0,
        }
    }

    pub(super) fn clear(&mut self) {
        self.segments.clear();
        self.camera.clear();
        self.shaded.clear();
    }

    /// The lists (segments sealed), shrunk to their length; in their place, empty lists
    /// with room for a quarter more than these held (the next task's blocks are alike).
    pub(super) fn take(&mut self) -> Recorded {
        let room = |n: usize| n + n / 4;
        let next = Recorded {
            segments: BlockSegments::with_room_of(&self.segments),
            camera: Vec::with_capacity(room(self.camera.len())),
            shaded: Vec::with_capacity(room(self.shaded.len())),
            ..Recorded::new()
        };
        let mut taken = std::mem::replace(self, next);
        taken.segments.seal();
        taken.segments.shrink_to_fit();
        taken.camera.shrink_to_fit();
        taken.shaded.shrink_to_fit();
        taken
    }

    /// Appends `other`'s lists (its samples' queries moved past this one's).
    pub fn append(&mut self, other: Recorded) {
        let offset = self.camera.len() as u32;
        self.segments.append(other.segments);
        self.camera.extend_from_slice(&other.camera);
        (self.shaded).extend(other.shaded.iter().map(|s| Shaded {
            at: s.at + offset,
            ..*s
        }));
    }
}

/// How a retraced block's rays may reuse the answers of its last trace.
pub struct Reuse<'a> {
    /// The block's queries of its last trace, in the order traced.
    pub previous: &'a [Query],
    /// The samples of its camera rays, and whether they may be reused (no light changed).
    pub shaded: &'a [Shaded],
    pub shading: bool,
    /// The voxels where a surface changed in this frame.
    pub changed: &'a ActiveVoxels,
}

impl RecordingAccel<'_> {
    /// The sample of camera ray `ray` in the block's last trace, with the rays its tree
    /// traced, if every query of that tree holds in this frame: its queries are then
    /// recorded and kept again as if traced, and the sample is not shaded.
    fn sample_of(&self, ray: &Ray) -> Option<(Sample, RayStats)> {
        let reuse = self.reuse.as_ref().filter(|r| r.shading)?;
        let j = self.find_camera(ray)?;
        let k = *self.samples.get(j).filter(|&&k| k != u32::MAX)?;
        let tree = self.tree_of(j);
        if !reuse.previous[tree.clone()].iter().all(|q| self.holds(q)) {
            return None;
        }
        self.sync_camera(j);
        self.tree.store(UNSYNCED, Ordering::Relaxed);
        self.replay(&reuse.previous[tree]);
        let s = reuse.shaded[k as usize];
        self.keep_shaded(ray, s.object, s.radiance, s.closest, s.shadow);
        bump(&self.samples_reused);
        let rays = RayStats {
            closest: s.closest as u64,
            shadow: s.shadow as u64,
        };
        let sample = Sample {
            radiance: s.radiance,
            object: s.object,
        };
        Some((sample, rays))
    }

    /// Keeps the sample of the last camera ray kept (`ray`), with the rays its tree traced.
    fn keep_shaded(&self, ray: &Ray, object: u32, radiance: Rgb, closest: u32, shadow: u32) {
        let at = self.last_camera.swap(usize::MAX, Ordering::Relaxed);
        if at == usize::MAX {
            return;
        }
        self.with_lists(|list| {
            if list.camera.get(at).is_some_and(|q| same_ray(&q.ray, ray)) {
                list.shaded.push(Shaded {
                    at: at as u32,
                    object,
                    radiance,
                    closest,
                    shadow,
                });
            }
        });
    }

    /// Records and keeps the queries of a stored tree whose every answer holds, as tracing
    /// them would (without their queries to the backend).
    fn replay(&self, tree: &[Query]) {
        for q in tree {
            let ray = &q.ray;
            match q.kind {
                Kind::Camera => {
                    bump(&self.camera_rays);
                    bump(&self.camera_reused);
                    self.keep_camera(ray, q.hit);
                }
                Kind::Surface => {
                    bump(&self.others_reused);
                    self.record_surface(ray, q.hit);
                }
                Kind::Blocked | Kind::Clear => {
                    bump(&self.others_reused);
                    self.record_occlusion(ray, q.kind == Kind::Blocked, Some(q.hit));
                    // (The integrator's query of the nearest blocker that follows.)
                    if q.hit.is_some() {
                        self.hit.store(true, Ordering::Relaxed);
                    }
                }
            }
        }
        self.with_lists(|list| {
            let at = list.camera.len();
            list.camera.extend_from_slice(tree);
            self.last_camera.store(at, Ordering::Relaxed);
        });
    }
}

impl RecordingAccel<'_> {
    /// Whether the recorder keeps camera samples ([`Replaying`] asks it for them).
    pub(in crate::coherence) fn keeps_samples(&self) -> bool {
        self.shape_keys.is_some()
    }
}

/// A block's integrator over its recorder, which keeps samples: a camera sample whose
/// every query holds is given back from the block's last trace instead of being shaded
/// again; the others are shaded by `inner` and kept for the next frame. The sample is the
/// same either way (same answers, shapes, lights and random stream), so frames stay
/// bit-identical.
pub(in crate::coherence) struct Replaying<'a> {
    pub inner: &'a dyn Integrator,
    pub recorder: &'a RecordingAccel<'a>,
}

impl Integrator for Replaying<'_> {
    fn radiance(&self, ctx: &Context, ray: &Ray, rng: &mut Rng, stats: &mut RayStats) -> Sample {
        if let Some((sample, rays)) = self.recorder.sample_of(ray) {
            stats.add(&rays);
            return sample;
        }
        let before = *stats;
        let sample = self.inner.radiance(ctx, ray, rng, stats);
        let count = |n: u64| n.min(u32::MAX as u64) as u32;
        let closest = count(stats.closest - before.closest);
        let shadow = count(stats.shadow - before.shadow);
        (self.recorder).keep_shaded(ray, sample.object, sample.radiance, closest, shadow);
        sample
    }
}
