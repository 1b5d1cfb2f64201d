//! The flux arriving at sets of surfaces of a scene, estimated by gathering and by shooting
//! (Dutré, Lafortune & Willems: ⟨L, W_e⟩ = ⟨L_e, W⟩), printed as a Markdown table:
//! `cargo run --release --example flux_agreement -- [SCENE [PATHS]]` (default
//! scenes/cornell-spheres.toml, 200000 paths). Each set is a list of shape indices; by
//! default the sets of cornell-spheres.toml's rough gold sphere, its mirror and glass
//! spheres, and its floor (lit through the glass). docs/reproductions.md's table of the
//! same sets is made by the test `dutre_lafortune_willems_fluxes_are_the_pages`.

use raylink::flux::{estimate, Estimator, Flux, FluxJob};
use raylink::{Backend, Control, Scene};
use std::path::Path;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let file = args
        .get(1)
        .map_or("scenes/cornell-spheres.toml", String::as_str);
    let paths: u64 = args.get(2).map_or(200_000, |s| {
        s.parse().unwrap_or_else(|_| {
            eprintln!("PATHS: {s} is not a count");
            std::process::exit(2)
        })
    });
    let scene = Scene::load(Path::new(file)).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(2)
    });
    let sets = [
        ("rough gold sphere", vec![0]),
        ("mirror and glass spheres", vec![1, 2]),
        ("floor (caustics through the glass)", vec![3]),
    ];
    println!(
        "| set of surfaces (flux arriving, W, red green blue) | gathering | shooting | largest \
         difference / σ |"
    );
    println!("|---|---|---|---|");
    for (name, surfaces) in sets {
        let run = |estimator| -> (Flux, f64) {
            let job = FluxJob {
                surfaces: surfaces.clone(),
                estimator,
                max_depth: 8,
                paths,
                seed: 7,
                threads: None,
                accel: Backend::Embree,
            };
            let start = Instant::now();
            let flux = estimate(&scene, &job, &Control::default()).unwrap_or_else(|e| {
                eprintln!("{e}");
                std::process::exit(1)
            });
            (flux, start.elapsed().as_secs_f64())
        };
        let (gathered, tg) = run(Estimator::Gathering);
        let (shot, ts) = run(Estimator::Shooting);
        let show = |f: &Flux, t: f64| {
            let v = f.flux.to_array();
            let e = f.standard_error.to_array();
            format!(
                "{:.4} ± {:.4}, {:.4} ± {:.4}, {:.4} ± {:.4} ({t:.1} s)",
                v[0], e[0], v[1], e[1], v[2], e[2]
            )
        };
        let sigmas = (0..3)
            .map(|c| {
                let (a, b) = (gathered.flux[c], shot.flux[c]);
                let s = gathered.standard_error[c].hypot(shot.standard_error[c]);
                (a - b).abs() / s.max(1e-30)
            })
            .fold(0.0f32, f32::max);
        println!(
            "| {name} | {} | {} | {sigmas:.2} |",
            show(&gathered, tg),
            show(&shot, ts)
        );
    }
    println!(
        "\n{paths} paths for each estimate, 8 bounces, seed 7; σ combines both standard errors."
    );
}
