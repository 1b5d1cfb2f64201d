//! The statistics of a sequence for people: a summary in the manner of Table 2 of Jevans's
//! paper, a per-frame CSV, and a map of what each frame retraced.

use super::record::Records;
use super::renderer::FrameStats;
use super::sequence::{Placement, Report, Time};
use super::tables::BlockLayout;
use crate::accel::Update;
use crate::image::Image;
use crate::math::Rgb;
use std::fmt::Write as _;

/// The per-frame CSV.
pub fn csv_text(report: &Report) -> String {
    let mut s = String::from(
        "frame,rays,cpu_seconds,wall_seconds,pixels_retraced,blocks_retraced,changed_voxels,\
         bookkeeping_seconds,accel_update,camera_rays_kept,camera_rays_reused,full_rays,\
         full_cpu_seconds,full_wall_seconds,identical\n",
    );
    for r in &report.rows {
        let c = &r.coherent;
        let (fr, fc, fw) = r.full.map_or(Default::default(), |(rays, t)| {
            (
                rays.total().to_string(),
                format!("{:.6}", t.cpu),
                format!("{:.6}", t.wall),
            )
        });
        let update = match r.update {
            // --no-coherence: no structure is kept.
            None if r.time.wall == 0.0 => "",
            None => "built",
            Some(Update::Unchanged) => "unchanged",
            Some(Update::Refit(_)) => "refit",
            Some(Update::Rebuilt) => "rebuilt",
        };
        let _ = writeln!(
            s,
            "{},{},{:.6},{:.6},{},{},{},{:.6},{update},{},{},{fr},{fc},{fw},{}",
            r.frame,
            c.rays.total(),
            r.time.cpu,
            r.time.wall,
            c.pixels_retraced,
            c.blocks_retraced,
            c.changed_voxels,
            c.bookkeeping_seconds,
            c.camera_rays,
            c.camera_reused,
            r.identical.map_or(String::new(), |b| b.to_string()),
        );
    }
    s
}

