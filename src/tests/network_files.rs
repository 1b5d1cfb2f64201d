//! Network files whose checksums are right but whose contents no build or distribution
//! writes: counts that do not match the data, node and link indices out of range, light
//! bases of the wrong sizes or with impossible radiances. Each is refused with a message
//! naming the file and the reason, never used; a truncated file says it is truncated.

use super::network_common::{build, params, scene};
use super::network_scenes::{wall, CAMERA};
use crate::binary_file::checksum;
use crate::integrators::illumination_network::distribute::{DistributeOptions, Run};
use crate::integrators::illumination_network::file;
use crate::integrators::illumination_network::preprocess::Builder;
use crate::integrators::illumination_network::relight::LightBasis;
use crate::integrators::illumination_network::{Network, NetworkParams, NONE};
use crate::scene::Scene;
use std::path::{Path, PathBuf};

/// A box lit by a lamp (the ceiling) and by its walls, with a floor of `floor`.
fn lit_box(floor: &str) -> Scene {
    let mut text = format!(
        "{CAMERA}\n[materials.m]\ndiffuse = 0.5\nemission = 0.2\n[materials.lamp]\n\
         diffuse = 0.3\nemission = [4, 3, 2]\n[materials.floor]\n{floor}\n"
    );
    for axis in 0..3 {
        for side in [0.0, 1.0] {
            let mat = match (axis, side == 0.0) {
                (1, true) => "floor",
                (1, false) => "lamp",
                _ => "m",
            };
            text += &wall(axis, side, mat);
        }
    }
    scene(&text)
}

const P: fn() -> NetworkParams = || params(3, 1.0 / 4.0);

/// The network of `scene` with a light basis (and the reflectance series of the floor when
/// `series`), saved to `dir`.
fn saved(scene: &Scene, dir: &Path, series: bool) -> (Network, LightBasis, PathBuf) {
    let net = build(scene, P(), Builder::Scan);
    let options = DistributeOptions::default();
    let emission: Vec<_> = scene.materials.iter().map(|m| m.emission).collect();
    let mut basis = LightBasis::compute(&net, scene, &emission, &options, Run::now());
    if series {
        basis
            .add_series(&net, scene, (&options, Run::now()), "floor")
            .unwrap();
    }
    let path = dir.join("box.net");
    file::save(&path, &net, scene, Some(&basis)).unwrap();
    (net, basis, path)
}

/// Where things are in a network file (file.rs's layout).
const NODES: usize = 48;
const LINKS: usize = 52;
const SECONDS: usize = 104;
const KEYS: usize = 120;

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

fn put(b: &mut [u8], at: usize, bytes: &[u8]) {
    b[at..at + bytes.len()].copy_from_slice(bytes);
}

fn put_f32(b: &mut [u8], at: usize, v: f32) {
    put(b, at, &v.to_le_bytes());
}

fn put_u32(b: &mut [u8], at: usize, v: u32) {
    put(b, at, &v.to_le_bytes());
}

/// Offsets in a file: the basis, its light parts, the link table.
struct Layout {
    nodes: usize,
    basis: usize,
    /// dir_index, dir_rows, then each light's start.
    dir_index: usize,
    dir_rows: usize,
    lights: Vec<usize>,
    /// The first series' first term (its flux).
    series: Option<usize>,
    link_start: usize,
}

