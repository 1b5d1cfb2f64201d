//! Vertex connection and merging against independent estimators: its image mean converges
//! to bidirectional path tracing's on the Cornell box and on the box with glossy, mirror
//! and glass spheres; its merges' bias shrinks with the radius; its image does not depend
//! on the thread count, and a render stopped between or in the middle of iterations
//! resumes (through a checkpoint file) to the same bits; bad settings are refused, naming
//! the setting.

use raylink::{
    checkpoint, Control, Film, Image, Job, RenderStats, Renderer, Scene, Settings, Shown,
    Technique, TechniqueKind, Watch,
};
use std::path::Path;
use std::sync::Arc;

#[path = "common/render.rs"]
mod render;
use render::{mean, mean_error};
use std::time::Duration;

fn scene(name: &str) -> Arc<Scene> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    Arc::new(Scene::load(&path).unwrap())
}

fn job(scene: &Arc<Scene>, settings: &Settings, size: u32, seed: u64, threads: usize) -> Job {
    Job {
        width: size,
        height: size,
        seed,
        threads: Some(threads),
        ..Job::new(scene, Technique::create(settings).unwrap())
    }
}

/// `scene` rendered at `size`² with `settings`, seed and threads as given.
fn render(scene: &Arc<Scene>, settings: &Settings, size: u32, seed: u64, threads: usize) -> Image {
    render_job(scene, job(scene, settings, size, seed, threads)).0
}

/// The image of `job` and the rays it traced.
fn render_job(scene: &Arc<Scene>, job: Job) -> (Image, u64) {
    let control = Control::default();
    let rendered = Renderer::new(scene.clone(), job, &control)
        .unwrap()
        .render(&control)
        .unwrap();
    assert!(!rendered.is_partial());
    (rendered.image, rendered.stats.rays.total())
}

fn technique(kind: TechniqueKind, max_depth: u32, spp: u32, radius: Option<f32>) -> Settings {
    Settings {
        integrator: Some(kind),
        spp: Some(spp),
        max_depth: Some(max_depth),
        sppm_radius: radius,
        ..Settings::default()
    }
}

/// The RMS difference of the means of 8x8 blocks, over the reference's mean.
fn block_error(a: &Image, reference: &Image) -> f64 {
    let (w, h) = (a.width as usize, a.height as usize);
    let block = |img: &Image, bx: usize, by: usize, c: usize| -> f64 {
        let mut sum = 0.0;
        for y in by * 8..by * 8 + 8 {
            for x in bx * 8..bx * 8 + 8 {
                sum += img.pixels[y * w + x][c] as f64;
            }
        }
        sum / 64.0
    };
    let (mut sum, mut n) = (0.0, 0.0);
    for by in 0..h / 8 {
        for bx in 0..w / 8 {
            for c in 0..3 {
                sum += (block(a, bx, by, c) - block(reference, bx, by, c)).powi(2);
                n += 1.0;
            }
        }
    }
    let r = mean(reference);
    (sum / n).sqrt() / ((r[0] + r[1] + r[2]) / 3.0)
}

/// Every surface diffuse: the image means agree within 1% per channel (measured 0.1%).
#[test]
fn vcm_matches_bdpt_on_the_cornell_box() {
    let s = scene("cornell-box.toml");
    let reference = render(&s, &technique(TechniqueKind::Bdpt, 6, 256, None), 32, 1, 2);
    let vcm = render(&s, &technique(TechniqueKind::Vcm, 6, 256, None), 32, 2, 2);
    let e = mean_error(&vcm, &reference);
    eprintln!("mean error {e:.5}");
    assert!(e < 0.01, "{e}");
}

/// Rough gold, a mirror and clear glass: the caustics under the glass ball and beside the
/// mirror are the merges' part; the means agree within 1% per channel, with one light
/// subpath per pixel and with three times as many.
#[test]
fn vcm_matches_bdpt_with_glossy_mirror_and_glass_spheres() {
    let s = scene("cornell-spheres.toml");
    let reference = render(&s, &technique(TechniqueKind::Bdpt, 8, 512, None), 32, 1, 2);
    for light_paths in [None, Some(3072)] {
        let settings = Settings {
            photons_per_iteration: light_paths,
            ..technique(TechniqueKind::Vcm, 8, 512, None)
        };
        let vcm = render(&s, &settings, 32, 2, 2);
        let e = mean_error(&vcm, &reference);
        eprintln!("{light_paths:?} light subpaths: mean error {e:.5}");
        assert!(e < 0.01, "{light_paths:?}: {e}");
    }
}

