//! `raylink bench --network`: illumination networks (Buckalew & Fussell 1989) on the office
//! scene at network sizes a factor apart: patches, links, line-patch intersections, memory,
//! the preprocess with the scan-conversion and the Embree builders side by side, the
//! distribution, the render, and relighting against a full rebuild, all in one run.
//!
//! Each repetition runs, back to back: a full rebuild (scan preprocess + distribution +
//! render), a relight of light strengths (network file prefix + light basis superposition +
//! render), a relight of reflectances (the carpet recoloured: whole network file +
//! distribution started from the stored light basis + render; and, for comparison, the same
//! distribution started cold), the same recolouring from the carpet's reflectance series
//! (network file prefix + the series' weighted sum + render) and, for the first `build_reps`
//! repetitions, the Embree preprocess. Interleaving them makes a change
//! of the machine's load hit them alike, so ratios within a run stay fair. Numbers are
//! medians with [min–max] over the repetitions.
//!
//! The machine may be shared: next to wall-clock rates the report gives the preprocess's rate
//! per CPU-second of the process times the thread count (what the threads would reach if they
//! had their cores to themselves; it assumes they scale perfectly).

use super::Spread;
use crate::accel::{self, Backend};
use crate::control::Control;
use crate::error::{Error, Result};
use crate::integrators::illumination_network::distribute::{
    distribute, DistributeOptions, Run, Solution,
};
use crate::integrators::illumination_network::relight::LightBasis;
use crate::integrators::illumination_network::render::{NetworkRenderer, Tables};
use crate::integrators::illumination_network::{file, Builder, Network, NetworkParams};
use crate::math::Rgb;
use crate::render::pixels::{render_pixels, PixelView};
use crate::render::{PixelSampling, RenderStats, Tile};
use crate::scene::Scene;
use crate::transport::Context;
use crate::transport::View;
use std::fmt::Write;
use std::path::PathBuf;
use std::time::Instant;

/// What to measure.
#[derive(Clone, Debug)]
pub struct NetworkBench {
    pub scene: PathBuf,
    pub slopes: u32,
    /// Intercept steps (patch size = step), one network each.
    pub steps: Vec<f32>,
    pub width: u32,
    pub height: u32,
    pub reps: usize,
    pub embree_reps: usize,
    pub seed: u64,
    /// Where the network files go.
    pub dir: PathBuf,
}

/// One network's measurements (seconds unless named otherwise).
#[derive(Clone, Debug, Default)]
pub struct NetworkRow {
    pub step: f32,
    pub polygons: usize,
    pub patches: u32,
    pub nodes: usize,
    pub slots: usize,
    pub link_ends: u64,
    pub intersections: u64,
    pub rays: u64,
    pub memory_bytes: usize,
    pub file_bytes: u64,
    pub basis_bytes: u64,
    pub basis_lights: usize,
    pub sweeps: u32,
    pub scan: Spread,
    pub scan_lines: Spread,
    pub scan_assembly: Spread,
    /// Intersections per CPU-second of the process, times the thread count.
    pub scan_cpu_rate: Spread,
    pub embree: Spread,
    pub distribution: Spread,
    pub render: Spread,
    pub rebuild: Spread,
    pub relight_strengths: Spread,
    /// The network work alone, render excluded: preprocess + distribution, and prefix load +
    /// superposition.
    pub rebuild_network: Spread,
    pub relight_network: Spread,
    pub relight_reflectances: Spread,
    /// The relight's distribution, from the basis, and a cold one of the same scene.
    pub warm_distribution: Spread,
    pub cold_distribution: Spread,
    pub warm_sweeps: u32,
    pub cold_sweeps: u32,
    pub load_prefix: Spread,
    pub load_all: Spread,
    pub basis_seconds: f64,
    /// The carpet's reflectance series: a relight from it (prefix + sum + render) and its
    /// prefix load; computing it once, its terms, and what it adds to the file.
    pub relight_series: Spread,
    pub load_series_prefix: Spread,
    pub series_seconds: f64,
    pub series_terms: usize,
    pub series_bytes: u64,
}

