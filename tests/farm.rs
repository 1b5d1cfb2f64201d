//! Rendering in parts (docs/farm.md): tiles and crops merged by `raylink merge` equal the
//! whole render bit for bit (path tracer with a filter wider than a pixel, Whitted's adaptive
//! anti-aliasing, the irradiance cache from `raylink precompute`, the illumination network);
//! merge refuses parts that do not fit; render jobs only read precomputed files.

mod common;

use common::{raylink, stderr};
use raylink::image::output::read_image;
use raylink::image::{Image, MetaValue};
use std::path::{Path, PathBuf};

fn path(dir: &tempfile::TempDir, name: &str) -> String {
    dir.path().join(name).to_string_lossy().into_owned()
}

/// Runs raylink with `args` and asserts success.
fn ok(args: &[&str]) {
    let out = raylink(args);
    assert!(out.status.success(), "{args:?}: {}", stderr(&out));
}

/// Runs raylink with `args`, asserts exit status 2 with one line naming `names`; returns it.
fn refused(args: &[&str], names: &str) -> String {
    let out = raylink(args);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains(names), "{names} not in {err}");
    assert!(!err.contains("panicked"), "{err}");
    err
}

fn assert_bit_identical(a: &Image, b: &Image) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        let (p, q) = (
            p.to_array().map(f32::to_bits),
            q.to_array().map(f32::to_bits),
        );
        assert_eq!(
            p,
            q,
            "pixel ({}, {}) differs",
            i as u32 % a.width,
            i as u32 / a.width
        );
    }
}

/// Renders `scene` whole and as `tiles` tiles (plus the crops given), merges the tiles and
/// checks both images are identical; returns the tile paths and the temporary directory.
fn tiles_equal_whole(
    scene: &str,
    options: &[&str],
    tiles: u32,
    dir: &tempfile::TempDir,
) -> (Vec<String>, Image) {
    let whole = path(dir, "whole.exr");
    let mut args = vec!["render", scene, "-q", "-o", &whole];
    args.extend_from_slice(options);
    ok(&args);
    let pattern = path(dir, "tile_{tile}.exr");
    let mut parts = Vec::new();
    for i in 0..tiles {
        let tile = format!("{i}/{tiles}");
        let mut args = vec!["render", scene, "-q", "--tile", &tile, "-o", &pattern];
        args.extend_from_slice(options);
        ok(&args);
        parts.push(path(dir, &format!("tile_{i}.exr")));
    }
    let merged = path(dir, "merged.exr");
    let mut args = vec!["merge", "-o", &merged];
    args.extend(parts.iter().map(String::as_str));
    ok(&args);
    let (a, _) = read_image(Path::new(&whole)).unwrap();
    let (b, meta) = read_image(Path::new(&merged)).unwrap();
    assert_bit_identical(&a, &b);
    let merged_parts = meta.iter().find(|(n, _)| n == "raylink:merged_parts");
    assert_eq!(
        merged_parts.map(|m| &m.1),
        Some(&MetaValue::Int(tiles as i32))
    );
    (parts, a)
}

