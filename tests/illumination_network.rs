//! Illumination networks (Buckalew & Fussell 1989): the ray space's étendue against π·area,
//! the incremental intersections against direct ones, the two builders against each other,
//! energy in closed boxes against Le/(1−ρ), the Cornell box against the path tracer at two
//! resolutions, and network files (reuse, relighting, bad files) through the CLI.

mod common;

use common::{raylink, stderr};
use raylink::accel::{self, Backend};
use raylink::image::compare::{box_downsample, bright_mask, mean, rmse};
use raylink::image::filter::Filter;
use raylink::image::output::read_image;
use raylink::image::Image;
use raylink::integrators::illumination_network::distribute::{
    distribute, DistributeOptions, Solution,
};
use raylink::integrators::illumination_network::patches::Patches;
use raylink::integrators::illumination_network::preprocess::{
    line_point, scan_order, scan_polygon, scan_slot, Builder,
};
use raylink::integrators::illumination_network::ray_space::{axes, RaySpace};
use raylink::integrators::illumination_network::render::NetworkRenderer;
use raylink::integrators::illumination_network::{Network, NetworkParams, ESCAPE, NONE};
use raylink::integrators::path::{PathOptions, PathTracer};
use raylink::integrators::Context;
use raylink::math::Vec3;
use raylink::render::progressive::{render_progressive, ProgressiveOptions};
use raylink::render::{render, PixelSampling, RenderOptions};
use raylink::scene::Scene;
use std::path::Path;

fn scene(text: &str) -> Scene {
    raylink::scene::toml::from_str(text, Path::new("test.toml")).expect("test scene parses")
}

const CAMERA: &str = r#"
[camera]
position = [0.5, 0.5, 0.95]
look_at = [0.5, 0.5, 0]
fov = 60
width = 16
height = 16
"#;

/// A quad facing the inside of the unit cube on face `axis` = `side`.
fn wall(axis: usize, side: f32, material: &str) -> String {
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let corner = |a: f32, b: f32| {
        let mut p = [0.0; 3];
        p[axis] = side;
        p[u] = a;
        p[v] = b;
        p
    };
    let mut vs = vec![
        corner(0., 0.),
        corner(1., 0.),
        corner(1., 1.),
        corner(0., 1.),
    ];
    // Wind so the normal (v1−v0)×(v2−v0) points inside.
    let n = (Vec3::from(vs[1]) - Vec3::from(vs[0])).cross(Vec3::from(vs[2]) - Vec3::from(vs[0]));
    if (n[axis] > 0.0) != (side == 0.0) {
        vs.reverse();
    }
    format!("[[shapes]]\ntype = \"quad\"\nmaterial = \"{material}\"\nvertices = {vs:?}\n")
}

/// The unit cube, closed, every wall of material `m` except the floor (y = 0) of `floor`.
fn closed_box(materials: &str, m: &str, floor: &str) -> Scene {
    scene(&closed_box_text(materials, m, floor))
}

/// [`closed_box`]'s scene file.
fn closed_box_text(materials: &str, m: &str, floor: &str) -> String {
    let mut text = format!("{CAMERA}\n{materials}\n");
    for axis in 0..3 {
        for side in [0.0, 1.0] {
            let mat = if axis == 1 && side == 0.0 { floor } else { m };
            text += &wall(axis, side, mat);
        }
    }
    text
}

fn params(slopes: u32, step: f32) -> NetworkParams {
    NetworkParams {
        slopes,
        step,
        patch_size: step,
        jitter: 1.0,
        seed: 7,
    }
}

fn build(scene: &Scene, p: NetworkParams, builder: Builder) -> Network {
    let accel = accel::build(scene, Backend::Embree).unwrap();
    let ctx = Context::new(scene, accel.as_ref());
    Network::build(scene, &ctx, p, builder).unwrap()
}

/// The lines of every slot that meet a patch, weighted by their étendue, add up to π·area:
/// the per-slope weight is the Jacobian of slope-intercept space (1.5%: the boundary of the
/// projected patch cuts intercept cells).
#[test]
fn etendue_of_lines_through_a_patch_is_pi_area() {
    for (i, verts) in [
        "[[0.2, 0.3, 0.5], [0.8, 0.3, 0.5], [0.8, 0.7, 0.5], [0.2, 0.7, 0.5]]",
        "[[0.2, 0.2, 0.2], [0.8, 0.3, 0.4], [0.7, 0.8, 0.9], [0.1, 0.7, 0.7]]",
    ]
    .iter()
    .enumerate()
    {
        let s = scene(&format!(
            "{CAMERA}\n[materials.m]\ndiffuse = 0.5\n[[shapes]]\ntype = \"quad\"\nmaterial = \"m\"\nvertices = {verts}\n"
        ));
        // A ray space over a fixed box, so the patch has its own size in the unit cube.
        let space = RaySpace::new(16, 1.0 / 128.0, (Vec3::ZERO, Vec3::ONE));
        let patches = Patches::new(&s, &space, 1.0).unwrap();
        let pg = &patches.polygons[0];
        let mut sum = 0.0f64;
        for slot in 0..space.slots() as u32 {
            let mut count = 0u32;
            scan_polygon(&space, slot, pg, 3, 1.0, |_, _, _, _| count += 1);
            sum += count as f64 * space.etendue(slot) as f64;
        }
        let exact = std::f64::consts::PI * pg.area() as f64;
        let err = (sum - exact).abs() / exact;
        assert!(err < 0.015, "patch {i}: Σw = {sum}, π·A = {exact} ({err})");
    }
}

/// Patches much larger than the intercept step in an open scene: a patch meets many lines of
/// each slot, most of them leaving the scene. Every one is kept (a slot can have several
/// links), so each node's étendue W is still π·area, as for the
/// lines through one patch above.
#[test]
fn large_patches_in_an_open_scene_keep_every_escape() {
    let s = scene(&format!(
        "{CAMERA}\n[materials.m]\ndiffuse = 0.5\n[materials.lamp]\ndiffuse = 0\nemission = 1\n\
         [[shapes]]\ntype = \"quad\"\nmaterial = \"m\"\nvertices = [[0, 0, 0], [0, 0, 1], [1, 0, 1], [1, 0, 0]]\n\
         [[shapes]]\ntype = \"quad\"\nmaterial = \"lamp\"\nvertices = [[0.4, 0.3, 0.4], [0.6, 0.3, 0.4], [0.6, 0.3, 0.6], [0.4, 0.3, 0.6]]\n"
    ));
    let p = NetworkParams {
        patch_size: 0.25,
        ..params(6, 1.0 / 128.0)
    };
    let net = build(&s, p, Builder::Scan);
    let mut checked = 0;
    for node in 0..net.nodes() as u32 {
        let (poly, _, side) = net.node_place(node);
        // The floor's upper sides (the lamp's lower sides link to the floor only).
        if poly != 0 || side != 0 {
            continue;
        }
        let pg = &net.patches.polygons[0];
        let exact = std::f64::consts::PI * pg.area() as f64 / (pg.ns * pg.nt) as f64;
        let w = net.etendue[node as usize] as f64;
        let err = (w - exact).abs() / exact;
        assert!(err < 0.03, "node {node}: W = {w}, π·A = {exact} ({err})");
        checked += 1;
    }
    assert!(checked >= 4, "{checked} floor nodes");
    assert!(
        net.stats.extra > 100 * net.nodes() as u64,
        "{:?}",
        net.stats
    );
}

