//! Whitted's adaptive anti-aliasing against regular supersampling on scenes/whitted.toml.

use raylink::job::AntiAliasing;
use raylink::{
    Backend, Control, Image, Job, RenderStats, Renderer, Scene, Settings, Technique, TechniqueKind,
};
use std::path::Path;
use std::sync::Arc;

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

/// Whitted with its default options and the pixel sampling `sampling` gives (the settings
/// of anti-aliasing only).
fn whitted(sampling: Settings) -> Technique {
    Technique::create(&Settings {
        integrator: Some(TechniqueKind::Whitted),
        ..sampling
    })
    .unwrap()
}

/// Uniform `n`×`n` supersampling.
fn uniform(n: u32) -> Settings {
    Settings {
        aa: Some(AntiAliasing::Uniform),
        spp: Some(n * n),
        ..Settings::default()
    }
}

#[test]
fn adaptive_traces_fewer_rays_than_4x4_and_stays_close_to_16x16() {
    let scene = Arc::new(
        Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/whitted.toml")).unwrap(),
    );
    let run = |sampling: Settings| -> (Image, RenderStats) {
        let job = Job {
            width: 160,
            height: 120,
            region: None,
            seed: 3,
            threads: None,
            accel: Backend::Embree,
            ..Job::new(&scene, whitted(sampling))
        };
        let control = Control::default();
        let rendered = Renderer::new(scene.clone(), job, &control)
            .unwrap()
            .render(&control)
            .unwrap();
        (clamped(&rendered.image), rendered.stats)
    };
    let (reference, _) = run(uniform(16));
    let (uniform, uniform_stats) = run(uniform(4));
    // The default: adaptive, threshold 0.1, depth 3.
    let (adaptive, adaptive_stats) = run(Settings::default());
    let (corners, _) = run(Settings {
        aa: Some(AntiAliasing::Adaptive),
        aa_threshold: Some(0.0),
        aa_depth: Some(0),
        ..Settings::default()
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

/// A 32x32 view down −z (fov 40°) of one sphere of emission 1 whose image has radius
/// `radius_px` pixels around raster position (`x`, `y`), on black, with no other light.
fn small_sphere_scene(x: f32, y: f32, radius_px: f32) -> Scene {
    let pixel = 2.0 * 20f32.to_radians().tan() / 32.0;
    let distance = 10.0;
    let (cx, cy) = ((x - 16.0) * pixel * distance, (16.0 - y) * pixel * distance);
    let radius = radius_px * pixel * distance;
    let text = format!(
        "[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\nfov = 40\nwidth = 32\nheight = 32\n\
         [world]\nambient = 0\nbackground = 0\n\
         [materials.glow]\ndiffuse = 0\nemission = 1\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"glow\"\ncenter = [{cx}, {cy}, -{distance}]\n\
         radius = {radius}\n"
    );
    raylink::scene::toml::from_str(&text, Path::new("small-sphere.toml")).unwrap()
}

fn render_whitted(scene: Scene, sampling: Settings) -> Image {
    let scene = Arc::new(scene);
    let job = Job::new(&scene, whitted(sampling));
    let control = Control::default();
    Renderer::new(scene, job, &control)
        .unwrap()
        .render(&control)
        .unwrap()
        .image
}

#[test]
fn adaptive_finds_a_sphere_smaller_than_a_pixel_between_its_corners() {
    // Radius 0.3 px at the centre of pixel (16, 16): no pixel corner sees it.
    let scene = || small_sphere_scene(16.5, 16.5, 0.3);
    let corners_only = render_whitted(
        scene(),
        Settings {
            aa: Some(AntiAliasing::Adaptive),
            aa_depth: Some(0),
            ..Settings::default()
        },
    );
    assert!(
        corners_only.pixels.iter().all(|p| p.max_element() == 0.0),
        "the corners alone should miss the sphere"
    );
    // Default adaptive sampling (depth 3, an 8x8 lattice in the pixel) finds it; the pixel
    // then holds its coverage, the disc's area π·0.3² = 0.283 of the pixel, up to the
    // lattice's resolution, and no other pixel sees it.
    let adaptive = render_whitted(scene(), Settings::default());
    let coverage = std::f32::consts::PI * 0.3 * 0.3;
    let found = adaptive.get(16, 16).x;
    assert!(
        (found - coverage).abs() < 0.2 * coverage,
        "pixel (16, 16) holds {found}, coverage is {coverage}"
    );
    let total: f32 = adaptive.pixels.iter().map(|p| p.x).sum();
    assert!(
        (total - found).abs() < 1e-6,
        "light outside the pixel: {total}"
    );
}
