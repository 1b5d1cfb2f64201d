//! What the tests that render through the library share: Monte Carlo settings with a box
//! filter, the image of a technique over a scene, and image means. Included with `#[path]`; each test
//! uses a part.
#![allow(dead_code)]

use raylink::image::filter::Filter;
use raylink::image::Image;
use raylink::job::MonteCarloSettings;
use raylink::scene::Scene;
use raylink::{Backend, Control, Job, Renderer, Technique};

/// Monte Carlo settings of `max_depth` bounces and `spp` samples per pixel, with a box
/// filter (a sample counts in its pixel only) and no time limit.
pub fn boxed(max_depth: u32, spp: u32) -> MonteCarloSettings {
    MonteCarloSettings {
        max_depth,
        spp,
        time_limit: None,
        filter: Filter::Box { radius: 0.5 },
        reconstruction: raylink::image::filter::Reconstruction::Splat,
        adaptive: None,
        max_component_value: None,
        guiding: false,
        spectral: false,
    }
}

/// Where and how a test renders: the image size, the seed, the threads (`None`: every
/// core) and the intersection backend.
#[derive(Clone, Copy, Debug)]
pub struct View {
    pub size: (u32, u32),
    pub seed: u64,
    pub threads: Option<usize>,
    pub accel: Backend,
}

impl View {
    /// The scene camera's own size.
    pub fn of(scene: &Scene, seed: u64, threads: Option<usize>, accel: Backend) -> View {
        View {
            size: (scene.camera.width, scene.camera.height),
            seed,
            threads,
            accel,
        }
    }
}

/// The image of `technique` over the whole of `scene` as `view` says, or the error.
pub fn try_image(scene: &Scene, technique: Technique, view: View) -> raylink::Result<Image> {
    let job = Job {
        width: view.size.0,
        height: view.size.1,
        region: None,
        seed: view.seed,
        threads: view.threads,
        accel: view.accel,
        ..Job::new(scene, technique)
    };
    let control = Control::default();
    Ok(Renderer::new(scene.clone(), job, &control)?
        .render(&control)?
        .image)
}

/// [`try_image`], which must succeed.
pub fn image(scene: &Scene, technique: Technique, view: View) -> Image {
    try_image(scene, technique, view).unwrap_or_else(|e| panic!("{e}"))
}

/// The image's mean, per channel.
pub fn mean(image: &Image) -> [f64; 3] {
    let mut m = [0.0; 3];
    for p in &image.pixels {
        for c in 0..3 {
            m[c] += p[c] as f64;
        }
    }
    m.map(|v| v / image.pixels.len() as f64)
}

/// The largest relative difference of the image means, over the channels.
pub fn mean_error(a: &Image, reference: &Image) -> f64 {
    let (a, r) = (mean(a), mean(reference));
    (0..3)
        .map(|c| ((a[c] - r[c]) / r[c]).abs())
        .fold(0.0, f64::max)
}
