//! The engine as a library user drives it: jobs cancelled by their caller stop within a
//! second in every long phase and say what they kept; jobs in one process keep their own
//! controls; the image does not depend on the thread count.

use raylink::{
    CancelToken, Control, Error, Film, Job, MemoryBudget, RenderStats, Rendered, Renderer, Scene,
    Settings, Shown, Technique, TechniqueKind, Watch,
};
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

fn scene(name: &str) -> Arc<Scene> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    Arc::new(Scene::load(&path).unwrap())
}

fn job(scene: &Scene, settings: Settings, size: (u32, u32)) -> Job {
    Job {
        width: size.0,
        height: size.1,
        seed: 3,
        threads: Some(2),
        ..Job::new(scene, Technique::create(&settings).unwrap())
    }
}

/// Runs `work` on a thread, cancels its token after `after`, and returns what it gave and
/// how long it took to stop after the cancel.
fn cancel_after<T: Send + 'static>(
    after: Duration,
    work: impl FnOnce(Control) -> T + Send + 'static,
) -> (T, Duration) {
    let control = Control::with_cancel(CancelToken::new());
    let token = control.cancel.clone();
    let worker = std::thread::spawn(move || work(control));
    std::thread::sleep(after);
    let asked = Instant::now();
    token.cancel();
    let result = worker.join().expect("the job does not panic");
    (result, asked.elapsed())
}

fn checksum(rendered: &Rendered) -> Vec<[u32; 3]> {
    rendered
        .image
        .pixels
        .iter()
        .map(|p| p.to_array().map(f32::to_bits))
        .collect()
}

#[test]
fn a_cancelled_path_render_stops_within_a_second_and_is_partial() {
    let box_scene = scene("cornell-box.toml");
    let settings = Settings {
        integrator: Some(TechniqueKind::Path),
        spp: Some(1 << 16),
        ..Settings::default()
    };
    let job = job(&box_scene, settings, (128, 128));
    let (rendered, stop) = cancel_after(Duration::from_millis(400), move |control| {
        Renderer::new(box_scene, job, &control)?.render(&control)
    });
    let rendered = rendered.unwrap();
    assert!(stop < Duration::from_secs(1), "took {stop:?} to stop");
    assert!(rendered.is_partial());
    let film = rendered.film.as_ref().unwrap();
    assert!(film.mean_spp() > 0.0 && film.mean_spp() < (1 << 16) as f64);
    assert!(rendered.stats.samples > 0);
}

#[test]
fn a_cancelled_irradiance_cache_overture_stops_within_a_second() {
    let room = scene("indirect-room.toml");
    let settings = Settings {
        integrator: Some(TechniqueKind::IrradianceCache),
        spp: Some(4),
        ic_samples: Some(4096),
        ..Settings::default()
    };
    let job = job(&room, settings, (320, 240));
    let (result, stop) = cancel_after(Duration::from_millis(400), move |control| {
        Renderer::new(room, job, &control)?.render(&control)
    });
    assert!(stop < Duration::from_secs(1), "took {stop:?} to stop");
    match result {
        Err(Error::Cancelled { stage }) => assert!(stage.contains("overture"), "{stage}"),
        other => panic!("expected a cancel during the overture, got {other:?}"),
    }
}

