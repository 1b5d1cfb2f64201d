//! Adaptive sampling: the same image for any thread count and through an interrupted and
//! resumed render, the same mean as uniform sampling, and less error at equal samples.

use crate::accel::{self, Backend};
use crate::control::{CancelToken, Control};
use crate::image::filter::{Filter, Reconstruction};
use crate::image::Image;
use crate::integrators::path::{PathOptions, PathTracer};
use crate::render::progressive::render_passes;
use crate::render::{checkpoint, Film, RenderStats, Shown, Watch};
use crate::scene::Scene;
use crate::transport::settings::AdaptiveSampling;
use crate::transport::{Context, ProgressiveOptions, View};
use std::path::Path;

fn scene(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(name);
    Scene::load(&path).unwrap()
}

fn options(
    (w, h): (u32, u32),
    spp: u32,
    adaptive: Option<AdaptiveSampling>,
    seed: u64,
) -> ProgressiveOptions {
    ProgressiveOptions {
        view: View {
            seed,
            ..View::new(w, h)
        },
        spp,
        time_limit: None,
        filter: Filter::default(),
        // Adaptive sampling takes each pixel's samples from the filter; so does the
        // uniform render it is compared with.
        reconstruction: Reconstruction::Importance,
        adaptive,
        max_component_value: None,
        statistics: false,
    }
}

/// Renders `scene` with the path tracer (5 bounces), from `resume` if given; `watch` sees
/// every pass and may cancel through the token it is given.
fn render(
    scene: &Scene,
    options: &ProgressiveOptions,
    resume: Option<Film>,
    watch: &mut dyn FnMut(&Film, Shown, &CancelToken),
) -> (Film, RenderStats) {
    let accel = accel::build(scene, Backend::Embree, &Control::default()).unwrap();
    let ctx = Context::new(scene, accel.as_ref());
    let tracer = PathTracer::new(PathOptions { max_depth: 5 });
    let cancel = CancelToken::new();
    let control = Control::with_cancel(cancel.clone());
    let mut show = |film: &Film, shown: Shown, _: &RenderStats| {
        watch(film, shown, &cancel);
        Ok(())
    };
    let watch = Watch {
        film: &mut show,
        mid_pass: Some(std::time::Duration::ZERO),
    };
    render_passes(&ctx, &tracer, options, resume, watch, &control).unwrap()
}

fn bits(image: &Image) -> Vec<u32> {
    image
        .pixels
        .iter()
        .flat_map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
        .collect()
}

const RULE: AdaptiveSampling = AdaptiveSampling {
    threshold: 0.05,
    min_samples: 8,
};

/// One thread or two, and a render interrupted in the middle of a pass, saved to a
/// checkpoint, read back and resumed: the same pixels and sample counts bit for bit.
#[test]
fn adaptive_sampling_is_the_same_for_any_thread_count_and_after_a_resume() {
    let scene = scene("scenes/cornell-box.toml");
    let mut base = options((48, 36), 128, Some(RULE), 3);
    base.view.threads = Some(2);
    let (whole, stats) = render(&scene, &base, None, &mut |_, _, _| {});
    let image = whole.image().unwrap();
    let total = stats.samples;
    // Some pixels stopped early, others went on to the end.
    let counts = &whole.statistics().unwrap().counts;
    assert!(counts.iter().any(|&n| n < 128) && counts.contains(&128));
    assert_eq!(total, counts.iter().map(|&n| n as u64).sum::<u64>());

    let mut one = base.clone();
    one.view.threads = Some(1);
    let (single, _) = render(&scene, &one, None, &mut |_, _, _| {});
    assert!(
        bits(&single.image().unwrap()) == bits(&image),
        "1 thread differs"
    );
    assert_eq!(&single.statistics().unwrap().counts, counts);

    // Stop in the middle of the pass that takes pixels past 16 samples.
    let (cut, cut_stats) = render(&scene, &base, None, &mut |film, shown, cancel| {
        if shown == Shown::MidPass && film.spp >= 16 {
            cancel.cancel();
        }
    });
    assert!(cut_stats.cancelled && cut.is_partial_pass(), "{cut:?}");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cut.checkpoint");
    checkpoint::save(&path, &cut, "adaptive test", 0).unwrap();
    let blank = Film::new(48, 36, base.filter, base.reconstruction)
        .unwrap()
        .with_adaptive(Some(RULE))
        .unwrap();
    let restored = checkpoint::load(&path, "adaptive test", blank, 128)
        .unwrap()
        .film;
    assert_eq!(restored.statistics(), cut.statistics());
    // A film without statistics cannot take it.
    let plain = Film::new(48, 36, base.filter, base.reconstruction).unwrap();
    assert!(checkpoint::load(&path, "adaptive test", plain, 128).is_err());
    let (resumed, _) = render(&scene, &base, Some(restored), &mut |_, _, _| {});
    assert!(
        bits(&resumed.image().unwrap()) == bits(&image),
        "the resume differs"
    );
    assert_eq!(&resumed.statistics().unwrap().counts, counts);
}