/// A slot's scan (hits bucketed by intercept row as they are found, then counted out by
/// column) gives exactly the hits of its polygons' scans, sorted by line and, on a line, in
/// the polygons' scan order (by their centres along the slot's direction; the links do not
/// depend on it).
#[test]
fn slot_scan_sorts_the_polygons_hits_by_line() {
    let s = scene(&format!(
        "{CAMERA}\n[materials.m]\ndiffuse = 0.5\n\
         [[shapes]]\ntype = \"quad\"\nmaterial = \"m\"\nvertices = [[0.1, 0.2, 0.3], [0.9, 0.3, 0.5], [0.8, 0.8, 0.9], [0.0, 0.7, 0.7]]\n\
         [[shapes]]\ntype = \"quad\"\nmaterial = \"m\"\nvertices = [[0, 0, 0.2], [1, 0, 0.2], [1, 1, 0.2], [0, 1, 0.2]]\n\
         [[shapes]]\ntype = \"quad\"\nmaterial = \"m\"\nvertices = [[0.3, 0, 0], [0.3, 1, 0], [0.3, 1, 1], [0.3, 0, 1]]\n"
    ));
    let space = RaySpace::new(4, 1.0 / 32.0, (Vec3::ZERO, Vec3::ONE));
    let patches = Patches::new(&s, &space, 1.0 / 8.0).unwrap();
    let mut total = 0;
    let mut order = Vec::new();
    for slot in 0..space.slots() as u32 {
        let mut want = Vec::new();
        scan_order(&patches, space.direction(slot), &mut order);
        assert!(order.windows(2).all(|w| w[0].0 <= w[1].0), "slot {slot}");
        for &(_, i) in &order {
            let pg = &patches.polygons[i as usize];
            scan_polygon(&space, slot, pg, 5, 1.0, |line, _, _, pa| {
                want.push((line, pa))
            });
        }
        want.sort_by_key(|&(line, _)| line);
        let got: Vec<(u32, f32)> = scan_slot(&space, &patches, slot, 5, 1.0)
            .iter()
            .map(|h| (h.line, h.depth))
            .collect();
        assert_eq!(got, want, "slot {slot}");
        total += got.len();
    }
    assert!(total > 10_000, "{total} hits");
}

/// The scan converter's incremental p_a equals the directly computed ray-plane intersection,
/// and it reports exactly the lines whose direct intersection lies inside the polygon (away
/// from the edges, where rounding decides).
#[test]
fn incremental_intersections_equal_direct_ones() {
    let s = scene(&format!(
        "{CAMERA}\n[materials.m]\ndiffuse = 0.5\n[[shapes]]\ntype = \"quad\"\nmaterial = \"m\"\nvertices = [[0.1, 0.2, 0.3], [0.9, 0.3, 0.5], [0.8, 0.8, 0.9], [0.0, 0.7, 0.7]]\n"
    ));
    let space = RaySpace::new(5, 1.0 / 40.0, (Vec3::ZERO, Vec3::ONE));
    let patches = Patches::new(&s, &space, 1.0).unwrap();
    let pg = &patches.polygons[0];
    let n = space.intercepts;
    let mut checked = 0;
    for slot in 0..space.slots() as u32 {
        let (f, su, sv) = space.slot_slopes(slot);
        let (a, _, _) = axes(f);
        let d = space.direction(slot);
        let mut found = vec![None; (n * n) as usize];
        scan_polygon(&space, slot, pg, 11, 1.0, |line, iu, iv, pa| {
            found[line as usize] = Some((iu, iv, pa));
        });
        for ju in 0..n {
            for jv in 0..n {
                let (du, dv) = space.jitter(11, 1.0, slot, ju, jv);
                let (iu, iv) = (space.intercept(ju) + du, space.intercept(jv) + dv);
                let o = line_point(f, su, sv, iu, iv, 0.0);
                let t = pg.n.dot(pg.o - o) / pg.n.dot(d);
                let p = o + d * t;
                let (ps, pt) = pg.st(p);
                let margin = 1e-4;
                let inside = ps > margin && pt > margin && ps < 1.0 - margin && pt < 1.0 - margin;
                let outside =
                    ps < -margin || pt < -margin || ps > 1.0 + margin || pt > 1.0 + margin;
                match found[(ju * n + jv) as usize] {
                    Some((fu, fv, pa)) => {
                        assert!(
                            !outside,
                            "slot {slot} line ({ju}, {jv}) reported but misses"
                        );
                        assert_eq!((fu, fv), (iu, iv));
                        assert!(
                            (pa - p[a]).abs() < 2e-5,
                            "slot {slot}: incremental {pa} vs direct {}",
                            p[a]
                        );
                        checked += 1;
                    }
                    None => assert!(!inside, "slot {slot} line ({ju}, {jv}) meets but missed"),
                }
            }
        }
    }
    assert!(checked > 10_000, "only {checked} intersections checked");
}

/// A room with a tilted panel: scan conversion and Embree casting of the same jittered lines
/// give the same links (up to lines through polygon edges, which the two decide differently).
#[test]
fn scan_and_embree_builders_agree() {
    let mut text = format!("{CAMERA}\n[materials.m]\ndiffuse = 0.5\n");
    for axis in 0..3 {
        for side in [0.0, 1.0] {
            text += &wall(axis, side, "m");
        }
    }
    text += "[[shapes]]\ntype = \"quad\"\nmaterial = \"m\"\nvertices = [[0.2, 0.2, 0.3], [0.7, 0.3, 0.4], [0.6, 0.7, 0.8], [0.1, 0.6, 0.7]]\n";
    let s = scene(&text);
    let p = params(6, 1.0 / 24.0);
    let scan = build(&s, p, Builder::Scan);
    let cast = build(&s, p, Builder::Embree);
    assert!(cast.stats.rays > 0);
    // Compare link ends as (side key, slot) → target side key.
    let ends = |net: &Network| {
        let mut v = Vec::new();
        for node in 0..net.nodes() as u32 {
            let key = net.key_of_node[node as usize];
            let target = |t: u32| {
                if t < ESCAPE {
                    net.key_of_node[t as usize]
                } else {
                    t
                }
            };
            for (slot, t) in net.slot_links(node) {
                v.push((key, slot as u32, target(t)));
            }
        }
        v.sort_unstable();
        v
    };
    let (a, b) = (ends(&scan), ends(&cast));
    let common = {
        let (mut i, mut j, mut c) = (0, 0, 0);
        while i < a.len() && j < b.len() {
            match a[i].cmp(&b[j]) {
                std::cmp::Ordering::Equal => {
                    c += 1;
                    i += 1;
                    j += 1;
                }
                std::cmp::Ordering::Less => i += 1,
                std::cmp::Ordering::Greater => j += 1,
            }
        }
        c
    };
    let differ = (a.len() + b.len() - 2 * common) as f64 / a.len() as f64;
    assert!(a.len() > 50_000, "{} link ends", a.len());
    eprintln!("{:.4}% of {} link ends differ", 100.0 * differ, a.len());
    assert!(differ < 0.002, "{:.4}% of link ends differ", 100.0 * differ);
}

/// Total radiance leaving each node: emission plus the reflected out-buffers.
fn closed_box_radiance(net: &Network, sol: &Solution) -> (f64, f64, f64) {
    let w: Vec<f32> = (0..net.slots() as u32)
        .map(|s| net.space.etendue(s))
        .collect();
    let (mut lo, mut hi, mut flux, mut etendue) = (f64::MAX, f64::MIN, 0.0, 0.0);
    for node in 0..net.nodes() {
        let sfc = &sol.surfaces[node];
        let l = (sfc.emission + sol.diffuse[node]).x as f64;
        lo = lo.min(l);
        hi = hi.max(l);
        let mut f = l * net.etendue[node] as f64;
        let k = sol.dir_index[node];
        if k != NONE {
            let row = &sol.directional[k as usize * net.slots()..][..net.slots()];
            for (l, _) in net.slot_links(node as u32) {
                f += (row[l].x * w[l]) as f64;
            }
        }
        flux += f;
        etendue += net.etendue[node] as f64;
    }
    (lo, hi, flux / etendue)
}

/// A closed diffuse box with albedo ρ and uniform emission Le: every node converges to
/// Le/(1−ρ) within the tolerance (the network's form factors sum to one exactly), by the
/// sweeps and by conjugate gradients.
#[test]
fn closed_diffuse_box_converges_to_le_over_one_minus_rho() {
    use raylink::integrators::illumination_network::distribute::Order;
    let s = closed_box("[materials.m]\ndiffuse = 0.6\nemission = 1\n", "m", "m");
    let net = build(&s, params(6, 1.0 / 16.0), Builder::Scan);
    assert_eq!(net.stats.escapes, 0, "a closed box has no escaping links");
    let tol = 1e-4;
    for order in [Order::Sweeps, Order::ConjugateGradients] {
        let sol = distribute(
            &net,
            &s,
            &DistributeOptions {
                tolerance: tol,
                order,
                ..Default::default()
            },
        );
        let exact = 1.0 / (1.0 - 0.6);
        let (lo, hi, _) = closed_box_radiance(&net, &sol);
        assert!(
            (lo - exact).abs() / exact < 2.0 * tol as f64
                && (hi - exact).abs() / exact < 2.0 * tol as f64,
            "{order:?}: radiance in [{lo}, {hi}], expected {exact}"
        );
        let expected = match order {
            // Sweep k adds ρ^k·Le: the count is the geometric series' (log tol / log ρ, ± 1).
            Order::Sweeps => ((tol as f64).ln() / 0.6f64.ln()).ceil() as u32,
            // The emission is an eigenvector of the symmetrised system (uniform ρ, and every
            // row of links sums to its node's W): one iteration after the first gather.
            _ => 2,
        };
        assert!(
            sol.stats.sweeps.abs_diff(expected) <= 1,
            "{order:?}: {} sweeps",
            sol.stats.sweeps
        );
    }
}

