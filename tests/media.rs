//! Participating media: Beer–Lambert attenuation through a slab, an absorbing ball and a
//! density grid, and an emitting slab's glow, against their closed forms; a white furnace
//! filled with a scattering medium (path and bidirectional tracing); a scene of haze, ink
//! and tinted glass, and a smoke grid, against Mitsuba 3's volumetric path tracer; path, light and
//! bidirectional tracing against each other through media; the same pixels for any thread
//! count and farm tiles; and media read from pbrt-v4 files and written back by `convert`.

#[path = "common/render.rs"]
mod render_common;

use raylink::image::filter::Filter;
use raylink::image::Image;
use raylink::job::MonteCarloSettings;
use raylink::math::{Rgb, Vec3};
use raylink::scene::Scene;
use raylink::{Backend, Technique};
use render_common::{image, View};
use std::path::{Path, PathBuf};

mod agreement;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn toml(text: &str) -> Scene {
    raylink::scene::toml::from_str(text, Path::new("media.toml")).unwrap_or_else(|e| panic!("{e}"))
}

fn pbrt(text: &str) -> Scene {
    raylink::scene::pbrt::from_str(text, Path::new("media.pbrt")).unwrap_or_else(|e| panic!("{e}"))
}

fn path(spp: u32, max_depth: u32) -> Technique {
    Technique::Path(boxed(spp, max_depth))
}

fn boxed(spp: u32, max_depth: u32) -> MonteCarloSettings {
    MonteCarloSettings {
        max_depth,
        spp,
        time_limit: None,
        filter: Filter::Box { radius: 0.5 },
        reconstruction: raylink::image::filter::Reconstruction::Splat,
        adaptive: None,
        max_component_value: None,
        guiding: false,
        spectral: false,
    }
}

fn render(scene: &Scene, spp: u32, seed: u64, accel: Backend) -> Image {
    image(scene, path(spp, 64), View::of(scene, seed, None, accel))
}

fn mean(image: &Image) -> Rgb {
    image.pixels.iter().copied().sum::<Rgb>() / image.pixels.len() as f32
}

/// Asserts `got` is within `tolerance` (relative) of `want` in every channel.
fn assert_close(case: &str, got: Rgb, want: Rgb, tolerance: f32) {
    eprintln!(
        "{case}: {got} against {want}, off by {}",
        got / want - Rgb::ONE
    );
    for c in 0..3 {
        assert!(
            (got[c] / want[c] - 1.0).abs() < tolerance,
            "{case}: channel {c}: {} against {} (tolerance {tolerance})",
            got[c],
            want[c]
        );
    }
}

fn exp(v: Rgb) -> Rgb {
    Rgb::new(v.x.exp(), v.y.exp(), v.z.exp())
}

/// An orthographic camera looking down −z at an emitter of radiance 1 at z = −2, through
/// what `between` adds.
fn through(between: &str, camera_medium: &str, size: f32) -> String {
    format!(
        r#"
[camera]
position = [0, 0, 2]
look_at = [0, 0, 0]
projection = "orthographic"
size = {size}
width = 32
height = 32
{camera_medium}

[materials.light]
diffuse = 0
emission = 1

[materials.boundary]
interface = true

[[shapes]]
type = "quad"
material = "light"
vertices = [[-3, -3, -2], [3, -3, -2], [3, 3, -2], [-3, 3, -2]]
{between}
"#
    )
}

/// Beer–Lambert: light crossing a slab of absorption σa and thickness d keeps e^(−σa·d),
/// per channel, on either backend (delta tracking's estimate is that, without bias).
#[test]
fn a_slab_attenuates_light_by_beer_lambert() {
    let sigma_a = Rgb::new(0.2, 0.5, 1.0);
    let d = 1.0;
    let scene = toml(&through(
        r#"
[media.ink]
type = "homogeneous"
sigma_a = [0.2, 0.5, 1.0]
sigma_s = 0

[[shapes]]
type = "mesh"
material = "boundary"
media = { inside = "ink" }
positions = [[-2, -2, -0.5], [2, -2, -0.5], [2, 2, -0.5], [-2, 2, -0.5],
             [-2, -2, 0.5], [2, -2, 0.5], [2, 2, 0.5], [-2, 2, 0.5]]
indices = [[4, 5, 6], [4, 6, 7], [0, 2, 1], [0, 3, 2], [0, 1, 5], [0, 5, 4],
           [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]]
"#,
        "",
        2.0,
    ));
    let want = exp(-sigma_a * d);
    for accel in [Backend::Embree, Backend::Bvh] {
        let got = mean(&render(&scene, 1024, 1, accel));
        assert_close(&format!("slab, {accel:?}"), got, want, 0.005);
    }
}

