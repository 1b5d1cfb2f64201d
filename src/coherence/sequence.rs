//! Rendering a keyframed sequence with a still camera: every frame through the coherent
//! renderer (or from scratch, or both to verify them against each other), with the
//! statistics of Table 2 of Jevans's paper. The caller gets each frame as it is finished, to
//! write or show it.

use super::changes::{Aabb, Changes, FrameSummary};
use super::grid::Grid;
use super::record::Records;
use super::renderer::{CoherentRenderer, Engine, FrameStats};
use super::tables::BlockLayout;
use crate::accel::{self, DynamicAccel, Update};
use crate::control::Control;
use crate::error::{Error, Result};
use crate::image::Image;
use crate::integrators::path::{PathOptions, PathTracer};
use crate::integrators::whitted::{Whitted, WhittedOptions};
use crate::job::{Job, MonteCarloSettings, Technique, TechniqueKind};
use crate::math::Vec3;
use crate::render::pixels::PixelView;
use crate::render::PixelSampling;
use crate::scene::animation::Animation;
use crate::scene::{Light, Scene};
use crate::transport::{Context, RayStats};
use std::time::Instant;

/// Whether the coherence engine renders a technique: Whitted's and the path tracer (whose
/// samples splat nothing, so that a block of pixels renders alone). Others render a keyframed
/// scene's frames one at a time through [`crate::Renderer`].
pub fn animates(kind: TechniqueKind) -> bool {
    matches!(kind, TechniqueKind::Whitted | TechniqueKind::Path)
}

/// How the frames are made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SequenceMode {
    /// Coherently: frame k retraces only what changed since frame k - 1.
    Coherent,
    /// Every frame from scratch (the traditional frame-by-frame method).
    Full,
    /// Both, each coherent frame checked bit for bit against its full render.
    Verify,
}

/// The coherence engine's own settings. What each frame is rendered with (technique, size,
/// seed, threads, backend) is the [`Job`]'s, as for any render.
#[derive(Clone, Debug, PartialEq)]
pub struct Coherence {
    pub mode: SequenceMode,
    pub records: Records,
    /// Approximate number of voxels of the grid.
    pub voxels: u32,
    /// Pixel blocks of the tables, columns by rows.
    pub blocks: (u32, u32),
    /// Render the first frame this many times both ways first, for the frame-0 overhead.
    pub overhead_reps: u32,
    /// Where the grid goes: online (frame by frame) or foreseen from every frame.
    pub placement: Placement,
}

impl Default for Coherence {
    /// Coherent, online, segment records with their default voxels, 16x16 blocks.
    fn default() -> Coherence {
        Coherence {
            mode: SequenceMode::Coherent,
            records: Records::Segments,
            voxels: Placement::Online.default_voxels(Records::Segments),
            blocks: (16, 16),
            overhead_reps: 0,
            placement: Placement::Online,
        }
    }
}

/// The integrator of a sequence, with the settings of its pixels.
pub(crate) enum Integrators {
    Whitted(Whitted, PixelSampling),
    Path(PathTracer, MonteCarloSettings),
}

impl Integrators {
    /// What renders `job`'s frames; an error for a technique the engine does not render, or
    /// a job it cannot follow (a part of the image, a time limit).
    pub(crate) fn for_job(job: &Job) -> Result<Integrators> {
        job.validate()?;
        if job.region.is_some() {
            return Err(Error::setting(
                "region",
                "does not apply to an animation: its frames are rendered whole",
            ));
        }
        match &job.technique {
            Technique::Whitted(w) => Ok(Integrators::Whitted(
                Whitted::new(WhittedOptions {
                    max_depth: w.max_depth,
                    area_samples: w.area_samples,
                    fresnel: w.fresnel,
                    ..WhittedOptions::default()
                }),
                w.sampling,
            )),
            Technique::Path(mc) if mc.time_limit.is_some() => Err(Error::setting(
                "time_limit",
                "cannot be used for an animation: every frame takes the same samples",
            )),
            Technique::Path(mc) if mc.adaptive.is_some() => Err(Error::setting(
                "adaptive_threshold",
                "cannot be used for an animation: every frame takes the same samples",
            )),
            Technique::Path(mc) if mc.guiding => Err(Error::setting(
                "guiding",
                "cannot be used for an animation: frames reuse unchanged pixels, which \
                 must not depend on a guide learned from the others",
            )),
            Technique::Path(mc) => Ok(Integrators::Path(
                PathTracer::new(PathOptions {
                    max_depth: mc.max_depth,
                }),
                *mc,
            )),
            other => Err(Error::setting(
                "integrator",
                format!(
                    "must be whitted or path for an animation, not \"{}\"",
                    other.kind()
                ),
            )),
        }
    }

