//! The flux arriving at a set of surfaces (Dutré, Lafortune & Willems): gathering (path
//! tracing from the surfaces) and shooting (light tracing from the lights) against analytic
//! answers and against each other, on diffuse, glossy and specular scenes.

use raylink::flux::{estimate, Estimator, Flux, FluxJob};
use raylink::{Backend, Control, Scene};
use std::path::Path;

fn run(scene: &Scene, surfaces: &[usize], estimator: Estimator, depth: u32, paths: u64) -> Flux {
    let job = FluxJob {
        surfaces: surfaces.to_vec(),
        estimator,
        max_depth: depth,
        paths,
        seed: 7,
        threads: None,
        accel: Backend::Embree,
    };
    estimate(scene, &job, &Control::default()).unwrap()
}

fn scene(text: &str) -> Scene {
    raylink::scene::toml::from_str(text, Path::new("flux.toml")).unwrap()
}

/// A closed cube of grey walls from -1 to 1, and `inside`.
fn closed_cube(inside: &str) -> Scene {
    closed_box(0.5, inside)
}

/// A closed cube of walls of reflectance `wall` from -1 to 1, and `inside`.
fn closed_box(wall: f32, inside: &str) -> Scene {
    let quad = |v: [[i32; 3]; 4]| {
        format!("[[shapes]]\ntype = \"quad\"\nmaterial = \"wall\"\nvertices = {v:?}\n")
    };
    let walls = [
        quad([[-1, -1, -1], [1, -1, -1], [1, -1, 1], [-1, -1, 1]]),
        quad([[-1, 1, -1], [-1, 1, 1], [1, 1, 1], [1, 1, -1]]),
        quad([[-1, -1, -1], [-1, 1, -1], [1, 1, -1], [1, -1, -1]]),
        quad([[-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]]),
        quad([[-1, -1, -1], [-1, -1, 1], [-1, 1, 1], [-1, 1, -1]]),
        quad([[1, -1, -1], [1, 1, -1], [1, 1, 1], [1, -1, 1]]),
    ]
    .concat();
    scene(&format!(
        "[camera]\nposition = [0, 0, 0.5]\nlook_at = [0, 0, 0]\nwidth = 8\nheight = 8\n\
         [materials.wall]\ndiffuse = {wall}\n[materials.glow]\ndiffuse = 0\nemission = [2, 3, 4]\n\
         {walls}{inside}"
    ))
}

/// Asserts `f` is within `k` standard errors (plus a relative 1e-4 for rounding) of `value`.
fn assert_near(what: &str, f: &Flux, value: [f32; 3], k: f32) {
    for (c, v) in value.into_iter().enumerate() {
        let allowed = k * f.standard_error[c] + 1e-4 * v.abs();
        assert!(
            (f.flux[c] - v).abs() <= allowed,
            "{what}: channel {c}: {} ± {} against {v}",
            f.flux[c],
            f.standard_error[c],
        );
    }
}

/// Asserts two estimates agree within `k` combined standard errors, and that each error is
/// under `relative` of the value (so that the test has power).
fn assert_agree(what: &str, a: &Flux, b: &Flux, k: f32, relative: f32) {
    for c in 0..3 {
        let se = (a.standard_error[c].powi(2) + b.standard_error[c].powi(2)).sqrt();
        let d = a.flux[c] - b.flux[c];
        eprintln!(
            "{what}: channel {c}: {} ± {} against {} ± {} ({:.2} se)",
            a.flux[c],
            a.standard_error[c],
            b.flux[c],
            b.standard_error[c],
            d / se
        );
        assert!(
            d.abs() <= k * se,
            "{what}: channel {c} differs by {} se",
            d / se
        );
        for f in [a, b] {
            assert!(
                f.standard_error[c] < relative * f.flux[c],
                "{what}: error {} too large for {}",
                f.standard_error[c],
                f.flux[c]
            );
        }
    }
}