/// An emitting slab in the dark, absorbing and not scattering: absorption σa and emitted
/// radiance Le over a thickness d give Le·(1 − e^(−σa·d)) per channel (emission σa·Le per
/// unit length, itself absorbed on its way out).
#[test]
fn an_emitting_slab_glows_by_its_absorption() {
    let sigma_a = Rgb::new(0.3, 1.0, 3.0);
    let le = Rgb::new(2.0, 1.0, 0.5);
    let scene = toml(
        r#"
[camera]
position = [0, 0, 2]
look_at = [0, 0, 0]
projection = "orthographic"
size = 2
width = 32
height = 32

[media.glow]
type = "homogeneous"
sigma_a = [0.3, 1.0, 3.0]
sigma_s = 0
emission = [2, 1, 0.5]

[materials.boundary]
interface = true

[[shapes]]
type = "mesh"
material = "boundary"
media = { inside = "glow" }
positions = [[-2, -2, -0.5], [2, -2, -0.5], [2, 2, -0.5], [-2, 2, -0.5],
             [-2, -2, 0.5], [2, -2, 0.5], [2, 2, 0.5], [-2, 2, 0.5]]
indices = [[4, 5, 6], [4, 6, 7], [0, 2, 1], [0, 3, 2], [0, 1, 5], [0, 5, 4],
           [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]]
"#,
    );
    let want = le * (Rgb::ONE - exp(-sigma_a));
    let got = mean(&render(&scene, 1024, 7, Backend::Embree));
    assert_close("emitting slab", got, want, 0.005);
}

/// A ball of radius r and absorption σ seen by an orthographic camera against a white
/// background: the image's mean is 1 − (2π/W²)·∫₀^r (1 − e^(−2σ√(r²−ρ²))) ρ dρ, in closed
/// form r²/2 − (1 − e^(−2σr)(1 + 2σr))/(4σ²) for the integral.
#[test]
fn an_absorbing_ball_darkens_a_white_background_by_its_chords() {
    let (r, size) = (0.8f32, 2.0f32);
    let sigma = Rgb::new(0.5, 1.5, 3.0);
    let scene = toml(&format!(
        r#"
[camera]
position = [0, 0, 3]
look_at = [0, 0, 0]
projection = "orthographic"
size = {size}
width = 32
height = 32

[world]
background = 1

[media.ink]
type = "homogeneous"
sigma_a = [0.5, 1.5, 3.0]
sigma_s = 0

[materials.boundary]
interface = true

[[shapes]]
type = "sphere"
material = "boundary"
radius = {r}
media = {{ inside = "ink" }}
"#
    ));
    let integral = |s: f32| {
        let k = 2.0 * s;
        r * r / 2.0 - (1.0 - (-k * r).exp() * (1.0 + k * r)) / (k * k)
    };
    let want = Rgb::new(
        1.0 - std::f32::consts::TAU / (size * size) * integral(sigma.x),
        1.0 - std::f32::consts::TAU / (size * size) * integral(sigma.y),
        1.0 - std::f32::consts::TAU / (size * size) * integral(sigma.z),
    );
    let got = mean(&render(&scene, 1024, 2, Backend::Embree));
    assert_close("absorbing ball", got, want, 0.005);
}

/// A white furnace: inside an emitter of radiance 1 that reflects nothing, a medium that
/// scatters everything (albedo 1, a different density per channel, forward scattering)
/// leaves radiance 1 everywhere: every path ends on the emitter.
#[test]
fn a_scattering_medium_in_a_white_furnace_stays_white() {
    let scene = pbrt(
        r#"
MakeNamedMedium "fog" "string type" "homogeneous" "rgb sigma_a" [0 0 0]
    "rgb sigma_s" [0.5 1 2] "float g" 0.5
MediumInterface "fog"
LookAt 0 0 0  0 0 -1  0 1 0
Camera "perspective" "float fov" [60]
Film "rgb" "integer xresolution" [32] "integer yresolution" [32]
WorldBegin
AttributeBegin
  MediumInterface "fog" ""
  Material "diffuse" "rgb reflectance" [0 0 0]
  AreaLightSource "diffuse" "rgb L" [1 1 1] "bool twosided" true
  Shape "sphere" "float radius" 2
AttributeEnd
"#,
    );
    assert_eq!(scene.camera_medium, Some(0));
    let got = mean(&render(&scene, 256, 3, Backend::Embree));
    assert_close("furnace", got, Rgb::ONE, 0.005);
    // Bidirectional: light subpaths leave the emitter into the medium it bounds.
    let view = View::of(&scene, 3, None, Backend::Embree);
    let got = mean(&image(&scene, Technique::Bdpt(boxed(256, 64)), view));
    assert_close("furnace, bdpt", got, Rgb::ONE, 0.005);
}