#[test]
fn concurrent_jobs_keep_their_own_controls() {
    let box_scene = scene("cornell-box.toml");
    let settings = Settings {
        integrator: Some(TechniqueKind::Path),
        spp: Some(8),
        ..Settings::default()
    };
    let small = job(&box_scene, settings.clone(), (48, 48));
    let solo = {
        let control = Control::default();
        let mut r = Renderer::new(box_scene.clone(), small.clone(), &control).unwrap();
        checksum(&r.render(&control).unwrap())
    };
    // Job A: long, cancelled, with a large budget. Job B: small budget, never cancelled.
    let long = job(
        &box_scene,
        Settings {
            spp: Some(1 << 16),
            ..settings
        },
        (96, 96),
    );
    let a_control = Control {
        budget: MemoryBudget::bytes(1 << 32),
        ..Control::with_cancel(CancelToken::new())
    };
    let b_control = Control {
        budget: MemoryBudget::bytes(64 << 20),
        ..Control::with_cancel(CancelToken::new())
    };
    let a_token = a_control.cancel.clone();
    let (scene_a, scene_b) = (box_scene.clone(), box_scene.clone());
    let a = std::thread::spawn(move || {
        Renderer::new(scene_a, long, &a_control)
            .unwrap()
            .render(&a_control)
            .unwrap()
    });
    let b = std::thread::spawn(move || {
        let mut r = Renderer::new(scene_b, small, &b_control).unwrap();
        // B runs while A is under way, and A is cancelled while B renders.
        std::thread::sleep(Duration::from_millis(200));
        a_token.cancel();
        r.render(&b_control).unwrap()
    });
    let (a, b) = (a.join().unwrap(), b.join().unwrap());
    assert!(a.is_partial());
    assert!(!b.is_partial());
    assert_eq!(checksum(&b), solo, "job B differs from its solo run");
    // B's budget is its own: a film B's size fits, one A's size past 64 MiB does not.
    let huge = job(&box_scene, Settings::default(), (8192, 8192));
    let refused = Renderer::new(
        box_scene,
        huge,
        &Control {
            budget: MemoryBudget::bytes(64 << 20),
            ..Control::default()
        },
    );
    assert!(matches!(refused, Err(Error::Memory { .. })), "{refused:?}");
}

#[test]
fn images_do_not_depend_on_the_thread_count() {
    let spheres = scene("cornell-spheres.toml");
    for kind in [
        TechniqueKind::Path,
        TechniqueKind::Bdpt,
        TechniqueKind::Whitted,
    ] {
        let settings = Settings {
            integrator: Some(kind),
            spp: Some(4),
            ..Settings::default()
        };
        let images: Vec<_> = [1, 2, 5]
            .into_iter()
            .map(|threads| {
                let job = Job {
                    threads: Some(threads),
                    ..job(&spheres, settings.clone(), (40, 40))
                };
                let control = Control::default();
                checksum(
                    &Renderer::new(spheres.clone(), job, &control)
                        .unwrap()
                        .render(&control)
                        .unwrap(),
                )
            })
            .collect();
        assert!(images.windows(2).all(|w| w[0] == w[1]), "{kind}");
    }
}

