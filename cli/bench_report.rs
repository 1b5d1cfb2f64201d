//! The bench's outputs: a Markdown report (printed, and saved as bench.md), a CSV file with
//! one row per (scene, backend, ray kind, threads), and an SVG chart.

use raylink::bench::{BenchConfig, RayKind, Row, Spread};
use raylink::Backend;
use std::fmt::Write;

pub const CSV_HEADER: &str = "scene,primitives,backend,threads,kind,rays,hits,reps,\
mrays_median,mrays_min,mrays_max,build_ms_median,build_ms_min,build_ms_max,memory_bytes";

pub fn csv(rows: &[Row], reps: usize) -> String {
    let mut out = String::from(CSV_HEADER);
    out.push('\n');
    for r in rows {
        let (m, b) = (r.mrays_per_s, r.build_ms);
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{:.4},{:.4},{:.4},{:.3},{:.3},{:.3},{}",
            r.scene,
            r.primitives,
            r.backend,
            r.threads,
            r.kind,
            r.rays,
            r.hits,
            reps,
            m.median,
            m.min,
            m.max,
            b.median,
            b.min,
            b.max,
            r.memory_bytes
        );
    }
    out
}

/// The first "model name" of /proc/cpuinfo, if there is one.
fn cpu_model() -> Option<String> {
    let info = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    info.lines()
        .find_map(|l| l.strip_prefix("model name"))
        .map(|l| l.trim_start_matches([' ', '\t', ':']).to_string())
}

fn find<'a>(
    rows: &'a [Row],
    scene: &str,
    backend: Backend,
    threads: usize,
    kind: RayKind,
) -> Option<&'a Row> {
    rows.iter().find(|r| {
        r.scene == scene && r.backend == backend && r.threads == threads && r.kind == kind
    })
}

/// A positive number with three significant digits (at least none after the point).
/// A number with three significant digits (as the tables print them).
pub fn sig(x: f64) -> String {
    let digits = if x <= 0.0 || !x.is_finite() {
        0
    } else {
        (2 - x.abs().log10().floor() as i32).max(0) as usize
    };
    format!("{x:.digits$}")
}

fn spread(s: Spread) -> String {
    format!("{} [{}–{}]", sig(s.median), sig(s.min), sig(s.max))
}

/// a / b as "1.23×", or "–" when either is missing.
fn ratio(a: Option<f64>, b: Option<f64>) -> String {
    match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => format!("{:.2}×", a / b),
        _ => "–".into(),
    }
}

/// A Markdown table header and rule: the `fixed` columns (the first left-aligned), then for
/// each group a column per backend ("{backend} {unit}") and, when both backends ran, the
/// group's ratio column.
fn table_header(fixed: &[&str], groups: &[(&str, &str)], config: &BenchConfig) -> (String, String) {
    let mut header = String::from("|");
    let mut rule = String::from("|");
    let mut column = |name: &str, right: bool| {
        let _ = write!(header, " {name} |");
        rule.push_str(if right { "---:|" } else { "---|" });
    };
    for (i, name) in fixed.iter().enumerate() {
        column(name, i > 0 && *name != "kind");
    }
    for (unit, ratio) in groups {
        for b in &config.backends {
            column(&format!("{b} {unit}"), true);
        }
        if both_backends(config) {
            column(ratio, true);
        }
    }
    (header, rule)
}

fn both_backends(config: &BenchConfig) -> bool {
    config.backends.contains(&Backend::Embree) && config.backends.contains(&Backend::Bvh)
}

