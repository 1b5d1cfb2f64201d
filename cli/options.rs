//! The options of `raylink render`, `precompute` and `relight`, grouped as `--help` shows
//! them, and how they become the library's [`Settings`] and [`Job`]. Settings a scene file
//! gives are the defaults; options override them. An option that does not apply to the
//! chosen integrator is an error naming it.

use clap::ValueEnum;
use raylink::farm::Part;
use raylink::image::display::DisplayAddress;
use raylink::image::filter::Filter;
use raylink::job::{technique_info, AntiAliasing, NetworkBuilder, NetworkOrder, TECHNIQUES};
use raylink::{Backend, Error, Job, Scene, Settings, TechniqueKind, Tile};
use std::path::PathBuf;

const COMMON: &str = "Common options";
const MONTE_CARLO: &str = "Monte Carlo (path, light, bdpt, irradiance-cache)";
const WHITTED: &str = "Whitted and network pixel sampling";
const CACHE: &str = "Irradiance cache";
const NETWORK: &str = "Illumination network";
const SPPM: &str = "Photon mapping (sppm, and vcm's merges)";
const OUTPUT: &str = "Output";
const FARM: &str = "Parts of an image (render farms)";

/// A technique's name on the command line: the registered techniques' names, each with its
/// summary as help (`raylink::job::TECHNIQUES`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntegratorName(pub TechniqueKind);

impl IntegratorName {
    pub fn kind(self) -> TechniqueKind {
        self.0
    }
}

impl ValueEnum for IntegratorName {
    fn value_variants<'a>() -> &'a [Self] {
        static ALL: std::sync::LazyLock<Vec<IntegratorName>> = std::sync::LazyLock::new(|| {
            TECHNIQUES.iter().map(|t| IntegratorName(t.kind)).collect()
        });
        &ALL
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(clap::builder::PossibleValue::new(self.0.name()).help(technique_info(self.0).summary))
    }
}

/// `--accel`'s default: Embree where this build has it, else the BVH.
pub const DEFAULT_ACCEL: &str = if cfg!(feature = "embree") {
    "embree"
} else {
    "bvh"
};

#[derive(Clone, Copy, Debug, PartialEq, ValueEnum)]
pub enum AccelName {
    /// The system Embree.
    Embree,
    /// obvhs's compressed wide BVH, pure Rust.
    Bvh,
}

