//! The `raylink` binary end to end: renders, version, and every bad input through the CLI.

use raylink::image::output::read_image;
use raylink::image::MetaValue;
use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::{raylink, stderr};

fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    v.sort();
    v
}

fn assert_clean_failure(out: &Output, needles: &[&str]) {
    common::assert_clean_failure_of("", out, needles)
}

#[test]
fn version_names_embree_and_openimageio() {
    let out = raylink(&["--version"]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains(env!("CARGO_PKG_VERSION")), "{text}");
    assert!(
        text.contains("Embree 3.") || text.contains("Embree 4."),
        "{text}"
    );
    assert!(
        text.contains("OpenImageIO 2.") || text.contains("OpenImageIO 3."),
        "{text}"
    );
}

#[test]
fn renders_both_example_scenes_to_exr_and_png_with_metadata() {
    let dir = tempfile::tempdir().unwrap();
    // The Cornell box asks for the path tracer in its [render] table; Whitted is the default.
    for (scene, integrator) in [
        ("scenes/cornell-box.toml", "path"),
        ("scenes/whitted.toml", "whitted"),
    ] {
        let exr = dir.path().join("out.exr");
        let png = dir.path().join("out.png");
        let out = raylink(&[
            "render",
            scene,
            "-o",
            exr.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--width",
            "64",
            "--height",
            "48",
            "--seed",
            "9",
            "--quiet",
        ]);
        assert!(out.status.success(), "{scene}: {}", stderr(&out));
        let (image, meta) = read_image(&exr).unwrap();
        assert_eq!((image.width, image.height), (64, 48));
        let mean: f32 =
            image.pixels.iter().map(|p| p.element_sum()).sum::<f32>() / image.pixels.len() as f32;
        assert!(mean > 0.01 && mean.is_finite(), "{scene}: mean {mean}");
        let get = |k: &str| meta.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone());
        assert_eq!(
            get("raylink:integrator"),
            Some(MetaValue::Str(integrator.into()))
        );
        assert_eq!(get("raylink:seed"), Some(MetaValue::Str("9".into())));
        assert_eq!(get("raylink:scene"), Some(MetaValue::Str(scene.into())));
        assert!(matches!(get("raylink:render_seconds"), Some(MetaValue::Float(s)) if s >= 0.0));
        // The settings in the settings' own words (`aa=adaptive aa_threshold=0.1`), not
        // the program's debugging text.
        let Some(MetaValue::Str(settings)) = get("raylink:settings") else {
            panic!("{scene}: no raylink:settings");
        };
        assert!(
            settings
                .split(' ')
                .all(|w| w.split_once('=').is_some_and(|(k, v)| {
                    !k.is_empty()
                        && !v.is_empty()
                        && k.chars().all(|c| c.is_ascii_lowercase() || c == '_')
                }))
                && !settings.contains(['{', '}', ':']),
            "{scene}: {settings}"
        );
        let (png_image, _) = read_image(&png).unwrap();
        assert_eq!((png_image.width, png_image.height), (64, 48));
        // Nothing but the two outputs is left behind.
        assert_eq!(files_in(dir.path()), vec![exr.clone(), png.clone()]);
    }
}

/// Every case in tests/bad_inputs/scenes: exit code 2, one line naming the file and the problem
/// (the `# expect:` substring on the case's first line), no output file.
#[test]
fn bad_scenes_fail_cleanly_through_the_cli() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut cases: Vec<_> = files_in(&root.join("tests/bad_inputs/scenes"))
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    cases.sort();
    assert!(cases.len() >= 15, "only {} bad scene cases", cases.len());
    // Each run is a separate process; run a few at once (startup is dominated by loading
    // OpenImageIO's many shared libraries).
    let workers = 4;
    std::thread::scope(|scope| {
        for chunk in cases.chunks(cases.len().div_ceil(workers)) {
            scope.spawn(move || {
                for case in chunk {
                    check_bad_scene(case);
                }
            });
        }
    });
}

fn check_bad_scene(case: &Path) {
    let text = std::fs::read_to_string(case).unwrap();
    let expect = text
        .lines()
        .next()
        .and_then(|l| l.strip_prefix("# expect:"))
        .unwrap_or_else(|| panic!("{} lacks an # expect: line", case.display()))
        .trim()
        .to_string();
    let name = case.file_name().unwrap().to_str().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("never.exr");
    let out = raylink(&[
        "render",
        case.to_str().unwrap(),
        "-o",
        output.to_str().unwrap(),
        "--quiet",
    ]);
    assert_clean_failure(&out, &[name, &expect]);
    assert!(files_in(dir.path()).is_empty(), "{name} left files behind");
}

