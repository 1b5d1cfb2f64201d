//! The `raylink` command line: parses arguments, calls the library, maps errors to exit codes
//! (0 success, 1 a failure while rendering or writing, 2 bad input or options).

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand, ValueEnum};
use raylink::image::output::{check_output_path, write_image, OutputOptions};
use raylink::image::{MetaValue, Metadata};
use raylink::integrators::whitted::{Whitted, WhittedOptions};
use raylink::integrators::{Context, Integrator};
use raylink::render::{
    render, PixelSampling, RenderOptions, DEFAULT_AA_DEPTH, DEFAULT_AA_THRESHOLD,
};
use raylink::scene::{Scene, MAX_RESOLUTION};
use raylink::{accel, Error};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "raylink",
    about = "A global-illumination renderer over Embree",
    long_about = "raylink renders scenes described in TOML files (see docs/scene-format.md) \
                  with Whitted ray tracing, writing EXR, HDR, TIFF, PNG or JPEG through OpenImageIO.\n\n\
                  Example:\n  raylink render scenes/cornell-box.toml -o cornell.exr -o cornell.png"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to one or more image files.
    Render(RenderArgs),
    /// Compare the intersection backends: build time, memory and Mrays/s on a ladder of scenes.
    Bench(raylink::bench::BenchArgs),
}

#[derive(Clone, Copy, ValueEnum)]
enum IntegratorName {
    /// Whitted 1980: recursive reflection, refraction and shadows.
    Whitted,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum AntiAliasing {
    /// Whitted's adaptive corner subdivision.
    Adaptive,
    /// A regular grid of --spp samples in every pixel.
    Uniform,
}

#[derive(clap::Args)]
struct RenderArgs {
    /// The scene file (.toml).
    scene: PathBuf,
    /// Output image; the extension picks the format (.exr .hdr .tif .png .jpg). Repeat for
    /// several formats of the same render.
    #[arg(short, long = "output", required = true, value_name = "FILE")]
    outputs: Vec<PathBuf>,
    /// Light-transport technique.
    #[arg(long, value_enum, default_value = "whitted")]
    integrator: IntegratorName,
    /// Intersection backend: Embree, or the pure-Rust BVH (obvhs). Images match up to
    /// floating-point ties.
    #[arg(long, value_enum, default_value = "embree")]
    accel: accel::Backend,
    /// Image width in pixels (default: the scene's).
    #[arg(long)]
    width: Option<u32>,
    /// Image height in pixels (default: the scene's).
    #[arg(long)]
    height: Option<u32>,
    /// Samples per pixel for uniform supersampling; must be a square (1, 4, 9, 16, ...).
    /// Giving it selects --aa uniform.
    #[arg(long)]
    spp: Option<u32>,
    /// Anti-aliasing: adaptive (default) or uniform supersampling.
    #[arg(long, value_enum)]
    aa: Option<AntiAliasing>,
    /// Adaptive anti-aliasing: largest corner difference accepted without subdividing.
    #[arg(long, default_value_t = DEFAULT_AA_THRESHOLD)]
    aa_threshold: f32,
    /// Adaptive anti-aliasing: deepest subdivision level (each level halves the square).
    #[arg(long, default_value_t = DEFAULT_AA_DEPTH)]
    aa_depth: u32,
    /// Maximum depth of the ray tree.
    #[arg(long, default_value_t = 8)]
    max_depth: u32,
    /// Shadow rays per area light at each shading point.
    #[arg(long, default_value_t = 16)]
    area_samples: u32,
    /// Weight reflection and transmission by Fresnel's law on every material.
    #[arg(long)]
    fresnel: bool,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long)]
    threads: Option<usize>,
    /// Seed of the random streams.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Exposure in stops applied to 8-bit outputs (PNG, JPEG).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// Store EXR pixels as half floats instead of 32-bit floats.
    #[arg(long)]
    half: bool,
    /// No progress bar and no summary line.
    #[arg(short, long)]
    quiet: bool,
}

/// The exit code of a failed run: 2 for bad input or options, 1 for the rest.
fn exit_code(error: &Error) -> u8 {
    match error {
        Error::Input { .. } | Error::Options(_) | Error::Io { .. } => 2,
        _ => 1,
    }
}

fn main() -> ExitCode {
    // Only --version needs Embree's version; don't start a device (and its thread pool) for
    // every other command.
    let asks_version = std::env::args_os()
        .skip(1)
        .any(|a| a == "--version" || a == "-V");
    let version = if asks_version {
        version_string()
    } else {
        raylink::VERSION.to_string()
    };
    let matches = Cli::command().version(version).get_matches();
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    let result = match cli.command {
        Command::Render(args) => run_render(args),
        Command::Bench(args) => raylink::bench::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("raylink: error: {error}");
            ExitCode::from(exit_code(&error))
        }
    }
}