/// The pool of `scenes/pool-caustics.toml` at 64x48: the floor's caustics, seen through
/// the wavy water, are light no connection finds (every path to the lamp crosses the
/// water). Against the reference kept in `tests/data` (VCM, 768 iterations of 50000 light
/// subpaths at radius 0.01, another seed), VCM's RMS error after 16 iterations (20000
/// light subpaths, radius 0.02) is at least 4 times lower than BDPT's at 64 samples per
/// pixel, and its image mean within 5% of the reference's, while VCM traces fewer rays (the two trace rays at about the same rate: the
/// time to equal error is in benches/caustics_compare.py).
#[test]
fn vcm_beats_bdpt_on_caustics_seen_through_water() {
    let s = scene("pool-caustics.toml");
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/pool-caustics-reference-64x48.exr");
    let (reference, _) = raylink::read_image(&path).unwrap();
    let box_filter = Some(raylink::image::filter::Filter::Box { radius: 0.5 });
    let sized = |settings: Settings| Job {
        width: 64,
        height: 48,
        seed: 5,
        threads: Some(2),
        ..Job::new(
            &s,
            Technique::create(&Settings {
                filter: box_filter,
                ..settings
            })
            .unwrap(),
        )
    };
    let vcm = Settings {
        photons_per_iteration: Some(20000),
        ..technique(TechniqueKind::Vcm, 8, 16, Some(0.02))
    };
    let (vcm, vcm_rays) = render_job(&s, sized(vcm));
    let (bdpt, bdpt_rays) = render_job(&s, sized(technique(TechniqueKind::Bdpt, 8, 64, None)));
    let rmse = |a: &Image| {
        let sum: f64 = a
            .pixels
            .iter()
            .zip(&reference.pixels)
            .map(|(p, r)| {
                (0..3)
                    .map(|c| (p[c] as f64 - r[c] as f64).powi(2))
                    .sum::<f64>()
            })
            .sum();
        (sum / (3 * a.pixels.len()) as f64).sqrt()
    };
    let (e_vcm, e_bdpt) = (rmse(&vcm), rmse(&bdpt));
    eprintln!("RMSE: vcm {e_vcm:.4} ({vcm_rays} rays), bdpt {e_bdpt:.4} ({bdpt_rays} rays)");
    assert!(vcm_rays < bdpt_rays, "{vcm_rays} rays against {bdpt_rays}");
    // The caustics are there: the image mean is the reference's within 5% per channel
    // (without the merges it is 48% too dark; measured 2.0%).
    let e_mean = mean_error(&vcm, &reference);
    eprintln!("mean error: vcm {e_mean:.4}");
    assert!(e_mean < 0.05, "{e_mean}");
    assert!(e_vcm * 4.0 < e_bdpt, "vcm {e_vcm}, bdpt {e_bdpt}");
}

/// Merges blur light over their radius: with a radius a fifth of the box's width the image
/// departs from bidirectional tracing's at the box's edges and corners; at a radius four
/// times smaller the bias (as r²) is 16 times smaller and the block error, then mostly
/// noise, at least three times smaller.
#[test]
fn the_merges_bias_shrinks_with_the_radius() {
    let s = scene("cornell-box.toml");
    let reference = render(&s, &technique(TechniqueKind::Bdpt, 6, 1024, None), 32, 1, 2);
    let wide = render(
        &s,
        &technique(TechniqueKind::Vcm, 6, 256, Some(0.4)),
        32,
        2,
        2,
    );
    let narrow = render(
        &s,
        &technique(TechniqueKind::Vcm, 6, 256, Some(0.1)),
        32,
        2,
        2,
    );
    let (wide, narrow) = (
        block_error(&wide, &reference),
        block_error(&narrow, &reference),
    );
    eprintln!("block error: radius 0.4 {wide:.5}, radius 0.1 {narrow:.5}");
    assert!(narrow * 3.0 < wide, "{wide} -> {narrow}");
}

