//! Irradiance caching (Ward et al. 1988): the primary estimator against an analytic answer,
//! the Cornell box against Tungsten's reference and raylink's path tracer, determinism across
//! thread counts, and cache files.

use raylink::accel::{self, Backend};
use raylink::image::compare::{box_downsample, bright_mask, mean, rmse};
use raylink::image::filter::Filter;
use raylink::image::output::read_image;
use raylink::image::Image;
use raylink::integrators::irradiance_cache::{file, Cache, IcOptions, IrradianceCache};
use raylink::integrators::path::{PathOptions, PathTracer};
use raylink::integrators::{Context, MonteCarlo};
use raylink::math::Vec3;
use raylink::render::progressive::{render_progressive, ProgressiveOptions};
use raylink::scene::Scene;
use std::path::Path;
use std::time::Instant;

fn manifest(p: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

struct Run {
    image: Image,
    /// Values in the cache after the render.
    records: usize,
    /// Primary values computed by the overture and by the final render.
    overture: u64,
    misses: u64,
    seconds: f64,
    cache: Cache,
}

fn options(w: u32, h: u32, spp: u32, threads: Option<usize>) -> ProgressiveOptions {
    ProgressiveOptions {
        width: w,
        height: h,
        spp,
        time_limit: None,
        threads,
        seed: 3,
        progress: false,
        filter: Filter::Box { radius: 0.5 },
    }
}

fn render_ic(
    scene: &Scene,
    ic: IcOptions,
    o: &ProgressiveOptions,
    cache: Option<Cache>,
    check: impl FnOnce(&Context, &IrradianceCache),
) -> Run {
    let start = Instant::now();
    let accel = accel::build(scene, Backend::Embree).unwrap();
    let ctx = Context::new(scene, accel.as_ref());
    let mut camera = scene.camera.clone();
    camera.width = o.width;
    camera.height = o.height;
    let mut basis = camera.basis();
    basis.margin = o.filter.radius();
    let integrator = IrradianceCache::build(&ctx, &basis, o, ic, cache);
    let (film, _) = render_progressive(&ctx, &integrator, o, |_| Ok(())).unwrap();
    assert_eq!(film.invalid, 0);
    check(&ctx, &integrator);
    Run {
        image: film.image(),
        records: integrator.cache().len(),
        overture: integrator.stats.overture_primaries,
        misses: integrator.misses(),
        seconds: start.elapsed().as_secs_f64(),
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
        samples: 256,
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
            let e = integ.irradiance(ctx, p, n);
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

fn tungsten_256() -> Image {
    let reference = manifest("../shared/scenes/cornell-box-bitterli/TungstenRender.exr");
    let (reference, _) = read_image(&reference).expect("../shared holds the Tungsten render");
    box_downsample(&reference, 256, 256).unwrap()
}

/// The Cornell box at 128x128 (compared with Tungsten's render box-downsampled to 128x128,
/// light pixels excluded) with the irradiance cache and with the path tracer at a sample
/// count of similar error. The cache must be close to the reference (the figures are
/// printed; the time ratio is a benchmark, not asserted).
#[test]
fn cornell_box_against_tungsten_and_path_tracer() {
    let scene = Scene::load(&manifest("scenes/cornell-box.toml")).unwrap();
    let reference = box_downsample(&tungsten_256(), 128, 128).unwrap();
    let mask = bright_mask(&reference, 1.0);
    let ic = IcOptions {
        bounces: 5,
        ar: 16.0,
        ..IcOptions::default()
    };
    let run = render_ic(&scene, ic, &options(128, 128, 16, None), None, |_, _| {});
    let e_ic = rmse(&run.image, &reference, Some(&mask));

    let start = Instant::now();
    let accel = accel::build(&scene, Backend::Embree).unwrap();
    let ctx = Context::new(&scene, accel.as_ref());
    let pt: Box<dyn MonteCarlo> = Box::new(PathTracer::new(PathOptions { max_depth: 64 }));
    let (film, _) =
        render_progressive(&ctx, pt.as_ref(), &options(128, 128, 64, None), |_| Ok(())).unwrap();
    let pt_seconds = start.elapsed().as_secs_f64();
    let e_pt = rmse(&film.image(), &reference, Some(&mask));
    let e_between = rmse(&run.image, &film.image(), Some(&mask));
    let (m, r) = (mean(&run.image, Some(&mask)), mean(&reference, Some(&mask)));
    eprintln!(
        "cornell 128: IC RMSE {e_ic:.5} in {:.2} s ({} values, {} final-pass misses); \
         path 64 spp RMSE {e_pt:.5} in {pt_seconds:.2} s; IC vs path {e_between:.5}; \
         mean {m} vs {r}",
        run.seconds, run.records, run.misses
    );
    for c in 0..3 {
        assert!((m[c] / r[c] - 1.0).abs() < 0.02, "mean {m} vs {r}");
    }
    assert!(e_ic < 0.02, "IC RMSE {e_ic}");
}

/// The same seed gives the same image, bit for bit, on 1 and 2 threads.
#[test]
fn images_do_not_depend_on_thread_count() {
    let scene = Scene::load(&manifest("scenes/cornell-box.toml")).unwrap();
    let ic = IcOptions {
        bounces: 2,
        samples: 64,
        accuracy: 0.3,
        ..IcOptions::default()
    };
    let a = render_ic(&scene, ic, &options(32, 32, 4, Some(1)), None, |_, _| {});
    let b = render_ic(&scene, ic, &options(32, 32, 4, Some(2)), None, |_, _| {});
    assert!(a.image.pixels == b.image.pixels, "images differ");
    assert_eq!(a.records, b.records);
    assert_eq!(a.misses, b.misses);
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
    assert!(
        e.contains("cornell.ic") && e.contains("--ic-accuracy"),
        "{e}"
    );
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

/// The command line: a second view with --cache-file loads the values and computes none in
/// its overture; a foreign file is a one-line error naming it, exit status 2.
#[test]
fn cli_cache_file() {
    let dir = std::env::temp_dir().join(format!("raylink-ic-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cache = dir.join("box.ic");
    let run = |out: &str, cache: &Path| {
        std::process::Command::new(env!("CARGO_BIN_EXE_raylink"))
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(["render", "scenes/cornell-box.toml", "--integrator"])
            .args([
                "irradiance-cache",
                "--width",
                "16",
                "--height",
                "16",
                "--spp",
                "1",
            ])
            .args(["--ab", "1", "--ic-samples", "32", "--cache-file"])
            .arg(cache)
            .arg("-o")
            .arg(dir.join(out))
            .output()
            .unwrap()
    };
    let first = run("a.exr", &cache);
    let err = String::from_utf8_lossy(&first.stderr).into_owned();
    assert!(first.status.success(), "{err}");
    assert!(err.contains("(0 loaded,"), "{err}");
    let second = run("b.exr", &cache);
    let err = String::from_utf8_lossy(&second.stderr).into_owned();
    assert!(second.status.success(), "{err}");
    assert!(err.contains(" 0 computed by the overture"), "{err}");
    let bad = dir.join("bad.ic");
    std::fs::write(&bad, b"not a cache at all").unwrap();
    let third = run("c.exr", &bad);
    let err = String::from_utf8_lossy(&third.stderr).into_owned();
    assert_eq!(third.status.code(), Some(2), "{err}");
    assert!(
        err.contains("bad.ic") && err.trim().lines().count() == 1,
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Benchmark (ignored): the Cornell box at 256x256 against Tungsten's reference, irradiance
/// cache and path tracer, with times. `cargo test --test irradiance_cache -- --ignored
/// --nocapture`.
#[test]
#[ignore]
fn cornell_256_benchmark() {
    let scene = Scene::load(&manifest("scenes/cornell-box.toml")).unwrap();
    let reference = tungsten_256();
    let mask = bright_mask(&reference, 1.0);
    for (ab, ar, samples) in [(5, 16.0, 512), (8, 32.0, 1024)] {
        let ic = IcOptions {
            bounces: ab,
            ar,
            samples,
            ..IcOptions::default()
        };
        let run = render_ic(&scene, ic, &options(256, 256, 16, None), None, |_, _| {});
        let e = rmse(&run.image, &reference, Some(&mask));
        eprintln!(
            "IC ab {ab} ar {ar} ad {samples}: RMSE {e:.5} in {:.2} s, {} values",
            run.seconds, run.records
        );
    }
    for spp in [64, 256] {
        let start = Instant::now();
        let accel = accel::build(&scene, Backend::Embree).unwrap();
        let ctx = Context::new(&scene, accel.as_ref());
        let pt = PathTracer::new(PathOptions { max_depth: 64 });
        let (film, _) =
            render_progressive(&ctx, &pt, &options(256, 256, spp, None), |_| Ok(())).unwrap();
        let e = rmse(&film.image(), &reference, Some(&mask));
        eprintln!(
            "path {spp} spp: RMSE {e:.5} in {:.2} s",
            start.elapsed().as_secs_f64()
        );
    }
}