/// The same box with a mirror floor (ks = ρ, kd = 0) and every surface emitting: the mirror's
/// rows sum to ρ exactly, so the flux-weighted mean radiance is still Le/(1−ρ), no flux
/// escapes, and emitted = absorbed + unshot.
#[test]
fn mirror_floor_box_conserves_energy() {
    for floor in [
        "[materials.floor]\ndiffuse = 0\nspecular = 0.6\nemission = 1\n",
        "[materials.floor]\ndiffuse = 0.2\nspecular = 0.4\nroughness = 0.2\nemission = 1\n",
    ] {
        let s = closed_box(
            &format!("[materials.m]\ndiffuse = 0.6\nemission = 1\n{floor}"),
            "m",
            "floor",
        );
        let net = build(&s, params(6, 1.0 / 16.0), Builder::Scan);
        let tol = 1e-4;
        let sol = distribute(
            &net,
            &s,
            &DistributeOptions {
                tolerance: tol,
                ..Default::default()
            },
        );
        assert!(sol.stats.map_entries > 0);
        let st = &sol.stats;
        for c in 0..3 {
            assert_eq!(st.escaped[c], 0.0);
            let balance = st.emitted[c] - st.absorbed[c] - st.unshot[c];
            assert!(
                balance.abs() < 1e-4 * st.emitted[c],
                "channel {c}: {balance}"
            );
        }
        let (_, _, mean) = closed_box_radiance(&net, &sol);
        let exact = 1.0 / (1.0 - 0.6);
        assert!(
            (mean - exact).abs() / exact < 2.0 * tol as f64,
            "{floor}: mean radiance {mean}, expected {exact}"
        );
    }
}

fn cornell() -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml")).unwrap()
}

fn network_image(scene: &Scene, p: NetworkParams, size: u32, hybrid: bool) -> Image {
    let accel = accel::build(scene, Backend::Embree).unwrap();
    let ctx = Context::new(scene, accel.as_ref());
    let net = Network::build(scene, &ctx, p, Builder::Scan).unwrap();
    let sol = distribute(&net, scene, &DistributeOptions::default());
    let renderer = NetworkRenderer {
        net: &net,
        solution: &sol,
        hybrid,
    };
    let options = RenderOptions {
        width: size,
        height: size,
        // The hybrid mode samples the lights: more samples per pixel.
        sampling: PixelSampling::Uniform {
            n: if hybrid { 4 } else { 2 },
        },
        threads: None,
        seed: 1,
        progress: false,
    };
    render(&ctx, &renderer, &options).unwrap().0
}

/// The Cornell box against the path tracer: the relative RMSE of 4×4-pixel block means
/// (the light excluded), averaged over four jitter seeds, is below 30% at a coarse network,
/// shrinks to under half at a finer one, and shrinks with the hybrid mode (direct light per
/// pixel) on the coarse network. One seed's error is itself random: at the coarse network
/// it spans 17–29% over eight seeds, so a single seed would test the jitter's luck.
#[test]
fn cornell_box_approaches_the_path_tracer() {
    let scene = cornell();
    let size = 32;
    let accel = accel::build(&scene, Backend::Embree).unwrap();
    let ctx = Context::new(&scene, accel.as_ref());
    let options = ProgressiveOptions {
        width: size,
        height: size,
        spp: 1024,
        time_limit: None,
        threads: None,
        seed: 5,
        progress: false,
        filter: Filter::Box { radius: 0.5 },
    };
    let (film, _) = render_progressive(
        &ctx,
        &PathTracer::new(PathOptions { max_depth: 64 }),
        &options,
        |_| Ok(()),
    )
    .unwrap();
    // The light (rendered exactly by both) and its neighbours are left out of the blocks.
    let full = film.image();
    let mask = bright_mask(&full, 1.0);
    let masked = |img: &Image| {
        let mut img = img.clone();
        for (p, &m) in img.pixels.iter_mut().zip(&mask) {
            if m {
                *p = Vec3::ZERO;
            }
        }
        box_downsample(&img, 8, 8).unwrap()
    };
    let reference = masked(&full);
    let scale = mean(&reference, None).element_sum() as f64 / 3.0;
    let seeds = 1..=4u64;
    let error = |slopes: u32, step: f32, hybrid: bool| {
        let errors: Vec<f64> = seeds
            .clone()
            .map(|seed| {
                let p = NetworkParams {
                    seed,
                    ..params(slopes, step)
                };
                let img = masked(&network_image(&scene, p, size, hybrid));
                rmse(&img, &reference, None) / scale
            })
            .collect();
        eprintln!("slopes {slopes}, h {step}, hybrid {hybrid}: relative RMSE by seed {errors:.4?}");
        errors.iter().sum::<f64>() / errors.len() as f64
    };
    let coarse = error(6, 1.0 / 16.0, false);
    let fine = error(12, 1.0 / 32.0, false);
    let hybrid = error(6, 1.0 / 16.0, true);
    eprintln!("mean relative RMSE: coarse {coarse:.4}, fine {fine:.4}, coarse hybrid {hybrid:.4}");
    assert!(coarse < 0.3, "coarse network: {coarse}");
    assert!(fine < 0.5 * coarse, "fine {fine} vs coarse {coarse}");
    // Direct light per pixel removes the coarse network's blurred shadows.
    assert!(hybrid < 0.4 * coarse, "hybrid {hybrid} vs coarse {coarse}");
}

fn tmp_path(dir: &tempfile::TempDir, name: &str) -> String {
    dir.path().join(name).to_string_lossy().into_owned()
}

/// `raylink COMMAND` (render, or relight, which always uses the network and refuses
/// `--integrator`) with the network's small test settings; `--slopes 6` unless `extra`
/// gives its own.
fn network_command(command: &str, scene: &str, out: &str, extra: &[&str]) -> std::process::Output {
    let slopes = if extra.contains(&"--slopes") {
        &[][..]
    } else {
        &["--slopes", "6"][..]
    };
    let mut args = vec![command, scene];
    if command == "render" {
        args.extend_from_slice(&["--integrator", "network"]);
    }
    args.extend_from_slice(&[
        "--intercept-step",
        "0.0625",
        "--width",
        "24",
        "--height",
        "24",
        "--spp",
        "1",
        "-o",
        out,
    ]);
    args.extend_from_slice(slopes);
    args.extend_from_slice(extra);
    raylink(&args)
}

fn network_render(scene: &str, out: &str, extra: &[&str]) -> std::process::Output {
    network_command("render", scene, out, extra)
}