#[test]
fn missing_scene_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = raylink(&[
        "render",
        "scenes/no-such-scene.toml",
        "-o",
        dir.path().join("x.exr").to_str().unwrap(),
    ]);
    assert_clean_failure(&out, &["no-such-scene.toml"]);
    assert!(files_in(dir.path()).is_empty());
}

#[test]
fn bad_options_are_rejected_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("x.exr");
    let exr = exr.to_str().unwrap();
    let missing_dir = dir.path().join("no/such/dir/x.exr");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--spp", "5"], "--spp"),
        (vec!["--threads", "0"], "--threads"),
        (vec!["--width", "0"], "--width"),
        (vec!["--aa-depth", "99"], "--aa-depth"),
        (vec!["--aa-threshold", "NaN"], "--aa-threshold"),
    ];
    for (extra, needle) in cases {
        let mut args = vec!["render", "scenes/whitted.toml", "-o", exr, "--quiet"];
        args.extend(extra);
        assert_clean_failure(&raylink(&args), &[needle]);
    }
    let out = raylink(&[
        "render",
        "scenes/whitted.toml",
        "-o",
        missing_dir.to_str().unwrap(),
    ]);
    assert_clean_failure(&out, &["x.exr"]);
    let bmp = dir.path().join("x.bmp");
    let out = raylink(&["render", "scenes/whitted.toml", "-o", bmp.to_str().unwrap()]);
    assert_clean_failure(&out, &["x.bmp"]);
    assert!(files_in(dir.path()).is_empty());
}

#[test]
fn a_failed_run_leaves_an_existing_output_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let precious = dir.path().join("precious.exr");
    std::fs::write(&precious, b"the user's earlier render").unwrap();
    let bad = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/bad_inputs/scenes");
    let case = files_in(&bad)
        .into_iter()
        .find(|p| p.extension().is_some_and(|e| e == "toml"))
        .unwrap();
    let out = raylink(&[
        "render",
        case.to_str().unwrap(),
        "-o",
        precious.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        std::fs::read(&precious).unwrap(),
        b"the user's earlier render"
    );
    assert_eq!(files_in(dir.path()), vec![precious]);
}

/// Every case in tests/bad_inputs/pbrt through the CLI: exit code 2, one line naming the file, line
/// and problem, no output file, no panic.
#[test]
fn bad_pbrt_files_fail_cleanly_through_the_cli() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let cases: Vec<_> = files_in(&root.join("tests/bad_inputs/pbrt"))
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "pbrt"))
        .collect();
    assert!(cases.len() >= 20, "only {} bad pbrt cases", cases.len());
    std::thread::scope(|scope| {
        for chunk in cases.chunks(cases.len().div_ceil(4)) {
            scope.spawn(move || {
                for case in chunk {
                    check_bad_scene(case);
                }
            });
        }
    });
}

