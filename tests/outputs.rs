//! What the render command writes: multilayer EXR outputs with the auxiliary images.

use raylink::image::io;
use raylink::image::output::read_image;
use std::path::Path;

mod common;
use common::{raylink, stderr};

/// Two quads side by side at z = -4 facing a camera at the origin: the left one (the first
/// shape) of material `blue`, the right one of material `red`, listed in the other order.
const TWO_QUADS: &str = r#"
[camera]
position = [0, 0, 0]
look_at = [0, 0, -1]
fov = 40
width = 16
height = 16

[materials.red]
diffuse = [0.8, 0.1, 0.1]

[materials.blue]
diffuse = [0.1, 0.2, 0.7]

[[shapes]]
type = "quad"
material = "blue"
vertices = [[-10, -10, -4], [0, -10, -4], [0, 10, -4], [-10, 10, -4]]

[[shapes]]
type = "quad"
material = "red"
vertices = [[0, -10, -4], [10, -10, -4], [10, 10, -4], [0, 10, -4]]

[[lights]]
type = "point"
position = [0, 3, 0]
intensity = 20
"#;

/// The channel `name` of `raw`, one value a pixel.
fn channel(raw: &io::RawImage, name: &str) -> Vec<f32> {
    let n = raw.channels.len();
    let c = raw
        .channels
        .iter()
        .position(|c| c == name)
        .unwrap_or_else(|| panic!("no channel {name} in {:?}", raw.channels));
    raw.data.chunks_exact(n).map(|p| p[c]).collect()
}

#[test]
fn aov_exr_holds_every_auxiliary_image_as_a_layer() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("quads.toml");
    std::fs::write(&scene, TWO_QUADS).unwrap();
    let exr = dir.path().join("out.exr");
    let tif = dir.path().join("out.tif");
    let out = raylink(&[
        "render",
        scene.to_str().unwrap(),
        "--aov",
        "-o",
        exr.to_str().unwrap(),
        "-o",
        tif.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));

    let raw = io::read(&exr).unwrap();
    let mut names = raw.channels.clone();
    names.sort();
    let mut expected = [
        "R",
        "G",
        "B",
        "albedo.R",
        "albedo.G",
        "albedo.B",
        "normal.X",
        "normal.Y",
        "normal.Z",
        "depth.Z",
        "P.X",
        "P.Y",
        "P.Z",
        "IndexOB.X",
        "IndexMA.X",
    ]
    .map(String::from)
    .to_vec();
    expected.sort();
    assert_eq!(names, expected);

    // The main image is the one the TIFF (which has no layers) holds.
    let plain = io::read(&tif).unwrap();
    assert_eq!(plain.channels, ["R", "G", "B"]);
    for c in ["R", "G", "B"] {
        assert_eq!(channel(&raw, c), channel(&plain, c), "{c}");
    }
    // Each layer is the separate auxiliary image, value for value.
    for (file, layer) in [
        ("albedo", ["albedo.R", "albedo.G", "albedo.B"]),
        ("normal", ["normal.X", "normal.Y", "normal.Z"]),
        ("depth", ["depth.Z", "depth.Z", "depth.Z"]),
    ] {
        let own = io::read(&dir.path().join(format!("out.{file}.exr"))).unwrap();
        for (c, name) in ["R", "G", "B"].iter().zip(layer) {
            assert_eq!(channel(&raw, name), channel(&own, c), "{name}");
        }
    }
    // The quads lie at z = -4 and the camera at the origin: every point seen has P.Z = -4,
    // and its distance is the depth.
    let (px, py, pz) = (
        channel(&raw, "P.X"),
        channel(&raw, "P.Y"),
        channel(&raw, "P.Z"),
    );
    let depth = channel(&raw, "depth.Z");
    for i in 0..px.len() {
        assert!((pz[i] + 4.0).abs() < 1e-4, "P.Z {} at {i}", pz[i]);
        let d = (px[i] * px[i] + py[i] * py[i] + pz[i] * pz[i]).sqrt();
        assert!(
            (d - depth[i]).abs() < 2e-3 * depth[i],
            "|P| {d} depth {}",
            depth[i]
        );
    }
    // The left half sees the first shape, the right half the second; their materials are
    // 1 + their indices in the scene.
    let loaded = raylink::Scene::load(&scene).unwrap();
    let material = |name: &str| {
        1.0 + loaded
            .materials
            .iter()
            .position(|m| m.name == name)
            .unwrap() as f32
    };
    let (objects, materials) = (channel(&raw, "IndexOB.X"), channel(&raw, "IndexMA.X"));
    assert_ne!(material("blue"), material("red"));
    for y in 0..16 {
        for x in 0..16 {
            let i = y * 16 + x;
            let (object, mat) = if x < 8 {
                (1.0, material("blue"))
            } else {
                (2.0, material("red"))
            };
            assert_eq!((objects[i], materials[i]), (object, mat), "pixel {x},{y}");
        }
    }
    // Readers that want RGB still get the main image.
    let (rgb, _) = read_image(&exr).unwrap();
    assert_eq!(
        rgb.pixels.iter().map(|p| p.x).collect::<Vec<_>>(),
        channel(&raw, "R")
    );
    assert!(Path::new(&dir.path().join("out.albedo.exr")).exists());
}

