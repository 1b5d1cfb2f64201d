//! Motion blur: a sphere moving across the shutter against the analytic streak it leaves,
//! both intersection backends meeting moving shapes where they are at the ray's time, the
//! same image for any thread count, pbrt's `ActiveTransform EndTime` against the TOML
//! `motion` key, and a bad `motion` refused with one line.

use raylink::accel::{self, Backend};
use raylink::image::Image;
use raylink::math::{Ray, Vec3};
use raylink::scene::{Geometry, Scene, Sphere};
use raylink::{Control, Technique};
use std::path::Path;

mod common;
#[path = "common/render.rs"]
mod render_common;
use render_common::{boxed, image, View};

/// Pixels per scene unit of the streak scene: an orthographic view 8 units across 128 pixels.
const SCALE: f64 = 16.0;
/// The sphere's radius and its displacement over the shutter, in scene units.
const RADIUS: f64 = 0.5;
const DISPLACEMENT: f64 = 3.0;
const START_X: f64 = -1.5;

/// A black sphere in front of a white background (radiance 1), moving along +x by
/// `DISPLACEMENT` while the shutter is open, seen by an orthographic camera: one minus the
/// image is the fraction of the shutter the sphere covers each point.
fn streak_toml() -> String {
    format!(
        "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nwidth = 128\nheight = 32\n\
         projection = \"orthographic\"\nsize = 8\n\
         [world]\nbackground = [1, 1, 1]\n[materials.black]\ndiffuse = 0\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [{START_X}, 0, 0]\nradius = {RADIUS}\n\
         material = \"black\"\nmotion = {{ translate = [{DISPLACEMENT}, 0, 0] }}\n"
    )
}

fn parse(text: &str) -> Scene {
    raylink::scene::toml::from_str(text, Path::new("motion.toml")).unwrap()
}

fn render(scene: &Scene, backend: Backend, threads: usize, spp: u32) -> Image {
    let view = View::of(scene, 11, Some(threads), backend);
    image(scene, Technique::Path(boxed(1, spp)), view)
}

/// The exact box-filtered image of the streak: at each of 16x16 points of a pixel, the
/// fraction of the shutter during which the sphere covers it (a point at height y is inside
/// while the centre is within the half chord √(r² − y²) of it).
fn analytic(width: u32, height: u32) -> Vec<f64> {
    let n = 16;
    let mut out = Vec::with_capacity((width * height) as usize);
    for py in 0..height {
        for px in 0..width {
            let mut sum = 0.0;
            for j in 0..n {
                for i in 0..n {
                    let rx = px as f64 + (i as f64 + 0.5) / n as f64;
                    let ry = py as f64 + (j as f64 + 0.5) / n as f64;
                    let x = (rx - width as f64 / 2.0) / SCALE;
                    let y = (height as f64 / 2.0 - ry) / SCALE;
                    if y.abs() >= RADIUS {
                        continue;
                    }
                    let h = (RADIUS * RADIUS - y * y).sqrt();
                    let t0 = ((x - h - START_X) / DISPLACEMENT).max(0.0);
                    let t1 = ((x + h - START_X) / DISPLACEMENT).min(1.0);
                    sum += (t1 - t0).max(0.0);
                }
            }
            out.push(sum / (n * n) as f64);
        }
    }
    out
}

/// The mean of rows `rows` at each column.
fn profile(values: impl Fn(u32, u32) -> f64, width: u32, rows: &[u32]) -> Vec<f64> {
    (0..width)
        .map(|x| rows.iter().map(|&y| values(x, y)).sum::<f64>() / rows.len() as f64)
        .collect()
}

/// The width of the part of `p` at or above `level`, its ends placed by linear interpolation
/// between columns (pixel centres).
fn width_above(p: &[f64], level: f64) -> f64 {
    let first = p.iter().position(|&v| v >= level).unwrap();
    let last = p.iter().rposition(|&v| v >= level).unwrap();
    let left = first as f64 - (p[first] - level) / (p[first] - p[first - 1]);
    let right = last as f64 + (p[last] - level) / (p[last] - p[last + 1]);
    right - left
}