/// One thread or three: the same bits. Another seed: another image.
#[test]
fn the_image_is_the_same_for_any_thread_count_and_changes_with_the_seed() {
    let s = scene("cornell-spheres.toml");
    let settings = technique(TechniqueKind::Vcm, 6, 5, None);
    let one = render(&s, &settings, 40, 7, 1);
    let three = render(&s, &settings, 40, 7, 3);
    assert!(
        one.pixels == three.pixels,
        "the thread count changed the image"
    );
    let other = render(&s, &settings, 40, 8, 3);
    assert!(one.pixels != other.pixels, "the seed changed nothing");
}

/// A render cancelled after its third iteration (the fourth's tiles under way may be kept:
/// iterations held together run as one stream of tiles), and one cancelled in the middle of
/// its fourth (after a few of its tiles), saved to a checkpoint file, read back and
/// resumed, end as the same bits as the uninterrupted render; the film shown after each
/// pass holds one more sample per pixel than the last.
#[test]
fn a_stopped_render_resumes_through_a_checkpoint_to_the_same_image() {
    let s = scene("cornell-spheres.toml");
    let settings = technique(TechniqueKind::Vcm, 6, 6, None);
    let make = |control: &Control| {
        Renderer::new(s.clone(), job(&s, &settings, 80, 3, 2), control).unwrap()
    };
    let control = Control::default();
    let full = make(&control).render(&control).unwrap().image;
    let dir = tempfile::tempdir().unwrap();
    for mid_pass in [false, true] {
        let control = Control::default();
        let mut seen = Vec::new();
        let cancel = control.cancel.clone();
        let mut show = |film: &Film, shown: Shown, _: &RenderStats| {
            seen.push(film.spp);
            let stop = if mid_pass {
                shown == Shown::MidPass && film.spp == 3
            } else {
                shown == Shown::AfterPass && film.spp == 3
            };
            if stop {
                cancel.cancel();
            }
            Ok(())
        };
        let watch = Watch {
            film: &mut show,
            mid_pass: Some(Duration::ZERO),
        };
        let stopped = make(&control)
            .render_progressive(&control, None, watch)
            .unwrap();
        assert!(stopped.is_partial());
        let film = stopped.film.unwrap();
        assert_eq!(film.spp, 3);
        assert!(film.is_partial_pass() || !mid_pass);
        let after: Vec<u32> = seen
            .windows(2)
            .filter(|w| w[1] != w[0])
            .map(|w| w[1])
            .collect();
        assert_eq!(after, [1, 2, 3], "{seen:?}");
        let file = dir.path().join(format!("vcm-{mid_pass}.checkpoint"));
        checkpoint::save(&file, &film, "vcm test", 0).unwrap();
        let blank = Film::new(
            80,
            80,
            film_filter(&settings),
            film_reconstruction(&settings),
        )
        .unwrap()
        .with_one_sample_passes(true);
        let resumed = checkpoint::load(&file, "vcm test", blank, 6).unwrap().film;
        let control = Control::default();
        let finished = make(&control)
            .render_progressive(&control, Some(resumed), Watch::nobody())
            .unwrap();
        assert!(!finished.is_partial());
        assert!(
            finished.image.pixels == full.pixels,
            "resumed {} differs",
            if mid_pass {
                "mid-pass"
            } else {
                "between passes"
            }
        );
    }
}

fn film_filter(settings: &Settings) -> raylink::image::filter::Filter {
    Technique::create(settings)
        .unwrap()
        .monte_carlo()
        .unwrap()
        .filter
}

fn film_reconstruction(settings: &Settings) -> raylink::image::filter::Reconstruction {
    Technique::create(settings)
        .unwrap()
        .monte_carlo()
        .unwrap()
        .reconstruction
}

/// A film from a technique with the usual passes cannot be resumed by VCM, nor the
/// reverse: a one-line error, not a different image.
#[test]
fn a_film_with_other_passes_is_refused() {
    let s = scene("cornell-box.toml");
    let settings = technique(TechniqueKind::Vcm, 4, 4, None);
    let film = Film::new(
        16,
        16,
        film_filter(&settings),
        film_reconstruction(&settings),
    )
    .unwrap();
    let control = Control::default();
    let err = Renderer::new(s.clone(), job(&s, &settings, 16, 1, 1), &control)
        .unwrap()
        .render_progressive(&control, Some(film), Watch::nobody())
        .unwrap_err()
        .to_string();
    assert!(err.contains("other passes"), "{err}");
}