    /// The engine rendering `job`'s view with these integrators.
    pub(crate) fn engine(&self, job: &Job) -> Engine<'_> {
        match self {
            Integrators::Whitted(integrator, sampling) => Engine::Whitted {
                integrator,
                view: PixelView {
                    view: job.view(),
                    sampling: *sampling,
                },
            },
            Integrators::Path(integrator, mc) => Engine::MonteCarlo {
                integrator,
                options: job.view().progressive(&MonteCarloSettings {
                    // Unchanged blocks are copied: a pixel must depend on its own samples.
                    reconstruction: crate::image::filter::Reconstruction::Importance,
                    adaptive: None,
                    max_component_value: None,
                    ..*mc
                }),
            },
        }
    }
}

/// Where the voxel grid goes and which voxels keep records.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Placement {
    /// Frame by frame, with no knowledge of the future (Jevans's method): the grid covers the
    /// first frame's scene and grows when something leaves it (that frame is traced in
    /// full), and every voxel keeps records. What an editor or a simulation feeding frames
    /// one at a time gets from [`Sequence`].
    #[default]
    Online,
    /// Every frame read first: the grid covers only the boxes that later frames change, and
    /// a voxel keeps records only until the last frame that changes it.
    Lookahead,
}

impl Placement {
    /// The voxels a grid gets unless told: an online grid spans the whole scene, where a
    /// look-ahead grid spans only the region where things change, so with segment records
    /// it takes 8 times as many for voxels as small around the moving objects (measured on
    /// scenes/anim-audition.toml: 32.5% of the pixels retraced instead of 41.8%, with the
    /// same ratio of CPU time to rays). A segment record costs the same however many voxels
    /// there are; only the walks through the changed voxels take more steps. Voxel tables
    /// walk every recorded ray through the grid, and keep 8192.
    pub fn default_voxels(self, records: Records) -> u32 {
        match (self, records) {
            (Placement::Online, Records::Segments) => 65536,
            _ => 8192,
        }
    }
}

/// The grid an online sequence starts with: over the scene's shapes and point lights.
pub(crate) fn online_grid(scene: &Scene, voxels: u32) -> Grid {
    CoherentRenderer::grid_around(&extent(scene), voxels)
}

/// The grid a look-ahead sequence uses: over the boxes that the frame-to-frame `changes`
/// mark (a change with no extent, a light's intensity, marks no box).
pub(crate) fn lookahead_grid(changes: &[Changes], voxels: u32) -> Grid {
    let boxes: Vec<Aabb> = changes
        .iter()
        .flat_map(|c| c.objects.iter().chain(&c.shadows))
        .copied()
        .collect();
    CoherentRenderer::grid_around(&boxes, voxels)
}

/// The boxes of a scene that an online grid must hold: its shapes' bounds and its point
/// lights (whose shadow segments end there).
fn extent(scene: &Scene) -> Vec<Aabb> {
    let mut boxes: Vec<Aabb> = scene.bounds().into_iter().collect();
    for l in &scene.lights {
        if let Light::Point(l) = l {
            boxes.push((l.position, l.position));
        }
    }
    boxes
}

/// Whether `grid` holds every box of `boxes`.
fn holds(grid: &Grid, boxes: &[Aabb]) -> bool {
    boxes
        .iter()
        .all(|(lo, hi)| lo.cmpge(grid.lo).all() && hi.cmple(grid.hi).all())
}

