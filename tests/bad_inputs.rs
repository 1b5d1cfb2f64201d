//! The bad-input corpus in tests/bad_inputs/ through the `raylink` binary: every case exits
//! with code 2 and one `raylink: error:` line naming the file or option and the problem, with
//! no panic, no output file, and the bad input file left as it was. (The scene and pbrt
//! cases, tests/bad_inputs/scenes and tests/bad_inputs/pbrt, run in tests/cli.rs.)

use std::path::{Path, PathBuf};

mod common;
use common::{assert_clean_failure_of as assert_clean_failure, raylink};

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/bad_inputs")
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

/// The cases of a list file: one `CASE{separator}EXPECTED` per line, `#` lines are comments.
fn read_cases(path: &Path, separator: &str) -> Vec<(String, String)> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let (case, expect) = l.split_once(separator).expect("a case has its expectation");
            (case.to_string(), expect.to_string())
        })
        .collect()
}

/// tests/bad_inputs/options.txt: bad command lines.
#[test]
fn bad_command_lines_fail_cleanly() {
    let cases = read_cases(&corpus().join("options.txt"), " # expect: ");
    assert!(cases.len() >= 40, "only {} command-line cases", cases.len());
    run_parallel(&cases, |(args, expect)| {
        let dir = tempfile::tempdir().unwrap();
        let args = args.replace("{dir}", dir.path().to_str().unwrap());
        let argv: Vec<&str> = args.split_whitespace().collect();
        assert_clean_failure(&args, &raylink(&argv), &[expect.as_str()]);
        assert!(entries(dir.path()).is_empty(), "{args} left files behind");
    });
}

/// tests/bad_inputs/files: damaged or foreign cache, network and checkpoint files.
#[test]
fn bad_cache_network_and_checkpoint_files_fail_cleanly() {
    let files = corpus().join("files");
    let cases = read_cases(&files.join("expect.txt"), ": ");
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
        assert_clean_failure(name, &raylink(&argv), &[placed_name, expect.as_str()]);
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
