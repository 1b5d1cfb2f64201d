//! Object-space temporal coherence through the command line: `raylink animate` writes every
//! frame and its statistics, verifies the frames against full renders, renders a range of
//! frames as the whole sequence does, and rejects bad input. (The library's tests, the DDA,
//! the records and every incremental frame against its full render, are in
//! `src/tests/coherence.rs`.)

mod common;
#[path = "../src/tests/coherence_scenes.rs"]
mod scenes;

use raylink::image::Image;
use scenes::{animated, MOVING};

fn bits(image: &Image) -> Vec<[u32; 3]> {
    image
        .pixels
        .iter()
        .map(|p| p.to_array().map(f32::to_bits))
        .collect()
}

#[test]
fn cli_writes_frames_and_statistics() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("a.toml");
    std::fs::write(&scene, animated("", MOVING)).unwrap();
    let pattern = dir.path().join("out/f_%02d.exr");
    let csv = dir.path().join("stats.csv");
    let out = common::raylink(&[
        "animate",
        scene.to_str().unwrap(),
        "-o",
        pattern.to_str().unwrap(),
        "--verify",
        "--stats",
        "--quiet",
        "--aa-depth",
        "1",
        "--csv",
        csv.to_str().unwrap(),
        "--overhead-reps",
        "3",
    ]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    for f in 0..4 {
        assert!(dir.path().join(format!("out/f_{f:02}.exr")).is_file());
    }
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert_eq!(rows.len(), 4);
    assert!(rows.iter().all(|r| r.ends_with(",true")), "{text}");
    // Frame 3 is at rest: no rays.
    assert!(rows[3].starts_with("3,0,"), "{text}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("every frame identical"), "{stdout}");
    assert!(stdout.contains("records: segments, at most"), "{stdout}");
    // CPU time is measured finely enough for a frame of a few milliseconds (the retraced
    // frames 1 and 2, coherent and full), and the repeated first frame is reported.
    for r in &rows[1..3] {
        let f: Vec<&str> = r.split(',').collect();
        for i in [2, 12] {
            let cpu: f64 = f[i].parse().unwrap();
            assert!(cpu > 0.0, "column {i} of {r}");
        }
    }
    // Frame 2 retraces blocks that frame 1 retraced: some of their camera rays are answered
    // from the hits kept then (columns 9 and 10: camera rays kept, reused).
    let camera: Vec<u64> = rows[2]
        .split(',')
        .skip(9)
        .take(2)
        .map(|c| c.parse().unwrap())
        .collect();
    assert!(camera[1] > 0 && camera[1] < camera[0], "{text}");
    assert!(
        stdout.contains("stored answers (section 3.3.3): "),
        "{stdout}"
    );
    assert!(
        stdout.contains("first frame rendered 3 times both ways: median"),
        "{stdout}"
    );

    // The path tracer, through the command line.
    let out = common::raylink(&[
        "animate",
        scene.to_str().unwrap(),
        "-o",
        dir.path().join("path_%d.exr").to_str().unwrap(),
        "--integrator",
        "path",
        "--spp",
        "2",
        "--width",
        "24",
        "--height",
        "18",
        "--verify",
        "--stats",
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("every frame identical"), "{stdout}");
    assert!(dir.path().join("path_3.exr").is_file());

    // Segment records over a quarter of --max-memory (about 200 KiB of them here) become
    // voxel tables after frame 0, with a notice; every frame is still verified.
    let out = common::raylink(&[
        "animate",
        scene.to_str().unwrap(),
        "-o",
        dir.path().join("small_%d.exr").to_str().unwrap(),
        "--verify",
        "--stats",
        "--max-memory",
        "512K",
    ]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("every frame identical"), "{stdout}");
    assert!(stdout.contains("records: voxel tables"), "{stdout}");
    assert!(
        common::stderr(&out).contains("notice: frame 0: the records grew past"),
        "{}",
        common::stderr(&out)
    );
}

#[test]
fn cli_rejects_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("a.toml");
    std::fs::write(&scene, animated("", MOVING)).unwrap();
    let s = scene.to_str().unwrap();
    let no_number = dir.path().join("f.exr");
    let out = common::raylink(&["animate", s, "-o", no_number.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        common::stderr(&out).contains("%d"),
        "{}",
        common::stderr(&out)
    );
    assert!(!no_number.exists());

    let pattern = dir.path().join("f_%d.exr");
    let p = pattern.to_str().unwrap();
    let out = common::raylink(&["animate", s, "-o", p, "--block-table", "16"]);
    assert_eq!(out.status.code(), Some(2));
    let out = common::raylink(&["animate", s, "-o", p, "--max-memory", "lots"]);
    assert_eq!(out.status.code(), Some(2));
    let err = common::stderr(&out);
    assert!(
        err.contains("--max-memory") && err.lines().count() == 1,
        "{err}"
    );

    let bad = dir.path().join("bad.toml");
    std::fs::write(
        &bad,
        animated("", MOVING).replace("frame = 2", "frame = -1"),
    )
    .unwrap();
    let out = common::raylink(&["animate", bad.to_str().unwrap(), "-o", p]);
    assert_eq!(out.status.code(), Some(2));
    let err = common::stderr(&out);
    assert!(
        err.contains("bad.toml") && err.contains("increasing frame order"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!dir.path().join("f_0.exr").exists());
}

/// An animation's job is made as a still render's: the scene file's `[render]` settings
/// with the options over them; a technique the coherence engine does not render is refused
/// at its line in the scene file.
#[test]
fn cli_takes_the_scene_files_settings_and_refuses_other_techniques() {
    let dir = tempfile::tempdir().unwrap();
    let frame0 = |name: &str, render: &str, args: &[&str]| {
        let scene = dir.path().join(format!("{name}.toml"));
        std::fs::write(&scene, animated("", MOVING) + render).unwrap();
        let pattern = dir.path().join(format!("{name}_%d.exr"));
        let mut all = vec![
            "animate",
            scene.to_str().unwrap(),
            "-o",
            pattern.to_str().unwrap(),
            "--frames",
            "0",
            "--quiet",
            "--aa-depth",
            "1",
        ];
        all.extend_from_slice(args);
        let out = common::raylink(&all);
        let written = dir.path().join(format!("{name}_0.exr"));
        (out, written)
    };
    let read = |path: &std::path::Path| bits(&raylink::read_image(path).unwrap().0);
    let (out, default) = frame0("default", "", &[]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let (out, given) = frame0("given", "", &["--spp", "4", "--max-depth", "1"]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let (out, scene) = frame0("scene", "\n[render]\nspp = 4\nmax_depth = 1\n", &[]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    // Adaptive anti-aliasing against a 2x2 grid, and the mirror sphere black at depth 1.
    assert_ne!(read(&default), read(&given));
    assert_eq!(
        read(&scene),
        read(&given),
        "the scene's settings were not used"
    );

    let (out, written) = frame0("bdpt", "\n[render]\nintegrator = \"bdpt\"\n", &[]);
    let err = common::stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("bdpt.toml") && err.contains("line") && err.contains("whitted or path"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!written.exists());
    let (out, _) = frame0("option", "", &["--integrator", "bdpt"]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn cli_frame_range_matches_the_whole_sequence() {
    // A sub-range starts with a full frame and continues coherently; its frames must equal
    // those of the whole sequence, and keep their absolute numbers.
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("a.toml");
    std::fs::write(
        &scene,
        animated("start = 10\n", MOVING)
            .replace("frame = 0\n", "frame = 10\n")
            .replace("frame = 2\n", "frame = 12\n"),
    )
    .unwrap();
    let s = scene.to_str().unwrap();
    let render = |name: &str, extra: &[&str]| {
        let pattern = dir.path().join(format!("{name}/f_%d.exr"));
        let mut args = vec!["animate", s, "-o", pattern.to_str().unwrap(), "--quiet"];
        args.extend(["--aa-depth", "1", "--width", "40", "--height", "30"]);
        args.extend(extra);
        let out = common::raylink(&args);
        assert!(out.status.success(), "{}", common::stderr(&out));
    };
    render("all", &[]);
    render("part", &["--frames", "11..12"]);
    render("tail", &["--frames", "12.."]);
    // The paper's voxel tables instead of segment records: the same frames.
    render("tables", &["--records", "tables"]);
    let read = |name: &str, f: i64| {
        let path = dir.path().join(format!("{name}/f_{f}.exr"));
        bits(&raylink::image::output::read_image(&path).unwrap().0)
    };
    for f in 10..14 {
        assert!(dir.path().join(format!("all/f_{f}.exr")).is_file());
    }
    for f in [11, 12] {
        assert!(read("part", f) == read("all", f), "frame {f} differs");
    }
    // Frame 11 is in motion: the range's first frame differs from the sequence's first.
    assert!(read("part", 11) != read("all", 10));
    assert!(read("tail", 12) == read("all", 12) && read("tail", 13) == read("all", 13));
    for f in 10..14 {
        assert!(
            read("tables", f) == read("all", f),
            "frame {f}: voxel tables"
        );
    }
    for (name, f) in [("part", 10), ("part", 13), ("tail", 11)] {
        assert!(!dir.path().join(format!("{name}/f_{f}.exr")).exists());
    }
    // A range outside the sequence is an error naming it.
    let bad = dir.path().join("bad/f_%d.exr");
    for spec in ["8..11", "12..11", "x"] {
        let out = common::raylink(&["animate", s, "-o", bad.to_str().unwrap(), "--frames", spec]);
        assert_eq!(out.status.code(), Some(2), "{spec}");
        assert!(common::stderr(&out).contains("--frames"), "{spec}");
    }
}

/// A sub-range of the moving-light animation where only a point light's intensity changes
/// (a change with no extent in space): every frame must equal its full render. It once
/// placed the voxel grid around the light's position alone, recorded nothing there, and
/// retraced nothing.
#[test]
fn a_light_that_only_dims_retraces_what_it_lights() {
    for placement in ["", "--lookahead"] {
        for (width, height) in [("160", "120"), ("320", "240")] {
            let dir = tempfile::tempdir().unwrap();
            let pattern = dir.path().join("f_%02d.exr");
            let mut args = vec![
                "animate",
                "scenes/anim-light.toml",
                "-o",
                pattern.to_str().unwrap(),
                "--frames",
                "0..9",
                "--width",
                width,
                "--height",
                height,
                "--verify",
                "--stats",
                "--quiet",
            ];
            if !placement.is_empty() {
                args.push(placement);
            }
            let out = common::raylink(&args);
            let text = String::from_utf8_lossy(&out.stdout);
            let case = format!("{width}x{height} {placement}");
            assert!(
                out.status.success(),
                "{case}: {}{text}",
                common::stderr(&out)
            );
            assert!(
                text.contains("every frame identical to its full render"),
                "{case}: {text}"
            );
            let mode = if placement.is_empty() {
                "online"
            } else {
                "look-ahead"
            };
            assert!(
                text.contains(&format!("placement: {mode}")),
                "{case}: {text}"
            );
        }
    }
}

/// `--retrace-map` draws, per frame, exactly the pixels the statistics count as retraced: red
/// over the retraced blocks of a coherent frame (as many as the CSV's `pixels_retraced`),
/// blue over a frame traced in full; and it may not name the frames' own files.
#[test]
fn retrace_maps_show_the_retraced_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("moving.toml");
    std::fs::write(&scene, animated("", MOVING)).unwrap();
    let frames = dir.path().join("f_%d.exr");
    let maps = dir.path().join("maps/m_%d.exr");
    let csv = dir.path().join("stats.csv");
    let out = common::raylink(&[
        "animate",
        scene.to_str().unwrap(),
        "-o",
        frames.to_str().unwrap(),
        "--retrace-map",
        maps.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
        "--block-table",
        "8x6",
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let text = std::fs::read_to_string(&csv).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let column = header.iter().position(|h| *h == "pixels_retraced").unwrap();
    for (f, line) in text.lines().skip(1).enumerate() {
        let retraced: usize = line.split(',').nth(column).unwrap().parse().unwrap();
        let path = dir.path().join(format!("maps/m_{f}.exr"));
        let (map, _) = raylink::read_image(&path).unwrap();
        let red = map.pixels.iter().filter(|p| p.x > 0.5 && p.z < 0.5).count();
        let blue = map.pixels.iter().filter(|p| p.z > 0.5).count();
        if f == 0 {
            assert_eq!(
                (red, blue),
                (0, map.pixels.len()),
                "frame 0 is traced in full"
            );
        } else {
            assert_eq!((red, blue), (retraced, 0), "frame {f}");
        }
    }
    let clash = common::raylink(&[
        "animate",
        scene.to_str().unwrap(),
        "-o",
        frames.to_str().unwrap(),
        "--retrace-map",
        frames.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(clash.status.code(), Some(2));
    assert!(common::stderr(&clash).contains("--retrace-map"));
}