/// With the path tracer, `--aov` adds each pixel's sample statistics as layers (`error.X`,
/// `variance.R/G/B`, `samples.X`) though adaptive sampling is off: read back, they are the
/// film's own statistics of the same job through the library, value for value, and the
/// image is the same as without `--aov`. Light tracing, whose samples are no pixel's own,
/// writes none.
#[test]
fn aov_exr_holds_the_path_tracers_variance_without_adaptive_sampling() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("quads.toml");
    std::fs::write(&scene, TWO_QUADS).unwrap();
    let run = |name: &str, extra: &[&str]| {
        let exr = dir.path().join(name);
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "--spp",
            "8",
            "--seed",
            "4",
            "-o",
            exr.to_str().unwrap(),
            "--quiet",
        ];
        args.extend_from_slice(extra);
        let out = raylink(&args);
        assert!(out.status.success(), "{}", stderr(&out));
        io::read(&exr).unwrap()
    };
    let raw = run("path.exr", &["--integrator", "path", "--aov"]);
    for name in [
        "error.X",
        "variance.R",
        "variance.G",
        "variance.B",
        "samples.X",
    ] {
        assert!(
            raw.channels.iter().any(|c| c == name),
            "{name} in {:?}",
            raw.channels
        );
    }
    assert!(channel(&raw, "samples.X").iter().all(|&n| n == 8.0));
    let plain = run("plain.exr", &["--integrator", "path"]);
    for c in ["R", "G", "B"] {
        assert_eq!(channel(&raw, c), channel(&plain, c), "{c}");
    }

    // The same job through the library.
    let loaded = raylink::Scene::load(&scene).unwrap();
    let given = raylink::settings::Settings {
        integrator: Some(raylink::settings::TechniqueKind::Path),
        spp: Some(8),
        ..Default::default()
    };
    let technique = raylink::job::technique_for(&loaded, &given).unwrap();
    let job = raylink::Job {
        seed: 4,
        statistics: true,
        ..raylink::Job::new(&loaded, technique)
    };
    let control = raylink::control::Control::default();
    let mut renderer = raylink::Renderer::new(loaded, job, &control).unwrap();
    let film = renderer.render(&control).unwrap().film.unwrap();
    let [error, variance, _] = film.statistics_images().unwrap().unwrap();
    assert_eq!(
        channel(&raw, "error.X"),
        error.pixels.iter().map(|p| p.x).collect::<Vec<_>>()
    );
    for (c, name) in ["variance.R", "variance.G", "variance.B"]
        .iter()
        .enumerate()
    {
        let own: Vec<f32> = variance.pixels.iter().map(|p| [p.x, p.y, p.z][c]).collect();
        assert_eq!(channel(&raw, name), own, "{name}");
    }
    assert!(variance.pixels.iter().any(|p| p.x > 0.0), "some noise");

    let light = run("light.exr", &["--integrator", "light", "--aov"]);
    assert!(
        !light.channels.iter().any(|c| c.starts_with("variance.")),
        "{:?}",
        light.channels
    );
}

/// A small pbrt scene whose film names `film` (none if empty).
fn pbrt_scene(film: &str) -> String {
    let filename = if film.is_empty() {
        String::new()
    } else {
        format!(" \"string filename\" \"{film}\"")
    };
    format!(
        "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n\
         Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 6{filename}\n\
         WorldBegin\nLightSource \"point\" \"point3 from\" [0 0 5] \"rgb I\" [5 5 5]\n\
         Shape \"sphere\" \"float radius\" 1\n"
    )
}