/// A grid over `grid`'s box and `boxes`, a quarter larger on every side, so that an object
/// moving steadily out of the scene makes it grow a few times rather than every frame.
fn grown(grid: &Grid, boxes: &[Aabb], voxels: u32) -> Grid {
    let mut all = boxes.to_vec();
    all.push((grid.lo, grid.hi));
    let tight = CoherentRenderer::grid_around(&all, voxels);
    let pad = 0.25 * (tight.hi - tight.lo);
    CoherentRenderer::grid_around(&[(tight.lo - pad, tight.hi + pad)], voxels)
}

/// A coherent sequence made one frame at a time: [`next`](Self::next) takes the next
/// frame's scene and returns its image, traced only where something changed since the
/// frame before. Frame k is made from frames up to k alone; an editor or a simulation can
/// drive it with scenes as they come. [`render_frames`] drives it from an animation.
pub struct Sequence {
    job: Job,
    coherence: Coherence,
    integrators: Integrators,
    layout: BlockLayout,
    coherent: Option<CoherentRenderer>,
    dynamic: Option<Box<dyn DynamicAccel>>,
    /// With [`Placement::Lookahead`]: the grid and, per voxel, the last position in the
    /// sequence that changes it, foreseen.
    foreseen: Option<(Grid, Vec<u32>)>,
    full_notice: bool,
    /// The most the records held after a frame: bytes, segments, bytes of stored answers.
    peaks: (usize, usize, usize),
    /// How many times the grid grew to hold the scene.
    regrids: usize,
}

impl Sequence {
    /// A sequence rendering frames as `job` says, with `coherence`'s records and grid (its
    /// `mode` and `overhead_reps` are the driver's: [`next`](Self::next) renders whatever it
    /// is given, coherently).
    pub fn new(job: &Job, coherence: &Coherence) -> Result<Sequence> {
        let voxels = coherence.voxels;
        if voxels == 0 || voxels > 1 << 24 {
            return Err(Error::setting(
                "voxels",
                format!("must be between 1 and {}, got {voxels}", 1 << 24),
            ));
        }
        let (cols, rows) = coherence.blocks;
        if !(1..=65536).contains(&cols) || !(1..=65536).contains(&rows) {
            return Err(Error::setting(
                "blocks",
                format!("must be 1 to 65536 each way, got {cols}x{rows}"),
            ));
        }
        Ok(Sequence {
            integrators: Integrators::for_job(job)?,
            layout: BlockLayout::new(job.width, job.height, cols, rows),
            job: job.clone(),
            coherence: coherence.clone(),
            coherent: None,
            dynamic: None,
            foreseen: None,
            full_notice: false,
            peaks: (0, 0, 0),
            regrids: 0,
        })
    }

    /// Look-ahead: places the grid over what `changes` (frame k to k + 1, for the whole
    /// sequence) mark and keeps records only where a later frame changes something. Before
    /// the first frame.
    pub(crate) fn foresee(&mut self, changes: &[Changes]) {
        let grid = lookahead_grid(changes, self.coherence.voxels);
        let probe =
            CoherentRenderer::with_records(grid.clone(), self.layout, self.coherence.records);
        let marked: Vec<Vec<Aabb>> = changes.iter().map(|c| probe.surface_boxes(c)).collect();
        // Worked out here, with the reading, not in the first frame's time.
        let last = CoherentRenderer::last_changes(&grid, &marked);
        self.foreseen = Some((grid, last));
    }

    /// The renderer of a sequence starting at `scene`.
    fn start(&self, scene: &Scene, control: &Control) -> CoherentRenderer {
        let grid = match &self.foreseen {
            Some((grid, _)) => grid.clone(),
            None => online_grid(scene, self.coherence.voxels),
        };
        self.renderer(grid, control)
    }

    fn renderer(&self, grid: Grid, control: &Control) -> CoherentRenderer {
        let mut r = CoherentRenderer::with_records(grid, self.layout, self.coherence.records);
        r.set_segment_budget((control.budget.limit() / 4).min(usize::MAX as u64) as usize);
        if let Some((_, last)) = &self.foreseen {
            r.restrict_to_last_changes(last.clone());
        }
        r
    }

