//! Illumination networks through the command line: network files reused for other views and
//! lighting, bad files refused, scenes that absorb no light refused, and `raylink relight`
//! with its light basis and reflectance series. (The library's tests of the networks are in
//! `src/tests/network_*.rs`.)

mod common;
#[path = "../src/tests/network_scenes.rs"]
mod scenes;

use common::{raylink, stderr};
use raylink::image::compare::{mean, rmse};
use raylink::image::output::read_image;
use scenes::{closed_box_text, sealed_box_text};
use std::path::Path;

fn tmp_path(dir: &tempfile::TempDir, name: &str) -> String {
    dir.path().join(name).to_string_lossy().into_owned()
}

/// `raylink COMMAND` (render, or relight, which always uses the network and refuses
/// `--integrator`) with the network's small test settings; `--slopes 6` unless `extra`
/// gives its own.
fn network_command(command: &str, scene: &str, out: &str, extra: &[&str]) -> std::process::Output {
    let slopes = if extra.contains(&"--slopes") {
        &[][..]
    } else {
        &["--slopes", "6"][..]
    };
    let mut args = vec![command, scene];
    if command == "render" {
        args.extend_from_slice(&["--integrator", "network"]);
    }
    args.extend_from_slice(&[
        "--intercept-step",
        "0.0625",
        "--width",
        "24",
        "--height",
        "24",
        "--spp",
        "1",
        "-o",
        out,
    ]);
    args.extend_from_slice(slopes);
    args.extend_from_slice(extra);
    raylink(&args)
}

fn network_render(scene: &str, out: &str, extra: &[&str]) -> std::process::Output {
    network_command("render", scene, out, extra)
}

/// Network files: a second view from the saved network runs no preprocess and equals a fresh
/// build; doubling the lights doubles the image exactly; bad files are one-line errors.
#[test]
fn network_files_are_reused_for_views_and_lighting() {
    let dir = tempfile::tempdir().unwrap();
    let file = tmp_path(&dir, "cornell.net");
    let first = network_render(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "a.exr"),
        &["--network-file", &file, "--network-stats"],
    );
    assert!(first.status.success(), "{}", stderr(&first));
    assert!(stderr(&first).contains("preprocess"), "{}", stderr(&first));
    assert!(
        stderr(&first).contains(" M/s)") && !stderr(&first).contains("when it was built"),
        "{}",
        stderr(&first)
    );
    assert!(Path::new(&file).exists());

    // Another view of the same geometry (the camera moved).
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml"),
    )
    .unwrap()
    .replace("position = [0, 1, 6.8]", "position = [0.5, 1.2, 3.5]");
    let moved = tmp_path(&dir, "moved.toml");
    std::fs::write(&moved, text).unwrap();
    let loaded = network_render(
        &moved,
        &tmp_path(&dir, "b.exr"),
        &["--network-file", &file, "--network-stats"],
    );
    assert!(loaded.status.success(), "{}", stderr(&loaded));
    // Its statistics say it was read, not built (the build's times are the saved ones).
    assert!(
        stderr(&loaded).contains("network stats: read from its file in")
            && !stderr(&loaded).contains("network stats: preprocess"),
        "{}",
        stderr(&loaded)
    );
    assert!(
        stderr(&loaded).contains("no preprocess"),
        "{}",
        stderr(&loaded)
    );
    // The intersection speed is the saved build's, and says so.
    assert!(
        stderr(&loaded).contains(" M/s when it was built)"),
        "{}",
        stderr(&loaded)
    );
    assert!(!stderr(&loaded).contains("network: preprocess"));
    let fresh = network_render(&moved, &tmp_path(&dir, "c.exr"), &[]);
    assert!(fresh.status.success(), "{}", stderr(&fresh));
    let img = |name: &str| read_image(&dir.path().join(name)).unwrap().0;
    assert_eq!(img("b.exr").pixels, img("c.exr").pixels);

    // Relighting: twice the emission, exactly twice the radiance (a power of two is exact).
    let relit = network_render(
        &moved,
        &tmp_path(&dir, "d.exr"),
        &["--network-file", &file, "--light-scale", "2"],
    );
    assert!(relit.status.success(), "{}", stderr(&relit));
    assert!(stderr(&relit).contains("no preprocess"));
    let (b, d) = (img("b.exr"), img("d.exr"));
    assert!(b.pixels.iter().any(|p| p.x > 0.0));
    for (x, y) in b.pixels.iter().zip(&d.pixels) {
        assert_eq!(*x * 2.0, *y);
    }

    // Other parameters, another scene, a corrupt file: errors naming the file, exit 2.
    let other = network_render(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "e.exr"),
        &["--network-file", &file, "--slopes", "7"],
    );
    assert_eq!(other.status.code(), Some(2));
    assert!(stderr(&other).contains("cornell.net") && stderr(&other).contains("network settings"));
    let box_scene = network_render(
        "scenes/cornell-spheres.toml",
        &tmp_path(&dir, "f.exr"),
        &["--network-file", &file],
    );
    assert_eq!(box_scene.status.code(), Some(2), "{}", stderr(&box_scene));
    let mut bytes = std::fs::read(&file).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0xff;
    let corrupt = tmp_path(&dir, "corrupt.net");
    std::fs::write(&corrupt, &bytes).unwrap();
    let bad = network_render(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "g.exr"),
        &["--network-file", &corrupt],
    );
    assert_eq!(bad.status.code(), Some(2));
    assert!(stderr(&bad).contains("corrupt.net") && stderr(&bad).contains("checksum"));
    assert!(!dir.path().join("g.exr").exists());
}

