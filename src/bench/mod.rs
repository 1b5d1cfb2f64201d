//! `raylink bench`: Embree against the pure-Rust BVH. For every scene of a ladder, every
//! backend and every thread count it measures the build time, the memory the structure holds
//! and the throughput of three ray kinds (camera, shadow, diffuse bounce) on ray sets that are
//! generated once per scene and traced by every backend. Each number is the median of
//! repetitions after warm-up runs, with the minimum and maximum as its spread. Results go to
//! the terminal (a Markdown table), a CSV file and an SVG chart.

pub mod network;
pub mod path;
pub mod rays;
pub mod report;
pub mod scenes;

pub use rays::{RayKind, RaySets};

use crate::accel::bvh::BvhAccel;
use crate::accel::embree::{set_flush_denormals, Device, EmbreeAccel};
use crate::accel::{Accel, Backend};
use crate::math::Ray;
use crate::scene::Scene;
use crate::{Error, Result};
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// CPU time of the process so far (user + system, every thread, also threads that have
/// ended), to the nanosecond (`clock_gettime(CLOCK_PROCESS_CPUTIME_ID)`); 0 where the clock
/// cannot be read. For figures that must hold on a shared machine (per CPU-second rates,
/// `raylink animate --stats`).
pub fn cpu_seconds() -> f64 {
    cpu_time::ProcessTime::try_now().map_or(0.0, |t| t.as_duration().as_secs_f64())
}

/// Options of `raylink bench`.
#[derive(Clone, Debug, clap::Args)]
pub struct BenchArgs {
    /// Comma-separated scenes: cornell (scenes/cornell-box.toml), spheres-N, terrain-N (N
    /// triangles, like 10k or 1m) or .toml scene files [default: the full ladder, or a small
    /// one with --quick].
    #[arg(long, value_delimiter = ',')]
    pub scenes: Option<Vec<String>>,
    /// Comma-separated backends to measure.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "embree,bvh")]
    pub backends: Vec<Backend>,
    /// Comma-separated thread counts [default: 1 and all cores].
    #[arg(long, value_delimiter = ',')]
    pub threads: Option<Vec<usize>>,
    /// Timed repetitions of each ray kind [default: 7, 2 with --quick].
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
    /// Measure the path tracer instead (Cornell box, 512x512 unless --width/--height, max
    /// depth 8): paths/s and Mrays/s per backend and thread count; writes path.md.
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
    #[arg(long, value_delimiter = ',')]
    pub network_steps: Option<Vec<f32>>,
    /// Network bench: slopes per axis [default: 20, the paper's 1,200 links per patch; 8
    /// with --quick].
    #[arg(long)]
    pub network_slopes: Option<u32>,
}

/// The resolved settings of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchConfig {
    pub scenes: Vec<String>,
    pub backends: Vec<Backend>,
    pub threads: Vec<usize>,
    pub reps: usize,
    pub warmup: usize,
    pub build_reps: usize,
    pub width: u32,
    pub height: u32,
    pub seed: u64,
}

impl BenchConfig {
    pub fn from_args(args: &BenchArgs) -> Result<BenchConfig> {
        let q = args.quick;
        let all = std::thread::available_parallelism().map_or(1, |n| n.get());
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
            backends: args.backends.clone(),
            threads,
            reps: args.reps.unwrap_or(if q { 2 } else { 7 }),
            warmup: args.warmup.unwrap_or(if q { 1 } else { 2 }),
            build_reps: args.build_reps.unwrap_or(if q { 1 } else { 3 }),
            width: args.width.unwrap_or(if q { 64 } else { 640 }),
            height: args.height.unwrap_or(if q { 48 } else { 480 }),
            seed: args.seed,
        };
        for name in &config.scenes {
            scenes::SceneSpec::parse(name)?;
        }
        let problem = if config.scenes.is_empty() || config.backends.is_empty() {
            Some("--scenes and --backends need at least one entry")
        } else if config.threads.is_empty() || config.threads.contains(&0) {
            Some("--threads needs thread counts of at least 1")
        } else if config.reps == 0 || (config.build_reps == 0 && !args.network) {
            Some("--reps and --build-reps must be at least 1")
        } else if config.width == 0 || config.height == 0 {
            Some("--width and --height must be at least 1")
        } else {
            None
        };
        match problem {
            Some(p) => Err(Error::Options(p.into())),
            None => Ok(config),
        }
    }
}

