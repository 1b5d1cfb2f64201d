//! The limits on reading a pbrt scene, through the command line: includes that fan out
//! exponentially and object instances that multiply geometry are refused quickly, within the
//! memory limit, with exit code 2 and one line naming the limit and how to raise it; a
//! reasonable instanced scene still renders.

mod common;

use common::{assert_clean_failure_of, raylink, stderr};
use raylink::image::output::read_image;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

const HEADER: &str = "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n\
    WorldBegin\nLightSource \"point\" \"rgb I\" [10 10 10] \"point3 from\" [0 0 4]\n";

fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    v.sort();
    v
}

/// Renders `scene` to `out` (a small image) with `extra` options: the run and its wall time.
fn render(scene: &Path, out: &Path, extra: &[&str]) -> (std::process::Output, Duration) {
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "32",
        "--height",
        "24",
        "--quiet",
    ];
    args.extend(extra);
    let start = Instant::now();
    let output = raylink(&args);
    (output, start.elapsed())
}

/// `main.pbrt` includes `l00.pbrt` and each `lNN.pbrt` includes the next level twice,
/// `levels` levels: 2^levels includes if nothing stopped it.
fn write_fan_out(dir: &Path, levels: usize) -> PathBuf {
    for i in 0..levels {
        let text = if i + 1 < levels {
            format!(
                "Include \"l{:02}.pbrt\"\nInclude \"l{:02}.pbrt\"\n",
                i + 1,
                i + 1
            )
        } else {
            "Translate 0 0 0\n".to_string()
        };
        std::fs::write(dir.join(format!("l{i:02}.pbrt")), text).unwrap();
    }
    let main = dir.join("main.pbrt");
    std::fs::write(
        &main,
        format!("{HEADER}Shape \"sphere\" \"float radius\" 1\nInclude \"l00.pbrt\"\n"),
    )
    .unwrap();
    main
}

/// Include fan-out, 40 levels: refused at the fixed limit on Include statements, within a few
/// seconds, under a small memory limit and under the default one; nothing written.
#[test]
fn include_fan_out_is_refused_quickly() {
    for extra in [&["--max-memory", "512M"][..], &[]] {
        let dir = tempfile::tempdir().unwrap();
        let main = write_fan_out(dir.path(), 40);
        let before = files_in(dir.path());
        let (out, time) = render(&main, &dir.path().join("out.exr"), extra);
        eprintln!(
            "include fan-out {extra:?}: {time:.2?}: {}",
            stderr(&out).trim()
        );
        assert_clean_failure_of(
            "include fan-out",
            &out,
            &[
                ".pbrt: line ",
                "more than 100000 Include and Import statements",
                "fixed limit",
            ],
        );
        assert!(time < Duration::from_secs(20), "took {time:?}");
        assert_eq!(files_in(dir.path()), before, "something was written");
    }
}

/// One object of `triangles` triangles (a grid) and `instances` instances of it; a
/// `cut_out` object has an alpha, so each instance copies its shapes.
fn write_instances(path: &Path, cells: usize, instances: usize, cut_out: bool) {
    let mut s = String::from(HEADER);
    s.push_str("ObjectBegin \"grid\"\nShape \"trianglemesh\" \"point3 P\" [");
    for j in 0..=cells {
        for i in 0..=cells {
            write!(
                s,
                " {} {} 0",
                i as f32 / cells as f32,
                j as f32 / cells as f32
            )
            .unwrap();
        }
    }
    s.push_str(" ] \"integer indices\" [");
    let at = |i: usize, j: usize| j * (cells + 1) + i;
    for j in 0..cells {
        for i in 0..cells {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            write!(s, " {a} {b} {c} {a} {c} {d}").unwrap();
        }
    }
    s.push_str(if cut_out {
        " ] \"float alpha\" 0.5\n"
    } else {
        " ]\n"
    });
    s.push_str("ObjectEnd\nScale 0.5 0.5 0.5\n");
    for k in 0..instances {
        writeln!(
            s,
            "AttributeBegin Translate {} {} -1 ObjectInstance \"grid\" AttributeEnd",
            k as i64 % 4 - 2,
            k as i64 / 4 % 4 - 2
        )
        .unwrap();
    }
    std::fs::write(path, s).unwrap();
}

/// A cut-out object of 20,000 triangles instanced 20,000 times (400 million triangles, each
/// placement a copy: the alpha test works on world-space shapes) under `--max-memory 1G`:
/// refused before the copies pass the limit, saying what it would need, with the process's
/// peak memory well under the limit. (Instances of an opaque object share one copy:
/// tests/instancing.rs renders such a scene.)
#[test]
fn an_instance_bomb_is_refused_within_the_memory_limit() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("bomb.pbrt");
    write_instances(&scene, 100, 20_000, true);
    let size = std::fs::metadata(&scene).unwrap().len();
    let before = files_in(dir.path());
    let (out, time) = render(&scene, &dir.path().join("out.exr"), &["--max-memory", "1G"]);
    // The largest peak of this process's children so far: an upper bound on this one's.
    let usage =
        nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_CHILDREN).unwrap();
    let peak_mib = usage.max_rss() as f64 / 1024.0;
    eprintln!(
        "instance bomb ({} KiB): {time:.2?}, peak RSS {peak_mib:.0} MiB: {}",
        size / 1024,
        stderr(&out).trim()
    );
    assert_clean_failure_of(
        "instance bomb",
        &out,
        &[
            "bomb.pbrt: line ",
            "ObjectInstance \"grid\"",
            "would need",
            "more than the limit of 1.0 GiB set by --max-memory",
        ],
    );
    assert!(peak_mib < 300.0, "peak RSS {peak_mib:.0} MiB");
    assert!(time < Duration::from_secs(20), "took {time:?}");
    assert_eq!(files_in(dir.path()), before, "something was written");
}

/// A few instances of a small object render, and every instance is there: the image of
/// eight instances differs from that of one.
#[test]
fn a_small_instanced_scene_renders() {
    let dir = tempfile::tempdir().unwrap();
    let (one, eight) = (dir.path().join("one.pbrt"), dir.path().join("eight.pbrt"));
    write_instances(&one, 4, 1, false);
    write_instances(&eight, 4, 8, false);
    for (scene, name) in [(&one, "one.exr"), (&eight, "eight.exr")] {
        let (out, _) = render(scene, &dir.path().join(name), &["--max-memory", "256M"]);
        assert!(out.status.success(), "{}", stderr(&out));
    }
    let (a, _) = read_image(&dir.path().join("one.exr")).unwrap();
    let (b, _) = read_image(&dir.path().join("eight.exr")).unwrap();
    let lit =
        |pixels: &[raylink::math::Rgb]| pixels.iter().filter(|p| p.max_element() > 0.0).count();
    assert!(
        lit(&b.pixels) > lit(&a.pixels) && lit(&a.pixels) > 0,
        "the instances are missing: {} and {} lit values",
        lit(&a.pixels),
        lit(&b.pixels)
    );
}
