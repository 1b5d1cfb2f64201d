//! The command line of rendering beyond one machine (docs/farm.md): `render --tile I/N` and
//! `--crop`, `raylink precompute` and `raylink merge`. The library side is `raylink::farm`.

use super::{
    choose_filter, choose_integrator, integrator_name, pixel_sampling, IntegratorName, RenderArgs,
};
use raylink::farm::{self, Part};
use raylink::image::output::{check_output_path, write_image, write_image_window, OutputOptions};
use raylink::image::{Image, MetaValue, Metadata};
use raylink::integrators::Context;
use raylink::render::progressive::ProgressiveOptions;
use raylink::render::{RenderStats, Tile};
use raylink::scene::{Scene, MAX_RESOLUTION};
use raylink::{accel, Error};
use std::path::PathBuf;

/// Options of `raylink render` that select a part of the image.
#[derive(clap::Args)]
pub struct PartArgs {
    /// Render only tile I of N (0 <= I < N): the image cut into N horizontal bands of equal
    /// height (to a row). Written as EXR with the band as its data window, for `raylink
    /// merge`. `{tile}` and `{tiles}` in -o names become I and N.
    #[arg(long, value_name = "I/N", value_parser = farm::parse_tile, conflicts_with = "crop")]
    tile: Option<Part>,
    /// Render only the pixels x0 <= x < x1, y0 <= y < y1 (0,0 is the top-left pixel; x1 and y1
    /// are excluded). Written as EXR with those pixels as its data window.
    #[arg(long, value_name = "x0,y0,x1,y1", value_parser = farm::parse_crop)]
    crop: Option<Part>,
}

impl PartArgs {
    pub fn part(&self) -> Option<&Part> {
        self.tile.as_ref().or(self.crop.as_ref())
    }
}

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
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// Store EXR pixels as half floats instead of 32-bit floats.
    #[arg(long)]
    half: bool,
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
            return Err(Error::Options(format!(
                "{}: a tile or crop is written only as .exr, which keeps where it lies in the \
                 image",
                out.display()
            )));
        }
    }
    Ok(())
}

/// The region a render job renders (`None`: the whole image), after checking that the
/// integrator and options allow rendering part of the image exactly.
pub fn region(
    args: &RenderArgs,
    integrator: IntegratorName,
    width: u32,
    height: u32,
) -> raylink::Result<Option<Tile>> {
    let Some(part) = args.part.part() else {
        return Ok(None);
    };
    if matches!(integrator, IntegratorName::Light | IntegratorName::Bdpt) {
        return Err(Error::Options(format!(
            "--tile and --crop do not apply to the {} integrator: its light paths splat onto \
             every pixel of the image, so a part cannot be rendered alone",
            integrator_name(integrator)
        )));
    }
    for (option, given) in [
        ("--time-limit", args.time_limit.is_some()),
        ("--write-interval", args.write_interval.is_some()),
        ("--checkpoint-interval", args.checkpoint_interval.is_some()),
        ("--resume", args.resume),
        ("--show-cache-points", args.show_cache_points),
    ] {
        if given {
            return Err(Error::Options(format!(
                "{option} cannot be used with --tile or --crop"
            )));
        }
    }
    if integrator == IntegratorName::Network {
        match &args.network.network_file {
            Some(f) if f.exists() => {}
            Some(f) => {
                return Err(Error::input(
                    f,
                    "no such network: run `raylink precompute --network-file` with the \
                     render's options first",
                ))
            }
            None => {
                return Err(Error::Options(
                    "--tile and --crop with the network integrator need an existing \
                     --network-file (run `raylink precompute --network-file F` first)"
                        .into(),
                ))
            }
        }
    }
    if integrator == IntegratorName::IrradianceCache && args.cache_file.is_none() {
        return Err(Error::Options(
            "--tile and --crop with the irradiance cache need --cache-file F precomputed for \
             this view (run `raylink precompute --cache-file F` with the same options first)"
                .into(),
        ));
    }
    part.region(width, height).map(Some)
}

