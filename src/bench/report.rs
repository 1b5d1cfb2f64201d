//! The bench's outputs: a Markdown report (printed, and saved as bench.md), a CSV file with
//! one row per (scene, backend, ray kind, threads), and an SVG chart.

use super::{BenchConfig, RayKind, Row, Spread};
use crate::accel::Backend;
use crate::{Error, Result};
use plotters::prelude::*;
use std::fmt::Write;
use std::path::Path;

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
fn sig(x: f64) -> String {
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
    let embree = crate::accel::embree::version().unwrap_or_else(|_| "unavailable".into());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let _ = writeln!(
        out,
        "raylink {} bench: Embree {embree} against obvhs 0.4 (CWBVH), on {} ({cores} hardware \
         threads). Camera grid {}×{}; throughput is the median of {} timed runs after {} \
         warm-up runs, [min–max] over the runs; build time the median of {} builds.\n",
        crate::VERSION,
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

/// Colour of a (backend, thread count) series: blues for Embree, reds for the BVH; darker for
/// more threads.
fn colour(backend: Backend, thread_index: usize) -> RGBColor {
    let dark = thread_index > 0;
    match (backend, dark) {
        (Backend::Embree, false) => RGBColor(110, 160, 230),
        (Backend::Embree, true) => RGBColor(20, 60, 160),
        (Backend::Bvh, false) => RGBColor(240, 150, 90),
        (Backend::Bvh, true) => RGBColor(170, 30, 20),
    }
}

/// One panel of the chart: its title, unit, the value plotted, which rows (a ray kind; build
/// times are the same on every kind's rows, so the camera rows), and whether the axis is
/// logarithmic.
struct Panel {
    title: &'static str,
    unit: &'static str,
    value: fn(&Row) -> Spread,
    kind: RayKind,
    log: bool,
}

/// Four panels: Mrays/s of each ray kind (linear, from zero) and build time (logarithmic), per
/// scene of the ladder, one line per (backend, threads) with min–max bars.
pub fn svg(rows: &[Row], config: &BenchConfig, path: &Path) -> Result<()> {
    draw(rows, config, path).map_err(|e| Error::io(path, std::io::Error::other(e.to_string())))
}

fn draw(
    rows: &[Row],
    config: &BenchConfig,
    path: &Path,
) -> std::result::Result<(), Box<dyn std::error::Error>> {
    let root = SVGBackend::new(path, (1400, 1000)).into_drawing_area();
    root.fill(&WHITE)?;
    let (title, body) = root.split_vertically(40);
    title.titled(
        &format!(
            "raylink bench: Embree vs obvhs CWBVH (medians of {} runs, bars: min–max)",
            config.reps
        ),
        ("sans-serif", 22),
    )?;
    let throughput = |title, kind| Panel {
        title,
        unit: "Mrays/s",
        value: |r: &Row| r.mrays_per_s,
        kind,
        log: false,
    };
    let panels = [
        throughput("camera rays", RayKind::Camera),
        throughput("shadow rays", RayKind::Shadow),
        throughput("diffuse-bounce rays", RayKind::Diffuse),
        Panel {
            title: "build time",
            unit: "ms (log scale)",
            value: |r: &Row| r.build_ms,
            kind: RayKind::Camera,
            log: true,
        },
    ];
    let scenes = &config.scenes;
    for (area, panel) in body.split_evenly((2, 2)).iter().zip(panels) {
        // Log panels plot log10 of the value on a linear axis labelled with the value.
        let y = |v: f64| if panel.log { v.max(1e-9).log10() } else { v };
        let panel_rows: Vec<&Row> = rows.iter().filter(|r| r.kind == panel.kind).collect();
        let (lo, hi) = panel_rows
            .iter()
            .map(|r| (panel.value)(r))
            .fold((f64::MAX, f64::MIN), |(lo, hi), s| {
                (lo.min(y(s.min)), hi.max(y(s.max)))
            });
        let range = match (panel.log, lo <= hi) {
            (_, false) => 0.0..1.0,
            (true, true) => lo.floor()..hi.ceil().max(lo.floor() + 1.0),
            (false, true) => 0.0..hi * 1.15,
        };
        let decades = (range.end - range.start).round() as usize + 1;
        let mut chart = ChartBuilder::on(area)
            .caption(panel.title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d((0..scenes.len() - 1).into_segmented(), range)?;
        let x_label = |v: &SegmentValue<usize>| match v {
            SegmentValue::CenterOf(i) | SegmentValue::Exact(i) => {
                scenes.get(*i).cloned().unwrap_or_default()
            }
            SegmentValue::Last => String::new(),
        };
        let y_label = |v: &f64| {
            let label = sig(if panel.log { 10f64.powf(*v) } else { *v });
            match label.contains('.') {
                true => label
                    .trim_end_matches('0')
                    .trim_end_matches('.')
                    .to_string(),
                false => label,
            }
        };
        let mut mesh = chart.configure_mesh();
        mesh.x_labels(scenes.len())
            .x_label_formatter(&x_label)
            .y_label_formatter(&y_label)
            .y_desc(panel.unit);
        if panel.log {
            mesh.y_labels(decades);
        }
        mesh.draw()?;
        for &backend in &config.backends {
            for (ti, &threads) in config.threads.iter().enumerate() {
                let c = colour(backend, ti);
                let points: Vec<(SegmentValue<usize>, Spread)> = scenes
                    .iter()
                    .enumerate()
                    .filter_map(|(i, s)| {
                        panel_rows
                            .iter()
                            .find(|r| r.scene == *s && r.backend == backend && r.threads == threads)
                            .map(|r| (SegmentValue::CenterOf(i), (panel.value)(r)))
                    })
                    .collect();
                chart
                    .draw_series(LineSeries::new(
                        points.iter().map(|(x, s)| (x.clone(), y(s.median))),
                        c.stroke_width(2),
                    ))?
                    .label(format!("{backend}, {threads} thread(s)"))
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                    });
                chart.draw_series(
                    points
                        .iter()
                        .map(|(x, s)| Circle::new((x.clone(), y(s.median)), 4, c.filled())),
                )?;
                chart.draw_series(points.iter().map(|(x, s)| {
                    PathElement::new(
                        vec![(x.clone(), y(s.min)), (x.clone(), y(s.max))],
                        c.stroke_width(2),
                    )
                }))?;
            }
        }
        chart
            .configure_series_labels()
            .position(if panel.log {
                SeriesLabelPosition::UpperLeft
            } else {
                SeriesLabelPosition::UpperRight
            })
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
    }
    root.present()?;
    Ok(())
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
