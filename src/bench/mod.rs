//! `raylink bench`: Embree against the pure-Rust BVH. For every scene of a ladder, every
//! backend and every thread count it measures the build time, the memory the structure holds
//! and the throughput of three ray kinds (camera, shadow, diffuse bounce) on ray sets that are
//! generated once per scene and traced by every backend. Each number is the median of
//! repetitions after warm-up runs, with the minimum and maximum as its spread. The command
//! line writes the results as a Markdown table, a CSV file and an SVG chart.

pub mod equal_error;
pub mod network;
pub mod path;
pub mod rays;
pub mod scenes;

pub use rays::{RayKind, RaySets};

use crate::accel::bvh::BvhAccel;
#[cfg(feature = "embree")]
use crate::accel::embree::{Device, EmbreeAccel};
use crate::accel::{Accel, Backend};
use crate::error::{human_size, Error, Result};
use crate::math::Ray;
use crate::platform::set_flush_denormals;
use crate::scene::{Scene, MAX_RESOLUTION};
use rayon::prelude::*;
use std::time::Instant;

pub use crate::platform::cpu_seconds;

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
    /// Checks the configuration; the message names the setting.
    pub fn validate(&self, network: bool) -> Result<()> {
        for name in &self.scenes {
            scenes::SceneSpec::parse(name)?;
        }
        if self.scenes.is_empty() || self.backends.is_empty() {
            return Err(Error::Invalid(
                "the bench needs at least one scene and one backend".into(),
            ));
        }
        if self.threads.is_empty() {
            return Err(Error::setting(
                "threads",
                "needs thread counts of at least 1",
            ));
        }
        for &t in &self.threads {
            crate::platform::check_threads("threads", t)?;
        }
        if self.reps == 0 || (self.build_reps == 0 && !network) {
            return Err(Error::setting("reps", "and build_reps must be at least 1"));
        }
        // The bounds of a render's image, and its ray sets within the machine's budget.
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if !(1..=MAX_RESOLUTION).contains(&v) {
                return Err(Error::setting(
                    name,
                    format!("must be between 1 and {MAX_RESOLUTION}, got {v}"),
                ));
            }
        }
        let rays = self.width as u64 * self.height as u64 * RayKind::ALL.len() as u64;
        let bytes = rays * std::mem::size_of::<Ray>() as u64;
        let limit = crate::control::MemoryBudget::default().limit();
        if bytes > limit {
            return Err(Error::Invalid(format!(
                "the bench's ray sets for a {}x{} grid would need {} of memory, more than 3/4 \
                 of the physical memory ({})",
                self.width,
                self.height,
                human_size(bytes),
                human_size(limit)
            )));
        }
        Ok(())
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
        .map_err(|e| Error::Invalid(format!("cannot start {threads} bench threads: {e}")))
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
pub(crate) fn build_timed(
    scene: &Scene,
    backend: Backend,
    pool: &rayon::ThreadPool,
) -> Result<Built> {
    match backend {
        #[cfg(not(feature = "embree"))]
        Backend::Embree => Err(Backend::missing_embree()),
        #[cfg(feature = "embree")]
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
            let reference = crate::accel::build(&scene, Backend::default(), &Default::default())?;
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