fn timed<T>(f: impl FnOnce() -> Result<T>) -> Result<(T, f64)> {
    let start = Instant::now();
    let v = f()?;
    Ok((v, start.elapsed().as_secs_f64()))
}

/// Renders a view of a distributed network.
fn render_view(
    ctx: &Context,
    net: &Network,
    sol: &Solution,
    view: &PixelView,
) -> Result<RenderStats> {
    let tables = Tables::new(net, sol, false);
    let renderer = NetworkRenderer {
        net,
        solution: sol,
        hybrid: false,
        tables: Some(&tables),
    };
    let whole = Tile::whole(view.view.width, view.view.height);
    Ok(render_pixels(ctx, &renderer, view, &whole, &Control::default())?.1)
}

/// Measures every network of the bench.
pub fn measure(bench: &NetworkBench, progress: &mut dyn FnMut(&str)) -> Result<Vec<NetworkRow>> {
    let scene = Scene::load(&bench.scene)?;
    let accel = accel::build(&scene, Backend::Embree, &Default::default())?;
    let ctx = Context::new(&scene, accel.as_ref());
    let threads = rayon::current_num_threads();
    let view = PixelView {
        view: View {
            seed: bench.seed,
            ..View::new(bench.width, bench.height)
        },
        sampling: PixelSampling::Uniform { n: 1 },
    };
    let options = DistributeOptions::default();
    let emission: Vec<Rgb> = scene.materials.iter().map(|m| m.emission).collect();
    // The reflectance relight's edit: another carpet.
    let mut recoloured = scene.clone();
    let carpet = recoloured
        .materials
        .iter_mut()
        .find(|m| m.name == "carpet")
        .ok_or_else(|| Error::input(&bench.scene, "the bench scene has no material \"carpet\""))?;
    let Some(colour) = carpet.diffuse_mut() else {
        return Err(Error::input(
            &bench.scene,
            "the bench scene's \"carpet\" has no diffuse colour",
        ));
    };
    *colour = crate::scene::Texture::Constant(Rgb::new(0.35, 0.3, 0.45));
    let recoloured_ctx = Context::new(&recoloured, accel.as_ref());
    std::fs::create_dir_all(&bench.dir).map_err(|e| Error::io(&bench.dir, e))?;
    let mut rows = Vec::new();
    for &step in &bench.steps {
        let params = NetworkParams {
            slopes: bench.slopes,
            step,
            patch_size: step,
            jitter: 1.0,
            seed: bench.seed,
        };
        let path = bench.dir.join(format!("network-{step}.net"));
        // The same network with the carpet's reflectance series beside the light basis.
        let series_path = bench.dir.join(format!("network-{step}-series.net"));
        let bad = |e: String| Error::input(&bench.scene, e);
        let mut row = NetworkRow {
            step,
            ..NetworkRow::default()
        };
        let mut t: [Vec<f64>; 18] = Default::default();
        for rep in 0..bench.reps {
            progress(&format!("step {step}, repetition {}: rebuild", rep + 1));
            // Full rebuild: scan preprocess + distribution + render.
            let start = Instant::now();
            let cpu = super::cpu_seconds();
            let net = Network::build(&scene, &ctx, params, Builder::Scan).map_err(bad)?;
            let cpu = super::cpu_seconds() - cpu;
            let sol = distribute(&net, &scene, &options);
            t[12].push(start.elapsed().as_secs_f64());
            let rs = render_view(&ctx, &net, &sol, &view)?;
            t[0].push(start.elapsed().as_secs_f64());
            t[1].push(net.stats.seconds);
            t[2].push(net.stats.link_seconds);
            t[3].push(net.stats.assemble_seconds);
            if cpu > 0.0 {
                t[4].push(net.stats.intersections as f64 / (cpu / threads as f64));
            }
            t[5].push(sol.stats.seconds);
            t[6].push(rs.seconds);
            if rep == 0 {
                row.polygons = net.patches.polygons.len();
                row.patches = net.patches.cells;
                row.nodes = net.nodes();
                row.slots = net.slots();
                row.link_ends = net.stats.link_ends;
                row.intersections = net.stats.intersections;
                row.memory_bytes = net.memory();
                row.sweeps = sol.stats.sweeps;
                file::save(&path, &net, &scene, None)?;
                row.file_bytes = std::fs::metadata(&path).map_or(0, |m| m.len());
                progress(&format!("step {step}: light basis"));
                let (basis, s) = timed(|| {
                    let b = LightBasis::compute(&net, &scene, &emission, &options, Run::now());
                    file::save(&path, &net, &scene, Some(&b))?;
                    Ok(b)
                })?;
                row.basis_seconds = s;
                row.basis_lights = basis.lights.len();
                row.basis_bytes = std::fs::metadata(&path).map_or(0, |m| m.len()) - row.file_bytes;
                progress(&format!("step {step}: reflectance series of the carpet"));
                let (basis, s) = timed(|| {
                    let mut b = basis;
                    b.add_series(&net, &scene, (&options, Run::now()), "carpet")
                        .map_err(bad)?;
                    file::save(&series_path, &net, &scene, Some(&b))?;
                    Ok(b)
                })?;
                row.series_seconds = s;
                row.series_terms = basis.series[0].terms.len();
                row.series_bytes = std::fs::metadata(&series_path).map_or(0, |m| m.len())
                    - row.file_bytes
                    - row.basis_bytes;
            }
            drop(sol);
            drop(net);

            progress(&format!("step {step}, repetition {}: relight", rep + 1));
            // Light strengths: the file's prefix and its basis, no distribution.
            let relit = DistributeOptions {
                light_scale: 2.0,
                ..options
            };
            let start = Instant::now();
            let ((prefix, basis), load) =
                timed(|| file::load_prefix(&path, &scene, Some(&params)))?;
            let basis = basis.ok_or_else(|| bad("the light basis was not stored".into()))?;
            let sol = basis
                .superpose(&prefix, &scene, &emission, &relit)
                .map_err(bad)?;
            t[13].push(start.elapsed().as_secs_f64());
            render_view(&ctx, &prefix, &sol, &view)?;
            t[7].push(start.elapsed().as_secs_f64());
            t[8].push(load);
            drop((prefix, sol));

            // Reflectances (the carpet recoloured): the whole file and a distribution that
            // starts from the basis stored for the old carpet (`raylink relight`'s way).
            let start = Instant::now();
            let ((net, basis), load) = timed(|| file::load_all(&path, &recoloured, Some(&params)))?;
            let basis = basis.ok_or_else(|| bad("the light basis was not stored".into()))?;
            let sol = basis.redistribute(&net, &recoloured, &emission, &relit, Run::now());
            render_view(&recoloured_ctx, &net, &sol, &view)?;
            t[9].push(start.elapsed().as_secs_f64());
            t[10].push(load);
            t[14].push(sol.stats.seconds);
            row.warm_sweeps = sol.stats.sweeps;
            drop(sol);
            // The same distribution started cold, for comparison.
            let sol = distribute(&net, &recoloured, &relit);
            t[15].push(sol.stats.seconds);
            row.cold_sweeps = sol.stats.sweeps;
            drop((net, sol));

            // Reflectances from the carpet's series: the file's prefix and a weighted sum.
            let start = Instant::now();
            let ((prefix, basis), load) =
                timed(|| file::load_prefix(&series_path, &recoloured, Some(&params)))?;
            let basis = basis.ok_or_else(|| bad("the light basis was not stored".into()))?;
            let (sol, _) = basis
                .relit_from_series(&prefix, &recoloured, &emission, &relit)
                .map_err(bad)?;
            render_view(&recoloured_ctx, &prefix, &sol, &view)?;
            t[16].push(start.elapsed().as_secs_f64());
            t[17].push(load);
            drop((prefix, sol));

            if rep < bench.embree_reps {
                progress(&format!("step {step}, repetition {}: Embree", rep + 1));
                let net = Network::build(&scene, &ctx, params, Builder::Embree).map_err(bad)?;
                t[11].push(net.stats.seconds);
                row.rays = net.stats.rays;
            }
        }
        let s = |v: &Vec<f64>| {
            if v.is_empty() {
                Spread::default()
            } else {
                Spread::of(v)
            }
        };
        row.rebuild = s(&t[0]);
        row.scan = s(&t[1]);
        row.scan_lines = s(&t[2]);
        row.scan_assembly = s(&t[3]);
        row.scan_cpu_rate = s(&t[4]);
        row.distribution = s(&t[5]);
        row.render = s(&t[6]);
        row.relight_strengths = s(&t[7]);
        row.rebuild_network = s(&t[12]);
        row.relight_network = s(&t[13]);
        row.load_prefix = s(&t[8]);
        row.relight_reflectances = s(&t[9]);
        row.load_all = s(&t[10]);
        row.warm_distribution = s(&t[14]);
        row.cold_distribution = s(&t[15]);
        row.embree = s(&t[11]);
        row.relight_series = s(&t[16]);
        row.load_series_prefix = s(&t[17]);
        for p in [&path, &series_path] {
            std::fs::remove_file(p).map_err(|e| Error::io(p, e))?;
        }
        progress(&format!(
            "step {step}: rebuild {:.3} s, relight {:.3} s ({:.1}×)",
            row.rebuild.median,
            row.relight_strengths.median,
            row.rebuild.median / row.relight_strengths.median
        ));
        rows.push(row);
    }
    Ok(rows)
}

