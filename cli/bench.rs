//! `raylink bench`: the options, and the reports the library's measurements are written to
//! (the terminal, Markdown, CSV and an SVG chart).

use crate::bench_report as report;
use crate::options::AccelName;
use raylink::bench::{equal_error, measure, network, path, scenes, BenchConfig};
use raylink::{Error, Result};
use std::path::PathBuf;

/// `--backends`' default: every backend this build has.
const BACKENDS: &str = if cfg!(feature = "embree") {
    "embree,bvh"
} else {
    "bvh"
};

/// Options of `raylink bench`.
#[derive(Clone, Debug, clap::Args)]
pub struct BenchArgs {
    /// Comma-separated scenes: cornell (scenes/cornell-box.toml), spheres-N, terrain-N (N
    /// triangles, like 10k or 1m) or .toml scene files [default: the full ladder, or a small
    /// one with --quick].
    #[arg(long, value_delimiter = ',')]
    pub scenes: Option<Vec<String>>,
    /// Comma-separated backends to measure (default: both, or the BVH alone in a build
    /// without Embree).
    #[arg(long, value_enum, value_delimiter = ',', default_value = BACKENDS)]
    pub backends: Vec<AccelName>,
    /// Comma-separated thread counts [default: 1 and all cores].
    #[arg(long, value_delimiter = ',')]
    pub threads: Option<Vec<usize>>,
    /// Timed repetitions of each ray kind [default: 7, 2 with --quick; with --path-tracer
    /// at least 3, default 7, 3 with --quick].
    #[arg(long)]
    pub reps: Option<usize>,
    /// Untimed warm-up runs before the repetitions [default: 2, 1 with --quick].
    #[arg(long)]
    pub warmup: Option<usize>,
    /// Timed builds per backend and thread count [default: 3, 1 with --quick].
    #[arg(long)]
    pub build_reps: Option<usize>,
    /// Width of the camera ray grid [default: 640, 64 with --quick].
    #[arg(long)]
    pub width: Option<u32>,
    /// Height of the camera ray grid [default: 480, 48 with --quick].
    #[arg(long)]
    pub height: Option<u32>,
    /// Seed of the ray sets.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// A small run for checking that everything works (seconds, not minutes).
    #[arg(long)]
    pub quick: bool,
    /// Directory for bench.csv, bench.svg and bench.md.
    #[arg(long, default_value = "bench-results")]
    pub out: PathBuf,
    /// No progress lines on stderr.
    #[arg(short, long)]
    pub quiet: bool,
    /// Measure the path tracer instead, per backend and thread count, the runs interleaved:
    /// paths/s and Mrays/s on the Cornell box (512x512 unless --width/--height, max depth 8),
    /// and the time to RMSE 0.0056 against Tungsten's render (256x256, 64 spp per render, 4
    /// with --quick, 7 bounces); the load average before and after; writes path.md.
    #[arg(long)]
    pub path_tracer: bool,
    /// Measure illumination networks instead (the office scene, or the first of --scenes, at
    /// --network-steps): preprocess with both builders, distribution, render, relighting
    /// against a full rebuild; writes network.md. --reps defaults to 3 here, --build-reps
    /// (Embree builds) to 1.
    #[arg(long)]
    pub network: bool,
    /// Network bench: comma-separated intercept steps, one network each [default:
    /// 0.03125,0.0078125 (16× the patches); 0.0625,0.03125 with --quick].
    #[arg(long, value_parser = crate::options::finite_f32, value_delimiter = ',')]
    pub network_steps: Option<Vec<f32>>,
    /// Network bench: slopes per axis [default: 20, the paper's 1,200 links per patch; 8
    /// with --quick].
    #[arg(long)]
    pub network_slopes: Option<u32>,
}

/// The bench's configuration from the options.
fn config(args: &BenchArgs) -> Result<BenchConfig> {
    let q = args.quick;
    let all = raylink::platform::cores();
    let mut threads = args.threads.clone().unwrap_or_else(|| vec![1, all]);
    threads.dedup();
    let ladder = if q {
        scenes::QUICK_LADDER
    } else {
        scenes::DEFAULT_LADDER
    };
    let config = BenchConfig {
        scenes: args
            .scenes
            .clone()
            .unwrap_or_else(|| ladder.split(',').map(String::from).collect()),
        backends: args.backends.iter().map(|b| b.backend()).collect(),
        threads,
        reps: args.reps.unwrap_or(match (q, args.path_tracer) {
            (false, _) => 7,
            (true, false) => 2,
            (true, true) => path::MIN_REPS,
        }),
        warmup: args.warmup.unwrap_or(if q { 1 } else { 2 }),
        build_reps: args.build_reps.unwrap_or(if q { 1 } else { 3 }),
        width: args.width.unwrap_or(if q { 64 } else { 640 }),
        height: args.height.unwrap_or(if q { 48 } else { 480 }),
        seed: args.seed,
    };
    if args.path_tracer && !args.network {
        path::validate(&config)?;
    }
    config.validate(args.network)?;
    Ok(config)
}

