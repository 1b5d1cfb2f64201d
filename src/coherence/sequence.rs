//! Rendering a keyframed sequence with a still camera: every frame through the coherent
//! renderer (or from scratch, or both to verify them against each other), with the
//! statistics of Table 2 of Jevans's paper. The caller gets each frame as it is finished, to
//! write or show it.

use super::changes::FrameSummary;
use super::record::Records;
use super::renderer::{CoherentRenderer, Engine, FrameStats};
use super::tables::BlockLayout;
use crate::accel::{self, Backend, DynamicAccel, Update};
use crate::control::Control;
use crate::image::Image;
use crate::integrators::path::{PathOptions, PathTracer};
use crate::integrators::technique::{MonteCarloSettings, WhittedSettings};
use crate::integrators::whitted::{Whitted, WhittedOptions};
use crate::integrators::{Context, RayStats};
use crate::render::pixels::PixelView;
use crate::render::progressive::ProgressiveOptions;
use crate::scene::animation::Animation;
use crate::{Error, Result};
use std::time::Instant;

/// The techniques a sequence renders with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SequenceTechnique {
    Whitted(WhittedSettings),
    /// The path tracer (whose samples splat nothing, so that blocks render alone).
    Path(MonteCarloSettings),
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

/// A sequence to render.
#[derive(Clone, Debug, PartialEq)]
pub struct SequenceJob {
    pub technique: SequenceTechnique,
    pub width: u32,
    pub height: u32,
    pub seed: u64,
    pub threads: Option<usize>,
    pub accel: Backend,
    /// The frames, in the scene's numbers (consecutive); the first is traced in full.
    pub frames: Vec<i64>,
    pub mode: SequenceMode,
    pub records: Records,
    /// Approximate number of voxels of the grid.
    pub voxels: u32,
    /// Pixel blocks of the tables, columns by rows.
    pub blocks: (u32, u32),
    /// Render the first frame this many times both ways first, for the frame-0 overhead.
    pub overhead_reps: u32,
}

/// The integrator of a sequence.
enum Integrators {
    Whitted(Whitted),
    Path(PathTracer),
}

impl SequenceJob {
    fn integrators(&self) -> Integrators {
        match self.technique {
            SequenceTechnique::Whitted(w) => Integrators::Whitted(Whitted::new(WhittedOptions {
                max_depth: w.max_depth,
                area_samples: w.area_samples,
                fresnel: w.fresnel,
                ..WhittedOptions::default()
            })),
            SequenceTechnique::Path(mc) => Integrators::Path(PathTracer::new(PathOptions {
                max_depth: mc.max_depth,
            })),
        }
    }

    fn engine<'a>(&self, integrators: &'a Integrators) -> Engine<'a> {
        match (integrators, self.technique) {
            (Integrators::Whitted(w), SequenceTechnique::Whitted(s)) => Engine::Whitted {
                integrator: w,
                view: PixelView {
                    width: self.width,
                    height: self.height,
                    sampling: s.sampling,
                    threads: self.threads,
                    seed: self.seed,
                },
            },
            (Integrators::Path(p), SequenceTechnique::Path(mc)) => Engine::MonteCarlo {
                integrator: p,
                options: ProgressiveOptions {
                    width: self.width,
                    height: self.height,
                    spp: mc.spp,
                    time_limit: None,
                    threads: self.threads,
                    seed: self.seed,
                    filter: mc.filter,
                },
            },
            _ => unreachable!("the integrators are made from the same technique"),
        }
    }
}