/// Every setting that changes pixels, as one string: parts merge only if theirs are equal.
pub fn settings(
    args: &RenderArgs,
    scene: &Scene,
    integrator: IntegratorName,
    width: u32,
    height: u32,
    max_depth: u32,
) -> raylink::Result<String> {
    let spp = args.spp.or(scene.settings.spp);
    let mut s = format!(
        "integrator={} size={width}x{height} max_depth={max_depth} accel={:?} seed={} half={}",
        integrator_name(integrator),
        args.accel,
        args.seed,
        args.half
    );
    match integrator {
        IntegratorName::Whitted | IntegratorName::Network => {
            s += &format!(" sampling={:?}", pixel_sampling(args, spp)?);
        }
        // As `raylink render` defaults it (parts refuse --time-limit).
        _ => {
            s += &format!(
                " spp={} filter={:?}",
                spp.unwrap_or(16),
                choose_filter(args, scene)?
            )
        }
    }
    if integrator == IntegratorName::Whitted {
        s += &format!(
            " area_samples={} fresnel={}",
            args.area_samples.unwrap_or(16),
            args.fresnel
        );
    }
    if integrator == IntegratorName::IrradianceCache {
        s += &format!(
            " ab={} ic_accuracy={} ic_samples={} ar={}",
            args.ab, args.ic_accuracy, args.ic_samples, args.ar
        );
    }
    if integrator == IntegratorName::Network {
        let n = &args.network;
        s += &format!(
            " slopes={} intercept_step={} patch_size={:?} jitter={} builder={:?} \
             tolerance={} light_scale={} order={:?} hybrid={}",
            n.slopes,
            n.intercept_step,
            n.patch_size,
            n.network_jitter,
            n.network_builder as u8,
            n.tolerance,
            n.light_scale,
            n.network_order as u8,
            n.network_hybrid
        );
    }
    Ok(s)
}

/// The settings every render records, and what a part needs for merging.
pub fn part_metadata(
    metadata: &mut Metadata,
    settings: String,
    scene: &Scene,
    part: Option<(&Part, &Tile)>,
) {
    metadata.push((farm::META_SETTINGS.into(), MetaValue::Str(settings)));
    if let Some((part, region)) = part {
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
            MetaValue::Str(farm::region_label(region)),
        ));
    }
}

/// The key of the render view an irradiance-cache overture traces: everything its camera
/// rays and cached values depend on besides the cache options (which the file's header
/// holds): scene with camera, size, samples, filter, seed and intersection backend.
pub fn view_key(args: &RenderArgs, scene: &Scene, render: &ProgressiveOptions) -> u64 {
    let text = format!(
        "{:016x}|{}x{}|{}|{:?}|{}|{:?}",
        farm::scene_hash(scene),
        render.width,
        render.height,
        render.spp,
        render.filter,
        render.seed,
        args.accel
    );
    // Never 0, which marks a cache without a view.
    raylink::binary_file::fnv1a(text.as_bytes()).max(1)
}

/// Writes a rendered part (and its AOVs) to the outputs, as EXR with the region as data
/// window, then prints the summary.
#[allow(clippy::too_many_arguments)]
pub fn write_part(
    args: &RenderArgs,
    ctx: &Context,
    region: &Tile,
    (width, height): (u32, u32),
    image: Image,
    stats: RenderStats,
    mut metadata: Metadata,
    out_options: &OutputOptions,
    filter: raylink::image::filter::Filter,
) -> raylink::Result<()> {
    if stats.interrupted {
        // A part is merged as a whole, so an unfinished one is not written at all.
        let signal = raylink::interrupt::signal().unwrap_or(2);
        return Err(Error::Interrupted {
            signal,
            detail: format!(
                "interrupted by {}: a part is written whole or not at all, so nothing was \
                 written",
                raylink::interrupt::name(signal)
            ),
        });
    }
    if stats.invalid > 0 && !args.quiet {
        eprintln!(
            "raylink: warning: {} samples were not finite and were dropped",
            stats.invalid
        );
    }
    let pixels = (region.x1 - region.x0) as f32 * (region.y1 - region.y0) as f32;
    metadata.extend([
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
    ]);
    let window = farm::window(region, width, height);
    for out in &args.outputs {
        write_image_window(out, &image, window, &metadata, out_options)?;
    }
    if args.aov {
        let aovs = raylink::render::aov::render_aovs_region(
            ctx,
            width,
            height,
            region,
            filter,
            args.seed,
            args.threads,
        )?;
        let first = &args.outputs[0];
        let stem = first.file_stem().unwrap_or_default().to_string_lossy();
        for (aov, img) in raylink::render::aov::Aov::ALL.iter().zip(&aovs) {
            let path = first.with_file_name(format!("{stem}.{}.exr", aov.name()));
            write_image_window(&path, img, window, &metadata, out_options)?;
        }
    }
    if !args.quiet {
        eprintln!("tile {}: {}", farm::region_label(region), stats.summary());
    }
    Ok(())
}

