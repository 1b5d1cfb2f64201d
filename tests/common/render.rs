//! What the tests that render through the library share: Monte Carlo settings with a box
//! filter, and the image of a technique over a scene. Included with `#[path]`; each test
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