/// Renders `job`'s frames of `anim`, handing each finished frame to `on_frame` (to write or
/// show it); returns the statistics. A cancel stops after the frame in hand with
/// [`Error::Cancelled`] naming the next frame; the frames handed over are whole.
pub fn render_sequence(
    anim: &Animation,
    job: &SequenceJob,
    control: &Control,
    on_frame: &mut dyn FnMut(i64, &Image, &FrameRow) -> Result<()>,
) -> Result<Report> {
    let frames = &job.frames;
    if frames.is_empty() {
        return Err(Error::setting("frames", "is empty"));
    }
    if job.voxels == 0 || job.voxels > 1 << 24 {
        return Err(Error::setting(
            "voxels",
            format!("must be between 1 and {}, got {}", 1 << 24, job.voxels),
        ));
    }
    let (width, height) = (job.width, job.height);
    // The frames are the caller's progress; the renders inside them report nothing.
    let outer = control;
    let control = &Control {
        progress: std::sync::Arc::new(crate::control::Silent),
        ..outer.clone()
    };
    let scene0 = anim.scene_at(frames[0])?;
    let integrators = job.integrators();
    let engine = job.engine(&integrators);
    // Voxels only need records where something will change: the grid covers the boxes that
    // the frame-to-frame changes mark (found by reading every frame once first), so its
    // resolution goes where it matters and rays crossing the still parts cost nothing.
    let prepare = Instant::now();
    let mut changes = Vec::new();
    let mut previous = FrameSummary::new(&scene0, None);
    for &f in &frames[1..] {
        let next = FrameSummary::new(&anim.scene_at(f)?, None);
        changes.push(previous.diff(&next));
        previous = next;
    }
    let boxes: Vec<_> = changes
        .iter()
        .flat_map(|c| c.objects.iter().chain(&c.shadows))
        .copied()
        .collect();
    let grid = CoherentRenderer::grid_around(&boxes, job.voxels);
    let layout = BlockLayout::new(width, height, job.blocks.0, job.blocks.1);
    let mut coherent = CoherentRenderer::with_records(grid, layout, job.records);
    coherent.set_segment_budget((control.budget.limit() / 4).min(usize::MAX as u64) as usize);
    // Records are kept only where a later frame changes something: in the voxels that the
    // changed objects' surfaces touch.
    let marked: Vec<Vec<_>> = changes.iter().map(|c| coherent.surface_boxes(c)).collect();
    coherent.restrict_to_sequence(&marked);
    drop((changes, marked));
    let prepare_seconds = prepare.elapsed().as_secs_f64();
    let mut overhead = Vec::new();
    for rep in 0..job.overhead_reps {
        let full = || -> Result<f64> {
            let clock = Clock::start();
            let accel = accel::build(&scene0, job.accel, control)?;
            engine.render_full(&Context::new(&scene0, accel.as_ref()), control)?;
            Ok(clock.elapsed().cpu)
        };
        let mut recorded = || -> Result<f64> {
            coherent.reset();
            let clock = Clock::start();
            let accel = accel::build_dynamic(&scene0, job.accel, control)?;
            coherent.render_frame(&scene0, accel.as_ref(), &engine, control)?;
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
    coherent.reset();
    let mut rows = Vec::new();
    let mut full_notice = false;
    let progress = outer.phase("frames", Some(frames.len() as u64), "frames");
    // The most the records held after a frame: bytes, segments, bytes of camera hits.
    let (mut peak_bytes, mut peak_segments, mut peak_camera) = (0, 0, 0);
    let mut dynamic: Option<Box<dyn DynamicAccel>> = None;
    for &f in frames {
        control.cancel.check(&format!("frame {f}"))?;
        let scene = if f == frames[0] {
            scene0.clone()
        } else {
            anim.scene_at(f)?
        };
        let mut row = FrameRow {
            frame: f,
            ..FrameRow::default()
        };
        let image: Image;
        if job.mode == SequenceMode::Full {
            let clock = Clock::start();
            let accel = accel::build(&scene, job.accel, control)?;
            let (img, rays) = engine.render_full(&Context::new(&scene, accel.as_ref()), control)?;
            row.full = Some((rays, clock.elapsed()));
            image = img;
        } else {
            // The coherent renderer updates one structure from frame to frame; the full
            // renders build their own, as a frame-by-frame renderer does.
            let clock = Clock::start();
            match dynamic.as_mut() {
                None => dynamic = Some(accel::build_dynamic(&scene, job.accel, control)?),
                Some(d) => row.update = Some(d.update(&scene)?),
            }
            let accel = dynamic.as_deref().expect("built above");
            let before = (coherent.records(), coherent.keeps_camera_hits());
            let (img, stats) = coherent.render_frame(&scene, accel, &engine, control)?;
            if before != (coherent.records(), coherent.keeps_camera_hits()) {
                outer.note(&format!(
                    "notice: frame {f}: the records grew past a quarter of the memory budget; \
                     going on with voxel tables and without keeping camera hits (same frames)"
                ));
            }
            peak_bytes = peak_bytes.max(coherent.record_bytes());
            peak_segments = peak_segments.max(coherent.segments());
            peak_camera = peak_camera.max(coherent.camera_bytes());
            row.time = clock.elapsed();
            if f != frames[0] && stats.full_reason.is_some() && !full_notice {
                outer.note(&format!(
                    "notice: frame {f}: every pixel retraced ({}); such frames are rendered in \
                     full",
                    stats.full_reason.as_deref().unwrap_or("")
                ));
                full_notice = true;
            }
            row.coherent = stats;
            if job.mode == SequenceMode::Verify {
                let clock = Clock::start();
                let accel = accel::build(&scene, job.accel, control)?;
                let (full, rays) =
                    engine.render_full(&Context::new(&scene, accel.as_ref()), control)?;
                row.full = Some((rays, clock.elapsed()));
                let same = full.pixels.len() == img.pixels.len()
                    && full.pixels.iter().zip(&img.pixels).all(|(a, b)| {
                        a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)
                    });
                row.identical = Some(same);
            }
            image = img;
        }
        on_frame(f, &image, &row)?;
        progress.advance(1);
        rows.push(row);
    }
    progress.end(&format!("{} frames", rows.len()));
    Ok(Report {
        rows,
        pixels_per_frame: width as u64 * height as u64,
        records: coherent.records(),
        record_bytes: peak_bytes,
        camera_bytes: peak_camera,
        segments: peak_segments,
        voxels: coherent.grid.len(),
        active_voxels: coherent.active_voxels(),
        blocks: (layout.cols, layout.rows),
        prepare_seconds,
        grid: (coherent.grid.lo, coherent.grid.hi),
        overhead,
    })
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
    /// The most memory the kept camera hits took after a frame.
    pub camera_bytes: usize,
    pub voxels: usize,
    /// Voxels where a change can happen (the only ones recorded).
    pub active_voxels: usize,
    pub blocks: (u32, u32),
    /// Seconds spent reading every frame to place the grid before frame 0.
    pub prepare_seconds: f64,
    /// The grid's box.
    pub grid: (crate::math::Vec3, crate::math::Vec3),
    /// `--overhead-reps`: CPU seconds of the first frame rendered coherently and in full,
    /// per repeat.
    pub overhead: Vec<(f64, f64)>,
}