    /// `scene` rendered from scratch, as a frame-by-frame renderer does (with a static
    /// intersection structure of its own): the image, its rays and its time.
    fn render_full(&self, scene: &Scene, control: &Control) -> Result<(Image, RayStats, Time)> {
        let clock = Clock::start();
        let accel = accel::build(scene, self.job.accel, control)?;
        let engine = self.integrators.engine(&self.job);
        let (image, rays) = engine.render_full(
            &Context::with_light_selection(scene, accel.as_ref(), super::LIGHT_SELECTION),
            control,
        )?;
        Ok((image, rays, clock.elapsed()))
    }

    /// The CPU seconds of the first frame `scene` rendered coherently (recording) and in
    /// full, `reps` times alternating which goes first: the frame-0 overhead. Before
    /// the first [`next`](Self::next).
    pub(crate) fn first_frame_overhead(
        &mut self,
        scene: &Scene,
        reps: u32,
        control: &Control,
    ) -> Result<Vec<(f64, f64)>> {
        let engine = self.integrators.engine(&self.job);
        let mut coherent = self.start(scene, control);
        let mut overhead = Vec::new();
        for rep in 0..reps {
            let full = || -> Result<f64> { Ok(self.render_full(scene, control)?.2.cpu) };
            let mut recorded = || -> Result<f64> {
                coherent.reset();
                let clock = Clock::start();
                let accel = accel::build_dynamic(scene, self.job.accel, control)?;
                coherent.render_frame(scene, accel.as_ref(), &engine, control)?;
                Ok(clock.elapsed().cpu)
            };
            // Alternating the order evens out whatever the first of a pair pays for.
            overhead.push(if rep % 2 == 0 {
                let f = full()?;
                (recorded()?, f)
            } else {
                let c = recorded()?;
                (c, full()?)
            });
        }
        Ok(overhead)
    }