/// The image's mean per channel, over pixels.
fn mean(image: &Image) -> [f64; 3] {
    let n = image.pixels.len() as f64;
    let mut m = [0.0; 3];
    for p in &image.pixels {
        for (c, v) in m.iter_mut().zip([p.x, p.y, p.z]) {
            *c += v as f64 / n;
        }
    }
    m
}

/// The relative mean squared error against `reference` (per channel, over ref² + 0.01).
fn rel_mse(image: &Image, reference: &Image) -> f64 {
    let mut e = 0.0;
    for (p, r) in image.pixels.iter().zip(&reference.pixels) {
        for (a, b) in [(p.x, r.x), (p.y, r.y), (p.z, r.z)] {
            let (a, b) = (a as f64, b as f64);
            e += (a - b) * (a - b) / (b * b + 0.01);
        }
    }
    e / (3.0 * image.pixels.len() as f64)
}

/// On the room lit through a window (40×30, threshold 0.1), adaptive sampling's image has
/// the uniform render's mean (each channel within 3 standard errors over 4 seeds) and, at
/// no more samples in all, a lower relative error against a long uniform render (0.86 of
/// uniform sampling's when recorded).
#[test]
fn adaptive_sampling_keeps_the_mean_and_lowers_the_error_at_equal_samples() {
    let scene = scene(ROOM);
    let size = (40, 30);
    let reference = render(
        &scene,
        &options(size, 1024, None, 99),
        None,
        &mut |_, _, _| {},
    )
    .0
    .image()
    .unwrap();
    let rule = AdaptiveSampling {
        threshold: 0.1,
        min_samples: 16,
    };
    let seeds = 4;
    let (mut adaptive_err, mut uniform_err) = (0.0, 0.0);
    let mut means = Vec::new();
    for seed in 0..seeds {
        let (film, stats) = render(
            &scene,
            &options(size, 512, Some(rule), seed),
            None,
            &mut |_, _, _| {},
        );
        let image = film.image().unwrap();
        // The uniform render takes at least as many samples in all.
        let spp = stats.samples.div_ceil(size.0 as u64 * size.1 as u64) as u32;
        let uniform = render(
            &scene,
            &options(size, spp, None, seed),
            None,
            &mut |_, _, _| {},
        )
        .0
        .image()
        .unwrap();
        adaptive_err += rel_mse(&image, &reference);
        uniform_err += rel_mse(&uniform, &reference);
        means.push(mean(&image));
    }
    let truth = mean(&reference);
    for c in 0..3 {
        let m = means.iter().map(|v| v[c]).sum::<f64>() / seeds as f64;
        let var = means.iter().map(|v| (v[c] - m).powi(2)).sum::<f64>() / (seeds - 1) as f64;
        let se = (var / seeds as f64).sqrt();
        assert!(
            (m - truth[c]).abs() < 3.0 * se + 2e-3 * truth[c],
            "channel {c}: adaptive mean {m} vs reference {} (se {se})",
            truth[c]
        );
    }
    let ratio = adaptive_err / uniform_err;
    eprintln!("adaptive / uniform relative MSE at equal samples: {ratio:.3}");
    assert!(ratio < 0.93, "adaptive / uniform relative MSE {ratio}");
}

/// The scene of the error comparison.
const ROOM: &str = "scenes/window-room.toml";

/// Clamping scales every sample down to the bound (so no pixel of a positive filter
/// exceeds it), darkens the light the camera sees, and a bound above every sample changes
/// nothing.
#[test]
fn clamping_bounds_every_sample_and_only_when_exceeded() {
    let scene = scene("scenes/cornell-box.toml");
    let plain = options((24, 24), 8, None, 1);
    let image = |o: &ProgressiveOptions| {
        render(&scene, o, None, &mut |_, _, _| {})
            .0
            .image()
            .unwrap()
    };
    let free = image(&plain);
    let brightest = free
        .pixels
        .iter()
        .map(|p| p.max_element())
        .fold(0.0, f32::max);
    assert!(brightest > 1.0, "the light is brighter than the bound");
    let clamped = image(&ProgressiveOptions {
        max_component_value: Some(0.5),
        ..plain.clone()
    });
    for p in &clamped.pixels {
        assert!(p.max_element() <= 0.5 + 1e-6, "{p}");
    }
    assert!(mean(&clamped)[0] < mean(&free)[0]);
    let loose = image(&ProgressiveOptions {
        max_component_value: Some(1e30),
        ..plain
    });
    assert!(bits(&loose) == bits(&free));
}
