//! The `raylink` command line: parses arguments, describes a job, calls the library, and
//! owns what a front end owns: signals, progress bars, printing and exit codes (0 success,
//! 1 a failure while working, 2 bad input or options, 128 + N stopped by signal N).

mod animate;
mod bench;
mod bench_chart;
mod bench_report;
mod farm;
mod log;
mod options;
mod progress;
mod render;
mod serve;
mod signals;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use options::flag;
use raylink::job::{human_size, parse_size};
use raylink::{CancelToken, Control, Error, MemoryBudget, Scene};
use signals::Signals;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

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
struct Args {
    #[command(subcommand)]
    command: Command,
    /// What to print on stderr besides errors: warn (warnings), info (also progress bars,
    /// notes and summary lines; the default) or debug (also what is read and written);
    /// error prints errors only. --quiet lowers info to warn.
    #[arg(
        long,
        value_enum,
        value_name = "LEVEL",
        global = true,
        default_value = "info"
    )]
    log_level: log::Level,
    /// Print everything, as --log-level debug.
    #[arg(long, global = true, conflicts_with = "log_level")]
    verbose: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to one or more image files.
    Render(options::RenderArgs),
    /// Convert a scene (.pbrt or .toml) to a native TOML scene; meshes are written as PLY
    /// files in a NAME.meshes folder beside it.
    Convert(ConvertArgs),
    /// Render a keyframed animation (static camera), retracing in each frame only the pixels
    /// whose rays crossed voxels where something changed; every frame equals a full render.
    Animate(animate::AnimateArgs),
    /// Compare the intersection backends: build time, memory and Mrays/s on a ladder of scenes.
    Bench(bench::BenchArgs),
    /// Compute the irradiance cache of a view (--cache-file F) or the illumination network
    /// (--network-file F) once, for render jobs (--tile, --crop) to read; takes the render
    /// options (docs/farm.md).
    #[command(mut_arg("outputs", |a| a.required(false).hide(true)))]
    Precompute(options::RenderArgs),
    /// Assemble the parts of a render (--tile or --crop EXR files) into the full image,
    /// refusing parts that do not fit together (docs/farm.md).
    Merge(farm::MergeArgs),
    /// Relight a saved illumination network (--network-file, required): new light strengths
    /// (--light NAME=K, --light-scale, the scene file's emissions) and reflectances (the scene
    /// file's materials), no preprocess, then render as `render` does. Light strengths alone
    /// come from a stored light basis (one solution per emissive material) without a
    /// distribution, and so does a new colour for a material with a stored reflectance
    /// series (--reflectance-series).
    Relight(render::RelightArgs),
    /// raylink studio: a live view of the render in the browser (docs/studio.md). Takes the
    /// render options; orbit, pan and zoom restart the render, the network relights, the
    /// page saves images to --save-dir.
    #[command(
        mut_arg("outputs", |a| a.required(false).hide(true)),
        mut_arg("write_interval", |a| a.hide(true)),
        mut_arg("checkpoint_interval", |a| a.hide(true)),
        mut_arg("resume", |a| a.hide(true)),
        mut_arg("aov", |a| a.hide(true)),
        mut_arg("light_passes", |a| a.hide(true)),
        mut_arg("light_groups", |a| a.hide(true)),
        mut_arg("exposure", |a| a.hide(true)),
        mut_arg("half", |a| a.hide(true)),
        mut_arg("tile", |a| a.hide(true)),
        mut_arg("crop", |a| a.hide(true))
    )]
    Serve(serve::ServeArgs),
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
    /// Print nothing but errors and warnings.
    #[arg(short, long)]
    quiet: bool,
}

/// Why a command failed: a library error, a signal that stopped the work, or a failure
/// while working after a signal (exit 1, `detail` saying what was kept and what failed).
pub enum Failure {
    Error(Error),
    Interrupted { signal: i32, detail: String },
    Incomplete { detail: String },
}

impl From<Error> for Failure {
    fn from(e: Error) -> Failure {
        Failure::Error(e)
    }
}