/// Network files: a second view from the saved network runs no preprocess and equals a fresh
/// build; doubling the lights doubles the image exactly; bad files are one-line errors.
#[test]
fn network_files_are_reused_for_views_and_lighting() {
    let dir = tempfile::tempdir().unwrap();
    let file = tmp_path(&dir, "cornell.net");
    let first = network_render(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "a.exr"),
        &["--network-file", &file],
    );
    assert!(first.status.success(), "{}", stderr(&first));
    assert!(stderr(&first).contains("preprocess"), "{}", stderr(&first));
    assert!(Path::new(&file).exists());

    // Another view of the same geometry (the camera moved).
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml"),
    )
    .unwrap()
    .replace("position = [0, 1, 6.8]", "position = [0.5, 1.2, 3.5]");
    let moved = tmp_path(&dir, "moved.toml");
    std::fs::write(&moved, text).unwrap();
    let loaded = network_render(&moved, &tmp_path(&dir, "b.exr"), &["--network-file", &file]);
    assert!(loaded.status.success(), "{}", stderr(&loaded));
    assert!(
        stderr(&loaded).contains("no preprocess"),
        "{}",
        stderr(&loaded)
    );
    assert!(!stderr(&loaded).contains("network: preprocess"));
    let fresh = network_render(&moved, &tmp_path(&dir, "c.exr"), &[]);
    assert!(fresh.status.success(), "{}", stderr(&fresh));
    let img = |name: &str| read_image(&dir.path().join(name)).unwrap().0;
    assert_eq!(img("b.exr").pixels, img("c.exr").pixels);

    // Relighting: twice the emission, exactly twice the radiance (a power of two is exact).
    let relit = network_render(
        &moved,
        &tmp_path(&dir, "d.exr"),
        &["--network-file", &file, "--light-scale", "2"],
    );
    assert!(relit.status.success(), "{}", stderr(&relit));
    assert!(stderr(&relit).contains("no preprocess"));
    let (b, d) = (img("b.exr"), img("d.exr"));
    assert!(b.pixels.iter().any(|p| p.x > 0.0));
    for (x, y) in b.pixels.iter().zip(&d.pixels) {
        assert_eq!(*x * 2.0, *y);
    }

    // Other parameters, another scene, a corrupt file: errors naming the file, exit 2.
    let other = network_render(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "e.exr"),
        &["--network-file", &file, "--slopes", "7"],
    );
    assert_eq!(other.status.code(), Some(2));
    assert!(stderr(&other).contains("cornell.net") && stderr(&other).contains("parameters"));
    let box_scene = network_render(
        "scenes/cornell-spheres.toml",
        &tmp_path(&dir, "f.exr"),
        &["--network-file", &file],
    );
    assert_eq!(box_scene.status.code(), Some(2), "{}", stderr(&box_scene));
    let mut bytes = std::fs::read(&file).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0xff;
    let corrupt = tmp_path(&dir, "corrupt.net");
    std::fs::write(&corrupt, &bytes).unwrap();
    let bad = network_render(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "g.exr"),
        &["--network-file", &corrupt],
    );
    assert_eq!(bad.status.code(), Some(2));
    assert!(stderr(&bad).contains("corrupt.net") && stderr(&bad).contains("checksum"));
    assert!(!dir.path().join("g.exr").exists());
}

/// The Cornell box's network (S = 5, h = 1/16), saved to a file in a temporary directory.
fn saved_cornell_network() -> (
    raylink::scene::Scene,
    Network,
    tempfile::TempDir,
    std::path::PathBuf,
) {
    use raylink::integrators::illumination_network::file;
    let scene = cornell();
    let net = build(&scene, params(5, 1.0 / 16.0), Builder::Scan);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cornell.net");
    file::save(&path, &net, &scene, None).unwrap();
    (scene, net, dir, path)
}

/// A network read back from its file is the one that was built: the same link lists, and
/// the same W and escapes' part of W bit for bit (the loader adds them up as the build does,
/// beside its checks, the link table read in two halves at once). The escapes' part agrees
/// with a plain sum over each node's escaping links.
#[test]
fn a_loaded_network_is_the_built_one() {
    use raylink::integrators::illumination_network::file;
    let (scene, net, _dir, path) = saved_cornell_network();
    let loaded = file::load(&path, &scene, None).unwrap();
    assert!(net.links.len() > 50_000, "{} links", net.links.len());
    assert_eq!(loaded.link_start, net.link_start);
    assert_eq!(loaded.links, net.links);
    assert_eq!(loaded.key_of_node, net.key_of_node);
    let bits = |w: &[f32]| w.iter().map(|w| w.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&loaded.etendue), bits(&net.etendue));
    assert_eq!(bits(&loaded.escape_etendue), bits(&net.escape_etendue));
    // The box is open at the front: some nodes' lines escape, not all.
    let mut escaping = 0;
    for node in 0..net.nodes() as u32 {
        let plain: f64 = net
            .slot_links(node)
            .filter(|&(_, t)| t == ESCAPE)
            .map(|(l, _)| net.space.etendue(l as u32) as f64)
            .sum();
        let got = net.escape_etendue[node as usize] as f64;
        assert!(
            (got - plain).abs() <= 1e-5 * plain,
            "node {node}: {got} against {plain}"
        );
        escaping += usize::from(plain > 0.0);
    }
    assert!(
        escaping > 0 && escaping < net.nodes(),
        "{escaping} escaping nodes"
    );
}

/// A link table damaged under a valid checksum (a link to a node past the last, a node's links
/// out of slot order) is refused with a one-line error naming the file.
#[test]
fn damaged_link_tables_are_refused_even_with_a_valid_checksum() {
    use raylink::integrators::illumination_network::file;
    let (scene, net, _dir, path) = saved_cornell_network();
    assert!(file::load(&path, &scene, None).is_ok());
    let bytes = std::fs::read(&path).unwrap();
    // The links are the last words before the checksum.
    let links_at = bytes.len() - 8 - 4 * net.links.len();
    let damaged = |i: usize, link: u32| {
        let mut b = bytes.clone();
        b[links_at + 4 * i..links_at + 4 * i + 4].copy_from_slice(&link.to_le_bytes());
        let n = b.len() - 8;
        let sum = raylink::binary_file::checksum(&b[..n]);
        b[n..].copy_from_slice(&sum.to_le_bytes());
        std::fs::write(&path, b).unwrap();
        file::load(&path, &scene, None).unwrap_err().to_string()
    };
    let code = net.code;
    let first = net.links[0];
    let past = damaged(0, code.pack(code.slot(first) as u32, net.nodes() as u32));
    // A node whose first link takes the last slot, before its other links.
    let node = (0..net.nodes() as u32)
        .find(|&n| net.links_of(n).len() >= 2)
        .unwrap();
    let i = net.link_start[node as usize] as usize;
    let last_slot = net.slots() as u32 - 1;
    assert!(code.slot(net.links[i + 1]) < last_slot as usize);
    let unordered = damaged(i, code.pack(last_slot, code.target(net.links[i])));
    for (e, what) in [
        (past, "past the last slot or node"),
        (unordered, "not in slot order"),
    ] {
        assert!(e.contains("cornell.net") && e.contains(what), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }
}

/// The network and its image do not depend on the number of threads.
#[test]
fn network_is_independent_of_thread_count() {
    let scene = cornell();
    let p = params(5, 1.0 / 16.0);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| build(&scene, p, Builder::Scan));
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap()
        .install(|| build(&scene, p, Builder::Scan));
    assert_eq!(one.link_start, two.link_start);
    assert_eq!(one.links, two.links);
    let sol1 = distribute(&one, &scene, &DistributeOptions::default());
    let sol2 = distribute(&two, &scene, &DistributeOptions::default());
    assert_eq!(sol1.diffuse, sol2.diffuse);
}