/// Gathering's batch standard error is trusted here because of the light's distance to the
/// walls, not measured: a gathering sample of a point light of intensity I is at most
/// I·A_S/h² (a point of S at distance h straight below the light), so a light close to S
/// gives a heavy tail that 64 batch means understate (most batches miss the few samples
/// that carry much of the flux). The light is kept at least 0.7 (over a third of a wall's
/// side) from every wall, which bounds every sample to under 5 times the mean (3.9 for the
/// walls, 2.5 for the floor, asserted): no sample holds more than 2% of its batch.
#[test]
fn a_point_light_in_a_closed_cube_sends_its_whole_power_to_the_walls() {
    // Straight from the light (no bounce), every direction reaches a wall: Φ = 4π I.
    let light = [0.2f32, -0.1, 0.3];
    let cube = closed_cube(&format!(
        "[[lights]]\ntype = \"point\"\nposition = {light:?}\nintensity = [1, 2, 3]\n"
    ));
    let nearest = light
        .iter()
        .map(|v| 1.0 - v.abs())
        .fold(f32::INFINITY, f32::min);
    assert!(nearest >= 0.7, "the light is {nearest} from a wall");
    // Largest sample over the mean: (I·A_S/h²) / Φ.
    let tail = |area: f32, h: f32, flux_over_i: f32| area / (h * h) / flux_over_i;
    assert!(tail(24.0, nearest, 4.0 * std::f32::consts::PI) < 5.0);
    let walls: Vec<usize> = (0..6).collect();
    let power = [1.0, 2.0, 3.0].map(|i: f32| 4.0 * std::f32::consts::PI * i);
    let gathered = run(&cube, &walls, Estimator::Gathering, 0, 20_000);
    let shot = run(&cube, &walls, Estimator::Shooting, 0, 2_000);
    assert_near("gathering", &gathered, power, 4.0);
    assert!(gathered.standard_error[0] < 0.02 * power[0]);
    assert_near("shooting", &shot, power, 4.0);
    // One wall alone: the light reaches the floor (y = -1, 0.9 below it) over the solid
    // angle of a 2x2 square seen off-centre, which both estimate alike.
    let gathered = run(&cube, &[0], Estimator::Gathering, 0, 40_000);
    let shot = run(&cube, &[0], Estimator::Shooting, 0, 40_000);
    assert_agree("floor", &gathered, &shot, 4.0, 0.02);
    let solid_angle = rectangle_solid_angle([-1.2, 0.8], [-1.3, 0.7], 0.9);
    assert!(tail(4.0, 0.9, solid_angle) < 5.0);
    let expected = [1.0, 2.0, 3.0].map(|i| i * solid_angle);
    assert_near("floor, analytic, shooting", &shot, expected, 4.0);
    assert_near("floor, analytic, gathering", &gathered, expected, 4.0);
}