/// A glowing, scattering ball of chromatic fog in a box of haze lit by a small light: the path
/// and bidirectional tracers give the same mean per channel (the fog's own emission has
/// only the camera subpath as its strategy in the bidirectional tracer).
#[test]
fn path_and_bidirectional_tracing_agree_on_glowing_fog() {
    let text = std::fs::read_to_string(root().join("tests/scenes/media-box.toml")).unwrap();
    let ink = "[media.ink]\ntype = \"homogeneous\"\n";
    assert!(text.contains(ink));
    let text = text.replace(ink, &format!("{ink}emission = [0.5, 1.5, 3]\n"));
    // Tint behind an interface, not glass: the caustics through glass would leave the path
    // tracer too noisy for the comparison.
    let text = text.replace(
        "material = \"glass\"\ncenter = [0.45, 0.4, 0.3]",
        "material = \"boundary\"\ncenter = [0.45, 0.4, 0.3]",
    );
    assert!(text.contains("material = \"boundary\"\ncenter = [0.45"));
    let mut scene = toml(&text);
    assert!(scene.media.iter().any(|m| m.model().emits()));
    scene.camera.width = 16;
    scene.camera.height = 16;
    let path_means = channel_means(&seeds(&scene, &path(256, 64)));
    let bdpt_means = channel_means(&seeds(&scene, &Technique::Bdpt(boxed(64, 64))));
    assert_channels_agree("glowing fog", ("path", path_means), ("bdpt", bdpt_means));
}

/// Renders of `scene` by `technique` with seeds 100 to 107.
fn seeds(scene: &Scene, technique: &Technique) -> Vec<Image> {
    (100..108)
        .map(|seed| {
            let view = View::of(scene, seed, None, Backend::Embree);
            image(scene, technique.clone(), view)
        })
        .collect()
}

/// Each channel's image mean over renders with different seeds, and its variance (the
/// square of its standard error).
fn channel_means(images: &[Image]) -> (Rgb, Rgb) {
    let per_seed: Vec<Rgb> = images.iter().map(mean).collect();
    let k = per_seed.len() as f32;
    let m = per_seed.iter().fold(Rgb::ZERO, |a, &b| a + b) / k;
    let var = per_seed
        .iter()
        .fold(Rgb::ZERO, |a, &b| a + (b - m) * (b - m))
        / ((k - 1.0) * k);
    (m, var)
}

/// Asserts that two estimators' channel means differ by less than 4 standard errors.
fn assert_channels_agree(
    case: &str,
    (ka, (a, va)): (&str, (Rgb, Rgb)),
    (kb, (b, vb)): (&str, (Rgb, Rgb)),
) {
    for c in 0..3 {
        let z = (a[c] - b[c]) / (va[c] + vb[c]).sqrt();
        eprintln!(
            "{case}, channel {c}: {ka} {:.4}, {kb} {:.4}, z = {z:.2}",
            a[c], b[c]
        );
        assert!(
            z.abs() < 4.0,
            "{case}, channel {c}: {ka} {a:?} against {kb} {b:?}"
        );
    }
}

/// Haze filling a closed box (the camera's medium), a ball of chromatic scattering ink and
/// a glass ball holding an absorbing medium: the mean of each channel within 1% of Mitsuba
/// 3's `volpath` (tests/data/media-box-mitsuba-64.exr, made by scripts/media-reference.py).
#[test]
fn haze_ink_and_tinted_glass_agree_with_mitsuba() {
    let scene = Scene::load(&root().join("tests/scenes/media-box.toml")).unwrap();
    let (reference, _) =
        raylink::read_image(&root().join("tests/data/media-box-mitsuba-64.exr")).unwrap();
    let got = mean(&render(&scene, 1024, 4, Backend::Embree));
    let want = mean(&reference);
    eprintln!("media box: raylink {got} against Mitsuba {want}");
    assert_close("media box against Mitsuba", got, want, 0.01);
}

/// A cloud of chromatic smoke given as a density grid in a closed box: the mean of each
/// channel within 1% of Mitsuba 3's `volpath` over a grid volume
/// (tests/data/media-grid-box-mitsuba-64.exr, made by scripts/media-reference.py).
#[test]
fn smoke_grid_agrees_with_mitsuba() {
    let scene = Scene::load(&root().join("tests/scenes/media-grid-box.toml")).unwrap();
    let (reference, _) =
        raylink::read_image(&root().join("tests/data/media-grid-box-mitsuba-64.exr")).unwrap();
    let got = mean(&render(&scene, 256, 4, Backend::Embree));
    let want = mean(&reference);
    eprintln!("media grid box: raylink {got} against Mitsuba {want}");
    assert_close("media grid box against Mitsuba", got, want, 0.01);
}