/// Two rooms of the unit cube split by a panel at x = ½, lit in the left room: an opaque
/// panel leaves the right room exactly dark (no link crosses a surface); a clear or frosted
/// panel (kt = 0.5) lights it, and energy balances (emitted = absorbed + unshot, nothing
/// escapes).
#[test]
fn transmission_carries_light_through_a_panel() {
    for panel in [
        "diffuse = 0.5",
        "diffuse = 0.2\ntransmission = 0.5",
        "diffuse = 0.2\ntransmission = 0.5\nroughness = 0.3",
    ] {
        let mut text = format!(
            "{CAMERA}\n[materials.m]\ndiffuse = 0.5\n[materials.panel]\n{panel}\n\
             [materials.lamp]\ndiffuse = 0\nemission = 5\n"
        );
        for axis in 0..3 {
            for side in [0.0, 1.0] {
                text += &wall(axis, side, "m");
            }
        }
        text += "[[shapes]]\ntype = \"quad\"\nmaterial = \"panel\"\nvertices = [[0.5, 0, 0], [0.5, 1, 0], [0.5, 1, 1], [0.5, 0, 1]]\n";
        text += "[[shapes]]\ntype = \"quad\"\nmaterial = \"lamp\"\nvertices = [[0.1, 0.02, 0.4], [0.1, 0.02, 0.6], [0.3, 0.02, 0.6], [0.3, 0.02, 0.4]]\n";
        let s = scene(&text);
        let net = build(&s, params(6, 1.0 / 16.0), Builder::Scan);
        let sol = distribute(&net, &s, &DistributeOptions::default());
        let st = &sol.stats;
        for c in 0..3 {
            assert_eq!(st.escaped[c], 0.0);
            let balance = st.emitted[c] - st.absorbed[c] - st.unshot[c];
            assert!(balance.abs() < 1e-4 * st.emitted[c], "{panel}: {balance}");
        }
        // Light reflected by the surfaces of the right room (x > ½, the panel excluded).
        let mut right = 0.0;
        for node in 0..net.nodes() as u32 {
            let (poly, cell, _) = net.node_place(node);
            let pg = &net.patches.polygons[poly as usize];
            let local = cell - pg.first_cell;
            let centre = pg.o
                + pg.e1 * ((local / pg.nt) as f32 + 0.5) / pg.ns as f32
                + pg.e2 * ((local % pg.nt) as f32 + 0.5) / pg.nt as f32;
            let centre = net.space.to_world(centre);
            if centre.x > 0.55 {
                right += sol.diffuse[node as usize].x as f64 * net.etendue[node as usize] as f64;
            }
        }
        eprintln!(
            "{panel:?}: right room {:.4} of emitted",
            right / st.emitted[0]
        );
        if panel.contains("transmission") {
            assert!(right > 0.05 * st.emitted[0], "{panel}: {right}");
        } else {
            assert_eq!(right, 0.0, "light leaked through an opaque panel");
        }
    }
}

/// Curved geometry through the Embree builder: a sphere in the closed box (everything of
/// albedo ρ, emitting Le) converges to Le/(1−ρ) on every node, sphere patches included; the
/// scan converter refuses spheres with a clear error.
#[test]
fn spheres_are_linked_by_the_embree_builder() {
    let mut text = format!("{CAMERA}\n[materials.m]\ndiffuse = 0.6\nemission = 1\n");
    for axis in 0..3 {
        for side in [0.0, 1.0] {
            text += &wall(axis, side, "m");
        }
    }
    text +=
        "[[shapes]]\ntype = \"sphere\"\nmaterial = \"m\"\ncenter = [0.5, 0.4, 0.5]\nradius = 0.2\n";
    let s = scene(&text);
    let accel = accel::build(&s, Backend::Embree).unwrap();
    let ctx = Context::new(&s, accel.as_ref());
    let err = Network::build(&s, &ctx, params(6, 1.0 / 16.0), Builder::Scan).unwrap_err();
    assert!(err.contains("sphere") && err.contains("embree"), "{err}");
    let net = Network::build(&s, &ctx, params(6, 1.0 / 16.0), Builder::Embree).unwrap();
    let sphere_nodes = (0..net.nodes() as u32)
        .filter(|&n| {
            net.patches.polygons[net.node_place(n).0 as usize]
                .sphere
                .is_some()
        })
        .count();
    assert!(sphere_nodes > 50, "{sphere_nodes} sphere nodes");
    let tol = 1e-4;
    let sol = distribute(
        &net,
        &s,
        &DistributeOptions {
            tolerance: tol,
            ..Default::default()
        },
    );
    // Fronts only: the inside of the sphere is a closed dark cavity (emission is one-sided).
    let exact = 1.0 / (1.0 - 0.6);
    let mut fronts = 0;
    for node in 0..net.nodes() {
        let (_, _, side) = net.node_place(node as u32);
        if side == 0 {
            let l = (sol.surfaces[node].emission + sol.diffuse[node]).x as f64;
            assert!(
                (l - exact).abs() / exact < 2.0 * tol as f64,
                "node {node}: {l}"
            );
            fronts += 1;
        } else {
            assert_eq!(sol.diffuse[node], Vec3::ZERO);
        }
    }
    assert!(fronts > 1000);
}

/// The three distribution orders (parallel sweeps, sequential largest-first shooting,
/// conjugate gradients) converge to the same radiances on the Cornell box (flux-weighted L1
/// difference within a few tolerances); shooting's direct part equals the first sweep's,
/// and conjugate gradients' is the first sweep's bit for bit (the same first gather), with
/// the energy balance kept (emitted = escaped + absorbed + unshot).
#[test]
fn the_distribution_orders_agree() {
    use raylink::integrators::illumination_network::distribute::Order;
    let scene = cornell();
    let net = build(&scene, params(5, 1.0 / 16.0), Builder::Scan);
    let tol = 1e-4;
    let run = |order| {
        distribute(
            &net,
            &scene,
            &DistributeOptions {
                tolerance: tol,
                order,
                ..Default::default()
            },
        )
    };
    let (a, b, c) = (
        run(Order::Sweeps),
        run(Order::Shoot),
        run(Order::ConjugateGradients),
    );
    assert!(
        b.stats.sweeps as usize > net.nodes(),
        "{} shots",
        b.stats.sweeps
    );
    assert!(
        c.stats.sweeps < a.stats.sweeps,
        "{} gathers, {} sweeps",
        c.stats.sweeps,
        a.stats.sweeps
    );
    let diff = |x: &[Vec3], y: &[Vec3]| {
        let (mut d, mut t) = (0.0f64, 0.0f64);
        for i in 0..net.nodes() {
            let w = net.etendue[i] as f64;
            d += w * (x[i] - y[i]).abs().element_sum() as f64;
            t += w * x[i].element_sum() as f64;
        }
        d / t
    };
    for (name, other) in [("shooting", &b), ("conjugate gradients", &c)] {
        let total = diff(&a.diffuse, &other.diffuse);
        let direct = diff(&a.direct, &other.direct);
        eprintln!("sweeps vs {name}: {total:.2e} (direct {direct:.2e})");
        assert!(
            total < 5.0 * tol as f64,
            "{name}: radiance differs by {total}"
        );
        assert!(direct < 1e-5, "{name}: direct light differs by {direct}");
    }
    assert!(a.direct == c.direct, "the first gather is the same");
    let (sa, sc) = (&a.stats, &c.stats);
    for ch in 0..3 {
        let balance = sc.emitted[ch] - sc.escaped[ch] - sc.absorbed[ch] - sc.unshot[ch];
        assert!(
            balance.abs() < 1e-5 * sc.emitted[ch],
            "channel {ch}: {balance}"
        );
        assert!(sc.escaped[ch] > 0.0, "the box is open");
        let escaped = (sc.escaped[ch] - sa.escaped[ch]).abs() / sc.emitted[ch];
        assert!(
            escaped < 5.0 * tol as f64,
            "channel {ch}: escapes differ by {escaped}"
        );
    }
}

/// A closed box whose every wall reflects all of the red light (green and blue are partly
/// absorbed) has no finite red radiance: rendering and relighting refuse it with a one-line
/// error naming the scene and the channel, exit 2, and write no image; with one wall
/// absorbing a little red it renders.
#[test]
fn a_closed_scene_that_absorbs_no_light_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, floor: &str| {
        let materials = format!(
            "[materials.m]\ndiffuse = [1, 0.5, 0.5]\nemission = 1\n[materials.floor]\n\
             diffuse = {floor}\n"
        );
        let path = tmp_path(&dir, name);
        std::fs::write(&path, closed_box_text(&materials, "m", "floor")).unwrap();
        path
    };
    let white = write("white.toml", "[1, 0.2, 0.2]");
    let out = tmp_path(&dir, "white.png");
    let net = tmp_path(&dir, "white.net");
    let render = network_render(&white, &out, &["--network-file", &net]);
    let relight = network_relight(&white, &out, &net, &["--light", "m=2"]);
    for (what, run) in [("render", &render), ("relight", &relight)] {
        let e = stderr(run);
        assert_eq!(run.status.code(), Some(2), "{what}: {e}");
        let errors: Vec<&str> = e.lines().filter(|l| l.contains("error")).collect();
        assert!(
            errors.len() == 1
                && errors[0].contains("white.toml")
                && errors[0].contains("no red light emitted by material 'm' can leave"),
            "{what}: {e}"
        );
        assert!(!std::path::Path::new(&out).exists(), "{what}");
    }
    let grey = write("grey.toml", "[0.9, 0.2, 0.2]");
    let ok = network_render(&grey, &out, &[]);
    assert!(ok.status.success(), "{}", stderr(&ok));
    assert!(std::path::Path::new(&out).exists());
}

