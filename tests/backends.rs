//! The pure-Rust BVH against Embree: the same closest primitive, distance, barycentrics and
//! normal orientation on random rays and the same occlusion answers, up to floating-point
//! ties (which are counted and bounded); Whitted images that match; Monte Carlo images that
//! agree in the mean (a path that meets a tie continues another way).
#![cfg(feature = "embree")]

#[path = "common/render.rs"]
mod render_common;

use raylink::accel::bvh::BvhAccel;
use raylink::accel::embree::EmbreeAccel;
use raylink::accel::{Accel, Backend, Hit};
use raylink::bench::{rays, scenes};
use raylink::image::Image;
use raylink::math::{Ray, Rgb, Rng, Vec3};
use raylink::scene::{Camera, Geometry, Material, QuadMesh, Scene, Shape, Sphere};
use raylink::{Settings, Technique, TechniqueKind};
use render_common::{image, View};
use std::path::Path;

fn load(name: &str) -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join(name)).unwrap()
}

/// A scene built to stress the primitive tests: non-rectangular planar quads, a fan of thin
/// triangles sharing a vertex, overlapping spheres (one containing the other's centre), a
/// tiny sphere and a large one, and geometry touching.
fn mixed_scene() -> Scene {
    let mut shapes = Vec::new();
    // Planar quads: a trapezoid, a parallelogram and a kite-like convex quad, in tilted planes.
    let quads = QuadMesh {
        positions: vec![
            Vec3::new(-2.0, 0.0, -2.0),
            Vec3::new(2.0, 0.0, -2.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(-1.0, 0.0, 1.0),
            Vec3::new(-2.0, 0.5, 2.0),
            Vec3::new(0.0, 1.5, 2.5),
            Vec3::new(1.0, 2.5, 2.5),
            Vec3::new(-1.0, 1.5, 2.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(3.0, 1.0, 0.0),
            Vec3::new(3.0, 3.0, 0.0),
            Vec3::new(1.5, 1.5, 0.0),
        ],
        indices: vec![[0, 1, 2, 3], [4, 5, 6, 7], [8, 9, 10, 11]],
    };
    shapes.push(Shape {
        media: None,
        geometry: Geometry::Quads(quads),
        material: 0,
        alpha: None,
        motion: None,
    });
    // A fan of 24 thin triangles around (0, 1, -1).
    let centre = Vec3::new(0.0, 1.0, -1.0);
    let mut positions = vec![centre];
    let mut indices = Vec::new();
    for i in 0..=24 {
        let a = i as f32 / 24.0 * std::f32::consts::TAU;
        positions.push(centre + Vec3::new(a.cos(), a.sin(), 0.3 * (3.0 * a).sin()) * 1.2);
        if i > 0 {
            indices.push([0, i as u32, i as u32 + 1]);
        }
    }
    shapes.push(scenes::mesh_shape(positions, indices));
    for (c, r) in [
        (Vec3::new(-1.0, 1.0, 0.5), 0.6),
        (Vec3::new(-0.6, 1.2, 0.6), 0.5),
        (Vec3::new(1.5, 0.3, 1.5), 0.01),
        (Vec3::new(0.0, -6.0, 0.0), 5.5),
    ] {
        shapes.push(Shape {
            media: None,
            geometry: Geometry::Sphere(Sphere {
                center: c,
                radius: r,
            }),
            material: 0,
            alpha: None,
            motion: None,
        });
    }
    Scene {
        media: Vec::new(),
        camera_medium: None,
        source: "mixed".into(),
        camera: Camera {
            position: Vec3::new(0.0, 2.0, 6.0),
            look_at: Vec3::new(0.0, 0.5, 0.0),
            up: Vec3::Y,
            fov_deg: 50.0,
            width: 64,
            height: 48,
            projection: raylink::scene::Projection::Pinhole,
        },
        materials: vec![Material::default()],
        shapes,
        prototypes: Vec::new(),
        instances: Vec::new(),
        lights: Vec::new(),
        ambient: Rgb::splat(0.1),
        background: Rgb::ZERO,
        settings: Default::default(),
        setting_sources: Vec::new(),
        output: None,
        color_space: None,
        inputs: Vec::new(),
        environment: None,
        warnings: Vec::new(),
    }
}

/// Random rays: origins uniform in the scene's bounds grown by a quarter on each side,
/// directions uniform on the sphere (and some exactly along an axis, with signed zeros).
fn random_rays(scene: &Scene, count: usize, seed: u64) -> Vec<Ray> {
    let (lo, hi) = scene.bounds().unwrap();
    let pad = (hi - lo) * 0.25 + Vec3::splat(1e-3);
    let (lo, hi) = (lo - pad, hi + pad);
    let mut rng = Rng::for_key(seed, &[]);
    (0..count)
        .map(|i| {
            let u = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
            let origin = lo + (hi - lo) * u;
            let dir = if i % 16 == 0 {
                // Axis-aligned, with -0.0 in the other components half of the time.
                let z = if i % 32 == 0 { -0.0 } else { 0.0 };
                let s = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
                match (i / 16) % 3 {
                    0 => Vec3::new(s, z, z),
                    1 => Vec3::new(z, s, z),
                    _ => Vec3::new(z, z, s),
                }
            } else {
                let z = 1.0 - 2.0 * rng.uniform();
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = std::f32::consts::TAU * rng.uniform();
                // Unnormalised directions as well: backends must not assume unit length.
                Vec3::new(r * phi.cos(), r * phi.sin(), z) * (0.5 + 2.0 * rng.uniform())
            };
            Ray::new(origin, dir)
        })
        .collect()
}

fn relative(a: f32, b: f32) -> f32 {
    (a - b).abs() / a.abs().max(b.abs()).max(1e-6)
}

/// Whether two hit distances along `ray` agree: within a relative 1e-4, or, for hits very
/// close to the origin, at points within 1e-6 of the scene's size of each other (float
/// cancellation makes tiny distances relatively inexact in both backends).
fn same_t(a: f32, b: f32, ray: &Ray, scene_size: f32) -> bool {
    relative(a, b) < 1e-4 || (a - b).abs() * ray.dir.length() < 1e-6 * scene_size
}

fn scene_size(scene: &Scene) -> f32 {
    scene.bounds().map_or(1.0, |(lo, hi)| (hi - lo).length())
}

/// What a comparison of closest hits found.
#[derive(Debug, Default)]
struct Agreement {
    rays: usize,
    hits: usize,
    /// Different primitives at the same distance (within the tolerance).
    ties: usize,
    /// One backend hit and the other missed.
    hit_miss: usize,
}

/// Compares closest hits ray by ray; panics on any disagreement that is not a tie.
fn compare_closest(
    scene_name: &str,
    size: f32,
    embree: &dyn Accel,
    bvh: &dyn Accel,
    rays: &[Ray],
) -> Agreement {
    let mut a = Agreement {
        rays: rays.len(),
        ..Default::default()
    };
    for (i, ray) in rays.iter().enumerate() {
        let (e, b) = (embree.intersect(ray), bvh.intersect(ray));
        match (e, b) {
            (None, None) => {}
            (Some(_), None) | (None, Some(_)) => a.hit_miss += 1,
            (Some(e), Some(b)) => {
                a.hits += 1;
                let ctx = || format!("{scene_name} ray {i} {ray:?}:\n embree {e:?}\n bvh    {b:?}");
                assert!(same_t(e.t, b.t, ray, size), "t differs: {}", ctx());
                if (e.geom_id, e.prim_id) != (b.geom_id, b.prim_id) {
                    a.ties += 1;
                    continue;
                }
                assert_same_surface(&e, &b, ctx);
            }
        }
    }
    a
}

fn assert_same_surface(e: &Hit, b: &Hit, ctx: impl Fn() -> String) {
    assert!(
        (e.u - b.u).abs() < 2e-4 && (e.v - b.v).abs() < 2e-4,
        "u, v differ: {}",
        ctx()
    );
    let (ne, nb) = (e.ng.normalize(), b.ng.normalize());
    assert!(ne.dot(nb) > 0.9999, "normals differ: {}", ctx());
}

fn backends(scene: &Scene) -> (EmbreeAccel, BvhAccel) {
    (
        EmbreeAccel::build(scene).unwrap(),
        BvhAccel::build(scene).unwrap(),
    )
}

fn test_scenes() -> Vec<(&'static str, Scene)> {
    vec![
        ("cornell-box", load("scenes/cornell-box.toml")),
        ("whitted", load("scenes/whitted.toml")),
        ("obj-demo", load("scenes/obj-demo.toml")),
        ("mixed", mixed_scene()),
        ("spheres-5k", scenes::sphere_field(5_000)),
        ("terrain-2k", scenes::terrain(2_000)),
    ]
}

#[test]
fn closest_hits_agree_on_random_rays() {
    for (name, scene) in test_scenes() {
        let (embree, bvh) = backends(&scene);
        let rays = random_rays(&scene, 20_000, 1);
        let a = compare_closest(name, scene_size(&scene), &embree, &bvh, &rays);
        eprintln!("{name}: {a:?}");
        // Random rays must hit something often enough for the comparison to mean anything.
        assert!(a.hits > a.rays / 10, "{name}: {a:?}");
        // Grazing rays along an edge or silhouette may go either way; they are rare.
        assert!(a.hit_miss * 1000 <= a.rays, "{name}: {a:?}");
        assert!(a.ties * 1000 <= a.rays, "{name}: {a:?}");
    }
}

/// The bench's ray sets (camera rays, then shadow and diffuse rays leaving surfaces from
/// offset origins) get the same answers: the queries integrators actually make.
#[test]
fn answers_agree_on_rays_leaving_surfaces() {
    for (name, scene) in test_scenes() {
        let (embree, bvh) = backends(&scene);
        let sets = rays::generate(&scene, &embree, 48, 36, 7);
        for set in [&sets.camera, &sets.diffuse] {
            let a = compare_closest(name, scene_size(&scene), &embree, &bvh, set);
            assert!(
                a.hit_miss * 1000 <= a.rays && a.ties * 1000 <= a.rays,
                "{name}: {a:?}"
            );
        }
        let differ = sets
            .shadow
            .iter()
            .filter(|r| embree.occluded(r) != bvh.occluded(r))
            .count();
        assert!(
            differ * 1000 <= sets.shadow.len(),
            "{name}: {differ} shadow answers differ"
        );
    }
}

#[test]
fn occlusion_agrees_on_random_segments() {
    for (name, scene) in test_scenes() {
        let (embree, bvh) = backends(&scene);
        let mut rng = Rng::for_key(2, &[]);
        let rays = random_rays(&scene, 20_000, 3);
        let (mut occluded, mut differ) = (0, 0);
        for (i, ray) in rays.iter().enumerate() {
            // Segments of random length, some open-ended.
            let ray = Ray {
                tmax: if i % 4 == 0 {
                    f32::INFINITY
                } else {
                    3.0 * rng.uniform()
                },
                ..*ray
            };
            let (e, b) = (embree.occluded(&ray), bvh.occluded(&ray));
            occluded += e as usize;
            if e != b {
                differ += 1;
                // Only near-ties may differ: the nearest surface sits at the segment's end.
                let t = embree
                    .intersect(&Ray {
                        tmax: f32::INFINITY,
                        ..ray
                    })
                    .map(|h| h.t);
                assert!(
                    t.is_some_and(|t| relative(t, ray.tmax) < 1e-4),
                    "{name}: occlusion differs on {ray:?} (closest hit {t:?})"
                );
            }
        }
        eprintln!(
            "{name}: {occluded} of {} occluded, {differ} differ",
            rays.len()
        );
        assert!(occluded > rays.len() / 20, "{name}: {occluded} occluded");
        assert!(differ * 1000 <= rays.len(), "{name}: {differ} differ");
    }
}

/// The interval [tmin, tmax] is honoured at both ends, including hits closer than obvhs's
/// built-in 1e-4 near clamp, and a sphere around the origin is hit from inside.
#[test]
fn ray_intervals_are_respected() {
    let scene = mixed_scene();
    let (embree, bvh) = backends(&scene);
    // The floor quad at y = 0 seen from just above, with a long direction vector: t ≈ 1e-6.
    let close = Ray {
        origin: Vec3::new(0.0, 1e-4, 0.0),
        dir: Vec3::new(0.0, -100.0, 0.0),
        tmin: 0.0,
        tmax: 1.0,
        time: 0.0,
    };
    for accel in [&embree as &dyn Accel, &bvh] {
        let hit = accel.intersect(&close).expect("the floor is just below");
        assert_eq!((hit.geom_id, hit.prim_id), (0, 0));
        assert!(relative(hit.t, 1e-6) < 1e-3, "t {}", hit.t);
        assert!(accel.occluded(&close));
        // tmin past the floor: the big sphere below is next.
        let past = Ray {
            tmin: 2e-6,
            tmax: f32::INFINITY,
            ..close
        };
        assert_eq!(accel.intersect(&past).map(|h| h.geom_id), Some(5));
        // tmax short of the floor: nothing.
        let short = Ray {
            tmax: 0.5e-6,
            ..close
        };
        assert!(accel.intersect(&short).is_none() && !accel.occluded(&short));
    }
    // From inside the sphere of radius 0.6 around (-1, 1, 0.5), off-centre by (-0.3, -0.1,
    // -0.1): the exit point at t = sqrt(0.6² − 0.1² − 0.1²) − 0.3, normal pointing outwards.
    let inside = Ray::new(Vec3::new(-1.3, 0.9, 0.4), Vec3::NEG_X);
    let exit = 0.34f32.sqrt() - 0.3;
    let (e, b) = (
        embree.intersect(&inside).unwrap(),
        bvh.intersect(&inside).unwrap(),
    );
    assert_eq!((e.geom_id, b.geom_id), (2, 2));
    assert!(
        relative(e.t, exit) < 1e-5 && relative(b.t, exit) < 1e-5,
        "{e:?} {b:?}"
    );
    assert!(e.ng.x < 0.0 && b.ng.x < 0.0);
}

/// Quads report the quad's index and Embree's quad parameterisation on both halves.
#[test]
fn quads_report_quad_uv_on_both_halves() {
    let scene = mixed_scene();
    let (embree, bvh) = backends(&scene);
    // The trapezoid (-2,0,-2) (2,0,-2) (1,0,1) (-1,0,1): hit points on either side of the
    // diagonal v1-v3.
    for p in [Vec3::new(-1.0, 0.0, -1.5), Vec3::new(0.8, 0.0, 0.5)] {
        let ray = Ray::new(p + Vec3::Y, Vec3::NEG_Y);
        let (e, b) = (
            embree.intersect(&ray).unwrap(),
            bvh.intersect(&ray).unwrap(),
        );
        assert_eq!((e.geom_id, e.prim_id), (0, 0));
        assert_eq!((b.geom_id, b.prim_id), (0, 0));
        assert_same_surface(&e, &b, || format!("{p}: embree {e:?}, bvh {b:?}"));
    }
}

#[test]
fn empty_scene_and_single_primitive() {
    let mut scene = mixed_scene();
    scene.shapes.clear();
    let (embree, bvh) = backends(&scene);
    let ray = Ray::new(Vec3::ZERO, Vec3::X);
    assert!(embree.intersect(&ray).is_none() && bvh.intersect(&ray).is_none());
    assert!(!embree.occluded(&ray) && !bvh.occluded(&ray));
    scene.shapes.push(Shape {
        media: None,
        geometry: Geometry::Sphere(Sphere {
            center: Vec3::new(3.0, 0.0, 0.0),
            radius: 1.0,
        }),
        material: 0,
        alpha: None,
        motion: None,
    });
    let (embree, bvh) = backends(&scene);
    let (e, b) = (
        embree.intersect(&ray).unwrap(),
        bvh.intersect(&ray).unwrap(),
    );
    assert!((e.t - 2.0).abs() < 1e-6 && (b.t - 2.0).abs() < 1e-6);
    assert!(e.ng.x < 0.0 && b.ng.x < 0.0);
}

/// Rebuilding after the geometry moved answers as a fresh build does (and not as before).
#[test]
fn rebuild_follows_moved_geometry() {
    let mut scene = scenes::sphere_field(3_000);
    let mut bvh = BvhAccel::build(&scene).unwrap();
    let rays = random_rays(&scene, 2_000, 9);
    let before: Vec<Option<Hit>> = rays.iter().map(|r| bvh.intersect(r)).collect();
    for shape in &mut scene.shapes {
        if let Geometry::Triangles(m) = &mut shape.geometry {
            for p in &mut m.positions {
                *p += Vec3::new(0.3, 0.2, -0.1);
            }
        }
    }
    bvh.rebuild(&scene).unwrap();
    let (embree, fresh) = backends(&scene);
    let mut changed = 0;
    for (ray, old) in rays.iter().zip(before) {
        let now = bvh.intersect(ray);
        assert_eq!(now, fresh.intersect(ray));
        changed += (now != old) as usize;
        assert_eq!(now.is_some(), embree.intersect(ray).is_some());
    }
    assert!(changed > 50, "only {changed} answers changed");
}

const W: u32 = 128;
const H: u32 = 96;

fn render_with(scene: &Scene, backend: Backend) -> Image {
    // Whitted with its defaults, one sample per pixel (uniform 1x1).
    let technique = Technique::create(&Settings {
        integrator: Some(TechniqueKind::Whitted),
        spp: Some(1),
        ..Settings::default()
    })
    .unwrap();
    let view = View {
        size: (W, H),
        seed: 3,
        threads: None,
        accel: backend,
    };
    image(scene, technique, view)
}

/// Whitted renders through both backends (128×96, one sample per pixel, area lights sampled):
/// RMSE below 1e-3 in radiance, and at least 99.5% of the pixels the same up to float noise
/// (every channel within 1e-4 relative). Bit-identical pixels cannot be asked for: Embree
/// divides with the CPU's approximate reciprocal (rcpps, which differs between CPU makers)
/// refined by a Newton step, so hit distances differ in their last bits and a near-tie can
/// go to another primitive.
#[test]
fn whitted_images_match_between_backends() {
    for name in [
        "scenes/cornell-box.toml",
        "scenes/whitted.toml",
        "scenes/obj-demo.toml",
    ] {
        let scene = load(name);
        let (e, b) = (
            render_with(&scene, Backend::Embree),
            render_with(&scene, Backend::Bvh),
        );
        let pixels = || (0..H).flat_map(|y| (0..W).map(move |x| (x, y)));
        let fraction = |same: &dyn Fn(Rgb, Rgb) -> bool| {
            pixels()
                .filter(|&(x, y)| same(e.get(x, y), b.get(x, y)))
                .count() as f64
                / (W * H) as f64
        };
        let identical = fraction(&|p, q| p == q);
        let close = fraction(&|p, q| (p - q).abs().max_element() <= 1e-4 * (1.0 + p.max_element()));
        let rmse = e.rmse(&b);
        eprintln!(
            "{name}: RMSE {rmse:.2e}; {:.2}% of pixels identical, {:.2}% within float noise",
            100.0 * identical,
            100.0 * close
        );
        assert!(rmse < 1e-3, "{name}: RMSE {rmse}");
        assert!(
            close > 0.995,
            "{name}: only {:.3}% of pixels match",
            100.0 * close
        );
    }
}

/// Path-traced images through both backends (cornell-spheres.toml, glossy, mirror and glass
/// spheres, 64×48, 16 samples a pixel, seed 3): their means agree within 4 standard errors
/// of the mean difference of a pixel, per channel. Pixel for pixel they need not: raylink
/// recomputes every hit on the primitive the backend found, so paths are the same bit for
/// bit until a ray meets a floating-point tie the two backends settle differently (Embree's
/// distances come from the CPU's approximate reciprocal), and past it the path continues
/// another way. (The pixels' sample streams are independent, so the pixels' differences
/// are independent draws, of mean zero when the backends agree in the mean.)
#[test]
fn monte_carlo_images_agree_in_the_mean_between_backends() {
    let (w, h) = (64u32, 48u32);
    let scene = load("scenes/cornell-spheres.toml");
    let render = |backend| {
        let technique = Technique::create(&Settings {
            integrator: Some(TechniqueKind::Path),
            spp: Some(16),
            max_depth: Some(8),
            ..Settings::default()
        })
        .unwrap();
        let view = View {
            size: (w, h),
            seed: 3,
            threads: None,
            accel: backend,
        };
        image(&scene, technique, view)
    };
    let (e, b) = (render(Backend::Embree), render(Backend::Bvh));
    let n = f64::from(w * h);
    let (mut identical, mut sum, mut sum_sq, mut total) = (0, [0.0f64; 3], [0.0f64; 3], [0.0; 3]);
    for y in 0..h {
        for x in 0..w {
            let (p, q) = (e.get(x, y), b.get(x, y));
            identical += usize::from(p == q);
            for c in 0..3 {
                let d = f64::from(p[c]) - f64::from(q[c]);
                sum[c] += d;
                sum_sq[c] += d * d;
                total[c] += f64::from(p[c]);
            }
        }
    }
    eprintln!(
        "{:.1}% of the pixels identical",
        100.0 * identical as f64 / n
    );
    for c in 0..3 {
        let mean = sum[c] / n;
        let se = ((sum_sq[c] / n - mean * mean).max(0.0) / (n - 1.0)).sqrt();
        let level = total[c] / n;
        eprintln!("channel {c}: mean {level:.4}, difference {mean:.2e} ± {se:.2e}");
        // The test has power: the standard error is a small part of the image's mean.
        assert!(se < 0.01 * level, "channel {c}: {se} against {level}");
        assert!(mean.abs() <= 4.0 * se, "channel {c}: {mean} ± {se}");
    }
}