fn sec(s: Spread) -> String {
    format!("{:.3} [{:.3}–{:.3}]", s.median, s.min, s.max)
}

/// The report: one column per network.
pub fn markdown(rows: &[NetworkRow], bench: &NetworkBench) -> String {
    let mut out = String::new();
    let threads = rayon::current_num_threads();
    let _ = writeln!(
        out,
        "raylink {} bench --network: {}, --slopes {}, render {}×{} at 1 sample per pixel, {} \
         threads; seconds are medians [min–max] of {} repetitions (Embree builder: {}).\n",
        crate::VERSION,
        bench.scene.display(),
        bench.slopes,
        bench.width,
        bench.height,
        threads,
        bench.reps,
        bench.embree_reps,
    );
    let mut header = String::from("| |");
    let mut rule = String::from("|---|");
    for r in rows {
        let _ = write!(header, " h = {} |", r.step);
        rule.push_str("---:|");
    }
    let _ = writeln!(out, "{header}\n{rule}");
    let mut line = |name: &str, f: &dyn Fn(&NetworkRow) -> String| {
        let _ = write!(out, "| {name} |");
        for r in rows {
            let _ = write!(out, " {} |", f(r));
        }
        out.push('\n');
    };
    line("polygons / patches / nodes", &|r| {
        format!("{} / {} / {}", r.polygons, r.patches, r.nodes)
    });
    line("links (per node)", &|r| {
        format!(
            "{:.2} M ({:.0})",
            r.link_ends as f64 / 2e6,
            r.link_ends as f64 / r.nodes.max(1) as f64
        )
    });
    line("line-patch intersections", &|r| {
        format!("{:.2} M", r.intersections as f64 / 1e6)
    });
    line("network memory / file", &|r| {
        format!(
            "{:.1} MB / {:.1} MB",
            r.memory_bytes as f64 / 1e6,
            r.file_bytes as f64 / 1e6
        )
    });
    line("preprocess, scan conversion (s)", &|r| sec(r.scan));
    line("… lines / assembly (s)", &|r| {
        format!("{:.3} / {:.3}", r.scan_lines.median, r.scan_assembly.median)
    });
    line("… M intersections/s (wall)", &|r| {
        format!(
            "{:.1}",
            r.intersections as f64 / r.scan.median.max(1e-9) / 1e6
        )
    });
    line("… M intersections/s per CPU-second × threads", &|r| {
        format!("{:.1}", r.scan_cpu_rate.median / 1e6)
    });
    // Embree rows only where it ran (--build-reps 0 leaves it out).
    let ran = |r: &NetworkRow| r.embree.median > 0.0;
    line("preprocess, Embree casting (s)", &|r| {
        if ran(r) {
            sec(r.embree)
        } else {
            "–".into()
        }
    });
    line("… M intersections/s; closest-hit queries", &|r| {
        if ran(r) {
            format!(
                "{:.1}; {:.1} M",
                r.intersections as f64 / r.embree.median / 1e6,
                r.rays as f64 / 1e6
            )
        } else {
            "–".into()
        }
    });
    line("… Embree / scan time", &|r| {
        if ran(r) {
            format!("{:.1}×", r.embree.median / r.scan.median.max(1e-9))
        } else {
            "–".into()
        }
    });
    line("distribution (s)", &|r| {
        format!("{} ({} sweeps)", sec(r.distribution), r.sweeps)
    });
    line("render (s)", &|r| sec(r.render));
    line(
        "**full rebuild**: preprocess + distribution + render (s)",
        &|r| sec(r.rebuild),
    );
    line("**relight, light strengths** (basis; s)", &|r| {
        sec(r.relight_strengths)
    });
    line("… of which: file prefix load (s)", &|r| sec(r.load_prefix));
    line("… rebuild / relight", &|r| {
        format!(
            "**{:.1}×**",
            r.rebuild.median / r.relight_strengths.median.max(1e-9)
        )
    });
    line(
        "… network work alone, render excluded: rebuild / relight (s)",
        &|r| {
            format!(
                "{:.3} / {:.4}: **{:.0}×**",
                r.rebuild_network.median,
                r.relight_network.median,
                r.rebuild_network.median / r.relight_network.median.max(1e-9)
            )
        },
    );
    line(
        "**relight, reflectances**: carpet recoloured (load + distribution from the basis + render; s)",
        &|r| sec(r.relight_reflectances),
    );
    line("… of which: whole file load (s)", &|r| sec(r.load_all));
    line("… of which: distribution from the basis (s)", &|r| {
        format!("{} ({} sweeps)", sec(r.warm_distribution), r.warm_sweeps)
    });
    line("… the same distribution started cold (s)", &|r| {
        format!("{} ({} sweeps)", sec(r.cold_distribution), r.cold_sweeps)
    });
    line("… rebuild / relight", &|r| {
        format!(
            "{:.1}×",
            r.rebuild.median / r.relight_reflectances.median.max(1e-9)
        )
    });
    line(
        "**relight, reflectances from a series**: the same carpet (file prefix + the carpet's series summed + render; s)",
        &|r| sec(r.relight_series),
    );
    line("… of which: file prefix load (s)", &|r| {
        sec(r.load_series_prefix)
    });
    line("… rebuild / relight", &|r| {
        format!(
            "**{:.1}×**",
            r.rebuild.median / r.relight_series.median.max(1e-9)
        )
    });
    line("light basis, once (distributions + save; s)", &|r| {
        format!(
            "{:.3} ({} emissive materials, {:.1} MB)",
            r.basis_seconds,
            r.basis_lights,
            r.basis_bytes as f64 / 1e6
        )
    });
    line(
        "the carpet's reflectance series, once (distributions + save; s)",
        &|r| {
            format!(
                "{:.3} ({} terms, {:.1} MB)",
                r.series_seconds,
                r.series_terms,
                r.series_bytes as f64 / 1e6
            )
        },
    );
    out
}