impl AccelName {
    pub fn backend(self) -> Backend {
        match self {
            AccelName::Embree => Backend::Embree,
            AccelName::Bvh => Backend::Bvh,
        }
    }
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
enum AntiAliasingName {
    /// Whitted's adaptive corner subdivision.
    Adaptive,
    /// A regular grid of --spp samples in every pixel.
    Uniform,
}

#[derive(clap::Args)]
pub struct RenderArgs {
    /// The scene file (.toml or .pbrt).
    pub scene: PathBuf,
    /// Output image; the extension picks the format (.exr .hdr .tif .png .jpg). Repeat for
    /// several formats of the same render. Default: a pbrt scene's Film "filename",
    /// relative to the current directory as in pbrt-v4.
    #[arg(short, long = "output", value_name = "FILE", help_heading = OUTPUT)]
    pub outputs: Vec<PathBuf>,
    /// Light-transport technique (default: the scene's, else whitted).
    #[arg(long, value_enum, help_heading = COMMON)]
    pub integrator: Option<IntegratorName>,
    /// Intersection backend: Embree (the default where raylink is built with it), or the
    /// pure-Rust BVH (obvhs). Images match but where a ray meets a floating-point tie; past
    /// one a Monte Carlo path continues another way, so those images agree in the mean.
    #[arg(long, value_enum, default_value = DEFAULT_ACCEL, help_heading = COMMON)]
    pub accel: AccelName,
    /// Image width in pixels (default: the scene's).
    #[arg(long, help_heading = COMMON)]
    pub width: Option<u32>,
    /// Image height in pixels (default: the scene's).
    #[arg(long, help_heading = COMMON)]
    pub height: Option<u32>,
    /// Samples per pixel (default: the scene's, else 16). For Whitted and the network it
    /// selects uniform supersampling and must be a square (1, 4, 9, 16, ...).
    #[arg(long, help_heading = COMMON)]
    pub spp: Option<u32>,
    /// Maximum depth of the ray tree (Whitted) or number of bounces (Monte Carlo; 1 is
    /// direct lighting only). Default: the scene's, else 8.
    #[arg(long, help_heading = COMMON)]
    pub max_depth: Option<u32>,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long, help_heading = COMMON)]
    pub threads: Option<usize>,
    /// Seed of the random streams.
    #[arg(long, default_value_t = 0, help_heading = COMMON)]
    pub seed: u64,
    /// Refuse, before allocating, work that needs more memory than this (bytes, or with a
    /// K, M, G or T suffix). Default: 3/4 of the physical memory.
    #[arg(long, value_name = "SIZE", help_heading = COMMON)]
    pub max_memory: Option<String>,
    /// No progress bars, notes or summary lines (warnings and errors are still printed).
    #[arg(short, long, help_heading = COMMON)]
    pub quiet: bool,
    /// Render whole sample passes until this many seconds have passed (--spp, if given,
    /// still caps the samples).
    #[arg(long, value_parser = finite_f64, value_name = "SECONDS", allow_negative_numbers = true,
        help_heading = MONTE_CARLO)]
    pub time_limit: Option<f64>,
    /// Adaptive sampling (path tracing): stop sampling a pixel once its estimated error is
    /// below this (Cycles' noise threshold: 0.01 for a final image, 0.1 for a preview). The
    /// render ends when every pixel has, or at --spp (default 4096 with a threshold).
    #[arg(long, value_parser = finite_f32, value_name = "ERROR", allow_negative_numbers = true,
        help_heading = MONTE_CARLO)]
    pub adaptive_threshold: Option<f32>,
    /// Samples every pixel takes before adaptive sampling may stop it (default: 16 /
    /// threshold^0.3, as Cycles).
    #[arg(long, value_name = "N", help_heading = MONTE_CARLO)]
    pub adaptive_min_samples: Option<u32>,
    /// Path guiding (path tracing): learn where light arrives from during the first half of
    /// the samples and draw directions from it as well as from the BSDF (off by default).
    #[arg(long, value_name = "BOOL", help_heading = MONTE_CARLO)]
    pub guiding: Option<bool>,
    /// Spectral mode (path tracing): carry light at three sampled wavelengths instead of
    /// red, green and blue, so glasses disperse and metals reflect by their measured index
    /// (off by default).
    #[arg(long, value_name = "BOOL", help_heading = MONTE_CARLO)]
    pub spectral: Option<bool>,
    /// Scale every sample down so that no channel exceeds this value (pbrt-v4's
    /// maxcomponentvalue): fewer fireflies, but biased; the outputs' metadata says so.
    #[arg(long, value_parser = finite_f32, value_name = "VALUE", allow_negative_numbers = true,
        help_heading = MONTE_CARLO)]
    pub max_component_value: Option<f32>,
    /// Write the outputs after a pass when this many seconds have passed since the last
    /// write, so a long render can be watched.
    #[arg(long, value_parser = finite_f64, value_name = "SECONDS",
        help_heading = MONTE_CARLO)]
    pub write_interval: Option<f64>,
    /// Save the film every this many seconds (after a pass) to OUTPUT.checkpoint beside the
    /// first output, for --resume. An interrupted render (SIGINT, SIGTERM) always saves one.
    /// The checkpoint is removed when the render ends.
    #[arg(long, value_parser = finite_f64, value_name = "SECONDS",
        help_heading = MONTE_CARLO)]
    pub checkpoint_interval: Option<f64>,
    /// Continue an interrupted render from OUTPUT.checkpoint (same scene and options); the
    /// image equals that of an uninterrupted render.
    #[arg(long, help_heading = MONTE_CARLO)]
    pub resume: bool,
    /// Pixel reconstruction filter (default: the scene's, else a Gaussian of radius 1.5 and
    /// sigma 0.5, as in pbrt).
    #[arg(long, value_enum, help_heading = MONTE_CARLO)]
    filter: Option<FilterName>,
    /// Radius of the pixel filter in pixels (default 0.5 for box, 2 for triangle, 1.5 for
    /// Gaussian).
    #[arg(long, value_parser = finite_f32, help_heading = MONTE_CARLO)]
    filter_radius: Option<f32>,
    /// Anti-aliasing: adaptive (default) or uniform supersampling.
    #[arg(long, value_enum, help_heading = WHITTED)]
    aa: Option<AntiAliasingName>,
    /// Adaptive anti-aliasing: largest corner difference accepted without subdividing
    /// (default 0.1).
    #[arg(long, value_parser = finite_f32, help_heading = WHITTED)]
    aa_threshold: Option<f32>,
    /// Adaptive anti-aliasing: deepest subdivision level, each level halving the square
    /// (default 3).
    #[arg(long, help_heading = WHITTED)]
    aa_depth: Option<u32>,
    /// Whitted: shadow rays per area light at each shading point (default 16).
    #[arg(long, help_heading = WHITTED)]
    area_samples: Option<u32>,
    /// Whitted: weight reflection and transmission by Fresnel's law on every material.
    #[arg(long, help_heading = WHITTED)]
    fresnel: bool,
    /// Diffuse bounces, each with its own value set (default 4).
    #[arg(long, help_heading = CACHE)]
    ab: Option<u32>,
    /// Accuracy a: values are used where the estimated error is below a (default 0.15).
    #[arg(long, value_parser = finite_f32, help_heading = CACHE)]
    ic_accuracy: Option<f32>,
    /// Rays per primary value at the first bounce, halved per bounce (default 512).
    #[arg(long, help_heading = CACHE)]
    ic_samples: Option<u32>,
    /// Ward & Heckbert's irradiance gradients: each value follows the irradiance around it
    /// (default true).
    #[arg(long, value_name = "BOOL", help_heading = CACHE)]
    ic_gradients: Option<bool>,
    /// A value's R is at least the scene's size / ar (default 64).
    #[arg(long, value_parser = finite_f32, help_heading = CACHE)]
    ar: Option<f32>,
    /// Load values from this file if it exists, and write the cache to it; a file holding
    /// this view's overture (raylink precompute) is only read.
    #[arg(long, value_name = "FILE", help_heading = CACHE)]
    pub cache_file: Option<PathBuf>,
    /// Mark the pixels of the first-bounce values the camera sees (red), as in figure 5b of
    /// Ward et al. 1988.
    #[arg(long, help_heading = CACHE)]
    show_cache_points: bool,
    /// Photons shot per iteration (default: the image's pixel count); --spp gives the
    /// iterations.
    #[arg(long, value_name = "N", help_heading = SPPM)]
    photons_per_iteration: Option<u32>,
    /// Initial photon search radius in scene units (default: 1/200 of the scene's
    /// bounding-box diagonal); it shrinks as photons arrive (sppm) or as iterations go on
    /// (vcm's merge radius).
    #[arg(long, value_parser = finite_f32, value_name = "RADIUS", allow_negative_numbers = true,
        help_heading = SPPM)]
    sppm_radius: Option<f32>,
    #[command(flatten)]
    pub network: NetworkArgs,
    #[command(flatten)]
    pub part: PartArgs,
    /// Also write auxiliary images of the first surface seen (albedo, normal, depth) as
    /// STEM.albedo.exr, STEM.normal.exr and STEM.depth.exr beside the first output, and
    /// store them, with position (P) and object and material indices (IndexOB, IndexMA),
    /// as layers of each EXR output; the path tracer adds each pixel's sample variance,
    /// error estimate and sample count (variance, error, samples).
    #[arg(long, help_heading = OUTPUT)]
    pub aov: bool,
    /// With --aov, the path tracer's light passes as further layers of each EXR output,
    /// named as Blender Cycles names them: DiffDir, DiffInd, DiffCol, GlossDir, GlossInd,
    /// GlossCol, TransDir, TransInd, TransCol, Emit, Env. Takes the image's samples again.
    #[arg(long, requires = "aov", help_heading = OUTPUT)]
    pub light_passes: bool,
    /// With --light-passes, a layer for each light alone (Combined_light0, ...: emitting
    /// shapes, then lights, then the background), at most 64.
    #[arg(long, requires = "light_passes", help_heading = OUTPUT)]
    pub light_groups: bool,
    /// Exposure in stops applied to 8-bit outputs (PNG, JPEG).
    #[arg(long, value_parser = finite_f32, allow_negative_numbers = true,
        help_heading = OUTPUT)]
    pub exposure: Option<f32>,
    /// Store EXR pixels as half floats instead of 32-bit floats.
    #[arg(long, help_heading = OUTPUT)]
    pub half: bool,
    /// The RGB of the linear outputs (EXR, HDR, TIFF): srgb (linear sRGB, the default),
    /// rec2020, dci-p3 or aces2065-1, converted from the render's linear sRGB (unclipped,
    /// so spectral renders keep colours outside sRGB); EXR files record the primaries in
    /// their chromaticities. PNG and JPEG outputs stay sRGB.
    #[arg(long, value_name = "NAME", help_heading = OUTPUT)]
    pub color_space: Option<String>,
    /// Show the image in the tev viewer as it renders (tev listens on 127.0.0.1:14158), as
    /// pbrt-v4's --display-server: progressive techniques update it a few times a second,
    /// the others show the final image. The render does not wait for the viewer.
    #[arg(long, value_name = "HOST:PORT", help_heading = OUTPUT)]
    pub display_server: Option<String>,
}