/// Solid angle of the rectangle [x0, x1] × [z0, z1] in a plane at distance `h`, seen from
/// the origin's projection onto it (Van Oosterom–Strackee over its two triangles).
fn rectangle_solid_angle(x: [f32; 2], z: [f32; 2], h: f32) -> f32 {
    let corner = |x: f32, z: f32| [x as f64, -h as f64, z as f64];
    let c = [
        corner(x[0], z[0]),
        corner(x[1], z[0]),
        corner(x[1], z[1]),
        corner(x[0], z[1]),
    ];
    let tri = |a: [f64; 3], b: [f64; 3], c: [f64; 3]| {
        let len = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let dot = |u: [f64; 3], v: [f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
        let cross = [
            b[1] * c[2] - b[2] * c[1],
            b[2] * c[0] - b[0] * c[2],
            b[0] * c[1] - b[1] * c[0],
        ];
        let num = dot(a, cross).abs();
        let den =
            len(a) * len(b) * len(c) + dot(a, b) * len(c) + dot(a, c) * len(b) + dot(b, c) * len(a);
        2.0 * num.atan2(den)
    };
    (tri(c[0], c[1], c[2]) + tri(c[0], c[2], c[3])) as f32
}

#[test]
fn an_area_light_in_a_closed_cube_sends_its_whole_power_to_the_walls() {
    // A one-sided emitter of radiance Le and area A facing down: Φ = π Le A, all of it
    // arriving at the walls before any bounce.
    let cube = closed_cube(
        "[[shapes]]\ntype = \"quad\"\nmaterial = \"glow\"\n\
         vertices = [[-0.25, 0.9, -0.25], [0.25, 0.9, -0.25], [0.25, 0.9, 0.25], [-0.25, 0.9, 0.25]]\n",
    );
    let walls: Vec<usize> = (0..6).collect();
    let power = [2.0, 3.0, 4.0].map(|le: f32| std::f32::consts::PI * le * 0.25);
    let shot = run(&cube, &walls, Estimator::Shooting, 0, 2_000);
    assert_near("shooting", &shot, power, 4.0);
    let gathered = run(&cube, &walls, Estimator::Gathering, 0, 100_000);
    assert_near("gathering", &gathered, power, 4.0);
    // With bounces, walls of albedo 0.5 receive the light again and again: the flux
    // arriving is the geometric series P·(1 + 0.5 + 0.25 + ...) = 2P, less what the
    // emitter's own surface (black, albedo 0) catches; both estimators must agree.
    let gathered = run(&cube, &walls, Estimator::Gathering, 64, 100_000);
    let shot = run(&cube, &walls, Estimator::Shooting, 64, 100_000);
    assert_agree("bounces", &gathered, &shot, 4.0, 0.02);
    for (c, p) in power.into_iter().enumerate() {
        assert!(shot.flux[c] > 1.8 * p && shot.flux[c] < 2.0 * p);
    }
}

fn cornell_spheres() -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-spheres.toml")).unwrap()
}

#[test]
fn gathering_and_shooting_agree_on_glossy_and_specular_surfaces() {
    // Shapes of cornell-spheres.toml: 0 rough gold, 1 mirror, 2 glass, 3 floor (lit through
    // the glass: caustics), 4 ceiling, 5 back wall, 6 right wall, 7 left wall, 8 light.
    let scene = cornell_spheres();
    for (what, surfaces) in [
        ("rough gold sphere", vec![0]),
        ("mirror and glass spheres", vec![1, 2]),
        ("floor", vec![3]),
    ] {
        let gathered = run(&scene, &surfaces, Estimator::Gathering, 8, 200_000);
        let shot = run(&scene, &surfaces, Estimator::Shooting, 8, 200_000);
        assert_agree(what, &gathered, &shot, 4.0, 0.03);
    }
}

#[test]
fn estimates_do_not_depend_on_the_thread_count() {
    let scene = cornell_spheres();
    for estimator in [Estimator::Gathering, Estimator::Shooting] {
        let job = |threads| FluxJob {
            surfaces: vec![3, 2],
            estimator,
            max_depth: 5,
            paths: 3_000,
            seed: 11,
            threads: Some(threads),
            accel: Backend::Embree,
        };
        let one = estimate(&scene, &job(1), &Control::default()).unwrap();
        let two = estimate(&scene, &job(2), &Control::default()).unwrap();
        assert_eq!(
            one.flux.to_array().map(f32::to_bits),
            two.flux.to_array().map(f32::to_bits)
        );
        assert_eq!(one.rays, two.rays);
    }
}

#[test]
fn bad_sets_and_counts_are_errors() {
    let scene = cornell_spheres();
    let job = |surfaces: Vec<usize>, paths| FluxJob {
        surfaces,
        estimator: Estimator::Shooting,
        max_depth: 1,
        paths,
        seed: 0,
        threads: Some(1),
        accel: Backend::Embree,
    };
    for (bad, needle) in [
        (job(vec![], 100), "no surface"),
        (job(vec![99], 100), "shape 99"),
        (job(vec![3, 3], 100), "twice"),
        (job(vec![3], 10), "paths"),
    ] {
        let e = estimate(&scene, &bad, &Control::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains(needle), "{e}");
    }
}