/// Runs raylink in `dir`.
fn raylink_in(dir: &Path, args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_raylink"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

fn files_under(dir: &Path) -> Vec<String> {
    fn walk(root: &Path, dir: &Path, names: &mut Vec<String>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, names);
            } else {
                names.push(p.strip_prefix(root).unwrap().display().to_string());
            }
        }
    }
    let mut names = Vec::new();
    walk(dir, dir, &mut names);
    names.sort();
    names
}

#[test]
fn pbrt_film_filename_is_the_output_without_o() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("scene")).unwrap();
    let scene = dir.path().join("scene/a.pbrt");
    std::fs::write(&scene, pbrt_scene("film.png")).unwrap();
    // Relative to the current directory, as pbrt-v4 takes it, not to the scene's folder.
    let out = raylink_in(dir.path(), &["render", "scene/a.pbrt", "--quiet"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (image, _) = read_image(&dir.path().join("film.png")).unwrap();
    assert_eq!((image.width, image.height), (8, 6));
    assert!(image.pixels.iter().any(|p| p.x > 0.0), "the sphere is lit");
    assert!(!dir.path().join("scene/film.png").exists());

    // -o wins over the film's name.
    let out = raylink_in(
        dir.path(),
        &["render", "scene/a.pbrt", "-o", "o.exr", "--quiet"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(
        files_under(dir.path()),
        ["film.png", "o.exr", "scene/a.pbrt"]
    );

    // Bad input: one line naming what is wrong, exit 2, nothing written.
    for (film, needles) in [
        ("", vec!["-o FILE is needed", "a.pbrt names no output"]),
        (
            "film.bmp",
            vec!["Film \"filename\"", "unsupported output format .bmp"],
        ),
        (
            "missing/film.exr",
            vec!["Film \"filename\"", "does not exist"],
        ),
        ("scene/a.pbrt", vec!["a.pbrt"]),
    ] {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("scene")).unwrap();
        std::fs::write(dir.path().join("scene/a.pbrt"), pbrt_scene(film)).unwrap();
        let out = raylink_in(dir.path(), &["render", "scene/a.pbrt", "--quiet"]);
        common::assert_clean_failure_of(film, &out, &needles);
        assert_eq!(files_under(dir.path()), ["scene/a.pbrt"], "{film}");
    }
}

/// A native scene names its output as `[render] output`; `convert` keeps a pbrt scene's
/// Film "filename" there, so the converted scene writes the same file.
#[test]
fn converted_scenes_keep_the_film_filename() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("scene")).unwrap();
    std::fs::write(dir.path().join("scene/a.pbrt"), pbrt_scene("film.png")).unwrap();
    let out = raylink_in(
        dir.path(),
        &["convert", "scene/a.pbrt", "-o", "scene/a.toml", "--quiet"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let text = std::fs::read_to_string(dir.path().join("scene/a.toml")).unwrap();
    assert!(text.contains("output = \"film.png\""), "{text}");
    let out = raylink_in(dir.path(), &["render", "scene/a.pbrt", "--quiet"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (from_pbrt, _) = read_image(&dir.path().join("film.png")).unwrap();
    std::fs::remove_file(dir.path().join("film.png")).unwrap();
    let out = raylink_in(dir.path(), &["render", "scene/a.toml", "--quiet"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (from_toml, _) = read_image(&dir.path().join("film.png")).unwrap();
    assert_eq!(from_pbrt, from_toml);

    // Bad input: one line, exit 2, nothing written.
    let without = text.replace("output = \"film.png\"", "");
    let empty = text.replace("output = \"film.png\"", "output = \"\"");
    for (name, scene, needles) in [
        (
            "none",
            without,
            vec!["-o FILE is needed", "[render] output"],
        ),
        (
            "empty",
            empty,
            vec!["b.toml", "line", "render.output", "must name a file"],
        ),
    ] {
        std::fs::write(dir.path().join("scene/b.toml"), scene).unwrap();
        let before = files_under(dir.path());
        let out = raylink_in(dir.path(), &["render", "scene/b.toml", "--quiet"]);
        common::assert_clean_failure_of(name, &out, &needles);
        assert_eq!(files_under(dir.path()), before, "{name}");
    }
}

#[test]
fn crop_writes_png_and_jpeg_of_the_crop_alone() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("quads.toml");
    std::fs::write(&scene, TWO_QUADS).unwrap();
    let file = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let whole = raylink(&[
        "render",
        &file("quads.toml"),
        "-o",
        &file("whole.png"),
        "--quiet",
    ]);
    assert!(whole.status.success(), "{}", stderr(&whole));
    let crop = raylink(&[
        "render",
        &file("quads.toml"),
        "--crop",
        "3,5,11,12",
        "-o",
        &file("crop.png"),
        "-o",
        &file("crop.jpg"),
        "-o",
        &file("crop.exr"),
        "--quiet",
    ]);
    assert!(crop.status.success(), "{}", stderr(&crop));
    let (whole, _) = read_image(&dir.path().join("whole.png")).unwrap();
    let (png, _) = read_image(&dir.path().join("crop.png")).unwrap();
    let (jpg, _) = read_image(&dir.path().join("crop.jpg")).unwrap();
    assert_eq!((png.width, png.height), (8, 7));
    assert_eq!((jpg.width, jpg.height), (8, 7));
    let mut jpeg_error = 0.0f32;
    for y in 0..7 {
        for x in 0..8 {
            // A part is exact: the crop's pixels are the whole render's.
            let expected = whole.get(x + 3, y + 5);
            assert_eq!(png.get(x, y), expected, "pixel {x},{y}");
            jpeg_error += (jpg.get(x, y) - expected).abs().element_sum() / (3.0 * 56.0);
        }
    }
    // JPEG is lossy (and subsamples colour): close on average.
    assert!(jpeg_error < 0.03, "JPEG off by {jpeg_error} on average");
    // The EXR keeps where the crop lies.
    let exr = io::read(&dir.path().join("crop.exr")).unwrap();
    assert_eq!((exr.window.x, exr.window.y), (3, 5));
    assert_eq!((exr.window.full_width, exr.window.full_height), (16, 16));
}

#[test]
fn exr_metadata_names_the_filter_as_the_options_do() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("m.exr");
    let out = raylink(&[
        "render",
        "scenes/cornell-box.toml",
        "--integrator",
        "path",
        "--spp",
        "1",
        "--width",
        "8",
        "--height",
        "8",
        "--filter",
        "triangle",
        "--filter-radius",
        "1",
        "-o",
        exr.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let raw = io::read(&exr).unwrap();
    let text = |name: &str| match raw.meta(name) {
        Some(raylink::MetaValue::Str(s)) => s.clone(),
        other => panic!("{name}: {other:?}"),
    };
    assert_eq!(text("raylink:filter"), "triangle radius=1");
    let settings = text("raylink:settings");
    assert!(
        settings.contains(" spp=1 filter=triangle radius=1 "),
        "{settings}"
    );
    assert!(!settings.contains(['{', '}', ':']), "{settings}");
}

#[test]
fn log_level_chooses_what_is_printed() {
    let dir = tempfile::tempdir().unwrap();
    // Film "foo" is replaced by an RGB film, with a warning.
    std::fs::write(
        dir.path().join("a.pbrt"),
        pbrt_scene("").replace("Film \"rgb\"", "Film \"foo\""),
    )
    .unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec!["render", "a.pbrt", "-o", "x.png"];
        args.extend(extra);
        let out = raylink_in(dir.path(), &args);
        assert!(out.status.success(), "{extra:?}: {}", stderr(&out));
        stderr(&out)
    };
    let warning = "warning: a.pbrt:3: Film \"foo\" is not supported";
    let summary = "rendered in ";
    let debug = "raylink: debug: wrote x.png";
    for (extra, expected) in [
        (&[][..], [true, true, false]),
        (&["--log-level", "error"][..], [false, false, false]),
        (&["--log-level", "warn"][..], [true, false, false]),
        (&["--log-level", "info"][..], [true, true, false]),
        (&["--log-level", "debug"][..], [true, true, true]),
        (&["--verbose"][..], [true, true, true]),
        (&["--quiet"][..], [true, false, false]),
        (
            &["--quiet", "--log-level", "error"][..],
            [false, false, false],
        ),
    ] {
        let err = run(extra);
        let found = [warning, summary, debug].map(|n| err.contains(n));
        assert_eq!(found, expected, "{extra:?}: {err}");
        if extra == ["--log-level", "error"] {
            assert_eq!(err, "", "{extra:?}");
        }
    }
    // The level goes before the command too.
    let out = raylink_in(
        dir.path(),
        &["--log-level", "error", "render", "a.pbrt", "-o", "x.png"],
    );
    assert!(
        out.status.success() && out.stderr.is_empty(),
        "{}",
        stderr(&out)
    );
    // A bad level is a bad option.
    let out = raylink_in(
        dir.path(),
        &["render", "a.pbrt", "-o", "x.png", "--log-level", "loud"],
    );
    common::assert_clean_failure_of("loud", &out, &["--log-level"]);
}
