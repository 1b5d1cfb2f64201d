//! Irradiance caching (Ward et al. 1988) from inside: the primary estimator against an
//! analytic answer and a quadrature, determinism across thread counts (values and misses
//! too), and cache files (moved from tests/irradiance_cache.rs, which keeps the Cornell box
//! through the job API and the command line).

use crate::accel::{self, Backend};
use crate::control::Control;
use crate::image::compare::{mean, rmse};
use crate::image::filter::Filter;
use crate::image::Image;
use crate::integrators::irradiance_cache::{file, Cache, IcOptions, IrradianceCache};
use crate::math::Vec3;
use crate::render::progressive::render_passes;
use crate::scene::Scene;
use crate::transport::Context;
use crate::transport::ProgressiveOptions;
use crate::transport::View;
use std::path::Path;

pub(super) fn manifest(p: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

pub(super) struct Run {
    pub image: Image,
    /// Values in the cache after the render.
    pub records: usize,
    /// Primary values computed by the overture and by the final render.
    overture: u64,
    misses: u64,
    cache: Cache,
}

pub(super) fn options(w: u32, h: u32, spp: u32, threads: Option<usize>) -> ProgressiveOptions {
    ProgressiveOptions {
        view: View {
            seed: 3,
            threads,
            ..View::new(w, h)
        },
        spp,
        time_limit: None,
        filter: Filter::Box { radius: 0.5 },
        reconstruction: crate::image::filter::Reconstruction::Splat,
        adaptive: None,
        max_component_value: None,
        statistics: false,
    }
}

pub(super) fn render_ic(
    scene: &Scene,
    ic: IcOptions,
    o: &ProgressiveOptions,
    cache: Option<Cache>,
    check: impl FnOnce(&Context, &IrradianceCache),
) -> Run {
    let control = Control::default();
    let accel = accel::build(scene, Backend::Embree, &control).unwrap();
    let ctx = Context::new(scene, accel.as_ref());
    let integrator = IrradianceCache::build(&ctx, o, ic, cache, &control).unwrap();
    let (film, _) = render_passes(
        &ctx,
        &integrator,
        o,
        None,
        crate::render::Watch::nobody(),
        &control,
    )
    .unwrap();
    assert_eq!(film.invalid, 0);
    check(&ctx, &integrator);
    Run {
        image: film.image().unwrap(),
        records: integrator.cache().len(),
        overture: integrator.stats.overture_primaries,
        misses: integrator.misses(),
        cache: integrator.cache().clone(),
    }
}

/// Furnace: a closed cube, walls of albedo ρ = 1/2 emitting Le = 1. Direct light gives every
/// wall point ρ·Le = 1/2 of reflected radiance; with `ab` cached bounces (ambient 0 beyond)
/// the indirect irradiance is exactly E = π(1 − 2^-ab) (a geometric series of radiances
/// 1/2 + 1/4 + ...), and the pixels 2 − 2^-(ab+1). Uniform radiance makes the primary
/// estimator's only noise the direct-light sampling at the hit points.
#[test]
fn furnace_irradiance_is_analytic() {
    let scene = Scene::load(&manifest("tests/scenes/furnace.toml")).unwrap();
    let ab = 3;
    let ic = IcOptions {
        bounces: ab,
        samples: 1024,
        ..IcOptions::default()
    };
    let want_e = std::f32::consts::PI * (1.0 - 0.5f32.powi(ab as i32));
    let run = render_ic(&scene, ic, &options(24, 16, 4, None), None, |ctx, integ| {
        for (p, n) in [
            (Vec3::new(0.0, 0.0, -1.0), Vec3::Z),
            (Vec3::new(0.7, -0.3, -1.0), Vec3::Z),
            (Vec3::new(1.0, 0.2, 0.5), -Vec3::X),
            (Vec3::new(-0.9, 1.0, 0.9), -Vec3::Y),
        ] {
            let e = integ.irradiance(ctx, &on_surface(p, n), n);
            for c in 0..3 {
                assert!(
                    (e[c] / want_e - 1.0).abs() < 0.02,
                    "E at {p}: {e} vs {want_e}"
                );
            }
        }
    });
    let want_l = 2.0 - 0.5f32.powi(ab as i32 + 1);
    let m = mean(&run.image, None);
    eprintln!("furnace: mean {m} vs {want_l}, {} values", run.records);
    for c in 0..3 {
        assert!((m[c] as f32 / want_l - 1.0).abs() < 0.01, "{m} vs {want_l}");
    }
}

/// The same seed gives the same image, bit for bit, on 1 and 2 threads (72x72 pixels: the
/// overture's phases have up to four 32x32 tiles each), with diffuse walls alone and with
/// glossy spheres, whose traced glossy rays the final render follows as the overture did
/// (no misses).
#[test]
fn images_do_not_depend_on_thread_count() {
    for path in [
        "scenes/cornell-box.toml",
        "tests/scenes/cornell-glossy.toml",
    ] {
        let scene = Scene::load(&manifest(path)).unwrap();
        let ic = IcOptions {
            bounces: 2,
            samples: 64,
            accuracy: 0.3,
            ..IcOptions::default()
        };
        let a = render_ic(&scene, ic, &options(72, 72, 2, Some(1)), None, |_, _| {});
        let b = render_ic(&scene, ic, &options(72, 72, 2, Some(2)), None, |_, _| {});
        assert!(a.image.pixels == b.image.pixels, "{path}: images differ");
        assert_eq!(a.records, b.records, "{path}");
        assert_eq!(a.misses, b.misses, "{path}");
        assert_eq!(a.misses, 0, "{path}");
    }
}

/// A second render that loads the first one's cache file computes no new primary values in
/// its overture and gives the same image; a foreign or corrupt file is rejected.
#[test]
fn cache_files_are_reused_and_checked() {
    let scene = Scene::load(&manifest("scenes/cornell-box.toml")).unwrap();
    let ic = IcOptions {
        bounces: 2,
        samples: 64,
        accuracy: 0.3,
        ..IcOptions::default()
    };
    let dir = std::env::temp_dir().join(format!("raylink-ic-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("cornell.ic");
    let o = options(32, 32, 2, None);
    let first = render_ic(&scene, ic, &o, None, |_, _| {});
    file::save(&path, &first.cache, &scene, &ic).unwrap();
    let loaded = file::load(&path, &scene, &ic).unwrap();
    assert_eq!(loaded.len(), first.records);
    let second = render_ic(&scene, ic, &o, Some(loaded), |_, _| {});
    eprintln!(
        "cache file: first view {} primary values, second {} (misses {} / {})",
        first.overture, second.overture, first.misses, second.misses
    );
    assert!(first.overture > 0);
    assert_eq!(second.overture, 0);
    assert!(first.image.pixels == second.image.pixels, "images differ");

    // Other parameters, another scene, corruption: one-line errors naming the file.
    let other = IcOptions {
        accuracy: 0.2,
        ..ic
    };
    let e = file::load(&path, &scene, &other).unwrap_err().to_string();
    assert!(e.contains("cornell.ic") && e.contains("ic_accuracy"), "{e}");
    let furnace = Scene::load(&manifest("tests/scenes/furnace.toml")).unwrap();
    let e = file::load(&path, &furnace, &ic).unwrap_err().to_string();
    assert!(e.contains("another scene"), "{e}");
    let mut bytes = std::fs::read(&path).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x40;
    std::fs::write(&path, &bytes).unwrap();
    let e = file::load(&path, &scene, &ic).unwrap_err().to_string();
    assert!(e.contains("corrupt"), "{e}");
    std::fs::write(&path, b"hello").unwrap();
    let e = file::load(&path, &scene, &ic).unwrap_err().to_string();
    assert!(e.contains("cornell.ic") && !e.contains('\n'), "{e}");
    std::fs::write(&path, b"").unwrap();
    assert!(file::load(&path, &scene, &ic).is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A sphere of radius 1 centred at (0, 1, 0) resting on a square plane of half-width 50 at
/// y = 0 of reflectance `rho`, under a parallel light of unit irradiance along `sun`.
#[derive(Clone, Copy)]
pub(super) struct SphereOnPlane {
    pub scene: &'static str,
    pub rho: f64,
    pub sun: Vec3,
}

/// The tests' scene: a 50% plane, the light oblique.
pub(super) const OBLIQUE: SphereOnPlane = SphereOnPlane {
    scene: "tests/scenes/sphere-on-plane.toml",
    rho: 0.5,
    sun: Vec3::new(-0.6, -1.0, -0.5),
};

impl SphereOnPlane {
    /// First-bounce irradiance on the sphere by quadrature: midpoints of an n × 2n grid in
    /// (sin²θ, φ) about the normal, a cosine-weighted grid, so that E = π/(2n²) Σ L. A
    /// direction that leaves P below its tangent plane never meets the sphere (it is
    /// convex), so L is the plane's radiance where the direction meets it: ρ/π · E_sun ·
    /// cos θ_sun, zero where the sphere shadows the plane or beyond its edges.
    pub(super) fn first_bounce(&self, p: Vec3, n: Vec3, grid: u32) -> f64 {
        let (half, center) = (50.0f32, Vec3::new(0.0, 1.0, 0.0));
        let sun = self.sun.normalize();
        let radiance = self.rho / std::f64::consts::PI * (-sun.y) as f64;
        let (t, b) = crate::math::frame(n);
        let mut sum = 0.0f64;
        for j in 0..grid {
            let sin2 = (j as f32 + 0.5) / grid as f32;
            let (sin_t, cos_t) = (sin2.sqrt(), (1.0 - sin2).sqrt());
            for k in 0..2 * grid {
                let phi = std::f32::consts::PI * (k as f32 + 0.5) / grid as f32;
                let d = t * (sin_t * phi.cos()) + b * (sin_t * phi.sin()) + n * cos_t;
                if d.y >= 0.0 {
                    continue;
                }
                let q = p + d * (-p.y / d.y);
                if q.x.abs() > half || q.z.abs() > half {
                    continue;
                }
                // Shadowed if the ray from q toward the sun meets the sphere.
                let (o, l) = (q - center, -sun);
                let bq = o.dot(l);
                let disc = bq * bq - (o.length_squared() - 1.0);
                if disc > 0.0 && -bq - disc.sqrt() > 0.0 {
                    continue;
                }
                sum += radiance;
            }
        }
        sum * std::f64::consts::PI / (2 * grid * grid) as f64
    }

    /// The direct irradiance at a point of the sphere with normal `n` (the plane never
    /// shadows the sphere, nor does the sphere itself beyond its terminator).
    pub(super) fn direct(&self, n: Vec3) -> f64 {
        n.dot(-self.sun.normalize()).max(0.0) as f64
    }
}

/// Two views sharing a cache file: the second view, started from the first view's file,
/// computes far fewer primary values than it does from scratch, and its image equals the
/// one rendered after the first view in the same process (the file keeps every value
/// exactly and in order).
#[test]
fn second_view_reuses_the_first_views_values() {
    let scene_a = Scene::load(&manifest("scenes/cornell-box.toml")).unwrap();
    let mut scene_b = scene_a.clone();
    scene_b.camera.position = Vec3::new(-0.6, 1.3, 5.5);
    scene_b.camera.look_at = Vec3::new(0.2, 0.8, 0.0);
    let ic = IcOptions {
        bounces: 2,
        samples: 128,
        accuracy: 0.2,
        ..IcOptions::default()
    };
    let o = options(48, 48, 2, None);
    let a = render_ic(&scene_a, ic, &o, None, |_, _| {});
    let b_fresh = render_ic(&scene_b, ic, &o, None, |_, _| {});
    let dir = std::env::temp_dir().join(format!("raylink-ic-views-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("views.ic");
    file::save(&path, &a.cache, &scene_a, &ic).unwrap();
    // The camera is not part of the scene hash: the file serves every view.
    let loaded = file::load(&path, &scene_b, &ic).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    let b_loaded = render_ic(&scene_b, ic, &o, Some(loaded), |_, _| {});
    let b_after_a = render_ic(&scene_b, ic, &o, Some(a.cache.clone()), |_, _| {});
    eprintln!(
        "two views: view A {} values; view B alone {} values; view B from A's file computes \
         {} more ({} in all)",
        a.records, b_fresh.overture, b_loaded.overture, b_loaded.records
    );
    assert!(
        b_loaded.overture * 3 < b_fresh.overture,
        "{} vs {}",
        b_loaded.overture,
        b_fresh.overture
    );
    assert_eq!(b_loaded.records, a.records + b_loaded.overture as usize);
    assert!(b_loaded.image.pixels == b_after_a.image.pixels);
    // And the shared cache gives view B the same picture as its own cache, within noise.
    let d = rmse(&b_loaded.image, &b_fresh.image, None);
    assert!(
        d < 0.02,
        "view B from the shared cache vs its own: RMSE {d}"
    );
}

/// Ward & Heckbert's gradients on the sphere-on-plane scene, against the quadrature: at
/// points of the sphere's underside, a value extrapolated by its gradients to a point moved
/// along the surface's tangents (0.1, a tenth of the radius) and to a normal turned by 0.1
/// rad is much closer to the true irradiance there than the value itself. (The gradient
/// takes hit distances as at least the smallest radius, scene size / ar: the plane is 100
/// wide, so ar is raised from 64 to 1024 to keep that floor, 0.1, below the distances
/// that matter here, about 1.)
#[test]
fn gradients_predict_the_change_of_irradiance() {
    let scene = Scene::load(&manifest(OBLIQUE.scene)).unwrap();
    let ic = IcOptions {
        bounces: 1,
        samples: 4096,
        gradients: true,
        ar: 1024.0,
        ..IcOptions::default()
    };
    // [translations, rotations]: summed errors of the value itself and extrapolated.
    let (mut constant, mut extrapolated, mut moves) = ([0.0f64; 2], [0.0f64; 2], 0);
    render_ic(&scene, ic, &options(8, 8, 1, None), None, |ctx, integ| {
        for (theta, phi) in [
            (2.4f32, 0.3f32),
            (2.6, 1.9),
            (2.2, 4.0),
            (2.8, 5.2),
            (2.5, 2.8),
        ] {
            let n = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            let p = Vec3::new(0.0, 1.0, 0.0) + n;
            let rec = integ.primary_value(ctx, &on_surface(p, n), n);
            let (t, b) = crate::math::frame(n);
            let turn = |axis: Vec3| (n + axis * 0.1).normalize();
            let cases = [
                (p + t * 0.1, n),
                (p - t * 0.1, n),
                (p + b * 0.1, n),
                (p - b * 0.1, n),
                (p, turn(t)),
                (p, turn(-b)),
            ];
            for (i, (q, m)) in cases.into_iter().enumerate() {
                let want = OBLIQUE.first_bounce(q, m, 256);
                let got = rec.extrapolated(q, m)[0] as f64;
                let kind = usize::from(i >= 4);
                constant[kind] += (rec.e[0] as f64 - want).abs();
                extrapolated[kind] += (got - want).abs();
                moves += 1;
            }
        }
    });
    eprintln!(
        "gradients: summed error over {moves} moves (translations, rotations): extrapolated \
         {extrapolated:.4?} against {constant:.4?} constant"
    );
    for kind in 0..2 {
        assert!(
            extrapolated[kind] < 0.5 * constant[kind],
            "{extrapolated:?} vs {constant:?}"
        );
    }
}

/// A point a test computed on a surface of unit size, as rays leave it: γ8 of |p| + 1 bounds
/// the error of the few operations that made it.
fn on_surface(p: Vec3, n: Vec3) -> crate::math::spawn::Spot {
    crate::math::spawn::Spot {
        p,
        error: (p.abs() + Vec3::ONE) * crate::math::spawn::gamma(8),
        n,
    }
}
