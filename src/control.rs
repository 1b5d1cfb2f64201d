//! What the caller of a job controls: a cancel token, a memory budget and a progress sink.
//! The library keeps no process-wide state: two jobs in one process each have their own, so
//! one can be cancelled or refused memory while the other runs on untouched.

pub use crate::error::human_size;
use crate::error::{Error, Result};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// A request to stop, shared between the caller and the work it started. Cloning it gives
/// another handle on the same request.
#[derive(Clone, Debug, Default)]
pub struct CancelToken(Arc<AtomicBool>);

impl CancelToken {
    pub fn new() -> CancelToken {
        CancelToken::default()
    }

    /// Asks the work to stop: a render keeps what it finished and returns it marked
    /// partial; work with nothing to keep (parsing, a preprocess) returns
    /// [`Error::Cancelled`].
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    pub(crate) fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// [`Error::Cancelled`] naming `stage` once a stop was asked for.
    pub fn check(&self, stage: &str) -> Result<()> {
        if self.is_cancelled() {
            return Err(Error::Cancelled {
                stage: stage.to_string(),
            });
        }
        Ok(())
    }
}

/// How much memory a job may take. The large allocations (film, intersection structures,
/// network, irradiance cache, parsed meshes) are estimated before they are made and checked
/// against it, so that too big a job is a one-line error rather than an out-of-memory kill.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryBudget {
    bytes: u64,
    /// Whether the caller chose it, or it is the machine's default.
    chosen: bool,
}

impl Default for MemoryBudget {
    /// 3/4 of the physical memory, or of the cgroup (container) limit when that is lower.
    fn default() -> Self {
        MemoryBudget {
            bytes: machine_default(),
            chosen: false,
        }
    }
}

impl MemoryBudget {
    /// A budget of `bytes`.
    pub fn bytes(bytes: u64) -> MemoryBudget {
        MemoryBudget {
            bytes,
            chosen: true,
        }
    }

    pub fn limit(&self) -> u64 {
        self.bytes
    }

    /// Whether the budget is the machine's default rather than one the caller chose.
    pub fn is_default(&self) -> bool {
        !self.chosen
    }

    /// [`Error::Memory`] if `what` would need more than the budget.
    pub fn check(&self, what: &str, bytes: u64) -> Result<()> {
        if bytes <= self.bytes {
            return Ok(());
        }
        Err(Error::Memory {
            what: what.to_string(),
            needed: bytes,
            limit: self.bytes,
            default_limit: !self.chosen,
        })
    }
}

fn machine_default() -> u64 {
    let physical = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| {
            let line = t.lines().find(|l| l.starts_with("MemTotal:"))?;
            let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
            Some(kib * 1024)
        })
        .unwrap_or(u64::MAX / 2);
    let cgroup = std::fs::read_to_string("/sys/fs/cgroup/memory.max")
        .ok()
        .and_then(|t| t.trim().parse::<u64>().ok())
        .unwrap_or(u64::MAX);
    physical.min(cgroup) / 4 * 3
}

/// Where a job reports what it is doing. Every method has an empty default, so a sink
/// implements only what it shows. Calls come from the job's worker threads too.
pub trait Progress: Send + Sync {
    /// A phase starts (`"parse"`, `"overture"`, `"preprocess"`, `"render"`, ...): `total`
    /// units of `unit` if known.
    fn begin(&self, _phase: &str, _total: Option<u64>, _unit: &str) {}
    /// `units` more of the phase in hand are done.
    fn advance(&self, _units: u64) {}
    /// Where the phase in hand stands, in a few words ("unshot 3.1e-4 of emitted").
    fn status(&self, _text: &str) {}
    /// The phase in hand ended after `seconds`; `summary` says what it did, one line.
    fn end(&self, _phase: &str, _seconds: f64, _summary: &str) {}
    /// Something worth telling a person, one line (what was loaded, what was skipped).
    fn note(&self, _line: &str) {}
    /// What the job replaced, ignored or could not do as asked, one line.
    fn warn(&self, _line: &str) {}
}

/// A sink that shows nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Progress for Silent {}

/// The controls of a job: passed to every long phase.
#[derive(Clone)]
pub struct Control {
    pub cancel: CancelToken,
    pub budget: MemoryBudget,
    pub progress: Arc<dyn Progress>,
}