/// `raylink render scene.pbrt` prints the reader's warnings as `warning: FILE:LINE: ...`
/// and renders; `raylink convert` writes a TOML scene that renders the same image.
#[test]
fn pbrt_scenes_render_with_warnings_and_convert_to_toml() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.pbrt");
    std::fs::write(
        &scene,
        "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\nWorldBegin\n\
         LightSource \"point\" \"rgb I\" [10 10 10] \"point3 from\" [0 0 4]\n\
         Shape \"sphere\" \"float radius\" 1\nShape \"curve\" \"point3 P\" [0 0 0 1 1 1 2 2 2 3 3 3]\n",
    )
    .unwrap();
    let exr = dir.path().join("a.exr");
    let args = |out: &Path, input: &Path| {
        vec![
            "render".to_string(),
            input.display().to_string(),
            "-o".into(),
            out.display().to_string(),
            "--width".into(),
            "24".into(),
            "--height".into(),
            "16".into(),
            "--quiet".into(),
        ]
    };
    let run = |a: Vec<String>| raylink(&a.iter().map(String::as_str).collect::<Vec<_>>());
    let out = run(args(&exr, &scene));
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    assert_eq!(
        err.trim_end(),
        format!(
            "warning: {}:6: Shape \"curve\" is not supported; the shape is left out",
            scene.display()
        )
    );
    let toml = dir.path().join("s.toml");
    let out = raylink(&[
        "convert",
        scene.to_str().unwrap(),
        "-o",
        toml.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let exr2 = dir.path().join("b.exr");
    let out = run(args(&exr2, &toml));
    assert!(out.status.success(), "{}", stderr(&out));
    let (a, _) = read_image(&exr).unwrap();
    let (b, _) = read_image(&exr2).unwrap();
    assert_eq!(a.pixels, b.pixels);
    // A failed conversion writes nothing.
    let bad =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/bad_inputs/pbrt/unknown-statement.pbrt");
    let never = dir.path().join("never.toml");
    let out = raylink(&[
        "convert",
        bad.to_str().unwrap(),
        "-o",
        never.to_str().unwrap(),
    ]);
    assert_clean_failure(&out, &["unknown-statement.pbrt", "line 5"]);
    assert!(!never.exists());
}

/// An environment map neither square (equal-area) nor 2:1 (lat-long) is refused with exit
/// code 2 and one line naming the file and the accepted shapes, from a TOML scene and from
/// pbrt's `infinite` light; a 2:1 map from pbrt renders, with a warning that pbrt-v4 itself
/// needs it converted.
#[test]
fn environment_maps_of_other_shapes_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut image = raylink::Image::new(48, 16);
    image.pixels.fill(raylink::math::Rgb::ONE);
    raylink::write_image(
        &dir.path().join("wide.exr"),
        &image,
        &[],
        &Default::default(),
    )
    .unwrap();
    let toml = dir.path().join("s.toml");
    std::fs::write(
        &toml,
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\n\
         [world]\nenvironment = { file = \"wide.exr\" }\n\n\
         [materials.m]\n\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"m\"\n",
    )
    .unwrap();
    let pbrt = |file: &str| {
        let path = dir.path().join(format!("{file}.pbrt"));
        std::fs::write(
            &path,
            format!(
                "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\n\
                 LightSource \"infinite\" \"string filename\" \"{file}\"\n\
                 Shape \"sphere\" \"float radius\" 1\n"
            ),
        )
        .unwrap();
        path
    };
    let out_file = dir.path().join("never.exr");
    let render = |scene: &Path, out: &Path| {
        raylink(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--width",
            "8",
            "--height",
            "8",
            "--quiet",
        ])
    };
    for scene in [toml, pbrt("wide.exr")] {
        let out = render(&scene, &out_file);
        assert_clean_failure(&out, &["wide.exr", "48x16", "square", "2:1"]);
        assert!(!out_file.exists());
    }
    let mut image = raylink::Image::new(32, 16);
    image.pixels.fill(raylink::math::Rgb::ONE);
    raylink::write_image(
        &dir.path().join("sky.exr"),
        &image,
        &[],
        &Default::default(),
    )
    .unwrap();
    let scene = pbrt("sky.exr");
    let out = render(&scene, &dir.path().join("sky-lit.exr"));
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(
        stderr(&out).trim_end(),
        format!(
            "warning: {}:4: LightSource \"infinite\": \"sky.exr\" is a lat-long image, converted \
             to the equal-area mapping (pbrt-v4 itself needs `imgtool makeequiarea`)",
            scene.display()
        )
    );
}

fn meta_value(meta: &raylink::image::Metadata, key: &str) -> Option<MetaValue> {
    meta.iter().find(|(n, _)| n == key).map(|(_, v)| v.clone())
}