    /// Renders the next frame, `scene` (numbered `frame` in the statistics), from what the
    /// frames before it recorded; with `verify`, renders it in full too and compares them
    /// bit for bit. Notices (a frame traced in full, records cut down, the grid grown) go
    /// to `control`'s progress; the renders inside report nothing.
    pub fn next(
        &mut self,
        frame: i64,
        scene: &Scene,
        control: &Control,
        verify: bool,
    ) -> Result<(Image, FrameRow)> {
        if !scene.media.is_empty() {
            return Err(Error::input(
                &scene.source,
                "the scene has participating media, which animations do not render: render \
                 its frames one at a time with `raylink render`",
            ));
        }
        let outer = control;
        let control = &outer.silenced();
        let (width, height) = (self.job.width, self.job.height);
        let mut row = FrameRow {
            frame,
            ..FrameRow::default()
        };
        // The coherent renderer updates one structure from frame to frame; the full renders
        // build their own, as a frame-by-frame renderer does.
        let clock = Clock::start();
        let mut coherent = match self.coherent.take() {
            None => self.start(scene, control),
            Some(c) if self.foreseen.is_some() || holds(&c.grid, &extent(scene)) => c,
            Some(c) => {
                // Something left the grid: records outside it cannot exist, so the grid grows
                // and this frame is traced in full (section 3.3.2 re-subdivides in place).
                let grid = grown(&c.grid, &extent(scene), self.coherence.voxels);
                self.regrids += 1;
                outer.note(&format!(
                    "notice: frame {frame}: the scene left the voxel grid; the grid grows to \
                     [{:.2},{:.2},{:.2}]..[{:.2},{:.2},{:.2}] and this frame is traced in full",
                    grid.lo.x, grid.lo.y, grid.lo.z, grid.hi.x, grid.hi.y, grid.hi.z
                ));
                self.renderer(grid, control)
            }
        };
        match self.dynamic.as_mut() {
            None => self.dynamic = Some(accel::build_dynamic(scene, self.job.accel, control)?),
            Some(d) => {
                scene.check_extent()?;
                row.update = Some(d.update(scene)?)
            }
        }
        let accel = self.dynamic.as_deref().expect("built above");
        let engine = self.integrators.engine(&self.job);
        let before = (coherent.records(), coherent.keeps_camera_hits());
        let rendered = coherent.render_frame(scene, accel, &engine, control);
        let (image, stats) = match rendered {
            Ok(r) => r,
            Err(e) => {
                // A cancelled frame resets the records; the next frame starts afresh.
                self.coherent = Some(coherent);
                return Err(e);
            }
        };
        if before != (coherent.records(), coherent.keeps_camera_hits()) {
            outer.note(&format!(
                "notice: frame {frame}: the records grew past a quarter of the memory budget; \
                 going on with voxel tables and without keeping stored answers (same frames)"
            ));
        }
        let p = &mut self.peaks;
        p.0 = p.0.max(coherent.record_bytes());
        p.1 = p.1.max(coherent.segments());
        p.2 = p.2.max(coherent.camera_bytes());
        row.time = clock.elapsed();
        if !self.full_notice {
            // (A sequence's first frame, and the first after the grid grew, are traced in
            // full as a matter of course.)
            if let Some(reason) = stats.full_reason.as_deref().filter(|r| *r != "first frame") {
                outer.note(&format!(
                    "notice: frame {frame}: every pixel retraced ({reason}); such frames are \
                     rendered in full"
                ));
                self.full_notice = true;
            }
        }
        row.coherent = stats;
        if verify {
            let (full, rays, time) = self.render_full(scene, control)?;
            row.full = Some((rays, time));
            row.identical = Some(
                (full.width, full.height) == (width, height)
                    && full.pixels.len() == image.pixels.len()
                    && full.pixels.iter().zip(&image.pixels).all(|(a, b)| {
                        a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)
                    }),
            );
        }
        self.coherent = Some(coherent);
        Ok((image, row))
    }

    /// The statistics of the sequence so far, around its `rows`.
    pub fn report(&self, rows: Vec<FrameRow>, prepare: Time) -> Report {
        let grid = self.coherent.as_ref().map(|c| &c.grid);
        Report {
            rows,
            pixels_per_frame: self.job.width as u64 * self.job.height as u64,
            records: self
                .coherent
                .as_ref()
                .map_or(self.coherence.records, |c| c.records()),
            record_bytes: self.peaks.0,
            segments: self.peaks.1,
            camera_bytes: self.peaks.2,
            voxels: grid.map_or(0, |g| g.len()),
            active_voxels: self.coherent.as_ref().map_or(0, |c| c.active_voxels()),
            blocks: (self.layout.cols, self.layout.rows),
            prepare,
            grid: grid.map_or((Vec3::ZERO, Vec3::ZERO), |g| (g.lo, g.hi)),
            overhead: Vec::new(),
            placement: if self.foreseen.is_some() {
                Placement::Lookahead
            } else {
                Placement::Online
            },
            regrids: self.regrids,
        }
    }
}