/// What every command shares: the signal handlers, installed before any work.
pub struct Cli {
    signals: Signals,
}

impl Cli {
    /// The controls of a job: the signals' cancel token, the budget of `--max-memory` and
    /// the terminal's progress.
    pub fn control(&self, quiet: bool, max_memory: Option<&str>) -> Result<Control, Failure> {
        let budget = match max_memory {
            None => MemoryBudget::default(),
            Some(size) => MemoryBudget::bytes(
                parse_size(size).map_err(|e| Error::Invalid(format!("--max-memory: {e}")))?,
            ),
        };
        Ok(Control {
            cancel: self.signals.cancel().clone(),
            budget,
            progress: Arc::new(progress::Terminal::new(!log::info(quiet))),
        })
    }

    /// The failure of work stopped by a signal during `stage`, saying what was kept.
    pub fn interrupted(&self, stage: &str, kept: &str) -> Failure {
        Failure::Interrupted {
            signal: self.signals.received().unwrap_or(2),
            detail: format!("{} during {stage}: {kept}", self.stopped_by()),
        }
    }

    /// "interrupted by SIGINT" (or the signal received).
    pub fn stopped_by(&self) -> String {
        let signal = self.signals.received().unwrap_or(2);
        format!("interrupted by {}", signals::name(signal))
    }

    /// `--network-stats` and the like: the technique's statistics.
    pub fn print_report(&self, args: &options::RenderArgs, renderer: &raylink::Renderer) {
        if args.network.network_stats {
            for line in renderer.report() {
                eprintln!("{line}");
            }
        }
    }
}

/// "Too many levels of symbolic links" (a link loop), whose kind std does not name yet.
#[cfg(target_os = "linux")]
const ELOOP: i32 = 40;
#[cfg(not(target_os = "linux"))]
const ELOOP: i32 = 62;

/// The exit code of a failed run: 2 for bad input or options, 1 for a failure while working
/// (a full disk, an I/O error), 128 + N when signal N (`signal`, the one received) stopped it.
fn exit_code(failure: &Failure, signal: Option<i32>) -> u8 {
    use std::io::ErrorKind::{
        InvalidData, InvalidFilename, IsADirectory, NotADirectory, NotFound, PermissionDenied,
    };
    match failure {
        Failure::Error(
            Error::Input { .. }
            | Error::Inputs(_)
            | Error::Setting { .. }
            | Error::Invalid(_)
            | Error::Memory { .. },
        ) => 2,
        // A file the user named that cannot be read as given is bad input; anything else
        // that goes wrong reading or writing is a failure while working.
        Failure::Error(Error::Io { source, .. })
            if matches!(
                source.kind(),
                NotFound
                    | PermissionDenied
                    | IsADirectory
                    | NotADirectory
                    | InvalidData
                    | InvalidFilename
            ) || source.raw_os_error() == Some(ELOOP) =>
        {
            2
        }
        // As a shell reports a process killed by the signal.
        Failure::Interrupted { signal, .. } => (128 + signal).clamp(1, 255) as u8,
        Failure::Error(Error::Cancelled { .. }) => (128 + signal.unwrap_or(2)).clamp(1, 255) as u8,
        Failure::Error(_) | Failure::Incomplete { .. } => 1,
    }
}

/// The one line a failure prints, in the command line's words: settings by their flags.
fn message(cli: &Cli, failure: &Failure) -> String {
    let text = match failure {
        Failure::Interrupted { detail, .. } | Failure::Incomplete { detail } => detail.clone(),
        Failure::Error(Error::Setting { name, detail }) => format!("{} {detail}", flag(name)),
        Failure::Error(Error::Memory {
            what,
            needed,
            limit,
            default_limit,
        }) => format!(
            "{what} would need {} of memory, more than the limit of {}{}",
            human_size(*needed),
            human_size(*limit),
            if *default_limit {
                " (3/4 of the physical memory; raise it with --max-memory)"
            } else {
                " set by --max-memory"
            }
        ),
        Failure::Error(Error::Cancelled { stage }) => {
            let signal = cli.signals.received().unwrap_or(2);
            format!(
                "interrupted by {} during {stage}; nothing was written",
                signals::name(signal)
            )
        }
        Failure::Error(e) => e.to_string(),
    };
    raylink::error::one_line(&text)
}

