//! Embedding raylink: a path-traced render runs on a thread of its own while the caller
//! watches its progress, then cancels it and looks at the partial image.
//!
//! `cargo run --release --example embed [SCENE] [MILLISECONDS]`

use raylink::{CancelToken, Control, Job, Progress, Renderer, Scene, Settings, Technique};
use raylink::{MemoryBudget, TechniqueKind};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A progress sink that counts the samples taken, for the caller to read at any time.
#[derive(Default)]
struct Counter {
    samples: AtomicU64,
}

impl Progress for Counter {
    fn advance(&self, units: u64) {
        self.samples.fetch_add(units, Ordering::Relaxed);
    }
}

fn main() -> Result<(), raylink::Error> {
    let mut args = std::env::args().skip(1);
    let scene_path = args.next().unwrap_or_else(|| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.toml").to_string()
    });
    let wait: u64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(500);

    let scene = Scene::load(scene_path.as_ref())?;
    let technique = Technique::create(&Settings {
        integrator: Some(TechniqueKind::Path),
        // Far more samples than the wait allows: the render is cancelled long before.
        spp: Some(1 << 16),
        ..Settings::default()
    })?;
    let job = Job {
        width: 128,
        height: 128,
        seed: 1,
        ..Job::new(&scene, technique)
    };
    let counter = Arc::new(Counter::default());
    let control = Control {
        cancel: CancelToken::new(),
        budget: MemoryBudget::bytes(1 << 30),
        progress: counter.clone(),
    };
    let started = Instant::now();
    let worker = {
        let control = control.clone();
        std::thread::spawn(move || Renderer::new(scene, job, &control)?.render(&control))
    };
    std::thread::sleep(Duration::from_millis(wait));
    println!(
        "after {:.2} s: {} samples taken; cancelling",
        started.elapsed().as_secs_f64(),
        counter.samples.load(Ordering::Relaxed)
    );
    let asked = Instant::now();
    control.cancel.cancel();
    let rendered = worker.join().expect("the render thread does not panic")?;
    let mean = rendered
        .image
        .pixels
        .iter()
        .map(|p| p.x + p.y + p.z)
        .sum::<f32>()
        / (3 * rendered.image.pixels.len()) as f32;
    println!(
        "stopped {:.3} s after the cancel: partial {}, {} samples ({:.2} per pixel), {} rays, \
         mean value {mean:.4}",
        asked.elapsed().as_secs_f64(),
        rendered.is_partial(),
        rendered.stats.samples,
        rendered.stats.samples as f64 / (128.0 * 128.0),
        rendered.stats.rays.total()
    );
    Ok(())
}