/// Adaptive sampling, guiding, a bad radius and a part of the image are refused, each in
/// one line naming what is wrong.
#[test]
fn bad_settings_are_refused_naming_the_setting() {
    let s = scene("cornell-box.toml");
    let control = Control::default();
    let refused = |settings: Settings| -> String {
        let technique = match Technique::create(&settings) {
            Ok(t) => t,
            Err(e) => return e.to_string(),
        };
        let job = Job::new(&s, technique);
        match Renderer::new(s.clone(), job, &control) {
            Ok(_) => panic!("accepted {settings:?}"),
            Err(e) => e.to_string(),
        }
    };
    let base = technique(TechniqueKind::Vcm, 4, 4, None);
    let e = refused(Settings {
        sppm_radius: Some(-1.0),
        ..base.clone()
    });
    assert!(e.contains("sppm_radius") && !e.contains('\n'), "{e}");
    let e = refused(Settings {
        guiding: Some(true),
        ..base.clone()
    });
    assert!(e.contains("guiding") && !e.contains('\n'), "{e}");
    let e = refused(Settings {
        adaptive_threshold: Some(0.01),
        ..base.clone()
    });
    assert!(e.contains("adaptive") && !e.contains('\n'), "{e}");
    let part = Job {
        region: Some(raylink::Tile {
            x0: 0,
            y0: 0,
            x1: 8,
            y1: 8,
        }),
        ..Job::new(&s, Technique::create(&base).unwrap())
    };
    let e = Renderer::new(s.clone(), part, &control)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(e.contains("part") || e.contains("region"), "{e}");
}

/// A memory budget too small for an iteration's light vertices is refused before the
/// render, in one line naming them and their count: by default one in 32 pixels in a
/// scene without smooth surfaces (the Cornell box), one per pixel in a scene with a
/// mirror and glass. (The 32x32 image itself needs 132 KiB.)
#[test]
fn a_budget_too_small_for_the_light_vertices_is_refused() {
    let control = Control {
        budget: raylink::MemoryBudget::bytes(150 << 10),
        ..Control::default()
    };
    let settings = technique(TechniqueKind::Vcm, 8, 1, None);
    for (name, count) in [("cornell-box.toml", 32), ("cornell-spheres.toml", 1024)] {
        let s = scene(name);
        let e = Renderer::new(s.clone(), job(&s, &settings, 32, 1, 1), &control)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        let named = format!("light vertices ({count} light subpaths");
        assert!(e.contains(&named) && !e.contains('\n'), "{name}: {e}");
    }
}

/// The command line takes `--integrator vcm`, and the technique list names it.
#[test]
fn the_command_line_renders_with_vcm() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("v.exr");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_raylink"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["render", "scenes/cornell-box.toml", "--integrator", "vcm"])
        .args([
            "--width", "16", "--height", "16", "--spp", "2", "--quiet", "-o",
        ])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let (image, _) = raylink::read_image(&out).unwrap();
    assert!(image.pixels.iter().any(|p| p.max_element() > 0.0));
}

/// Lights at infinity: an environment map alone (`sky-balls.toml`), and a sun with a sky
/// seen through a window (`window-room.toml`): the image means agree with bidirectional
/// tracing's within 2% per channel (measured: 0.2% and 0.4% at 64 samples a pixel; a
/// background weight a half off makes the first 4%).
#[test]
fn vcm_matches_bdpt_under_a_sky_and_a_sun() {
    for name in ["sky-balls.toml", "window-room.toml"] {
        let s = scene(name);
        let job = |kind| Job {
            width: 48,
            height: 36,
            seed: 3,
            threads: Some(2),
            ..Job::new(
                &s,
                Technique::create(&Settings {
                    filter: Some(raylink::image::filter::Filter::Box { radius: 0.5 }),
                    ..technique(kind, 6, 64, None)
                })
                .unwrap(),
            )
        };
        let (reference, _) = render_job(&s, job(TechniqueKind::Bdpt));
        let (vcm, _) = render_job(&s, job(TechniqueKind::Vcm));
        let e = mean_error(&vcm, &reference);
        eprintln!("{name}: mean error {e:.5}");
        assert!(e < 0.02, "{name}: {e}");
    }
}