/// The same pixels for one thread and for several: media draw their free flights from
/// streams keyed by the sample, not by the thread.
#[test]
fn media_render_the_same_for_any_thread_count() {
    let scene = Scene::load(&root().join("tests/scenes/media-box.toml")).unwrap();
    let view = |threads| View {
        size: (24, 24),
        seed: 5,
        threads,
        accel: Backend::Embree,
    };
    let one = image(&scene, path(8, 64), view(Some(1)));
    let two = image(&scene, path(8, 64), view(Some(2)));
    assert!(one.pixels == two.pixels, "the images differ");
}

/// pbrt-v4's `SampledGrid::Lookup` of a grid constant in x and y and `column` along z, at
/// unit-box height `u`: samples at the cells' centres, 0 beyond the grid.
fn column_lookup(column: &[f32], u: f32) -> f32 {
    let n = column.len() as i64;
    let s = u * n as f32 - 0.5;
    let i = s.floor() as i64;
    let at = |k: i64| {
        if (0..n).contains(&k) {
            column[k as usize]
        } else {
            0.0
        }
    };
    at(i) + (at(i + 1) - at(i)) * (s - i as f32)
}

/// A density grid varying along the rays (0.5, 1, 2, 4 over four cells) and constant
/// across them: the light through it keeps e^(−σa·∫density), the integral of the grid's
/// interpolation (computed here by Simpson's rule), read from a pbrt-v4 `uniformgrid` placed
/// by a transform.
#[test]
fn a_density_grid_attenuates_by_its_interpolated_integral() {
    let column = [0.5f32, 1.0, 2.0, 4.0];
    let density: Vec<String> = (0..4 * 4 * 4).map(|i| column[i / 16].to_string()).collect();
    // The unit box of the grid's own space, placed over [-1, 1]² × [-0.5, 0.5].
    let scene = pbrt(&grid_scene(
        &format!(
            r#""string type" "uniformgrid" "integer nx" 4 "integer ny" 4 "integer nz" 4
               "float density" [{}] "rgb sigma_a" [0.2 0.5 1.0] "rgb sigma_s" [0 0 0]"#,
            density.join(" ")
        ),
        32,
    ));
    // The grid as the scene holds it: density at world points against the lookup.
    let grid = scene.media[0].model();
    for z in [-0.45f32, -0.2, 0.0, 0.13, 0.4] {
        let d = grid.at(Vec3::new(0.1, -0.3, z)).sigma_a.x / 0.2;
        let want = column_lookup(&column, z + 0.5);
        assert!(
            (d - want).abs() < 1e-4,
            "density at z {z}: {d} against {want}"
        );
    }
    let n = 1000;
    let h = 1.0 / n as f32;
    let integral = (0..=n)
        .map(|i| {
            let w = if i == 0 || i == n {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            w * column_lookup(&column, i as f32 * h)
        })
        .sum::<f32>()
        * h
        / 3.0;
    let want = exp(-Rgb::new(0.2, 0.5, 1.0) * integral);
    let got = mean(&render(&scene, 2048, 6, Backend::Embree));
    assert_close("density grid", got, want, 0.005);
}

/// `convert` writes media, the camera's medium, shapes' interfaces and interface materials
/// so that they read back as they were.
#[test]
fn convert_writes_media_that_read_back_the_same() {
    let dir = tempfile::tempdir().unwrap();
    let grid = r#"
[media.smoke]
type = "uniformgrid"
sigma_a = [0.1, 0.2, 0.3]
sigma_s = 0.5
emission = [1, 0.5, 0]
g = 0.25
resolution = [2, 1, 2]
density = [0, 1, 2, 3]
emission_scale = [1, 1, 0.5, 0]
bounds = [[-1, -1, -1], [1, 1, 1]]
transform = { rotate = { axis = [0, 1, 0], degrees = 30 } }
"#;
    let text = std::fs::read_to_string(root().join("tests/scenes/media-box.toml")).unwrap();
    let source = dir.path().join("in.toml");
    std::fs::write(&source, format!("{text}\n{grid}")).unwrap();
    let scene = Scene::load(&source).unwrap();
    let out = dir.path().join("out.toml");
    raylink::scene::convert::write_toml(&scene, &out).unwrap();
    let back = Scene::load(&out).unwrap();
    assert_eq!(back.media, scene.media);
    assert_eq!(back.camera_medium, scene.camera_medium);
    let interfaces = |s: &Scene| s.shapes.iter().map(|s| s.media).collect::<Vec<_>>();
    assert_eq!(interfaces(&back), interfaces(&scene));
    let kinds = |s: &Scene| {
        s.materials
            .iter()
            .map(|m| m.is_interface())
            .collect::<Vec<_>>()
    };
    assert_eq!(kinds(&back), kinds(&scene));
    assert!(kinds(&scene).contains(&true));
}

/// Farm tiles of a scene with media merge into the whole render, bit for bit: free flights
/// are drawn from the pixel's own sample streams.
#[test]
fn farm_tiles_of_media_merge_into_the_whole_render() {
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str| dir.path().join(name).to_string_lossy().into_owned();
    let run = |args: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_raylink"))
            .args(args)
            .current_dir(root())
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    let options = [
        "-q",
        "--width",
        "24",
        "--height",
        "20",
        "--spp",
        "4",
        "--filter",
        "gaussian",
        "--filter-radius",
        "1.5",
        "--seed",
        "9",
    ];
    let scene = "tests/scenes/media-box.toml";
    let whole = at("whole.exr");
    run(&[&["render", scene, "-o", &whole][..], &options].concat());
    let pattern = at("tile_{tile}.exr");
    for tile in ["0/3", "1/3", "2/3"] {
        run(&[
            &["render", scene, "--tile", tile, "-o", &pattern][..],
            &options,
        ]
        .concat());
    }
    let merged = at("merged.exr");
    let parts: Vec<String> = (0..3).map(|i| at(&format!("tile_{i}.exr"))).collect();
    let mut args = vec!["merge", "-o", &merged];
    args.extend(parts.iter().map(String::as_str));
    run(&args);
    let (a, _) = raylink::read_image(Path::new(&whole)).unwrap();
    let (b, _) = raylink::read_image(Path::new(&merged)).unwrap();
    assert!(mean(&a).min_element() > 0.0, "the render is black");
    assert!(
        a.pixels == b.pixels,
        "the merged tiles differ from the whole render"
    );
}

/// The test box with its ink ball made a density grid (denser towards the ball's top and
/// one side) over the ball's bounds.
fn box_with_grid_ink(text: &str) -> String {
    let homogeneous = "[media.ink]\ntype = \"homogeneous\"\n";
    assert!(text.contains(homogeneous));
    let density: Vec<String> = (0..64)
        .map(|i| format!("{}", 0.25 + 0.5 * (i % 4) as f32 + 0.25 * (i / 16) as f32))
        .collect();
    text.replace(
        homogeneous,
        &format!(
            "[media.ink]\ntype = \"uniformgrid\"\nresolution = [4, 4, 4]\n\
             bounds = [[-0.9, 0, -0.65], [0, 0.9, 0.25]]\ndensity = [{}]\n",
            density.join(", ")
        ),
    )
}

/// Renders `scene` by each technique over 8 seeds and asserts that they agree pixel by
/// pixel and over the image.
fn assert_techniques_agree(case: &str, scene: &Scene, runs: &[(&str, Technique)]) {
    let results = agreement::over_seeds(runs.iter().cloned(), |technique, seed| {
        image(
            scene,
            technique.clone(),
            View::of(scene, seed, None, Backend::Embree),
        )
    });
    let means: Vec<f64> = results
        .iter()
        .map(|(_, m, _)| m.iter().sum::<f64>() / m.len() as f64)
        .collect();
    eprintln!("{case}: image means {means:?}");
    agreement::assert_agree(&results, |_, _, _| true);
}

/// Path tracing (gathering from the camera), light tracing (shooting from the light) and
/// bidirectional path tracing (both, with every connection between them) agree, pixel by
/// pixel and over the image, on a box of haze holding a ball of coloured scattering ink of
/// varying density (a grid) and a ball of absorbing tint, both bounded by interfaces: three
/// independent estimators of the same light through media.
#[test]
fn path_light_and_bidirectional_tracing_agree_through_media() {
    let text = std::fs::read_to_string(root().join("tests/scenes/media-box.toml")).unwrap();
    // The glass ball becomes a ball of tint bounded by an interface: light tracing cannot
    // see through a smooth dielectric.
    let text = text.replace(
        "material = \"glass\"\ncenter = [0.45, 0.4, 0.3]",
        "material = \"boundary\"\ncenter = [0.45, 0.4, 0.3]",
    );
    assert!(text.contains("material = \"boundary\"\ncenter = [0.45"));
    let mut scene = toml(&box_with_grid_ink(&text));
    scene.camera.width = 20;
    scene.camera.height = 20;
    let runs = [
        ("path", Technique::Path(boxed(64, 64))),
        ("light", Technique::Light(boxed(64, 64))),
        ("bdpt", Technique::Bdpt(boxed(16, 64))),
    ];
    assert_techniques_agree("path, light and bdpt through media", &scene, &runs);
}

/// An open scene lit from infinity (a blue sky and a sun) and by a small lamp that bounds a
/// medium: a ball of fog around the lamp (the lamp's outside is the fog) and a box of ink
/// of varying density (a grid) on a floor.
const SKY_FOG_AND_INK: &str = r#"
[camera]
position = [0, 1.3, 4]
look_at = [0, 0.5, 0]
fov = 45
width = 20
height = 20

[world]
background = [0.3, 0.45, 0.7]

[[lights]]
type = "directional"
direction = [0.5, -1, -0.4]
irradiance = [2, 1.8, 1.4]

[media.fog]
type = "homogeneous"
sigma_a = [0.1, 0.2, 0.3]
sigma_s = [1.0, 1.4, 1.8]
g = 0.3

[media.ink]
type = "uniformgrid"
sigma_a = 0.3
sigma_s = [2, 1.5, 1]
resolution = [2, 2, 2]
density = [0.2, 1.5, 0.5, 1.0, 1.2, 0.3, 0.8, 2.0]
bounds = [[0.2, 0, -0.5], [1.2, 1, 0.5]]

[materials.ground]
diffuse = 0.5

[materials.boundary]
interface = true

[materials.lamp]
diffuse = 0
emission = [6, 4, 2]

[[shapes]]
type = "mesh"
material = "ground"
positions = [[-3, 0, -3], [3, 0, -3], [3, 0, 3], [-3, 0, 3]]
indices = [[0, 2, 1], [0, 3, 2]]

[[shapes]]
type = "sphere"
material = "boundary"
center = [-0.6, 0.6, 0]
radius = 0.6
media = { inside = "fog" }

[[shapes]]
type = "sphere"
material = "lamp"
center = [-0.6, 0.6, 0]
radius = 0.15
media = { outside = "fog" }

[[shapes]]
type = "mesh"
material = "boundary"
positions = [[0.2, 0, -0.5], [1.2, 0, -0.5], [1.2, 1, -0.5], [0.2, 1, -0.5],
             [0.2, 0, 0.5], [1.2, 0, 0.5], [1.2, 1, 0.5], [0.2, 1, 0.5]]
indices = [[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
           [3, 7, 6], [3, 6, 2], [0, 4, 7], [0, 7, 3], [1, 2, 6], [1, 6, 5]]
media = { inside = "ink" }
"#;

/// Path, light and bidirectional tracing agree, pixel by pixel and over the image, on
/// media lit from infinity (sky and sun reach the fog and the ink through their
/// boundaries; the sky is seen through them) and by an emitter that bounds a medium (light
/// paths leave the lamp in the fog around it).
#[test]
fn path_light_and_bidirectional_tracing_agree_on_media_under_the_sky_and_around_a_lamp() {
    let scene = toml(SKY_FOG_AND_INK);
    let runs = [
        ("path", Technique::Path(boxed(64, 64))),
        ("light", Technique::Light(boxed(64, 64))),
        ("bdpt", Technique::Bdpt(boxed(32, 64))),
    ];
    assert_techniques_agree("sky, fog and ink", &scene, &runs);
}

/// Path tracing and bidirectional path tracing agree on the box with its ink grid, the
/// tint inside a glass ball (a medium seen and lit through a smooth dielectric) and haze
/// that scatters blue fifteen times as much as red: pixel by pixel, and channel by channel
/// over the image, where a wrong weighting of the channels' densities shows.
#[test]
fn path_and_bidirectional_tracing_agree_through_tinted_glass() {
    let text = std::fs::read_to_string(root().join("tests/scenes/media-box.toml")).unwrap();
    assert!(text.contains("material = \"glass\"\ncenter = [0.45"));
    let haze = "sigma_s = [0.15, 0.2, 0.3]";
    assert!(text.contains(haze));
    let text = text.replace(haze, "sigma_s = [0.1, 0.6, 1.5]");
    let mut scene = toml(&box_with_grid_ink(&text));
    scene.camera.width = 20;
    scene.camera.height = 20;
    let runs = [
        ("path", Technique::Path(boxed(64, 64))),
        ("bdpt", Technique::Bdpt(boxed(16, 64))),
    ];
    let mut results = Vec::new();
    let mut channels = Vec::new();
    for (name, technique) in &runs {
        let images = seeds(&scene, technique);
        channels.push((*name, channel_means(&images)));
        let (pm, pv) = agreement::stats(&images);
        results.push((*name, pm, pv));
    }
    assert_channels_agree("tinted glass", channels[0], channels[1]);
    agreement::assert_agree(&results, |_, _, _| true);
}

/// A box of a grid medium over [-1, 1]² × [-0.5, 0.5] (its unit box placed by a transform)
/// in front of an emitter, seen by an orthographic camera on a film of `size`² pixels, with
/// `medium` as its `MakeNamedMedium` parameters.
fn grid_scene(medium: &str, size: u32) -> String {
    format!(
        r#"
LookAt 0 0 2  0 0 0  0 1 0
Camera "orthographic" "float screenwindow" [-0.7 0.7 -0.7 0.7]
Film "rgb" "integer xresolution" [{size}] "integer yresolution" [{size}]
WorldBegin
AttributeBegin
  Translate -1 -1 -0.5
  Scale 2 2 1
  MakeNamedMedium "smoke" {medium}
AttributeEnd
AttributeBegin
  MediumInterface "smoke" ""
  Material "interface"
  Shape "trianglemesh" "point3 P" [-2 -2 -0.5  2 -2 -0.5  2 2 -0.5  -2 2 -0.5
      -2 -2 0.5  2 -2 0.5  2 2 0.5  -2 2 0.5]
    "integer indices" [4 5 6 4 6 7  0 2 1 0 3 2  0 1 5 0 5 4  1 2 6 1 6 5  2 3 7 2 7 6
      3 0 4 3 4 7]
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1]
  Shape "trianglemesh" "point3 P" [-3 -3 -2  3 -3 -2  3 3 -2  -3 3 -2]
    "integer indices" [0 1 2 0 2 3]
AttributeEnd
"#
    )
}

/// pbrt-v4's `rgbgrid` with grey coefficients is the `uniformgrid` of the same densities:
/// the same coefficients at every point, and renders within noise of each other.
#[test]
fn a_grey_rgbgrid_renders_like_its_uniformgrid() {
    let density: Vec<f32> = (0..3 * 4 * 2).map(|i| ((i * 7) % 5) as f32 * 0.6).collect();
    let list = |k: f32, triple: bool| {
        let v: Vec<String> = density
            .iter()
            .map(|d| {
                let x = (d * k).to_string();
                if triple {
                    format!("{x} {x} {x}")
                } else {
                    x
                }
            })
            .collect();
        v.join(" ")
    };
    let res = r#""integer nx" 3 "integer ny" 4 "integer nz" 2 "float g" 0.3"#;
    let uniform = pbrt(&grid_scene(
        &format!(
            r#""string type" "uniformgrid" {res} "float density" [{}]
           "rgb sigma_a" [0.6 0.6 0.6] "rgb sigma_s" [0.3 0.3 0.3] "float scale" 2"#,
            list(1.0, false)
        ),
        16,
    ));
    let rgb = pbrt(&grid_scene(
        &format!(
            r#""string type" "rgbgrid" {res} "rgb sigma_a" [{}] "rgb sigma_s" [{}]
           "float scale" 2"#,
            list(0.6, true),
            list(0.3, true)
        ),
        16,
    ));
    let (a, b) = (uniform.media[0].model(), rgb.media[0].model());
    assert_eq!(b.kind(), "rgbgrid");
    let mut rng = raylink::math::Rng::for_key(3, &[]);
    for _ in 0..2000 {
        let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.4 - Vec3::splat(1.2);
        let (pa, pb) = (a.at(p), b.at(p));
        let off = (pa.sigma_a - pb.sigma_a)
            .abs()
            .max(pa.sigma_s - pb.sigma_s)
            .max_element();
        assert!(off < 1e-5, "at {p}: {pa:?} against {pb:?}");
        assert_eq!(pa.g, pb.g);
    }
    let (ia, ib) = (
        render(&uniform, 64, 9, Backend::Embree),
        render(&rgb, 64, 9, Backend::Embree),
    );
    assert_close("grey rgbgrid", mean(&ib), mean(&ia), 0.01);
}

/// An rgbgrid with colours, emission and a transform goes through `convert` and reads back
/// the same, and a `[media]` table of type rgbgrid reads as pbrt's does.
#[test]
fn rgbgrids_convert_and_read_back_the_same() {
    let scene = pbrt(&grid_scene(
        r#""string type" "rgbgrid" "integer nx" 2 "rgb sigma_a" [0.1 0.2 0.3  1 2 3]
           "rgb Le" [0 0 0  4 2 1] "float Lescale" 0.5 "float g" -0.2
           "point3 p0" [-1 -1 -1] "point3 p1" [1 1 1]"#,
        16,
    ));
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.toml");
    raylink::scene::convert::write_toml(&scene, &out).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("type = \"rgbgrid\""), "{text}");
    let back = Scene::load(&out).unwrap();
    assert_eq!(back.media, scene.media);
    let m = scene.media[0].model();
    assert!(m.emits());
    // The second sample's centre, (0.5, 0, 0) of the box [-1, 1]³, placed by the transform.
    let p = Vec3::new(-1.0, -1.0, -0.5) + Vec3::new(2.0, 2.0, 1.0) * Vec3::new(0.5, 0.0, 0.0);
    let at = m.at(p);
    assert!(
        (at.sigma_a - Rgb::new(1.0, 2.0, 3.0)).abs().max_element() < 1e-5,
        "{at:?}"
    );
    assert_eq!(at.sigma_s, Rgb::ONE, "sigma_s not given is 1");
    assert!(
        (at.le - Rgb::new(2.0, 1.0, 0.5)).abs().max_element() < 1e-5,
        "{at:?}"
    );
    let native = toml(&format!(
        "{}\n[media.colours]\ntype = \"rgbgrid\"\nresolution = [2, 1, 1]\n\
         sigma_a_grid = [0.1, 0.2, 0.3, 1, 2, 3]\nemission_grid = [0, 0, 0, 2, 1, 0.5]\n\
         g = -0.2\nbounds = [[-1, -1, -1], [1, 1, 1]]\n",
        std::fs::read_to_string(root().join("tests/scenes/media-box.toml")).unwrap()
    ));
    let tint = native
        .media
        .iter()
        .find(|m| m.name == "colours")
        .unwrap()
        .model();
    let q = Vec3::new(0.5, 0.0, 0.0);
    assert_eq!(tint.at(q), {
        let mut want = at;
        want.g = -0.2;
        want
    });
}

