//! Irradiance caching against path tracing where it should pay: `scenes/indirect-room.toml`,
//! a room lit only by light bounced off its ceiling (issue 5's benchmark).
//!
//! `cargo bench --bench irradiance_cache` renders the room at 256x192 with the irradiance
//! cache and with the path tracer at doubling sample counts, all on every core, and reports
//! each one's time and RMSE against a converged path-traced reference (box-downsampled to
//! 128x96 for the comparison, which halves the reference's own noise), then the time the
//! path tracer needs to reach the cache's error (interpolated between the two sample counts
//! that bracket it, error ∝ time^-1/2 between them) and the speedup.
//!
//! The reference is the stored `tests/data/indirect-room-reference-128x96.exr` (4096 spp with
//! another seed, box-downsampled to 128x96; tests/data/README.md says how it was made). With
//! `RAYLINK_IC_REFERENCE` set, it is that file instead (at 256x192, or already at 128x96);
//! when that file is missing the reference is rendered at 256x192 (6 to 15 minutes on 2
//! cores) and kept there.
//!
//! The same race runs on the Cornell box at 256x256 against Tungsten's render
//! (`scenes/cornell-box-bitterli/TungstenRender-256.exr`, box-downsampled from 1024x1024, the
//! light's pixels excluded), where issue 5 quotes Radiance 5.4 at RMSE 0.0056 in 247 s.

use raylink::image::compare::{box_downsample, bright_mask, rmse};
use raylink::image::filter::Filter;
use raylink::{read_image, write_image, Control, Image, Job, OutputOptions, Renderer};
use raylink::{Scene, Settings, Technique, TechniqueKind};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

const WIDTH: u32 = 256;
const HEIGHT: u32 = 192;
const REFERENCE_SPP: u32 = 4096;
/// The room's reference, rendered by the path tracer at 4096 spp and 256x192 and
/// box-downsampled to 128x96 (tests/data/README.md).
const STORED_REFERENCE: &str = "tests/data/indirect-room-reference-128x96.exr";

/// A render of `scene` at `size` with `settings` (a box filter, every core): its image and
/// seconds, and the technique's report.
fn render(
    scene: &Arc<Scene>,
    size: (u32, u32),
    settings: Settings,
    seed: u64,
) -> (Image, f64, Vec<String>) {
    let settings = Settings {
        filter: Some(Filter::Box { radius: 0.5 }),
        ..settings
    };
    let job = Job {
        width: size.0,
        height: size.1,
        seed,
        ..Job::new(scene, Technique::create(&settings).unwrap())
    };
    let control = Control::default();
    let start = Instant::now();
    let mut renderer = Renderer::new(scene.clone(), job, &control).unwrap();
    let image = renderer.render(&control).unwrap().image;
    (image, start.elapsed().as_secs_f64(), renderer.report())
}

/// The settings of a cache render.
#[derive(Clone, Copy)]
struct Cache {
    spp: u32,
    bounces: u32,
    samples: u32,
    accuracy: f32,
    ar: f32,
    gradients: bool,
}

impl Cache {
    fn settings(&self) -> Settings {
        Settings {
            integrator: Some(TechniqueKind::IrradianceCache),
            spp: Some(self.spp),
            ab: Some(self.bounces),
            ic_samples: Some(self.samples),
            ic_accuracy: Some(self.accuracy),
            ar: Some(self.ar),
            ic_gradients: Some(self.gradients),
            ..Settings::default()
        }
    }
}

fn half(image: &Image) -> Image {
    box_downsample(image, image.width / 2, image.height / 2).expect("even size")
}

fn path_trace(scene: &Arc<Scene>, size: (u32, u32), spp: u32, seed: u64) -> (Image, f64) {
    let settings = Settings {
        integrator: Some(TechniqueKind::Path),
        spp: Some(spp),
        max_depth: Some(8),
        ..Settings::default()
    };
    let (image, seconds, _) = render(scene, size, settings, seed);
    (image, seconds)
}

/// The room's reference at 128x96 (see the module's documentation).
fn room_reference(scene: &Arc<Scene>) -> Image {
    let Some(path) = std::env::var_os("RAYLINK_IC_REFERENCE").map(PathBuf::from) else {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(STORED_REFERENCE);
        let (image, _) = read_image(&path).unwrap_or_else(|e| panic!("{e}"));
        eprintln!("reference: {}", path.display());
        return image;
    };
    let image = match read_image(&path) {
        Ok((image, _)) => {
            eprintln!("reference: {}", path.display());
            image
        }
        Err(_) => {
            eprintln!(
                "rendering the reference ({REFERENCE_SPP} spp) to {}",
                path.display()
            );
            let (image, seconds) = path_trace(scene, (WIDTH, HEIGHT), REFERENCE_SPP, 99);
            eprintln!("reference rendered in {seconds:.0} s");
            let options = OutputOptions::new(0.0, false);
            write_image(&path, &image, &[], &options).unwrap();
            image
        }
    };
    match (image.width, image.height) {
        (WIDTH, HEIGHT) => half(&image),
        (w, h) if (w, h) == (WIDTH / 2, HEIGHT / 2) => image,
        (w, h) => panic!(
            "{}: {w}x{h}, not {WIDTH}x{HEIGHT} or {}x{}",
            path.display(),
            WIDTH / 2,
            HEIGHT / 2
        ),
    }
}