/// `raylink bench`: measures, prints the Markdown report and writes bench.csv, bench.svg and
/// bench.md to the output directory.
pub fn run(args: &BenchArgs) -> Result<()> {
    let mut config = config(args)?;
    let quiet = args.quiet;
    if args.network {
        let q = args.quick;
        let bench = network::NetworkBench {
            scene: args
                .scenes
                .as_ref()
                .and_then(|s| s.first())
                .map_or_else(|| "scenes/network-office.toml".into(), PathBuf::from),
            slopes: args.network_slopes.unwrap_or(if q { 8 } else { 20 }),
            steps: args.network_steps.clone().unwrap_or(if q {
                vec![0.0625, 0.03125]
            } else {
                vec![0.03125, 0.0078125]
            }),
            width: args.width.unwrap_or(if q { 64 } else { 480 }),
            height: args.height.unwrap_or(if q { 48 } else { 360 }),
            reps: args.reps.unwrap_or(if q { 1 } else { 3 }).max(1),
            embree_reps: args.build_reps.unwrap_or(1),
            seed: args.seed,
            dir: args.out.clone(),
        };
        let mut names = vec!["network.md".to_string()];
        for step in &bench.steps {
            names.push(format!("network-{step}.net"));
            names.push(format!("network-{step}-series.net"));
        }
        plan_outputs(args, std::slice::from_ref(&bench.scene), &names)?;
        let rows = network::measure(&bench, &mut |line| {
            if !quiet {
                eprintln!("bench: {line}");
            }
        })?;
        let md = network::markdown(&rows, &bench);
        raylink::atomic_file::write(&args.out.join("network.md"), md.as_bytes())?;
        println!("{md}");
        return Ok(());
    }
    if args.path_tracer {
        plan_outputs(args, &[], &["path.md".to_string()])?;
        config.width = args.width.unwrap_or(512);
        config.height = args.height.unwrap_or(512);
        let spp = if args.quick {
            equal_error::QUICK_SPP
        } else {
            equal_error::SPP
        };
        let report = path::measure(&config, spp, &mut |line| {
            if !quiet {
                eprintln!("bench: {line}");
            }
        })?;
        let markdown = path::markdown(&report, &config);
        raylink::atomic_file::write(&args.out.join("path.md"), markdown.as_bytes())?;
        println!("{markdown}");
        return Ok(());
    }
    let scene_files: Vec<PathBuf> = (args.scenes.iter().flatten())
        .filter(|s| s.ends_with(".toml"))
        .map(PathBuf::from)
        .collect();
    let names = ["bench.csv", "bench.md", "bench.svg"].map(String::from);
    plan_outputs(args, &scene_files, &names)?;
    let rows = measure(&config, &mut |line| {
        if !quiet {
            eprintln!("bench: {line}");
        }
    })?;
    let markdown = report::markdown(&rows, &config);
    let write =
        |name: &str, text: &str| raylink::atomic_file::write(&args.out.join(name), text.as_bytes());
    write("bench.csv", &report::csv(&rows, config.reps))?;
    write("bench.md", &markdown)?;
    let svg = args.out.join("bench.svg");
    crate::bench_chart::svg(&rows, &config, &svg)?;
    println!("{markdown}");
    if !quiet {
        eprintln!(
            "bench: wrote {}, {} and {}",
            args.out.join("bench.csv").display(),
            args.out.join("bench.md").display(),
            svg.display()
        );
    }
    Ok(())
}

/// Checks the files a bench run writes in `--out` (`names`) against the scene files it reads
/// and each other, as every command's files are, and makes the folder: before any
/// measuring, so that a bad `--out` costs nothing and leaves nothing.
fn plan_outputs(args: &BenchArgs, scenes: &[PathBuf], names: &[String]) -> Result<()> {
    if args.out.exists() && !args.out.is_dir() {
        return Err(Error::Invalid(format!(
            "{}: --out must name a folder (bench writes several files into it), and this is \
             a file",
            args.out.display()
        )));
    }
    let mut plan = raylink::output_paths::FilePlan::new();
    plan.reads("a scene", scenes);
    for name in names {
        plan.write("--out", &args.out.join(name));
    }
    plan.check()?;
    std::fs::create_dir_all(&args.out).map_err(|e| Error::io(&args.out, e))
}