/// Memory the system refuses ends the program with one line and exit status 1, not an abort.
#[global_allocator]
static ALLOCATOR: raylink::platform::ExitOnOutOfMemory = raylink::platform::ExitOnOutOfMemory;

fn main() -> ExitCode {
    raylink::platform::exit_on_uncaught_exceptions();
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
    let parsed = command()
        .version(version)
        .try_get_matches()
        .and_then(|m| Args::from_arg_matches(&m));
    let args = match parsed {
        Ok(args) => args,
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
    log::set(if args.verbose {
        log::Level::Debug
    } else {
        args.log_level
    });
    if let Err(e) = check_thread_environment() {
        eprintln!("raylink: error: {e}");
        return ExitCode::from(2);
    }
    // The handlers before any work. The commands that keep what they finished cancel their
    // job on a first signal; the others stop at once.
    let graceful = matches!(
        args.command,
        Command::Render(_)
            | Command::Relight(_)
            | Command::Precompute(_)
            | Command::Animate(_)
            | Command::Convert(_)
            | Command::Serve(_)
    );
    let signals = match Signals::install(CancelToken::new(), graceful) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("raylink: error: {e}");
            return ExitCode::from(1);
        }
    };
    let cli = Cli { signals };
    let result = match args.command {
        Command::Render(a) => render::run_render(&cli, a, raylink::Settings::default()),
        Command::Convert(a) => run_convert(&cli, a),
        Command::Animate(a) => animate::run(&cli, &a),
        Command::Bench(a) => bench::run(&a).map_err(Failure::from),
        Command::Precompute(a) => render::run_precompute(&cli, a),
        Command::Merge(a) => farm::run_merge(a),
        Command::Relight(a) => render::run_relight(&cli, a),
        Command::Serve(a) => serve::run(&cli, a),
        Command::GenerateAssets { dir } => generate_assets(&dir).map_err(Failure::from),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            match &failure {
                // Several bad inputs (the files a scene names that are missing): one line each.
                Failure::Error(Error::Inputs(all)) => {
                    for e in all {
                        eprintln!(
                            "raylink: error: {}",
                            raylink::error::one_line(&e.to_string())
                        );
                    }
                }
                _ => eprintln!("raylink: error: {}", message(&cli, &failure)),
            }
            ExitCode::from(exit_code(&failure, cli.signals.received()))
        }
    }
}

/// Rayon's pools take their size from `RAYON_NUM_THREADS` (or the older `RAYON_RS_NUM_CPUS`)
/// where no thread count is given: a count past the limit of `--threads` is refused, as a
/// huge one would start threads until the system has none left, or hang.
fn check_thread_environment() -> Result<(), Error> {
    for name in ["RAYON_NUM_THREADS", "RAYON_RS_NUM_CPUS"] {
        // Rayon ignores what is not a count, and takes 0 for every core.
        let count = std::env::var(name)
            .ok()
            .and_then(|v| v.parse::<usize>().ok());
        if let Some(n) = count.filter(|&n| n > 0) {
            raylink::platform::check_threads(name, n)?;
        }
    }
    Ok(())
}

