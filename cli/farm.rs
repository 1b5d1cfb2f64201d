//! The command line of rendering beyond one machine (docs/farm.md): `render --tile I/N` and
//! `--crop`, and `raylink merge`. The library side is `raylink::farm`.

use crate::options::RenderArgs;
use crate::{Cli, Failure};
use raylink::farm;
use raylink::image::output::{check_output_path, write_image_window};
use raylink::{
    write_image, Aov, Control, Error, Job, MetaValue, Metadata, OutputOptions, RenderStats,
    Rendered, Renderer, Scene, Tile,
};
use std::path::PathBuf;

/// Arguments of `raylink merge`.
#[derive(clap::Args)]
pub struct MergeArgs {
    /// The parts: EXR files written by `raylink render --tile` or `--crop`.
    #[arg(required = true, value_name = "PART")]
    parts: Vec<PathBuf>,
    /// The merged image; the extension picks the format. Repeat for several formats.
    #[arg(short, long = "output", required = true, value_name = "FILE")]
    outputs: Vec<PathBuf>,
    /// Exposure in stops applied to 8-bit outputs (PNG, JPEG).
    #[arg(long, value_parser = crate::options::finite_f32, default_value_t = 0.0,
        allow_negative_numbers = true)]
    exposure: f32,
    /// Store EXR pixels as half floats instead of 32-bit floats.
    #[arg(long)]
    half: bool,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
}

/// Expands `{tile}` patterns in the outputs and checks what a part needs before anything is
/// loaded: EXR outputs only.
pub fn resolve_outputs(args: &mut RenderArgs) -> raylink::Result<()> {
    let part = args.part.part().copied();
    for out in &mut args.outputs {
        *out = farm::output_path(out, part.as_ref())?;
        let exr = out
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        if part.is_some() && !exr {
            return Err(Error::Invalid(format!(
                "{}: a tile or crop is written only as .exr, which keeps where it lies in the \
                 image",
                out.display()
            )));
        }
    }
    Ok(())
}

/// The region a render job renders (`None`: the whole image), after checking the options
/// that cannot go with a part.
pub fn region(args: &RenderArgs, job: &Job) -> raylink::Result<Option<Tile>> {
    let Some(part) = args.part.part() else {
        return Ok(None);
    };
    for (option, given) in [
        ("--time-limit", args.time_limit.is_some()),
        ("--write-interval", args.write_interval.is_some()),
        ("--checkpoint-interval", args.checkpoint_interval.is_some()),
        ("--resume", args.resume),
    ] {
        if given {
            return Err(Error::Invalid(format!(
                "{option} cannot be used with --tile or --crop"
            )));
        }
    }
    match &job.technique {
        raylink::Technique::IrradianceCache(_, c) if c.show_points => {
            return Err(Error::Invalid(
                "--show-cache-points cannot be used with --tile or --crop".into(),
            ));
        }
        raylink::Technique::IrradianceCache(_, c) if c.file.is_none() => {
            return Err(Error::Invalid(
                "--tile and --crop with the irradiance cache need --cache-file F precomputed \
                 for this view (run `raylink precompute --cache-file F` with the same options \
                 first)"
                    .into(),
            ));
        }
        raylink::Technique::Network(n) if !n.file.as_ref().is_some_and(|f| f.exists()) => {
            return Err(Error::Invalid(
                "--tile and --crop with the network integrator need an existing \
                 --network-file (run `raylink precompute --network-file F` first)"
                    .into(),
            ));
        }
        _ => {}
    }
    part.region(job.width, job.height).map(Some)
}

/// The settings every render records, and what a part needs for merging.
pub fn part_metadata(
    metadata: &mut Metadata,
    settings: String,
    scene: &Scene,
    args: &RenderArgs,
    job: &Job,
) {
    metadata.push((farm::META_SETTINGS.into(), MetaValue::Str(settings)));
    let (Some(part), Some(region)) = (args.part.part(), job.region) else {
        return;
    };
    // Only parts: hashing a large scene's description takes time.
    metadata.push((
        farm::META_SCENE_HASH.into(),
        MetaValue::Str(format!("{:016x}", farm::scene_hash(scene))),
    ));
    if let Some(label) = part.tile_label() {
        metadata.push((farm::META_TILE.into(), MetaValue::Str(label)));
    }
    metadata.push((
        farm::META_REGION.into(),
        MetaValue::Str(farm::region_label(&region)),
    ));
}

/// What a render's images record of its statistics, over `pixels` pixels.
pub fn stats_metadata(stats: &RenderStats, pixels: f32) -> Metadata {
    vec![
        (
            "raylink:samples_per_pixel".into(),
            MetaValue::Float(stats.samples as f32 / pixels),
        ),
        (
            "raylink:render_seconds".into(),
            MetaValue::Float(stats.seconds as f32),
        ),
        (
            "raylink:rays".into(),
            MetaValue::Str(stats.rays.total().to_string()),
        ),
    ]
}

/// Writes a rendered part (and its AOVs) to the outputs, as EXR with the region as data
/// window, then prints the summary.
pub fn write_part(
    cli: &Cli,
    args: &RenderArgs,
    renderer: &Renderer,
    rendered: Rendered,
    mut metadata: Metadata,
    out_options: &OutputOptions,
    control: &Control,
) -> Result<(), Failure> {
    let job = renderer.job();
    let region = job.region.expect("a part has a region");
    let Rendered { image, stats, .. } = rendered;
    if stats.cancelled {
        // A part is merged as a whole, so an unfinished one is not written at all.
        return Err(cli.interrupted(
            "the render",
            "a part is written whole or not at all, so nothing was written",
        ));
    }
    if stats.invalid > 0 {
        eprintln!(
            "raylink: warning: {} samples were not finite and were dropped",
            stats.invalid
        );
    }
    metadata.extend(stats_metadata(&stats, region.pixels() as f32));
    let window = farm::window(&region, job.width, job.height);
    for out in &args.outputs {
        write_image_window(out, &image, window, &metadata, out_options)?;
    }
    if args.aov {
        let aovs = renderer
            .render_aovs(control)?
            .ok_or_else(|| cli.interrupted("the auxiliary images", "the part was written"))?;
        let first = &args.outputs[0];
        let stem = first.file_stem().unwrap_or_default().to_string_lossy();
        for (aov, img) in Aov::ALL.iter().zip(&aovs) {
            let path = first.with_file_name(format!("{stem}.{}.exr", aov.name()));
            write_image_window(&path, img, window, &metadata, out_options)?;
        }
    }
    if !args.quiet {
        eprintln!("tile {}: {}", farm::region_label(&region), stats.summary());
    }
    Ok(())
}

/// `raylink merge`.
pub fn run_merge(args: MergeArgs) -> Result<(), Failure> {
    for out in &args.outputs {
        check_output_path(out).map_err(|e| Error::Invalid(e.to_string()))?;
    }
    crate::aliases::refuse_aliases(&args.outputs, &args.parts)?;
    let merged = farm::merge::merge(&args.parts)?;
    let options = OutputOptions {
        exposure: args.exposure,
        half: args.half,
    };
    for out in &args.outputs {
        write_image(out, &merged.image, &merged.metadata, &options)?;
    }
    if !args.quiet {
        eprintln!(
            "merged {} parts into {}",
            args.parts.len(),
            args.outputs
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(())
}
