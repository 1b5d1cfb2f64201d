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

/// A horizontal rectangle at height `y` over `x` × `z`, of material `m`.
fn level_quad(m: &str, y: f32, x: [f32; 2], z: [f32; 2]) -> String {
    format!(
        "[[shapes]]\ntype = \"quad\"\nmaterial = \"{m}\"\nvertices = [[{a}, {y}, {c}], \
         [{b}, {y}, {c}], [{b}, {y}, {d}], [{a}, {y}, {d}]]\n",
        a = x[0],
        b = x[1],
        c = z[0],
        d = z[1]
    )
}

/// The two small patches of [`panel_between`]: (x range, z range, height), areas 0.16 and 0.12.
const PATCHES: [([f32; 2], [f32; 2], f32); 2] = [
    ([-0.75, -0.35], [-0.2, 0.2], 0.4),
    ([0.35, 0.65], [-0.1, 0.3], 0.0),
];

/// Two small horizontal patches of unequal size and height in the closed box (walls of
/// reflectance 0.1), hidden from each other by a black screen (the plane x = 0 from the
/// ceiling down to y = -0.4), over a panel of material `panel` just above the floor: light
/// goes from one patch to the other under the screen by the panel, or by the dim walls.
/// Patch `source` (0 or 1) glows with radiance 1 on both sides, the other is black.
/// Shapes: 0-5 walls, 6 the panel, 7 the screen, 8 and 9 the patches.
fn panel_between(panel: &str, source: usize) -> Scene {
    panel_in_box(0.1, panel, source)
}

/// [`panel_between`] with walls of reflectance `wall`.
fn panel_in_box(wall: f32, panel: &str, source: usize) -> Scene {
    let patches: String = PATCHES
        .iter()
        .enumerate()
        .map(|(i, &(x, z, y))| level_quad(if i == source { "on" } else { "off" }, y, x, z))
        .collect();
    closed_box(
        wall,
        &format!(
            "[materials.panel]\n{panel}\n[materials.on]\ndiffuse = 0\nemission = 1\n\
             two_sided_emission = true\n[materials.off]\ndiffuse = 0\n{}\
             [[shapes]]\ntype = \"quad\"\nmaterial = \"off\"\nvertices = [[0, -0.4, -1], \
             [0, 1, -1], [0, 1, 1], [0, -0.4, 1]]\n{patches}",
            level_quad("panel", -0.9, [-0.9, 0.9], [-0.9, 0.9]),
        ),
    )
}

/// The patch-averaged GRDF of two patches: the flux `f` received by one when the other
/// glows with radiance 1 on both sides, over the measure (projected solid angle times area,
/// both sides) of each, 2πA each: the mean of F_r(y ← ψ, x → θ) over the pair.
fn mean_grdf(f: &Flux) -> [f32; 3] {
    let area = |(x, z, _): ([f32; 2], [f32; 2], f32)| (x[1] - x[0]) * (z[1] - z[0]);
    let measure = PATCHES.map(|p| std::f32::consts::TAU * area(p));
    f.flux.to_array().map(|v| v / (measure[0] * measure[1]))
}

/// Asserts `a` and `b` agree within `k` combined standard errors, each under `error` of the
/// value, and differ by at most `relative` of their mean.
fn assert_within(what: &str, a: &Flux, b: &Flux, k: f32, error: f32, relative: f32) {
    assert_agree(what, a, b, k, error);
    for c in 0..3 {
        let d = (a.flux[c] - b.flux[c]).abs();
        assert!(
            d <= relative * 0.5 * (a.flux[c] + b.flux[c]),
            "{what}: channel {c}: {} against {}, more than {relative} apart",
            a.flux[c],
            b.flux[c]
        );
    }
}

