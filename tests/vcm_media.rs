//! Vertex connection and merging through participating media, against independent
//! estimators: the volumetric path tracer on a Cornell box filled with grey fog (with the
//! default merge radius and a wide one), and bidirectional path tracing (one hero channel
//! for a whole path, weights that leave transmittance out) on a box of chromatic haze
//! holding a glowing ball of chromatic ink and through a glass ball holding a tinted
//! medium; and the same bits for any thread count.

use raylink::{Control, Image, Job, Renderer, Scene, Settings, Technique, TechniqueKind};
use std::path::Path;
use std::sync::Arc;

#[path = "common/render.rs"]
mod render;
use render::mean_error;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn toml(text: &str) -> Arc<Scene> {
    let scene = raylink::scene::toml::from_str(text, Path::new("vcm-media.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(!scene.media.is_empty());
    Arc::new(scene)
}

fn read(name: &str) -> String {
    std::fs::read_to_string(root().join(name)).unwrap()
}

/// Replaces `from` by `to` in `text`, which must hold it.
fn replace(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "{from}");
    text.replacen(from, to, 1)
}

/// `scene` rendered by `kind` at `size`² with a box filter.
fn render(
    scene: &Arc<Scene>,
    kind: TechniqueKind,
    (size, spp, max_depth): (u32, u32, u32),
) -> Image {
    render_with(scene, kind, (size, spp, max_depth), (1, 2))
}

fn render_with(
    scene: &Arc<Scene>,
    kind: TechniqueKind,
    (size, spp, max_depth): (u32, u32, u32),
    (seed, threads): (u64, usize),
) -> Image {
    render_settings(scene, kind, (size, spp, max_depth), (seed, threads), None)
}

fn render_settings(
    scene: &Arc<Scene>,
    kind: TechniqueKind,
    (size, spp, max_depth): (u32, u32, u32),
    (seed, threads): (u64, usize),
    radius: Option<f32>,
) -> Image {
    let settings = Settings {
        sppm_radius: radius,
        integrator: Some(kind),
        spp: Some(spp),
        max_depth: Some(max_depth),
        filter: Some(raylink::image::filter::Filter::Box { radius: 0.5 }),
        ..Settings::default()
    };
    let job = Job {
        width: size,
        height: size,
        seed,
        threads: Some(threads),
        ..Job::new(scene, Technique::create(&settings).unwrap())
    };
    let control = Control::default();
    let rendered = Renderer::new(scene.clone(), job, &control)
        .unwrap()
        .render(&control)
        .unwrap();
    assert!(!rendered.is_partial());
    rendered.image
}

/// VCM's image mean of `scene` at `spp` samples per pixel and that of `reference` (a
/// technique and its samples per pixel) agree within 1% per channel.
fn assert_agree(
    case: &str,
    scene: &Arc<Scene>,
    (size, max_depth): (u32, u32),
    (reference, reference_spp): (TechniqueKind, u32),
    spp: u32,
) {
    let t = std::time::Instant::now();
    let reference = render(scene, reference, (size, reference_spp, max_depth));
    let t_ref = t.elapsed().as_secs_f32();
    let t = std::time::Instant::now();
    let vcm = render(scene, TechniqueKind::Vcm, (size, spp, max_depth));
    let t_vcm = t.elapsed().as_secs_f32();
    let e = mean_error(&vcm, &reference);
    eprintln!(
        "{case}: vcm {:?} against {:?}: mean error {e:.5} ({t_vcm:.1} s, {t_ref:.1} s)",
        render::mean(&vcm),
        render::mean(&reference)
    );
    assert!(e < 0.01, "{case}: {e}");
}

/// The Cornell box filled with grey fog (the camera's medium, reaching beyond the box's
/// open front), looked at a little lower so that the light is out of view (its direct view,
/// through fog whose transmittance is 0 or 1 in each sample, would make the means noisy):
/// light and camera subpaths scatter in the fog, connect through it and merge on the walls.
/// Against the volumetric path tracer (4096 samples per pixel), VCM's mean at 256 samples
/// per pixel is within 1% per channel (24x24, 8 bounces).
#[test]
fn vcm_matches_the_path_tracer_in_a_cornell_box_filled_with_fog() {
    let text = replace(
        &read("scenes/cornell-box.toml"),
        "[camera]\n",
        "[camera]\nmedium = \"fog\"\n",
    );
    let text = replace(&text, "look_at = [0, 1, 0]", "look_at = [0, 0.7, 0]");
    let text = format!(
        "{text}\n[media.fog]\ntype = \"homogeneous\"\nsigma_a = 0.02\nsigma_s = 0.12\ng = 0.3\n"
    );
    let scene = toml(&text);
    let reference = (TechniqueKind::Path, 4096);
    assert_agree("fog box", &scene, (24, 8), reference, 256);
}

/// The fog box with a wide merge radius (0.1, a twentieth of the box), where merges carry
/// much of the light on the walls: a vertex in the fog has no merge, and its weights must
/// say so, or the light scattered in the fog before reaching a wall loses its share
/// (keeping the merge terms there puts the mean 4.5% off). Within 1% per channel of
/// the path tracer (4096 samples per pixel) at 128 samples per pixel.
#[test]
fn vcm_matches_the_path_tracer_in_fog_with_a_wide_merge_radius() {
    let text = replace(
        &read("scenes/cornell-box.toml"),
        "[camera]\n",
        "[camera]\nmedium = \"fog\"\n",
    );
    let text = replace(&text, "look_at = [0, 1, 0]", "look_at = [0, 0.7, 0]");
    let text = format!(
        "{text}\n[media.fog]\ntype = \"homogeneous\"\nsigma_a = 0.02\nsigma_s = 0.12\ng = 0.3\n"
    );
    let scene = toml(&text);
    let reference = render(&scene, TechniqueKind::Path, (24, 4096, 8));
    let vcm = render_settings(&scene, TechniqueKind::Vcm, (24, 128, 8), (1, 2), Some(0.1));
    let e = mean_error(&vcm, &reference);
    eprintln!("fog box, radius 0.1: mean error {e:.5}");
    assert!(e < 0.01, "{e}");
}

/// Haze that scatters blue twice as much as red and a glowing ball of ink whose
/// coefficients differ by channel (its emission has the camera subpath as its one
/// strategy), the glass ball made a ball of tint behind an interface. Means within 1% per
/// channel at 24x24, 16 bounces, 128 samples per pixel for both.
#[test]
fn vcm_matches_bdpt_in_chromatic_media() {
    let text = read("tests/scenes/media-box.toml");
    let ink = "[media.ink]\ntype = \"homogeneous\"\n";
    let text = replace(&text, ink, &format!("{ink}emission = [0.5, 1.5, 3]\n"));
    let text = replace(
        &text,
        "material = \"glass\"\ncenter = [0.45, 0.4, 0.3]",
        "material = \"boundary\"\ncenter = [0.45, 0.4, 0.3]",
    );
    let scene = toml(&text);
    assert_agree(
        "chromatic media",
        &scene,
        (24, 16),
        (TechniqueKind::Bdpt, 128),
        128,
    );
}

/// A glass ball holding an absorbing tint, in the box of haze with its ball of ink: light
/// focused by the glass reaches the floor through the haze (the merges' part), the tint is
/// seen and lit through the glass. Means within 1% per channel at 24x24, 16 bounces, 128
/// samples per pixel for both.
#[test]
fn vcm_matches_bdpt_through_a_glass_ball_holding_a_medium() {
    let scene = toml(&read("tests/scenes/media-box.toml"));
    assert_agree(
        "tinted glass",
        &scene,
        (24, 16),
        (TechniqueKind::Bdpt, 128),
        128,
    );
}

/// One thread or two: the same bits, in media (free flights and ratio tracking draw from
/// the streams of their subpaths).
#[test]
fn media_render_the_same_for_any_thread_count() {
    let scene = toml(&read("tests/scenes/media-box.toml"));
    let size = (24, 4, 16);
    let one = render_with(&scene, TechniqueKind::Vcm, size, (5, 1));
    let two = render_with(&scene, TechniqueKind::Vcm, size, (5, 2));
    assert!(
        one.pixels == two.pixels,
        "the thread count changed the image"
    );
    assert!(one.pixels.iter().any(|p| p.max_element() > 0.0));
}