/// The streak of a sphere of radius r = 8 px moving d = 48 px: along its middle row the
/// profile is a trapezoid, 2r + d = 64 px wide at its foot, d = 48 at half its height,
/// 2r + d − 2r·2f wide at fraction f of its plateau, the plateau at 2r/d = 1/3 (the sphere
/// covers a point for a third of the shutter). Measured on both backends at 256 samples
/// per pixel: the widths at f = 1/4, 1/2, 3/4 within 0.5 px of the analytic ones, the
/// plateau within 2% of 1/3, every pixel within 0.04 of the exact box-filtered image, and
/// the image's total (the sphere's area, conserved by the blur) within 1%.
#[test]
fn a_moving_sphere_leaves_the_analytic_streak() {
    let scene = parse(&streak_toml());
    assert!(scene.moves());
    let (w, h) = (scene.camera.width, scene.camera.height);
    let exact = analytic(w, h);
    let rows = [h / 2 - 1, h / 2];
    let (diameter, travel) = (2.0 * RADIUS * SCALE, DISPLACEMENT * SCALE);
    let plateau = diameter / travel;
    let exact_profile = profile(|x, y| exact[(y * w + x) as usize], w, &rows);
    for backend in Backend::ALL {
        let image = render(&scene, backend, 2, 256);
        let value = |x: u32, y: u32| {
            let p = image.get(x, y);
            1.0 - (p.x + p.y + p.z) as f64 / 3.0
        };
        let measured = profile(value, w, &rows);
        for f in [0.25, 0.5, 0.75] {
            let got = width_above(&measured, f * plateau);
            let want = width_above(&exact_profile, f * plateau);
            let ideal = diameter + travel - 2.0 * diameter * f;
            eprintln!("{backend}: width at {f} of the plateau: {got:.2} px (exact {want:.2}, ideal {ideal:.1})");
            assert!(
                (got - want).abs() < 0.5,
                "{backend} at {f}: {got} vs {want}"
            );
            assert!(
                (want - ideal).abs() < 0.2,
                "the analytic image: {want} vs {ideal}"
            );
        }
        let middle = &measured[52..76];
        let mean = middle.iter().sum::<f64>() / middle.len() as f64;
        eprintln!("{backend}: plateau {mean:.4} (analytic {plateau:.4})");
        assert!(
            (mean / plateau - 1.0).abs() < 0.02,
            "{backend}: plateau {mean}"
        );
        let mut worst: f64 = 0.0;
        let mut total = 0.0;
        for y in 0..h {
            for x in 0..w {
                worst = worst.max((value(x, y) - exact[(y * w + x) as usize]).abs());
                total += value(x, y);
            }
        }
        let area = std::f64::consts::PI * (RADIUS * SCALE).powi(2);
        eprintln!("{backend}: worst pixel error {worst:.4}; total {total:.2} (area {area:.2})");
        assert!(worst < 0.04, "{backend}: a pixel is off by {worst}");
        assert!(
            (total / area - 1.0).abs() < 0.01,
            "{backend}: total {total}"
        );
    }
}

/// Both backends meet a moving sphere and a moving quad where they are at the ray's time:
/// rays down the middle of each shape's path at times 0, 1/4, 1/2, 1 hit it exactly when
/// it is over them, with the normal of the shape as it is then.
#[test]
fn backends_meet_moving_shapes_at_the_ray_time() {
    let scene = parse(
        "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\n\
         [materials.m]\ndiffuse = 0.5\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 0.5\nmaterial = \"m\"\n\
         motion = { translate = [4, 0, 0] }\n\
         [[shapes]]\ntype = \"quad\"\nvertices = [[-0.5, 3, 0], [0.5, 3, 0], [0.5, 4, 0], [-0.5, 4, 0]]\n\
         material = \"m\"\nmotion = [{ translate = [4, 0, 0] }, { translate = [0, 0, -1] }]\n",
    );
    let control = Control::default();
    for backend in Backend::ALL {
        let accel = accel::build(&scene, backend, &control).unwrap();
        for time in [0.0f32, 0.25, 0.5, 1.0] {
            let x = 4.0 * time;
            // A ray onto the sphere's centre, a little off its top so the normal tilts.
            let ray = Ray::new(Vec3::new(x, 0.3, 5.0), Vec3::NEG_Z).at_time(time);
            let hit = accel
                .intersect(&ray)
                .unwrap_or_else(|| panic!("{backend} t={time}"));
            let sp = hit.surface_point(&scene, &ray);
            assert_eq!(sp.shape, 0);
            let want_t = 5.0 - (0.25f32 - 0.09).sqrt();
            assert!(
                (hit.t - want_t).abs() < 1e-4,
                "{backend} t={time}: {}",
                hit.t
            );
            let want_n = Vec3::new(0.0, 0.3, 0.4).normalize();
            assert!(
                (sp.ns - want_n).length() < 1e-4,
                "{backend} t={time}: {}",
                sp.ns
            );
            // Where the sphere was at time 0 it no longer is.
            if time > 0.25 {
                let old = Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z).at_time(time);
                assert!(accel.intersect(&old).is_none(), "{backend} t={time}");
            }
            let ray = Ray::new(Vec3::new(x, 3.5, 5.0), Vec3::NEG_Z).at_time(time);
            let hit = accel
                .intersect(&ray)
                .unwrap_or_else(|| panic!("{backend} quad t={time}"));
            assert_eq!(hit.geom_id, 1);
            assert!(
                (hit.t - (5.0 + time)).abs() < 1e-4,
                "{backend} t={time}: {}",
                hit.t
            );
            assert!(accel.occluded(&ray), "{backend} t={time}");
            let beside = Ray::new(Vec3::new(x + 1.0, 3.5, 5.0), Vec3::NEG_Z).at_time(time);
            assert!(!accel.occluded(&beside), "{backend} t={time}");
        }
    }
}