/// `raylink precompute`: the irradiance cache (`--cache-file`) of one view, or the
/// illumination network (`--network-file`), computed once and written atomically for render
/// jobs to read.
pub fn run_precompute(mut args: RenderArgs) -> raylink::Result<()> {
    if !args.outputs.is_empty() {
        return Err(Error::Options(
            "precompute writes no image: -o does not apply".into(),
        ));
    }
    if args.part.part().is_some() {
        return Err(Error::Options(
            "precompute covers the whole view: --tile and --crop do not apply".into(),
        ));
    }
    let wanted = match (&args.cache_file, &args.network.network_file) {
        (Some(_), None) => IntegratorName::IrradianceCache,
        (None, Some(_)) => IntegratorName::Network,
        _ => {
            return Err(Error::Options(
                "precompute needs one of --cache-file F (irradiance cache) and \
                 --network-file F (illumination network)"
                    .into(),
            ))
        }
    };
    if let Some(i) = args.integrator.filter(|&i| i != wanted) {
        return Err(Error::Options(format!(
            "--integrator {} does not precompute anything; --cache-file is for \
             irradiance-cache, --network-file for network",
            integrator_name(i)
        )));
    }
    args.integrator = Some(wanted);
    if args.threads == Some(0) {
        return Err(Error::Options("--threads must be at least 1".into()));
    }
    let scene = Scene::load(&args.scene)?;
    super::print_warnings(&scene);
    choose_integrator(&args, &scene)?;
    let width = args.width.unwrap_or(scene.camera.width);
    let height = args.height.unwrap_or(scene.camera.height);
    for (name, v) in [("--width", width), ("--height", height)] {
        if !(1..=MAX_RESOLUTION).contains(&v) {
            return Err(Error::Options(format!(
                "{name} must be between 1 and {MAX_RESOLUTION}, got {v}"
            )));
        }
    }
    let accel = accel::build(&scene, args.accel)?;
    let ctx = Context::new(&scene, accel.as_ref());
    let start = std::time::Instant::now();
    match wanted {
        IntegratorName::IrradianceCache => {
            if args.time_limit.is_some() {
                return Err(Error::Options(
                    "--time-limit does not apply to the irradiance cache: give --spp".into(),
                ));
            }
            // As `raylink render` sets up the same view.
            let options = ProgressiveOptions {
                width,
                height,
                spp: args.spp.or(scene.settings.spp).unwrap_or(16),
                time_limit: None,
                threads: args.threads,
                seed: args.seed,
                progress: !args.quiet,
                filter: choose_filter(&args, &scene)?,
            };
            super::irradiance_cache(&args, &scene, &ctx, &options)?;
        }
        _ => {
            // The network's structure only: a render distributes the light itself.
            let params = super::network_params(&args)?;
            let say = |line: String| {
                if !args.quiet {
                    eprintln!("{line}");
                }
            };
            super::network_structure(&args, &scene, &ctx, params, &say)?;
        }
    }
    if !args.quiet {
        eprintln!("precomputed in {:.2} s", start.elapsed().as_secs_f64());
    }
    Ok(())
}

/// `raylink merge`.
pub fn run_merge(args: MergeArgs) -> raylink::Result<()> {
    for out in &args.outputs {
        check_output_path(out).map_err(|e| Error::Options(e.to_string()))?;
    }
    let merged = farm::merge::merge(&args.parts)?;
    let options = OutputOptions {
        exposure: args.exposure,
        half: args.half,
    };
    for out in &args.outputs {
        write_image(out, &merged.image, &merged.metadata, &options)?;
    }
    Ok(())
}
