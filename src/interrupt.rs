//! Interruption. The first SIGINT or SIGTERM asks the running render to stop: it finishes
//! the tile in hand, writes what it has (marked partial) and exits with 128 + the signal's
//! number. A second signal ends the process at once, with the signal's default action.
//!
//! Only `raylink render` installs the handler; the other commands keep the default action
//! (their outputs are written atomically, so being killed loses only the work in progress).

use crate::{Error, Result};
use signal_hook::consts::{SIGINT, SIGTERM};
use std::sync::atomic::{AtomicI32, Ordering};

/// The first signal received (0: none).
static SIGNAL: AtomicI32 = AtomicI32::new(0);

/// Starts listening for SIGINT and SIGTERM (on a thread of its own, so that the handler
/// itself only records the signal).
pub fn install() -> Result<()> {
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])
        .map_err(|e| Error::Options(format!("cannot install the signal handlers: {e}")))?;
    std::thread::Builder::new()
        .name("raylink-signals".into())
        .spawn(move || {
            for signal in signals.forever() {
                if SIGNAL
                    .compare_exchange(0, signal, Ordering::SeqCst, Ordering::SeqCst)
                    .is_err()
                {
                    // The second one: the user does not want to wait.
                    let _ = signal_hook::low_level::emulate_default_handler(signal);
                    std::process::exit(128 + signal);
                }
                eprintln!(
                    "\nraylink: {}: stopping after the work in hand (again to quit at once)",
                    name(signal)
                );
            }
        })
        .map_err(|e| Error::Options(format!("cannot start the signal thread: {e}")))?;
    Ok(())
}

/// Whether a stop was asked for.
pub fn requested() -> bool {
    SIGNAL.load(Ordering::Relaxed) != 0
}

/// The signal that asked for the stop.
pub fn signal() -> Option<i32> {
    match SIGNAL.load(Ordering::SeqCst) {
        0 => None,
        s => Some(s),
    }
}

/// The signal's usual name.
pub fn name(signal: i32) -> &'static str {
    match signal {
        SIGINT => "SIGINT",
        SIGTERM => "SIGTERM",
        _ => "signal",
    }
}

/// An [`Error::Interrupted`] if a stop was asked for, for work that has nothing to keep
/// (a preprocess): `stage` names it.
pub fn check(stage: &str) -> Result<()> {
    match signal() {
        None => Ok(()),
        Some(signal) => Err(Error::Interrupted {
            signal,
            detail: format!(
                "interrupted by {} during {stage}; nothing was written",
                name(signal)
            ),
        }),
    }
}
