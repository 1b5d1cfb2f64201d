//! How much the command line prints on stderr (`--log-level`, `--verbose`): errors always;
//! warnings from `warn`; progress bars, notes and summary lines from `info` (the default);
//! what was read and written from `debug`.

use std::sync::atomic::{AtomicU8, Ordering};

/// A level of `--log-level`, each printing what the ones before it print.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, clap::ValueEnum)]
pub enum Level {
    /// Errors only.
    Error,
    /// Errors and warnings.
    Warn,
    /// Also progress bars, notes and summary lines.
    Info,
    /// Also what was read and written.
    Debug,
}

static LEVEL: AtomicU8 = AtomicU8::new(Level::Info as u8);

/// Sets the level for the run.
pub fn set(level: Level) {
    LEVEL.store(level as u8, Ordering::Relaxed);
}

/// Whether lines of `level` are printed.
pub fn enabled(level: Level) -> bool {
    level as u8 <= LEVEL.load(Ordering::Relaxed)
}

/// Whether info lines are printed for a command given `--quiet` or not.
pub fn info(quiet: bool) -> bool {
    !quiet && enabled(Level::Info)
}

/// Prints a debug line, `raylink: debug: ...`, at `--log-level debug`.
pub fn debug(line: impl FnOnce() -> String) {
    if enabled(Level::Debug) {
        eprintln!("raylink: debug: {}", line());
    }
}
