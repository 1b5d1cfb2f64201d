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

/// `raylink bench --path-tracer` reports positive path and ray rates for each backend, the
/// load average, and each backend's error against Tungsten's render with the time and samples
/// to RMSE 0.0056 (`--quick`: 4 spp per error render, about 0.029).
#[test]
fn path_tracer_bench_reports_each_backend() {
    let dir = tempfile::tempdir().unwrap();
    let out = raylink(&[
        "bench",
        "--path-tracer",
        "--quick",
        "--width",
        "24",
        "--height",
        "24",
        "--reps",
        "3",
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
    assert!(md.contains("of 3 interleaved runs"), "{md}");
    let load = md.split("load average (1 min) ").nth(1).unwrap_or_default();
    let first = load.split(' ').next().unwrap_or_default();
    assert!(
        first == "unknown" || first.parse::<f64>().is_ok_and(|l| l >= 0.0),
        "{md}"
    );
    let (throughput, error) = md
        .split_once("Time to equal error")
        .unwrap_or_else(|| panic!("no error table in {md}"));
    assert!(error.contains("TungstenRender-256.exr"), "{md}");
    let numbers = |table: &str, backend: &str| -> Vec<f64> {
        let row = table
            .lines()
            .find(|l| l.starts_with(&format!("| {backend} | 1 |")))
            .unwrap_or_else(|| panic!("no {backend} row in {md}"));
        row.split(['|', '(', ')', ' '])
            .filter_map(|w| w.split('-').next()?.parse().ok())
            .collect()
    };
    for backend in ["Embree", "Bvh"] {
        let t = numbers(throughput, backend);
        assert!(t.len() >= 3 && t[1..].iter().all(|v| *v > 0.0), "{t:?}");
        // threads, then median and min of: render s, RMSE, s to target, spp to target.
        let e = numbers(error, backend);
        assert_eq!(e.len(), 9, "{e:?} in {md}");
        assert!(e[1..].iter().all(|v| *v > 0.0), "{e:?}");
        let (seconds, rmse, to_target, spp) = (e[1], e[3], e[5], e[7]);
        assert!(rmse < 0.05, "RMSE {rmse} at 4 spp");
        let scale = (rmse / 0.0056).powi(2);
        // spp · (e/E)² grows with e: its median over 3 runs is that of the median RMSE (up to
        // the printed digits).
        assert!(
            (spp / (4.0 * scale) - 1.0).abs() < 0.01,
            "{spp} spp for {rmse}"
        );
        assert!(to_target > seconds, "{to_target} s from {seconds} s");
    }
}

/// The path tracer bench needs at least 3 timed runs: fewer is an error naming --reps,
/// before anything is measured or written.
#[test]
fn path_tracer_bench_needs_three_runs() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("results");
    for reps in ["0", "1", "2"] {
        let out = raylink(&[
            "bench",
            "--path-tracer",
            "--reps",
            reps,
            "--out",
            out_dir.to_str().unwrap(),
        ]);
        assert_eq!(out.status.code(), Some(2), "{reps}: {}", stderr(&out));
        let err = stderr(&out);
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(
            err.starts_with("raylink: error: --reps ") && err.contains("at least 3"),
            "{err}"
        );
        assert!(!out_dir.exists());
    }
}
