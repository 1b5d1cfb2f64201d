//! Whitted's adaptive anti-aliasing against regular supersampling on scenes/whitted.toml.

use raylink::accel::{self, Backend};
use raylink::image::Image;
use raylink::integrators::whitted::{Whitted, WhittedOptions};
use raylink::integrators::Context;
use raylink::render::{render, PixelSampling, RenderOptions, RenderStats};
use raylink::scene::Scene;
use std::path::Path;

/// Largest RMSE (display values, clamped to [0, 1]) accepted between the adaptive image and
/// the 16x16-supersampled reference at 160x120. At this size most of the checkerboard is
/// sub-pixel, so 4x4 supersampling itself is 0.006 away and 2x2 0.017.
const ADAPTIVE_TOLERANCE: f32 = 0.012;

fn clamped(image: &Image) -> Image {
    Image {
        pixels: image
            .pixels
            .iter()
            .map(|p| p.clamp(raylink::math::Vec3::ZERO, raylink::math::Vec3::ONE))
            .collect(),
        ..image.clone()
    }
}

#[test]
fn adaptive_traces_fewer_rays_than_4x4_and_stays_close_to_16x16() {
    let scene =
        Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/whitted.toml")).unwrap();
    let accel = accel::build(&scene, Backend::Embree).unwrap();
    let ctx = Context::new(&scene, accel.as_ref());
    let whitted = Whitted::new(WhittedOptions::default());
    let run = |sampling| -> (Image, RenderStats) {
        let options = RenderOptions {
            width: 160,
            height: 120,
            sampling,
            threads: None,
            seed: 3,
            progress: false,
        };
        let (image, stats) = render(&ctx, &whitted, &options).unwrap();
        (clamped(&image), stats)
    };
    let (reference, _) = run(PixelSampling::Uniform { n: 16 });
    let (uniform, uniform_stats) = run(PixelSampling::Uniform { n: 4 });
    let (adaptive, adaptive_stats) = run(PixelSampling::default());
    let (corners, _) = run(PixelSampling::Adaptive {
        threshold: 0.0,
        max_depth: 0,
    });
    let (e_uniform, e_adaptive, e_corners) = (
        uniform.rmse(&reference),
        adaptive.rmse(&reference),
        corners.rmse(&reference),
    );
    eprintln!(
        "rays: adaptive {} vs 4x4 {}; RMSE to 16x16: adaptive {e_adaptive:.5}, 4x4 {e_uniform:.5}, corners only {e_corners:.5}",
        adaptive_stats.rays.total(),
        uniform_stats.rays.total()
    );
    assert!(adaptive_stats.rays.total() < uniform_stats.rays.total());
    assert!(
        e_adaptive < ADAPTIVE_TOLERANCE,
        "adaptive RMSE {e_adaptive}"
    );
    // Subdividing must actually pay: adaptive beats the unsubdivided corner average.
    assert!(
        e_adaptive < 0.5 * e_corners,
        "adaptive {e_adaptive} vs corners {e_corners}"
    );
}