/// The GRDF between two small patches (Dutré, Lafortune & Willems, F_r; areas 0.16 and 0.12,
/// unequal heights, each hidden from the other) by both adjoint estimators, each way: the
/// flux patch B receives when A glows, gathered at B (path tracing from B, which finds A by
/// its light sample or by hitting it) and shot from A (particles from A that arrive at B),
/// and the same with A and B exchanged. The GRDF is symmetric for reciprocal BSDFs, so the
/// four are estimates of one number. Between the patches lies a rough metal panel
/// (glossy, α = 0.25) or a mirror (specular: no light sample reaches A through it, so
/// gathering must hit A by chance, and shooting must land on B by chance).
///
/// Asserted, for each panel: every pair of the four estimates agrees within 4 combined
/// standard errors and 7% (each standard error under 2%); the panel carries most of the
/// flux (a black panel leaves less than half of it), so its transport is what is compared;
/// the fraction of the emitted power that arrives, which is not symmetric (the patches'
/// areas differ by a third), differs between the two ways by more than 10 standard errors,
/// so a check of a quantity that is not symmetric would fail.
///
/// Measured (2M paths each, 8 bounces, seed 7, Embree 3.13.5): glossy 1.7960e-3 and
/// 1.7951e-3 gathered (errors 0.19%, 0.27%), 1.8061e-3 and 1.8020e-3 shot (1.2%), largest
/// pair 0.50 σ, mean GRDF 2.37e-3; mirror (red) 2.558e-3 and 2.569e-3 gathered, 2.565e-3
/// and 2.549e-3 shot (errors 0.9-1.1%), largest pair 0.57 σ, mean GRDF 3.37e-3; a black
/// panel leaves 1.67e-5 (under 1%).
#[test]
fn the_grdf_between_small_patches_is_symmetric_over_a_glossy_panel_and_a_mirror() {
    const PATHS: u64 = 2_000_000;
    for (what, panel) in [
        ("glossy", "diffuse = 0\nspecular = 0.9\nroughness = 0.25"),
        ("mirror", "diffuse = 0\nspecular = [0.9, 0.8, 0.7]"),
    ] {
        let flux = |source: usize, estimator| {
            run(
                &panel_between(panel, source),
                &[9 - source],
                estimator,
                8,
                PATHS,
            )
        };
        let estimates = [
            ("A to B, gathered", flux(0, Estimator::Gathering)),
            ("A to B, shot", flux(0, Estimator::Shooting)),
            ("B to A, gathered", flux(1, Estimator::Gathering)),
            ("B to A, shot", flux(1, Estimator::Shooting)),
        ];
        for (name, f) in &estimates {
            let g = mean_grdf(f);
            eprintln!(
                "{what}: {name}: flux {} ± {}, mean GRDF {:.4e} {:.4e} {:.4e}",
                f.flux, f.standard_error, g[0], g[1], g[2]
            );
        }
        for i in 0..4 {
            for j in i + 1..4 {
                let ((a, fa), (b, fb)) = (&estimates[i], &estimates[j]);
                assert_within(&format!("{what}: {a} / {b}"), fa, fb, 4.0, 0.02, 0.07);
            }
        }
        // Power emitted: radiance 1 over both sides, 2πA.
        let emitted = |p: usize| {
            let (x, z, _) = PATCHES[p];
            std::f32::consts::TAU * (x[1] - x[0]) * (z[1] - z[0])
        };
        let (there, back) = (&estimates[0].1, &estimates[2].1);
        let fraction = |f: &Flux, p: usize, c: usize| {
            (f.flux[c] / emitted(p), f.standard_error[c] / emitted(p))
        };
        for c in 0..3 {
            let ((a, sa), (b, sb)) = (fraction(there, 0, c), fraction(back, 1, c));
            assert!(
                (a - b).abs() > 10.0 * sa.hypot(sb),
                "{what}: channel {c}: fractions {a} and {b} do not tell the ways apart"
            );
        }
        let black = run(
            &panel_between("diffuse = 0", 0),
            &[9],
            Estimator::Gathering,
            8,
            PATHS / 4,
        );
        eprintln!("{what}: A to B with a black panel: {}", black.flux);
        for c in 0..3 {
            assert!(
                black.flux[c] < 0.5 * there.flux[c],
                "{what}: channel {c}: {} with the panel, {} with a black one",
                there.flux[c],
                black.flux[c]
            );
        }
    }
}