/// The report: the setting, a throughput table and a build/memory table, with Embree/BVH
/// ratios when both backends ran.
pub fn markdown(rows: &[Row], config: &BenchConfig) -> String {
    let mut out = String::new();
    let embree = raylink::accel::embree_version().unwrap_or_else(|_| "unavailable".into());
    let cores = raylink::platform::cores();
    let _ = writeln!(
        out,
        "raylink {} bench: Embree {embree} against obvhs 0.4 (CWBVH), on {} ({cores} hardware \
         threads). Camera grid {}×{}; throughput is the median of {} timed runs after {} \
         warm-up runs, [min–max] over the runs; build time the median of {} builds.\n",
        raylink::VERSION,
        cpu_model().unwrap_or_else(|| "an unknown CPU".into()),
        config.width,
        config.height,
        config.reps,
        config.warmup,
        config.build_reps,
    );
    let both = both_backends(config);
    let (header, rule) = table_header(
        &["scene", "primitives", "rays", "kind", "threads"],
        &[("Mrays/s", "embree/bvh")],
        config,
    );
    let _ = writeln!(
        out,
        "Throughput (Mrays/s; ratio > 1: Embree is faster)\n\n{header}\n{rule}"
    );
    let mut disagreements = Vec::new();
    for scene in &config.scenes {
        for kind in RayKind::ALL {
            for &threads in &config.threads {
                let per: Vec<Option<&Row>> = config
                    .backends
                    .iter()
                    .map(|&b| find(rows, scene, b, threads, kind))
                    .collect();
                let Some(first) = per.iter().flatten().next() else {
                    continue;
                };
                let _ = write!(
                    out,
                    "| {scene} | {} | {} | {kind} | {threads} |",
                    first.primitives, first.rays
                );
                for r in &per {
                    let cell = r.map_or("–".into(), |r| spread(r.mrays_per_s));
                    let _ = write!(out, " {cell} |");
                }
                let median = |b| find(rows, scene, b, threads, kind).map(|r| r.mrays_per_s.median);
                if both {
                    let _ = write!(
                        out,
                        " {} |",
                        ratio(median(Backend::Embree), median(Backend::Bvh))
                    );
                }
                out.push('\n');
                let hits: Vec<u64> = per.iter().flatten().map(|r| r.hits).collect();
                let (lo, hi) = (hits.iter().min(), hits.iter().max());
                if let (Some(&lo), Some(&hi)) = (lo, hi) {
                    // Floating-point ties may flip a handful of grazing rays; more is a bug.
                    if (hi - lo) as f64 > 1e-3 * first.rays as f64 + 1.0 {
                        disagreements
                            .push(format!("{scene} {kind} ({threads} threads): hits {hits:?}"));
                    }
                }
            }
        }
    }
    out.push('\n');
    let (header, rule) = table_header(
        &["scene", "primitives", "threads"],
        &[
            ("build ms", "build embree/bvh"),
            ("MiB", "memory embree/bvh"),
        ],
        config,
    );
    let _ = writeln!(
        out,
        "Build time and memory (ratio < 1: Embree builds faster / holds less)\n\n{header}\n{rule}"
    );
    for scene in &config.scenes {
        for &threads in &config.threads {
            let per: Vec<Option<&Row>> = config
                .backends
                .iter()
                .map(|&b| find(rows, scene, b, threads, RayKind::Camera))
                .collect();
            let Some(first) = per.iter().flatten().next() else {
                continue;
            };
            let _ = write!(out, "| {scene} | {} | {threads} |", first.primitives);
            let get = |b, f: fn(&Row) -> f64| find(rows, scene, b, threads, RayKind::Camera).map(f);
            for r in &per {
                let cell = r.map_or("–".into(), |r| spread(r.build_ms));
                let _ = write!(out, " {cell} |");
            }
            if both {
                let f = |r: &Row| r.build_ms.median;
                let _ = write!(
                    out,
                    " {} |",
                    ratio(get(Backend::Embree, f), get(Backend::Bvh, f))
                );
            }
            for r in &per {
                let cell = r.map_or("–".into(), |r| sig(mib(r.memory_bytes)));
                let _ = write!(out, " {cell} |");
            }
            if both {
                let f = |r: &Row| r.memory_bytes as f64;
                let _ = write!(
                    out,
                    " {} |",
                    ratio(get(Backend::Embree, f), get(Backend::Bvh, f))
                );
            }
            out.push('\n');
        }
    }
    out.push('\n');
    if disagreements.is_empty() {
        out.push_str(
            "Hit counts agree between the backends on every row (within 0.1% of the rays).\n",
        );
    } else {
        let _ = writeln!(
            out,
            "WARNING: hit counts differ between backends by more than 0.1%: {}",
            disagreements.join("; ")
        );
    }
    out
}

fn mib(bytes: usize) -> f64 {
    bytes as f64 / (1024.0 * 1024.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_keep_three_significant_digits() {
        assert_eq!(sig(1234.4), "1234");
        assert_eq!(sig(12.345), "12.3");
        assert_eq!(sig(1.2345), "1.23");
        assert_eq!(sig(0.012345), "0.0123");
        assert_eq!(sig(0.0), "0");
    }
}