/// The same inside an open scene: the box, sealed, stands above a ground that absorbs half
/// the light and whose lines escape. The box's inner sides still keep all the red light
/// they emit (its outer sides lead out), so `render` refuses it; with the box's floor
/// absorbing a tenth of the red it renders. The library's check names the channel and an
/// emitter inside the box.
#[test]
fn a_sealed_box_that_absorbs_no_light_is_refused_in_an_open_scene() {
    use raylink::integrators::illumination_network::distribute::{lossless_channel, surfaces};
    let dir = tempfile::tempdir().unwrap();
    let ground = "[[shapes]]\ntype = \"quad\"\nmaterial = \"ground\"\n\
                  vertices = [[-1, -0.5, -1], [-1, -0.5, 2], [2, -0.5, 2], [2, -0.5, -1]]\n";
    let text = |floor: &str| {
        let materials = format!(
            "[materials.m]\ndiffuse = [1, 0.5, 0.5]\nemission = 1\n[materials.floor]\n\
             diffuse = {floor}\n[materials.ground]\ndiffuse = 0.5\n"
        );
        closed_box_text(&materials, "m", "floor") + ground
    };
    let (sealed, grey) = (text("[1, 0.2, 0.2]"), text("[0.9, 0.2, 0.2]"));
    let s = scene(&sealed);
    let net = build(&s, params(6, 1.0 / 32.0), Builder::Scan);
    assert!(net.stats.escapes > 0, "the scene is open");
    let (c, node) = lossless_channel(&net, &surfaces(&net, &s, 1.0)).expect("refused");
    let (poly, _, side) = net.node_place(node);
    let material = s.shapes[net.patches.polygons[poly as usize].shape as usize].material;
    assert_eq!((c, side, s.materials[material].name.as_str()), (0, 0, "m"));
    let g = scene(&grey);
    let net = build(&g, params(6, 1.0 / 32.0), Builder::Scan);
    assert_eq!(lossless_channel(&net, &surfaces(&net, &g, 1.0)), None);
    // Through the CLI.
    let out = tmp_path(&dir, "sealed.png");
    for (name, text, refused) in [("sealed.toml", &sealed, true), ("grey.toml", &grey, false)] {
        let path = tmp_path(&dir, name);
        std::fs::write(&path, text).unwrap();
        let run = network_render(&path, &out, &[]);
        let e = stderr(&run);
        if refused {
            assert_eq!(run.status.code(), Some(2), "{e}");
            let errors: Vec<&str> = e.lines().filter(|l| l.contains("error")).collect();
            assert!(
                errors.len() == 1
                    && errors[0].contains(name)
                    && errors[0].contains("no red light emitted by material 'm' can leave"),
                "{e}"
            );
            assert!(!std::path::Path::new(&out).exists());
        } else {
            assert!(run.status.success(), "{e}");
            assert!(std::path::Path::new(&out).exists());
        }
    }
}

fn network_relight(scene: &str, out: &str, file: &str, extra: &[&str]) -> std::process::Output {
    network_command(
        "relight",
        scene,
        out,
        &[&["--network-file", file], extra].concat(),
    )
}

/// The Cornell box's network saved by `render --network-file` in `dir`: the file's path.
fn cornell_network_file(dir: &tempfile::TempDir) -> String {
    let file = tmp_path(dir, "cornell.net");
    let built = network_render(
        "scenes/cornell-box.toml",
        &tmp_path(dir, "render.exr"),
        &["--network-file", &file],
    );
    assert!(built.status.success(), "{}", stderr(&built));
    file
}

/// `raylink relight`: no preprocess (counters in its messages); the first relight stores a
/// light basis, later ones superpose it (no distribution, no link table); doubling the
/// lights doubles the image exactly, globally or per material; the superposed image agrees
/// with a fresh distribution; changed reflectances distribute again and give exactly what
/// `render` gives from the same file; bad options are errors with exit 2.
#[test]
fn relight_subcommand_reuses_the_network() {
    let dir = tempfile::tempdir().unwrap();
    let file = cornell_network_file(&dir);
    let img = |name: &str| read_image(&dir.path().join(name)).unwrap().0;
    let size = std::fs::metadata(&file).unwrap().len();

    let first = network_relight(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "r1.exr"),
        &file,
        &[],
    );
    let e = stderr(&first);
    assert!(first.status.success(), "{e}");
    assert!(!e.contains("network: preprocess"), "{e}");
    assert!(
        e.contains("no preprocess") && e.contains("light basis"),
        "{e}"
    );
    assert!(
        std::fs::metadata(&file).unwrap().len() > size,
        "basis not stored"
    );

    let second = network_relight(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "r2.exr"),
        &file,
        &["--light-scale", "2"],
    );
    let e = stderr(&second);
    assert!(second.status.success(), "{e}");
    assert!(!e.contains("network: preprocess"), "{e}");
    assert!(
        e.contains("no distribution (0 sweeps)") && e.contains("link table not read"),
        "{e}"
    );
    let per_light = network_relight(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "r3.exr"),
        &file,
        &["--light", "light=2"],
    );
    assert!(per_light.status.success(), "{}", stderr(&per_light));
    assert!(stderr(&per_light).contains("0 sweeps"));
    let (r1, r2, r3) = (img("r1.exr"), img("r2.exr"), img("r3.exr"));
    assert!(r1.pixels.iter().any(|p| p.x > 0.0));
    for ((a, b), c) in r1.pixels.iter().zip(&r2.pixels).zip(&r3.pixels) {
        assert_eq!(*a * 2.0, *b);
        assert_eq!(*b, *c);
    }
    // The basis (one solution per emissive material, each to the tolerance) against the
    // render's single distribution.
    let fresh = img("render.exr");
    let diff: f32 = fresh
        .pixels
        .iter()
        .zip(&r1.pixels)
        .map(|(a, b)| (*a - *b).abs().element_sum())
        .sum();
    let total: f32 = fresh.pixels.iter().map(|a| a.element_sum()).sum();
    assert!(
        diff / total < 2e-3,
        "basis vs distribution {}",
        diff / total
    );

    // Other reflectances: the basis does not apply as it is; the distribution runs again,
    // starting from it, and agrees with `render` from the same file (a cold start) up to
    // the tolerance.
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml"),
    )
    .unwrap()
    .replace("diffuse = [0.63, 0.065, 0.05]", "diffuse = [0.2, 0.6, 0.6]");
    let edited = tmp_path(&dir, "edited.toml");
    std::fs::write(&edited, text).unwrap();
    let relit = network_relight(&edited, &tmp_path(&dir, "r4.exr"), &file, &[]);
    let e = stderr(&relit);
    assert!(relit.status.success(), "{e}");
    assert!(
        e.contains("other reflectances")
            && e.contains("sweeps")
            && e.contains("starting from the stored light basis"),
        "{e}"
    );
    assert!(
        !e.contains("network: preprocess") && !e.contains("0 sweeps"),
        "{e}"
    );
    let rendered = network_render(
        &edited,
        &tmp_path(&dir, "r5.exr"),
        &["--network-file", &file],
    );
    assert!(rendered.status.success(), "{}", stderr(&rendered));
    let (warm, cold) = (img("r4.exr"), img("r5.exr"));
    let (mut diff, mut total) = (0.0f64, 0.0f64);
    for (a, b) in warm.pixels.iter().zip(&cold.pixels) {
        diff += (*a - *b).abs().element_sum() as f64;
        total += b.element_sum() as f64;
    }
    eprintln!("warm against cold relight: {}", diff / total);
    assert!(total > 0.0 && diff / total < 1e-3, "{}", diff / total);
    assert_ne!(warm.pixels, r1.pixels);

    // Bad input: exit 2, nothing written.
    for (args, needle) in [
        (vec!["--light", "nosuch=2"], "nosuch"),
        (vec!["--light", "light"], "NAME=K"),
        (vec!["--integrator", "path"], "network integrator"),
    ] {
        let out = network_relight(
            "scenes/cornell-box.toml",
            &tmp_path(&dir, "x.exr"),
            &file,
            &args,
        );
        assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
        assert!(stderr(&out).contains(needle), "{}", stderr(&out));
    }
    let missing = network_relight(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "x.exr"),
        &tmp_path(&dir, "missing.net"),
        &[],
    );
    assert_eq!(missing.status.code(), Some(2));
    assert!(stderr(&missing).contains("missing.net"));
    let none = raylink(&[
        "relight",
        "scenes/cornell-box.toml",
        "-o",
        &tmp_path(&dir, "x.exr"),
    ]);
    assert_eq!(none.status.code(), Some(2));
    assert!(stderr(&none).contains("--network-file"));
    assert!(!dir.path().join("x.exr").exists());
}