/// Median, minimum and maximum of a set of measurements.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spread {
    pub median: f64,
    pub min: f64,
    pub max: f64,
}

impl Spread {
    /// Panics on an empty set (the configuration asks for at least one repetition).
    pub fn of(samples: &[f64]) -> Spread {
        let mut s = samples.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len();
        let median = if n % 2 == 1 {
            s[n / 2]
        } else {
            0.5 * (s[n / 2 - 1] + s[n / 2])
        };
        Spread {
            median,
            min: s[0],
            max: s[n - 1],
        }
    }
}

/// One measurement: a ray kind traced by one backend with one thread count on one scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub scene: String,
    /// Triangles (quads count two) plus spheres.
    pub primitives: usize,
    pub backend: Backend,
    pub threads: usize,
    pub kind: RayKind,
    pub rays: usize,
    /// Rays that hit something (closest hit) or were occluded (shadow): the same ray sets
    /// give the same counts on both backends up to floating-point ties.
    pub hits: u64,
    pub mrays_per_s: Spread,
    /// Build time of the structure with this thread count, in milliseconds.
    pub build_ms: Spread,
    /// Bytes the built structure holds (see `docs/benchmarks.md` for what each counts).
    pub memory_bytes: usize,
}

/// Rays handed to a worker at a time.
const CHUNK: usize = 256;

/// Traces a ray set on the pool; returns the seconds taken and the number of hits.
pub fn trace(
    pool: &rayon::ThreadPool,
    accel: &dyn Accel,
    rays: &[Ray],
    kind: RayKind,
) -> (f64, u64) {
    pool.install(|| {
        let start = Instant::now();
        let hits = rays
            .par_chunks(CHUNK)
            .map(|chunk| count_hits(accel, chunk, kind))
            .sum();
        (start.elapsed().as_secs_f64(), hits)
    })
}

/// Traces rays one after another on the calling thread; returns how many hit.
pub fn count_hits(accel: &dyn Accel, rays: &[Ray], kind: RayKind) -> u64 {
    if kind.is_occlusion() {
        rays.iter().filter(|r| accel.occluded(r)).count() as u64
    } else {
        rays.iter().filter(|r| accel.intersect(r).is_some()).count() as u64
    }
}

/// A rayon pool of `threads` workers with flush-to-zero set, as the renderer uses.
pub fn pool(threads: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .start_handler(|_| set_flush_denormals())
        .build()
        .map_err(|e| Error::Options(format!("cannot start {threads} bench threads: {e}")))
}

/// A built structure with its build time and memory.
pub struct Built {
    pub accel: Box<dyn Accel>,
    pub seconds: f64,
    pub memory_bytes: usize,
}

/// Builds a backend's structure with `threads` build threads (Embree: a device configured
/// with that many threads; the BVH: obvhs's parallel builder on the pool), timing the build
/// alone (Embree's device start-up excluded).
pub fn build_timed(scene: &Scene, backend: Backend, pool: &rayon::ThreadPool) -> Result<Built> {
    match backend {
        Backend::Embree => {
            let device = Device::with_config(&format!("threads={}", pool.current_num_threads()))?;
            let start = Instant::now();
            let accel = EmbreeAccel::build_on(scene, device)?;
            let seconds = start.elapsed().as_secs_f64();
            Ok(Built {
                memory_bytes: accel.memory_bytes(),
                accel: Box::new(accel),
                seconds,
            })
        }
        Backend::Bvh => pool.install(|| {
            let start = Instant::now();
            let accel = BvhAccel::build(scene)?;
            let seconds = start.elapsed().as_secs_f64();
            Ok(Built {
                memory_bytes: accel.memory_bytes(),
                accel: Box::new(accel),
                seconds,
            })
        }),
    }
}

