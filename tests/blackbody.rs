//! Blackbody emitters: seen directly they have the CIE chromaticity of Planck's law, and in
//! spectral mode the light they cast on a coloured surface is Planck's spectrum times the
//! surface's reflectance spectrum, integrated against the matching functions (which RGB mode
//! only approximates), for the path, light and bidirectional tracers alike.

#[path = "common/pbrt.rs"]
mod pbrt_common;
#[path = "common/render.rs"]
mod render_common;

use glam::DVec3;
use raylink::image::Image;
use raylink::job::MonteCarloSettings;
use raylink::scene::Scene;
use raylink::spectrum::blackbody::planck;
use raylink::spectrum::{cie, BlackbodyEmission, ColorSpace, RgbAlbedo};
use raylink::{Backend, Technique};
use render_common::{boxed, image, mean, View};
use std::path::Path;

/// A floor of diffuse colour `floor` (2 by 2) under a lamp of its size emitting a blackbody
/// at `kelvin` (luminance 1, both sides, itself black), seen from between them looking
/// down; with `see_light` the camera looks up at the lamp instead. Small, so that most light
/// paths reach what the camera sees.
fn room(kelvin: f32, floor: [f32; 3], see_light: bool) -> Scene {
    let look = if see_light { 2.0 } else { 0.0 };
    let fov = if see_light { 40 } else { 70 };
    let text = format!(
        r#"
[camera]
position = [0, 1.5, 0]
look_at = [0.001, {look}, 0]
fov = {fov}
width = 24
height = 24

[materials.floor]
diffuse = [{}, {}, {}]
[materials.lamp]
diffuse = 0
emission = 1
emission_temperature = {kelvin}
two_sided_emission = true

[[shapes]]
type = "quad"
material = "floor"
vertices = [[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]]
[[shapes]]
type = "quad"
material = "lamp"
vertices = [[-1, 2, -1], [1, 2, -1], [1, 2, 1], [-1, 2, 1]]
"#,
        floor[0], floor[1], floor[2]
    );
    raylink::scene::toml::from_str(&text, Path::new("blackbody.toml"))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// A Monte Carlo technique of its settings.
type Make = fn(MonteCarloSettings) -> Technique;

fn render(scene: &Scene, technique: Technique) -> Image {
    image(scene, technique, View::of(scene, 3, None, Backend::Bvh))
}

fn settings(spp: u32, spectral: bool) -> MonteCarloSettings {
    MonteCarloSettings {
        spectral,
        ..boxed(2, spp)
    }
}

/// The chromaticity of an image's mean colour (linear sRGB).
fn chromaticity_of(image: &Image) -> (f64, f64) {
    let m = mean(image);
    cie::chromaticity(ColorSpace::srgb().rgb_to_xyz(DVec3::from(m)))
}

/// Planck's law's chromaticity at `kelvin`, integrated here every nanometre.
fn planck_xy(kelvin: f64) -> (f64, f64) {
    cie::chromaticity(cie::spectrum_to_xyz(|l| planck(l, kelvin)))
}

/// The chromaticity of Planck's light at `kelvin` reflected by the reflectance spectrum of
/// the colour `floor` (the spectrum spectral mode gives a reflectance).
fn reflected_xy(kelvin: f64, floor: [f32; 3]) -> (f64, f64) {
    let r = RgbAlbedo::new(ColorSpace::srgb(), floor).unwrap();
    cie::chromaticity(cie::spectrum_to_xyz(|l| {
        planck(l, kelvin) * r.eval(l as f32) as f64
    }))
}

fn distance(a: (f64, f64), b: (f64, f64)) -> f64 {
    (a.0 - b.0).hypot(a.1 - b.1)
}

/// A lamp at 2700 K and at 6500 K seen directly: its chromaticity is Planck's within Δxy
/// 0.002 in spectral mode (path, light and bidirectional tracing) and in RGB mode.
#[test]
fn a_blackbody_has_the_chromaticity_of_plancks_law() {
    for kelvin in [2700.0, 6500.0] {
        let want = planck_xy(kelvin as f64);
        let scene = room(kelvin, [0.5; 3], true);
        let techniques: [(&str, Make, u32, bool); 4] = [
            ("path", Technique::Path, 64, true),
            ("light", Technique::Light, 1024, true),
            ("bdpt", Technique::Bdpt, 64, true),
            ("path (RGB)", Technique::Path, 4, false),
        ];
        for (name, technique, spp, spectral) in techniques {
            let seen = chromaticity_of(&render(&scene, technique(settings(spp, spectral))));
            let d = distance(seen, want);
            eprintln!("{kelvin} K, {name}: {seen:?} against {want:?}: {d:.5}");
            assert!(d < 0.002, "{kelvin} K, {name}: {seen:?} vs {want:?}");
        }
    }
}

/// Warm light on an orange floor: in spectral mode the floor has the chromaticity of
/// Planck's spectrum times the floor's reflectance spectrum (within Δxy 0.002) for the
/// path, light and bidirectional tracers; RGB mode's product of RGB triples is further off
/// than that (so the test tells the two apart).
#[test]
fn blackbody_light_reflects_as_a_product_of_spectra() {
    let (kelvin, floor) = (2700.0, [0.9, 0.35, 0.05]);
    let want = reflected_xy(kelvin as f64, floor);
    let scene = room(kelvin, floor, false);
    let techniques: [(&str, Make, u32); 3] = [
        ("path", Technique::Path, 64),
        ("light", Technique::Light, 64),
        ("bdpt", Technique::Bdpt, 32),
    ];
    for (name, technique, spp) in techniques {
        let seen = chromaticity_of(&render(&scene, technique(settings(spp, true))));
        let d = distance(seen, want);
        eprintln!("{name}: {seen:?} against {want:?}: {d:.5}");
        assert!(d < 0.002, "{name}: {seen:?} against {want:?}");
    }
    // RGB mode: the floor's RGB times the light's.
    let body = BlackbodyEmission::new(kelvin as f64).unwrap();
    let rgb = body.rgb() * glam::Vec3::from(floor);
    let rgb_xy = cie::chromaticity(ColorSpace::srgb().rgb_to_xyz(rgb.as_dvec3()));
    eprintln!("RGB product: {rgb_xy:?}: {:.5}", distance(rgb_xy, want));
    assert!(
        distance(rgb_xy, want) > 0.004,
        "{rgb_xy:?} against {want:?}"
    );
}

/// pbrt-v4's `"blackbody L"` area light: its emission has luminance `scale` and Planck's
/// colour (the CIE tables, not a fit: chromaticity within 1e-4), and spectral renders know
/// its temperature; written as a scene file and read back, it is the same emitter.
#[test]
fn pbrt_blackbody_lights_keep_their_temperature() {
    let scene = pbrt_common::world(
        r#"AttributeBegin
AreaLightSource "diffuse" "blackbody L" [ 3200 ] "float scale" [ 3 ]
Shape "sphere" "float radius" [ 1 ]
AttributeEnd
"#,
    );
    let m = scene
        .materials
        .iter()
        .find(|m| m.is_emissive())
        .expect("an emissive material");
    let body = m.emission_spectrum.expect("a blackbody spectrum");
    assert_eq!(body.kelvin(), 3200.0);
    let xyz = ColorSpace::srgb().rgb_to_xyz(m.emission.as_dvec3());
    assert!((xyz.y - 3.0).abs() < 1e-4, "luminance {}", xyz.y);
    assert!(distance(cie::chromaticity(xyz), planck_xy(3200.0)) < 1e-4);

    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.toml");
    raylink::scene::convert::write_toml(&scene, &out).unwrap();
    let back = Scene::load(&out).unwrap_or_else(|e| panic!("{e}"));
    let b = back.materials.iter().find(|m| m.is_emissive()).unwrap();
    assert_eq!(b.emission_spectrum, m.emission_spectrum);
    assert!((b.emission - m.emission).abs().max_element() < 1e-5 * 3.0);
}

/// The orange floor of [`room`] lit by a point light 1.9 above it and by a directional light
/// from above (no lamp), each a blackbody of `kelvin` given by `temperature`.
fn lit_by_lights(kelvin: f32, floor: [f32; 3]) -> Scene {
    let text = format!(
        r#"
[camera]
position = [0, 1.5, 0]
look_at = [0.001, 0, 0]
fov = 70
width = 24
height = 24

[materials.floor]
diffuse = [{}, {}, {}]

[[shapes]]
type = "quad"
material = "floor"
vertices = [[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]]

[[lights]]
type = "point"
position = [0, 1.9, 0]
intensity = 3
temperature = {kelvin}

[[lights]]
type = "directional"
direction = [0.2, -1, 0.1]
irradiance = 2
temperature = {kelvin}
"#,
        floor[0], floor[1], floor[2]
    );
    raylink::scene::toml::from_str(&text, Path::new("lights.toml"))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Point and directional lights given a temperature emit Planck's law in spectral mode:
/// the floor has the product of spectra's chromaticity (within Δxy 0.002) for the three
/// techniques; the lights keep their temperature and luminance through conversion, as a
/// pbrt-v4 `"blackbody I"` point light does through the reader.
#[test]
fn point_and_directional_lights_can_be_blackbodies() {
    let (kelvin, floor) = (2700.0, [0.9, 0.35, 0.05]);
    let want = reflected_xy(kelvin as f64, floor);
    let scene = lit_by_lights(kelvin, floor);
    let techniques: [(&str, Make, u32); 3] = [
        ("path", Technique::Path, 64),
        ("light", Technique::Light, 64),
        ("bdpt", Technique::Bdpt, 32),
    ];
    for (name, technique, spp) in techniques {
        let seen = chromaticity_of(&render(&scene, technique(settings(spp, true))));
        let d = distance(seen, want);
        eprintln!("{name}: {seen:?} against {want:?}: {d:.5}");
        assert!(d < 0.002, "{name}: {seen:?} against {want:?}");
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("lights.toml");
    raylink::scene::convert::write_toml(&scene, &out).unwrap();
    let back = Scene::load(&out).unwrap_or_else(|e| panic!("{e}"));
    for (a, b) in scene.lights.iter().zip(&back.lights) {
        assert_eq!(a.model().spectrum(), b.model().spectrum());
        assert!(a.model().spectrum().is_some());
    }
    let pbrt = pbrt_common::world(
        "LightSource \"point\" \"blackbody I\" [ 4000 ] \"float scale\" [ 2 ]\n\
         Shape \"sphere\" \"float radius\" [ 1 ]\n",
    );
    let light = &pbrt.lights[0];
    assert_eq!(light.model().spectrum().map(|b| b.kelvin()), Some(4000.0));
}
