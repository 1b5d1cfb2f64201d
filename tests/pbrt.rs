//! The pbrt-v4 reader end to end: Bitterli's Cornell box against the same scene written in
//! TOML, statements and transforms on small scenes, PLY in every encoding, and the bad-input
//! corpus in tests/bad_pbrt.

use raylink::accel::{self, Backend};
use raylink::image::Image;
use raylink::integrators::whitted::{Whitted, WhittedOptions};
use raylink::integrators::Context;
use raylink::math::{Rgb, Vec3};
use raylink::render::{render, PixelSampling, RenderOptions};
use raylink::scene::{Geometry, Scene};
use std::path::{Path, PathBuf};

#[allow(dead_code)]
fn _unused(_: &Path, _: &Geometry) {}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn bitterli() -> PathBuf {
    root().join("../shared/scenes/cornell-box-bitterli/scene-v4.pbrt")
}

fn whitted_render(scene: &Scene, size: u32) -> Image {
    let accel = accel::build(scene, Backend::Embree).unwrap();
    let ctx = Context::new(scene, accel.as_ref());
    let options = RenderOptions {
        width: size,
        height: size,
        sampling: PixelSampling::Uniform { n: 2 },
        threads: Some(2),
        seed: 7,
        progress: false,
    };
    render(&ctx, &Whitted::new(WhittedOptions::default()), &options)
        .unwrap()
        .0
}

#[test]
fn bitterli_cornell_box_loads_with_the_expected_contents() {
    let scene = Scene::load(&bitterli()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.shapes.len(), 8);
    assert_eq!(scene.materials.len(), 8);
    assert!(scene.lights.is_empty());
    let emitters: Vec<_> = scene.materials.iter().filter(|m| m.is_emissive()).collect();
    assert_eq!(emitters.len(), 1);
    assert_eq!(emitters[0].emission, Rgb::new(17.0, 12.0, 4.0));
    let cam = &scene.camera;
    assert!(
        (cam.position - Vec3::new(0.0, 1.0, 6.8)).length() < 1e-5,
        "{cam:?}"
    );
    assert!(((cam.look_at - cam.position).normalize() - Vec3::NEG_Z).length() < 1e-5);
    assert!((cam.up - Vec3::Y).length() < 1e-5);
    assert_eq!((cam.width, cam.height, cam.fov_deg), (1024, 1024, 19.5));
    assert_eq!(scene.settings.spp, Some(64));
    assert_eq!(scene.settings.max_depth, Some(65));
    assert_eq!(scene.settings.integrator.as_deref(), Some("path"));
    assert_eq!(
        scene.settings.filter,
        Some(raylink::image::filter::Filter::Triangle { radius: 1.0 })
    );
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    // The light faces down, as pbrt's normals say.
    let light = scene
        .shapes
        .iter()
        .find(|s| scene.materials[s.material].is_emissive())
        .unwrap();
    for [a, b, c] in light.geometry.triangles() {
        assert!((b - a).cross(c - a).y < 0.0);
    }
}

/// Mean colour of a vertical band of the image (x in [x0, x1) as fractions of the width,
/// middle half of the height).
fn band(image: &Image, x0: f32, x1: f32) -> Rgb {
    let (w, h) = (image.width as f32, image.height as f32);
    let mut sum = Rgb::ZERO;
    let mut n = 0.0;
    for y in (h * 0.25) as u32..(h * 0.75) as u32 {
        for x in (w * x0) as u32..(w * x1) as u32 {
            sum += image.get(x, y);
            n += 1.0;
        }
    }
    sum / n
}

/// The pbrt file and scenes/cornell-box.toml (the same scene written by hand) give the same
/// Whitted image; with the same ambient term (pbrt has none, the TOML sets 0.05), the RMSE
/// is below 1% of the mean pixel value. The red wall is on the left as in Tungsten's
/// reference image, so the camera does not mirror.
#[test]
fn bitterli_pbrt_renders_like_the_toml_cornell_box_and_the_reference() {
    let mut from_pbrt = Scene::load(&bitterli()).unwrap();
    let toml = Scene::load(&root().join("scenes/cornell-box.toml")).unwrap();
    from_pbrt.ambient = toml.ambient;
    let a = whitted_render(&from_pbrt, 128);
    let b = whitted_render(&toml, 128);
    let mean: f32 =
        b.pixels.iter().map(|p| p.element_sum() / 3.0).sum::<f32>() / b.pixels.len() as f32;
    let rmse = a.rmse(&b);
    eprintln!("pbrt vs TOML Whitted RMSE {rmse} (mean {mean})");
    assert!(mean > 0.05);
    assert!(rmse < 0.01 * mean, "RMSE {rmse}, mean {mean}");

    let (reference, _) =
        raylink::image::output::read_image(&bitterli().with_file_name("TungstenRender.png"))
            .unwrap();
    for image in [&a, &reference] {
        let (left, right) = (band(image, 0.0, 0.15), band(image, 0.85, 1.0));
        assert!(
            left.x > 1.5 * left.y && right.y > 1.2 * right.x,
            "{left} {right}"
        );
    }
}

/// The substring a bad case's message must contain, from its first line `# expect: ...`.
fn expectation(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .next()
        .and_then(|l| l.strip_prefix("# expect: "))
        .unwrap_or_else(|| panic!("{}: first line must be `# expect: ...`", path.display()))
        .trim_end()
        .to_string()
}

fn bad_cases() -> Vec<PathBuf> {
    let dir = root().join("tests/bad_pbrt");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "pbrt"))
        .collect();
    files.sort();
    files
}

#[test]
fn bad_pbrt_files_fail_with_one_line_naming_file_line_and_problem() {
    let files = bad_cases();
    assert!(files.len() >= 20, "only {} cases", files.len());
    let mut failures = Vec::new();
    for path in &files {
        let expect = expectation(path);
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        match std::panic::catch_unwind(|| Scene::load(path)) {
            Err(_) => failures.push(format!("{name}: panicked")),
            Ok(Ok(_)) => failures.push(format!("{name}: loaded, expected an error")),
            Ok(Err(e)) => {
                let msg = e.to_string();
                if msg.contains('\n') || !msg.contains(&name) || !msg.contains(&expect) {
                    failures.push(format!("{name}: `{expect}` not in:\n      {msg}"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "\n  {}", failures.join("\n  "));
}