/// A summary like Table 2 of the paper: rays and CPU time of the full ("traditional") and the
/// coherent renders, per frame and for the whole sequence.
pub fn summary(report: &Report) -> String {
    let mut s = String::new();
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { f64::NAN };
    // Only the columns measured: the full renders with --verify or --no-coherence, the
    // coherent ones unless --no-coherence.
    let full_cols = report.rows.iter().any(|r| r.full.is_some());
    let coherent_cols = report.rows.iter().any(|r| r.time.wall > 0.0);
    let both = full_cols && coherent_cols;
    let row = |label: &str, full: (u64, f64), rays: u64, time: Time, retraced: f64| {
        let mut line = format!("{label:>6}");
        if full_cols {
            line += &format!(" {:>12} {:>9.2}", full.0, full.1);
        }
        if both {
            line += " |";
        }
        if coherent_cols {
            line += &format!(" {rays:>12}");
            if both {
                line += &format!(" {:>7.4}", ratio(rays as f64, full.0 as f64));
            }
            line += &format!(" {:>9.2}", time.cpu);
            if both {
                line += &format!(" {:>7.4}", ratio(time.cpu, full.1));
            }
            line += &format!(" {retraced:>8.2}% {:>9.3}", time.wall);
        }
        line
    };
    let mut header = format!("{:>6}", "frame");
    if full_cols {
        header += &format!(" {:>12} {:>9}", "full rays", "full cpu");
    }
    if both {
        header += " |";
    }
    if coherent_cols {
        header += &format!(" {:>12}", "rays");
        if both {
            header += &format!(" {:>7}", "ratio");
        }
        header += &format!(" {:>9}", "cpu s");
        if both {
            header += &format!(" {:>7}", "ratio");
        }
        header += &format!(" {:>9} {:>9}", "retraced", "wall s");
    }
    let _ = writeln!(s, "{header}");
    let (mut cr, mut fr, mut px) = (0u64, 0u64, 0u64);
    let (mut ct, mut ft) = (Time::default(), Time::default());
    let mut all_full = !report.rows.is_empty();
    for r in &report.rows {
        let c = &r.coherent;
        cr += c.rays.total();
        ct.cpu += r.time.cpu;
        ct.wall += r.time.wall;
        px += c.pixels_retraced;
        let (frays, ftime) = r
            .full
            .map_or((0, Time::default()), |(rays, t)| (rays.total(), t));
        all_full &= r.full.is_some();
        fr += frays;
        ft.cpu += ftime.cpu;
        ft.wall += ftime.wall;
        let retraced = 100.0 * c.pixels_retraced as f64 / report.pixels_per_frame as f64;
        let line = row(
            &r.frame.to_string(),
            (frays, ftime.cpu),
            c.rays.total(),
            r.time,
            retraced,
        );
        let _ = writeln!(s, "{line}");
    }
    // Look-ahead's reading of every frame before the first is part of the sequence's cost.
    ct.cpu += report.prepare.cpu;
    ct.wall += report.prepare.wall;
    let frames = report.rows.len() as u64;
    let retraced = 100.0 * px as f64 / (report.pixels_per_frame * frames.max(1)) as f64;
    let _ = writeln!(s, "{}", row("all", (fr, ft.cpu), cr, ct, retraced));
    let all_full = all_full && coherent_cols;
    if all_full {
        let r0 = &report.rows[0];
        if let Some((_, f0)) = r0.full {
            let _ = writeln!(
                s,
                "frame-0 overhead: {:+.1}% CPU, {:+.1}% wall ({:.2} s / {:.2} s CPU)",
                100.0 * (r0.time.cpu / f0.cpu - 1.0),
                100.0 * (r0.time.wall / f0.wall - 1.0),
                r0.time.cpu,
                f0.cpu
            );
        }
        let (rf, tf) = (ratio(cr as f64, fr as f64), ratio(ct.cpu, ft.cpu));
        let pf = retraced / 100.0;
        // The paper's measure: CPU per retraced pixel (its primary rays) against a full
        // render's CPU per pixel.
        let _ = writeln!(
            s,
            "sequence: pixel fraction {pf:.4}, ray fraction {rf:.4}, CPU time fraction {tf:.4} \
             ({:.2}x the pixel fraction, {:.2}x the ray fraction), wall time fraction {:.4}",
            tf / pf,
            tf / rf,
            ratio(ct.wall, ft.wall),
        );
    }
    if !report.overhead.is_empty() {
        let median = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            let n = v.len();
            (v[(n - 1) / 2] + v[n / 2]) / 2.0
        };
        let ratios: Vec<f64> = report.overhead.iter().map(|&(c, f)| c / f).collect();
        let (lo, hi) = ratios
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &r| {
                (a.min(r), b.max(r))
            });
        let _ = writeln!(
            s,
            "frame-0 overhead, first frame rendered {} times both ways: median {:+.1}% CPU \
             ({:+.1}% to {:+.1}%; median {:.3} s coherent / {:.3} s full)",
            ratios.len(),
            100.0 * (median(ratios.clone()) - 1.0),
            100.0 * (lo - 1.0),
            100.0 * (hi - 1.0),
            median(report.overhead.iter().map(|o| o.0).collect()),
            median(report.overhead.iter().map(|o| o.1).collect()),
        );
    }
    match report.placement {
        Placement::Lookahead => {
            let _ = writeln!(
                s,
                "placement: look-ahead (every frame read first to place the grid: {:.2} s, \
                 {:.2} s CPU)",
                report.prepare.wall, report.prepare.cpu
            );
        }
        Placement::Online => {
            let _ = writeln!(
                s,
                "placement: online (frame by frame; the grid grew {} times)",
                report.regrids
            );
        }
    }
    let verified: Option<Vec<bool>> = report.rows.iter().map(|r| r.identical).collect();
    if let Some(v) = verified.filter(|v| !v.is_empty()) {
        let _ = writeln!(
            s,
            "verify: {}",
            if v.iter().all(|&b| b) {
                "every frame identical to its full render"
            } else {
                "DIFFERENCES (see above)"
            }
        );
    }
    let (lo, hi) = report.grid;
    let _ = writeln!(
        s,
        "voxel grid: {} voxels ({} keeping records) over [{:.2}, {:.2}, {:.2}]..[{:.2}, \
         {:.2}, {:.2}], {}x{} pixel blocks",
        report.voxels,
        report.active_voxels,
        lo.x,
        lo.y,
        lo.z,
        hi.x,
        hi.y,
        hi.z,
        report.blocks.0,
        report.blocks.1,
    );
    let kib = report.record_bytes as f64 / 1024.0;
    let _ = match report.records {
        Records::Tables => writeln!(s, "records: voxel tables x 2 = {kib:.1} KiB"),
        Records::Segments => writeln!(
            s,
            "records: segments, at most {} held after a frame = {kib:.1} KiB",
            report.segments
        ),
    };
    let (kept, reused) = report.rows.iter().fold((0, 0), |(k, r), row| {
        (k + row.coherent.camera_rays, r + row.coherent.camera_reused)
    });
    if kept > 0 {
        let _ = writeln!(
            s,
            "stored answers (section 3.3.3): {reused} of {kept} camera rays in retraced blocks \
             ({:.1}%) answered from the block's last trace; at most {:.1} KiB kept",
            100.0 * reused as f64 / kept as f64,
            report.camera_bytes as f64 / 1024.0
        );
    }
    let shaded: u64 = report.rows.iter().map(|r| r.coherent.samples_reused).sum();
    if shaded > 0 {
        let _ = writeln!(
            s,
            "samples not shaded again (every ray of their tree answered from the block's last \
             trace, no light changed): {shaded}"
        );
    }
    let others: u64 = report.rows.iter().map(|r| r.coherent.others_reused).sum();
    if others > 0 {
        let _ = writeln!(
            s,
            "reflection, refraction and shadow rays answered from the block's last trace: \
             {others}"
        );
    }
    s
}

