//! `raylink animate`: renders a keyframed scene's frames with object-space temporal coherence,
//! optionally checking every frame against a full render (`--verify`) and reporting what was
//! saved per frame (`--stats`, `--csv`), like Table 2 of the paper.

use super::changes::FrameSummary;
use super::record::Records;
use super::renderer::{CoherentRenderer, Engine, FrameStats};
use crate::accel::{self, Backend, DynamicAccel, Update};
use crate::image::output::{check_output_path, write_image, OutputOptions};
use crate::image::{Image, MetaValue, Metadata};
use crate::integrators::path::{PathOptions, PathTracer, DEFAULT_MAX_DEPTH, MAX_DEPTH_LIMIT};
use crate::integrators::whitted::{Whitted, WhittedOptions};
use crate::integrators::{Context, RayStats};
use crate::render::progressive::{ProgressiveOptions, MAX_SPP};
use crate::render::{PixelSampling, RenderOptions, DEFAULT_AA_DEPTH, DEFAULT_AA_THRESHOLD};
use crate::scene::animation::Animation;
use crate::scene::MAX_RESOLUTION;
use crate::{Error, Result};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

/// The integrators `animate` can render with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum AnimIntegrator {
    /// Whitted 1980 (adaptive or uniform supersampling).
    Whitted,
    /// Path tracing with next-event estimation.
    Path,
}

/// Options of `raylink animate`.
#[derive(Clone, Debug, clap::Args)]
pub struct AnimateArgs {
    /// The animated scene (.toml with an `[animation]` table and keyframes; docs/animation.md).
    pub scene: PathBuf,
    /// Output file pattern: `%d` or `%0Nd` is replaced by the frame number
    /// (e.g. frames/frame_%04d.exr); the extension picks the format.
    #[arg(short, long = "output", value_name = "PATTERN")]
    pub output: String,
    /// Light-transport technique (default: the scene's, else whitted).
    #[arg(long, value_enum)]
    pub integrator: Option<AnimIntegrator>,
    /// Intersection backend.
    #[arg(long, value_enum, default_value = "embree")]
    pub accel: Backend,
    /// Image width in pixels (default: the scene's).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height in pixels (default: the scene's).
    #[arg(long)]
    pub height: Option<u32>,
    /// Samples per pixel: path tracer (default: the scene's, else 16); Whitted: uniform
    /// supersampling with this square number of samples instead of adaptive anti-aliasing.
    #[arg(long)]
    pub spp: Option<u32>,
    /// Adaptive anti-aliasing (Whitted): largest corner difference accepted.
    #[arg(long, default_value_t = DEFAULT_AA_THRESHOLD)]
    pub aa_threshold: f32,
    /// Adaptive anti-aliasing (Whitted): deepest subdivision level.
    #[arg(long, default_value_t = DEFAULT_AA_DEPTH)]
    pub aa_depth: u32,
    /// Maximum ray-tree depth (Whitted) or bounces (path). Default: the scene's, else 8.
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Whitted: shadow rays per area light at each shading point.
    #[arg(long, default_value_t = 16)]
    pub area_samples: u32,
    /// Pixel blocks of the voxel bit tables, COLSxROWS (at most one block per pixel).
    #[arg(long, default_value = "16x16", value_name = "COLSxROWS")]
    pub block_table: String,
    /// How the records are kept: each block's ray segments, walked through the voxels that
    /// changed when a frame needs them (faster), or the paper's per-voxel bit tables filled
    /// by walking every segment as it is traced (less memory). Same frames, same blocks.
    #[arg(long, value_enum, default_value = "segments")]
    pub records: Records,
    /// Approximate number of voxels of the grid (over the region where the sequence changes).
    /// More voxels retrace fewer pixels but cost more per recorded ray.
    #[arg(long, default_value_t = 8192)]
    pub voxels: u32,
    /// Render only these frames of the sequence: A..B (both included), A.., ..B or A, in the
    /// scene's frame numbers (e.g. one render-farm job's share). Frame A is traced in full,
    /// the rest coherently; the frames equal those of the whole sequence bit for bit.
    #[arg(long, value_name = "A..B")]
    pub frames: Option<String>,
    /// Render every frame from scratch instead (the traditional frame-by-frame method).
    #[arg(long, conflicts_with = "verify")]
    pub no_coherence: bool,
    /// Also render every frame from scratch, check that the coherent frame is identical bit
    /// for bit, and report the full render's rays and time. Exits with 1 on a difference.
    #[arg(long)]
    pub verify: bool,
    /// Print per-frame statistics and a summary (rays, pixels retraced, time).
    #[arg(long)]
    pub stats: bool,
    /// Before the sequence, render its first frame N times both ways (coherently, recording,
    /// and from scratch, in alternating order) and report the median of the N ratios of
    /// their CPU times as the frame-0 overhead (with --stats): one frame's time is too short
    /// and too noisy to compare once.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub overhead_reps: u32,
    /// Write the per-frame statistics to this CSV file.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Refuse work that needs more memory than this (bytes, or with a K, M, G or T suffix);
    /// segment records that grow past a quarter of it become voxel tables. Default: 3/4 of
    /// the physical memory.
    #[arg(long, value_name = "SIZE")]
    pub max_memory: Option<String>,
    /// Worker threads (default: all cores). The images do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Seed of the random streams.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Store EXR pixels as half floats.
    #[arg(long)]
    pub half: bool,
    /// Exposure in stops for 8-bit outputs.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// No progress lines.
    #[arg(short, long)]
    pub quiet: bool,
}

