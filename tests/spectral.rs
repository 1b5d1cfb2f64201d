//! Spectral mode of the path tracer: a white furnace stays white, colours lit by white light
//! render as in RGB mode, copper and gold seen at normal incidence have the colour of their
//! measured index integrated against the CIE matching functions, a glass's dispersion
//! splits colours that RGB mode renders alike, the same pixels for any thread count, and
//! what spectral mode does not render is refused in one line.

#[path = "common/render.rs"]
mod render_common;

use raylink::image::Image;
use raylink::job::MonteCarloSettings;
use raylink::math::Vec3;
use raylink::scene::Scene;
use raylink::spectrum::{cie, named, ColorSpace};
use raylink::{Backend, Technique};
use render_common::{boxed, image, mean, try_image, View};
use std::path::Path;

fn toml(text: &str) -> Scene {
    raylink::scene::toml::from_str(text, Path::new("spectral.toml"))
        .unwrap_or_else(|e| panic!("{e}"))
}

fn path(spp: u32, max_depth: u32, spectral: bool) -> Technique {
    Technique::Path(spectral_settings(spp, max_depth, spectral))
}

fn spectral_settings(spp: u32, max_depth: u32, spectral: bool) -> MonteCarloSettings {
    MonteCarloSettings {
        spectral,
        ..boxed(max_depth, spp)
    }
}

fn scene_file(name: &str) -> Scene {
    let file = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    raylink::scene::toml::read(&file).unwrap_or_else(|e| panic!("{e}"))
}

/// The relative differences of two images' channel means.
fn mean_difference(a: &Image, b: &Image) -> [f64; 3] {
    let (a, b) = (mean(a), mean(b));
    [0, 1, 2].map(|c| (a[c] - b[c]).abs() / b[c])
}

fn render(scene: &Scene, technique: Technique, threads: Option<usize>) -> Image {
    image(scene, technique, View::of(scene, 7, threads, Backend::Bvh))
}

