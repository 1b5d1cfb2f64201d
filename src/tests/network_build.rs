//! Illumination networks (Buckalew & Fussell 1989), the preprocess: the ray space's étendue
//! against π·area, the incremental intersections against direct ones, the two builders
//! against each other, network files read back, and the network independent of the threads.

use super::network_common::{build, cornell, params, scene};
use super::network_scenes::{wall, CAMERA};
use crate::accel::{self, Backend};
use crate::control::Control;
use crate::integrators::illumination_network::distribute::{distribute, DistributeOptions};
use crate::integrators::illumination_network::patches::Patches;
use crate::integrators::illumination_network::preprocess::{
    line_point, scan_order, scan_polygon, scan_slot, Builder,
};
use crate::integrators::illumination_network::ray_space::{axes, RaySpace};
use crate::integrators::illumination_network::{Network, NetworkParams, ESCAPE};
use crate::math::Vec3;
use crate::transport::Context;

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
    let accel = accel::build(&s, Backend::Embree, &Control::default()).unwrap();
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

/// The Cornell box's network (S = 5, h = 1/16), saved to a file in a temporary directory.
fn saved_cornell_network() -> (
    crate::scene::Scene,
    Network,
    tempfile::TempDir,
    std::path::PathBuf,
) {
    use crate::integrators::illumination_network::file;
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
    use crate::integrators::illumination_network::file;
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
    use crate::integrators::illumination_network::file;
    let (scene, net, _dir, path) = saved_cornell_network();
    assert!(file::load(&path, &scene, None).is_ok());
    let bytes = std::fs::read(&path).unwrap();
    // The links are the last words before the checksum.
    let links_at = bytes.len() - 8 - 4 * net.links.len();
    let damaged = |i: usize, link: u32| {
        let mut b = bytes.clone();
        b[links_at + 4 * i..links_at + 4 * i + 4].copy_from_slice(&link.to_le_bytes());
        let n = b.len() - 8;
        let sum = crate::binary_file::checksum(&b[..n]);
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
