//! An illumination network through the library alone: built once, two views rendered from
//! it without a new preprocess or distribution, then the lamp relit from the saved network.
//!
//! `cargo run --release --example network_relight [OUTPUT_DIR]`

use raylink::{Control, Job, Relight, Renderer, Scene, Settings, Technique, TechniqueKind};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

fn main() -> Result<(), raylink::Error> {
    let out = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    let scene = Arc::new(Scene::load(
        concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/network-room.toml").as_ref(),
    )?);
    let network_file = out.join("network-room.rlnet");
    let settings = Settings {
        integrator: Some(TechniqueKind::Network),
        intercept_step: Some(1.0 / 32.0),
        slopes: Some(8),
        network_file: Some(network_file.clone()),
        ..Settings::default()
    };
    let job = Job {
        width: 160,
        height: 120,
        ..Job::new(&scene, Technique::create(&settings)?)
    };
    let control = Control::default();
    let mean = |image: &raylink::Image| {
        image.pixels.iter().map(|p| p.x + p.y + p.z).sum::<f32>() / (3 * image.pixels.len()) as f32
    };

    // The network is built (and saved) by the first render's preparation.
    let mut renderer = Renderer::new(scene.clone(), job.clone(), &control)?;
    let start = Instant::now();
    renderer.prepare(&control)?;
    println!(
        "network built and lit in {:.2} s",
        start.elapsed().as_secs_f64()
    );
    let front = renderer.render(&control)?;
    let front_file = out.join("network-front.exr");
    raylink::write_image(&front_file, &front.image, &[], &Default::default())?;

    // A second view from the same network: no preprocess, no distribution.
    let mut side = scene.camera.clone();
    side.position = raylink::math::Vec3::new(3.6, 2.2, 4.0);
    side.look_at = raylink::math::Vec3::new(1.0, 1.0, 0.5);
    renderer.set_camera(side)?;
    let start = Instant::now();
    let side_view = renderer.render(&control)?;
    println!(
        "second view in {:.3} s from the same network",
        start.elapsed().as_secs_f64()
    );
    raylink::write_image(
        &out.join("network-side.exr"),
        &side_view.image,
        &[],
        &Default::default(),
    )?;

    // The lamp twice as bright, from the saved network's light basis.
    let relit = Settings {
        relight: Some(Relight {
            lights: vec![("lamp".into(), raylink::math::Rgb::splat(2.0))],
            ..Relight::default()
        }),
        ..settings
    };
    let job = Job {
        technique: Technique::create(&relit)?,
        ..job
    };
    let start = Instant::now();
    let relit_view = Renderer::new(scene, job, &control)?.render(&control)?;
    println!("relit in {:.3} s", start.elapsed().as_secs_f64());
    raylink::write_image(
        &out.join("network-relit.exr"),
        &relit_view.image,
        &[],
        &Default::default(),
    )?;
    println!(
        "mean values: front {:.5}, side {:.5}, relit front {:.5} (relit / front = {:.4})",
        mean(&front.image),
        mean(&side_view.image),
        mean(&relit_view.image),
        mean(&relit_view.image) / mean(&front.image)
    );
    Ok(())
}