impl Default for Control {
    fn default() -> Self {
        Control {
            cancel: CancelToken::new(),
            budget: MemoryBudget::default(),
            progress: Arc::new(Silent),
        }
    }
}

impl std::fmt::Debug for Control {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Control")
            .field("cancel", &self.cancel)
            .field("budget", &self.budget)
            .finish_non_exhaustive()
    }
}

impl Control {
    /// Controls with this cancel token, the default budget and no progress.
    pub fn with_cancel(cancel: CancelToken) -> Control {
        Control {
            cancel,
            ..Control::default()
        }
    }

    /// These controls with no progress: for work inside a phase whose progress the caller
    /// reports itself (the renders of an animation's frames, say).
    pub(crate) fn silenced(&self) -> Control {
        Control {
            progress: Arc::new(Silent),
            ..self.clone()
        }
    }

    /// Starts reporting a phase; [`Phase::end`] closes it with its time.
    pub fn phase(&self, name: &'static str, total: Option<u64>, unit: &str) -> Phase<'_> {
        self.progress.begin(name, total, unit);
        Phase {
            control: self,
            name,
            start: Instant::now(),
        }
    }

    pub fn note(&self, line: &str) {
        self.progress.note(line);
    }

    pub fn warn(&self, line: &str) {
        self.progress.warn(line);
    }
}

/// A phase being reported (see [`Control::phase`]).
pub struct Phase<'a> {
    control: &'a Control,
    name: &'static str,
    start: Instant,
}

impl Phase<'_> {
    pub fn advance(&self, units: u64) {
        self.control.progress.advance(units);
    }

    pub fn status(&self, text: &str) {
        self.control.progress.status(text);
    }

    pub fn seconds(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// Ends the phase with a one-line summary.
    pub fn end(self, summary: &str) {
        self.control
            .progress
            .end(self.name, self.start.elapsed().as_secs_f64(), summary);
    }
}

/// Parses a size: bytes, or a number with a K, M, G or T suffix (powers of 1024; an optional
/// trailing B or iB is accepted).
pub fn parse_size(text: &str) -> std::result::Result<u64, String> {
    let t = text.trim();
    let t = t
        .strip_suffix("iB")
        .or_else(|| t.strip_suffix('B'))
        .unwrap_or(t);
    let (digits, unit) = match t.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => (&t[..i], c.to_ascii_uppercase()),
        _ => (t, ' '),
    };
    let scale: u64 = match unit {
        ' ' => 1,
        'K' => 1 << 10,
        'M' => 1 << 20,
        'G' => 1 << 30,
        'T' => 1 << 40,
        _ => {
            return Err(format!(
                "unknown size unit in \"{text}\" (use K, M, G or T)"
            ))
        }
    };
    let n: f64 = digits
        .trim()
        .parse()
        .map_err(|_| format!("\"{text}\" is not a size (e.g. 512M, 8G)"))?;
    let bytes = n * scale as f64;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < 2f64.powi(63)) {
        return Err(format!("\"{text}\" is not a usable memory size"));
    }
    Ok(bytes as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_size("4096"), Ok(4096));
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("1.5G"), Ok(3 << 29));
        assert_eq!(parse_size("2GiB"), Ok(2 << 30));
        assert_eq!(parse_size("8k"), Ok(8 << 10));
        for bad in ["", "G", "-1G", "12Q", "NaN", "1e30T", "0"] {
            assert!(parse_size(bad).is_err(), "{bad:?} was accepted");
        }
    }

    #[test]
    fn human_sizes() {
        assert_eq!(human_size(512), "512 bytes");
        assert_eq!(human_size(3 << 29), "1.5 GiB");
    }

    #[test]
    fn the_default_budget_is_below_physical_memory_and_nonzero() {
        let b = MemoryBudget::default();
        assert!(b.limit() > 1 << 20 && b.is_default(), "{b:?}");
    }

    #[test]
    fn budgets_and_tokens_are_per_instance() {
        let (a, b) = (CancelToken::new(), CancelToken::new());
        let a2 = a.clone();
        a2.cancel();
        assert!(a.is_cancelled() && !b.is_cancelled());
        assert!(matches!(a.check("x"), Err(Error::Cancelled { .. })));
        let small = MemoryBudget::bytes(1000);
        assert!(small.check("a film", 1001).is_err());
        assert!(small.check("a film", 1000).is_ok());
        assert!(MemoryBudget::bytes(1 << 40).check("a film", 1001).is_ok());
    }
}
