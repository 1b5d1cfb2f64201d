//! Rays leave surfaces from the hit point offset by its own floating-point error bound (issue
//! 66), so a render does not depend on where the scene stands and sheets far thinner than a
//! millimetre are seen as sheets:
//!
//! - closed sheets of a diffuse transmitter in front of an area light (the window blind of a
//!   public kitchen scene, and sheets from 1 µm to 1 mm thick, stacked or not) match the
//!   analytic value of light filtered by every face, with the path, light and bidirectional
//!   tracers on both backends;
//! - scenes moved 10, 1,000 and 10,000 units from the origin render as they do there;
//! - no fixed epsilon is left in the code that spawns rays.

#[path = "common/render.rs"]
mod render_common;

use raylink::image::Image;
use raylink::scene::Scene;
use raylink::{Backend, Settings, Technique, TechniqueKind};
use render_common::{boxed, image, View};
use std::f64::consts::PI;
use std::path::Path;

fn pbrt(text: &str) -> Scene {
    raylink::scene::pbrt::from_str(text, Path::new("spawn.pbrt")).unwrap_or_else(|e| panic!("{e}"))
}

/// The seed of the renders: 7, or `RAYLINK_TEST_SEED` (to measure a test's noise).
fn seed() -> u64 {
    std::env::var("RAYLINK_TEST_SEED").map_or(7, |s| s.parse().expect("a seed"))
}

/// The image's mean in each channel.
fn means(image: &Image) -> [f64; 3] {
    let mut sum = [0.0; 3];
    for y in 0..image.height {
        for x in 0..image.width {
            let c = image.get(x, y);
            for (s, v) in sum.iter_mut().zip([c.x, c.y, c.z]) {
                *s += v as f64;
            }
        }
    }
    let n = (image.width * image.height) as f64;
    sum.map(|s| s / n)
}

/// The form factor from a point to the part of a parallel plane at distance `d` over
/// [0, a] × [0, b] of its coordinates (the corner above the point; a, b signed).
fn corner_factor(a: f64, b: f64, d: f64) -> f64 {
    let (ra, rb) = ((a * a + d * d).sqrt(), (b * b + d * d).sqrt());
    (a / ra * (b / ra).atan() + b / rb * (a / rb).atan()) / (2.0 * PI)
}

/// The irradiance at (x, y) from a Lambertian rectangle of radiance `l` over
/// [x0, x1] × [y0, y1] in a parallel plane at distance `d`.
fn irradiance(l: f64, (x0, x1, y0, y1): (f64, f64, f64, f64), d: f64, x: f64, y: f64) -> f64 {
    let f = |a: f64, b: f64| corner_factor(a - x, b - y, d);
    PI * l * (f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0))
}

/// The irradiance averaged over a rectangle of centre (cx, cy) and half sizes (hx, hy).
fn mean_irradiance(
    l: f64,
    light: (f64, f64, f64, f64),
    d: f64,
    (cx, cy): (f64, f64),
    (hx, hy): (f64, f64),
) -> f64 {
    let n = 200;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let x = cx + hx * (2.0 * (i as f64 + 0.5) / n as f64 - 1.0);
            let y = cy + hy * (2.0 * (j as f64 + 0.5) / n as f64 - 1.0);
            sum += irradiance(l, light, d, x, y);
        }
    }
    sum / (n * n) as f64
}

/// The transmittance of `faces` parallel Lambertian faces of reflectance `r` and
/// transmittance `t` each, light bouncing between them without end (the adding method).
fn stack_transmittance(r: f64, t: f64, faces: usize) -> f64 {
    let (mut rs, mut ts) = (r, t);
    for _ in 1..faces {
        let k = 1.0 / (1.0 - rs * r);
        (rs, ts) = (rs + ts * ts * r * k, ts * t * k);
    }
    ts
}