/// Path tracing with a Gaussian of radius 2 (each sample splatted into the pixels within 2
/// of it, so a part's border pixels take samples of pixels outside it) and several passes:
/// five bands equal the whole image, and so does a crop that starts inside a render tile.
#[test]
fn path_traced_tiles_with_a_wide_filter_equal_the_whole_render() {
    let dir = tempfile::tempdir().unwrap();
    let options = [
        "--integrator",
        "path",
        "--width",
        "40",
        "--height",
        "30",
        "--spp",
        "6",
        "--filter",
        "gaussian",
        "--filter-radius",
        "2",
        "--seed",
        "3",
    ];
    let (parts, whole) = tiles_equal_whole("scenes/cornell-box.toml", &options, 5, &dir);
    // A tile is a band of rows with its place in the image as data window.
    let tile = raylink::image::io::read(Path::new(&parts[1])).unwrap();
    assert_eq!((tile.window.x, tile.window.y), (0, 6));
    assert_eq!((tile.window.full_width, tile.window.full_height), (40, 30));
    assert_eq!((tile.width, tile.height), (40, 6));
    // A crop that starts inside a 16-pixel render tile, with its auxiliary images.
    let crop = path(&dir, "crop.exr");
    let mut args = vec![
        "render",
        "scenes/cornell-box.toml",
        "-q",
        "--aov",
        "--crop",
        "7,5,23,19",
        "-o",
        &crop,
    ];
    args.extend_from_slice(&options);
    ok(&args);
    let (c, _) = read_image(Path::new(&crop)).unwrap();
    let region = tile_at(7, 5, 23, 19);
    assert_bit_identical(&c, &raylink::farm::crop(&whole, &region));
    let whole_aov = path(&dir, "whole_aov.exr");
    let mut args = vec![
        "render",
        "scenes/cornell-box.toml",
        "-q",
        "--aov",
        "-o",
        &whole_aov,
    ];
    args.extend_from_slice(&options);
    ok(&args);
    for aov in ["albedo", "normal", "depth"] {
        let (part, _) = read_image(&dir.path().join(format!("crop.{aov}.exr"))).unwrap();
        let (full, _) = read_image(&dir.path().join(format!("whole_aov.{aov}.exr"))).unwrap();
        assert!(full.pixels.iter().any(|p| p.max_element() > 0.0), "{aov}");
        assert_bit_identical(&part, &raylink::farm::crop(&full, &region));
    }
}

fn tile_at(x0: u32, y0: u32, x1: u32, y1: u32) -> raylink::Tile {
    raylink::Tile { x0, y0, x1, y1 }
}

/// Whitted's adaptive anti-aliasing: squares are subdivided by comparing corner samples, and
/// corners on a tile's edge are shared with the neighbour; band edges at rows that are not
/// multiples of the engine's tiles still give the whole render's pixels.
#[test]
fn whitted_adaptive_tiles_equal_the_whole_render() {
    let dir = tempfile::tempdir().unwrap();
    tiles_equal_whole(
        "scenes/whitted.toml",
        &["--width", "48", "--height", "36", "--aa-depth", "3"],
        3,
        &dir,
    );
}

/// The irradiance cache: `raylink precompute` runs the overture of the whole view once;
/// every tile job reads the file (unchanged afterwards) and the merged tiles equal a whole
/// render that ran its own overture without any file. A file precomputed for another view
/// is refused.
#[test]
fn irradiance_cache_tiles_from_a_precomputed_cache_equal_the_whole_render() {
    let dir = tempfile::tempdir().unwrap();
    let cache = path(&dir, "view.ic");
    let view = [
        "--integrator",
        "irradiance-cache",
        "--width",
        "32",
        "--height",
        "24",
        "--spp",
        "2",
        "--ab",
        "2",
        "--ic-samples",
        "32",
    ];
    let mut args = vec![
        "precompute",
        "scenes/cornell-box.toml",
        "-q",
        "--cache-file",
        &cache,
    ];
    args.extend_from_slice(&view);
    ok(&args);
    let before = std::fs::read(&cache).unwrap();
    let modified = std::fs::metadata(&cache).unwrap().modified().unwrap();

    // The whole render (no cache file) against tiles reading the precomputed file.
    let whole = path(&dir, "whole.exr");
    let mut args = vec!["render", "scenes/cornell-box.toml", "-q", "-o", &whole];
    args.extend_from_slice(&view);
    ok(&args);
    let mut parts = Vec::new();
    for i in 0..3 {
        let tile = format!("{i}/3");
        let out = path(&dir, &format!("t{i}.exr"));
        let mut args = vec![
            "render",
            "scenes/cornell-box.toml",
            "-q",
            "--tile",
            &tile,
            "--cache-file",
            &cache,
            "-o",
            &out,
        ];
        args.extend_from_slice(&view);
        ok(&args);
        parts.push(out);
    }
    let merged = path(&dir, "merged.exr");
    let mut args = vec!["merge", "-o", &merged];
    args.extend(parts.iter().map(String::as_str));
    ok(&args);
    let (a, _) = read_image(Path::new(&whole)).unwrap();
    let (b, _) = read_image(Path::new(&merged)).unwrap();
    assert_bit_identical(&a, &b);
    assert_eq!(std::fs::read(&cache).unwrap(), before);
    assert_eq!(
        std::fs::metadata(&cache).unwrap().modified().unwrap(),
        modified
    );

    // Another view (more samples): its overture would trace other rays.
    let out = path(&dir, "other.exr");
    let mut args = vec![
        "render",
        "scenes/cornell-box.toml",
        "--tile",
        "0/2",
        "--cache-file",
        &cache,
        "-o",
        &out,
    ];
    args.extend_from_slice(&view);
    let spp = args.iter().position(|a| *a == "--spp").unwrap();
    args[spp + 1] = "3";
    refused(&args, "view.ic");
    assert!(!Path::new(&out).exists());
    // Without a precomputed file, a tile job would have to run the whole overture.
    let mut args = vec![
        "render",
        "scenes/cornell-box.toml",
        "--tile",
        "0/2",
        "-o",
        &out,
    ];
    args.extend_from_slice(&view);
    refused(&args, "raylink precompute");
    assert_eq!(std::fs::read(&cache).unwrap(), before);
    // precompute needs a file to write, and writes no image.
    refused(&["precompute", "scenes/cornell-box.toml"], "--cache-file");
    refused(
        &[
            "precompute",
            "scenes/cornell-box.toml",
            "--cache-file",
            &cache,
            "-o",
            &out,
        ],
        "-o",
    );
}