/// What a render is measured against: the reference, how a render is brought to its
/// resolution, and the reference pixels left out.
struct Target<'a> {
    reference: &'a Image,
    compare: &'a dyn Fn(&Image) -> Image,
    mask: Option<&'a [bool]>,
}

/// One scene's race: the cache at each setting, then the path tracer at doubling sample
/// counts until it reaches the best cache's error. `compare` maps a render to the
/// reference's resolution; `mask` excludes reference pixels.
fn race(
    title: &str,
    (scene, size): (&Arc<Scene>, (u32, u32)),
    target: Target,
    configs: &[Cache],
    max_spp: u32,
) {
    let Target {
        reference,
        compare,
        mask,
    } = target;
    println!("\n### {title}\n");
    println!("| render | time (s) | RMSE | cache |");
    println!("|---|---|---|---|");
    let mut best: Option<(f64, f64)> = None;
    for c in configs {
        let (image, seconds, report) = render(scene, size, c.settings(), 1);
        let error = rmse(&compare(&image), reference, mask);
        println!(
            "| irradiance cache, a {}, {} rays, ab {}, ar {}, gradients {}, {} spp | {seconds:.2} | \
             {error:.5} | {} |",
            c.accuracy,
            c.samples,
            c.bounces,
            c.ar,
            if c.gradients { "on" } else { "off" },
            c.spp,
            report.join("; ")
        );
        if best.is_none_or(|(t, e)| seconds * error * error < t * e * e) {
            best = Some((seconds, error));
        }
    }
    let (ic_seconds, target) = best.unwrap();

    let mut previous: Option<(f64, f64)> = None;
    let mut spp = 16;
    let mut reached = None;
    while spp <= max_spp {
        let (image, seconds) = path_trace(scene, size, spp, 1);
        let error = rmse(&compare(&image), reference, mask);
        println!("| path tracer, {spp} spp | {seconds:.2} | {error:.5} | |");
        if error <= target {
            // Between the two bracketing runs, error² · time is about constant.
            reached = Some(match previous {
                Some((t0, e0)) => {
                    let f = ((e0 / target).ln() / (e0 / error).ln()).clamp(0.0, 1.0);
                    t0 * (seconds / t0).powf(f)
                }
                None => seconds,
            });
            break;
        }
        previous = Some((seconds, error));
        spp *= 2;
    }
    match reached {
        Some(t) => println!(
            "\npath tracing reaches RMSE {target:.5} in about {t:.1} s: the irradiance cache \
             ({ic_seconds:.1} s) is {:.1}x faster",
            t / ic_seconds
        ),
        None => println!(
            "\npath tracing did not reach RMSE {target:.5} by {max_spp} spp: the irradiance \
             cache ({ic_seconds:.1} s) is faster than every path-traced render above"
        ),
    }
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = Arc::new(Scene::load(&root.join("scenes/indirect-room.toml")).unwrap());
    let reference = room_reference(&scene);
    // Radiance-style settings for an indirectly lit room: many bounces, many rays per
    // value, and a coarser minimum spacing (ar) than the defaults; the final pass needs few
    // samples since nothing in view is lit directly.
    let room = Cache {
        spp: 4,
        bounces: 7,
        samples: 2048,
        accuracy: 0.25,
        ar: 16.0,
        gradients: true,
    };
    let plain = Cache {
        gradients: false,
        ..room
    };
    race(
        "Indirectly lit room, 256x192 (RMSE at 128x96)",
        (&scene, (WIDTH, HEIGHT)),
        Target {
            reference: &reference,
            compare: &half,
            mask: None,
        },
        &[
            room,
            Cache { ar: 8.0, ..room },
            Cache { ar: 4.0, ..room },
            // The scene file's settings.
            Cache {
                samples: 1024,
                ar: 4.0,
                ..room
            },
            Cache {
                accuracy: 0.4,
                ..room
            },
            plain,
            Cache { ar: 8.0, ..plain },
            Cache { ar: 4.0, ..plain },
        ],
        REFERENCE_SPP / 4,
    );

    let cornell = Arc::new(Scene::load(&root.join("scenes/cornell-box.toml")).unwrap());
    let tungsten = root.join("scenes/cornell-box-bitterli/TungstenRender-256.exr");
    let (reference, _) = read_image(&tungsten).unwrap_or_else(|e| panic!("{e}"));
    let mask = bright_mask(&reference, 1.0);
    let box_cache = Cache {
        spp: 16,
        bounces: 5,
        samples: 512,
        accuracy: 0.15,
        ar: 16.0,
        gradients: true,
    };
    race(
        "Cornell box, 256x256, against Tungsten (light pixels excluded)",
        (&cornell, (256, 256)),
        Target {
            reference: &reference,
            compare: &|image: &Image| image.clone(),
            mask: Some(&mask),
        },
        &[
            box_cache,
            Cache {
                bounces: 8,
                ar: 32.0,
                samples: 1024,
                ..box_cache
            },
            Cache {
                gradients: false,
                ..box_cache
            },
        ],
        256,
    );
}
