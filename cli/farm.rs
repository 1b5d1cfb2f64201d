//! The command line of rendering beyond one machine (docs/farm.md): `render --tile I/N` and
//! `--crop`, and `raylink merge`. The library side is `raylink::farm`.

use crate::options::RenderArgs;
use crate::{Cli, Failure};
use raylink::farm::{self, Part};
use raylink::image::output::{check_output_path, write_image_window};
use raylink::output_paths::FilePlan;
use raylink::{
    write_image, Aov, Control, Error, Job, MetaValue, Metadata, OutputOptions, RenderStats,
    Rendered, Renderer, Scene, Tile,
};
use std::path::{Path, PathBuf};

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
/// loaded: a tile is written only as EXR (a crop in any format: only its EXR keeps where it
/// lies, for merging).
pub fn resolve_outputs(args: &mut RenderArgs) -> raylink::Result<()> {
    let part = args.part.part().copied();
    for out in &mut args.outputs {
        *out = output_path(out, part.as_ref())?;
        if matches!(part, Some(Part::Tile { .. })) && !is_exr(out) {
            return Err(Error::Invalid(format!(
                "{}: a tile is written only as .exr, which keeps where it lies in the image \
                 for raylink merge",
                out.display()
            )));
        }
    }
    Ok(())
}

/// True for an OpenEXR file name (`.exr`, any case).
fn is_exr(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// The region a render job renders (`None`: the whole image), after checking the command
/// line's own options that cannot go with a part.
pub fn region(args: &RenderArgs, job: &Job) -> raylink::Result<Option<Tile>> {
    let Some(part) = args.part.part() else {
        return Ok(None);
    };
    for (option, given) in [
        ("--write-interval", args.write_interval.is_some()),
        ("--checkpoint-interval", args.checkpoint_interval.is_some()),
        ("--resume", args.resume),
        ("--display-server", args.display_server.is_some()),
    ] {
        if given {
            return Err(Error::Invalid(format!(
                "{option} cannot be used with --tile or --crop"
            )));
        }
    }
    // What the technique needs of a part (a cache or network precomputed for the view)
    // is the library's to check: `Job::validate`, when the renderer is made.
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

/// Writes a rendered part (and its AOVs) to the outputs, EXR with the region as data window
/// (other formats, for a crop, as an image of the region's size), then prints the summary.
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
    if stats.invalid > 0 && crate::log::enabled(crate::log::Level::Warn) {
        eprintln!(
            "raylink: warning: {} samples were not finite and were dropped",
            stats.invalid
        );
    }
    metadata.extend(stats_metadata(&stats, region.pixels() as f32));
    let window = farm::window(&region, job.width, job.height);
    for out in &args.outputs {
        if is_exr(out) {
            write_image_window(out, &image, window, &metadata, out_options)?;
        } else {
            // A crop's other formats hold its pixels alone.
            write_image(out, &image, &metadata, out_options)?;
        }
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
    if crate::log::info(args.quiet) {
        eprintln!("tile {}: {}", farm::region_label(&region), stats.summary());
    }
    Ok(())
}

/// `raylink merge`.
pub fn run_merge(args: MergeArgs) -> Result<(), Failure> {
    for out in &args.outputs {
        check_output_path(out).map_err(|e| Error::Invalid(e.to_string()))?;
    }
    FilePlan::new()
        .reads("a part to merge", &args.parts)
        .writes("-o", &args.outputs)
        .check()?;
    let merged = farm::merge::merge(&args.parts)?;
    let options = OutputOptions::new(args.exposure, args.half);
    for out in &args.outputs {
        write_image(out, &merged.image, &merged.metadata, &options)?;
    }
    if crate::log::info(args.quiet) {
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

/// An output path with `{tile}` replaced by the tile index and `{tiles}` by the tile count.
/// A pattern without them is used as it is; `{tile}` without `--tile` is an error.
fn output_path(pattern: &Path, part: Option<&Part>) -> Result<PathBuf, Error> {
    let text = pattern.to_string_lossy();
    if !text.contains("{tile") {
        return Ok(pattern.to_path_buf());
    }
    match part {
        Some(Part::Tile { index, count }) => Ok(PathBuf::from(
            text.replace("{tiles}", &count.to_string())
                .replace("{tile}", &index.to_string()),
        )),
        _ => Err(Error::setting(
            "tile",
            format!(
                "is needed for {{tile}} and {{tiles}} in an output name ({})",
                pattern.display()
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::options::{parse_crop, parse_tile};
    use std::path::PathBuf;

    #[test]
    fn parses_tiles_and_crops() {
        assert_eq!(parse_tile("2/5"), Ok(Part::Tile { index: 2, count: 5 }));
        for bad in ["5/5", "1", "a/2", "0/0", "-1/3"] {
            assert!(parse_tile(bad).is_err(), "{bad}");
        }
        assert_eq!(
            parse_crop("1,2,3,4"),
            Ok(Part::Crop(Tile {
                x0: 1,
                y0: 2,
                x1: 3,
                y1: 4
            }))
        );
        for bad in ["1,2,1,4", "1,2,3", "0,0,4,4,5", "a,0,1,1", "0,3,2,1"] {
            assert!(parse_crop(bad).is_err(), "{bad}");
        }
        let crop = parse_crop("0,0,20,10").unwrap();
        assert!(crop.region(16, 16).is_err());
        assert!(parse_tile("0/17").unwrap().region(4, 16).is_err());
    }

    #[test]
    fn output_patterns() {
        let p = Part::Tile { index: 3, count: 8 };
        assert_eq!(
            output_path(Path::new("out/t_{tile}_of_{tiles}.exr"), Some(&p)).unwrap(),
            PathBuf::from("out/t_3_of_8.exr")
        );
        assert_eq!(
            output_path(Path::new("a.exr"), Some(&p)).unwrap(),
            PathBuf::from("a.exr")
        );
        assert!(output_path(Path::new("t_{tile}.exr"), None).is_err());
        let crop = parse_crop("0,0,1,1").unwrap();
        assert!(output_path(Path::new("t_{tile}.exr"), Some(&crop)).is_err());
    }
}