/// ∫∫ cos θ_a cos θ_b / r² dA_a dA_b between two horizontal rectangles `dy` apart (both
/// normals vertical), by the midpoint rule on 32 × 32 points of each: the flux from a
/// rectangle of radiance 1 to the other, with nothing between them.
fn parallel_transfer(a: ([f32; 2], [f32; 2]), b: ([f32; 2], [f32; 2]), dy: f64) -> f64 {
    const N: usize = 32;
    let points = |(x, z): ([f32; 2], [f32; 2])| {
        let (x0, x1, z0, z1) = (x[0] as f64, x[1] as f64, z[0] as f64, z[1] as f64);
        let cell = (x1 - x0) * (z1 - z0) / (N * N) as f64;
        let p: Vec<(f64, f64)> = (0..N * N)
            .map(|k| {
                let (i, j) = ((k / N) as f64 + 0.5, (k % N) as f64 + 0.5);
                (x0 + (x1 - x0) * i / N as f64, z0 + (z1 - z0) * j / N as f64)
            })
            .collect();
        (p, cell)
    };
    let ((pa, da), (pb, db)) = (points(a), points(b));
    let mut sum = 0.0;
    for &(xa, za) in &pa {
        for &(xb, zb) in &pb {
            let r2 = (xa - xb).powi(2) + (za - zb).powi(2) + dy * dy;
            sum += dy * dy / (r2 * r2);
        }
    }
    sum * da * db
}

/// The GRDF through a mirror, against its value: with black walls and screen the only way
/// from one patch to the other is one reflection in the mirror panel (reflectance ρ = 0.9,
/// 0.8, 0.7), so the flux is ρ times the transfer between the source and the receiver's
/// mirror image (2.2 below it), an integral computed here by the midpoint rule: 2.6015e-3·ρ.
/// Asserted: gathering (which can reach the source only by hitting it through the mirror)
/// and shooting, each way, within 4 standard errors and 5% of it (errors under 1.5%).
/// Measured (2M paths each, seed 7, Embree 3.13.5; red 2.3414e-3 expected): A to B
/// gathered -0.12 σ, shot +0.25 σ, B to A gathered +0.32 σ, shot -0.39 σ (all within
/// 0.4%, errors 0.95-1.2%).
#[test]
fn the_grdf_through_a_mirror_is_the_mirrored_transfer() {
    let [(xa, za, ya), (xb, zb, yb)] = PATCHES;
    let transfer = parallel_transfer((xa, za), (xb, zb), (ya - (2.0 * -0.9 - yb)) as f64);
    let mirror = [0.9f32, 0.8, 0.7];
    let expected = mirror.map(|r| r * transfer as f32);
    eprintln!("mirror, black walls: expected {expected:?}");
    let panel = "diffuse = 0\nspecular = [0.9, 0.8, 0.7]";
    for (name, source, estimator) in [
        ("A to B, gathered", 0, Estimator::Gathering),
        ("A to B, shot", 0, Estimator::Shooting),
        ("B to A, gathered", 1, Estimator::Gathering),
        ("B to A, shot", 1, Estimator::Shooting),
    ] {
        let scene = panel_in_box(0.0, panel, source);
        let f = run(&scene, &[9 - source], estimator, 8, 2_000_000);
        eprintln!(
            "mirror, black walls: {name}: {} ± {}",
            f.flux, f.standard_error
        );
        assert_near(name, &f, expected, 4.0);
        for (c, e) in expected.into_iter().enumerate() {
            assert!((f.flux[c] - e).abs() < 0.05 * e, "{name}: channel {c}");
            assert!(f.standard_error[c] < 0.015 * e, "{name}: channel {c}");
        }
    }
}
