//! The command line's options against the integrators: an option that does not apply to the
//! chosen integrator (or to the outputs given) is refused with exit 2, naming it; settings a
//! scene file carries are used, overridden by options, and a bad one is reported at its line.

mod common;
use common::{assert_clean_failure_of, raylink, stderr};

/// Every technique-specific option, a value, and the integrators it applies to (written out
/// here, apart from the program's own table, so that the two are checked against each other).
const OPTIONS: &[(&str, &str, &[&str])] = &[
    ("--time-limit", "5", &["path", "light", "bdpt"]),
    (
        "--filter",
        "box",
        &["path", "light", "bdpt", "irradiance-cache"],
    ),
    (
        "--filter-radius",
        "1",
        &["path", "light", "bdpt", "irradiance-cache"],
    ),
    (
        "--write-interval",
        "5",
        &["path", "light", "bdpt", "irradiance-cache"],
    ),
    (
        "--checkpoint-interval",
        "5",
        &["path", "light", "bdpt", "irradiance-cache"],
    ),
    ("--aa", "adaptive", &["whitted", "network"]),
    ("--aa-threshold", "0.2", &["whitted", "network"]),
    ("--aa-depth", "2", &["whitted", "network"]),
    ("--area-samples", "4", &["whitted"]),
    ("--fresnel", "", &["whitted"]),
    ("--ab", "2", &["irradiance-cache"]),
    ("--ic-accuracy", "0.2", &["irradiance-cache"]),
    ("--ic-samples", "64", &["irradiance-cache"]),
    ("--ar", "16", &["irradiance-cache"]),
    ("--cache-file", "c.rlic", &["irradiance-cache"]),
    ("--show-cache-points", "", &["irradiance-cache"]),
    ("--slopes", "4", &["network"]),
    ("--intercept-step", "0.0625", &["network"]),
    ("--patch-size", "0.0625", &["network"]),
    ("--network-jitter", "0.5", &["network"]),
    ("--network-builder", "embree", &["network"]),
    ("--tolerance", "0.01", &["network"]),
    ("--network-file", "n.rlnet", &["network"]),
    ("--light-scale", "2", &["network"]),
    ("--network-stats", "", &["network"]),
    ("--network-order", "sweeps", &["network"]),
    ("--network-hybrid", "", &["network"]),
];

const INTEGRATORS: [&str; 6] = [
    "whitted",
    "path",
    "light",
    "bdpt",
    "irradiance-cache",
    "network",
];

#[test]
fn every_option_that_does_not_apply_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.exr");
    let mut cases = Vec::new();
    for &(option, value, applies) in OPTIONS {
        for integrator in INTEGRATORS.iter().filter(|i| !applies.contains(i)) {
            cases.push((option, value, *integrator));
        }
    }
    assert!(cases.len() > 100, "{} cases", cases.len());
    std::thread::scope(|scope| {
        for chunk in cases.chunks(cases.len().div_ceil(4)) {
            let out = out.to_str().unwrap();
            scope.spawn(move || {
                for &(option, value, integrator) in chunk {
                    let mut args = vec![
                        "render",
                        "scenes/cornell-box.toml",
                        "-o",
                        out,
                        "--integrator",
                        integrator,
                        option,
                    ];
                    if !value.is_empty() {
                        args.push(value);
                    }
                    let case = args.join(" ");
                    assert_clean_failure_of(
                        &case,
                        &raylink(&args),
                        &[option, "does not apply", integrator],
                    );
                }
            });
        }
    });
    assert!(!out.exists(), "a refused command wrote its output");
}

#[test]
fn output_options_need_an_output_they_change() {
    let dir = tempfile::tempdir().unwrap();
    let (exr, png) = (dir.path().join("x.exr"), dir.path().join("x.png"));
    let (exr, png) = (exr.to_str().unwrap(), png.to_str().unwrap());
    let base = [
        "render",
        "scenes/whitted.toml",
        "--width",
        "8",
        "--height",
        "8",
    ];
    for (extra, needle) in [
        (vec!["-o", png, "--half"], "--half"),
        (vec!["-o", exr, "--exposure", "1"], "--exposure"),
        (vec!["-o", exr, "-o", exr], "twice"),
        (vec!["-o", png, "--exposure", "nan"], "--exposure"),
    ] {
        let args: Vec<&str> = base.iter().copied().chain(extra).collect();
        assert_clean_failure_of(&args.join(" "), &raylink(&args), &[needle]);
    }
}

