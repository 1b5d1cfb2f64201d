//! `raylink bench --path-tracer`: the path tracer on the Cornell box, per intersection backend
//! and thread count.
//!
//! - Throughput: paths/s and Mrays/s at the bench's size (512x512 from the command line), 4
//!   samples per pixel per render, max depth 8, the same seed every run. Paths are camera
//!   samples: one per pixel sample.
//! - Time to equal error ([`equal_error`]): the Bitterli box at 256x256, 64 samples per pixel
//!   per render, 7 bounces, a seed per run; the RMSE against Tungsten's converged render and
//!   the time and samples per pixel that reach RMSE 0.0056.
//!
//! A renderer is built for every configuration (backend, thread count) first; then every run
//! renders each configuration in turn (the repetition loop outermost, warm-up runs likewise),
//! so that a change in the machine's load hits every configuration alike. Each figure is the
//! median (min-max) of the timed runs. The 1-minute load average is read before and after.

use super::equal_error::{self, Reference};
use super::scenes::resolve;
use super::{BenchConfig, Spread};
use crate::accel::Backend;
use crate::control::Control;
use crate::error::{Error, Result};
use crate::image::filter::{Filter, Reconstruction};
use crate::job::{Job, MonteCarloSettings, Renderer, Technique};
use crate::platform::cores;

/// Samples per pixel of each timed throughput render.
const SPP: u32 = 4;
/// Max depth of the throughput renders.
const MAX_DEPTH: u32 = 8;
/// Timed runs needed at least: a median and a spread over fewer say little.
pub const MIN_REPS: usize = 3;

/// One configuration's figures.
pub struct PathRow {
    pub backend: Backend,
    pub threads: usize,
    pub paths_per_s: Spread,
    pub mrays_per_s: Spread,
    /// The error part, if the reference was found.
    pub error: Option<ErrorRow>,
}

/// One configuration's error renders: each figure over the timed runs.
pub struct ErrorRow {
    /// Render seconds at the error part's samples per pixel.
    pub seconds: Spread,
    pub rmse: Spread,
    /// Seconds to reach [`equal_error::TARGET_RMSE`]: seconds · (rmse/target)² per run.
    pub seconds_to_target: Spread,
    /// Samples per pixel to reach it: spp · (rmse/target)² per run.
    pub spp_to_target: Spread,
}

/// What the bench measured.
pub struct PathReport {
    pub rows: Vec<PathRow>,
    /// The 1-minute load average before and after the runs (`None`: unknown).
    pub load_before: Option<f64>,
    pub load_after: Option<f64>,
    /// Samples per pixel of each error render.
    pub error_spp: u32,
    /// The reference compared with, or why the error part was skipped.
    pub reference: std::result::Result<std::path::PathBuf, String>,
}

/// Checks what the path tracer bench needs beyond [`BenchConfig::validate`].
pub fn validate(config: &BenchConfig) -> Result<()> {
    if config.reps < MIN_REPS {
        return Err(Error::setting(
            "reps",
            format!(
                "must be at least {MIN_REPS} for the path tracer bench (a median and spread \
                 of interleaved runs), got {}",
                config.reps
            ),
        ));
    }
    Ok(())
}

/// The order of the runs: (run, configuration) pairs, run-major: run 0 renders every
/// configuration in turn, then run 1, and so on. Runs below `warmup` are warm-up runs.
pub fn schedule(warmup: usize, reps: usize, configs: usize) -> Vec<(usize, usize)> {
    (0..warmup + reps)
        .flat_map(|rep| (0..configs).map(move |c| (rep, c)))
        .collect()
}

/// The 1-minute load average from /proc/loadavg, `None` if it cannot be read.
pub(crate) fn load_average() -> Option<f64> {
    parse_load(&std::fs::read_to_string("/proc/loadavg").ok()?)
}

fn parse_load(text: &str) -> Option<f64> {
    let v: f64 = text.split_whitespace().next()?.parse().ok()?;
    (v.is_finite() && v >= 0.0).then_some(v)
}

/// A load average as printed: two decimals, or "unknown".
pub(crate) fn load_text(load: Option<f64>) -> String {
    load.map_or_else(|| "unknown".into(), |l| format!("{l:.2}"))
}

/// A renderer per configuration, and the error part's.
struct Config {
    backend: Backend,
    threads: usize,
    throughput: Renderer,
    error: Option<Renderer>,
    paths: Vec<f64>,
    mrays: Vec<f64>,
    /// (seconds, rmse) of the timed error renders.
    errors: Vec<(f64, f64)>,
}