/// A closed box lit by two emissive walls, "warm" (y = 0) and "cold" (x = 1); the others are
/// "m", except the floor (z = 0) and the wall x = 0 when their materials are given.
fn two_light_box(floor: Option<&str>, mirror: Option<&str>) -> Scene {
    let mut materials = "[materials.m]\ndiffuse = [0.6, 0.5, 0.4]\n\
                         [materials.warm]\ndiffuse = 0.3\nemission = [2, 1, 0.5]\n\
                         [materials.cold]\ndiffuse = 0.5\nemission = [0.5, 1, 3]\n"
        .to_string();
    for (name, m) in [("floor", floor), ("mirror", mirror)] {
        if let Some(m) = m {
            materials += &format!("[materials.{name}]\n{m}\n");
        }
    }
    let mut text = format!("{CAMERA}\n{materials}\n");
    for axis in 0..3 {
        for side in [0.0, 1.0] {
            let mat = match (axis, side == 0.0) {
                (1, true) => "warm",
                (0, false) => "cold",
                (2, true) if floor.is_some() => "floor",
                (0, true) if mirror.is_some() => "mirror",
                _ => "m",
            };
            text += &wall(axis, side, mat);
        }
    }
    scene(&text)
}

/// Asserts that `got` is within `bound` of `want`, relative: Σ|got − want| / Σ|want|.
fn assert_close(what: &str, got: &[raylink::math::Rgb], want: &[raylink::math::Rgb], bound: f64) {
    assert_eq!(got.len(), want.len(), "{what}");
    let (mut err, mut total) = (0.0f64, 0.0f64);
    for (x, y) in got.iter().zip(want) {
        err += (*x - *y).abs().element_sum() as f64;
        total += y.abs().element_sum() as f64;
    }
    assert!(
        total > 0.0 && err / total < bound,
        "{what}: relative error {}",
        err / total
    );
}

/// Superposition: in a closed box with two emissive materials, the basis solution for
/// strengths (a, b) agrees with a distribution of the box lit at (a, b); each material's own
/// solution is exactly the basis with the other switched off, and they add up exactly.
#[test]
fn light_basis_superposes_per_material() {
    use raylink::integrators::illumination_network::relight::LightBasis;
    use raylink::math::Rgb;
    let s = two_light_box(None, None);
    let net = build(&s, params(5, 1.0 / 8.0), Builder::Scan);
    let options = DistributeOptions {
        tolerance: 1e-5,
        ..Default::default()
    };
    let emission: Vec<Rgb> = s.materials.iter().map(|m| m.emission).collect();
    let basis = LightBasis::compute(&net, &s, &emission, &options);
    assert_eq!(basis.lights.len(), 2);
    let index = |name: &str| s.materials.iter().position(|m| m.name == name).unwrap();
    let (warm, cold) = (index("warm"), index("cold"));
    let with = |a: f32, b: f32| {
        let mut e = emission.clone();
        e[warm] *= a;
        e[cold] *= b;
        e
    };
    let sup = |a: f32, b: f32| basis.superpose(&net, &s, &with(a, b), &options).unwrap();
    let (only_warm, only_cold, both) = (sup(1.0, 0.0), sup(0.0, 1.0), sup(1.0, 1.0));
    for ((x, y), z) in only_warm
        .diffuse
        .iter()
        .zip(&only_cold.diffuse)
        .zip(&both.diffuse)
    {
        assert_eq!(*x + *y, *z);
    }
    // Against a distribution of the scene lit at other strengths.
    let (a, b) = (3.0, 0.25);
    let mut lit = s.clone();
    lit.materials[warm].emission *= a;
    lit.materials[cold].emission *= b;
    let reference = distribute(&net, &lit, &options);
    let got = sup(a, b);
    let (mut err, mut total) = (0.0f64, 0.0f64);
    for (x, y) in got.diffuse.iter().zip(&reference.diffuse) {
        err += (*x - *y).abs().element_sum() as f64;
        total += y.element_sum() as f64;
    }
    assert!(
        total > 0.0 && err / total < 1e-4,
        "relative error {}",
        err / total
    );
    // Other reflectances: the basis refuses.
    let mut grey = s.clone();
    grey.materials[index("m")].diffuse = raylink::scene::Texture::Constant(Rgb::splat(0.2));
    assert!(basis
        .superpose(&net, &grey, &emission, &options)
        .unwrap_err()
        .contains("reflectances"));
}

/// Relighting with other reflectances starts from the stored light basis (incremental
/// radiosity): the first sweep gathers the old solution through the new reflectances and
/// only the change is shot on. Against a cold distribution of the changed scene: the same
/// radiances (diffuse, directional, the direct part) up to the tolerance, the energy balance
/// kept, fewer sweeps; with nothing changed, one sweep. Cases: a diffuse box whose walls
/// change colour, and a box whose floor goes from diffuse to glossy (new directional nodes)
/// and whose mirror wall gets rougher.
#[test]
fn warm_start_from_a_basis_for_other_reflectances_matches_a_cold_distribution() {
    use raylink::integrators::illumination_network::distribute::Order;
    use raylink::integrators::illumination_network::relight::LightBasis;
    use raylink::math::Rgb;
    use raylink::scene::Texture;
    let box_with = |floor: &str, mirror: &str| two_light_box(Some(floor), Some(mirror));
    let diffuse_box = box_with("diffuse = 0.4", "diffuse = 0.7");
    let mut recoloured = diffuse_box.clone();
    let m = recoloured
        .materials
        .iter()
        .position(|m| m.name == "m")
        .unwrap();
    recoloured.materials[m].diffuse = Texture::Constant(Rgb::new(0.3, 0.6, 0.5));
    let glossy_box = box_with("diffuse = 0.4", "diffuse = 0\nspecular = 0.7");
    let changed_glossy = box_with(
        "diffuse = 0.2\nspecular = 0.5\nroughness = 0.3",
        "diffuse = 0\nspecular = 0.7\nroughness = 0.1",
    );
    for order in [Order::Sweeps, Order::ConjugateGradients] {
        let options = DistributeOptions {
            tolerance: 1e-5,
            order,
            ..Default::default()
        };
        for (name, old, new, step) in [
            ("diffuse box", &diffuse_box, &recoloured, 1.0 / 8.0),
            ("unchanged", &diffuse_box, &diffuse_box, 1.0 / 8.0),
            ("glossy box", &glossy_box, &changed_glossy, 1.0 / 6.0),
        ] {
            let net = build(old, params(5, step), Builder::Scan);
            let emission: Vec<Rgb> = old.materials.iter().map(|m| m.emission).collect();
            let basis = LightBasis::compute(&net, old, &emission, &options);
            let warm = basis.redistribute(&net, new, &emission, &options);
            let cold = distribute(&net, new, &options);
            assert!(warm.stats.warm_start && !cold.stats.warm_start);
            let close = |what: &str, got: &[Rgb], want: &[Rgb], bound: f64| {
                assert_close(&format!("{name}: {what}"), got, want, bound)
            };
            close("diffuse", &warm.diffuse, &cold.diffuse, 1e-4);
            close("direct", &warm.direct, &cold.direct, 1e-5);
            if name == "glossy box" {
                assert!(!warm.directional.is_empty());
                assert!(basis.dir_index != cold.dir_index, "new directional nodes");
                close("directional", &warm.directional, &cold.directional, 1e-4);
                close("incoming", &warm.incoming, &cold.incoming, 1e-4);
            }
            let st = &warm.stats;
            for c in 0..3 {
                let balance = st.emitted[c] - st.escaped[c] - st.absorbed[c] - st.unshot[c];
                assert!(
                    balance.abs() < 1e-4 * st.emitted[c],
                    "{name}: channel {c}: {balance}"
                );
                assert!((st.emitted[c] - cold.stats.emitted[c]).abs() <= 1e-6 * st.emitted[c]);
            }
            if name == "unchanged" {
                assert_eq!(st.sweeps, 1, "{name}");
            } else {
                // The sweeps carry the change alone from the start; conjugate gradients
                // start from a smaller residual at the same rate (a gather or two fewer, in
                // the larger scenes).
                let fewer = match order {
                    Order::Sweeps => st.sweeps < cold.stats.sweeps,
                    _ => st.sweeps <= cold.stats.sweeps,
                };
                assert!(
                    fewer,
                    "{name}: {} sweeps warm, {} cold",
                    st.sweeps, cold.stats.sweeps
                );
            }
            eprintln!(
                "{order:?}, {name}: {} sweeps warm, {} cold",
                st.sweeps, cold.stats.sweeps
            );
        }
    }
}