#[test]
fn every_subcommand_takes_quiet() {
    for command in [
        "render",
        "precompute",
        "relight",
        "animate",
        "bench",
        "convert",
        "merge",
    ] {
        let out = raylink(&[command, "--help"]);
        let help = String::from_utf8_lossy(&out.stdout);
        assert!(help.contains("--quiet"), "{command} --help has no --quiet");
    }
}

#[test]
fn render_help_is_grouped_under_headings() {
    let out = raylink(&["render", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    for heading in [
        "Common options:",
        "Monte Carlo",
        "Whitted and network pixel sampling:",
        "Irradiance cache:",
        "Illumination network:",
        "Parts of an image",
        "Output:",
    ] {
        assert!(
            help.contains(heading),
            "no heading {heading:?} in render --help"
        );
    }
}

/// A scene with `[render]` tables of its own, in `dir`.
fn scene_with(dir: &std::path::Path, render: &str) -> String {
    let base = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/indirect-room.toml"),
    )
    .unwrap();
    let start = base.find("[render]").unwrap();
    let end = base.find("[world]").unwrap();
    let text = format!("{}{render}\n{}", &base[..start], &base[end..]);
    let path = dir.join("room.toml");
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

#[test]
fn scene_files_carry_settings_that_options_override() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_with(
        dir.path(),
        "[render]\nintegrator = \"irradiance-cache\"\nspp = 1\n\n\
         [render.irradiance-cache]\nab = 2\nsamples = 16\naccuracy = 0.5\nar = 4\n",
    );
    let out = dir.path().join("x.exr");
    let out = out.to_str().unwrap();
    let settings = |extra: &[&str]| {
        let mut args = vec![
            "render", &scene, "-o", out, "--width", "16", "--height", "12",
        ];
        args.extend_from_slice(extra);
        let run = raylink(&args);
        assert!(run.status.success(), "{}", stderr(&run));
        let (_, meta) = raylink::read_image(std::path::Path::new(out)).unwrap();
        meta.iter()
            .find(|(k, _)| k == "raylink:settings")
            .map(|(_, v)| format!("{v:?}"))
            .unwrap()
    };
    let from_scene = settings(&[]);
    assert!(
        from_scene.contains("integrator=irradiance-cache")
            && from_scene.contains("ab=2 ic_accuracy=0.5 ic_samples=16 ar=4"),
        "{from_scene}"
    );
    let overridden = settings(&["--ab", "3", "--ic-accuracy", "0.4"]);
    assert!(
        overridden.contains("ab=3 ic_accuracy=0.4 ic_samples=16 ar=4"),
        "{overridden}"
    );
}

#[test]
fn a_bad_setting_in_a_scene_file_names_the_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_with(
        dir.path(),
        "[render]\nintegrator = \"irradiance-cache\"\n\n[render.irradiance-cache]\nab = 2\naccuracy = -1\n",
    );
    let out = dir.path().join("x.exr");
    let run = raylink(&["render", &scene, "-o", out.to_str().unwrap()]);
    let line = std::fs::read_to_string(&scene)
        .unwrap()
        .lines()
        .position(|l| l.starts_with("accuracy"))
        .unwrap()
        + 1;
    assert_clean_failure_of(
        "bad accuracy",
        &run,
        &[
            "room.toml",
            &format!("line {line}"),
            "[render.irradiance-cache] accuracy must be positive",
        ],
    );
    // The same value given as an option is named as the option.
    let run = raylink(&[
        "render",
        &scene,
        "-o",
        out.to_str().unwrap(),
        "--ic-accuracy",
        "-2",
    ]);
    assert_clean_failure_of(
        "bad --ic-accuracy",
        &run,
        &["--ic-accuracy must be positive"],
    );
    // An unknown integrator name is refused at its line when the scene is read.
    let scene = scene_with(dir.path(), "[render]\nintegrator = \"radiosity\"\n");
    let run = raylink(&["render", &scene, "-o", out.to_str().unwrap()]);
    assert_clean_failure_of(
        "bad integrator",
        &run,
        &["room.toml", "unknown integrator \"radiosity\""],
    );
    assert!(!out.exists());
}
