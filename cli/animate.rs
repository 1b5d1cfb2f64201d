//! `raylink animate`: renders a keyframed scene's frames with object-space temporal coherence,
//! optionally checking every frame against a full render (`--verify`) and reporting what was
//! saved per frame (`--stats`, `--csv`), like Table 2 of the paper.

use crate::options::{AccelName, IntegratorName};
use crate::{Cli, Failure};

use raylink::coherence::{
    animates, render_frames, report, Coherence, Placement, Records, Sequence, SequenceMode,
};
use raylink::image::output::check_output_path;
use raylink::output_paths::FilePlan;
use raylink::scene::animation::Animation;
use raylink::{write_image, Error, MetaValue, Metadata, OutputOptions, Result};
use raylink::{Job, Settings, Technique, TechniqueKind};
use std::path::PathBuf;

/// How the coherence records are kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RecordsName {
    /// Walk every segment through the grid as it is traced and set the block's bit in the
    /// voxels' tables (the paper's form).
    Tables,
    /// Keep the block's segments; a frame walks them through the voxels that changed.
    Segments,
}

/// The integrators `animate` can render with: the registered techniques that the coherence
/// engine renders ([`raylink::coherence::animates`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnimIntegrator(pub TechniqueKind);

impl clap::ValueEnum for AnimIntegrator {
    fn value_variants<'a>() -> &'a [Self] {
        static ALL: std::sync::LazyLock<Vec<AnimIntegrator>> = std::sync::LazyLock::new(|| {
            IntegratorName::value_variants()
                .iter()
                .filter(|i| animates(i.kind()))
                .map(|i| AnimIntegrator(i.kind()))
                .collect()
        });
        &ALL
    }

    /// As `render --integrator` names and describes it.
    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        IntegratorName(self.0).to_possible_value()
    }
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
    #[arg(long, value_enum, default_value = crate::options::DEFAULT_ACCEL)]
    pub accel: AccelName,
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
    #[arg(long, value_parser = crate::options::finite_f32)]
    pub aa_threshold: Option<f32>,
    /// Adaptive anti-aliasing (Whitted): deepest subdivision level.
    #[arg(long)]
    pub aa_depth: Option<u32>,
    /// Maximum ray-tree depth (Whitted) or bounces (path). Default: the scene's, else 8.
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Whitted: shadow rays per area light at each shading point (default: the scene's, else
    /// 16).
    #[arg(long)]
    pub area_samples: Option<u32>,
    /// Pixel blocks of the voxel bit tables, COLSxROWS (at most one block per pixel).
    #[arg(long, default_value = "16x16", value_name = "COLSxROWS")]
    pub block_table: String,
    /// How the records are kept: each block's ray segments, walked through the voxels that
    /// changed when a frame needs them (faster), or the paper's per-voxel bit tables filled
    /// by walking every segment as it is traced (less memory). Same frames, same blocks.
    #[arg(long, value_enum, default_value = "segments")]
    pub records: RecordsName,
    /// Approximate number of voxels of the grid (over the scene, or with --lookahead over the
    /// region where the sequence changes). More voxels retrace fewer pixels but cost more to
    /// look up. Default: 65536 online with segment records, else 8192.
    #[arg(long)]
    pub voxels: Option<u32>,
    /// Render only these frames of the sequence: A..B (both included), A.., ..B or A, in the
    /// scene's frame numbers (e.g. one render-farm job's share). Frame A is traced in full,
    /// the rest coherently; the frames equal those of the whole sequence bit for bit.
    #[arg(long, value_name = "A..B")]
    pub frames: Option<String>,
    /// Read every frame before rendering the first, and place the voxel grid (and keep
    /// records) only where later frames change something. By default the frames are made
    /// online, each from the frames before it alone (the grid covers the scene and grows
    /// when something leaves it). Same frames either way.
    #[arg(long, conflicts_with = "no_coherence")]
    pub lookahead: bool,
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
    /// Also write, per frame, a map of what was retraced (pattern as -o): the kept pixels in
    /// dim grey, red over the blocks retraced because something they saw changed, blue over
    /// a frame traced in full.
    #[arg(long, value_name = "PATTERN", conflicts_with = "no_coherence")]
    pub retrace_map: Option<String>,
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
    #[arg(long, value_parser = crate::options::finite_f32, allow_negative_numbers = true)]
    pub exposure: Option<f32>,
    /// No progress lines.
    #[arg(short, long)]
    pub quiet: bool,
}

