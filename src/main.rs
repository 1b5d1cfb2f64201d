//! The `raylink` command line: parses arguments, calls the library, maps errors to exit codes
//! (0 success, 1 a failure while rendering or writing, 2 bad input or options).

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand, ValueEnum};
use raylink::image::filter::Filter;
use raylink::image::output::{check_output_path, write_image, OutputOptions};
use raylink::image::{MetaValue, Metadata};
use raylink::integrators::bdpt::{Bdpt, BdptOptions};
use raylink::integrators::illumination_network as net;
use raylink::integrators::irradiance_cache::{self as ic, IcOptions, IrradianceCache};
use raylink::integrators::light::{LightOptions, LightTracer};
use raylink::integrators::path::{PathOptions, PathTracer, DEFAULT_MAX_DEPTH, MAX_DEPTH_LIMIT};
use raylink::integrators::whitted::{Whitted, WhittedOptions};
use raylink::integrators::{Context, Integrator, MonteCarlo};
use raylink::render::aov::{render_aovs, Aov};
use raylink::render::checkpoint;
use raylink::render::progressive::{render_progressive_from, Film, ProgressiveOptions, MAX_SPP};
use raylink::render::{
    render, PixelSampling, RenderOptions, DEFAULT_AA_DEPTH, DEFAULT_AA_THRESHOLD,
};
use raylink::scene::{Scene, MAX_RESOLUTION};
use raylink::{accel, Error};
use std::path::PathBuf;
use std::process::ExitCode;

mod farm_cli;

#[derive(Parser)]
#[command(
    name = "raylink",
    about = "A global-illumination renderer over Embree",
    long_about = "raylink renders scenes described in TOML files (scene-format.md) or pbrt-v4 \
                  files (pbrt.md) with Whitted ray tracing, path tracing, light tracing, \
                  bidirectional path tracing, irradiance caching or illumination networks, \
                  and animations with object-space temporal coherence, writing EXR, HDR, \
                  TIFF, PNG or JPEG through OpenImageIO. The documents named here are in \
                  docs/ in the source tree and in /usr/share/doc/raylink/ when installed \
                  from the Debian package.\n\n\
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
    /// Convert a scene (.pbrt or .toml) to a native TOML scene; meshes are written as PLY
    /// files in a NAME.meshes folder beside it.
    Convert(ConvertArgs),
    /// Render a keyframed animation (static camera), retracing in each frame only the pixels
    /// whose rays crossed voxels where something changed; every frame equals a full render.
    Animate(raylink::coherence::animate::AnimateArgs),
    /// Compare the intersection backends: build time, memory and Mrays/s on a ladder of scenes.
    Bench(raylink::bench::BenchArgs),
    /// Compute the irradiance cache of a view (--cache-file F) or the illumination network
    /// (--network-file F) once, for render jobs (--tile, --crop) to read; takes the render
    /// options (docs/farm.md).
    #[command(mut_arg("outputs", |a| a.required(false).hide(true)))]
    Precompute(RenderArgs),
    /// Assemble the parts of a render (--tile or --crop EXR files) into the full image,
    /// refusing parts that do not fit together (docs/farm.md).
    Merge(farm_cli::MergeArgs),
    /// Relight a saved illumination network (--network-file, required): new light strengths
    /// (--light NAME=K, --light-scale, the scene file's emissions) and reflectances (the scene
    /// file's materials), no preprocess, then render as `render` does. Light strengths alone
    /// come from a stored light basis (one solution per emissive material) without a
    /// distribution, and so does a new colour for a material with a stored reflectance
    /// series (--reflectance-series).
    Relight(RelightArgs),
    /// Packaging: write the man page (raylink.1) and the bash, zsh and fish completions
    /// generated from this command line into DIR.
    #[command(hide = true)]
    GenerateAssets {
        /// The directory to write into (created if missing).
        dir: PathBuf,
    },
}

