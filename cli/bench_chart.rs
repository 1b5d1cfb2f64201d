//! `raylink bench`'s chart: an SVG of four panels (plotters' SVG backend, so that no font
//! or image library is needed).

use crate::bench_report::sig;
use plotters::prelude::*;
use raylink::bench::{BenchConfig, RayKind, Row, Spread};
use raylink::Backend;
use std::path::Path;

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
/// Draws the chart and writes it to `path` whole (through a temporary file), or not at all.
pub fn svg(rows: &[Row], config: &BenchConfig, path: &Path) -> raylink::Result<()> {
    let mut text = String::new();
    draw(rows, config, &mut text)
        .map_err(|e| raylink::Error::io(path, std::io::Error::other(e.to_string())))?;
    raylink::atomic_file::write(path, text.as_bytes())
}

fn draw(
    rows: &[Row],
    config: &BenchConfig,
    text: &mut String,
) -> std::result::Result<(), Box<dyn std::error::Error>> {
    let root = SVGBackend::with_string(text, (1400, 1000)).into_drawing_area();
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