/// The output file of frame `frame`: `%d` / `%0Nd` replaced by the number.
pub fn frame_path(pattern: &str, frame: i64) -> Result<PathBuf> {
    let bad = || {
        Error::Options(format!(
            "--output {pattern}: needs one frame number placeholder, %d or %0Nd (e.g. %04d)"
        ))
    };
    let start = pattern.find('%').ok_or_else(bad)?;
    let rest = &pattern[start + 1..];
    let end = rest.find('d').ok_or_else(bad)?;
    let spec = &rest[..end];
    let width: usize = if spec.is_empty() {
        0
    } else if spec.starts_with('0') && spec.chars().all(|c| c.is_ascii_digit()) {
        spec.parse().map_err(|_| bad())?
    } else {
        return Err(bad());
    };
    let tail = &rest[end + 1..];
    if tail.contains('%') {
        return Err(bad());
    }
    Ok(PathBuf::from(format!(
        "{}{frame:0width$}{tail}",
        &pattern[..start]
    )))
}

/// The frames of `all` (consecutive numbers) that `--frames spec` selects.
pub fn select_frames(spec: &str, all: std::ops::Range<i64>) -> Result<Vec<i64>> {
    let (first, last) = (all.start, all.end - 1);
    let bad = |why: String| Error::Options(format!("--frames {spec}: {why}"));
    let number = |s: &str, default: i64| -> Result<i64> {
        let s = s.trim();
        if s.is_empty() {
            return Ok(default);
        }
        s.parse().map_err(|_| {
            bad(format!(
                "\"{s}\" is not a frame number (expected A..B, A.., ..B or A)"
            ))
        })
    };
    let (a, b) = match spec.split_once("..") {
        Some((a, b)) => (number(a, first)?, number(b, last)?),
        None if !spec.trim().is_empty() => {
            let n = number(spec, first)?;
            (n, n)
        }
        None => return Err(bad("expected A..B, A.., ..B or A".into())),
    };
    if a > b {
        return Err(bad(format!("the range is empty ({a} > {b})")));
    }
    if a < first || b > last {
        return Err(bad(format!("the sequence has frames {first} to {last}")));
    }
    Ok((a..=b).collect())
}

