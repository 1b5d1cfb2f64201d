//! Start-up: the program loads OpenImageIO (about 260 shared libraries, 0.25 s and 130 MB)
//! only when it first reads or writes an image, so printing its version, refusing an option
//! or a scene, and rendering until the image is written do without it.

mod common;

use std::path::Path;
use std::process::{Command, Output};

/// Runs raylink with the dynamic loader reporting every object it loads (on stderr).
fn traced(exe: &Path, args: &[&str]) -> (Output, String) {
    let out = Command::new(exe)
        .args(args)
        .env("LD_DEBUG", "files")
        .output()
        .expect("raylink runs");
    let loads = String::from_utf8_lossy(&out.stderr).into_owned();
    (out, loads)
}

fn exe() -> &'static Path {
    Path::new(env!("CARGO_BIN_EXE_raylink"))
}

#[test]
fn version_help_and_refusals_do_not_load_openimageio() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "[camera\n").unwrap();
    let bad = bad.to_str().unwrap();
    let runs: [&[&str]; 4] = [
        &["--version"],
        &["--help"],
        &["render", "scenes/cornell-box.toml", "--spp", "many"],
        &["render", bad, "-o", "never.png"],
    ];
    for args in runs {
        let (out, loads) = traced(exe(), args);
        // The loader does report what it loads: Embree, which is linked.
        assert!(loads.contains("libembree"), "{args:?}: no loader trace");
        assert!(
            !loads.contains("libOpenImageIO"),
            "{args:?} loaded OpenImageIO"
        );
        assert!(!loads.contains("libraylink_oiio"), "{args:?}");
        let expected = if args[0].starts_with("--") { 0 } else { 2 };
        assert_eq!(out.status.code(), Some(expected), "{args:?}");
    }
}

#[test]
fn writing_an_image_loads_openimageio_from_the_copy_the_program_carries() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("box.png");
    let (out, loads) = traced(
        exe(),
        &[
            "render",
            "scenes/cornell-box.toml",
            "--width",
            "16",
            "--height",
            "16",
            "--spp",
            "1",
            "--quiet",
            "-o",
            png.to_str().unwrap(),
        ],
    );
    assert!(out.status.success(), "{loads}");
    assert!(loads.contains("libOpenImageIO"));
    // No file of its own beside the build's program: the in-memory copy.
    assert!(
        loads.contains("file=/proc/self/fd/"),
        "not the carried copy"
    );
    let image = raylink::image::io::read(&png).unwrap();
    assert_eq!((image.width, image.height), (16, 16));
}

#[test]
fn an_installed_interface_beside_the_program_is_preferred() {
    // PREFIX/bin/raylink and PREFIX/lib/raylink/libraylink_oiio.so, as the package installs
    // them (written by `raylink generate-assets`).
    let prefix = tempfile::tempdir().unwrap();
    let bin = prefix.path().join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let copy = bin.join("raylink");
    std::fs::copy(exe(), &copy).unwrap();
    let assets = prefix.path().join("assets");
    let generated = common::raylink(&["generate-assets", assets.to_str().unwrap()]);
    assert!(generated.status.success());
    let lib = prefix.path().join("lib/raylink");
    std::fs::create_dir_all(&lib).unwrap();
    let object = lib.join("libraylink_oiio.so");
    std::fs::copy(assets.join("lib/libraylink_oiio.so"), &object).unwrap();
    let png = prefix.path().join("box.png");
    let (out, loads) = traced(
        &copy,
        &[
            "render",
            "scenes/cornell-box.toml",
            "--width",
            "8",
            "--height",
            "8",
            "--spp",
            "1",
            "--quiet",
            "-o",
            png.to_str().unwrap(),
        ],
    );
    assert!(out.status.success(), "{loads}");
    let installed = format!("file={}", object.display());
    assert!(
        loads.contains(&installed),
        "the installed object was not loaded"
    );
    assert!(!loads.contains("file=/proc/self/fd/"));
    assert!(png.is_file());
}