/// A closed box whose every wall reflects all of the red light (green and blue are partly
/// absorbed) has no finite red radiance: rendering and relighting refuse it with a one-line
/// error naming the scene and the channel, exit 2, and write no image; with one wall
/// absorbing a little red it renders.
#[test]
fn a_closed_scene_that_absorbs_no_light_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, floor: &str| {
        let materials = format!(
            "[materials.m]\ndiffuse = [1, 0.5, 0.5]\nemission = 1\n[materials.floor]\n\
             diffuse = {floor}\n"
        );
        let path = tmp_path(&dir, name);
        std::fs::write(&path, closed_box_text(&materials, "m", "floor")).unwrap();
        path
    };
    let white = write("white.toml", "[1, 0.2, 0.2]");
    let out = tmp_path(&dir, "white.png");
    let net = tmp_path(&dir, "white.net");
    let render = network_render(&white, &out, &["--network-file", &net]);
    let relight = network_relight(&white, &out, &net, &["--light", "m=2"]);
    for (what, run) in [("render", &render), ("relight", &relight)] {
        let e = stderr(run);
        assert_eq!(run.status.code(), Some(2), "{what}: {e}");
        let errors: Vec<&str> = e.lines().filter(|l| l.contains("error")).collect();
        assert!(
            errors.len() == 1
                && errors[0].contains("white.toml")
                && errors[0].contains("no red light emitted by material 'm' can leave"),
            "{what}: {e}"
        );
        assert!(!std::path::Path::new(&out).exists(), "{what}");
    }
    let grey = write("grey.toml", "[0.9, 0.2, 0.2]");
    let ok = network_render(&grey, &out, &[]);
    assert!(ok.status.success(), "{}", stderr(&ok));
    assert!(std::path::Path::new(&out).exists());
}

/// The same inside an open scene (the library's check: `src/tests/network_transport.rs`): the
/// box, sealed, stands above a ground that absorbs half the light and whose lines escape.
/// The box's inner sides still keep all the red light they emit (its outer sides lead out),
/// so `render` refuses it; with the box's floor absorbing a tenth of the red it renders.
#[test]
fn a_sealed_box_that_absorbs_no_light_is_refused_in_an_open_scene() {
    let dir = tempfile::tempdir().unwrap();
    let (sealed, grey) = (
        sealed_box_text("[1, 0.2, 0.2]"),
        sealed_box_text("[0.9, 0.2, 0.2]"),
    );
    // Through the CLI.
    let out = tmp_path(&dir, "sealed.png");
    for (name, text, refused) in [("sealed.toml", &sealed, true), ("grey.toml", &grey, false)] {
        let path = tmp_path(&dir, name);
        std::fs::write(&path, text).unwrap();
        let run = network_render(&path, &out, &[]);
        let e = stderr(&run);
        if refused {
            assert_eq!(run.status.code(), Some(2), "{e}");
            let errors: Vec<&str> = e.lines().filter(|l| l.contains("error")).collect();
            assert!(
                errors.len() == 1
                    && errors[0].contains(name)
                    && errors[0].contains("no red light emitted by material 'm' can leave"),
                "{e}"
            );
            assert!(!std::path::Path::new(&out).exists());
        } else {
            assert!(run.status.success(), "{e}");
            assert!(std::path::Path::new(&out).exists());
        }
    }
}

fn network_relight(scene: &str, out: &str, file: &str, extra: &[&str]) -> std::process::Output {
    network_command(
        "relight",
        scene,
        out,
        &[&["--network-file", file], extra].concat(),
    )
}