fn parse_blocks(s: &str) -> Result<(u32, u32)> {
    let bad = || {
        Error::Options(format!(
            "--block-table {s}: expected COLSxROWS with 1 to 65536 blocks each way, e.g. 16x16"
        ))
    };
    let (c, r) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let c: u32 = c.trim().parse().map_err(|_| bad())?;
    let r: u32 = r.trim().parse().map_err(|_| bad())?;
    if !(1..=65536).contains(&c) || !(1..=65536).contains(&r) {
        return Err(bad());
    }
    Ok((c, r))
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
            cpu: crate::bench::cpu_seconds(),
        }
    }

    fn elapsed(&self) -> Time {
        Time {
            wall: self.wall.elapsed().as_secs_f64(),
            cpu: crate::bench::cpu_seconds() - self.cpu,
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

pub fn run(args: &AnimateArgs) -> Result<()> {
    // SIGINT/SIGTERM stop the sequence after the frame in hand (frames are whole files).
    crate::interrupt::install()?;
    let report = animate(args)?;
    if args.stats {
        print!("{}", summary(&report));
    }
    if let Some(csv) = &args.csv {
        crate::atomic_file::write(csv, csv_text(&report).as_bytes())?;
    }
    if let Some(r) = report.rows.iter().find(|r| r.identical == Some(false)) {
        return Err(Error::image(
            frame_path(&args.output, r.frame)?,
            "--verify: the coherent frame differs from its full render",
        ));
    }
    Ok(())
}

/// Renders the animation and writes the frames; returns the statistics.
pub fn animate(args: &AnimateArgs) -> Result<Report> {
    if args.threads == Some(0) {
        return Err(Error::Options("--threads must be at least 1".into()));
    }
    crate::memory::set_limit_option(args.max_memory.as_deref())?;
    let blocks = parse_blocks(&args.block_table)?;
    if args.voxels == 0 || args.voxels > 1 << 24 {
        return Err(Error::Options(format!(
            "--voxels must be between 1 and {}, got {}",
            1 << 24,
            args.voxels
        )));
    }
    if args.scene.extension().and_then(|e| e.to_str()) != Some("toml") {
        return Err(Error::input(
            &args.scene,
            "animations are read from native .toml scenes (see docs/animation.md)",
        ));
    }
    let anim = Animation::read(&args.scene)?;
    let frames: Vec<i64> = match &args.frames {
        Some(spec) => select_frames(spec, anim.frame_numbers())?,
        None => anim.frame_numbers().collect(),
    };
    let first_path = frame_path(&args.output, frames[0])?;
    if let Some(dir) = first_path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    check_output_path(&first_path).map_err(|e| Error::Options(e.to_string()))?;
    let scene0 = anim.scene_at(frames[0])?;
    for w in &scene0.warnings {
        eprintln!("warning: {w}");
    }
    let width = args.width.unwrap_or(scene0.camera.width);
    let height = args.height.unwrap_or(scene0.camera.height);
    for (name, v) in [("--width", width), ("--height", height)] {
        if !(1..=MAX_RESOLUTION).contains(&v) {
            return Err(Error::Options(format!(
                "{name} must be between 1 and {MAX_RESOLUTION}, got {v}"
            )));
        }
    }
    let integrator = match (args.integrator, scene0.settings.integrator.as_deref()) {
        (Some(i), _) => i,
        (None, None | Some("whitted")) => AnimIntegrator::Whitted,
        (None, Some("path")) => AnimIntegrator::Path,
        (None, Some(other)) => {
            return Err(Error::input(
                &args.scene,
                format!("animate renders with the whitted or path integrator, not \"{other}\""),
            ))
        }
    };
    let max_depth = args
        .max_depth
        .or(scene0.settings.max_depth)
        .unwrap_or(DEFAULT_MAX_DEPTH);
    if max_depth > MAX_DEPTH_LIMIT {
        return Err(Error::Options(format!(
            "--max-depth must be at most {MAX_DEPTH_LIMIT}, got {max_depth}"
        )));
    }
    let whitted = Whitted::new(WhittedOptions {
        max_depth: max_depth.max(1),
        area_samples: args.area_samples,
        ..WhittedOptions::default()
    });
    let path = PathTracer::new(PathOptions { max_depth });
    let engine = match integrator {
        AnimIntegrator::Whitted => {
            let sampling = match args.spp {
                None => PixelSampling::Adaptive {
                    threshold: args.aa_threshold,
                    max_depth: args.aa_depth,
                },
                Some(spp) => {
                    let n = (spp as f64).sqrt().round() as u32;
                    if spp == 0 || n * n != spp {
                        return Err(Error::Options(format!(
                            "--spp must be a square number for Whitted (1, 4, 9, ...), got {spp}"
                        )));
                    }
                    PixelSampling::Uniform { n }
                }
            };
            sampling.validate()?;
            Engine::Whitted {
                integrator: &whitted,
                options: RenderOptions {
                    width,
                    height,
                    sampling,
                    threads: args.threads,
                    seed: args.seed,
                    progress: false,
                },
            }
        }
        AnimIntegrator::Path => {
            let spp = args.spp.or(scene0.settings.spp).unwrap_or(16);
            if spp == 0 || spp > MAX_SPP {
                return Err(Error::Options(format!(
                    "--spp must be between 1 and {MAX_SPP}, got {spp}"
                )));
            }
            let filter = scene0.settings.filter.unwrap_or_default();
            Engine::MonteCarlo {
                integrator: &path,
                options: ProgressiveOptions {
                    width,
                    height,
                    spp,
                    time_limit: None,
                    threads: args.threads,
                    seed: args.seed,
                    progress: false,
                    filter,
                },
            }
        }
    };

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
    let grid = CoherentRenderer::grid_around(&boxes, args.voxels);
    let layout = super::tables::BlockLayout::new(width, height, blocks.0, blocks.1);
    let mut coherent = CoherentRenderer::with_records(grid, layout, args.records);
    // Records are kept only where a later frame changes something: in the voxels that the
    // changed objects' surfaces touch.
    let marked: Vec<Vec<_>> = changes.iter().map(|c| coherent.surface_boxes(c)).collect();
    coherent.restrict_to_sequence(&marked);
    drop((changes, marked));
    let prepare_seconds = prepare.elapsed().as_secs_f64();
    let mut overhead = Vec::new();
    for rep in 0..args.overhead_reps {
        let full = || -> Result<f64> {
            let clock = Clock::start();
            let accel = accel::build(&scene0, args.accel)?;
            engine.render_full(&Context::new(&scene0, accel.as_ref()))?;
            Ok(clock.elapsed().cpu)
        };
        let mut recorded = || -> Result<f64> {
            coherent.reset();
            let clock = Clock::start();
            let accel = accel::build_dynamic(&scene0, args.accel)?;
            coherent.render_frame(&scene0, accel.as_ref(), &engine)?;
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
    let out_options = OutputOptions {
        exposure: args.exposure,
        half: args.half,
    };
    let mut rows = Vec::new();
    let mut full_notice = false;
    // The most the records held after a frame: bytes, segments, bytes of camera hits.
    let (mut peak_bytes, mut peak_segments, mut peak_camera) = (0, 0, 0);
    let mut dynamic: Option<Box<dyn DynamicAccel>> = None;
    for &f in &frames {
        if let Some(signal) = crate::interrupt::signal() {
            return Err(Error::Interrupted {
                signal,
                detail: format!(
                    "interrupted by {}: frames {}..{} were written; continue with --frames {f}..",
                    crate::interrupt::name(signal),
                    frames[0],
                    f - 1
                ),
            });
        }
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
        if args.no_coherence {
            let clock = Clock::start();
            let accel = accel::build(&scene, args.accel)?;
            let (img, rays) = engine.render_full(&Context::new(&scene, accel.as_ref()))?;
            row.full = Some((rays, clock.elapsed()));
            image = img;
        } else {
            // The coherent renderer updates one structure from frame to frame; the full
            // renders build their own, as a frame-by-frame renderer does.
            let clock = Clock::start();
            match dynamic.as_mut() {
                None => dynamic = Some(accel::build_dynamic(&scene, args.accel)?),
                Some(d) => row.update = Some(d.update(&scene)?),
            }
            let accel = dynamic.as_deref().expect("built above");
            let before = (coherent.records(), coherent.keeps_camera_hits());
            let (img, stats) = coherent.render_frame(&scene, accel, &engine)?;
            if before != (coherent.records(), coherent.keeps_camera_hits()) && !args.quiet {
                eprintln!(
                    "notice: frame {f}: the records grew past a quarter of the memory limit; \
                     going on with voxel tables and without keeping camera hits (same frames)"
                );
            }
            peak_bytes = peak_bytes.max(coherent.record_bytes());
            peak_segments = peak_segments.max(coherent.segments());
            peak_camera = peak_camera.max(coherent.camera_bytes());
            row.time = clock.elapsed();
            if f != frames[0] && stats.full_reason.is_some() && !full_notice && !args.quiet {
                eprintln!(
                    "notice: frame {f}: every pixel retraced ({}); such frames are rendered in \
                     full",
                    stats.full_reason.as_deref().unwrap_or("")
                );
                full_notice = true;
            }
            row.coherent = stats;
            if args.verify {
                let clock = Clock::start();
                let accel = accel::build(&scene, args.accel)?;
                let (full, rays) = engine.render_full(&Context::new(&scene, accel.as_ref()))?;
                row.full = Some((rays, clock.elapsed()));
                let same = full.pixels.len() == img.pixels.len()
                    && full.pixels.iter().zip(&img.pixels).all(|(a, b)| {
                        a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)
                    });
                row.identical = Some(same);
                if !same {
                    eprintln!(
                        "raylink: error: frame {f}: the coherent render differs from the full render"
                    );
                }
            }
            image = img;
        }
        let metadata: Metadata = vec![
            (
                "Software".into(),
                MetaValue::Str(format!("raylink {}", crate::VERSION)),
            ),
            (
                "raylink:scene".into(),
                MetaValue::Str(args.scene.display().to_string()),
            ),
            ("raylink:frame".into(), MetaValue::Int(f as i32)),
            ("raylink:fps".into(), MetaValue::Float(anim.fps as f32)),
            ("raylink:seed".into(), MetaValue::Str(args.seed.to_string())),
        ];
        write_image(
            &frame_path(&args.output, f)?,
            &image,
            &metadata,
            &out_options,
        )?;
        if !args.quiet {
            let r = &row.coherent;
            if args.no_coherence {
                eprintln!("frame {f}: rendered in full");
            } else {
                eprintln!(
                    "frame {f}: {} of {} blocks retraced, {} rays, {:.3} s",
                    r.blocks_retraced,
                    layout.len(),
                    r.rays.total(),
                    row.time.wall
                );
            }
        }
        rows.push(row);
    }
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

/// The per-frame CSV.
pub fn csv_text(report: &Report) -> String {
    let mut s = String::from(
        "frame,rays,cpu_seconds,wall_seconds,pixels_retraced,blocks_retraced,changed_voxels,\
         bookkeeping_seconds,accel_update,camera_rays_kept,camera_rays_reused,full_rays,\
         full_cpu_seconds,full_wall_seconds,identical\n",
    );
    for r in &report.rows {
        let c = &r.coherent;
        let (fr, fc, fw) = r.full.map_or(Default::default(), |(rays, t)| {
            (
                rays.total().to_string(),
                format!("{:.6}", t.cpu),
                format!("{:.6}", t.wall),
            )
        });
        let update = match r.update {
            // --no-coherence: no structure is kept.
            None if r.time.wall == 0.0 => "",
            None => "built",
            Some(Update::Unchanged) => "unchanged",
            Some(Update::Refit(_)) => "refit",
            Some(Update::Rebuilt) => "rebuilt",
        };
        let _ = writeln!(
            s,
            "{},{},{:.6},{:.6},{},{},{},{:.6},{update},{},{},{fr},{fc},{fw},{}",
            r.frame,
            c.rays.total(),
            r.time.cpu,
            r.time.wall,
            c.pixels_retraced,
            c.blocks_retraced,
            c.changed_voxels,
            c.bookkeeping_seconds,
            c.camera_rays,
            c.camera_reused,
            r.identical.map_or(String::new(), |b| b.to_string()),
        );
    }
    s
}

/// A summary like Table 2 of the paper: rays and CPU time of the full ("traditional") and the
/// coherent renders, per frame and for the whole sequence.
pub fn summary(report: &Report) -> String {
    let mut s = String::new();
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { f64::NAN };
    let _ = writeln!(
        s,
        "{:>6} {:>12} {:>9} | {:>12} {:>7} {:>9} {:>7} {:>9} {:>9}",
        "frame", "full rays", "full cpu", "rays", "ratio", "cpu s", "ratio", "retraced", "wall s"
    );
    let (mut cr, mut fr, mut px) = (0u64, 0u64, 0u64);
    let (mut ct, mut ft) = (Time::default(), Time::default());
    let mut all_full = !report.rows.is_empty();
    for r in &report.rows {
        let c = &r.coherent;
        cr += c.rays.total();
        ct.cpu += r.time.cpu;
        ct.wall += r.time.wall;
        px += c.pixels_retraced;
        let (frays, ftime) = r
            .full
            .map_or((0, Time::default()), |(rays, t)| (rays.total(), t));
        all_full &= r.full.is_some();
        fr += frays;
        ft.cpu += ftime.cpu;
        ft.wall += ftime.wall;
        let _ = writeln!(
            s,
            "{:>6} {:>12} {:>9.2} | {:>12} {:>7.4} {:>9.2} {:>7.4} {:>8.2}% {:>9.3}",
            r.frame,
            frays,
            ftime.cpu,
            c.rays.total(),
            ratio(c.rays.total() as f64, frays as f64),
            r.time.cpu,
            ratio(r.time.cpu, ftime.cpu),
            100.0 * c.pixels_retraced as f64 / report.pixels_per_frame as f64,
            r.time.wall,
        );
    }
    let frames = report.rows.len() as u64;
    let _ = writeln!(
        s,
        "{:>6} {:>12} {:>9.2} | {:>12} {:>7.4} {:>9.2} {:>7.4} {:>8.2}% {:>9.3}",
        "all",
        fr,
        ft.cpu,
        cr,
        ratio(cr as f64, fr as f64),
        ct.cpu,
        ratio(ct.cpu, ft.cpu),
        100.0 * px as f64 / (report.pixels_per_frame * frames.max(1)) as f64,
        ct.wall,
    );
    if all_full {
        let r0 = &report.rows[0];
        if let Some((_, f0)) = r0.full {
            let _ = writeln!(
                s,
                "frame-0 overhead: {:+.1}% CPU, {:+.1}% wall ({:.2} s / {:.2} s CPU)",
                100.0 * (r0.time.cpu / f0.cpu - 1.0),
                100.0 * (r0.time.wall / f0.wall - 1.0),
                r0.time.cpu,
                f0.cpu
            );
        }
        let (rf, tf) = (ratio(cr as f64, fr as f64), ratio(ct.cpu, ft.cpu));
        let _ = writeln!(
            s,
            "sequence: ray fraction {rf:.4}, CPU time fraction {tf:.4} ({:.2}x the ray fraction), \
             wall time fraction {:.4}",
            tf / rf,
            ratio(ct.wall, ft.wall),
        );
    }
    if !report.overhead.is_empty() {
        let median = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            let n = v.len();
            (v[(n - 1) / 2] + v[n / 2]) / 2.0
        };
        let ratios: Vec<f64> = report.overhead.iter().map(|&(c, f)| c / f).collect();
        let (lo, hi) = ratios
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &r| {
                (a.min(r), b.max(r))
            });
        let _ = writeln!(
            s,
            "frame-0 overhead, first frame rendered {} times both ways: median {:+.1}% CPU \
             ({:+.1}% to {:+.1}%; median {:.3} s coherent / {:.3} s full)",
            ratios.len(),
            100.0 * (median(ratios.clone()) - 1.0),
            100.0 * (lo - 1.0),
            100.0 * (hi - 1.0),
            median(report.overhead.iter().map(|o| o.0).collect()),
            median(report.overhead.iter().map(|o| o.1).collect()),
        );
    }
    let _ = writeln!(
        s,
        "preparation (reading every frame to place the grid): {:.2} s",
        report.prepare_seconds
    );
    let verified: Option<Vec<bool>> = report.rows.iter().map(|r| r.identical).collect();
    if let Some(v) = verified.filter(|v| !v.is_empty()) {
        let _ = writeln!(
            s,
            "verify: {}",
            if v.iter().all(|&b| b) {
                "every frame identical to its full render"
            } else {
                "DIFFERENCES (see above)"
            }
        );
    }
    let (lo, hi) = report.grid;
    let _ = writeln!(
        s,
        "voxel grid: {} voxels ({} where changes happen) over [{:.2}, {:.2}, {:.2}]..[{:.2}, \
         {:.2}, {:.2}], {}x{} pixel blocks",
        report.voxels,
        report.active_voxels,
        lo.x,
        lo.y,
        lo.z,
        hi.x,
        hi.y,
        hi.z,
        report.blocks.0,
        report.blocks.1,
    );
    let kib = report.record_bytes as f64 / 1024.0;
    let _ = match report.records {
        Records::Tables => writeln!(s, "records: voxel tables x 2 = {kib:.1} KiB"),
        Records::Segments => writeln!(
            s,
            "records: segments, at most {} held after a frame = {kib:.1} KiB",
            report.segments
        ),
    };
    let (kept, reused) = report.rows.iter().fold((0, 0), |(k, r), row| {
        (k + row.coherent.camera_rays, r + row.coherent.camera_reused)
    });
    if kept > 0 {
        let _ = writeln!(
            s,
            "camera hits (section 3.3.3): {reused} of {kept} camera rays in retraced blocks \
             ({:.1}%) answered from the block's last trace; at most {:.1} KiB kept",
            100.0 * reused as f64 / kept as f64,
            report.camera_bytes as f64 / 1024.0
        );
    }
    s
}