/// pbrt-v4's `preset` gives a homogeneous medium the measured coefficients it names (times
/// `scale`), replacing `sigma_a` and `sigma_s`; an unknown name keeps them.
#[test]
fn a_preset_medium_has_the_measured_coefficients() {
    let medium = |params: &str| {
        let scene = pbrt(&format!(
            "MakeNamedMedium \"m\" \"string type\" \"homogeneous\" {params}\n\
             LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\nShape \"sphere\"\n"
        ));
        scene.media[0].model().at(Vec3::ZERO)
    };
    let milk = medium(r#""string preset" "Skimmilk" "float scale" 10"#);
    let near = |a: Rgb, b: Rgb| (a - b).abs().max_element() < 1e-6;
    assert!(
        near(milk.sigma_a, Rgb::new(0.014, 0.025, 0.142)),
        "{milk:?}"
    );
    assert!(near(milk.sigma_s, Rgb::new(7.0, 12.2, 19.0)), "{milk:?}");
    let coffee = medium(r#""string preset" "Espresso""#);
    assert!(
        near(coffee.sigma_a, Rgb::new(4.7984, 6.5751, 8.8493)),
        "{coffee:?}"
    );
    assert!(
        near(coffee.sigma_s, Rgb::new(0.72378, 0.84557, 1.0247)),
        "{coffee:?}"
    );
    let unknown = medium(r#""string preset" "Quicksilver" "rgb sigma_a" [1 2 3]"#);
    assert_eq!(unknown.sigma_a, Rgb::new(1.0, 2.0, 3.0));
    assert_eq!(unknown.sigma_s, Rgb::ONE);
}

/// A medium's `Le "blackbody" T` is normalised as pbrt-v4 normalises emitters (luminance 1,
/// times `Lescale`) and has the chromaticity of the Planckian locus at T.
#[test]
fn blackbody_emission_has_the_planckian_chromaticity() {
    for (kelvin, x, y) in [(3000.0, 0.4369, 0.4041), (6500.0, 0.3135, 0.3237)] {
        let scene = pbrt(&format!(
            "MakeNamedMedium \"m\" \"string type\" \"homogeneous\" \"blackbody Le\" {kelvin}
             \"float Lescale\" 2\n\
             LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\nShape \"sphere\"\n"
        ));
        let le = scene.media[0].model().at(Vec3::ZERO).le;
        // Linear sRGB to XYZ.
        let xyz = [
            0.4124 * le.x + 0.3576 * le.y + 0.1805 * le.z,
            0.2126 * le.x + 0.7152 * le.y + 0.0722 * le.z,
            0.0193 * le.x + 0.1192 * le.y + 0.9505 * le.z,
        ];
        let sum = xyz[0] + xyz[1] + xyz[2];
        let (cx, cy) = (xyz[0] / sum, xyz[1] / sum);
        eprintln!("{kelvin} K: Le {le}, Y {}, xy ({cx:.4}, {cy:.4})", xyz[1]);
        assert!((xyz[1] - 2.0).abs() < 0.06, "{kelvin} K: Y {}", xyz[1]);
        assert!(
            (cx - x).abs() < 0.01 && (cy - y).abs() < 0.01,
            "{kelvin} K: xy ({cx}, {cy}) against ({x}, {y})"
        );
    }
}
