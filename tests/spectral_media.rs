//! Participating media in spectral mode: a coloured slab keeps Beer–Lambert's law at every
//! wavelength of its upsampled spectrum (not RGB's three exponentials), an emitting slab
//! glows by its spectra, path, light and bidirectional tracing agree through chromatic
//! haze, ink, tinted glass and a density grid, images do not depend on the thread count, and
//! an RGB grid of colours is refused in one line.

#[path = "common/render.rs"]
mod render_common;

use glam::DVec3;
use raylink::image::Image;
use raylink::job::MonteCarloSettings;
use raylink::scene::Scene;
use raylink::spectrum::rgb_to_spectrum::solve;
use raylink::spectrum::{cie, named, ColorSpace};
use raylink::{Backend, Technique};
use render_common::{boxed, image, mean, try_image, View};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn toml(text: &str) -> Scene {
    raylink::scene::toml::from_str(text, Path::new("spectral-media.toml"))
        .unwrap_or_else(|e| panic!("{e}"))
}

fn spectral(spp: u32, max_depth: u32) -> MonteCarloSettings {
    MonteCarloSettings {
        spectral: true,
        ..boxed(max_depth, spp)
    }
}

fn render(scene: &Scene, technique: Technique, threads: Option<usize>) -> Image {
    image(scene, technique, View::of(scene, 3, threads, Backend::Bvh))
}

/// An RGB coefficient as a spectrum (pbrt-v4's `RGBUnboundedSpectrum` in sRGB): a grey value
/// is itself, a colour is twice its largest channel times the sigmoid polynomial fitted to
/// it.
fn unbounded(rgb: [f32; 3]) -> impl Fn(f32) -> f64 {
    let m = rgb[0].max(rgb[1]).max(rgb[2]);
    let s = solve(ColorSpace::srgb(), rgb.map(|c| c / (2.0 * m)));
    move |lambda| 2.0 * m as f64 * s.eval(lambda) as f64
}

/// The linear sRGB of light whose spectrum is D65 (luminance 1) times `f`, integrated every
/// nanometre.
fn under_d65(f: impl Fn(f32) -> f64) -> [f64; 3] {
    let d65 = named("stdillum-D65").unwrap();
    let (mut xyz, mut y_white) = (DVec3::ZERO, 0.0);
    for l in 360..=830 {
        let l = l as f32;
        let cmf = cie::cmf_xyz(l as f64) * d65.eval(l) as f64;
        xyz += cmf * f(l);
        y_white += cmf.y;
    }
    ColorSpace::srgb().xyz_to_rgb(xyz / y_white).to_array()
}

/// Mesh text of the slab |x|, |y| ≤ 2, |z| ≤ 0.5 filled with `medium`.
fn slab(medium: &str) -> String {
    format!(
        r#"
[materials.boundary]
interface = true

[[shapes]]
type = "mesh"
material = "boundary"
media = {{ inside = "{medium}" }}
positions = [[-2, -2, -0.5], [2, -2, -0.5], [2, 2, -0.5], [-2, 2, -0.5],
             [-2, -2, 0.5], [2, -2, 0.5], [2, 2, 0.5], [-2, 2, 0.5]]
indices = [[4, 5, 6], [4, 6, 7], [0, 2, 1], [0, 3, 2], [0, 1, 5], [0, 5, 4],
           [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]]
"#
    )
}

/// A narrow view down −z from far away: every ray crosses the slab within 0.1% of its
/// thickness (light and bidirectional tracing need a perspective camera).
const CAMERA: &str = r#"
[camera]
position = [0, 0, 20]
look_at = [0, 0, 0]
fov = 5
width = 16
height = 16
"#;

/// Asserts every channel of `got` is within `tolerance` of `want`, relative to `want`'s
/// brightest channel (a dim channel of a saturated colour is the difference of larger
/// numbers, and as noisy as they are).
fn assert_close(what: &str, got: [f64; 3], want: [f64; 3], tolerance: f64) {
    let scale = want[0].max(want[1]).max(want[2]);
    for c in 0..3 {
        let rel = (got[c] - want[c]).abs() / scale;
        assert!(
            rel < tolerance,
            "{what}, channel {c}: {got:?} against {want:?}"
        );
    }
}

#[test]
fn a_coloured_slab_attenuates_each_wavelength_by_beer_lambert() {
    // White light (emission 1: D65) through a unit slab of σa = (0.1, 1.0, 3.0): spectral
    // mode sees e^(−σa(λ)) of the upsampled spectrum at every wavelength.
    let sigma_a = [0.1, 1.0, 3.0];
    let scene = toml(&format!(
        "{CAMERA}\n[materials.light]\ndiffuse = 0\nemission = 1\n\n[[shapes]]\ntype = \"quad\"\n\
         material = \"light\"\nvertices = [[-3, -3, -2], [3, -3, -2], [3, 3, -2], [-3, 3, -2]]\n\
         \n[media.ink]\ntype = \"homogeneous\"\nsigma_a = {sigma_a:?}\nsigma_s = 0\n{}",
        slab("ink")
    ));
    let s = unbounded(sigma_a);
    let want = under_d65(|l| (-s(l)).exp());
    // What RGB mode gives, e^(−σa) per channel, is visibly different: the test tells them
    // apart.
    let rgb = sigma_a.map(|s| (-s as f64).exp());
    assert!(
        (0..3).any(|c| (rgb[c] - want[c]).abs() / want[c] > 0.05),
        "{rgb:?} {want:?}"
    );
    // Light tracing's mean is the noisiest: most light paths leave the view.
    type Make = fn(MonteCarloSettings) -> Technique;
    let techniques: [(&str, Make, f64); 3] = [
        ("path", Technique::Path, 0.01),
        ("bdpt", Technique::Bdpt, 0.01),
        ("light", Technique::Light, 0.02),
    ];
    for (name, t, tolerance) in techniques {
        let got = mean(&render(&scene, t(spectral(1024, 4)), None));
        eprintln!("{name}: {got:?}, want {want:?}, RGB {rgb:?}");
        assert_close(name, got, want, tolerance);
    }
}