/// The output file of frame `frame`: `%d` / `%0Nd` replaced by the number.
pub fn frame_path(pattern: &str, frame: i64) -> Result<PathBuf> {
    let bad = || {
        Error::Invalid(format!(
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
    let bad = |why: String| Error::Invalid(format!("--frames {spec}: {why}"));
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

/// A frame-pattern error of `--output` said of `--retrace-map`.
fn retrace_map_error(pattern: &str, e: Error) -> Error {
    match e {
        Error::Invalid(_) => Error::Invalid(format!(
            "--retrace-map {pattern}: needs one frame number placeholder, %d or %0Nd (e.g. \
             %04d)"
        )),
        other => other,
    }
}

fn parse_blocks(s: &str) -> Result<(u32, u32)> {
    let bad = || {
        Error::Invalid(format!(
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

pub fn run(cli: &Cli, args: &AnimateArgs) -> std::result::Result<(), Failure> {
    let control = cli.control(args.quiet, args.max_memory.as_deref())?;
    if let Some(e) = args.exposure.filter(|e| !e.is_finite()) {
        return Err(Error::Invalid(format!(
            "--exposure must be a finite number of stops, got {e}"
        ))
        .into());
    }
    let blocks = parse_blocks(&args.block_table)?;
    if args.scene.extension().and_then(|e| e.to_str()) != Some("toml") {
        return Err(Error::input(
            &args.scene,
            "animations are read from native .toml scenes (see docs/animation.md)",
        )
        .into());
    }
    let anim = Animation::read(&args.scene)?;
    let frames: Vec<i64> = match &args.frames {
        Some(spec) => select_frames(spec, anim.frame_numbers())?,
        None => anim.frame_numbers().collect(),
    };
    let scene0 = anim.scene_at(frames[0])?;
    for w in &scene0.warnings {
        if crate::log::enabled(crate::log::Level::Warn) {
            eprintln!("warning: {w}");
        }
    }
    let outputs = frames
        .iter()
        .map(|&f| frame_path(&args.output, f))
        .collect::<Result<Vec<_>>>()?;
    let maps = match &args.retrace_map {
        Some(pattern) => frames
            .iter()
            .map(|&f| frame_path(pattern, f).map_err(|e| retrace_map_error(pattern, e)))
            .collect::<Result<Vec<_>>>()?,
        None => Vec::new(),
    };
    let mut plan = FilePlan::new();
    plan.reads("an input of the scene", &scene0.inputs);
    for (f, path) in frames.iter().zip(&outputs) {
        plan.write(format!("frame {f} of -o"), path);
    }
    for (f, path) in frames.iter().zip(&maps) {
        plan.write(format!("frame {f} of --retrace-map"), path);
    }
    if let Some(csv) = &args.csv {
        plan.write("--csv", csv);
    }
    plan.check()?;
    // The folders after the check, so that a refused run leaves none behind.
    for first in [outputs.first(), maps.first()].into_iter().flatten() {
        if let Some(dir) = first.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        }
        check_output_path(first).map_err(|e| Error::Invalid(e.to_string()))?;
    }
    raylink::image::io::load()?;
    // The scene's settings with the options over them, as for a still render; the job
    // each frame is rendered with, as `render` makes it.
    let given = Settings {
        integrator: args.integrator.map(|i| i.0),
        spp: args.spp,
        aa_threshold: args.aa_threshold,
        aa_depth: args.aa_depth,
        max_depth: args.max_depth,
        area_samples: args.area_samples,
        ..Settings::default()
    };
    // A bad value the scene file gives is reported at its line there.
    let locate = |e: Error| crate::options::locate(e, &scene0, &given);
    let settings = scene0.settings.clone().overlaid(&given);
    let technique = Technique::create(&settings).map_err(locate)?;
    let job = Job {
        width: args.width.unwrap_or(scene0.camera.width),
        height: args.height.unwrap_or(scene0.camera.height),
        seed: args.seed,
        threads: args.threads,
        accel: args.accel.backend(),
        ..Job::new(&scene0, technique)
    };
    let records = match args.records {
        RecordsName::Tables => Records::Tables,
        RecordsName::Segments => Records::Segments,
    };
    let placement = if args.lookahead {
        Placement::Lookahead
    } else {
        Placement::Online
    };
    let coherence = Coherence {
        mode: if args.no_coherence {
            SequenceMode::Full
        } else if args.verify {
            SequenceMode::Verify
        } else {
            SequenceMode::Coherent
        },
        records,
        voxels: args.voxels.unwrap_or(placement.default_voxels(records)),
        blocks,
        overhead_reps: args.overhead_reps,
        placement,
    };
    // What the engine refuses (a technique it does not render), before any frame.
    Sequence::new(&job, &coherence).map_err(locate)?;
    drop(scene0);
    let out_options = OutputOptions::new(args.exposure.unwrap_or(0.0), args.half);
    let mut written: Option<i64> = None;
    let result = render_frames(
        &anim,
        &job,
        &frames,
        &coherence,
        &control,
        &mut |f, image, row| {
            let metadata: Metadata = vec![
                (
                    "Software".into(),
                    MetaValue::Str(format!("raylink {}", raylink::VERSION)),
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
                image,
                &metadata,
                &out_options,
            )?;
            if let Some(pattern) = &args.retrace_map {
                let map = report::retrace_map(image, &row.coherent, blocks);
                write_image(&frame_path(pattern, f)?, &map, &metadata, &out_options)?;
            }
            written = Some(f);
            if row.identical == Some(false) {
                eprintln!(
                    "raylink: error: frame {f}: the coherent render differs from the full render"
                );
            }
            let r = &row.coherent;
            control.note(&if args.no_coherence {
                format!("frame {f}: rendered in full")
            } else {
                format!(
                    "frame {f}: {} of {} blocks retraced, {} rays, {:.3} s",
                    r.blocks_retraced,
                    r.blocks_total,
                    r.rays.total(),
                    row.time.wall
                )
            });
            Ok(())
        },
    );
    let report = match result {
        Ok(report) => report,
        Err(Error::Cancelled { .. }) => {
            let next = written.map_or(frames[0], |f| f + 1);
            let done = match written {
                Some(last) => format!("frames {}..{last} were written", frames[0]),
                None => "no frame was written".to_string(),
            };
            return Err(cli.interrupted(
                "the animation",
                &format!("{done}; continue with --frames {next}.."),
            ));
        }
        Err(e) => return Err(e.into()),
    };
    if args.stats {
        print!("{}", report::summary(&report));
    }
    if let Some(csv) = &args.csv {
        raylink::atomic_file::write(csv, report::csv_text(&report).as_bytes())?;
    }
    if let Some(r) = report.rows.iter().find(|r| r.identical == Some(false)) {
        return Err(Error::image(
            frame_path(&args.output, r.frame)?,
            "--verify: the coherent frame differs from its full render",
        )
        .into());
    }
    Ok(())
}
