//! The bad-input corpus in tests/bad_inputs/ through the `raylink` binary: every case exits
//! with code 2 and one `raylink: error:` line naming the file or option and the problem, with
//! no panic, no output file, and the bad input file left as it was. (The scene and pbrt
//! cases, tests/bad_inputs/scenes and tests/bad_inputs/pbrt, run in tests/cli.rs.)

use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::{raylink, stderr};

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/bad_inputs")
}

fn assert_clean_failure(case: &str, out: &Output, needles: &[&str]) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "{case}: {err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "{case}: expected one line, got: {err}");
    assert!(lines[0].starts_with("raylink: error: "), "{case}: {err}");
    for n in needles {
        assert!(lines[0].contains(n), "{case}: {n:?} not in: {err}");
    }
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Runs `cases` on four threads (each case is a process; startup dominates).
fn run_parallel<T: Sync>(cases: &[T], check: impl Fn(&T) + Sync) {
    std::thread::scope(|scope| {
        for chunk in cases.chunks(cases.len().div_ceil(4).max(1)) {
            let check = &check;
            scope.spawn(move || chunk.iter().for_each(check));
        }
    });
}

/// tests/bad_inputs/options.txt: bad command lines.
#[test]
fn bad_command_lines_fail_cleanly() {
    let text = std::fs::read_to_string(corpus().join("options.txt")).unwrap();
    let cases: Vec<(&str, &str)> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| l.split_once(" # expect: ").expect("a case has # expect:"))
        .collect();
    assert!(cases.len() >= 40, "only {} command-line cases", cases.len());
    run_parallel(&cases, |(args, expect)| {
        let dir = tempfile::tempdir().unwrap();
        let args = args.replace("{dir}", dir.path().to_str().unwrap());
        let argv: Vec<&str> = args.split_whitespace().collect();
        assert_clean_failure(&args, &raylink(&argv), &[expect]);
        assert!(entries(dir.path()).is_empty(), "{args} left files behind");
    });
}

/// tests/bad_inputs/files: damaged or foreign cache, network and checkpoint files.
#[test]
fn bad_cache_network_and_checkpoint_files_fail_cleanly() {
    let files = corpus().join("files");
    let text = std::fs::read_to_string(files.join("expect.txt")).unwrap();
    let cases: Vec<(&str, &str)> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| l.split_once(": ").expect("FILE: TEXT"))
        .collect();
    assert!(cases.len() >= 15, "only {} file cases", cases.len());
    run_parallel(&cases, |(name, expect)| {
        let dir = tempfile::tempdir().unwrap();
        let original = std::fs::read(files.join(name)).unwrap();
        let out = dir.path().join("x.exr");
        let (placed, args): (PathBuf, Vec<String>) = if name.starts_with("checkpoint-") {
            let placed = dir.path().join("x.exr.checkpoint");
            let args =
                "scenes/cornell-box.toml --integrator path --width 8 --height 8 --spp 4 --resume";
            (placed, args.split(' ').map(String::from).collect())
        } else {
            let placed = dir.path().join(name);
            let p = placed.to_str().unwrap().to_string();
            let args = if name.starts_with("cache-") {
                "scenes/cornell-box.toml --integrator irradiance-cache --width 8 --height 8 --spp 1 --cache-file"
            } else {
                assert!(name.starts_with("network-"), "{name}: unknown kind");
                "scenes/network-room.toml --integrator network --slopes 2 --intercept-step 0.5 --network-file"
            };
            let mut args: Vec<String> = args.split(' ').map(String::from).collect();
            args.push(p);
            (placed, args)
        };
        std::fs::write(&placed, &original).unwrap();
        let mut argv = vec!["render", "--quiet", "-o", out.to_str().unwrap()];
        argv.extend(args.iter().map(String::as_str));
        let placed_name = placed.file_name().unwrap().to_str().unwrap();
        assert_clean_failure(name, &raylink(&argv), &[placed_name, expect]);
        assert_eq!(
            std::fs::read(&placed).unwrap(),
            original,
            "{name} was changed"
        );
        assert_eq!(entries(dir.path()), vec![placed_name.to_string()], "{name}");
    });
}

/// The corpus holds at least 40 cases over every kind of input.
#[test]
fn the_corpus_covers_every_input() {
    let count = |sub: &str, ext: &str| {
        entries(&corpus().join(sub))
            .iter()
            .filter(|n| n.ends_with(ext))
            .count()
    };
    let scenes = count("scenes", ".toml");
    let pbrt = count("pbrt", ".pbrt");
    let meshes = count("scenes/meshes", ".obj") + count("scenes/meshes", ".ply");
    assert!(
        scenes >= 40 && pbrt >= 20 && meshes >= 10,
        "{scenes} {pbrt} {meshes}"
    );
}