/// Runs the whole bench and returns its rows (in scene, threads, kind, backend order).
/// `progress` receives one line per step.
pub fn measure(config: &BenchConfig, progress: &mut dyn FnMut(&str)) -> Result<Vec<Row>> {
    let pools = config
        .threads
        .iter()
        .map(|&t| pool(t))
        .collect::<Result<Vec<_>>>()?;
    let mut rows = Vec::new();
    for name in &config.scenes {
        progress(&format!("{name}: loading"));
        let scene = scenes::resolve(name)?;
        let primitives = scenes::primitive_count(&scene);
        progress(&format!("{name}: {primitives} primitives; generating rays"));
        let sets = {
            let reference = crate::accel::build(&scene, Backend::Embree)?;
            rays::generate(
                &scene,
                reference.as_ref(),
                config.width,
                config.height,
                config.seed,
            )
        };
        for (pool, &threads) in pools.iter().zip(&config.threads) {
            // Backends take turns, build by build and run by run, so that a change in the
            // machine's load (it may be shared) hits them alike and their ratios stay fair.
            progress(&format!("{name}, {threads} thread(s): building"));
            let mut build_ms = vec![Vec::new(); config.backends.len()];
            let mut built: Vec<Option<Built>> = config.backends.iter().map(|_| None).collect();
            for _ in 0..config.build_reps {
                for (b, &backend) in config.backends.iter().enumerate() {
                    // Drop the previous structure first so that builds do not overlap in memory.
                    drop(built[b].take());
                    let new = build_timed(&scene, backend, pool)?;
                    build_ms[b].push(new.seconds * 1e3);
                    built[b] = Some(new);
                }
            }
            let built: Vec<Built> = built.into_iter().flatten().collect();
            for kind in RayKind::ALL {
                let rays = sets.get(kind);
                progress(&format!(
                    "{name}, {threads} thread(s): {} {kind} rays",
                    rays.len()
                ));
                let mut hits = vec![0; built.len()];
                let mut mrays = vec![Vec::new(); built.len()];
                for rep in 0..config.warmup + config.reps {
                    for (b, structure) in built.iter().enumerate() {
                        let (seconds, h) = trace(pool, structure.accel.as_ref(), rays, kind);
                        hits[b] = h;
                        if rep >= config.warmup {
                            mrays[b].push(rays.len() as f64 / seconds.max(1e-9) / 1e6);
                        }
                    }
                }
                for (b, &backend) in config.backends.iter().enumerate() {
                    rows.push(Row {
                        scene: name.clone(),
                        primitives,
                        backend,
                        threads,
                        kind,
                        rays: rays.len(),
                        hits: hits[b],
                        mrays_per_s: Spread::of(&mrays[b]),
                        build_ms: Spread::of(&build_ms[b]),
                        memory_bytes: built[b].memory_bytes,
                    });
                }
            }
        }
    }
    Ok(rows)
}

/// `raylink bench`: measures, prints the Markdown report and writes bench.csv, bench.svg and
/// bench.md to the output directory.
pub fn run(args: &BenchArgs) -> Result<()> {
    let mut config = BenchConfig::from_args(args)?;
    std::fs::create_dir_all(&args.out).map_err(|e| Error::io(&args.out, e))?;
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
        return network::run(&bench, &args.out, quiet);
    }
    if args.path_tracer {
        config.width = args.width.unwrap_or(512);
        config.height = args.height.unwrap_or(512);
        let rows = path::measure(&config, &mut |line| {
            if !quiet {
                eprintln!("bench: {line}");
            }
        })?;
        let markdown = path::markdown(&rows, &config);
        let file = args.out.join("path.md");
        std::fs::write(&file, &markdown).map_err(|e| Error::io(&file, e))?;
        println!("{markdown}");
        return Ok(());
    }
    let rows = measure(&config, &mut |line| {
        if !quiet {
            eprintln!("bench: {line}");
        }
    })?;
    let markdown = report::markdown(&rows, &config);
    let write = |name: &str, text: &str| {
        let path = args.out.join(name);
        std::fs::write(&path, text).map_err(|e| Error::io(&path, e))
    };
    write("bench.csv", &report::csv(&rows, config.reps))?;
    write("bench.md", &markdown)?;
    let svg = args.out.join("bench.svg");
    report::svg(&rows, &config, &svg)?;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_takes_median_min_max() {
        let s = Spread::of(&[3.0, 1.0, 2.0]);
        assert_eq!((s.median, s.min, s.max), (2.0, 1.0, 3.0));
        let s = Spread::of(&[4.0, 1.0, 2.0, 3.0]);
        assert_eq!((s.median, s.min, s.max), (2.5, 1.0, 4.0));
    }
}
