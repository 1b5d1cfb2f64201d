//! SIGINT and SIGTERM. The first one cancels the running job through its cancel token: a
//! render keeps what it finished (written marked partial) and the process exits with
//! 128 + the signal's number. A second signal ends the process at once, with the signal's
//! default action, after removing the temporary files being written (so that an image being
//! written is neither half-written nor left as a temporary file), but not before a checkpoint
//! being saved is complete. Signals that arrive together (`timeout` signals the process and
//! then its group, so the process gets two at once) count as one.
//!
//! SIGXFSZ (a file past the size limit of `ulimit -f`) is caught and does nothing, so that the
//! write fails with `File too large` instead, reported as any failed write.
//!
//! Off Unix (Windows: Ctrl-C and Ctrl-Break arrive as SIGINT) the handler sets a flag that the
//! listening thread looks at every 20 ms, and a second signal exits with 128 + its number.

use raylink::CancelToken;
use signal_hook::consts::{SIGINT, SIGTERM};
use std::sync::atomic::{AtomicI32, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A signal this soon after the first is the same request (no one presses Ctrl-C twice
/// within it; programs that signal a process and its group do).
const SAME_REQUEST: Duration = Duration::from_millis(500);

/// The signals the process listens for, and the first one received.
#[derive(Clone)]
pub struct Signals {
    first: Arc<AtomicI32>,
    cancel: CancelToken,
}

impl Signals {
    /// Starts listening (on a thread of its own, so that the handler itself only records
    /// the signal). A first signal cancels `cancel` if `graceful`, else ends the process as
    /// the signal's default action would.
    pub fn install(cancel: CancelToken, graceful: bool) -> Result<Signals, String> {
        let mut signals =
            listen().map_err(|e| format!("cannot install the signal handlers: {e}"))?;
        let first = Arc::new(AtomicI32::new(0));
        let (seen, token) = (first.clone(), cancel.clone());
        std::thread::Builder::new()
            .name("raylink-signals".into())
            .spawn(move || {
                let mut since: Option<Instant> = None;
                for signal in std::iter::from_fn(&mut signals) {
                    let first = seen
                        .compare_exchange(0, signal, Ordering::SeqCst, Ordering::SeqCst)
                        .is_ok();
                    if !first && since.is_some_and(|t| t.elapsed() < SAME_REQUEST) {
                        continue;
                    }
                    since.get_or_insert_with(Instant::now);
                    if !first || !graceful {
                        // The second one: the user does not want to wait. No file is created
                        // or renamed while `_writes` is held.
                        let _writes = raylink::atomic_file::remove_temporaries();
                        #[cfg(unix)]
                        let _ = signal_hook::low_level::emulate_default_handler(signal);
                        std::process::exit(128 + signal);
                    }
                    token.cancel();
                    eprintln!(
                        "\nraylink: {}: stopping after the work in hand (again to quit at once)",
                        name(signal)
                    );
                }
            })
            .map_err(|e| format!("cannot start the signal thread: {e}"))?;
        Ok(Signals { first, cancel })
    }

    /// The signal that asked for the stop, if any.
    pub fn received(&self) -> Option<i32> {
        match self.first.load(Ordering::SeqCst) {
            0 => None,
            s => Some(s),
        }
    }

    pub fn cancel(&self) -> &CancelToken {
        &self.cancel
    }
}

/// The signals SIGINT and SIGTERM as they arrive, one at a time (blocking); SIGXFSZ ignored.
#[cfg(unix)]
fn listen() -> std::io::Result<impl FnMut() -> Option<i32> + Send> {
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])?;
    let ignored = Arc::new(std::sync::atomic::AtomicBool::new(false));
    signal_hook::flag::register(signal_hook::consts::SIGXFSZ, ignored)?;
    Ok(move || signals.forever().next())
}

/// The signals SIGINT and SIGTERM as they arrive, one at a time (blocking): the handler
/// records the last one and this looks every 20 ms.
#[cfg(not(unix))]
fn listen() -> std::io::Result<impl FnMut() -> Option<i32> + Send> {
    use std::sync::atomic::AtomicUsize;
    let last = Arc::new(AtomicUsize::new(0));
    for signal in [SIGINT, SIGTERM] {
        signal_hook::flag::register_usize(signal, last.clone(), signal as usize)?;
    }
    Ok(move || loop {
        match last.swap(0, Ordering::SeqCst) {
            0 => std::thread::sleep(Duration::from_millis(20)),
            signal => return Some(signal as i32),
        }
    })
}

/// The signal's usual name.
pub fn name(signal: i32) -> &'static str {
    match signal {
        SIGINT => "SIGINT",
        SIGTERM => "SIGTERM",
        _ => "signal",
    }
}
