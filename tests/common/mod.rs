//! Helpers shared by the integration tests that run the `raylink` binary.

use std::process::{Command, Output};

#[allow(dead_code)] // Not every test crate runs children it watches.
pub mod process;

/// Runs the binary from the repository root.
#[allow(dead_code)] // Not every test crate runs raylink this way.
pub fn raylink(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_raylink"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the raylink binary runs")
}

pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Asserts a run failed with exit code 2 and a single `raylink: error:` line containing
/// every one of `needles`, and no panic; `case` labels the failure message.
#[allow(dead_code)] // Not every test crate checks failures.
pub fn assert_clean_failure_of(case: &str, out: &Output, needles: &[&str]) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "{case}: {err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "{case}: expected one line, got: {err}");
    assert!(lines[0].starts_with("raylink: error: "), "{case}: {err}");
    for n in needles {
        assert!(lines[0].contains(n), "{case}: {n:?} not in: {err}");
    }
    assert!(!err.contains("panicked"), "{case}: {err}");
}