/// Renders the Cornell box per backend and thread count, the runs interleaved; error
/// renders take `error_spp` samples per pixel ([`equal_error::SPP`] for a measurement).
pub fn measure(
    config: &BenchConfig,
    error_spp: u32,
    progress: &mut dyn FnMut(&str),
) -> Result<PathReport> {
    validate(config)?;
    let scene = std::sync::Arc::new(resolve("cornell")?);
    let technique = Technique::Path(MonteCarloSettings {
        max_depth: MAX_DEPTH,
        spp: SPP,
        time_limit: None,
        filter: Filter::default(),
        reconstruction: Reconstruction::Splat,
        adaptive: None,
        max_component_value: None,
        guiding: false,
        spectral: false,
    });
    let missing = format!(
        "no {} in the working directory or the source tree",
        equal_error::REFERENCE
    );
    let reference = match equal_error::reference_path() {
        Some(path) => Some(Reference::load(&path)?),
        None => {
            progress(&format!("time to equal error skipped: {missing}"));
            None
        }
    };
    let error_technique = equal_error::technique(&scene, error_spp)?;
    let control = Control::default();
    let mut configs = Vec::new();
    for &backend in &config.backends {
        for &threads in &config.threads {
            let job = |technique: &Technique, size: (u32, u32)| Job {
                width: size.0,
                height: size.1,
                seed: config.seed,
                threads: Some(threads),
                accel: backend,
                ..Job::new(&scene, technique.clone())
            };
            let size = (config.width, config.height);
            let throughput = Renderer::new(scene.clone(), job(&technique, size), &control)?;
            let error = match reference {
                Some(_) => {
                    let size = (equal_error::SIZE, equal_error::SIZE);
                    let job = job(&error_technique, size);
                    Some(Renderer::new(scene.clone(), job, &control)?)
                }
                None => None,
            };
            configs.push(Config {
                backend,
                threads,
                throughput,
                error,
                paths: Vec::new(),
                mrays: Vec::new(),
                errors: Vec::new(),
            });
        }
    }
    let load_before = load_average();
    progress(&format!(
        "path tracer: {} configurations, {} warm-up and {} timed runs each, interleaved; load \
         average {} before, on {} cores",
        configs.len(),
        config.warmup,
        config.reps,
        load_text(load_before),
        cores()
    ));
    for (rep, c) in schedule(config.warmup, config.reps, configs.len()) {
        let timed = rep >= config.warmup;
        let cfg = &mut configs[c];
        if c == 0 {
            let what = if timed { "run" } else { "warm-up run" };
            let n = if timed { rep - config.warmup } else { rep };
            progress(&format!("path tracer: {what} {}", n + 1));
        }
        let stats = cfg.throughput.render(&control)?.stats;
        if timed {
            cfg.paths
                .push(stats.samples as f64 / stats.seconds.max(1e-9));
            cfg.mrays.push(stats.mrays_per_second());
        }
        if let (Some(renderer), Some(reference)) = (&mut cfg.error, &reference) {
            // A seed per run: the median error is over independent renders.
            renderer.set_seed(config.seed + rep as u64);
            let rendered = renderer.render(&control)?;
            let rmse = reference.rmse(&rendered.image).ok_or_else(|| {
                Error::Invalid("the error render's size does not match the reference".into())
            })?;
            if timed {
                cfg.errors.push((rendered.stats.seconds, rmse));
            }
        }
    }
    let load_after = load_average();
    let target = equal_error::TARGET_RMSE;
    let mut rows = Vec::new();
    for cfg in configs {
        let error = (!cfg.errors.is_empty()).then(|| {
            let of = |f: &dyn Fn(f64, f64) -> f64| {
                Spread::of(&cfg.errors.iter().map(|&(t, e)| f(t, e)).collect::<Vec<_>>())
            };
            ErrorRow {
                seconds: of(&|t, _| t),
                rmse: of(&|_, e| e),
                seconds_to_target: of(&|t, e| t * equal_error::scale_to(e, target)),
                spp_to_target: of(&|_, e| error_spp as f64 * equal_error::scale_to(e, target)),
            }
        });
        let row = PathRow {
            backend: cfg.backend,
            threads: cfg.threads,
            paths_per_s: Spread::of(&cfg.paths),
            mrays_per_s: Spread::of(&cfg.mrays),
            error,
        };
        let mut line = format!(
            "path tracer, {:?}, {} threads: {:.2} M paths/s, {:.2} Mrays/s",
            row.backend,
            row.threads,
            row.paths_per_s.median / 1e6,
            row.mrays_per_s.median
        );
        if let Some(e) = &row.error {
            line += &format!(
                "; RMSE {:.5} in {:.2} s, to RMSE {target}: {:.2} s, {:.0} spp",
                e.rmse.median, e.seconds.median, e.seconds_to_target.median, e.spp_to_target.median
            );
        }
        progress(&line);
        rows.push(row);
    }
    progress(&format!(
        "path tracer: load average {} before, {} after",
        load_text(load_before),
        load_text(load_after)
    ));
    Ok(PathReport {
        rows,
        load_before,
        load_after,
        error_spp,
        reference: reference.map(|r| r.path).ok_or(missing),
    })
}