/// The Cornell box's network saved by `render --network-file` in `dir`: the file's path.
fn cornell_network_file(dir: &tempfile::TempDir) -> String {
    let file = tmp_path(dir, "cornell.net");
    let built = network_render(
        "scenes/cornell-box.toml",
        &tmp_path(dir, "render.exr"),
        &["--network-file", &file],
    );
    assert!(built.status.success(), "{}", stderr(&built));
    file
}

/// `raylink relight`: no preprocess (counters in its messages); the first relight stores a
/// light basis, later ones superpose it (no distribution, no link table); doubling the
/// lights doubles the image exactly, globally or per material; the superposed image agrees
/// with a fresh distribution; changed reflectances distribute again and give exactly what
/// `render` gives from the same file; bad options are errors with exit 2.
#[test]
fn relight_subcommand_reuses_the_network() {
    let dir = tempfile::tempdir().unwrap();
    let file = cornell_network_file(&dir);
    let img = |name: &str| read_image(&dir.path().join(name)).unwrap().0;
    let size = std::fs::metadata(&file).unwrap().len();

    let first = network_relight(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "r1.exr"),
        &file,
        &[],
    );
    let e = stderr(&first);
    assert!(first.status.success(), "{e}");
    assert!(!e.contains("network: preprocess"), "{e}");
    assert!(
        e.contains("no preprocess") && e.contains("light basis"),
        "{e}"
    );
    assert!(
        std::fs::metadata(&file).unwrap().len() > size,
        "basis not stored"
    );

    let second = network_relight(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "r2.exr"),
        &file,
        &["--light-scale", "2"],
    );
    let e = stderr(&second);
    assert!(second.status.success(), "{e}");
    assert!(!e.contains("network: preprocess"), "{e}");
    assert!(
        e.contains("no distribution (0 sweeps)") && e.contains("link table not read"),
        "{e}"
    );
    let per_light = network_relight(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "r3.exr"),
        &file,
        &["--light", "light=2"],
    );
    assert!(per_light.status.success(), "{}", stderr(&per_light));
    assert!(stderr(&per_light).contains("0 sweeps"));
    // A colour, channel by channel: red doubled, blue off.
    let tinted = network_relight(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "r6.exr"),
        &file,
        &["--light", "light=2,1,0"],
    );
    assert!(tinted.status.success(), "{}", stderr(&tinted));
    let (r1, r2, r3) = (img("r1.exr"), img("r2.exr"), img("r3.exr"));
    let r6 = img("r6.exr");
    assert!(r1.pixels.iter().any(|p| p.x > 0.0));
    for (((a, b), c), t) in r1
        .pixels
        .iter()
        .zip(&r2.pixels)
        .zip(&r3.pixels)
        .zip(&r6.pixels)
    {
        assert_eq!(*a * 2.0, *b);
        assert_eq!(*b, *c);
        assert_eq!((t.x, t.y, t.z), (b.x, a.y, 0.0));
    }
    // The basis (one solution per emissive material, each to the tolerance) against the
    // render's single distribution.
    let fresh = img("render.exr");
    let diff: f32 = fresh
        .pixels
        .iter()
        .zip(&r1.pixels)
        .map(|(a, b)| (*a - *b).abs().element_sum())
        .sum();
    let total: f32 = fresh.pixels.iter().map(|a| a.element_sum()).sum();
    assert!(
        diff / total < 2e-3,
        "basis vs distribution {}",
        diff / total
    );

    // Other reflectances: the basis does not apply as it is; the distribution runs again,
    // starting from it, and agrees with `render` from the same file (a cold start) up to
    // the tolerance.
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml"),
    )
    .unwrap()
    .replace("diffuse = [0.63, 0.065, 0.05]", "diffuse = [0.2, 0.6, 0.6]");
    let edited = tmp_path(&dir, "edited.toml");
    std::fs::write(&edited, text).unwrap();
    let relit = network_relight(&edited, &tmp_path(&dir, "r4.exr"), &file, &[]);
    let e = stderr(&relit);
    assert!(relit.status.success(), "{e}");
    assert!(
        e.contains("other reflectances")
            && e.contains("sweeps")
            && e.contains("starting from the stored light basis"),
        "{e}"
    );
    assert!(
        !e.contains("network: preprocess") && !e.contains("0 sweeps"),
        "{e}"
    );
    let rendered = network_render(
        &edited,
        &tmp_path(&dir, "r5.exr"),
        &["--network-file", &file],
    );
    assert!(rendered.status.success(), "{}", stderr(&rendered));
    let (warm, cold) = (img("r4.exr"), img("r5.exr"));
    let (mut diff, mut total) = (0.0f64, 0.0f64);
    for (a, b) in warm.pixels.iter().zip(&cold.pixels) {
        diff += (*a - *b).abs().element_sum() as f64;
        total += b.element_sum() as f64;
    }
    eprintln!("warm against cold relight: {}", diff / total);
    assert!(total > 0.0 && diff / total < 1e-3, "{}", diff / total);
    assert_ne!(warm.pixels, r1.pixels);

    // Bad input: exit 2, nothing written.
    for (args, needle) in [
        (vec!["--light", "nosuch=2"], "nosuch"),
        (vec!["--light", "light"], "NAME=K"),
        (vec!["--light", "light=1,2"], "NAME=R,G,B"),
        (vec!["--light", "light=1,-1,1"], "NAME=R,G,B"),
        (vec!["--integrator", "path"], "network integrator"),
    ] {
        let out = network_relight(
            "scenes/cornell-box.toml",
            &tmp_path(&dir, "x.exr"),
            &file,
            &args,
        );
        assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
        assert!(stderr(&out).contains(needle), "{}", stderr(&out));
    }
    let missing = network_relight(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "x.exr"),
        &tmp_path(&dir, "missing.net"),
        &[],
    );
    assert_eq!(missing.status.code(), Some(2));
    assert!(stderr(&missing).contains("missing.net"));
    let none = raylink(&[
        "relight",
        "scenes/cornell-box.toml",
        "-o",
        &tmp_path(&dir, "x.exr"),
    ]);
    assert_eq!(none.status.code(), Some(2));
    assert!(stderr(&none).contains("--network-file"));
    assert!(!dir.path().join("x.exr").exists());
}

