//! Non-finite samples (issue 10), from a test integrator (moved from tests/robustness.rs,
//! which keeps the command line's interruption, resume and memory-limit tests).

use crate::control::Control;
use crate::image::filter::Reconstruction;
use crate::render::progressive::render_passes;
use crate::transport::ProgressiveOptions;
use crate::transport::View;
use std::path::Path;

/// A test integrator: 1 everywhere, except NaN or infinity on a fixed share of samples.
struct Faulty;

impl crate::transport::MonteCarlo for Faulty {
    fn sample(
        &self,
        _: &crate::transport::Context,
        _: &crate::scene::camera::CameraBasis,
        _: &crate::math::Ray,
        sampler: &mut crate::math::sobol::Sampler,
        _: &mut crate::transport::RayStats,
        _: &mut Vec<crate::transport::Splat>,
    ) -> crate::math::Rgb {
        match sampler.next_1d() {
            u if u < 0.1 => crate::math::Rgb::splat(f32::NAN),
            u if u < 0.2 => crate::math::Rgb::new(f32::INFINITY, 0.0, 0.0),
            _ => crate::math::Rgb::ONE,
        }
    }
}

/// NaN and infinite samples are dropped and counted; no pixel is poisoned.
#[test]
fn non_finite_samples_are_dropped_and_counted() {
    let scene = crate::scene::Scene::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml"),
    )
    .unwrap();
    let control = Control::default();
    let accel = crate::accel::build(&scene, crate::accel::Backend::Embree, &control).unwrap();
    let ctx = crate::transport::Context::new(&scene, accel.as_ref());
    // Counted in its own pixel, a dropped sample is one black sample of that pixel's count,
    // so the image's mean is the share of good samples exactly; splatted, it is a black
    // sample of its weight, and the mean of weighted means is that share within noise.
    for (reconstruction, tolerance) in [
        (Reconstruction::Importance, 1e-4),
        (Reconstruction::Splat, 0.01),
    ] {
        let options = ProgressiveOptions {
            view: View {
                seed: 3,
                threads: Some(2),
                ..View::new(16, 16)
            },
            spp: 64,
            time_limit: None,
            filter: Default::default(),
            reconstruction,
            adaptive: None,
            max_component_value: None,
            statistics: false,
        };
        let (film, _) = render_passes(
            &ctx,
            &Faulty,
            &options,
            None,
            crate::render::Watch::nobody(),
            &control,
        )
        .unwrap();
        let image = film.image().unwrap();
        assert!(image.pixels.iter().all(|p| p.is_finite()));
        // About a fifth of 16·16·64 samples fail; each pixel keeps its share of good ones.
        let total = 16 * 16 * 64;
        assert!(
            (film.invalid as f64 / total as f64 - 0.2).abs() < 0.03,
            "{} of {total} dropped",
            film.invalid
        );
        let mean: f32 = image.pixels.iter().map(|p| p.y).sum::<f32>() / 256.0;
        assert!(
            (mean - (1.0 - film.invalid as f32 / total as f32)).abs() < tolerance,
            "{reconstruction:?}: {mean}"
        );
    }
}