#[test]
fn bad_settings_name_the_setting() {
    let box_scene = scene("cornell-box.toml");
    for (settings, name) in [
        (
            Settings {
                max_depth: Some(9999),
                ..Settings::default()
            },
            "max_depth",
        ),
        (
            Settings {
                integrator: Some(TechniqueKind::Path),
                spp: Some(0),
                ..Settings::default()
            },
            "spp",
        ),
    ] {
        match Technique::create(&settings) {
            Err(Error::Setting { name: n, .. }) => assert_eq!(n, name),
            other => panic!("{other:?}"),
        }
    }
    let job = Job {
        width: 0,
        ..job(&box_scene, Settings::default(), (8, 8))
    };
    match Renderer::new(box_scene, job, &Control::default()) {
        Err(Error::Setting { name, .. }) => assert_eq!(name, "width"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_cancelled_network_preprocess_stops_within_a_second() {
    let office = scene("network-office.toml");
    let settings = Settings {
        integrator: Some(TechniqueKind::Network),
        intercept_step: Some(1.0 / 128.0),
        slopes: Some(20),
        ..Settings::default()
    };
    let job = job(&office, settings, (32, 24));
    let (result, stop) = cancel_after(Duration::from_millis(300), move |control| {
        Renderer::new(office, job, &control)?.render(&control)
    });
    assert!(stop < Duration::from_secs(1), "took {stop:?} to stop");
    match result {
        Err(Error::Cancelled { stage }) => assert!(stage.contains("network"), "{stage}"),
        other => panic!("expected a cancel during the network's preparation, got {other:?}"),
    }
}

#[test]
fn a_cancelled_parse_of_a_large_scene_stops_within_a_second() {
    // A pbrt scene whose includes fan out: each level includes the next twice, 2^24 leaves,
    // more than any machine reads in a second.
    let dir = tempfile::tempdir().unwrap();
    let levels = 24;
    for k in 0..levels {
        let next = format!("Include \"level{}.pbrt\"\n", k + 1);
        std::fs::write(dir.path().join(format!("level{k}.pbrt")), next.repeat(2)).unwrap();
    }
    std::fs::write(
        dir.path().join(format!("level{levels}.pbrt")),
        "AttributeBegin\nAttributeEnd\n",
    )
    .unwrap();
    let root = dir.path().join("scene.pbrt");
    std::fs::write(
        &root,
        "LookAt 0 0 5 0 0 0 0 1 0\nCamera \"perspective\"\nWorldBegin\nInclude \"level0.pbrt\"\n",
    )
    .unwrap();
    let (result, stop) = cancel_after(Duration::from_millis(300), move |control| {
        Scene::load_with(&root, &control).map(drop)
    });
    assert!(stop < Duration::from_secs(1), "took {stop:?} to stop");
    match result {
        Err(Error::Cancelled { stage }) => assert!(stage.contains("scene"), "{stage}"),
        other => panic!("expected a cancel while reading, got {other:?}"),
    }
}

/// A preview is the job with one sample at each pixel's centre (`aa = uniform, spp = 1`),
/// bit for bit, from the same prepared technique; the job's own render is unchanged by it;
/// the progressive techniques have none.
#[test]
fn a_preview_is_the_one_sample_render_of_the_view() {
    let room = scene("network-room.toml");
    let network = |spp, aa| Settings {
        integrator: Some(TechniqueKind::Network),
        slopes: Some(6),
        intercept_step: Some(0.0625),
        spp: Some(spp),
        aa,
        ..Settings::default()
    };
    let control = Control::default();
    for (kind, scene) in [
        (TechniqueKind::Whitted, scene("whitted.toml")),
        (TechniqueKind::Network, room.clone()),
    ] {
        let settings = |spp, aa| match kind {
            TechniqueKind::Network => network(spp, aa),
            _ => Settings {
                integrator: Some(kind),
                spp: Some(spp),
                aa,
                ..Settings::default()
            },
        };
        let full = job(&scene, settings(4, None), (24, 18));
        let mut renderer = Renderer::new(scene.clone(), full.clone(), &control).unwrap();
        let preview = renderer.render_preview(&control).unwrap().unwrap();
        let after = renderer.render(&control).unwrap();
        let uniform = Some(raylink::job::AntiAliasing::Uniform);
        let one = job(&scene, settings(1, uniform), (24, 18));
        let expected = Renderer::new(scene.clone(), one, &control)
            .unwrap()
            .render(&control)
            .unwrap();
        assert_eq!(checksum(&preview), checksum(&expected), "{kind}");
        let fresh = Renderer::new(scene.clone(), full, &control)
            .unwrap()
            .render(&control)
            .unwrap();
        assert_eq!(checksum(&after), checksum(&fresh), "{kind}");
        assert_ne!(checksum(&preview), checksum(&after), "{kind}");
    }
    let path = job(
        &room,
        Settings {
            integrator: Some(TechniqueKind::Path),
            ..Settings::default()
        },
        (8, 6),
    );
    let mut renderer = Renderer::new(room, path, &control).unwrap();
    assert!(renderer.render_preview(&control).unwrap().is_none());
}

#[test]
fn a_watched_render_shows_its_film_mid_pass_and_ends_the_same() {
    let box_scene = scene("cornell-box.toml");
    let settings = Settings {
        integrator: Some(TechniqueKind::Path),
        spp: Some(8),
        ..Settings::default()
    };
    let render = |mid_pass: Option<Duration>, seen: &mut Vec<(Shown, f64, u32, u64)>| {
        let control = Control::default();
        let mut renderer = Renderer::new(
            box_scene.clone(),
            job(&box_scene, settings.clone(), (64, 48)),
            &control,
        )
        .unwrap();
        let mut show = |film: &Film, shown: Shown, stats: &RenderStats| {
            assert_eq!(film.is_partial_pass(), shown == Shown::MidPass);
            let image = film.image()?;
            assert!(image.pixels.iter().all(|p| p.is_finite()));
            seen.push((shown, film.mean_spp(), film.spp, stats.rays.total()));
            Ok(())
        };
        let watch = Watch {
            film: &mut show,
            mid_pass,
        };
        checksum(&renderer.render_progressive(&control, None, watch).unwrap())
    };
    let (mut passes, mut every_tile) = (Vec::new(), Vec::new());
    let plain = render(None, &mut passes);
    // A zero interval shows the film after every tile: 12 tiles a pass.
    let watched = render(Some(Duration::ZERO), &mut every_tile);
    assert_eq!(plain, watched, "watching changed the image");
    let after: Vec<u32> = passes.iter().map(|s| s.2).collect();
    assert_eq!(after, [1, 2, 4, 8], "{passes:?}");
    assert!(passes.iter().all(|s| s.0 == Shown::AfterPass));
    let mid = every_tile.iter().filter(|s| s.0 == Shown::MidPass).count();
    assert_eq!(mid, 4 * 11, "{every_tile:?}");
    assert!(
        every_tile
            .windows(2)
            .all(|w| w[0].1 < w[1].1 && w[0].3 <= w[1].3),
        "samples and rays grow from one showing to the next: {every_tile:?}"
    );
}

/// Records, for each phase begun, how many threads rayon's pool has where it begins.
#[derive(Default)]
struct PoolSizes(std::sync::Mutex<Vec<(String, usize)>>);

impl raylink::control::Progress for PoolSizes {
    fn begin(&self, phase: &str, _total: Option<u64>, _unit: &str) {
        let mut seen = self.0.lock().unwrap();
        seen.push((phase.to_string(), rayon::current_num_threads()));
    }
}

/// Every phase of a job runs on the job's threads, not on every core: the intersection
/// structure's build and the network's preprocess and distribution begin inside a pool of
/// exactly `Job::threads` workers (3 and 1 here, neither of them this machine's count by
/// chance alone), and with `None` on rayon's global pool.
#[test]
fn preparation_runs_on_the_jobs_threads() {
    let office = scene("network-office.toml");
    let settings = Settings {
        integrator: Some(TechniqueKind::Network),
        intercept_step: Some(1.0 / 16.0),
        slopes: Some(4),
        ..Settings::default()
    };
    for threads in [Some(3), Some(1), None] {
        let sizes = Arc::new(PoolSizes::default());
        let control = Control {
            progress: sizes.clone(),
            ..Control::default()
        };
        let job = Job {
            threads,
            ..job(&office, settings.clone(), (16, 12))
        };
        let mut renderer = Renderer::new(office.clone(), job, &control).unwrap();
        renderer.prepare(&control).unwrap();
        let seen = sizes.0.lock().unwrap().clone();
        let phases: Vec<&str> = seen.iter().map(|(p, _)| p.as_str()).collect();
        assert!(
            phases.contains(&"building") && phases.len() >= 3,
            "{phases:?}"
        );
        let want = threads.unwrap_or_else(|| {
            rayon::ThreadPoolBuilder::new()
                .build()
                .unwrap()
                .current_num_threads()
        });
        for (phase, n) in &seen {
            assert_eq!(*n, want, "{threads:?}: phase {phase}");
        }
    }
}