/// Reflectance series: the floor of a closed box recoloured is a weighted sum of the
/// series' terms, with no distribution, agreeing with a distribution of the recoloured box
/// (the reflected light and its direct part), and exactly doubled with the lights doubled;
/// changes the series does not cover are refused with the reason (another material changed,
/// the material made glossy, one light alone changed); a network with directional surfaces
/// gets no series; the series survive the basis's bytes, and damage to them is refused.
#[test]
fn a_reflectance_series_relights_one_material_without_a_distribution() {
    use raylink::integrators::illumination_network::relight::{LightBasis, MAX_SERIES_TERMS};
    use raylink::math::Rgb;
    use raylink::scene::Texture;
    let s = two_light_box(Some("diffuse = 0.4"), None);
    let net = build(&s, params(5, 1.0 / 8.0), Builder::Scan);
    let options = DistributeOptions {
        tolerance: 1e-5,
        ..Default::default()
    };
    let emission: Vec<Rgb> = s.materials.iter().map(|m| m.emission).collect();
    let mut basis = LightBasis::compute(&net, &s, &emission, &options);
    basis.add_series(&net, &s, &options, "floor").unwrap();
    let terms = basis.series[0].terms.len();
    assert!((3..MAX_SERIES_TERMS).contains(&terms), "{terms} terms");
    let index = |name: &str| s.materials.iter().position(|m| m.name == name).unwrap();
    let with_floor = |kd: Rgb| {
        let mut t = s.clone();
        t.materials[index("floor")].diffuse = Texture::Constant(kd);
        t
    };
    let recoloured = with_floor(Rgb::new(0.9, 0.1, 0.6));
    let (got, used) = basis
        .from_series(&net, &recoloured, &emission, &options)
        .unwrap();
    assert_eq!(used.name, "floor");
    assert_eq!(got.stats.sweeps, 0);
    let reference = distribute(&net, &recoloured, &options);
    let close = assert_close;
    close("diffuse", &got.diffuse, &reference.diffuse, 1e-4);
    close("direct", &got.direct, &reference.direct, 1e-5);
    // The old colour gives the basis's own solution back; the lights doubled, double.
    let (unchanged, _) = basis.from_series(&net, &s, &emission, &options).unwrap();
    let superposed = basis.superpose(&net, &s, &emission, &options).unwrap();
    close("unchanged", &unchanged.diffuse, &superposed.diffuse, 1e-4);
    let doubled = DistributeOptions {
        light_scale: 2.0,
        ..options
    };
    let (twice, _) = basis
        .from_series(&net, &recoloured, &emission, &doubled)
        .unwrap();
    for (x, y) in twice.diffuse.iter().zip(&got.diffuse) {
        assert_eq!(*x, *y * 2.0);
    }
    // Changes the series does not cover.
    let mut two_changed = recoloured.clone();
    two_changed.materials[index("m")].diffuse = Texture::Constant(Rgb::splat(0.2));
    let e = basis
        .from_series(&net, &two_changed, &emission, &options)
        .unwrap_err();
    assert!(e.contains("no stored reflectance series"), "{e}");
    let mut glossy = recoloured.clone();
    glossy.materials[index("floor")].specular = Rgb::splat(0.3);
    let e = basis
        .from_series(&net, &glossy, &emission, &options)
        .unwrap_err();
    assert!(e.contains("one diffuse colour"), "{e}");
    let mut one_light = emission.clone();
    one_light[index("warm")] *= 2.0;
    let e = basis
        .from_series(&net, &recoloured, &one_light, &options)
        .unwrap_err();
    assert!(e.contains("unevenly"), "{e}");
    // A network with a mirror gets no series.
    let mirrored = two_light_box(Some("diffuse = 0.4"), Some("diffuse = 0\nspecular = 0.7"));
    let mnet = build(&mirrored, params(5, 1.0 / 6.0), Builder::Scan);
    let memission: Vec<Rgb> = mirrored.materials.iter().map(|m| m.emission).collect();
    let mut mbasis = LightBasis::compute(&mnet, &mirrored, &memission, &options);
    let e = mbasis
        .add_series(&mnet, &mirrored, &options, "floor")
        .unwrap_err();
    assert!(
        e.contains("diffuse surfaces") && e.contains("mirror"),
        "{e}"
    );
    // The bytes: the series come back; cut or lengthened, the basis is refused.
    let bytes = basis.to_bytes();
    let back = LightBasis::from_bytes(&bytes, net.nodes(), net.slots()).unwrap();
    assert_eq!(back, basis);
    for cut in [1, 12, 200] {
        assert!(
            LightBasis::from_bytes(&bytes[..bytes.len() - cut], net.nodes(), net.slots()).is_none()
        );
    }
    let mut longer = bytes.clone();
    longer.push(0);
    assert!(LightBasis::from_bytes(&longer, net.nodes(), net.slots()).is_none());
}

/// `raylink relight --reflectance-series`: an unknown material is an error naming the scene
/// file (exit 2, no image); a series stored for the Cornell box's left wall relights the
/// wall recoloured with no distribution and without reading the link table, close to a
/// render that distributes from the same file.
#[test]
fn relight_with_a_reflectance_series_reads_no_link_table() {
    let dir = tempfile::tempdir().unwrap();
    let file = cornell_network_file(&dir);
    let img = |name: &str| read_image(&dir.path().join(name)).unwrap().0;
    let bad = network_relight(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "bad.exr"),
        &file,
        &["--reflectance-series", "nosuch"],
    );
    let e = stderr(&bad);
    assert_eq!(bad.status.code(), Some(2), "{e}");
    assert!(
        e.contains("cornell-box.toml") && e.contains("no material named \"nosuch\""),
        "{e}"
    );
    assert!(!dir.path().join("bad.exr").exists());
    let stored = network_relight(
        "scenes/cornell-box.toml",
        &tmp_path(&dir, "stored.exr"),
        &file,
        &[
            "--reflectance-series",
            "left_wall",
            "--reflectance-series",
            "right_wall",
        ],
    );
    let e = stderr(&stored);
    assert!(stored.status.success(), "{e}");
    assert!(e.contains("reflectance series of 'left_wall'"), "{e}");
    // The left wall blue (the scene's meshes are inline: the copy reads nothing beside it).
    let text = std::fs::read_to_string("scenes/cornell-box.toml").unwrap();
    let recoloured = text.replace("diffuse = [0.63, 0.065, 0.05]", "diffuse = [0.1, 0.2, 0.7]");
    assert_ne!(text, recoloured);
    let scene = tmp_path(&dir, "recoloured.toml");
    std::fs::write(&scene, recoloured).unwrap();
    let relit = network_relight(&scene, &tmp_path(&dir, "relit.exr"), &file, &[]);
    let full = network_render(
        &scene,
        &tmp_path(&dir, "full.exr"),
        &["--network-file", &file],
    );
    let e = stderr(&relit);
    assert!(relit.status.success(), "{e}");
    assert!(
        e.contains("relit from the reflectance series of 'left_wall'")
            && !e.contains("right_wall")
            && e.contains("link table not read"),
        "{e}"
    );
    assert!(full.status.success(), "{}", stderr(&full));
    let (got, want) = (img("relit.exr"), img("full.exr"));
    let before = img("stored.exr");
    let (err, change) = (rmse(&got, &want, None), rmse(&before, &want, None));
    let level = mean(&want, None).element_sum() as f64 / 3.0;
    assert!(
        err < 1e-3 * level && change > 100.0 * err,
        "rmse {err}, change {change}, mean {level}"
    );
}
