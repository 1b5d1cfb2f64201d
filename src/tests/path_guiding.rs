//! Path guiding: guided and unguided path tracing agree within noise, a white furnace stays
//! white while the guide learns, and the image is the same bit for bit for any thread count
//! (with and without adaptive sampling); what cannot keep that is refused.

use crate::accel::{self, Backend};
use crate::control::Control;
use crate::image::filter::{Filter, Reconstruction};
use crate::image::Image;
use crate::integrators::path::{PathOptions, PathTracer};
use crate::render::progressive::render_passes;
use crate::render::{Film, RenderStats, Shown, Watch};
use crate::scene::Scene;
use crate::transport::settings::AdaptiveSampling;
use crate::transport::{Context, ProgressiveOptions, View};
use std::path::Path;

fn scene(name: &str) -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join(name)).unwrap()
}

struct Run {
    size: (u32, u32),
    spp: u32,
    seed: u64,
    threads: usize,
    guiding: bool,
    adaptive: Option<AdaptiveSampling>,
    max_depth: u32,
}

const RUN: Run = Run {
    size: (32, 24),
    spp: 32,
    seed: 1,
    threads: 2,
    guiding: true,
    adaptive: None,
    max_depth: 8,
};

fn render(scene: &Scene, run: &Run, resume: Option<Film>) -> crate::error::Result<Film> {
    let accel = accel::build(scene, Backend::Embree, &Control::default()).unwrap();
    let ctx = Context::new(scene, accel.as_ref());
    let tracer = PathTracer::new(PathOptions {
        max_depth: run.max_depth,
    })
    .with_guiding(run.guiding);
    let options = ProgressiveOptions {
        view: View {
            seed: run.seed,
            threads: Some(run.threads),
            ..View::new(run.size.0, run.size.1)
        },
        spp: run.spp,
        time_limit: None,
        filter: Filter::default(),
        reconstruction: Reconstruction::Importance,
        adaptive: run.adaptive,
        max_component_value: None,
        statistics: false,
    };
    let mut show = |_: &Film, _: Shown, _: &RenderStats| Ok(());
    let watch = Watch {
        film: &mut show,
        mid_pass: None,
    };
    render_passes(&ctx, &tracer, &options, resume, watch, &Control::default()).map(|r| r.0)
}

fn image(scene: &Scene, run: &Run) -> Image {
    render(scene, run, None).unwrap().image().unwrap()
}

fn channel_means(image: &Image) -> [f64; 3] {
    let n = image.pixels.len() as f64;
    std::array::from_fn(|c| image.pixels.iter().map(|p| p[c] as f64).sum::<f64>() / n)
}

/// Per channel: the mean over `seeds` independent renders of the image's mean, and the
/// standard error of that mean (from the spread between renders).
fn mean_and_error(scene: &Scene, run: &Run, seeds: u64) -> ([f64; 3], [f64; 3]) {
    let means: Vec<[f64; 3]> = (0..seeds)
        .map(|seed| channel_means(&image(scene, &Run { seed, ..*run })))
        .collect();
    let n = seeds as f64;
    let mean: [f64; 3] = std::array::from_fn(|c| means.iter().map(|m| m[c]).sum::<f64>() / n);
    let error = std::array::from_fn(|c| {
        let var = means.iter().map(|m| (m[c] - mean[c]).powi(2)).sum::<f64>() / (n - 1.0);
        (var / n).sqrt()
    });
    (mean, error)
}

/// On the rooms lit through a window and by a hidden lamp, the guided image's mean per
/// channel agrees with the unguided one's within 3 standard errors of their difference
/// (each from 8 independent renders of 32 samples, half of them guided by what the first
/// half learned).
#[test]
fn guided_and_unguided_agree_within_noise() {
    for name in ["scenes/window-room.toml", "scenes/indirect-room.toml"] {
        let scene = scene(name);
        let (guided, e_guided) = mean_and_error(&scene, &RUN, 8);
        let unguided_run = Run {
            guiding: false,
            ..RUN
        };
        let (unguided, e_unguided) = mean_and_error(&scene, &unguided_run, 8);
        for c in 0..3 {
            let sigma = (e_guided[c].powi(2) + e_unguided[c].powi(2)).sqrt();
            let diff = (guided[c] - unguided[c]).abs();
            assert!(
                diff <= 3.0 * sigma && sigma < 0.05 * unguided[c],
                "{name} channel {c}: guided {} unguided {} (σ {sigma})",
                guided[c],
                unguided[c]
            );
        }
    }
}

/// White diffuse spheres that see each other under a uniform white sky: every pixel's
/// expected value is 1, however the guide learns to sample. The image mean is within 3
/// standard errors (from the pixels' spread) of 1, and within 1%.
#[test]
fn a_white_furnace_stays_white_while_the_guide_learns() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("furnace.pbrt");
    let mut text = String::from(
        "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n\
         WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n\
         Material \"diffuse\" \"rgb reflectance\" [1 1 1]\n",
    );
    for (x, y, z) in [
        (-0.7, 0.0, 0.0),
        (0.7, 0.0, 0.0),
        (0.0, 0.9, -0.6),
        (0.0, -0.8, 0.5),
    ] {
        text += &format!(
            "AttributeBegin\nTranslate {x} {y} {z}\nShape \"sphere\" \"float radius\" 0.8\n\
             AttributeEnd\n"
        );
    }
    std::fs::write(&file, text).unwrap();
    let scene = Scene::load(&file).unwrap();
    let run = Run {
        spp: 64,
        max_depth: 1024,
        ..RUN
    };
    let img = image(&scene, &run);
    let n = img.pixels.len() as f64;
    let values: Vec<f64> = img.pixels.iter().map(|p| p[1] as f64).collect();
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let error = (var / n).sqrt();
    assert!(
        (mean - 1.0).abs() <= 3.0 * error && (mean - 1.0).abs() < 0.01,
        "furnace mean {mean} (standard error {error})"
    );
    // The spheres shade each other: guiding had bounces to learn from.
    assert!(var > 0.0);
}

fn bits(image: &Image) -> Vec<u32> {
    image
        .pixels
        .iter()
        .flat_map(|p| [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()])
        .collect()
}

/// One thread and two give the same guided image bit for bit, with and without adaptive
/// sampling; and the guided image differs from the unguided one (the guide is used).
#[test]
fn guided_images_are_the_same_for_any_thread_count() {
    let scene = scene("scenes/window-room.toml");
    for adaptive in [
        None,
        Some(AdaptiveSampling {
            threshold: 0.05,
            min_samples: 8,
        }),
    ] {
        let run = Run { adaptive, ..RUN };
        let two = bits(&image(&scene, &run));
        let one = bits(&image(&scene, &Run { threads: 1, ..run }));
        assert!(one == two, "adaptive {adaptive:?}: 1 and 2 threads differ");
        let unguided = bits(&image(
            &scene,
            &Run {
                guiding: false,
                ..run
            },
        ));
        assert!(unguided != two);
    }
}

/// A guided render does not resume (a checkpoint does not keep the guide), and a guided
/// job refuses to render a part of an image.
#[test]
fn what_guiding_cannot_keep_deterministic_is_refused() {
    let scene = scene("scenes/window-room.toml");
    let film = render(&scene, &Run { spp: 2, ..RUN }, None).unwrap();
    let e = render(&scene, &RUN, Some(film)).unwrap_err();
    assert!(e.to_string().contains("guiding"), "{e}");
    let e = crate::transport::settings::refuse_for_parts(None, None, true).unwrap_err();
    assert!(e.to_string().contains("guiding"), "{e}");
}
