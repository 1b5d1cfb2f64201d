//! The backend switch and `raylink bench` through the binary.

use raylink::image::output::read_image;
use std::collections::BTreeSet;

mod common;
use common::{raylink, stderr};

#[test]
fn render_with_each_backend_gives_the_same_image() {
    let dir = tempfile::tempdir().unwrap();
    let mut images = Vec::new();
    for accel in ["embree", "bvh"] {
        let exr = dir.path().join(format!("{accel}.exr"));
        let out = raylink(&[
            "render",
            "scenes/whitted.toml",
            "--accel",
            accel,
            "-o",
            exr.to_str().unwrap(),
            "--width",
            "64",
            "--height",
            "48",
            "--quiet",
        ]);
        assert!(out.status.success(), "{accel}: {}", stderr(&out));
        images.push(read_image(&exr).unwrap().0);
    }
    let rmse = images[0].rmse(&images[1]);
    assert!(rmse < 1e-3, "RMSE {rmse}");

    let out = raylink(&[
        "render",
        "scenes/whitted.toml",
        "--accel",
        "optix",
        "-o",
        "x.png",
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("optix"), "{}", stderr(&out));
}

#[test]
fn quick_bench_writes_a_complete_csv_chart_and_report() {
    let dir = tempfile::tempdir().unwrap();
    let out = raylink(&[
        "bench",
        "--quick",
        "--threads",
        "1,2",
        "--out",
        dir.path().to_str().unwrap(),
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(report.contains("embree/bvh"), "{report}");
    assert!(!report.contains("WARNING"), "{report}");

    let csv = std::fs::read_to_string(dir.path().join("bench.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let mut keys = BTreeSet::new();
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f.len(), header.len(), "{line}");
        keys.insert((
            f[col("scene")].to_string(),
            f[col("backend")].to_string(),
            f[col("kind")].to_string(),
            f[col("threads")].to_string(),
        ));
        for name in [
            "primitives",
            "rays",
            "hits",
            "mrays_median",
            "mrays_min",
            "mrays_max",
            "build_ms_median",
            "memory_bytes",
        ] {
            let v: f64 = f[col(name)].parse().unwrap();
            assert!(v > 0.0 && v.is_finite(), "{name} = {v} in {line}");
        }
        let (lo, med, hi): (f64, f64, f64) = (
            f[col("mrays_min")].parse().unwrap(),
            f[col("mrays_median")].parse().unwrap(),
            f[col("mrays_max")].parse().unwrap(),
        );
        assert!(lo <= med && med <= hi, "{line}");
    }
    // One row per (scene, backend, kind, threads): 2 scenes × 2 × 3 × 2.
    let mut expected = BTreeSet::new();
    for scene in ["cornell", "spheres-10k"] {
        for backend in ["embree", "bvh"] {
            for kind in ["camera", "shadow", "diffuse"] {
                for threads in ["1", "2"] {
                    expected.insert((scene.into(), backend.into(), kind.into(), threads.into()));
                }
            }
        }
    }
    assert_eq!(keys, expected);

    let svg = std::fs::read_to_string(dir.path().join("bench.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("diffuse-bounce rays"));
    assert!(std::fs::read_to_string(dir.path().join("bench.md"))
        .unwrap()
        .contains("| cornell |"));
}

#[test]
fn bench_rejects_bad_options() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("results");
    for args in [
        &["--scenes", "nope-3"][..],
        &["--scenes", "spheres-0"],
        &["--threads", "0"],
        &["--reps", "0"],
    ] {
        let args: Vec<&str> = ["bench", "--out", out_dir.to_str().unwrap()]
            .into_iter()
            .chain(args.iter().copied())
            .collect();
        let out = raylink(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        assert!(
            stderr(&out).starts_with("raylink: error: "),
            "{}",
            stderr(&out)
        );
        // Options are checked before anything is measured or written.
        assert!(!out_dir.exists());
    }
}

/// `raylink bench --path-tracer` reports positive path and ray rates for each backend.
#[test]
fn path_tracer_bench_reports_each_backend() {
    let dir = tempfile::tempdir().unwrap();
    let out = raylink(&[
        "bench",
        "--path-tracer",
        "--width",
        "24",
        "--height",
        "24",
        "--reps",
        "1",
        "--warmup",
        "0",
        "--threads",
        "1",
        "--quiet",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let md = std::fs::read_to_string(dir.path().join("path.md")).unwrap();
    for backend in ["Embree", "Bvh"] {
        let row = md
            .lines()
            .find(|l| l.starts_with(&format!("| {backend} | 1 |")))
            .unwrap_or_else(|| panic!("no {backend} row in {md}"));
        let numbers: Vec<f64> = row
            .split(['|', '(', ')', ' '])
            .filter_map(|w| w.split('-').next()?.parse().ok())
            .collect();
        assert!(
            numbers.len() >= 3 && numbers[1..].iter().all(|v| *v > 0.0),
            "{row}"
        );
    }
}