/// Options of the illumination-network integrator.
#[derive(clap::Args)]
pub struct NetworkArgs {
    /// Slopes per axis S (3·S² links per patch; default 12).
    #[arg(long, help_heading = NETWORK)]
    slopes: Option<u32>,
    /// Intercept step h, as a fraction of the scene's largest extent (default 1/64).
    #[arg(long, value_parser = finite_f32, help_heading = NETWORK)]
    intercept_step: Option<f32>,
    /// Patch edge, as a fraction of the scene's largest extent (default: the intercept
    /// step).
    #[arg(long, value_parser = finite_f32, help_heading = NETWORK)]
    patch_size: Option<f32>,
    /// Intercept jitter, a fraction of the intercept step (0 to 1; default 1).
    #[arg(long, value_parser = finite_f32, help_heading = NETWORK)]
    network_jitter: Option<f32>,
    /// How links are found (default scan).
    #[arg(long, value_enum, help_heading = NETWORK)]
    network_builder: Option<NetworkBuilderName>,
    /// Stop distributing when the unshot flux is below this fraction of the emitted flux
    /// (default 0.001; conjugate gradients hold it to a tenth of that: their error is less
    /// even).
    #[arg(long, value_parser = finite_f32, help_heading = NETWORK)]
    tolerance: Option<f32>,
    /// Load the network from this file if it exists (no preprocess), else build it and
    /// write it there.
    #[arg(long, value_name = "FILE", help_heading = NETWORK)]
    pub network_file: Option<PathBuf>,
    /// Multiply every emission by this factor (relighting a saved network; default 1).
    #[arg(long, value_parser = finite_f32, help_heading = NETWORK)]
    light_scale: Option<f32>,
    /// Print patches, links, intersections, memory and timings.
    #[arg(long, help_heading = NETWORK)]
    pub network_stats: bool,
    /// Order of the distribution (default cg).
    #[arg(long, value_enum, help_heading = NETWORK)]
    network_order: Option<NetworkOrderName>,
    /// Compute direct light per pixel (a light sample and a shadow ray) and take only the
    /// indirect light from the network.
    #[arg(long, help_heading = NETWORK)]
    network_hybrid: bool,
}