#[test]
fn an_emitting_slab_glows_by_its_spectra() {
    // An absorbing, emitting slab in the dark: Le(λ)·(1 − e^(−σa(λ))) with Le the
    // illuminant spectrum of its colour (D65 times the colour's unbounded spectrum).
    let (sigma_a, le) = ([0.3, 1.0, 3.0], [2.0, 1.0, 0.5]);
    let scene = toml(&format!(
        "{CAMERA}\n[media.glow]\ntype = \"homogeneous\"\nsigma_a = {sigma_a:?}\nsigma_s = 0\n\
         emission = {le:?}\n{}",
        slab("glow")
    ));
    let (s, e) = (unbounded(sigma_a), unbounded(le));
    let want = under_d65(|l| e(l) * (1.0 - (-s(l)).exp()));
    for t in [Technique::Path, Technique::Bdpt] {
        let got = mean(&render(&scene, t(spectral(512, 4)), None));
        eprintln!("emitting slab: {got:?}, want {want:?}");
        assert_close("emitting slab", got, want, 0.01);
    }
}

fn scene_file(name: &str, size: u32) -> Scene {
    let mut scene = Scene::load(&root().join("tests/scenes").join(name)).unwrap();
    (scene.camera.width, scene.camera.height) = (size, size);
    scene
}

#[test]
fn path_light_and_bidirectional_tracing_agree_through_media() {
    // Haze filling a box, a ball of chromatic ink and a glass ball of absorbing tint (light
    // tracing cannot see through the glass); then a cloud of chromatic smoke given as a
    // density grid. Blue is the noisiest channel: 1.5% is about three of its standard errors
    // at these counts, 2.5% for light tracing.
    let scene = scene_file("media-box.toml", 16);
    let path = mean(&render(&scene, Technique::Path(spectral(1024, 64)), None));
    let bdpt = mean(&render(&scene, Technique::Bdpt(spectral(512, 64)), None));
    eprintln!("media box: path {path:?}, bdpt {bdpt:?}");
    assert_close("media box, bdpt", bdpt, path, 0.015);
    // Spectral mode keeps the media's colours: within a few percent of RGB mode.
    let rgb = mean(&render(&scene, Technique::Path(boxed(64, 256)), None));
    eprintln!("media box: RGB {rgb:?}");
    assert_close("media box, spectral against RGB", path, rgb, 0.05);

    let scene = scene_file("media-grid-box.toml", 16);
    let path = mean(&render(&scene, Technique::Path(spectral(512, 64)), None));
    let bdpt = mean(&render(&scene, Technique::Bdpt(spectral(256, 64)), None));
    let light = mean(&render(&scene, Technique::Light(spectral(512, 64)), None));
    eprintln!("smoke grid: path {path:?}, bdpt {bdpt:?}, light {light:?}");
    assert_close("smoke grid, bdpt", bdpt, path, 0.015);
    assert_close("smoke grid, light", light, path, 0.025);
}

#[test]
fn spectral_media_render_the_same_for_any_thread_count() {
    let scene = scene_file("media-box.toml", 16);
    let one = render(&scene, Technique::Path(spectral(4, 64)), Some(1));
    let two = render(&scene, Technique::Path(spectral(4, 64)), Some(2));
    assert!(one.pixels == two.pixels, "1 and 2 threads differ");
}

#[test]
fn a_coloured_rgb_grid_is_refused_in_one_line() {
    // A two-sample rgbgrid of absorption `sigma_a` filling the slab, against a white sky.
    let grid = |sigma_a: &str| {
        toml(&format!(
            "{CAMERA}\n[world]\nbackground = 1\n\n[media.colours]\ntype = \"rgbgrid\"\n\
             resolution = [2, 1, 1]\nsigma_a_grid = {sigma_a}\n\
             bounds = [[-1, -1, -1], [1, 1, 1]]\n{}",
            slab("colours")
        ))
    };
    let scene = grid("[0.1, 0.2, 0.3, 1, 2, 3]");
    let view = View::of(&scene, 1, Some(1), Backend::Bvh);
    let e = try_image(&scene, Technique::Path(spectral(1, 4)), view)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("spectral") && e.contains("\"colours\"") && e.contains("rgbgrid"),
        "{e}"
    );
    assert!(!e.contains('\n'), "{e}");
    // The same grid in grey renders.
    let grey = grid("[0.2, 0.2, 0.2, 2, 2, 2]");
    let view = View::of(&grey, 1, Some(1), Backend::Bvh);
    assert!(try_image(&grey, Technique::Path(spectral(1, 4)), view).is_ok());
}