/// Two patches of the cube's floor and ceiling with a ball between them that hides each from
/// the other: `ball` is its material. Patch `source` glows (radiance 1 on both sides), the
/// other does not; neither reflects. Shapes: 0-5 walls, 6 the ball, 7 and 8 the patches.
fn two_patches(ball: &str, source: usize) -> Scene {
    let patch = |i: usize, y: f32, x: [f32; 2]| {
        let m = if i == source { "on" } else { "off" };
        format!(
            "[[shapes]]\ntype = \"quad\"\nmaterial = \"{m}\"\nvertices = [[{a}, {y}, -0.3], \
             [{b}, {y}, -0.3], [{b}, {y}, 0.3], [{a}, {y}, 0.3]]\n",
            a = x[0],
            b = x[1]
        )
    };
    closed_box(
        0.1,
        &format!(
            "[materials.ball]\n{ball}\n[materials.on]\ndiffuse = 0\nemission = 1\n\
             two_sided_emission = true\n[materials.off]\ndiffuse = 0\n\
             [[shapes]]\ntype = \"sphere\"\nmaterial = \"ball\"\ncenter = [0, 0, 0]\n\
             radius = 0.6\n{}{}",
            patch(7, -0.8, [-0.9, -0.3]),
            patch(8, 0.8, [0.3, 0.9])
        ),
    )
}

/// The GRDF is symmetric (Dutré, Lafortune & Willems; reciprocity of every BSDF in the
/// path): the flux patch 8 receives when patch 7 glows equals the flux patch 7 receives when
/// 8 glows, each estimated by both adjoint estimators (gathering at the receiver, shooting
/// from the source). The light between them goes around or through a rough metal ball
/// (glossy) or a glass ball (specular, refraction both ways), and off dim walls. A black ball
/// changes the flux by more than a fifth: the ball's transport is a large part of what is
/// compared.
#[test]
fn the_grdf_between_two_patches_is_symmetric() {
    for (what, ball) in [
        ("glossy", "diffuse = 0\nspecular = 0.9\nroughness = 0.25"),
        (
            "glass",
            "diffuse = 0\nspecular = 1\ntransmission = 1\nfresnel = true\nior = 1.5",
        ),
    ] {
        // Shooting finds the small receiver less often: it takes more paths.
        let flux = |source: usize, receiver: usize, estimator| {
            let paths = match estimator {
                Estimator::Gathering => 400_000,
                Estimator::Shooting => 1_600_000,
            };
            run(&two_patches(ball, source), &[receiver], estimator, 8, paths)
        };
        let there = flux(7, 8, Estimator::Gathering);
        let back = flux(8, 7, Estimator::Gathering);
        assert_agree(
            &format!("{what}: 7 to 8, 8 to 7, gathered"),
            &there,
            &back,
            4.0,
            0.02,
        );
        let there_shot = flux(7, 8, Estimator::Shooting);
        let back_shot = flux(8, 7, Estimator::Shooting);
        assert_agree(
            &format!("{what}: 7 to 8, 8 to 7, shot"),
            &there_shot,
            &back_shot,
            4.0,
            0.03,
        );
        assert_agree(
            &format!("{what}: 7 to 8 gathered, shot"),
            &there,
            &there_shot,
            4.0,
            0.03,
        );
        let black = run(
            &two_patches("diffuse = 0", 7),
            &[8],
            Estimator::Gathering,
            8,
            400_000,
        );
        for c in 0..3 {
            assert!(
                (there.flux[c] - black.flux[c]).abs() > 0.2 * there.flux[c],
                "{what}: channel {c}: {} with the ball, {} with a black one",
                there.flux[c],
                black.flux[c]
            );
        }
    }
}