/// An orthographic view of a unit sphere of `material` under a uniform white background.
fn sphere_under_white_sky(material: &str, size: f32, pixels: u32) -> Scene {
    toml(&format!(
        r#"
[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
projection = "orthographic"
size = {size}
width = {pixels}
height = {pixels}

[world]
background = 1

[materials.m]
{material}

[[shapes]]
type = "sphere"
material = "m"
center = [0, 0, 0]
radius = 1
"#
    ))
}

#[test]
fn a_white_furnace_stays_white() {
    // A white diffuse sphere under a white sky: every pixel is 1 in any correct renderer.
    let scene = sphere_under_white_sky("diffuse = 1", 3.0, 24);
    let m = mean(&render(&scene, path(64, 8, true), None));
    for (c, v) in m.iter().enumerate() {
        assert!((v - 1.0).abs() < 0.005, "channel {c}: {v}");
    }
}

#[test]
fn colours_under_white_light_render_as_in_rgb_mode() {
    // Coloured patches lit by a white sky, one bounce: spectral mode must give back the
    // colours RGB mode renders (the upsampled spectra keep their colour under D65).
    let scene = toml(
        r#"
[camera]
position = [0, 4, 0.001]
look_at = [0, 0, 0]
fov = 60
width = 32
height = 32

[world]
background = 1

[materials.red]
diffuse = [0.63, 0.065, 0.05]
[materials.green]
diffuse = [0.14, 0.45, 0.091]
[materials.blue]
diffuse = [0.1, 0.2, 0.8]

[[shapes]]
type = "quad"
material = "red"
vertices = [[-3, 0, -3], [-1, 0, -3], [-1, 0, 3], [-3, 0, 3]]
[[shapes]]
type = "quad"
material = "green"
vertices = [[-1, 0, -3], [1, 0, -3], [1, 0, 3], [-1, 0, 3]]
[[shapes]]
type = "quad"
material = "blue"
vertices = [[1, 0, -3], [3, 0, -3], [3, 0, 3], [1, 0, 3]]
"#,
    );
    let rgb = mean(&render(&scene, path(16, 1, false), None));
    let spectral = mean(&render(&scene, path(256, 1, true), None));
    for c in 0..3 {
        let rel = (spectral[c] - rgb[c]).abs() / rgb[c];
        assert!(
            rel < 0.01,
            "channel {c}: spectral {spectral:?}, rgb {rgb:?}"
        );
    }
}

/// Fresnel reflectance of a conductor at normal incidence.
fn normal_reflectance(eta: f64, k: f64) -> f64 {
    ((eta - 1.0).powi(2) + k * k) / ((eta + 1.0).powi(2) + k * k)
}

/// The linear sRGB of metal `name`'s normal-incidence reflectance under D65, integrated
/// every nanometre.
fn metal_colour(name: &str) -> [f64; 3] {
    let eta = named(&format!("metal-{name}-eta")).unwrap();
    let k = named(&format!("metal-{name}-k")).unwrap();
    let d65 = named("stdillum-D65").unwrap();
    let (mut xyz, mut y_white) = (glam::DVec3::ZERO, 0.0);
    for l in 360..=830 {
        let l = l as f32;
        let light = d65.eval(l) as f64;
        let cmf = cie::cmf_xyz(l as f64);
        let r = normal_reflectance(eta.eval(l) as f64, k.eval(l) as f64);
        xyz += cmf * light * r;
        y_white += cmf.y * light;
    }
    ColorSpace::srgb().xyz_to_rgb(xyz / y_white).to_array()
}

#[test]
fn copper_and_gold_have_the_colour_of_their_measured_index() {
    for metal in ["Cu", "Au"] {
        // The middle of a smooth metal sphere seen head-on: within 5.7° of normal incidence,
        // where the reflectance changes by less than 0.1%.
        let material = format!("diffuse = 0\nconductor = \"{metal}\"");
        let scene = sphere_under_white_sky(&material, 0.2, 8);
        let seen = mean(&render(&scene, path(512, 2, true), None));
        let expected = metal_colour(metal);
        for c in 0..3 {
            let rel = (seen[c] - expected[c]).abs() / expected[c];
            assert!(rel < 0.01, "{metal}: seen {seen:?}, expected {expected:?}");
        }
        // RGB mode's three-sample reduction of the same metal is visibly off.
        let rgb = mean(&render(&scene, path(4, 2, false), None));
        let off = (0..3).any(|c| (rgb[c] - expected[c]).abs() / expected[c] > 0.02);
        assert!(off, "{metal}: RGB mode {rgb:?} matches {expected:?}");
    }
}

/// A glass ball seen against a sky that is white above the horizon and black below: its
/// rim refracts the horizon, which a dispersive glass smears into colours.
fn ball_against_horizon(glass: &str) -> Scene {
    toml(&format!(
        r#"
[camera]
position = [0, 0, 6]
look_at = [0, 0, 0]
fov = 25
width = 24
height = 24

[materials.black]
diffuse = 0
[materials.white]
diffuse = 0
emission = 1
[materials.glass]
diffuse = 0
specular = 1
transmission = 1
fresnel = true
{glass}

[[shapes]]
type = "sphere"
material = "glass"
center = [0, 0, 0]
radius = 1
[[shapes]]
type = "quad"
material = "white"
vertices = [[-20, 0.3, -5], [20, 0.3, -5], [20, 20, -5], [-20, 20, -5]]
[[shapes]]
type = "quad"
material = "black"
vertices = [[-20, -20, -5], [20, -20, -5], [20, 0.3, -5], [-20, 0.3, -5]]
"#
    ))
}

/// The largest difference between a pixel's channels.
fn largest_chroma(image: &Image) -> f32 {
    image
        .pixels
        .iter()
        .map(|p| {
            let v = Vec3::new(p[0], p[1], p[2]);
            v.max_element() - v.min_element()
        })
        .fold(0.0, f32::max)
}

#[test]
fn a_dispersive_glass_splits_white_light_and_a_plain_one_does_not() {
    let dispersive = ball_against_horizon("glass = \"SF11\"");
    let plain = ball_against_horizon("ior = 1.7847");
    let spectral = |scene: &Scene| render(scene, path(256, 8, true), None);
    let split = largest_chroma(&spectral(&dispersive));
    let unsplit = largest_chroma(&spectral(&plain));
    assert!(split > 0.15, "dispersive glass: largest chroma {split}");
    assert!(unsplit < 0.5 * split, "plain glass {unsplit} vs {split}");
    // RGB mode renders the named glass at its index at 587.6 nm, without colours.
    let rgb = largest_chroma(&render(&dispersive, path(16, 8, false), None));
    assert!(rgb < 1e-4, "RGB mode: {rgb}");
}

#[test]
fn path_light_and_bidirectional_tracing_agree_in_spectral_mode() {
    // The Cornell box (coloured walls, a warm lamp) at 32x32: every technique sees all of
    // it. Light tracing's mean is the noisiest; 2% is about four of its standard errors.
    let mut scene = scene_file("cornell-box.toml");
    (scene.camera.width, scene.camera.height) = (32, 32);
    let spectral = |t: fn(MonteCarloSettings) -> Technique, spp| {
        render(&scene, t(spectral_settings(spp, 8, true)), None)
    };
    let path = spectral(Technique::Path, 512);
    let light = spectral(Technique::Light, 512);
    let bdpt = spectral(Technique::Bdpt, 256);
    for (name, other, tol) in [("light", &light, 0.02), ("bdpt", &bdpt, 0.01)] {
        let d = mean_difference(other, &path);
        eprintln!("{name} vs path: {d:?}");
        assert!(d.iter().all(|&d| d < tol), "{name} vs path: {d:?}");
    }
    // Spectral mode changes interreflected colours (products of spectra, not of RGB
    // triples) but not the light's overall balance.
    let rgb = render(&scene, path_rgb(512), None);
    let d = mean_difference(&path, &rgb);
    eprintln!("spectral vs RGB: {d:?}");
    assert!(d.iter().all(|&d| d < 0.06), "spectral vs RGB: {d:?}");
}

fn path_rgb(spp: u32) -> Technique {
    path(spp, 8, false)
}

#[test]
fn bidirectional_tracing_sees_dispersion_as_the_path_tracer_does() {
    // The SF11 ball against the horizon: refraction seen from the camera and the coloured
    // rim, by both techniques.
    let scene = ball_against_horizon("glass = \"SF11\"");
    let path = render(&scene, path(512, 8, true), None);
    let bdpt = render(
        &scene,
        Technique::Bdpt(spectral_settings(256, 8, true)),
        None,
    );
    let d = mean_difference(&bdpt, &path);
    eprintln!("dispersion, bdpt vs path: {d:?}");
    assert!(d.iter().all(|&d| d < 0.01), "bdpt vs path: {d:?}");
}

#[test]
fn spectral_images_are_the_same_for_any_thread_count() {
    let scene = ball_against_horizon("glass = \"BK7\"");
    let one = render(&scene, path(8, 8, true), Some(1));
    let two = render(&scene, path(8, 8, true), Some(2));
    assert!(one.pixels == two.pixels, "1 and 2 threads differ");
}

#[test]
fn what_spectral_mode_does_not_render_is_refused() {
    let scene = sphere_under_white_sky("diffuse = 0.5", 3.0, 8);
    let view = View::of(&scene, 1, Some(1), Backend::Bvh);
    let cache = Technique::create(&raylink::Settings {
        integrator: Some(raylink::settings::TechniqueKind::IrradianceCache),
        spectral: Some(true),
        ..Default::default()
    })
    .unwrap();
    let e = try_image(&scene, cache, view).unwrap_err().to_string();
    assert!(e.contains("spectral") && e.contains("irradiance"), "{e}");
    let guided = Technique::Path(MonteCarloSettings {
        spectral: true,
        guiding: true,
        ..boxed(4, 1)
    });
    let e = try_image(&scene, guided, view).unwrap_err().to_string();
    assert!(e.contains("spectral") && e.contains("guiding"), "{e}");
    let unknown = "diffuse = 0\nspecular = 1\ntransmission = 1\nglass = \"Unobtainium\"";
    let e = raylink::scene::toml::from_str(
        &sphere_under_white_sky_text(unknown),
        Path::new("spectral.toml"),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("spectral.toml") && e.contains("glass") && e.contains("Unobtainium"),
        "{e}"
    );
}

#[test]
fn named_glasses_and_metals_survive_conversion() {
    let material =
        "diffuse = 0\nspecular = 1\ntransmission = 1\nfresnel = true\nglass = \"SF11\"\n\n\
                    [materials.gold]\ndiffuse = 0\nconductor = \"Au\"";
    let scene = toml(&sphere_under_white_sky_text(material));
    let dir = std::env::temp_dir().join(format!("raylink-spectral-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("converted.toml");
    raylink::scene::convert::write_toml(&scene, &out).unwrap();
    let back = raylink::scene::toml::read(&out).unwrap_or_else(|e| panic!("{e}"));
    std::fs::remove_dir_all(&dir).ok();
    for (a, b) in scene.materials.iter().zip(&back.materials) {
        let (a, b) = (a.approximation(), b.approximation());
        assert_eq!(a.spectral, b.spectral);
        assert_eq!((a.ior, a.conductor), (b.ior, b.conductor));
    }
    let parts: Vec<_> = back
        .materials
        .iter()
        .map(|m| m.approximation().spectral)
        .collect();
    assert!(
        parts.iter().any(|p| p.glass_name() == Some("SF11")),
        "{parts:?}"
    );
    assert!(parts.iter().any(|p| p.metal.is_some()), "{parts:?}");
}

/// The text of [`sphere_under_white_sky`] at 8 pixels.
fn sphere_under_white_sky_text(material: &str) -> String {
    format!(
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nwidth = 8\nheight = 8\n\n\
         [materials.m]\n{material}\n\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"m\"\n\
         center = [0, 0, 0]\nradius = 1\n"
    )
}