/// The Monte Carlo integrators from the command line: sample counts, the scene's render
/// settings, a time limit, auxiliary outputs, and options that belong to another integrator.
#[test]
fn monte_carlo_integrators_from_the_cli() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("mc.exr");
    let exr_s = exr.to_str().unwrap();
    for integrator in ["path", "light", "bdpt"] {
        let out = raylink(&[
            "render",
            "scenes/cornell-box.toml",
            "--integrator",
            integrator,
            "--spp",
            "3",
            "--width",
            "32",
            "--height",
            "32",
            "-o",
            exr_s,
            "--quiet",
        ]);
        assert!(out.status.success(), "{integrator}: {}", stderr(&out));
        let (image, meta) = read_image(&exr).unwrap();
        assert!(image.pixels.iter().all(|p| p.is_finite()));
        assert_eq!(
            meta_value(&meta, "raylink:integrator"),
            Some(MetaValue::Str(integrator.into()))
        );
        assert_eq!(
            meta_value(&meta, "raylink:samples_per_pixel"),
            Some(MetaValue::Float(3.0))
        );
    }
    // The scene's [render] table picks the integrator and sample count.
    let out = raylink(&[
        "render",
        "scenes/cornell-spheres.toml",
        "--width",
        "24",
        "--height",
        "24",
        "-o",
        exr_s,
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (_, meta) = read_image(&exr).unwrap();
    assert_eq!(
        meta_value(&meta, "raylink:integrator"),
        Some(MetaValue::Str("path".into()))
    );
    assert_eq!(
        meta_value(&meta, "raylink:samples_per_pixel"),
        Some(MetaValue::Float(64.0))
    );
    // A time limit renders whole passes: at least one, and fewer than the cap.
    let out = raylink(&[
        "render",
        "scenes/cornell-box.toml",
        "--integrator",
        "path",
        "--time-limit",
        "0.5",
        "--width",
        "32",
        "--height",
        "32",
        "-o",
        exr_s,
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (_, meta) = read_image(&exr).unwrap();
    match meta_value(&meta, "raylink:samples_per_pixel") {
        Some(MetaValue::Float(spp)) => assert!((1.0..1e6).contains(&spp), "spp {spp}"),
        other => panic!("samples_per_pixel: {other:?}"),
    }
    // Auxiliary outputs beside the first output.
    let out = raylink(&[
        "render",
        "scenes/cornell-box.toml",
        "--integrator",
        "path",
        "--spp",
        "1",
        "--aov",
        "--width",
        "16",
        "--height",
        "16",
        "-o",
        exr_s,
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (depth, _) = read_image(&dir.path().join("mc.depth.exr")).unwrap();
    // The camera is 6.8 m from the box's centre and 7.8 m from its back wall (edge pixels
    // that partly see out of the open box average in zeros).
    assert!(
        depth.pixels.iter().all(|p| p.x >= 0.0 && p.x < 10.0),
        "depths"
    );
    let centre = depth.get(8, 8).x;
    assert!((7.0..7.9).contains(&centre), "centre depth {centre}");
    let (normal, _) = read_image(&dir.path().join("mc.normal.exr")).unwrap();
    assert!(normal.pixels.iter().all(|n| n.length() <= 1.001));
    let (albedo, _) = read_image(&dir.path().join("mc.albedo.exr")).unwrap();
    assert!(albedo.pixels.iter().all(|a| a.max_element() <= 1.0));

    let missing = dir.path().join("never.exr");
    let missing_s = missing.to_str().unwrap();
    for (args, needle) in [
        (
            vec!["--integrator", "path", "--aa", "adaptive"],
            "--aa does not apply",
        ),
        (
            vec!["--integrator", "whitted", "--time-limit", "3"],
            "--time-limit does not apply",
        ),
        (vec!["--integrator", "path", "--spp", "0"], "--spp"),
        (
            vec!["--integrator", "path", "--time-limit", "-1"],
            "--time-limit",
        ),
        (
            vec!["--integrator", "path", "--filter-radius", "0"],
            "filter radius",
        ),
        (
            vec!["--integrator", "path", "--max-depth", "100000"],
            "--max-depth",
        ),
    ] {
        let mut all = vec!["render", "scenes/cornell-box.toml", "-o", missing_s];
        all.extend(args);
        assert_clean_failure(&raylink(&all), &[needle]);
        assert!(!missing.exists());
    }
    // BDPT renders a scene with a background (a light at infinity).
    let whitted = std::fs::read_to_string("scenes/whitted.toml").unwrap();
    assert!(whitted.contains("background = [0.3"));
    let out = raylink(&[
        "render",
        "scenes/whitted.toml",
        "--integrator",
        "bdpt",
        "--spp",
        "2",
        "--width",
        "16",
        "--height",
        "12",
        "-o",
        exr_s,
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (image, _) = read_image(&exr).unwrap();
    assert!(image.pixels.iter().all(|p| p.is_finite()));
    assert!(image.pixels.iter().any(|p| p.max_element() > 0.0));
}

/// A scene naming several files that are not there (a texture, an OBJ mesh, a PLY mesh and
/// a normal map) is refused with one line for each, naming the scene's line, the field and
/// the file, in the file's order: exit code 2, nothing written.
#[test]
fn every_missing_file_of_a_scene_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    std::fs::write(
        &scene,
        "[camera]\nposition = [0, 1, 5]\nlook_at = [0, 1, 0]\n\
         [materials.a]\ndiffuse = { image = { file = \"no-such-wood.png\" } }\n\
         [materials.b]\ndiffuse = 0.5\nnormal_map = \"no-such-bumps.png\"\n\
         [[shapes]]\ntype = \"obj\"\nfile = \"meshes/no-such-chair.obj\"\nmaterial = \"a\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0, 1, 0]\nradius = 1\nmaterial = \"b\"\n\
         [[shapes]]\ntype = \"ply\"\nfile = \"no-such-table.ply\"\nmaterial = \"b\"\n",
    )
    .unwrap();
    let expected = [
        ("line 5: materials.a.diffuse.image.file", "no-such-wood.png"),
        ("line 8: materials.b.normal_map", "no-such-bumps.png"),
        ("line 11: shapes[0].file", "meshes/no-such-chair.obj"),
        ("line 20: shapes[2].file", "no-such-table.ply"),
    ];
    let err = refused_for_missing_files(&scene, &expected);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(files_in(dir.path()), vec![scene]);
}

/// A pbrt scene missing several files (an environment map, an image texture, a PLY mesh, a
/// normal map), or an OBJ missing two MTL files, is refused with every one of them, each
/// naming its line and statement; nothing is written.
#[test]
fn every_missing_file_of_a_pbrt_scene_or_obj_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.pbrt");
    std::fs::write(
        &scene,
        "LookAt 0 1 5  0 1 0  0 1 0\nCamera \"perspective\" \"float fov\" 45\n\
         Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\nWorldBegin\n\
         LightSource \"infinite\" \"string filename\" \"no-sky.exr\"\n\
         Texture \"wood\" \"spectrum\" \"imagemap\" \"string filename\" \"no-wood.png\"\n\
         Material \"diffuse\" \"texture reflectance\" \"wood\"\n\
         Shape \"plymesh\" \"string filename\" \"no-chair.ply\"\n\
         Shape \"sphere\" \"float radius\" 1\n\
         Material \"diffuse\" \"string normalmap\" \"no-bumps.png\"\n\
         Shape \"sphere\" \"float radius\" 0.5\n",
    )
    .unwrap();
    let expected = [
        ("line 5,", "LightSource \"infinite\": no-sky.exr"),
        ("line 6,", "\"imagemap\": no-wood.png"),
        ("line 8,", "Shape \"plymesh\": no-chair.ply"),
        ("line 10,", "Material \"diffuse\": no-bumps.png"),
    ];
    refused_for_missing_files(&scene, &expected);
    let out = dir.path().join("x.exr");

    std::fs::write(
        dir.path().join("m.obj"),
        "mtllib first.mtl\nmtllib second.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let toml = dir.path().join("t.toml");
    std::fs::write(
        &toml,
        "[camera]\nposition = [0, 1, 5]\nlook_at = [0, 0, 0]\n\
         [[shapes]]\ntype = \"obj\"\nfile = \"m.obj\"\n",
    )
    .unwrap();
    let run = raylink(&[
        "render",
        toml.to_str().unwrap(),
        "-q",
        "-o",
        out.to_str().unwrap(),
    ]);
    let err = stderr(&run);
    assert_eq!(run.status.code(), Some(2), "{err}");
    assert!(
        err.contains("first.mtl") && err.contains("second.mtl"),
        "{err}"
    );
    assert!(!out.exists());
}

/// Renders `scene` and checks that it is refused (exit 2) with exactly one line for each of
/// `expected`, in order: `(place, file)`, the line naming the scene file, the place and
/// `FILE: no such file`; nothing is written beside the scene. Returns the error text.
fn refused_for_missing_files(scene: &Path, expected: &[(&str, &str)]) -> String {
    let out = scene.with_file_name("x.exr");
    let run = raylink(&[
        "render",
        scene.to_str().unwrap(),
        "-q",
        "-o",
        out.to_str().unwrap(),
    ]);
    let err = stderr(&run);
    assert_eq!(run.status.code(), Some(2), "{err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), expected.len(), "{err}");
    let name = scene.file_name().unwrap().to_string_lossy();
    for (line, (place, file)) in lines.iter().zip(expected) {
        assert!(line.starts_with("raylink: error: "), "{err}");
        assert!(
            line.contains(&format!("{name}: ")) && line.contains(place),
            "{place}: {err}"
        );
        assert!(
            line.contains(&format!("{file}: no such file")),
            "{file}: {err}"
        );
    }
    assert!(!out.exists(), "{err}");
    err
}