/// The same motion-blurred image with one thread and with two, bit for bit, on both
/// backends (each sample's time comes from the sampler, not from the thread).
#[test]
fn motion_blur_does_not_depend_on_the_thread_count() {
    let scene = parse(&streak_toml());
    for backend in Backend::ALL {
        let one = render(&scene, backend, 1, 16);
        let two = render(&scene, backend, 2, 16);
        assert!(one.pixels == two.pixels, "{backend}: the images differ");
    }
}

/// pbrt's `ActiveTransform EndTime` + `Translate` moves a shape as the TOML `motion` does:
/// the same geometry at shutter open and close, and the same streak; `TransformTimes` and
/// the camera's shutter map scene time onto it (a shutter over the first half of the
/// motion gives half the displacement).
#[test]
fn pbrt_end_transforms_move_shapes_as_toml_motion_does() {
    let toml = parse(&streak_toml());
    let body = format!(
        "LightSource \"infinite\" \"rgb L\" [1 1 1]\n\
         AttributeBegin\nMaterial \"diffuse\" \"rgb reflectance\" [0 0 0]\n\
         Translate {START_X} 0 0\nActiveTransform EndTime\nTranslate {DISPLACEMENT} 0 0\n\
         ActiveTransform All\nShape \"sphere\" \"float radius\" {RADIUS}\nAttributeEnd\n"
    );
    let mut pbrt = common_pbrt::world(&body);
    assert_eq!(pbrt.shapes.len(), 1);
    let close = |a: &Geometry, b: &Geometry| match (a, b) {
        (
            Geometry::Sphere(Sphere { center, radius }),
            Geometry::Sphere(Sphere {
                center: c,
                radius: r,
            }),
        ) => (*center - *c).length() < 1e-5 && (radius - r).abs() < 1e-6,
        _ => false,
    };
    let (a, b) = (&pbrt.shapes[0], &toml.shapes[0]);
    assert!(close(&a.geometry, &b.geometry), "{a:?} vs {b:?}");
    assert!(
        close(a.motion.as_ref().unwrap(), b.motion.as_ref().unwrap()),
        "{a:?} vs {b:?}"
    );
    // Seen by the TOML scene's camera, the streaks agree.
    pbrt.camera = toml.camera.clone();
    let (x, y) = (
        render(&pbrt, Backend::Bvh, 2, 64),
        render(&toml, Backend::Bvh, 2, 64),
    );
    let diff: f64 = x
        .pixels
        .iter()
        .zip(&y.pixels)
        .map(|(p, q)| ((p.x - q.x).abs() + (p.y - q.y).abs() + (p.z - q.z).abs()) as f64)
        .sum::<f64>()
        / x.pixels.len() as f64;
    eprintln!("pbrt against TOML: mean absolute difference {diff:.2e}");
    assert!(diff < 1e-4, "mean difference {diff}");

    // TransformTimes 0 2 with the shutter open over [0, 1]: half the way.
    let half = common_pbrt::load(&format!(
        "Scale -1 1 1\nLookAt 0 0 5  0 0 0  0 1 0\nTransformTimes 0 2\n\
         Camera \"perspective\" \"float fov\" 40 \"float shutteropen\" 0 \"float shutterclose\" 1\n\
         WorldBegin\n{body}"
    ));
    match half.shapes[0].motion {
        Some(Geometry::Sphere(Sphere { center, .. })) => {
            assert!(
                (center.x as f64 - (START_X + DISPLACEMENT / 2.0)).abs() < 1e-5,
                "{center}"
            )
        }
        ref m => panic!("{m:?}"),
    }
}