/// The command line's definition. Every option that takes a value takes a negative number
/// as its value (then refused with the option's own message if it must be positive), not as
/// an unknown option.
fn command() -> clap::Command {
    Args::command().mut_subcommands(|sub| {
        sub.mut_args(|a| {
            if a.get_action().takes_values() && !a.is_positional() {
                a.allow_negative_numbers(true)
            } else {
                a
            }
        })
    })
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

fn run_convert(cli: &Cli, args: ConvertArgs) -> Result<(), Failure> {
    if args.output.extension().and_then(|e| e.to_str()) != Some("toml") {
        return Err(Error::Invalid(format!(
            "{}: the output of convert must be a .toml file",
            args.output.display()
        ))
        .into());
    }
    let control = cli.control(args.quiet, None)?;
    let scene: Scene = render::load_scene(&args.scene, &control)?;
    // Checks every file it writes against the scene's inputs first.
    raylink::scene::convert::write_toml_with(&scene, &args.output, &control.cancel)?;
    Ok(())
}

/// Writes the man pages DIR/man/raylink.1 and raylink-SUBCOMMAND.1 (clap_mangen) and the
/// completions DIR/completions/{raylink.bash,_raylink,raylink.fish} (clap_complete), all from
/// the same definition the program parses, and DIR/lib/libraylink_oiio.so, the interface to
/// OpenImageIO the program carries, to install as /usr/lib/raylink/libraylink_oiio.so (the
/// program loads it from there, and the package's dependencies are computed from it).
fn generate_assets(dir: &std::path::Path) -> raylink::Result<()> {
    use clap_complete::{generate, Generator, Shell};
    let mut cmd = command().version(raylink::VERSION);
    // Everything is made in memory first, then checked against the program's own files as
    // every run's outputs are (raylink::output_paths), then written atomically.
    let mut files: Vec<(&str, PathBuf, Vec<u8>)> = Vec::new();
    fn man_pages(
        cmd: clap::Command,
        dir: &std::path::Path,
        files: &mut Vec<(&str, PathBuf, Vec<u8>)>,
    ) {
        for sub in cmd.get_subcommands().filter(|s| !s.is_hide_set()).cloned() {
            man_pages(sub, dir, files);
        }
        let man = clap_mangen::Man::new(cmd);
        let mut page = Vec::new();
        man.render(&mut page)
            .expect("writing to memory does not fail");
        files.push(("a man page", dir.join(man.get_filename()), page));
    }
    let mut root = cmd.clone().disable_help_subcommand(true);
    root.build();
    man_pages(root, &dir.join("man"), &mut files);
    for shell in [Shell::Bash, Shell::Zsh, Shell::Fish] {
        let mut script = Vec::new();
        generate(shell, &mut cmd, "raylink", &mut script);
        let path = dir.join("completions").join(shell.file_name("raylink"));
        files.push(("a completion script", path, script));
    }
    #[cfg(feature = "oiio")]
    files.push((
        "the OpenImageIO interface",
        dir.join("lib").join(raylink::image::oiio::OBJECT_NAME),
        raylink::image::oiio::object().to_vec(),
    ));

    let mut plan = raylink::output_paths::FilePlan::new();
    // The program and the interface installed beside it, which may be what DIR's files are
    // (or link to), as in a package's staging tree.
    if let Ok(exe) = std::env::current_exe() {
        plan.read("the program", &exe);
        #[cfg(feature = "oiio")]
        if let Some(prefix) = exe.parent().and_then(|bin| bin.parent()) {
            let installed = prefix
                .join("lib/raylink")
                .join(raylink::image::oiio::OBJECT_NAME);
            if installed.is_file() {
                plan.read("the installed OpenImageIO interface", &installed);
            }
        }
    }
    for (what, path, _) in &files {
        plan.write(*what, path);
    }
    plan.check()?;
    for (_, path, bytes) in &files {
        if let Some(folder) = path.parent() {
            std::fs::create_dir_all(folder).map_err(|e| Error::io(folder, e))?;
        }
        raylink::atomic_file::write(path, bytes)?;
    }
    Ok(())
}

fn version_string() -> String {
    let accel = if cfg!(feature = "embree") {
        let version = raylink::accel::embree_version();
        format!(
            "Embree {}",
            version.unwrap_or_else(|e| format!("unavailable: {e}"))
        )
    } else {
        "no Embree: the BVH only".into()
    };
    format!(
        "{} ({accel}, {})",
        raylink::VERSION,
        raylink::image::io::library()
    )
}