/// A 64-bit float option: NaN and the infinities are refused (clap's message names the
/// option), as is a number beyond the type's range ("1e999").
pub fn finite_f64(text: &str) -> Result<f64, String> {
    let v: f64 = text.trim().parse().map_err(|e| format!("{e}"))?;
    if !v.is_finite() {
        return Err(format!("must be a finite number, got {v}"));
    }
    Ok(v)
}

/// [`finite_f64`] for a 32-bit float option ("1e39" is beyond its range).
pub fn finite_f32(text: &str) -> Result<f32, String> {
    let v: f32 = text.trim().parse().map_err(|e| format!("{e}"))?;
    if !v.is_finite() {
        return Err(format!("must be a finite number, got {v}"));
    }
    Ok(v)
}

/// The command-line name of a setting, for messages.
pub fn flag(setting: &str) -> String {
    match setting {
        "region" => "--tile/--crop".into(),
        "relight" => "--light".into(),
        s => format!("--{}", s.replace('_', "-")),
    }
}

/// `e` as the user should read it: a bad value the scene file gives (not one of the
/// options' settings `given`) is reported at its line there.
pub fn locate(e: Error, scene: &Scene, given: &Settings) -> Error {
    match &e {
        Error::Setting { name, .. } if !given.given().contains(&name.as_str()) => scene.locate(e),
        _ => e,
    }
}