impl Layout {
    fn of(b: &[u8]) -> Layout {
        let nodes = u32_at(b, NODES) as usize;
        let basis_len = u64::from_le_bytes(b[112..120].try_into().unwrap()) as usize;
        let basis = KEYS + 4 * nodes;
        let (n_lights, n_rows) = (u32_at(b, basis + 28), u32_at(b, basis + 36) as usize);
        let dir_index = basis + 40;
        let dir_rows = dir_index + 4 * nodes;
        let mut at = dir_rows + 4 * n_rows;
        let mut lights = Vec::new();
        for _ in 0..n_lights {
            lights.push(at);
            at += 12 + u32_at(b, at + 4) as usize + 12 + 96;
            for _ in 0..4 {
                at += 4 + 12 * u32_at(b, at) as usize;
            }
        }
        let series = (at < basis + basis_len).then(|| {
            let s = at + 4;
            s + 12 + u32_at(b, s + 4) as usize + 8 + 4
        });
        Layout {
            nodes,
            basis,
            dir_index,
            dir_rows,
            lights,
            series,
            link_start: basis + basis_len + 8,
        }
    }

    /// A light's diffuse radiances, and its incoming ones.
    fn diffuse(&self, b: &[u8], light: usize) -> usize {
        let at = self.lights[light];
        at + 12 + u32_at(b, at + 4) as usize + 12 + 96 + 4
    }

    fn incoming(&self, b: &[u8], light: usize) -> usize {
        let mut at = self.diffuse(b, light) - 4;
        for _ in 0..3 {
            at += 4 + 12 * u32_at(b, at) as usize;
        }
        at + 4
    }
}

/// Rewrites a network file with `edit` applied to its bytes (checksums included, which it
/// need not mind) and both checksums made right again.
fn reseal(path: &Path, edit: impl FnOnce(&mut Vec<u8>, &Layout)) {
    let mut b = std::fs::read(path).unwrap();
    let layout = Layout::of(&b);
    edit(&mut b, &layout);
    let prefix = layout.link_start - 8;
    let sum = checksum(&b[..prefix]);
    put(&mut b, prefix, &sum.to_le_bytes());
    let n = b.len() - 8;
    let sum = checksum(&b[..n]);
    put(&mut b, n, &sum.to_le_bytes());
    std::fs::write(path, b).unwrap();
}

type Edit = Box<dyn Fn(&mut Vec<u8>, &Layout)>;

/// Each case resealed into a fresh copy of `original`: refused by the whole load and by the
/// prefix's (but for cases marked `link:`, in the link table the prefix's does not read), with
/// a one-line message naming the file and holding `expected`.
fn assert_refused(scene: &Scene, original: &[u8], path: &Path, cases: Vec<(&str, Edit, &str)>) {
    for (case, edit, expected) in cases {
        std::fs::write(path, original).unwrap();
        reseal(path, edit);
        let whole = file::load_all(path, scene, Some(&P())).map(drop);
        let prefix = file::load_prefix(path, scene, Some(&P())).map(drop);
        for (how, result) in [("load", whole), ("prefix", prefix)] {
            let e = match result {
                Err(e) => e.to_string(),
                Ok(()) if how == "prefix" && expected.starts_with("link:") => continue,
                Ok(()) => panic!("{case}: accepted by {how}"),
            };
            let expected = expected.trim_start_matches("link:");
            assert!(
                e.contains("box.net") && e.contains(expected) && !e.contains('\n'),
                "{case} ({how}): {e}"
            );
        }
    }
}