fn version_string() -> String {
    let embree = accel::embree::version().unwrap_or_else(|e| format!("unavailable: {e}"));
    format!(
        "{} (Embree {embree}, OpenImageIO {})",
        raylink::VERSION,
        raylink::image::oiio::version()
    )
}

/// The name the integrator goes by on the command line.
fn integrator_name(name: IntegratorName) -> String {
    name.to_possible_value()
        .expect("integrator names are never skipped")
        .get_name()
        .to_string()
}

fn pixel_sampling(args: &RenderArgs) -> Result<PixelSampling, Error> {
    let aa = args.aa.unwrap_or(if args.spp.is_some() {
        AntiAliasing::Uniform
    } else {
        AntiAliasing::Adaptive
    });
    match aa {
        AntiAliasing::Adaptive => {
            if args.spp.is_some() {
                return Err(Error::Options(
                    "--spp applies to uniform supersampling; adaptive anti-aliasing is set by \
                     --aa-threshold and --aa-depth"
                        .into(),
                ));
            }
            Ok(PixelSampling::Adaptive {
                threshold: args.aa_threshold,
                max_depth: args.aa_depth,
            })
        }
        AntiAliasing::Uniform => {
            let spp = args.spp.unwrap_or(16);
            let n = (spp as f64).sqrt().round() as u32;
            if spp == 0 || n * n != spp {
                return Err(Error::Options(format!(
                    "--spp must be a square number of samples (1, 4, 9, 16, ...), got {spp}"
                )));
            }
            Ok(PixelSampling::Uniform { n })
        }
    }
}

fn run_render(args: RenderArgs) -> raylink::Result<()> {
    // Everything that can be checked is checked before the (possibly long) render.
    let sampling = pixel_sampling(&args)?;
    sampling.validate()?;
    if args.threads == Some(0) {
        return Err(Error::Options("--threads must be at least 1".into()));
    }
    for out in &args.outputs {
        // A bad output path is a bad option: report it before any work is done.
        check_output_path(out).map_err(|e| Error::Options(e.to_string()))?;
    }
    let scene = Scene::load(&args.scene)?;
    let width = args.width.unwrap_or(scene.camera.width);
    let height = args.height.unwrap_or(scene.camera.height);
    for (name, v) in [("--width", width), ("--height", height)] {
        if !(1..=MAX_RESOLUTION).contains(&v) {
            return Err(Error::Options(format!(
                "{name} must be between 1 and {MAX_RESOLUTION}, got {v}"
            )));
        }
    }

    let integrator: Box<dyn Integrator> = match args.integrator {
        IntegratorName::Whitted => Box::new(Whitted::new(WhittedOptions {
            max_depth: args.max_depth.max(1),
            area_samples: args.area_samples,
            fresnel: args.fresnel,
            ..WhittedOptions::default()
        })),
    };
    let accel = accel::build(&scene, args.accel)?;
    let ctx = Context::new(&scene, accel.as_ref());
    let options = RenderOptions {
        width,
        height,
        sampling,
        threads: args.threads,
        seed: args.seed,
        progress: !args.quiet,
    };
    let (image, stats) = render(&ctx, integrator.as_ref(), &options)?;

    let metadata: Metadata = vec![
        (
            "Software".into(),
            MetaValue::Str(format!("raylink {}", raylink::VERSION)),
        ),
        (
            "raylink:scene".into(),
            MetaValue::Str(args.scene.display().to_string()),
        ),
        (
            "raylink:integrator".into(),
            MetaValue::Str(integrator_name(args.integrator)),
        ),
        (
            "raylink:sampling".into(),
            MetaValue::Str(format!("{sampling:?}")),
        ),
        (
            "raylink:samples_per_pixel".into(),
            MetaValue::Float(stats.samples as f32 / (width as f32 * height as f32)),
        ),
        ("raylink:seed".into(), MetaValue::Str(args.seed.to_string())),
        (
            "raylink:render_seconds".into(),
            MetaValue::Float(stats.seconds as f32),
        ),
        (
            "raylink:rays".into(),
            MetaValue::Str(stats.rays.total().to_string()),
        ),
    ];
    let out_options = OutputOptions {
        exposure: args.exposure,
        half: args.half,
    };
    for out in &args.outputs {
        write_image(out, &image, &metadata, &out_options)?;
    }
    if !args.quiet {
        eprintln!("{}", stats.summary());
    }
    Ok(())
}
