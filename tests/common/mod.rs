//! Helpers shared by the integration tests that run the `raylink` binary.

use std::process::{Command, Output};

/// Runs the binary from the repository root.
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
