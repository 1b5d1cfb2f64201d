//! `raylink bench --path-tracer`: the path tracer's throughput on the Cornell box (paths/s
//! and Mrays/s, max depth 8), per intersection backend and thread count, median of the
//! repetitions after warm-up. Paths are camera samples: one per pixel sample.

use super::scenes::resolve;
use super::{BenchConfig, Spread};
use crate::accel::Backend;
use crate::control::Control;
use crate::image::filter::Filter;
use crate::job::{Job, MonteCarloSettings, Renderer, Technique};
use crate::Result;

/// Samples per pixel of each timed render.
const SPP: u32 = 4;

pub struct PathRow {
    pub backend: Backend,
    pub threads: usize,
    pub paths_per_s: Spread,
    pub mrays_per_s: Spread,
}

/// Renders the Cornell box through the job API per backend and thread count.
pub fn measure(config: &BenchConfig, progress: &mut dyn FnMut(&str)) -> Result<Vec<PathRow>> {
    let scene = std::sync::Arc::new(resolve("cornell")?);
    let technique = Technique::Path(MonteCarloSettings {
        max_depth: 8,
        spp: SPP,
        time_limit: None,
        filter: Filter::default(),
    });
    let control = Control::default();
    let mut rows = Vec::new();
    for &backend in &config.backends {
        for &threads in &config.threads {
            let job = Job {
                width: config.width,
                height: config.height,
                seed: config.seed,
                threads: Some(threads),
                accel: backend,
                ..Job::new(&scene, technique.clone())
            };
            let mut renderer = Renderer::new(scene.clone(), job, &control)?;
            let (mut paths, mut mrays) = (Vec::new(), Vec::new());
            for rep in 0..config.warmup + config.reps {
                let stats = renderer.render(&control)?.stats;
                if rep >= config.warmup {
                    paths.push(stats.samples as f64 / stats.seconds);
                    mrays.push(stats.mrays_per_second());
                }
            }
            let row = PathRow {
                backend,
                threads,
                paths_per_s: Spread::of(&paths),
                mrays_per_s: Spread::of(&mrays),
            };
            progress(&format!(
                "path tracer, {backend:?}, {threads} threads: {:.2} M paths/s, {:.2} Mrays/s",
                row.paths_per_s.median / 1e6,
                row.mrays_per_s.median
            ));
            rows.push(row);
        }
    }
    Ok(rows)
}

/// A Markdown table of the rows.
pub fn markdown(rows: &[PathRow], config: &BenchConfig) -> String {
    let mut s = format!(
        "Path tracer, Cornell box {}x{}, {SPP} spp per render, max depth 8, median (min-max) of {}\n\n\
         | backend | threads | M paths/s | Mrays/s |\n|---|---|---|---|\n",
        config.width, config.height, config.reps
    );
    for r in rows {
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
    s
}