#[derive(clap::Args)]
struct ConvertArgs {
    /// The scene file (.pbrt or .toml).
    scene: PathBuf,
    /// The TOML scene to write.
    #[arg(short, long = "output", value_name = "FILE")]
    output: PathBuf,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum IntegratorName {
    /// Whitted 1980: recursive reflection, refraction and shadows.
    Whitted,
    /// Path tracing with next-event estimation and multiple importance sampling.
    Path,
    /// Light (particle) tracing: paths from the lights, connected to the camera.
    Light,
    /// Bidirectional path tracing, all strategies combined by multiple importance sampling.
    Bdpt,
    /// Ward's irradiance caching: direct and specular as in the path tracer, indirect
    /// diffuse light from cached irradiance values.
    IrradianceCache,
    /// Buckalew & Fussell's illumination networks: a view-independent network of patches and
    /// links, built once (--network-file), lit by a distribution process.
    Network,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum NetworkOrderName {
    /// Jacobi sweeps over every node, in parallel.
    Sweeps,
    /// Largest unshot flux first, one node at a time (all-diffuse networks).
    Shoot,
    /// Conjugate gradients (all-diffuse networks; others use sweeps).
    #[value(name = "cg")]
    ConjugateGradients,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum NetworkBuilderName {
    /// Incremental scan conversion of the polygons (the paper's preprocess).
    Scan,
    /// Repeated closest-hit queries along every line through the intersection backend.
    Embree,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum FilterName {
    Box,
    Triangle,
    Gaussian,
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
    /// The scene file (.toml or .pbrt).
    scene: PathBuf,
    /// Output image; the extension picks the format (.exr .hdr .tif .png .jpg). Repeat for
    /// several formats of the same render.
    #[arg(short, long = "output", required = true, value_name = "FILE")]
    outputs: Vec<PathBuf>,
    /// Light-transport technique.
    /// (default: the scene's, else whitted).
    #[arg(long, value_enum)]
    integrator: Option<IntegratorName>,
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
    /// Samples per pixel (default: the scene's, else 16). For the Whitted integrator it
    /// selects uniform supersampling and must be a square (1, 4, 9, 16, ...).
    #[arg(long)]
    spp: Option<u32>,
    /// Monte Carlo integrators: render whole sample passes until this many seconds have
    /// passed (--spp, if given, still caps the samples).
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    time_limit: Option<f64>,
    /// Monte Carlo integrators: write the outputs after a pass when this many seconds have
    /// passed since the last write, so a long render can be watched.
    #[arg(long, value_name = "SECONDS")]
    write_interval: Option<f64>,
    /// Monte Carlo integrators: save the film every this many seconds (after a pass) to
    /// OUTPUT.checkpoint beside the first output, for --resume. An interrupted render
    /// (SIGINT, SIGTERM) always saves one. The checkpoint is removed when the render ends.
    #[arg(long, value_name = "SECONDS")]
    checkpoint_interval: Option<f64>,
    /// Monte Carlo integrators: continue an interrupted render from OUTPUT.checkpoint (same
    /// scene and options); the image equals that of an uninterrupted render.
    #[arg(long)]
    resume: bool,
    /// Refuse, before allocating, work that needs more memory than this (bytes, or with a
    /// K, M, G or T suffix). Default: 3/4 of the physical memory.
    #[arg(long, value_name = "SIZE")]
    max_memory: Option<String>,
    /// Monte Carlo integrators: pixel reconstruction filter (default: the scene's, else a
    /// Gaussian of radius 1.5 and sigma 0.5, as in pbrt).
    #[arg(long, value_enum)]
    filter: Option<FilterName>,
    /// Radius of the pixel filter in pixels (default 0.5 for box, 2 for triangle, 1.5 for
    /// Gaussian).
    #[arg(long)]
    filter_radius: Option<f32>,
    /// Also write auxiliary images of the first surface seen (albedo, normal, depth) as
    /// STEM.albedo.exr, STEM.normal.exr and STEM.depth.exr beside the first output.
    #[arg(long)]
    aov: bool,
    /// Anti-aliasing: adaptive (default) or uniform supersampling.
    #[arg(long, value_enum)]
    aa: Option<AntiAliasing>,
    /// Adaptive anti-aliasing: largest corner difference accepted without subdividing.
    #[arg(long, default_value_t = DEFAULT_AA_THRESHOLD)]
    aa_threshold: f32,
    /// Adaptive anti-aliasing: deepest subdivision level (each level halves the square).
    #[arg(long, default_value_t = DEFAULT_AA_DEPTH)]
    aa_depth: u32,
    /// Maximum depth of the ray tree (Whitted) or number of bounces (Monte Carlo; 1 is
    /// direct lighting only). Default: the scene's, else 8.
    #[arg(long)]
    max_depth: Option<u32>,
    /// Whitted: shadow rays per area light at each shading point (default 16).
    #[arg(long)]
    area_samples: Option<u32>,
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
    /// Irradiance cache: diffuse bounces, each with its own value set.
    #[arg(long, default_value_t = ic::DEFAULT_BOUNCES)]
    ab: u32,
    /// Irradiance cache: accuracy a (values are used where the estimated error is below a).
    #[arg(long, default_value_t = ic::DEFAULT_ACCURACY)]
    ic_accuracy: f32,
    /// Irradiance cache: rays per primary value at the first bounce (halved per bounce).
    #[arg(long, default_value_t = ic::DEFAULT_SAMPLES)]
    ic_samples: u32,
    /// Irradiance cache: a value's R is at least the scene's size / ar.
    #[arg(long, default_value_t = ic::DEFAULT_AR)]
    ar: f32,
    /// Irradiance cache: load values from this file if it exists, and write the cache to it;
    /// a file holding this view's overture (raylink precompute) is only read.
    #[arg(long, value_name = "FILE")]
    cache_file: Option<PathBuf>,
    /// Irradiance cache: mark the pixels of the first-bounce values the camera sees (red),
    /// as in figure 5b of Ward et al. 1988.
    #[arg(long)]
    show_cache_points: bool,
    #[command(flatten)]
    network: NetworkArgs,
    #[command(flatten)]
    part: farm_cli::PartArgs,
}

/// Options of `raylink relight`.
#[derive(clap::Args)]
struct RelightArgs {
    #[command(flatten)]
    render: RenderArgs,
    /// Multiply the emission of the scene's material NAME by K (repeatable).
    #[arg(long = "light", value_name = "NAME=K")]
    lights: Vec<String>,
    /// Recompute the light basis (one distribution per emissive material) for the scene's
    /// reflectances and store it in the network file, replacing one made for other
    /// reflectances and its reflectance series (a file without a basis gets one on its first
    /// relight anyway).
    #[arg(long)]
    store_basis: bool,
    /// With the light basis, store a reflectance series for the diffuse material NAME
    /// (repeatable): a later relight that gives that material another single colour, the
    /// rest of the scene unchanged, is then a weighted sum of the series' terms, with no
    /// distribution and without reading the link table. Implies --store-basis; costs about
    /// a dozen distributions per material; needs a network of diffuse surfaces.
    #[arg(long = "reflectance-series", value_name = "NAME")]
    reflectance_series: Vec<String>,
}

/// What `raylink relight` adds to a network render.
#[derive(Clone, Default)]
struct RelightSpec {
    lights: Vec<(String, f32)>,
    store_basis: bool,
    reflectance_series: Vec<String>,
}

/// Options of the illumination-network integrator.
#[derive(clap::Args)]
struct NetworkArgs {
    /// Set by `raylink relight`.
    #[arg(skip)]
    relight: Option<RelightSpec>,
    /// Network: slopes per axis S (3·S² links per patch).
    #[arg(long, default_value_t = net::DEFAULT_SLOPES)]
    slopes: u32,
    /// Network: intercept step h, as a fraction of the scene's largest extent.
    #[arg(long, default_value_t = net::DEFAULT_STEP)]
    intercept_step: f32,
    /// Network: patch edge, as a fraction of the scene's largest extent (default: the
    /// intercept step).
    #[arg(long)]
    patch_size: Option<f32>,
    /// Network: intercept jitter, a fraction of the intercept step (0 to 1).
    #[arg(long, default_value_t = 1.0)]
    network_jitter: f32,
    /// Network: how links are found.
    #[arg(long, value_enum, default_value = "scan")]
    network_builder: NetworkBuilderName,
    /// Network: stop distributing when the unshot flux is below this fraction of the emitted
    /// flux (conjugate gradients hold it to a tenth of that: their error is less even).
    #[arg(long, default_value_t = net::DEFAULT_TOLERANCE)]
    tolerance: f32,
    /// Network: load the network from this file if it exists (no preprocess), else build it
    /// and write it there.
    #[arg(long, value_name = "FILE")]
    network_file: Option<PathBuf>,
    /// Network: multiply every emission by this factor (relighting a saved network).
    #[arg(long, default_value_t = 1.0)]
    light_scale: f32,
    /// Network: print patches, links, intersections, memory and timings.
    #[arg(long)]
    network_stats: bool,
    /// Network: order of the distribution.
    #[arg(long, value_enum, default_value = "cg")]
    network_order: NetworkOrderName,
    /// Network: compute direct light per pixel (a light sample and a shadow ray) and take only
    /// the indirect light from the network.
    #[arg(long)]
    network_hybrid: bool,
}

/// The exit code of a failed run: 2 for bad input or options, 1 for the rest.
fn exit_code(error: &Error) -> u8 {
    match error {
        Error::Input { .. } | Error::Options(_) | Error::Io { .. } | Error::Memory(_) => 2,
        // As a shell reports a process killed by the signal.
        Error::Interrupted { signal, .. } => (128 + signal).clamp(1, 255) as u8,
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
    let parsed = Cli::command()
        .version(version)
        .try_get_matches()
        .and_then(|m| Cli::from_arg_matches(&m));
    let cli = match parsed {
        Ok(cli) => cli,
        // --help and --version print as clap does.
        Err(e)
            if !e.use_stderr()
                || e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand =>
        {
            e.exit()
        }
        Err(e) => {
            eprintln!("raylink: {}", one_line_usage_error(&e));
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::Render(args) => run_render(args),
        Command::Convert(args) => run_convert(args),
        Command::Animate(args) => raylink::coherence::animate::run(&args),
        Command::Bench(args) => raylink::bench::run(&args),
        Command::Precompute(args) => farm_cli::run_precompute(args),
        Command::Merge(args) => farm_cli::run_merge(args),
        Command::Relight(args) => run_relight(args),
        Command::GenerateAssets { dir } => generate_assets(&dir),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            // One line whatever the file names or input text hold.
            eprintln!(
                "raylink: error: {}",
                raylink::error::one_line(&error.to_string())
            );
            ExitCode::from(exit_code(&error))
        }
    }
}

/// A command-line error as one line: clap's message and its hint (possible values, a
/// suggestion), without the usage lines.
fn one_line_usage_error(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let parts: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| {
            !l.is_empty() && !l.starts_with("Usage:") && !l.starts_with("For more information")
        })
        .collect();
    parts.join(" ")
}

/// The reader's warnings (what it replaced by a substitute), one line each.
fn print_warnings(scene: &Scene) {
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
}

fn run_convert(args: ConvertArgs) -> raylink::Result<()> {
    if args.output.extension().and_then(|e| e.to_str()) != Some("toml") {
        return Err(Error::Options(format!(
            "{}: the output of convert must be a .toml file",
            args.output.display()
        )));
    }
    let scene = Scene::load(&args.scene)?;
    print_warnings(&scene);
    raylink::scene::convert::write_toml(&scene, &args.output)
}

/// Writes the man pages DIR/man/raylink.1 and raylink-SUBCOMMAND.1 (clap_mangen) and the
/// completions DIR/completions/{raylink.bash,_raylink,raylink.fish} (clap_complete), all from
/// the same `Cli` the program parses.
fn generate_assets(dir: &std::path::Path) -> raylink::Result<()> {
    use clap_complete::{generate_to, Shell};
    let mut cmd = Cli::command().version(raylink::VERSION);
    let man = dir.join("man");
    std::fs::create_dir_all(&man).map_err(|e| Error::io(&man, e))?;
    clap_mangen::generate_to(cmd.clone(), &man).map_err(|e| Error::io(&man, e))?;
    let completions = dir.join("completions");
    std::fs::create_dir_all(&completions).map_err(|e| Error::io(&completions, e))?;
    for shell in [Shell::Bash, Shell::Zsh, Shell::Fish] {
        generate_to(shell, &mut cmd, "raylink", &completions)
            .map_err(|e| Error::io(&completions, e))?;
    }
    Ok(())
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

fn pixel_sampling(args: &RenderArgs, spp: Option<u32>) -> Result<PixelSampling, Error> {
    let aa = args.aa.unwrap_or(if spp.is_some() {
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
            let spp = spp.unwrap_or(16);
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

/// The integrator: the command line's, else the scene's, else Whitted.
fn choose_integrator(args: &RenderArgs, scene: &Scene) -> Result<IntegratorName, Error> {
    if let Some(i) = args.integrator {
        return Ok(i);
    }
    match scene.settings.integrator.as_deref() {
        None => Ok(IntegratorName::Whitted),
        Some(name) => IntegratorName::from_str(name, true).map_err(|_| {
            Error::input(
                &scene.source,
                format!("unknown integrator \"{name}\" in the scene's render settings"),
            )
        }),
    }
}

/// The pixel filter: the command line's, else the scene's, else pbrt's Gaussian.
fn choose_filter(args: &RenderArgs, scene: &Scene) -> Result<Filter, Error> {
    let filter = match args.filter {
        None => {
            let f = scene.settings.filter.unwrap_or_default();
            match args.filter_radius {
                None => f,
                Some(radius) => match f {
                    Filter::Box { .. } => Filter::Box { radius },
                    Filter::Triangle { .. } => Filter::Triangle { radius },
                    Filter::Gaussian { sigma, .. } => Filter::Gaussian { radius, sigma },
                },
            }
        }
        Some(FilterName::Box) => Filter::Box {
            radius: args.filter_radius.unwrap_or(0.5),
        },
        Some(FilterName::Triangle) => Filter::Triangle {
            radius: args.filter_radius.unwrap_or(2.0),
        },
        Some(FilterName::Gaussian) => Filter::Gaussian {
            radius: args.filter_radius.unwrap_or(1.5),
            sigma: 0.5,
        },
    };
    filter
        .validate()
        .map_err(|e| Error::Options(format!("--filter: {e}")))?;
    Ok(filter)
}

fn run_render(mut args: RenderArgs) -> raylink::Result<()> {
    // Everything that can be checked is checked before the (possibly long) render.
    raylink::memory::set_limit_option(args.max_memory.as_deref())?;
    if let Some(t) = args.checkpoint_interval {
        if !(t.is_finite() && t >= 0.0) {
            return Err(Error::Options(format!(
                "--checkpoint-interval must be a non-negative number of seconds, got {t}"
            )));
        }
    }
    raylink::interrupt::install()?;
    if args.threads == Some(0) {
        return Err(Error::Options("--threads must be at least 1".into()));
    }
    farm_cli::resolve_outputs(&mut args)?;
    for out in &args.outputs {
        // A bad output path is a bad option: report it before any work is done.
        check_output_path(out).map_err(|e| Error::Options(e.to_string()))?;
    }
    let mut scene = Scene::load(&args.scene)?;
    print_warnings(&scene);
    let file_emission = relight_lights(&mut scene, &args)?;
    let width = args.width.unwrap_or(scene.camera.width);
    let height = args.height.unwrap_or(scene.camera.height);
    for (name, v) in [("--width", width), ("--height", height)] {
        if !(1..=MAX_RESOLUTION).contains(&v) {
            return Err(Error::Options(format!(
                "{name} must be between 1 and {MAX_RESOLUTION}, got {v}"
            )));
        }
    }
    let integrator = choose_integrator(&args, &scene)?;
    let spp = args.spp.or(scene.settings.spp);
    let max_depth = args
        .max_depth
        .or(scene.settings.max_depth)
        .unwrap_or(DEFAULT_MAX_DEPTH);
    if max_depth > MAX_DEPTH_LIMIT {
        return Err(Error::Options(format!(
            "--max-depth must be at most {MAX_DEPTH_LIMIT}, got {max_depth}"
        )));
    }
    let monte_carlo: Option<Box<dyn MonteCarlo>> = match integrator {
        IntegratorName::Whitted | IntegratorName::Network => None,
        IntegratorName::Path => Some(Box::new(PathTracer::new(PathOptions { max_depth }))),
        IntegratorName::Light => Some(Box::new(LightTracer::new(LightOptions { max_depth }))),
        IntegratorName::Bdpt => Some(Box::new(Bdpt::new(BdptOptions { max_depth }))),
        // Replaced by the irradiance cache once the scene's context exists (it fills its
        // cache before rendering).
        IntegratorName::IrradianceCache => {
            Some(Box::new(PathTracer::new(PathOptions { max_depth })))
        }
    };
    // The film (sums and splats for Monte Carlo), the tiles' results, the image, and the
    // output's conversion buffer; AOVs add three images.
    let per_pixel: u64 =
        if monte_carlo.is_some() { 48 + 24 } else { 24 } + 12 + 16 + if args.aov { 36 } else { 0 };
    raylink::memory::check(
        &format!("a {width}x{height} image"),
        width as u64 * height as u64 * per_pixel,
    )?;
    let whitted_only = [
        ("--aa", args.aa.is_some()),
        ("--area-samples", args.area_samples.is_some()),
        ("--fresnel", args.fresnel),
    ];
    let monte_carlo_only = [
        ("--time-limit", args.time_limit.is_some()),
        ("--write-interval", args.write_interval.is_some()),
        ("--checkpoint-interval", args.checkpoint_interval.is_some()),
        ("--resume", args.resume),
        ("--filter", args.filter.is_some()),
        ("--filter-radius", args.filter_radius.is_some()),
    ];
    let misplaced = if monte_carlo.is_some() {
        whitted_only.iter().find(|o| o.1)
    } else {
        monte_carlo_only.iter().find(|o| o.1)
    };
    if let Some((option, _)) = misplaced {
        return Err(Error::Options(format!(
            "{option} does not apply to the {} integrator",
            integrator_name(integrator)
        )));
    }
    let cache_only = [
        ("--cache-file", args.cache_file.is_some()),
        ("--show-cache-points", args.show_cache_points),
    ];
    if integrator != IntegratorName::IrradianceCache {
        if let Some((option, _)) = cache_only.iter().find(|o| o.1) {
            return Err(Error::Options(format!(
                "{option} applies only to the irradiance-cache integrator, not {}",
                integrator_name(integrator)
            )));
        }
    }
    if integrator == IntegratorName::Network {
        for (option, given) in [
            ("--area-samples", args.area_samples.is_some()),
            ("--fresnel", args.fresnel),
        ] {
            if given {
                return Err(Error::Options(format!(
                    "{option} does not apply to the network integrator"
                )));
            }
        }
    } else if args.network.network_file.is_some() || args.network.network_stats {
        return Err(Error::Options(format!(
            "--network-file and --network-stats apply to the network integrator, not {}",
            integrator_name(integrator)
        )));
    }
    if integrator == IntegratorName::Bdpt {
        Bdpt::check_scene(&scene).map_err(|e| Error::input(&args.scene, e))?;
    }
    let region = farm_cli::region(&args, integrator, width, height)?;
    let settings = farm_cli::settings(&args, &scene, integrator, width, height, max_depth)?;
    let filter = choose_filter(&args, &scene)?;
    let accel = accel::build(&scene, args.accel)?;
    let ctx = Context::new(&scene, accel.as_ref());
    let out_options = OutputOptions {
        exposure: args.exposure,
        half: args.half,
    };
    let mut metadata: Metadata = vec![
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
            MetaValue::Str(integrator_name(integrator)),
        ),
        ("raylink:seed".into(), MetaValue::Str(args.seed.to_string())),
        ("raylink:max_depth".into(), MetaValue::Int(max_depth as i32)),
    ];
    let part = args.part.part().zip(region.as_ref());
    farm_cli::part_metadata(&mut metadata, settings.clone(), &scene, part);

    // A part (--tile, --crop) is written as an EXR data window with what merge checks.
    let write_part = |r: &raylink::render::Tile, image, stats, metadata| {
        farm_cli::write_part(
            &args,
            &ctx,
            r,
            (width, height),
            image,
            stats,
            metadata,
            &out_options,
            filter,
        )
    };
    // What an interrupted render kept, for the closing message.
    let mut partial_note = String::new();
    let (image, stats) = match &monte_carlo {
        None => {
            let sampling = pixel_sampling(&args, spp)?;
            sampling.validate()?;
            let whitted = Whitted::new(WhittedOptions {
                max_depth: max_depth.max(1),
                area_samples: args.area_samples.unwrap_or(16),
                fresnel: args.fresnel,
                ..WhittedOptions::default()
            });
            let options = RenderOptions {
                width,
                height,
                sampling,
                threads: args.threads,
                seed: args.seed,
                progress: !args.quiet,
            };
            metadata.push((
                "raylink:sampling".into(),
                MetaValue::Str(format!("{sampling:?}")),
            ));
            let built;
            let renderer;
            let chosen: &dyn Integrator = if integrator == IntegratorName::Network {
                built = network(&args, &scene, &ctx, &file_emission)?;
                renderer = net::render::NetworkRenderer {
                    net: &built.0,
                    solution: &built.1,
                    hybrid: args.network.network_hybrid,
                };
                &renderer
            } else {
                &whitted
            };
            if let Some(r) = &region {
                let (image, stats) = raylink::farm::render_region(&ctx, chosen, &options, r)?;
                return write_part(r, image, stats, metadata);
            }
            render(&ctx, chosen, &options)?
        }
        Some(estimator) => {
            if let Some(t) = args.write_interval {
                if !(t.is_finite() && t >= 0.0) {
                    return Err(Error::Options(format!(
                        "--write-interval must be a non-negative number of seconds, got {t}"
                    )));
                }
            }
            let options = ProgressiveOptions {
                width,
                height,
                // With a time limit only an explicit --spp caps the samples.
                spp: match (args.spp, args.time_limit) {
                    (Some(n), _) => n,
                    (None, Some(_)) => MAX_SPP,
                    (None, None) => spp.unwrap_or(16),
                },
                time_limit: args.time_limit,
                threads: args.threads,
                seed: args.seed,
                progress: !args.quiet,
                filter,
            };
            metadata.push((
                "raylink:filter".into(),
                MetaValue::Str(format!("{filter:?}")),
            ));
            let built;
            let mut cache_view = None;
            let estimator: &dyn MonteCarlo = if integrator == IntegratorName::IrradianceCache {
                if args.time_limit.is_some() {
                    return Err(Error::Options(
                        "--time-limit does not apply to the irradiance-cache integrator (its \
                         overture traces every sample first): give --spp"
                            .into(),
                    ));
                }
                built = irradiance_cache(&args, &scene, &ctx, &options)?;
                cache_view = Some(&built);
                &built
            } else {
                estimator.as_ref()
            };
            if let Some(r) = &region {
                let (image, stats) =
                    raylink::farm::render_progressive_region(&ctx, estimator, &options, r)?;
                return write_part(r, image, stats, metadata);
            }
            let checkpoint = checkpoint::path_for(&args.outputs[0]);
            // What a resume must match: the settings parts record for merging, with the
            // version and the scene.
            let settings = format!(
                "raylink {} scene {:016x} {settings}",
                raylink::VERSION,
                raylink::farm::scene_hash(&scene)
            );
            let mut resumed_samples = 0;
            let resume = if args.resume {
                if !checkpoint.exists() {
                    return Err(Error::Options(format!(
                        "--resume: there is no checkpoint {} (an interrupted render or \
                         --checkpoint-interval writes one)",
                        checkpoint.display()
                    )));
                }
                let blank = Film::new(width, height, filter);
                let resumed = checkpoint::load(&checkpoint, &settings, blank)?;
                resumed_samples = resumed.samples;
                Some(resumed.film)
            } else {
                None
            };
            let mut last_write = std::time::Instant::now();
            let mut last_checkpoint = std::time::Instant::now();
            let (film, mut stats) =
                render_progressive_from(&ctx, estimator, &options, resume, |film| {
                    if args
                        .checkpoint_interval
                        .is_some_and(|t| last_checkpoint.elapsed().as_secs_f64() >= t)
                        && film.spp < options.spp
                    {
                        // Samples so far are only an estimate here; the image does not use them.
                        let samples = (film.mean_spp() * width as f64 * height as f64) as u64;
                        checkpoint::save(&checkpoint, film, &settings, samples)?;
                        last_checkpoint = std::time::Instant::now();
                    }
                    let due = args
                        .write_interval
                        .is_some_and(|t| last_write.elapsed().as_secs_f64() >= t);
                    if due && film.spp < options.spp {
                        let mut meta = metadata.clone();
                        meta.push((
                            "raylink:samples_per_pixel".into(),
                            MetaValue::Float(film.spp as f32),
                        ));
                        meta.push(("raylink:partial".into(), MetaValue::Int(1)));
                        for out in &args.outputs {
                            write_image(out, &film.image(), &meta, &out_options)?;
                        }
                        last_write = std::time::Instant::now();
                    }
                    Ok(())
                })?;
            stats.samples += resumed_samples;
            stats.invalid = film.invalid;
            if stats.interrupted {
                checkpoint::save(&checkpoint, &film, &settings, stats.samples)?;
                partial_note = format!(
                    "{:.2} of {} samples per pixel; the film is in {} for --resume",
                    film.mean_spp(),
                    options.spp,
                    checkpoint.display()
                );
            } else if checkpoint.exists() {
                // The render is complete: its checkpoint is stale.
                let _ = std::fs::remove_file(&checkpoint);
            }
            let mut image = film.image();
            if let Some(ic) = cache_view.filter(|_| args.show_cache_points) {
                let shown =
                    ic.show_points(&ctx, &mut image, raylink::math::Rgb::new(1.0, 0.0, 0.0));
                if !args.quiet {
                    eprintln!("marked {shown} irradiance cache values");
                }
            }
            (image, stats)
        }
    };
    if stats.invalid > 0 && !args.quiet {
        eprintln!(
            "raylink: warning: {} samples were not finite and were dropped",
            stats.invalid
        );
    }
    if stats.interrupted {
        metadata.push(("raylink:partial".into(), MetaValue::Int(1)));
    }
    metadata.extend([
        (
            "raylink:samples_per_pixel".into(),
            MetaValue::Float(stats.samples as f32 / (width as f32 * height as f32)),
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
    for out in &args.outputs {
        write_image(out, &image, &metadata, &out_options)?;
    }
    if stats.interrupted {
        let signal = raylink::interrupt::signal().unwrap_or(2);
        let outputs: Vec<String> = args
            .outputs
            .iter()
            .map(|p| p.display().to_string())
            .collect();
        return Err(Error::Interrupted {
            signal,
            detail: format!(
                "interrupted by {}: wrote the partial image {} ({})",
                raylink::interrupt::name(signal),
                outputs.join(", "),
                if partial_note.is_empty() {
                    "the tiles finished; the rest is black".to_string()
                } else {
                    partial_note
                }
            ),
        });
    }
    if args.aov {
        let aovs = render_aovs(&ctx, width, height, filter, args.seed, args.threads)?;
        let first = &args.outputs[0];
        let stem = first.file_stem().unwrap_or_default().to_string_lossy();
        for (aov, img) in Aov::ALL.iter().zip(&aovs) {
            let path = first.with_file_name(format!("{stem}.{}.exr", aov.name()));
            write_image(&path, img, &metadata, &out_options)?;
        }
    }
    if !args.quiet {
        eprintln!("{}", stats.summary());
    }
    Ok(())
}

/// Builds the irradiance cache (loading and writing --cache-file) for a width×height view.
fn irradiance_cache(
    args: &RenderArgs,
    scene: &Scene,
    ctx: &Context,
    render: &ProgressiveOptions,
) -> Result<IrradianceCache, Error> {
    let options = IcOptions {
        bounces: args.ab,
        accuracy: args.ic_accuracy,
        samples: args.ic_samples,
        ar: args.ar,
        ..IcOptions::default()
    };
    options.validate().map_err(Error::Options)?;
    // A file that holds this view's whole overture is used as it is and never written, so
    // that render jobs of parts of the view read the values the whole render would
    // (docs/farm.md).
    let view = match &args.cache_file {
        Some(_) => farm_cli::view_key(args, scene, render),
        None => 0,
    };
    let (loaded, frozen) = match &args.cache_file {
        Some(f) if f.exists() => {
            let (cache, key) = ic::file::load_with_view(f, scene, &options)?;
            (Some(cache), key == Some(view))
        }
        _ => (None, false),
    };
    if let (Some(f), false, Some(_)) = (&args.cache_file, frozen, args.part.part()) {
        return Err(Error::input(
            f,
            "missing or not precomputed for this view (scene, size, samples, filter, seed): \
             run `raylink precompute --cache-file` with the render's options first",
        ));
    }
    let start = std::time::Instant::now();
    let integrator = match loaded {
        Some(cache) if frozen => IrradianceCache::frozen(ctx, render, options, cache)?,
        loaded => IrradianceCache::build(ctx, render, options, loaded)?,
    };
    if !args.quiet {
        let stats = &integrator.stats;
        eprintln!(
            "irradiance cache: {} values ({} loaded, {} computed by the overture in {:.2} s, \
             {:.0} rays each); per bounce level: {:?}",
            integrator.cache().len(),
            stats.loaded,
            stats.overture_primaries,
            start.elapsed().as_secs_f64(),
            stats.overture_rays as f64 / stats.overture_primaries.max(1) as f64,
            integrator
                .cache()
                .levels
                .iter()
                .map(|l| l.len())
                .collect::<Vec<_>>()
        );
    }
    match &args.cache_file {
        Some(f) if frozen && !args.quiet => {
            eprintln!(
                "irradiance cache: {} holds this view's overture; read only",
                f.display()
            );
        }
        Some(_) if frozen => {}
        Some(f) => ic::file::save_for_view(f, integrator.cache(), scene, &options, view)?,
        None => {}
    }
    Ok(integrator)
}

/// `raylink relight`: a network render that must load its network and may change the lights.
fn run_relight(args: RelightArgs) -> raylink::Result<()> {
    let mut render = args.render;
    if render
        .integrator
        .is_some_and(|i| i != IntegratorName::Network)
    {
        return Err(Error::Options(
            "relight renders with the network integrator; leave out --integrator".into(),
        ));
    }
    render.integrator = Some(IntegratorName::Network);
    match &render.network.network_file {
        None => {
            return Err(Error::Options(
                "relight needs --network-file FILE (a network saved by raylink render \
                 --network-file)"
                    .into(),
            ))
        }
        Some(f) if !f.exists() => {
            return Err(Error::Options(format!(
                "{}: no such network file (save one with raylink render --network-file)",
                f.display()
            )))
        }
        Some(_) => {}
    }
    let mut lights = Vec::new();
    for l in &args.lights {
        let parsed = l
            .split_once('=')
            .and_then(|(name, k)| Some((name.to_string(), k.trim().parse::<f32>().ok()?)))
            .filter(|(name, k)| !name.is_empty() && k.is_finite() && *k >= 0.0);
        match parsed {
            Some(p) => lights.push(p),
            None => {
                return Err(Error::Options(format!(
                    "--light takes NAME=K with K a non-negative number, got \"{l}\""
                )))
            }
        }
    }
    // A series is stored with a light basis, computed afresh.
    render.network.relight = Some(RelightSpec {
        lights,
        store_basis: args.store_basis || !args.reflectance_series.is_empty(),
        reflectance_series: args.reflectance_series,
    });
    run_render(render)
}

/// Applies `raylink relight`'s --light NAME=K to the scene's materials; returns the
/// emissions as the scene file gives them (one per material).
fn relight_lights(scene: &mut Scene, args: &RenderArgs) -> Result<Vec<raylink::math::Rgb>, Error> {
    let original = scene.materials.iter().map(|m| m.emission).collect();
    for (name, k) in args.network.relight.iter().flat_map(|r| &r.lights) {
        let m = scene
            .materials
            .iter_mut()
            .find(|m| &m.name == name && m.emission.max_element() > 0.0)
            .ok_or_else(|| {
                Error::input(
                    &args.scene,
                    format!("--light {name}: no emissive material named \"{name}\""),
                )
            })?;
        m.emission *= *k;
    }
    for name in args
        .network
        .relight
        .iter()
        .flat_map(|r| &r.reflectance_series)
    {
        if !scene.materials.iter().any(|m| &m.name == name) {
            return Err(Error::input(
                &args.scene,
                format!("--reflectance-series {name}: no material named \"{name}\""),
            ));
        }
    }
    Ok(original)
}

/// Loads (--network-file) or builds the illumination network, then distributes the light.
/// `file_emission` is each material's emission before `raylink relight`'s --light.
fn network(
    args: &RenderArgs,
    scene: &Scene,
    ctx: &Context,
    file_emission: &[raylink::math::Rgb],
) -> Result<(net::Network, net::distribute::Solution), Error> {
    let a = &args.network;
    let params = network_params(args)?;
    if !(a.tolerance > 0.0 && a.tolerance < 1.0) {
        return Err(Error::Options(format!(
            "--tolerance must be between 0 and 1 (exclusive), got {}",
            a.tolerance
        )));
    }
    if !(a.light_scale.is_finite() && a.light_scale >= 0.0) {
        return Err(Error::Options(format!(
            "--light-scale must be a non-negative number, got {}",
            a.light_scale
        )));
    }
    let say = |line: String| {
        if !args.quiet {
            eprintln!("{line}");
        }
    };
    if !scene.lights.is_empty() && !a.network_hybrid {
        eprintln!(
            "raylink: warning: the network carries only emissive surfaces; the scene's point and \
             directional lights light it only with --network-hybrid"
        );
    }
    let options = net::distribute::DistributeOptions {
        tolerance: a.tolerance,
        light_scale: a.light_scale,
        order: match a.network_order {
            NetworkOrderName::Sweeps => net::distribute::Order::Sweeps,
            NetworkOrderName::Shoot => net::distribute::Order::Shoot,
            NetworkOrderName::ConjugateGradients => net::distribute::Order::ConjugateGradients,
        },
        ..Default::default()
    };
    if let (Some(spec), Some(f)) = (&a.relight, &a.network_file) {
        let (network, solution) =
            relight_network(f, spec, scene, file_emission, &params, &options, &say)?;
        if a.network_stats {
            print_network_stats(&network, &solution);
        }
        return Ok((network, solution));
    }
    let network = network_structure(args, scene, ctx, params, &say)?;
    let surfaces = net::distribute::surfaces(&network, scene, options.light_scale);
    check_bounded(&network, scene, &surfaces)?;
    let start = std::time::Instant::now();
    let solution = net::distribute::distribute_surfaces(&network, surfaces, &options, start);
    let st = &solution.stats;
    say(format!(
        "network: distribution in {:.2} s ({} sweeps or shots)",
        st.seconds, st.sweeps
    ));
    if a.network_stats {
        print_network_stats(&network, &solution);
    }
    Ok((network, solution))
}

/// The network's parameters from the options.
fn network_params(args: &RenderArgs) -> Result<net::NetworkParams, Error> {
    let a = &args.network;
    let params = net::NetworkParams {
        slopes: a.slopes,
        step: a.intercept_step,
        patch_size: a.patch_size.unwrap_or(a.intercept_step),
        jitter: a.network_jitter,
        seed: args.seed,
    };
    params.validate().map_err(Error::Options)?;
    Ok(params)
}

/// The network itself, without light: loaded from `--network-file` if it exists, else
/// preprocessed (and saved there). `raylink precompute --network-file` stops here.
fn network_structure(
    args: &RenderArgs,
    scene: &Scene,
    ctx: &Context,
    params: net::NetworkParams,
    say: &dyn Fn(String),
) -> Result<net::Network, Error> {
    let a = &args.network;
    let builder = match a.network_builder {
        NetworkBuilderName::Scan => net::Builder::Scan,
        NetworkBuilderName::Embree => net::Builder::Embree,
    };
    let network = match &a.network_file {
        Some(f) if f.exists() => {
            let start = std::time::Instant::now();
            let n = net::file::load(f, scene, Some(&params))?;
            say(format!(
                "network: loaded {} in {:.2} s (no preprocess): {} nodes",
                f.display(),
                start.elapsed().as_secs_f64(),
                n.nodes()
            ));
            n
        }
        _ => {
            let n = net::Network::build(scene, ctx, params, builder)
                .map_err(|e| Error::input(&args.scene, e))?;
            say(format!(
                "network: preprocess ({:?}) in {:.2} s: {} nodes, {} intersections",
                builder,
                n.stats.seconds,
                n.nodes(),
                n.stats.intersections
            ));
            if let Some(f) = &a.network_file {
                net::file::save(f, &n, scene, None)?;
            }
            n
        }
    };
    Ok(network)
}

/// An error naming the scene file and the material when light in some channel can never be
/// absorbed or leave the scene ([`net::distribute::lossless_channel`]): its radiance has no
/// finite value.
fn check_bounded(
    network: &net::Network,
    scene: &Scene,
    surfaces: &[net::distribute::Surface],
) -> Result<(), Error> {
    match net::distribute::lossless_channel(network, surfaces) {
        None => Ok(()),
        Some((c, node)) => {
            let material = &scene.materials[network.node_material(node, scene).0].name;
            Err(Error::input(
                &scene.source,
                format!(
                    "no {} light emitted by material '{material}' can leave: every surface it \
                     reaches reflects or transmits all of it (diffuse + specular + \
                     transmission = 1) and no line leads out of the scene, so its radiance \
                     grows without bound; lower one of them below 1",
                    ["red", "green", "blue"][c]
                ),
            ))
        }
    }
}

/// `raylink relight`'s network and solution: from the file's light basis when it holds one
/// for these reflectances (reading only the file's prefix: no link table, no distribution),
/// else the whole network and a distribution (storing a basis when the file has none or
/// `--store-basis` asks).
fn relight_network(
    file: &std::path::Path,
    spec: &RelightSpec,
    scene: &Scene,
    file_emission: &[raylink::math::Rgb],
    params: &net::NetworkParams,
    options: &net::distribute::DistributeOptions,
    say: &dyn Fn(String),
) -> Result<(net::Network, net::distribute::Solution), Error> {
    let emission: Vec<_> = scene.materials.iter().map(|m| m.emission).collect();
    let start = std::time::Instant::now();
    let (prefix, basis) = net::file::load_prefix(file, scene, Some(params))?;
    if let Some(b) = basis.as_ref().filter(|_| !spec.store_basis) {
        match b.superpose(&prefix, scene, &emission, options) {
            Ok(solution) => {
                say(format!(
                    "network: relit from the light basis in {} ({} emissive materials) in \
                     {:.3} s: no preprocess, no distribution (0 sweeps), link table not read",
                    file.display(),
                    b.lights.len(),
                    start.elapsed().as_secs_f64()
                ));
                return Ok((prefix, solution));
            }
            // No series stored: nothing more to try before distributing.
            Err(why) if b.series.is_empty() => say(format!("network: {why}; distributing again")),
            Err(why) => match b.from_series(&prefix, scene, &emission, options) {
                Ok((solution, series)) => {
                    say(format!(
                        "network: relit from the reflectance series of '{}' in {} ({} terms) \
                         in {:.3} s: no preprocess, no distribution (0 sweeps), link table not \
                         read",
                        series.name,
                        file.display(),
                        series.terms.len(),
                        start.elapsed().as_secs_f64()
                    ));
                    return Ok((prefix, solution));
                }
                Err(series) => say(format!("network: {why}, and {series}; distributing again")),
            },
        }
    }
    drop(prefix);
    let start = std::time::Instant::now();
    let (network, _) = net::file::load_all(file, scene, Some(params))?;
    say(format!(
        "network: loaded {} in {:.2} s (no preprocess): {} nodes",
        file.display(),
        start.elapsed().as_secs_f64(),
        network.nodes()
    ));
    // A distribution follows: of the lights as they are now, or (a new basis) of the file's.
    let lit: Vec<_> = (emission.iter().zip(file_emission))
        .map(|(&e, &f)| (e * options.light_scale).max(f))
        .collect();
    check_bounded(
        &network,
        scene,
        &net::distribute::surfaces_with(&network, scene, &lit),
    )?;
    let solution = match basis.as_ref().filter(|_| !spec.store_basis) {
        None => {
            let mut b = net::relight::LightBasis::compute(&network, scene, file_emission, options);
            for name in &spec.reflectance_series {
                b.add_series(&network, scene, options, name).map_err(|e| {
                    Error::input(&scene.source, format!("--reflectance-series: {e}"))
                })?;
                let s = b.series.last().expect("a series was added");
                say(format!(
                    "network: reflectance series of '{name}': {} terms ({} sweeps)",
                    s.terms.len(),
                    s.sweeps
                ));
            }
            net::file::save(file, &network, scene, Some(&b))?;
            say(format!(
                "network: distribution of a light basis in {:.2} s ({} emissive materials, {} \
                 sweeps in all), stored in {}",
                b.seconds,
                b.lights.len(),
                b.lights.iter().map(|l| l.sweeps).sum::<u32>(),
                file.display()
            ));
            b.superpose(&network, scene, &emission, options)
                .map_err(|e| Error::input(file, e))?
        }
        // The stored basis, for the old reflectances, is where the distribution starts.
        Some(b) => {
            let solution = b.redistribute(&network, scene, &emission, options);
            say(format!(
                "network: distribution in {:.2} s ({} sweeps or shots{})",
                solution.stats.seconds,
                solution.stats.sweeps,
                if solution.stats.warm_start {
                    ", starting from the stored light basis"
                } else {
                    ""
                }
            ));
            solution
        }
    };
    Ok((network, solution))
}

/// `--network-stats`: patches, links, intersections, memory, timings.
fn print_network_stats(network: &net::Network, solution: &net::distribute::Solution) {
    let st = &solution.stats;
    let bs = &network.stats;
    let links = bs.link_ends / 2;
    eprintln!(
        "network stats: {} polygons, {} patches, {} nodes, {} slots per node\n\
         network stats: {} links ({:.1} per node), {} escapes, {} beyond a slot's first, {} line-patch \
         intersections ({:.1} M/s), {} closest-hit queries\n\
         network stats: memory {:.1} MB network + {:.1} MB buffers, {} map entries\n\
         network stats: preprocess {:.3} s (lines {:.3} s, assembly {:.3} s), distribution {:.3} s, \
         {} sweeps, unshot {:.2e} of emitted",
        network.patches.polygons.len(),
        network.patches.cells,
        network.nodes(),
        network.slots(),
        links,
        bs.link_ends as f64 / network.nodes().max(1) as f64,
        bs.escapes,
        bs.extra,
        bs.intersections,
        bs.intersections as f64 / bs.seconds.max(1e-9) / 1e6,
        bs.rays,
        network.memory() as f64 / 1e6,
        solution.memory() as f64 / 1e6,
        st.map_entries,
        bs.seconds,
        bs.link_seconds,
        bs.assemble_seconds,
        st.seconds,
        st.sweeps,
        st.unshot.iter().sum::<f64>() / st.emitted.iter().sum::<f64>().max(1e-300),
    );
}