/// The illumination network: precomputed once, read by every tile job; the tiles equal a
/// whole render from the same file.
#[test]
fn network_tiles_from_a_precomputed_network_equal_the_whole_render() {
    let dir = tempfile::tempdir().unwrap();
    let file = path(&dir, "box.net");
    let options = [
        "--integrator",
        "network",
        "--slopes",
        "4",
        "--intercept-step",
        "0.125",
        "--width",
        "24",
        "--height",
        "20",
        "--network-file",
        &file,
    ];
    let mut args = vec!["precompute", "scenes/cornell-box.toml"];
    args.extend_from_slice(&options);
    let out = raylink(&args);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    // The network's structure only: every render distributes the light itself.
    assert!(err.contains("preprocess: "), "{err}");
    assert!(!err.contains("distribution"), "{err}");
    let before = std::fs::read(&file).unwrap();
    tiles_equal_whole("scenes/cornell-box.toml", &options, 2, &dir);
    assert_eq!(std::fs::read(&file).unwrap(), before);
}

/// Merge refuses, with one line naming the file, parts from another seed, overlapping parts
/// and an incomplete set; it writes nothing then. Splatting integrators refuse --tile.
#[test]
fn merge_refuses_parts_that_do_not_fit() {
    let dir = tempfile::tempdir().unwrap();
    let render_scene = |scene: &str, out: &str, extra: &[&str]| {
        let mut args = vec![
            "render",
            scene,
            "-q",
            "--integrator",
            "path",
            "--width",
            "16",
            "--height",
            "12",
            "--spp",
            "1",
            "-o",
            out,
        ];
        args.extend_from_slice(extra);
        ok(&args);
    };
    let render = |out: &str, extra: &[&str]| render_scene("scenes/cornell-box.toml", out, extra);
    let pattern = path(&dir, "t{tile}.exr");
    for i in 0..3 {
        render(&pattern, &["--tile", &format!("{i}/3")]);
    }
    let seeded = path(&dir, "seeded.exr");
    render(&seeded, &["--tile", "2/3", "--seed", "1"]);
    let crop = path(&dir, "crop.exr");
    render(&crop, &["--crop", "0,3,4,5"]);
    let [t0, t1, t2] = [0, 1, 2].map(|i| path(&dir, &format!("t{i}.exr")));
    let out = path(&dir, "merged.exr");

    let err = refused(&["merge", &t0, &t1, &seeded, "-o", &out], "seeded.exr");
    assert!(err.contains("seed"), "{err}");
    let err = refused(&["merge", &t0, &t1, &t2, &crop, "-o", &out], "crop.exr");
    assert!(err.contains("overlaps") && err.contains("t0.exr"), "{err}");
    let err = refused(&["merge", &t0, &t2, "-o", &out], "t0.exr");
    assert!(err.contains("missing tiles: 1/3"), "{err}");
    // A tile of an image of another size.
    let other = path(&dir, "other.exr");
    ok(&[
        "render",
        "scenes/cornell-box.toml",
        "-q",
        "--integrator",
        "path",
        "--width",
        "20",
        "--height",
        "12",
        "--spp",
        "1",
        "--tile",
        "1/3",
        "-o",
        &other,
    ]);
    refused(&["merge", &t0, &other, &t2, "-o", &out], "other.exr");
    // A tile of an edited scene (the right wall's colour), everything else equal.
    let edited = path(&dir, "edited.toml");
    let text = std::fs::read_to_string("scenes/cornell-box.toml").unwrap();
    let text = text.replace("[0.14, 0.45, 0.091]", "[0.14, 0.45, 0.092]");
    std::fs::write(&edited, text).unwrap();
    let from_edited = path(&dir, "from_edited.exr");
    render_scene(&edited, &from_edited, &["--tile", "1/3"]);
    let err = refused(
        &["merge", &t0, &from_edited, &t2, "-o", &out],
        "from_edited.exr",
    );
    assert!(err.contains("scene"), "{err}");
    assert!(!Path::new(&out).exists());
    // The full set merges.
    ok(&["merge", &t2, &t0, &t1, "-o", &out]);

    for integrator in ["light", "bdpt"] {
        refused(
            &[
                "render",
                "scenes/cornell-box.toml",
                "--integrator",
                integrator,
                "--tile",
                "0/2",
                "-o",
                &path(&dir, "x.exr"),
            ],
            integrator,
        );
    }
    // A tile is written only as EXR.
    refused(
        &[
            "render",
            "scenes/cornell-box.toml",
            "--tile",
            "0/2",
            "-o",
            &path(&dir, "x.png"),
        ],
        "x.png",
    );
    let leftovers: Vec<PathBuf> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap().to_string_lossy().starts_with('.'))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// The data window round trip through OpenImageIO: a region written at its place in a larger