/// Renders frames `frames` of `anim` (consecutive numbers) as `job` says, with
/// `coherence`'s engine, handing each finished frame to `on_frame` (to write or show it);
/// returns the statistics. The job is the one a still render takes (its technique, size,
/// seed, threads and backend); the technique must be one the engine [`animates`]. Online
/// (the default placement), each frame is read only when it is rendered. A cancel stops
/// after the frame in hand with [`Error::Cancelled`] naming the next frame; the frames
/// handed over are whole.
pub fn render_frames(
    anim: &Animation,
    job: &Job,
    frames: &[i64],
    coherence: &Coherence,
    control: &Control,
    on_frame: &mut dyn FnMut(i64, &Image, &FrameRow) -> Result<()>,
) -> Result<Report> {
    if frames.is_empty() {
        return Err(Error::setting("frames", "is empty"));
    }
    let mut sequence = Sequence::new(job, coherence)?;
    let quiet = control.silenced();
    let scene0 = anim.scene_at(frames[0])?;
    // Records of what each ray met hold for one time: moving shapes stay at shutter open.
    if scene0.moves() {
        control.warn(&crate::scene::motion::still_warning("animation renderer"));
    }
    let scene0 = scene0.into_shutter_open();
    let prepare = Clock::start();
    if coherence.placement == Placement::Lookahead && coherence.mode != SequenceMode::Full {
        // Reads every frame once first, to place the grid where things will change.
        let mut changes = Vec::new();
        let mut previous = FrameSummary::new(&scene0, None);
        for &f in &frames[1..] {
            quiet.cancel.check(&format!("reading frame {f}"))?;
            let next = FrameSummary::new(&anim.scene_at(f)?.into_shutter_open(), None);
            changes.push(previous.diff(&next));
            previous = next;
        }
        sequence.foresee(&changes);
    }
    let prepare = prepare.elapsed();
    let overhead = if coherence.mode == SequenceMode::Full {
        Vec::new()
    } else {
        sequence.first_frame_overhead(&scene0, coherence.overhead_reps, &quiet)?
    };
    let mut rows = Vec::new();
    let progress = control.phase("frames", Some(frames.len() as u64), "frames");
    let mut scene0 = Some(scene0);
    for &f in frames {
        control.cancel.check(&format!("frame {f}"))?;
        let scene = match scene0.take() {
            Some(s) => s,
            None => anim.scene_at(f)?.into_shutter_open(),
        };
        let (image, row) = if coherence.mode == SequenceMode::Full {
            let (img, rays, time) = sequence.render_full(&scene, &quiet)?;
            let row = FrameRow {
                frame: f,
                full: Some((rays, time)),
                ..FrameRow::default()
            };
            (img, row)
        } else {
            sequence.next(f, &scene, control, coherence.mode == SequenceMode::Verify)?
        };
        on_frame(f, &image, &row)?;
        progress.advance(1);
        rows.push(row);
    }
    progress.end(&format!("{} frames", rows.len()));
    let mut report = sequence.report(rows, prepare);
    report.overhead = overhead;
    Ok(report)
}

/// One row of the statistics.
#[derive(Clone, Debug, Default)]
pub struct FrameRow {
    pub frame: i64,
    pub coherent: FrameStats,
    /// The coherent frame's time, with the update of the intersection structure.
    pub time: Time,
    /// The full render's rays and time, with its build (with --verify or --no-coherence).
    pub full: Option<(RayStats, Time)>,
    pub identical: Option<bool>,
    /// How the coherent renderer's intersection structure followed the scene.
    pub update: Option<Update>,
}

/// Wall-clock and CPU seconds (all threads of the process).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Time {
    pub wall: f64,
    pub cpu: f64,
}

struct Clock {
    wall: Instant,
    cpu: f64,
}

impl Clock {
    fn start() -> Clock {
        Clock {
            wall: Instant::now(),
            cpu: crate::platform::cpu_seconds(),
        }
    }

    fn elapsed(&self) -> Time {
        Time {
            wall: self.wall.elapsed().as_secs_f64(),
            cpu: crate::platform::cpu_seconds() - self.cpu,
        }
    }
}

/// What a run did, for the summary.
pub struct Report {
    pub rows: Vec<FrameRow>,
    pub pixels_per_frame: u64,
    pub records: Records,
    /// The most memory the records took after a frame.
    pub record_bytes: usize,
    /// The most segments held after a frame (segment records).
    pub segments: usize,
    /// The most memory the stored answers took after a frame.
    pub camera_bytes: usize,
    pub voxels: usize,
    /// Voxels where a change can happen (the only ones recorded).
    pub active_voxels: usize,
    pub blocks: (u32, u32),
    /// The time spent reading every frame to place the grid before frame 0 (look-ahead):
    /// part of the sequence's cost.
    pub prepare: Time,
    /// The grid's box.
    pub grid: (crate::math::Vec3, crate::math::Vec3),
    /// `--overhead-reps`: CPU seconds of the first frame rendered coherently and in full,
    /// per repeat.
    pub overhead: Vec<(f64, f64)>,
    /// How the grid was placed.
    pub placement: Placement,
    /// How many times an online grid grew to hold the scene.
    pub regrids: usize,
}