#[test]
fn the_adding_method_and_the_form_factor_give_known_values() {
    // Two faces: T² / (1 − R²), the closed sheet's value.
    let two = stack_transmittance(0.3, 0.3, 2);
    assert!((two - 0.09 / 0.91).abs() < 1e-12);
    // A unit square seen from above its centre at distance 0.5: four corners of 1/2 × 1/2.
    let e = irradiance(1.0, (-0.5, 0.5, -0.5, 0.5), 0.5, 0.0, 0.0);
    let quarter = corner_factor(0.5, 0.5, 0.5);
    assert!((e - 4.0 * PI * quarter).abs() < 1e-12);
    // An unbounded plane: E = π L.
    let far = 1e7;
    let e = irradiance(1.0, (-far, far, -far, far), 1.0, 0.0, 0.0);
    assert!((e / PI - 1.0).abs() < 1e-6, "{e}");
}

const BLIND_REFLECTANCE: [f64; 3] = [0.3, 0.25, 0.2];

/// The issue's minimal case: a closed box 0.26 mm thick of the blind's material in front of
/// an area light, seen face-on (the whole image is the sheet).
const BLIND: &str = r#"
LookAt 0.057 2.84 -1.5  0.057 2.84 -2.75  0 1 0
Camera "perspective" "float fov" [ 10 ]
Film "rgb" "integer xresolution" [ 100 ] "integer yresolution" [ 25 ]
WorldBegin
AttributeBegin
    AreaLightSource "diffuse" "rgb L" [ 16.032043 16.032043 16.032043 ]
    Material "diffuse" "rgb reflectance" [ 0 0 0 ]
    Shape "trianglemesh" "point3 P" [ -0.75145 0.873153 -3.1173 0.872078 0.873153 -3.1173 0.872078 3.07443 -3.1173 -0.75145 3.07443 -3.1173 ] "integer indices" [ 0 1 2 0 2 3 ]
AttributeEnd
MakeNamedMaterial "Blinds" "string type" [ "diffusetransmission" ] "rgb reflectance" [ 0.3 .25 .2 ] "rgb transmittance" [ 0.3 .25 .2 ]
NamedMaterial "Blinds"
Shape "trianglemesh" "point3 P" [ -0.6 2.72 -2.74863 0.72 2.72 -2.74863 0.72 2.96 -2.74863 -0.6 2.96 -2.74863 -0.6 2.72 -2.74837 0.72 2.72 -2.74837 0.72 2.96 -2.74837 -0.6 2.96 -2.74837 ] "integer indices" [ 0 2 1 0 3 2 4 5 6 4 6 7 0 1 5 0 5 4 3 7 6 3 6 2 0 4 7 0 7 3 1 2 6 1 6 5 ]
"#;