/// The header's counts, the node table and the link table: damaged, each refused with its
/// reason (`link:` marks what only the whole load, which reads the link table, sees).
#[test]
fn networks_whose_counts_or_indices_do_not_match_are_refused() {
    let s = lit_box("diffuse = 0.6");
    let dir = tempfile::tempdir().unwrap();
    let (net, _, path) = saved(&s, dir.path(), false);
    let original = std::fs::read(&path).unwrap();
    // The file as written loads, and holds the build's counts.
    let loaded = file::load(&path, &s, Some(&P())).unwrap();
    assert_eq!(loaded.links, net.links);
    assert_eq!(
        net.stats.link_ends + net.stats.escapes,
        net.links.len() as u64
    );
    let (nodes, cells) = (net.nodes() as u32, net.patches.cells);
    let n_links = net.links.len() as u32;
    let code = net.code;
    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "a link more than the build made",
            Box::new(move |b, _| put_u32(b, LINKS, n_links + 1)),
            "link ends",
        ),
        (
            "more nodes than patch sides",
            Box::new(move |b, _| put_u32(b, NODES, 2 * cells + 1)),
            "nodes for",
        ),
        (
            "a build time of NaN",
            Box::new(|b, _| put(b, SECONDS, &f64::NAN.to_le_bytes())),
            "build statistics",
        ),
        (
            "two nodes on one patch side",
            Box::new(|b, _| {
                let k = u32_at(b, KEYS);
                put_u32(b, KEYS + 4, k);
            }),
            "out of order",
        ),
        (
            "a node on a patch side past the last",
            Box::new(move |b, l| put_u32(b, KEYS + 4 * (l.nodes - 1), 2 * cells)),
            "past the last",
        ),
        (
            "links that start past 0",
            Box::new(|b, l| put_u32(b, l.link_start, 1)),
            "link:start at 1",
        ),
        (
            "links that end before the link count",
            Box::new(move |b, l| put_u32(b, l.link_start + 4 * nodes as usize, n_links - 1)),
            "link:not at the link count",
        ),
        (
            "a node without links",
            Box::new(|b, l| {
                let first = u32_at(b, l.link_start);
                put_u32(b, l.link_start + 4, first);
            }),
            "link:node 0 has no links",
        ),
        (
            "a link to a node past the last",
            Box::new(move |b, l| {
                let links = l.link_start + 4 * (nodes as usize + 1);
                let slot = code.slot(u32_at(b, links)) as u32;
                put_u32(b, links, code.pack(slot, nodes));
            }),
            "link:past the last slot or node",
        ),
    ];
    assert_refused(&s, &original, &path, cases);
}

/// A light basis of the wrong sizes, with its directional nodes misnumbered or their rows
/// linking nowhere, two lights for one material, or an emission, radiance or flux that is
/// negative or not finite: refused by the prefix's load (relighting) and the whole one.
#[test]
fn light_bases_no_distribution_writes_are_refused() {
    let s = lit_box("diffuse = 0\nspecular = 0.7");
    let dir = tempfile::tempdir().unwrap();
    let (net, basis, path) = saved(&s, dir.path(), false);
    let original = std::fs::read(&path).unwrap();
    let (_, stored) = file::load_prefix(&path, &s, Some(&P())).unwrap();
    assert_eq!(stored.as_ref(), Some(&basis));
    // Two lights, and directional nodes (the mirror floor's) with rows.
    assert_eq!(basis.lights.len(), 2);
    let first_dir = basis.dir_index.iter().position(|&k| k != NONE).unwrap();
    assert!(!basis.dir_rows.is_empty());
    let nodes = net.nodes() as u32;
    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "a tolerance of NaN",
            Box::new(|b, l| put_f32(b, l.basis + 8, f32::NAN)),
            "tolerance NaN",
        ),
        (
            "a distribution order of 7",
            Box::new(|b, l| put_u32(b, l.basis + 16, 7)),
            "order 7",
        ),
        (
            "a directional-node entry too many",
            Box::new(move |b, l| put_u32(b, l.basis + 32, nodes + 1)),
            "directional-node entries",
        ),
        (
            "the first directional node numbered 5",
            Box::new(move |b, l| put_u32(b, l.dir_index + 4 * first_dir, 5)),
            "directional node 5",
        ),
        (
            "a directional row linking past the last node",
            Box::new(move |b, l| put_u32(b, l.dir_rows, nodes)),
            "past the last",
        ),
        (
            "two lights for one material",
            Box::new(|b, l| {
                let m = u32_at(b, l.lights[0]);
                put_u32(b, l.lights[1], m);
            }),
            "two lights for material",
        ),
        (
            "a negative emission",
            Box::new(|b, l| {
                let at = l.lights[0] + 12 + u32_at(b, l.lights[0] + 4) as usize;
                put_f32(b, at, -1.0);
            }),
            "emission",
        ),
        (
            "an infinite escaped flux",
            Box::new(|b, l| {
                let at = l.diffuse(b, 0) - 4 - 96 + 24;
                put(b, at, &f64::INFINITY.to_le_bytes());
            }),
            "escaped flux inf",
        ),
        (
            "a diffuse radiance of NaN",
            Box::new(|b, l| {
                let at = l.diffuse(b, 1) + 12 * 3 + 4;
                put_f32(b, at, f32::NAN)
            }),
            "diffuse radiance",
        ),
        (
            "a negative incoming radiance",
            Box::new(|b, l| {
                let at = l.incoming(b, 0);
                put_f32(b, at, -2.0)
            }),
            "incoming radiance",
        ),
        (
            "a light with a node's radiance missing",
            Box::new(move |b, l| {
                let at = l.diffuse(b, 0) - 4;
                put_u32(b, at, nodes - 1)
            }),
            "radiances where",
        ),
    ];
    assert_refused(&s, &original, &path, cases);
}

