//! Reading a scene takes time in proportion to its size, and a signal stops it: TOML scenes
//! of many instances or shapes once took time quadratic in their count (10k/20k/40k
//! instances: 2.5/8.6/33 s) and did not look at the cancel token between instances.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

mod common;
use common::process::{finish, spawn, wait_until};

/// A TOML scene of `n` instances of one triangle, or of `n` triangle shapes.
fn scene(dir: &Path, n: usize, instances: bool) -> PathBuf {
    let mut text = String::from(
        "[camera]\nposition = [0, 0, 50]\nlook_at = [0, 0, 0]\nfov = 40\nwidth = 8\n\
         height = 8\n\n[materials.white]\ndiffuse = 0.8\n",
    );
    let tri = "type = \"mesh\"\nmaterial = \"white\"\nindices = [[0, 1, 2]]\n";
    if instances {
        text.push_str(&format!(
            "\n[[objects]]\nname = \"tri\"\n[[objects.shapes]]\n{tri}positions = [[0, 0, 0], \
             [0, 1, 0], [0, 0, 1]]\n"
        ));
    }
    for i in 0..n {
        let x = i as f32 * 1e-3;
        if instances {
            text.push_str(&format!(
                "\n[[instances]]\nobject = \"tri\"\ntransform = [{{ translate = [{x}, 0, 0] }}]\n"
            ));
        } else {
            text.push_str(&format!(
                "\n[[shapes]]\n{tri}positions = [[{x}, 0, 0], [{x}, 1, 0], [{x}, 0, 1]]\n"
            ));
        }
    }
    let path = dir.join(format!("{}-{n}.toml", if instances { "i" } else { "s" }));
    std::fs::write(&path, text).unwrap();
    path
}

/// The shortest of three readings of `path`, in seconds.
fn reading_time(path: &Path) -> f64 {
    (0..3)
        .map(|_| {
            let start = Instant::now();
            raylink::Scene::load(path).unwrap();
            start.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Four times the instances (or shapes) take about four times as long to read, not
/// sixteen: the ratio must stay under 8.
#[test]
fn reading_many_instances_or_shapes_is_linear() {
    let dir = tempfile::tempdir().unwrap();
    for instances in [true, false] {
        let small = reading_time(&scene(dir.path(), 5_000, instances));
        let large = reading_time(&scene(dir.path(), 20_000, instances));
        let kind = if instances { "instances" } else { "shapes" };
        assert!(
            large < 8.0 * small.max(0.005),
            "{kind}: 5000 in {small:.3} s, 20000 in {large:.3} s"
        );
    }
}

/// SIGINT while 100 000 instances are read: the run stops within a second, as interrupted
/// during the reading.
#[test]
fn sigint_stops_the_reading_of_many_instances() {
    let dir = tempfile::tempdir().unwrap();
    let path = scene(dir.path(), 100_000, true);
    let out = dir.path().join("x.png");
    let mut child = spawn(&[
        "render",
        path.to_str().unwrap(),
        "-q",
        "-o",
        out.to_str().unwrap(),
    ]);
    wait_until(&mut child, |pid| {
        common::process::catches(pid, 2) && common::process::cpu_seconds(pid) > 0.1
    });
    let sent = Instant::now();
    common::process::signal(&child, nix::sys::signal::Signal::SIGINT);
    let run = finish(child);
    let stopped = sent.elapsed();
    let err = common::stderr(&run);
    assert_eq!(run.status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted by SIGINT"), "{err}");
    assert!(
        stopped < Duration::from_secs(1),
        "stopped after {stopped:?}"
    );
}