/// A picture of what a coherent frame retraced (the paper's figure 4): the frame in dim grey
/// where its pixels were kept from the frame before, red over the blocks retraced because
/// something they saw changed, and blue over the whole frame when it was traced in full (the
/// first frame, a grid that grew, a camera or world change: `stats.full_reason`).
/// `blocks`: the block table's columns and rows.
pub fn retrace_map(frame: &Image, stats: &FrameStats, blocks: (u32, u32)) -> Image {
    let layout = BlockLayout::new(frame.width, frame.height, blocks.0, blocks.1);
    let grey = |p: Rgb| 0.3 * (0.2126 * p.x + 0.7152 * p.y + 0.0722 * p.z).clamp(0.0, 1.0);
    let mut map = Image::new(frame.width, frame.height);
    for (m, p) in map.pixels.iter_mut().zip(&frame.pixels) {
        *m = Rgb::splat(grey(*p));
    }
    let tint = if stats.full_reason.is_some() {
        Rgb::new(0.1, 0.3, 1.0)
    } else {
        Rgb::new(1.0, 0.15, 0.1)
    };
    for &b in &stats.blocks {
        let r = layout.rect(b);
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                let i = (y * frame.width + x) as usize;
                map.pixels[i] = Rgb::splat(grey(frame.pixels[i])) + 0.7 * tint;
            }
        }
    }
    map
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_retrace_map_marks_exactly_the_retraced_blocks() {
        let frame = Image::new(8, 6);
        let stats = FrameStats {
            blocks: vec![1, 4],
            ..FrameStats::default()
        };
        let map = retrace_map(&frame, &stats, (4, 3));
        let layout = BlockLayout::new(8, 6, 4, 3);
        for y in 0..6 {
            for x in 0..8 {
                let block = (0..layout.len())
                    .find(|&b| {
                        let r = layout.rect(b);
                        (r.x0..r.x1).contains(&x) && (r.y0..r.y1).contains(&y)
                    })
                    .unwrap();
                let red = map.pixels[(y * 8 + x) as usize].x > 0.5;
                assert_eq!(red, block == 1 || block == 4, "pixel {x},{y}");
            }
        }
        let full = FrameStats {
            full_reason: Some("first frame".into()),
            ..stats
        };
        assert!(retrace_map(&frame, &full, (4, 3)).pixels[2].z > 0.5);
    }
}