/// image reads back with that window and its pixels; a region that does not fit, or a part
/// written as PNG (which has no data window), is an error and leaves no file.
#[test]
fn data_windows_round_trip_and_are_checked() {
    use raylink::image::io::Window;
    use raylink::image::output::{write_image_window, OutputOptions};
    use raylink::math::Rgb;
    let dir = tempfile::tempdir().unwrap();
    let mut image = Image::new(3, 2);
    for (i, p) in image.pixels.iter_mut().enumerate() {
        *p = Rgb::new(i as f32, 0.5, -1.0 / (i as f32 + 1.0));
    }
    let window = Window {
        x: 5,
        y: 7,
        full_x: 0,
        full_y: 0,
        full_width: 8,
        full_height: 9,
    };
    let meta = vec![("raylink:test".to_string(), MetaValue::Int(4))];
    let file = dir.path().join("part.exr");
    write_image_window(&file, &image, window, &meta, &OutputOptions::default()).unwrap();
    let raw = raylink::image::io::read(&file).unwrap();
    assert_eq!(raw.window, window);
    assert_eq!((raw.width, raw.height), (3, 2));
    let (back, _) = read_image(&file).unwrap();
    assert_bit_identical(&back, &image);
    assert_eq!(raw.meta("raylink:test"), Some(&MetaValue::Int(4)));

    let outside = Window { x: 6, ..window };
    let bad = dir.path().join("outside.exr");
    let e = write_image_window(&bad, &image, outside, &meta, &OutputOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("outside.exr") && e.contains("does not fit"),
        "{e}"
    );
    let png = dir.path().join("part.png");
    let e = write_image_window(&png, &image, window, &meta, &OutputOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("part.png"), "{e}");
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["part.exr"]);
}
