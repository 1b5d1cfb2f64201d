//! Light selection for next-event estimation: the light hierarchy against choosing by
//! power, on the hall of 288 small lamps (`scenes/lamp-room.toml`).

use crate::accel::{self, Backend};
use crate::control::Control;
use crate::image::filter::Filter;
use crate::image::Image;
use crate::integrators::path::{PathOptions, PathTracer};
use crate::render::progressive::render_passes;
use crate::scene::lights::{AreaLight, LightSet, SelectionKind};
use crate::scene::Scene;
use crate::transport::{Context, ProgressiveOptions, View};
use std::path::Path;

/// The lamp room at 40×30, 4 samples per pixel, seed `seed`, its lights chosen by `kind`.
fn render(scene: &Scene, kind: SelectionKind, seed: u64) -> Image {
    let accel = accel::build(scene, Backend::Embree, &Control::default()).unwrap();
    let mut ctx = Context::new(scene, accel.as_ref());
    ctx.lights = LightSet::with_selection(scene, &AreaLight::collect(scene), kind);
    let options = ProgressiveOptions {
        view: View {
            seed,
            ..View::new(40, 30)
        },
        spp: 4,
        time_limit: None,
        filter: Filter::Box { radius: 0.5 },
        reconstruction: crate::image::filter::Reconstruction::Splat,
        adaptive: None,
        max_component_value: None,
        statistics: false,
    };
    let tracer = PathTracer::new(PathOptions { max_depth: 1 });
    let watch = crate::render::Watch::nobody();
    let (film, _) =
        render_passes(&ctx, &tracer, &options, None, watch, &Control::default()).unwrap();
    film.image().unwrap()
}

/// Per channel, the image mean and its standard error over `images` (one per seed).
fn means(images: &[Image]) -> ([f64; 3], [f64; 3]) {
    let k = images.len() as f64;
    let n = images[0].pixels.len();
    let (mut mean, mut se) = ([0.0; 3], [0.0; 3]);
    for c in 0..3 {
        let means: Vec<f64> = images
            .iter()
            .map(|im| im.pixels.iter().map(|p| p[c] as f64).sum::<f64>() / n as f64)
            .collect();
        let m = means.iter().sum::<f64>() / k;
        let v = means.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (k - 1.0);
        mean[c] = m;
        se[c] = (v / k).sqrt();
    }
    (mean, se)
}

/// Each pixel's mean and variance between seeds, of the sum of its channels.
fn pixel_stats(images: &[Image]) -> Vec<(f64, f64)> {
    let k = images.len() as f64;
    (0..images[0].pixels.len())
        .map(|i| {
            let v: Vec<f64> = images
                .iter()
                .map(|im| {
                    let p = im.pixels[i];
                    (p.x + p.y + p.z) as f64
                })
                .collect();
            let m = v.iter().sum::<f64>() / k;
            (
                m,
                v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (k - 1.0),
            )
        })
        .collect()
}

/// The hierarchy and power selection give the same image (each channel's mean within 3
/// standard errors of the difference, over 8 seeds), and the hierarchy's pixels vary less
/// between seeds (the median pixel's variance at most 0.7 of power selection's).
#[test]
fn the_light_hierarchy_agrees_with_power_selection_and_is_less_noisy() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/lamp-room.toml");
    let scene = Scene::load(&path).unwrap();
    assert!(AreaLight::collect(&scene).len() >= 250);
    let run = |kind| -> Vec<Image> { (1..=8).map(|seed| render(&scene, kind, seed)).collect() };
    let (tree, power) = (run(SelectionKind::Tree), run(SelectionKind::Power));
    let ((tree_mean, tree_se), (power_mean, power_se)) = (means(&tree), means(&power));
    eprintln!("tree {tree_mean:?} ± {tree_se:?}; power {power_mean:?} ± {power_se:?}");
    for c in 0..3 {
        let z = (tree_mean[c] - power_mean[c]) / (tree_se[c].hypot(power_se[c]));
        assert!(
            z.abs() < 3.0,
            "channel {c}: means differ by {z:.2} standard errors"
        );
    }
    // Over the surfaces the lamps light, the median of each pixel's variance ratio: pixels
    // that see a lamp vary by where in the pixel it falls, alike for both, and are left out.
    let mut ratios: Vec<f64> = pixel_stats(&tree)
        .into_iter()
        .zip(pixel_stats(&power))
        .filter(|((mt, vt), (mp, vp))| mt.max(*mp) < 1.5 && *vt > 0.0 && *vp > 0.0)
        .map(|((_, vt), (_, vp))| vt / vp)
        .collect();
    ratios.sort_by(f64::total_cmp);
    assert!(ratios.len() > 600, "{} lit pixels", ratios.len());
    let median = ratios[ratios.len() / 2];
    eprintln!(
        "median variance ratio, hierarchy to power, over {} pixels: {median:.3}",
        ratios.len()
    );
    assert!(
        median < 0.7,
        "hierarchy variance {median} of power selection's"
    );
}