/// The settings the options give (only those given).
pub fn given_settings(args: &RenderArgs, scene: &Scene) -> Settings {
    let n = &args.network;
    let name = args.filter.map(|name| match name {
        FilterName::Box => "box",
        FilterName::Triangle => "triangle",
        FilterName::Gaussian => "gaussian",
    });
    // The names are clap's choices: every one is known.
    let filter = Filter::given(scene.settings.filter, name, args.filter_radius).unwrap_or_default();
    Settings {
        integrator: args.integrator.map(IntegratorName::kind),
        spp: args.spp,
        max_depth: args.max_depth,
        time_limit: args.time_limit,
        adaptive_threshold: args.adaptive_threshold,
        adaptive_min_samples: args.adaptive_min_samples,
        guiding: args.guiding,
        spectral: args.spectral,
        max_component_value: args.max_component_value,
        filter,
        aa: args.aa.map(|a| match a {
            AntiAliasingName::Adaptive => AntiAliasing::Adaptive,
            AntiAliasingName::Uniform => AntiAliasing::Uniform,
        }),
        aa_threshold: args.aa_threshold,
        aa_depth: args.aa_depth,
        area_samples: args.area_samples,
        fresnel: args.fresnel.then_some(true),
        ab: args.ab,
        ic_accuracy: args.ic_accuracy,
        ic_samples: args.ic_samples,
        ic_gradients: args.ic_gradients,
        ar: args.ar,
        cache_file: args.cache_file.clone(),
        show_cache_points: args.show_cache_points.then_some(true),
        slopes: n.slopes,
        intercept_step: n.intercept_step,
        patch_size: n.patch_size,
        network_jitter: n.network_jitter,
        network_builder: n.network_builder.map(|b| match b {
            NetworkBuilderName::Scan => NetworkBuilder::Scan,
            NetworkBuilderName::Embree => NetworkBuilder::Embree,
        }),
        tolerance: n.tolerance,
        network_file: n.network_file.clone(),
        light_scale: n.light_scale,
        network_order: n.network_order.map(|o| match o {
            NetworkOrderName::Sweeps => NetworkOrder::Sweeps,
            NetworkOrderName::Shoot => NetworkOrder::Shoot,
            NetworkOrderName::ConjugateGradients => NetworkOrder::ConjugateGradients,
        }),
        network_hybrid: n.network_hybrid.then_some(true),
        relight: None,
        photons_per_iteration: args.photons_per_iteration,
        sppm_radius: args.sppm_radius,
    }
}