/// `raylink relight --reflectance-series`: an unknown material is an error naming the scene
/// file (exit 2, no image); a series stored for the Cornell box's left wall relights the
/// wall recoloured with no distribution and without reading the link table, close to a
/// render that distributes from the same file.
#[test]
fn relight_with_a_reflectance_series_reads_no_link_table() {
    let dir = tempfile::tempdir().unwrap();
    let file = cornell_network_file(&dir);
    let img = |name: &str| read_image(&dir.path().join(name)).unwrap().0;
    let bad = network_relight(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "bad.exr"),
        &file,
        &["--reflectance-series", "nosuch"],
    );
    let e = stderr(&bad);
    assert_eq!(bad.status.code(), Some(2), "{e}");
    assert!(
        e.contains("cornell-box.toml") && e.contains("no material named \"nosuch\""),
        "{e}"
    );
    assert!(!dir.path().join("bad.exr").exists());
    let stored = network_relight(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "stored.exr"),
        &file,
        &[
            "--reflectance-series",
            "left_wall",
            "--reflectance-series",
            "right_wall",
        ],
    );
    let e = stderr(&stored);
    assert!(stored.status.success(), "{e}");
    assert!(e.contains("reflectance series of 'left_wall'"), "{e}");
    // The left wall blue (the scene's meshes are inline: the copy reads nothing beside it).
    let text = std::fs::read_to_string("scenes/cornell-box.toml").unwrap();
    let recoloured = text.replace("diffuse = [0.63, 0.065, 0.05]", "diffuse = [0.1, 0.2, 0.7]");
    assert_ne!(text, recoloured);
    let scene = tmp_path(&dir, "recoloured.toml");
    std::fs::write(&scene, recoloured).unwrap();
    let relit = network_relight(&scene, &tmp_path(&dir, "relit.exr"), &file, &[]);
    let full = network_render(
        &scene,
        &tmp_path(&dir, "full.exr"),
        &["--network-file", &file],
    );
    let e = stderr(&relit);
    assert!(relit.status.success(), "{e}");
    assert!(
        e.contains("relit from the reflectance series of 'left_wall'")
            && !e.contains("right_wall")
            && e.contains("link table not read"),
        "{e}"
    );
    assert!(full.status.success(), "{}", stderr(&full));
    let (got, want) = (img("relit.exr"), img("full.exr"));
    let before = img("stored.exr");
    let (err, change) = (rmse(&got, &want, None), rmse(&before, &want, None));
    let level = mean(&want, None).element_sum() as f64 / 3.0;
    assert!(
        err < 1e-3 * level && change > 100.0 * err,
        "rmse {err}, change {change}, mean {level}"
    );
}