/// The three techniques that carry light through the sheet, with enough bounces for the
/// light between its faces to die out. The light tracer, whose particles mostly leave
/// outside the camera's view, takes eight times the samples for the same noise.
fn techniques(spp: u32) -> [(&'static str, Technique); 3] {
    [
        ("path", Technique::Path(boxed(24, spp))),
        ("light", Technique::Light(boxed(24, 8 * spp))),
        ("bdpt", Technique::Bdpt(boxed(24, spp))),
    ]
}

/// Each technique's image of `scene` on each backend matches `want` in every channel
/// within `tolerance` (relative).
fn assert_matches(name: &str, scene: &Scene, spp: u32, want: [f64; 3], tolerance: f64) {
    for backend in Backend::ALL {
        for (technique, settings) in techniques(spp) {
            let got = means(&image(
                scene,
                settings,
                View::of(scene, seed(), None, backend),
            ));
            for c in 0..3 {
                let error = got[c] / want[c] - 1.0;
                if std::env::var_os("RAYLINK_TEST_SEED").is_some() {
                    eprintln!(
                        "{name}, {technique} on {backend}: channel {c} {:+.2}%",
                        100.0 * error
                    );
                }
                assert!(
                    error.abs() < tolerance,
                    "{name}, {technique} on {backend}: channel {c} is {:.4}, the analytic value \
                     {:.4} ({:+.2}%)",
                    got[c],
                    want[c],
                    100.0 * error
                );
            }
        }
    }
}

#[test]
fn the_blind_filters_the_light_through_both_faces() {
    let scene = pbrt(BLIND);
    // The visible part of the front face: the camera looks straight at it from 1.24837
    // away, with a 10° field of view across the image's height (a quarter of its width).
    let hy = 1.24837 * (5.0f64).to_radians().tan();
    let light = (-0.75145, 0.872078, 0.873153, 3.07443);
    let e = mean_irradiance(16.032043, light, 0.36867, (0.057, 2.84), (4.0 * hy, hy));
    let want = BLIND_REFLECTANCE.map(|r| stack_transmittance(r, r, 2) * e / PI);
    assert_matches("the blind", &scene, 64, want, 0.02);
}

/// `sheets` closed sheets `thickness` thick, `gap` apart, the first with its front face at
/// z = 0, over [−0.5, 0.5]², of a diffuse transmitter of reflectance `r` and transmittance
/// `t`; a 2 × 2 area light 0.4 behind the front face; a camera 1 in front seeing the middle;
/// all but the sheets' thickness and gaps times `scale`.
fn sheets_scene(sheets: usize, thickness: f64, gap: f64, (r, t): (f64, f64), scale: f64) -> String {
    let (l, z, h) = (scale, -0.4 * scale, 0.5 * scale);
    let mut text = format!(
        "LookAt 0 0 {scale}  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 20 ]\n\
         Film \"rgb\" \"integer xresolution\" [ 24 ] \"integer yresolution\" [ 24 ]\n\
         WorldBegin\nAttributeBegin\n\
         AreaLightSource \"diffuse\" \"rgb L\" [ 10 10 10 ]\n\
         Material \"diffuse\" \"rgb reflectance\" [ 0 0 0 ]\n\
         Shape \"trianglemesh\" \"point3 P\" [ -{l} -{l} {z}  {l} -{l} {z}  {l} {l} {z}  -{l} {l} {z} ] \
         \"integer indices\" [ 0 1 2 0 2 3 ]\nAttributeEnd\n\
         Material \"diffusetransmission\" \"rgb reflectance\" [ {r} {r} {r} ] \
         \"rgb transmittance\" [ {t} {t} {t} ]\n"
    );
    for s in 0..sheets {
        let front = -(s as f64) * (thickness + gap);
        let b = front - thickness;
        let f = front;
        text += &format!(
            "Shape \"trianglemesh\" \"point3 P\" [ -{h} -{h} {b:e} {h} -{h} {b:e} \
             {h} {h} {b:e} -{h} {h} {b:e} -{h} -{h} {f:e} {h} -{h} {f:e} \
             {h} {h} {f:e} -{h} {h} {f:e} ] \"integer indices\" [ 0 2 1 0 3 2 4 5 6 \
             4 6 7 0 1 5 0 5 4 3 7 6 3 6 2 0 4 7 0 7 3 1 2 6 1 6 5 ]\n"
        );
    }
    text
}

/// The analytic value of [`sheets_scene`]: the light's irradiance over the visible square
/// (the layers are too close together for their spacing to matter), filtered by each face.
fn sheets_value(sheets: usize, (r, t): (f64, f64)) -> [f64; 3] {
    let hy = (10.0f64).to_radians().tan();
    let e = mean_irradiance(10.0, (-1.0, 1.0, -1.0, 1.0), 0.4, (0.0, 0.0), (hy, hy));
    [stack_transmittance(r, t, 2 * sheets) * e / PI; 3]
}

/// Samples per pixel for the sheets: their means are within 0.6% at one standard deviation
/// (measured over seeds), the light tracer's being the noisiest.
const SHEET_SPP: u32 = 128;

#[test]
fn closed_sheets_from_a_micrometre_to_a_millimetre_thick_filter_twice() {
    // The blind's fabric, grey.
    let fabric = (0.3, 0.3);
    for thickness in [1e-6, 1e-5, 1e-4, 1e-3] {
        let scene = pbrt(&sheets_scene(1, thickness, 0.0, fabric, 1.0));
        let name = format!("a sheet {thickness:e} thick");
        assert_matches(&name, &scene, SHEET_SPP, sheets_value(1, fabric), 0.02);
    }
}

#[test]
fn stacked_sheets_filter_through_every_face() {
    // Clear enough for light to pass six faces often (fewer samples lost).
    let gauze = (0.1, 0.8);
    for (thickness, gap) in [(1e-6, 2e-6), (1e-4, 5e-5)] {
        let scene = pbrt(&sheets_scene(3, thickness, gap, gauze, 1.0));
        let name = format!("three sheets {thickness:e} thick {gap:e} apart");
        assert_matches(&name, &scene, SHEET_SPP, sheets_value(3, gauze), 0.02);
    }
}

/// The directions of the moves: away from the origin along an axis-free unit vector.
const AWAY: [f64; 3] = [0.6, -0.48, 0.64];

/// `text` (a pbrt scene) with everything, camera included, moved by `offset`.
fn moved(text: &str, offset: [f64; 3]) -> String {
    let [x, y, z] = offset;
    // The camera's transform is world to camera: the move is undone before it.
    let camera = text.find("Camera ").expect("a camera");
    let world = text.find("WorldBegin").expect("a world") + "WorldBegin".len();
    format!(
        "{}Translate {} {} {}\n{}\nTranslate {x} {y} {z}\n{}",
        &text[..camera],
        -x,
        -y,
        -z,
        &text[camera..world],
        &text[world..]
    )
}

/// A camera 32 pixels square looking from `eye` at `at` (y up) with a 40° field of view.
fn camera(eye: &str, at: &str) -> String {
    format!(
        "LookAt {eye}  {at}  0 1 0\nCamera \"perspective\" \"float fov\" [ 40 ]\n\
         Film \"rgb\" \"integer xresolution\" [ 32 ] \"integer yresolution\" [ 32 ]\n"
    )
}

/// A white floor over [−3, 3]² at y = 0 and a 1 × 1 light facing down at y = 2.5.
const ROOM: &str = r#"
AttributeBegin
    AreaLightSource "diffuse" "rgb L" [ 12 12 12 ]
    Shape "trianglemesh" "point3 P" [ -0.5 2.5 -0.5  0.5 2.5 -0.5  0.5 2.5 0.5  -0.5 2.5 0.5 ] "integer indices" [ 0 1 2 0 2 3 ]
AttributeEnd
Material "diffuse" "rgb reflectance" [ 0.7 0.7 0.7 ]
Shape "trianglemesh" "point3 P" [ -3 0 -3  -3 0 3  3 0 3  3 0 -3 ] "integer indices" [ 0 1 2 0 2 3 ]
"#;

/// A closed unit cube's mesh around the origin.
const CUBE: &str = r#"Shape "trianglemesh" "point3 P" [ -0.5 -0.5 -0.5  0.5 -0.5 -0.5  0.5 0.5 -0.5  -0.5 0.5 -0.5  -0.5 -0.5 0.5  0.5 -0.5 0.5  0.5 0.5 0.5  -0.5 0.5 0.5 ] "integer indices" [ 0 2 1 0 3 2 4 5 6 4 6 7 0 1 5 0 5 4 3 7 6 3 6 2 0 4 7 0 7 3 1 2 6 1 6 5 ]"#;

/// The scenes moved about: each with the techniques it is rendered with and a factor on
/// their samples (the sheet's light comes through a few faces, and is noisier).
fn translation_scenes() -> Vec<(&'static str, String, Vec<TechniqueKind>, u32)> {
    use TechniqueKind::{Bdpt, IrradianceCache, Light, Path, Whitted};
    let room =
        |eye: &str, at: &str, body: &str| format!("{}WorldBegin\n{ROOM}{body}", camera(eye, at));
    vec![
        (
            "the Cornell box",
            include_str!("../scenes/cornell-box-bitterli/scene-v4.pbrt").replace(
                "\"integer xresolution\" [ 1024 ]",
                "\"integer xresolution\" [ 32 ]",
            ).replace("\"integer yresolution\" [ 1024 ]", "\"integer yresolution\" [ 32 ]"),
            vec![Path, Bdpt, IrradianceCache],
            1,
        ),
        (
            "a glass sphere",
            room(
                "0 1.5 3",
                "0 0.5 0",
                "Material \"dielectric\" \"float eta\" [ 1.5 ]\n\
                 AttributeBegin\nTranslate 0 0.6 0\nShape \"sphere\" \"float radius\" [ 0.5 ]\nAttributeEnd\n",
            ),
            vec![Path, Bdpt, Whitted],
            1,
        ),
        (
            "a thin sheet",
            sheets_scene(1, 0.02, 0.0, (0.3, 0.3), 5.0),
            vec![Path, Light, Bdpt],
            4,
        ),
        (
            "an instanced mesh",
            room(
                "0 2 4",
                "0 0.4 0",
                &format!(
                    "AttributeBegin\nIdentity\nObjectBegin \"cube\"\n{CUBE}\nObjectEnd\nAttributeEnd\n\
                     AttributeBegin\nTranslate -0.8 0.5 0\nRotate 30 0 1 0\nObjectInstance \"cube\"\nAttributeEnd\n\
                     AttributeBegin\nTranslate 0.8 0.3 0.3\nRotate -20 0 1 0\nScale 0.6 0.6 0.6\nObjectInstance \"cube\"\nAttributeEnd\n"
                ),
            ),
            vec![Path],
            1,
        ),
        (
            "a mirror",
            room(
                "0 1.2 3",
                "0 0.6 0",
                "AttributeBegin\nMaterial \"conductor\" \"float roughness\" [ 0 ] \"rgb reflectance\" [ 0.9 0.9 0.9 ]\n\
                 Shape \"trianglemesh\" \"point3 P\" [ -1.2 0 -1  1.2 0 -1  1.2 1.6 -0.6  -1.2 1.6 -0.6 ] \
                 \"integer indices\" [ 0 1 2 0 2 3 ]\nAttributeEnd\n\
                 Material \"diffuse\" \"rgb reflectance\" [ 0.6 0.2 0.1 ]\n\
                 AttributeBegin\nTranslate 0.3 0.25 0\nShape \"sphere\" \"float radius\" [ 0.25 ]\nAttributeEnd\n",
            ),
            vec![Path, Whitted],
            1,
        ),
        (
            "a sphere resting on a plane",
            room(
                "0 0.8 2",
                "0 0.3 0",
                "AttributeBegin\nTranslate 0 0.5 0\nShape \"sphere\" \"float radius\" [ 0.5 ]\nAttributeEnd\n",
            ),
            vec![Path],
            1,
        ),
    ]
}

/// `kind` with samples enough for a mean within a fraction of a percent on these small
/// images, times `factor` (the irradiance cache with fewer hemisphere samples, to be quick).
fn technique(kind: TechniqueKind, factor: u32) -> Technique {
    let spp = match kind {
        TechniqueKind::Light => 2048 * factor,
        TechniqueKind::Whitted => 4,
        _ => 128 * factor,
    };
    Technique::create(&Settings {
        integrator: Some(kind),
        spp: Some(spp),
        max_depth: Some(8),
        filter: Some(raylink::image::filter::Filter::Box { radius: 0.5 }),
        ic_samples: Some(64),
        ..Settings::default()
    })
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Pixels of `a` and `b` that differ by more than a factor of two (the larger over 0.01).
fn speckles(a: &Image, b: &Image) -> usize {
    let mut count = 0;
    for y in 0..a.height {
        for x in 0..a.width {
            let (p, q) = (grey(a, x, y), grey(b, x, y));
            if p.max(q) > 0.01 && (p - q).abs() > 0.5 * p.max(q) {
                count += 1;
            }
        }
    }
    count
}

fn grey(image: &Image, x: u32, y: u32) -> f64 {
    let c = image.get(x, y);
    (c.x + c.y + c.z) as f64 / 3.0
}

fn grey_mean(image: &Image) -> f64 {
    means(image).iter().sum::<f64>() / 3.0
}

/// Every scene, with each of its techniques on each backend, moved 10, 1,000 and 10,000
/// units: the image's mean is within 1% of the one at the origin (same seed), and no more
/// pixels differ from it by a factor of two than differ between two seeds at the origin, or
/// two (10,000 units away, vertices round to half a millimetre, which may tip a pixel on a
/// sharp edge; self-intersections show as dark or bright pixels by the dozen).
#[test]
fn scenes_moved_up_to_ten_thousand_units_away_render_as_at_the_origin() {
    let mut failures = Vec::new();
    for (name, text, kinds, factor) in translation_scenes() {
        for kind in kinds {
            for backend in Backend::ALL {
                let render = |text: &str, seed: u64| {
                    let scene = pbrt(text);
                    image(
                        &scene,
                        technique(kind, factor),
                        View::of(&scene, seed, None, backend),
                    )
                };
                let origin = render(&text, 7);
                let noise = speckles(&origin, &render(&text, 8));
                for distance in [10.0, 1e3, 1e4] {
                    let image = render(&moved(&text, AWAY.map(|c| c * distance)), 7);
                    let change = grey_mean(&image) / grey_mean(&origin) - 1.0;
                    let spots = speckles(&origin, &image);
                    let line = format!(
                        "{name}, {kind:?} on {backend}, {distance} units away: mean {:+.2}%, \
                         {spots} pixels off by 2x (two seeds at the origin: {noise})",
                        100.0 * change
                    );
                    eprintln!("{line}");
                    if change.abs() > 0.01 || spots > noise.max(2) {
                        failures.push(line);
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The library's source files (outside its test modules), by path.
fn library_sources(dir: &Path, out: &mut Vec<(String, String)>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for path in entries {
        let name = path.to_string_lossy().into_owned();
        if path.is_dir() {
            if !name.ends_with("src/tests") {
                library_sources(&path, out);
            }
        } else if name.ends_with(".rs") {
            let text = std::fs::read_to_string(&path).unwrap();
            // Unit tests sit at the end of a file, after `#[cfg(test)]`.
            let code = text.split("#[cfg(test)]").next().unwrap_or("").to_string();
            out.push((name, code));
        }
    }
}

/// No fixed epsilon moves rays off surfaces: the old offset's names are gone, no ray's
/// interval starts at a constant past zero, and rays are made from scratch only where they
/// start off every surface (cameras, the network's lines, the backends and the ray type
/// itself); everything leaving a surface goes through `Spot::spawn` or `Spot::spawn_to`.
#[test]
fn no_fixed_epsilon_offsets_rays() {
    let mut sources = Vec::new();
    library_sources(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("src"),
        &mut sources,
    );
    assert!(sources.len() > 50, "the library's sources were not found");
    let rays_from_scratch = [
        "src/math/mod.rs",
        "src/math/spawn.rs",
        "src/scene/camera.rs",
        "src/integrators/illumination_network/preprocess/cast.rs",
        "src/accel/cutout.rs",
    ];
    let mut found = Vec::new();
    for (path, code) in &sources {
        for (i, line) in code.lines().enumerate() {
            let line = line.split("//").next().unwrap_or("");
            let at = format!("{path}:{}: {}", i + 1, line.trim());
            for name in ["offset_origin", "SHADOW_EPSILON", "RAY_EPSILON"] {
                if line.contains(name) {
                    found.push(at.clone());
                }
            }
            let starts_past_zero = line.contains("tmin")
                && (line.contains("+ 1e-") || line.contains("tmin: 1e-") || line.contains("= 1e-"));
            let literal = ["= Ray {", ": Ray {", "(Ray {"]
                .iter()
                .any(|l| line.contains(l))
                || line.trim_start().starts_with("Ray {");
            let from_scratch = line.contains("Ray::new(") || literal;
            if starts_past_zero
                || (from_scratch && !rays_from_scratch.iter().any(|f| path.ends_with(f)))
            {
                found.push(at);
            }
        }
    }
    assert!(
        found.is_empty(),
        "rays made without `Spot`:\n{}",
        found.join("\n")
    );
}