/// A reflectance series with no terms, or a term with a negative radiance or a flux of NaN.
#[test]
fn reflectance_series_no_distribution_writes_are_refused() {
    let s = lit_box("diffuse = 0.6");
    let dir = tempfile::tempdir().unwrap();
    let (_, basis, path) = saved(&s, dir.path(), true);
    assert_eq!(basis.series.len(), 1);
    let original = std::fs::read(&path).unwrap();
    assert!(file::load_prefix(&path, &s, Some(&P())).is_ok());
    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "no terms",
            Box::new(|b, l| put_u32(b, l.series.unwrap() - 4, 0)),
            "0 terms",
        ),
        (
            "a flux of NaN",
            Box::new(|b, l| put(b, l.series.unwrap() + 8, &f64::NAN.to_le_bytes())),
            "term 0: flux NaN",
        ),
        (
            "a negative radiance",
            Box::new(|b, l| put_f32(b, l.series.unwrap() + 48 + 4 + 12 * 2, -1.0)),
            "term 0: radiance",
        ),
    ];
    assert_refused(&s, &original, &path, cases);
}

/// A network cut short anywhere says it is truncated, even when the caller expects other
/// settings than its header's (the header is not there to compare).
#[test]
fn truncated_networks_say_so() {
    let s = lit_box("diffuse = 0.6");
    let dir = tempfile::tempdir().unwrap();
    let (_, _, path) = saved(&s, dir.path(), false);
    let original = std::fs::read(&path).unwrap();
    let layout = Layout::of(&original);
    let len = original.len();
    let other = NetworkParams { slopes: 4, ..P() };
    for cut in [
        1,
        7,
        8,
        11,
        12,
        40,
        119,
        120,
        layout.basis + 3,
        layout.link_start - 8,
        layout.link_start,
        len / 2,
        len - 9,
        len - 8,
        len - 1,
    ] {
        let cut_path = dir.path().join("cut.net");
        std::fs::write(&cut_path, &original[..cut]).unwrap();
        for expected in [Some(P()), None] {
            let e = file::load(&cut_path, &s, expected.as_ref()).unwrap_err();
            let e = e.to_string();
            assert!(
                e.contains("cut.net") && e.contains("truncated"),
                "{cut} of {len} bytes: {e}"
            );
            let e = file::load_prefix(&cut_path, &s, expected.as_ref()).unwrap_err();
            assert!(e.to_string().contains("truncated"), "{cut}: prefix: {e}");
        }
        // With other settings expected, a whole header is compared first.
        let e = file::load(&cut_path, &s, Some(&other))
            .unwrap_err()
            .to_string();
        let want = if cut < 120 {
            "truncated"
        } else {
            "other network settings"
        };
        assert!(e.contains(want), "{cut} with other settings: {e}");
    }
}