/// A Markdown report: the throughput table and the time-to-equal-error table.
pub fn markdown(report: &PathReport, config: &BenchConfig) -> String {
    let load = format!(
        "load average (1 min) {} before, {} after, on {} cores",
        load_text(report.load_before),
        load_text(report.load_after),
        cores()
    );
    let mut s = format!(
        "Path tracer, Cornell box {}x{}, {SPP} spp per render, max depth {MAX_DEPTH}, median \
         (min-max) of {} interleaved runs after {} warm-up; {load}\n\n\
         | backend | threads | M paths/s | Mrays/s |\n|---|---|---|---|\n",
        config.width, config.height, config.reps, config.warmup
    );
    for r in &report.rows {
        s += &format!(
            "| {:?} | {} | {:.3} ({:.3}-{:.3}) | {:.2} ({:.2}-{:.2}) |\n",
            r.backend,
            r.threads,
            r.paths_per_s.median / 1e6,
            r.paths_per_s.min / 1e6,
            r.paths_per_s.max / 1e6,
            r.mrays_per_s.median,
            r.mrays_per_s.min,
            r.mrays_per_s.max
        );
    }
    let target = equal_error::TARGET_RMSE;
    let path = match &report.reference {
        Ok(path) => path,
        Err(why) => {
            s += &format!("\nTime to equal error: skipped ({why}).\n");
            return s;
        }
    };
    s += &format!(
        "\nTime to equal error, Cornell box {size}x{size}, the scene's filter, max depth {}, \
         {} spp per render, a seed per run; RMSE against Tungsten's render ({}), light pixels \
         excluded; time and spp to RMSE {target} as t·(e/{target})² and spp·(e/{target})²; \
         median (min-max) of the same {} runs\n\n\
         | backend | threads | render s | RMSE | s to RMSE {target} | spp to RMSE {target} |\n\
         |---|---|---|---|---|---|\n",
        equal_error::MAX_DEPTH,
        report.error_spp,
        path.display(),
        config.reps,
        size = equal_error::SIZE,
    );
    for r in &report.rows {
        let Some(e) = &r.error else { continue };
        s += &format!(
            "| {:?} | {} | {:.3} ({:.3}-{:.3}) | {:.5} ({:.5}-{:.5}) | {:.3} ({:.3}-{:.3}) | {:.0} \
             ({:.0}-{:.0}) |\n",
            r.backend,
            r.threads,
            e.seconds.median,
            e.seconds.min,
            e.seconds.max,
            e.rmse.median,
            e.rmse.min,
            e.rmse.max,
            e.seconds_to_target.median,
            e.seconds_to_target.min,
            e.seconds_to_target.max,
            e.spp_to_target.median,
            e.spp_to_target.min,
            e.spp_to_target.max
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_are_interleaved_run_major() {
        let order = schedule(1, 3, 2);
        assert_eq!(
            order,
            [
                (0, 0),
                (0, 1),
                (1, 0),
                (1, 1),
                (2, 0),
                (2, 1),
                (3, 0),
                (3, 1)
            ]
        );
        // Every configuration gets every run, and no configuration runs twice in a row.
        for w in order.windows(2) {
            assert!(w[0].0 < w[1].0 || w[0].1 + 1 == w[1].1, "{w:?}");
        }
        assert!(schedule(0, 3, 0).is_empty());
        assert_eq!(schedule(0, 3, 1), [(0, 0), (1, 0), (2, 0)]);
    }

    #[test]
    fn load_average_is_the_first_field() {
        assert_eq!(parse_load("0.52 0.58 0.59 1/467 12345\n"), Some(0.52));
        assert_eq!(parse_load(""), None);
        assert_eq!(parse_load("x 1 2"), None);
        assert_eq!(load_text(None), "unknown");
        assert_eq!(load_text(Some(1.5)), "1.50");
    }

    #[test]
    fn fewer_than_three_runs_are_refused() {
        let config = |reps| BenchConfig {
            scenes: vec!["cornell".into()],
            backends: vec![Backend::Bvh],
            threads: vec![1],
            reps,
            warmup: 0,
            build_reps: 1,
            width: 8,
            height: 8,
            seed: 1,
        };
        for reps in [0, 1, 2] {
            match validate(&config(reps)) {
                Err(Error::Setting { name, .. }) => assert_eq!(name, "reps"),
                other => panic!("{reps} reps: {other:?}"),
            }
        }
        assert!(validate(&config(3)).is_ok());
    }
}
