//! Memory limits. The large allocations (the film, the intersection structures, the
//! illumination network, the irradiance cache) are estimated before they are made and
//! checked against a limit, so that too big a job is a one-line error saying how much it
//! needed rather than an out-of-memory kill. The limit is `--max-memory`, else 3/4 of the
//! physical memory (or of the cgroup's limit, if lower).

use crate::{Error, Result};
use std::sync::atomic::{AtomicU64, Ordering};

/// The limit set by [`set_limit`] (0: the default).
static LIMIT: AtomicU64 = AtomicU64::new(0);

/// Sets the process's limit in bytes.
pub fn set_limit(bytes: u64) {
    LIMIT.store(bytes, Ordering::Relaxed);
}

/// The limit in bytes, and whether it is the default.
pub fn limit() -> (u64, bool) {
    match LIMIT.load(Ordering::Relaxed) {
        0 => (default_limit(), true),
        n => (n, false),
    }
}

/// 3/4 of the physical memory, or of the cgroup (container) limit when that is lower.
fn default_limit() -> u64 {
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

/// Sets the limit from a `--max-memory` value, if one was given (an options error naming
/// the option if it does not parse).
pub fn set_limit_option(size: Option<&str>) -> Result<()> {
    if let Some(size) = size {
        let bytes = parse_size(size).map_err(|e| Error::Options(format!("--max-memory: {e}")))?;
        set_limit(bytes);
    }
    Ok(())
}

/// An error if `what` would need more than the limit.
pub fn check(what: &str, bytes: u64) -> Result<()> {
    let (limit, default) = limit();
    if bytes <= limit {
        return Ok(());
    }
    Err(Error::Memory(format!(
        "{what} would need {} of memory, more than the limit of {}{}",
        human(bytes),
        human(limit),
        if default {
            " (3/4 of the physical memory; raise it with --max-memory)"
        } else {
            " set by --max-memory"
        }
    )))
}

/// Parses a size: bytes, or a number with a K, M, G or T suffix (powers of 1024; an optional
/// trailing B or iB is accepted).
pub fn parse_size(text: &str) -> Result<u64, String> {
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

/// A size for people: "1.5 GiB".
pub fn human(bytes: u64) -> String {
    let units = ["bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < units.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} bytes")
    } else {
        format!("{v:.1} {}", units[u])
    }
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
        assert_eq!(human(512), "512 bytes");
        assert_eq!(human(3 << 29), "1.5 GiB");
    }

    #[test]
    fn the_default_limit_is_below_physical_memory_and_nonzero() {
        let l = default_limit();
        assert!(l > 1 << 20, "{l}");
    }
}
