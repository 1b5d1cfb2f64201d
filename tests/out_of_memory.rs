//! Memory the system refuses (an address-space limit, `ulimit -v`, set in a shell that then
//! runs raylink): wherever it happens (Embree's device or build, the irradiance cache's
//! records, the network's tables, the film, the image), the run ends with exit status 1 and a
//! `raylink: error:` line, never an abort, and leaves no file behind.

mod common;

use common::stderr;
use std::os::unix::process::ExitStatusExt;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// `raylink ARGS` under an address-space limit of `kib` KiB.
fn under_limit(kib: u64, args: &[&str]) -> Output {
    under_limit_within(kib, args, Duration::from_secs(600))
        .unwrap_or_else(|| panic!("raylink {args:?} under {kib} KiB still ran after 600 s"))
}

/// [`under_limit`], or `None` if the run has not ended within `limit` (it is then killed).
fn under_limit_within(kib: u64, args: &[&str], limit: Duration) -> Option<Output> {
    let mut child = Command::new("sh")
        .args(["-c", &format!("ulimit -v {kib} && exec \"$0\" \"$@\"")])
        .arg(env!("CARGO_BIN_EXE_raylink"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    Some(child.wait_with_output().unwrap())
}

/// Memory the system refuses (here an address-space limit, `ulimit -v`, set in a shell that
/// then runs raylink, 4 GiB) is an error naming what could not be allocated and how much,
/// exit code 1, not an abort: the film of a path-traced 30000x30000 image (20 GiB), and the
/// image of a Whitted one (10 GiB). `--max-memory 1T` lets the work past raylink's own
/// estimate, which would refuse it first.
#[test]
fn allocations_the_system_refuses_are_errors_not_aborts() {
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("huge.exr");
    for (integrator, needle) in [
        ("path", "for the film of a 30000x30000 image"),
        ("whitted", "for a 30000x30000 image"),
    ] {
        let out = under_limit(
            4194304,
            &[
                "render",
                "scenes/cornell-box.toml",
                "--integrator",
                integrator,
                "--spp",
                "1",
                "--width",
                "30000",
                "--height",
                "30000",
                "--max-memory",
                "1T",
                "--quiet",
                "-o",
                out_path.to_str().unwrap(),
            ],
        );
        let err = stderr(&out);
        assert_eq!(
            out.status.code(),
            Some(1),
            "{integrator}: {err} {:?}",
            out.status
        );
        assert_eq!(err.lines().count(), 1, "{integrator}: {err}");
        assert!(
            err.starts_with("raylink: error: cannot allocate ") && err.contains("GiB "),
            "{integrator}: {err}"
        );
        assert!(
            err.contains(needle) && err.contains("out of memory"),
            "{err}"
        );
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// `raylink render` of the Cornell box with `integrator` at `size`x`size`, 4 samples per pixel,
/// to `out`, under `mib` MiB of address space; `None` if it has not ended within `limit`.
fn render_under(
    mib: u64,
    integrator: &str,
    size: u32,
    out: &std::path::Path,
    limit: Duration,
) -> Option<Output> {
    let size = size.to_string();
    under_limit_within(
        mib * 1024,
        &[
            "render",
            "scenes/cornell-box.toml",
            "--integrator",
            integrator,
            "--width",
            &size,
            "--height",
            &size,
            "--spp",
            "4",
            "--quiet",
            "-o",
            out.to_str().unwrap(),
        ],
        limit,
    )
}

/// From the least memory in which raylink starts and renders a tiny image (its libraries
/// loaded, Embree's device made) up to 400 MiB more, in steps that land in every later phase
/// (Embree's build, the irradiance cache's records, the network's tables, the film, the
/// image): each run either renders (exit 0, an image) or fails with exit 1 and its last line
/// a `raylink: error:` naming memory; none is ended by a signal (SIGABRT from Rust's
/// allocation failure or from Embree's task scheduler's uncaught exception), and a failed
/// run leaves no file, and none runs on past two minutes. (The last line: libpng prints a
/// line of its own when OpenImageIO's writer fails.)
///
/// Below the least memory, Embree's task scheduler (TBB) fails to start its threads: it
/// aborts or crashes there, and once under load it was seen to hang, so the search gives each
/// of those runs half a minute.
#[test]
fn memory_refused_in_any_phase_ends_with_an_error_not_an_abort() {
    let dir = tempfile::tempdir().unwrap();
    let tiny = dir.path().join("tiny.png");
    let renders = |mib| {
        let run = render_under(mib, "whitted", 8, &tiny, Duration::from_secs(30));
        run.is_some_and(|out| out.status.success())
    };
    let start = (400..4096)
        .step_by(20)
        .find(|&mib| renders(mib))
        .expect("a tiny render within 4 GiB");
    std::fs::remove_file(&tiny).unwrap();
    let mut failed = std::collections::BTreeSet::new();
    let mut rendered = 0;
    for integrator in ["path", "irradiance-cache", "network", "whitted"] {
        for mib in (start..=start + 400).step_by(20) {
            let out_path = dir.path().join(format!("{integrator}-{mib}.png"));
            let out = render_under(mib, integrator, 200, &out_path, Duration::from_secs(120))
                .unwrap_or_else(|| panic!("{integrator} under {mib} MiB still ran after 120 s"));
            let err = stderr(&out);
            let case = format!("{integrator} under {mib} MiB: {:?} {err}", out.status);
            assert_eq!(out.status.signal(), None, "{case}");
            match out.status.code() {
                Some(0) => {
                    assert!(out_path.exists(), "{case}");
                    rendered += 1;
                }
                Some(1) => {
                    let last = err.lines().last().unwrap_or_default();
                    assert!(last.starts_with("raylink: error: "), "{case}");
                    assert!(
                        ["memory", "uncaught", "unavailable"]
                            .iter()
                            .any(|w| last.contains(w)),
                        "{case}"
                    );
                    assert!(!out_path.exists(), "{case}");
                    failed.insert(last.chars().take(60).collect::<String>());
                }
                _ => panic!("{case}"),
            }
        }
    }
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(left.len(), rendered, "temporary files left: {left:?}");
    assert!(
        failed.len() >= 2,
        "failures in fewer than two places: {failed:?}"
    );
}