/// An option that is not a setting: its name, whether it was given, and the integrators it
/// applies to.
type OtherOption = (&'static str, bool, fn(TechniqueKind) -> bool);

/// The options other than settings that apply only to some integrators.
fn other_options(args: &RenderArgs) -> [OtherOption; 4] {
    let progressive = |k: TechniqueKind| technique_info(k).progressive;
    [
        (
            "--write-interval",
            args.write_interval.is_some(),
            progressive,
        ),
        (
            "--checkpoint-interval",
            args.checkpoint_interval.is_some(),
            progressive,
        ),
        ("--resume", args.resume, progressive),
        ("--network-stats", args.network.network_stats, |k| {
            k == TechniqueKind::Network
        }),
    ]
}

/// The job the options and the scene describe: the scene's settings overridden by the
/// options, each option checked to apply to the integrator chosen.
pub fn job(args: &RenderArgs, scene: &Scene, extra: Settings) -> Result<Job, Error> {
    let flags = given_settings(args, scene).overlaid(&extra);
    let technique = raylink::job::technique_for(scene, &flags).map_err(|e| match e {
        // The filter's radius alone is given as its own option.
        Error::Setting { name, detail }
            if name == "filter" && args.filter.is_none() && detail.starts_with("does not") =>
        {
            Error::Invalid(format!("--filter-radius {detail}"))
        }
        e => e,
    })?;
    let kind = technique.kind();
    for (option, given, applies) in other_options(args) {
        if given && !applies(kind) {
            return Err(Error::Invalid(format!(
                "{option} does not apply to the {kind} integrator"
            )));
        }
    }
    Ok(Job {
        width: args.width.unwrap_or(scene.camera.width),
        height: args.height.unwrap_or(scene.camera.height),
        seed: args.seed,
        threads: args.threads,
        accel: args.accel.backend(),
        // The variance, error and sample-count layers of the EXR outputs.
        statistics: args.aov,
        ..Job::new(scene, technique)
    })
}

/// Checks of the options alone, before the scene is read.
pub fn check(args: &RenderArgs) -> Result<(), Error> {
    if let Some(address) = &args.display_server {
        address.parse::<DisplayAddress>()?;
    }
    for (name, v) in [
        ("--checkpoint-interval", args.checkpoint_interval),
        ("--write-interval", args.write_interval),
    ] {
        if let Some(t) = v {
            if !(t.is_finite() && t >= 0.0) {
                return Err(Error::Invalid(format!(
                    "{name} must be a non-negative number of seconds, got {t}"
                )));
            }
        }
    }
    if let Some(e) = args.exposure {
        if !e.is_finite() {
            return Err(Error::Invalid(format!(
                "--exposure must be a finite number of stops, got {e}"
            )));
        }
    }
    if args.threads == Some(0) {
        return Err(Error::setting("threads", "must be at least 1"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use clap::error::ErrorKind;
    use clap::CommandFactory;

    /// Every registered technique is a value of `--integrator`, and every setting a
    /// registered technique reads has its option, which gives that setting: the command
    /// line cannot miss a technique or a setting of one.
    #[test]
    fn the_options_cover_every_registered_technique() {
        use clap::Parser;
        use raylink::job::TECHNIQUES;
        let command = crate::Args::command();
        let render = command.find_subcommand("render").unwrap();
        let integrator = render
            .get_arguments()
            .find(|a| a.get_long() == Some("integrator"))
            .unwrap();
        let values: Vec<String> = integrator
            .get_possible_values()
            .iter()
            .map(|v| v.get_name().to_string())
            .collect();
        let names: Vec<String> = TECHNIQUES.iter().map(|t| t.kind.name().into()).collect();
        assert_eq!(values, names);
        let scene = raylink::Scene::load("scenes/cornell-box.toml".as_ref()).unwrap();
        for technique in TECHNIQUES {
            for setting in technique.all_settings() {
                let option = super::flag(setting.name);
                let long = option.trim_start_matches("--");
                let has = |sub: &str| {
                    command
                        .find_subcommand(sub)
                        .unwrap()
                        .get_arguments()
                        .any(|a| a.get_long() == Some(long))
                };
                if setting.name == "relight" {
                    // Only the relight command relights.
                    assert!(has("relight"), "relight has no {option}");
                    continue;
                }
                assert!(
                    has("render"),
                    "render has no {option} for {}",
                    technique.kind
                );
                // The option given alone sets its setting (a boolean that takes no value
                // is a flag).
                let takes_value = command
                    .find_subcommand("render")
                    .unwrap()
                    .get_arguments()
                    .find(|a| a.get_long() == Some(long))
                    .is_some_and(|a| a.get_action().takes_values());
                let value = match setting.example {
                    "true" if !takes_value => None,
                    e if e.starts_with('{') => Some("box".to_string()),
                    e => Some(e.trim_matches('"').to_string()),
                };
                let mut argv = vec!["raylink", "render", "s.toml", "-o", "x.exr", &option];
                if let Some(v) = &value {
                    argv.push(v);
                }
                let parsed =
                    crate::Args::try_parse_from(&argv).unwrap_or_else(|e| panic!("{argv:?}: {e}"));
                let crate::Command::Render(args) = parsed.command else {
                    unreachable!()
                };
                let given = super::given_settings(&args, &scene);
                assert_eq!(given.given(), vec![setting.name], "{argv:?}");
            }
        }
    }

    /// Every option of every subcommand that takes a number (found from the command itself:
    /// the options whose value clap parses, refusing "abc", that are not a choice of names;
    /// so a new option is covered as it comes) refuses NaN, the infinities and numbers
    /// beyond its type's range, naming the option. (tests/bad_inputs/options.txt runs some
    /// through the program: exit code 2, one line.)
    #[test]
    fn nan_and_infinities_are_refused_by_every_numeric_option() {
        let command = crate::Args::command();
        let mut numeric = Vec::new();
        for sub in command.get_subcommands() {
            let name = sub.get_name();
            for arg in sub.get_arguments() {
                let Some(long) = arg.get_long() else { continue };
                if !arg.get_action().takes_values() || !arg.get_possible_values().is_empty() {
                    continue;
                }
                let parse = |value: &str| {
                    command.clone().try_get_matches_from([
                        "raylink",
                        name,
                        &format!("--{long}={value}"),
                    ])
                };
                match parse("abc") {
                    Err(e) if e.kind() == ErrorKind::ValueValidation => {
                        numeric.push((name.to_string(), long.to_string()))
                    }
                    _ => continue,
                }
                for value in ["nan", "NaN", "inf", "-inf", "infinity", "1e999"] {
                    let case = format!("raylink {name} --{long}={value}");
                    match parse(value) {
                        Err(e) => {
                            let text = e.to_string();
                            assert_eq!(e.kind(), ErrorKind::ValueValidation, "{case}: {text}");
                            assert!(
                                text.contains(&format!("'--{long} <")) && text.contains(value),
                                "{case}: {text}"
                            );
                        }
                        Ok(_) => panic!("{case} is accepted"),
                    }
                }
            }
        }
        let names: Vec<String> = numeric.iter().map(|(s, o)| format!("{s} --{o}")).collect();
        for known in [
            "render --aa-threshold",
            "render --time-limit",
            "render --width",
            "render --exposure",
            "precompute --intercept-step",
            "relight --light-scale",
            "relight --tolerance",
            "animate --exposure",
            "animate --voxels",
            "merge --exposure",
            "bench --network-steps",
        ] {
            assert!(names.iter().any(|n| n == known), "{known} not in {names:?}");
        }
        assert!(names.len() > 80, "{} numeric options", names.len());
    }
}

/// Options of `raylink render` that select a part of the image.
#[derive(clap::Args)]
pub struct PartArgs {
    /// Render only tile I of N (0 <= I < N): the image cut into N horizontal bands of equal
    /// height (to a row). Written as EXR with the band as its data window, for `raylink
    /// merge`. `{tile}` and `{tiles}` in -o names become I and N.
    #[arg(long, value_name = "I/N", value_parser = parse_tile, conflicts_with = "crop",
          help_heading = FARM)]
    tile: Option<Part>,
    /// Render only the pixels x0 <= x < x1, y0 <= y < y1 (0,0 is the top-left pixel; x1 and y1
    /// are excluded). Written as EXR with those pixels as its data window; other formats hold
    /// the crop alone.
    #[arg(long, value_name = "x0,y0,x1,y1", value_parser = parse_crop, help_heading = FARM)]
    crop: Option<Part>,
}

/// Parses `I/N` (0 ≤ I < N).
pub(crate) fn parse_tile(text: &str) -> std::result::Result<Part, String> {
    let bad = || format!("takes I/N with 0 <= I < N (e.g. 0/4), got \"{text}\"");
    let (i, n) = text.split_once('/').ok_or_else(bad)?;
    let index: u32 = i.trim().parse().map_err(|_| bad())?;
    let count: u32 = n.trim().parse().map_err(|_| bad())?;
    if count == 0 || index >= count {
        return Err(bad());
    }
    Ok(Part::Tile { index, count })
}

/// Parses `x0,y0,x1,y1` (half-open pixel bounds, x0 < x1, y0 < y1).
pub(crate) fn parse_crop(text: &str) -> std::result::Result<Part, String> {
    let bad = || {
        format!(
            "takes pixel bounds x0,y0,x1,y1 with x0 < x1 and y0 < y1 (x1 and y1 \
             excluded), got \"{text}\""
        )
    };
    let v: Vec<u32> = text
        .split(',')
        .map(|s| s.trim().parse::<u32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| bad())?;
    match v[..] {
        [x0, y0, x1, y1] if x0 < x1 && y0 < y1 => Ok(Part::Crop(Tile { x0, y0, x1, y1 })),
        _ => Err(bad()),
    }
}

impl PartArgs {
    pub fn part(&self) -> Option<&Part> {
        self.tile.as_ref().or(self.crop.as_ref())
    }
}