/// A `motion` that is not a transform, or that mirrors, is refused with one line naming the
/// file, the line and the key, exit code 2.
#[test]
fn a_bad_motion_is_one_line_naming_the_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    for (name, motion, needle) in [
        (
            "short.toml",
            "{ translate = [3, 0] }",
            "motion = { translate",
        ),
        ("mirror.toml", "{ scale = [-1, 1, 1] }", "cannot mirror"),
        (
            "word.toml",
            "\"fast\"",
            "expected a table or an array of tables",
        ),
    ] {
        let path = dir.path().join(name);
        std::fs::write(
            &path,
            format!(
                "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\
                 [materials.m]\ndiffuse = 0.5\n\
                 [[shapes]]\ntype = \"sphere\"\nmaterial = \"m\"\nmotion = {motion}\n"
            ),
        )
        .unwrap();
        let out = dir.path().join("out.png");
        let result = common::raylink(&[
            "render",
            "--quiet",
            "-o",
            out.to_str().unwrap(),
            path.to_str().unwrap(),
        ]);
        common::assert_clean_failure_of(name, &result, &[name, "line 9", needle]);
        assert!(!out.exists());
    }
}

/// The irradiance cache keeps values per point: it renders a moving scene as it is at
/// shutter open, the same image as the scene without `motion`.
#[test]
fn the_irradiance_cache_renders_the_scene_at_shutter_open() {
    let moving = parse(&streak_toml());
    let still = moving.at_shutter_open().into_owned();
    assert!(!still.moves());
    let render = |scene: &Scene| {
        let technique = Technique::create(&raylink::Settings {
            integrator: Some(raylink::TechniqueKind::IrradianceCache),
            spp: Some(4),
            ..raylink::Settings::default()
        })
        .unwrap();
        let view = View {
            size: (64, 16),
            seed: 5,
            threads: Some(2),
            accel: Backend::Bvh,
        };
        image(scene, technique, view)
    };
    let (a, b) = (render(&moving), render(&still));
    assert!(a.pixels == b.pixels, "the cache blurred the moving sphere");
    assert!(a.pixels.iter().any(|p| p.x < 0.5), "the sphere is in view");
}

/// `raylink convert` writes a pbrt shape's translation over the shutter as the TOML
/// `motion`: the converted scene moves the same way; a rotation it cannot write is an error.
#[test]
fn convert_writes_a_translation_as_motion() {
    let dir = tempfile::tempdir().unwrap();
    let (input, output) = (dir.path().join("in.pbrt"), dir.path().join("out.toml"));
    let scene = |motion: &str| {
        format!(
            "{}AttributeBegin\nActiveTransform EndTime\n{motion}\nActiveTransform All\n\
             Shape \"sphere\" \"float radius\" 0.5\nShape \"bilinearmesh\" \"point3 P\" \
             [0 0 0 1 0 0 0 1 0 1 1 0]\nAttributeEnd\n",
            common_pbrt::HEADER
        )
    };
    std::fs::write(&input, scene("Translate 1 2 0")).unwrap();
    let read = raylink::scene::convert::convert(&input, &output).unwrap();
    let written = Scene::load(&output).unwrap();
    assert_eq!(read.shapes.len(), written.shapes.len());
    for (a, b) in read.shapes.iter().zip(&written.shapes) {
        assert!(a.motion.is_some());
        let (end_a, end_b) = (a.motion.as_ref().unwrap(), b.motion.as_ref().unwrap());
        let (lo_a, hi_a) = end_a.bounds();
        let (lo_b, hi_b) = end_b.bounds();
        assert!((lo_a - lo_b).length() < 1e-5 && (hi_a - hi_b).length() < 1e-5);
    }
    std::fs::write(&input, scene("Rotate 30 0 0 1")).unwrap();
    let e = raylink::scene::convert::convert(&input, &output).unwrap_err();
    assert!(e.to_string().contains("more than a translation"), "{e}");
}

/// Light samples are taken on still emitters, so an emitter does not move: in TOML its
/// `motion` is an error naming the file and line; in pbrt (as pbrt-v4 has no moving area
/// lights) a warning naming the line, and the shape stays where it is at shutter open.
#[test]
fn emitters_do_not_move() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lamp.toml");
    std::fs::write(
        &path,
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\
         [materials.lamp]\nemission = 2\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"lamp\"\n\
         motion = { translate = [1, 0, 0] }\n",
    )
    .unwrap();
    let out = dir.path().join("out.png");
    let result = common::raylink(&[
        "render",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
        path.to_str().unwrap(),
    ]);
    common::assert_clean_failure_of(
        "moving lamp",
        &result,
        &["lamp.toml", "line 9", "an emitting shape cannot move"],
    );
    let pbrt = common_pbrt::world(
        "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1]\n\
         ActiveTransform EndTime\nTranslate 1 0 0\nActiveTransform All\n\
         Shape \"sphere\" \"float radius\" 0.5\nAttributeEnd\n",
    );
    assert!(pbrt.shapes[0].motion.is_none());
    assert!(
        pbrt.warnings
            .iter()
            .any(|w| w.contains(":10: ") && w.contains("a moving area light is not supported")),
        "{:?}",
        pbrt.warnings
    );
}

#[path = "common/pbrt.rs"]
mod common_pbrt;
