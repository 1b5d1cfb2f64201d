//! NanoVDB volumes: files made by the test writer (`common/nanovdb.rs`, written from the
//! format's layout) read back with their values at known voxels, directly and through
//! pbrt-v4's `nanovdb` medium placed by the grid's map and the current transform; damaged
//! files refused with one line naming the file and the problem; and the committed files of
//! the bad-input cases and the fuzz corpus as the writer makes them.

#[path = "common/nanovdb.rs"]
mod writer;

use raylink::control::MemoryBudget;
use raylink::input_file::Allowance;
use raylink::math::{Mat4, Ray, Rng, Vec3};
use raylink::scene::media::nanovdb::{self, Layout};
use raylink::scene::media::{
    tracking, MediumKind, MediumModel, MediumPoint, SparseSource, SparseValues,
};
use raylink::scene::Scene;
use std::path::PathBuf;
use writer::Grid;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A grid over two upper nodes, three lower nodes and four leaves, with a rotating, scaling
/// map and an offset.
fn smoke() -> Grid {
    let mut g = Grid::new("density")
        .voxel([0, 0, 0], 1.0)
        .voxel([1, 2, 3], 2.5)
        .voxel([10, 0, 0], 0.5)
        .voxel([130, 5, -3], 3.0);
    // x ← -0.2 j, y ← 0.1 i, z ← 0.3 k, then (0.5, -1, 2).
    g.matrix = [0.0, -0.2, 0.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.3];
    g.translation = [0.5, -1.0, 2.0];
    g
}

fn read(bytes: &[u8], names: &[&str]) -> raylink::Result<Vec<Option<nanovdb::FloatGrid>>> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("v.nvdb");
    std::fs::write(&path, bytes).unwrap();
    nanovdb::read(&path, names, &Allowance::machine())
}

#[test]
fn a_grid_reads_back_at_its_voxels() {
    let grids = read(
        &writer::file(&[smoke(), Grid::new("other").voxel([5, 5, 5], 9.0)], 0),
        &["density", "temperature", "other"],
    )
    .unwrap();
    let g = grids[0].as_ref().expect("the density grid");
    assert!(grids[1].is_none());
    assert_eq!(grids[2].as_ref().unwrap().value([5, 5, 5]), 9.0);
    // The active box (0..130, 0..5, -3..3) and one voxel of background around it.
    assert_eq!(g.res, [133, 8, 9]);
    assert_eq!(g.origin, [-1, -1, -4]);
    for (ijk, v) in &smoke().voxels {
        assert_eq!(g.value(*ijk), *v, "voxel {ijk:?}");
    }
    let nonzero = g.dense().unwrap().iter().filter(|v| **v != 0.0).count();
    assert_eq!(nonzero, 4);
    let p = g.index_to_world.transform_point3(Vec3::new(1.0, 2.0, 3.0));
    assert!((p - Vec3::new(0.1, -0.9, 2.9)).length() < 1e-6, "{p}");
}

/// A pbrt scene in `dir` with [`smoke`] in `smoke.nvdb` as its medium "smoke", made under
/// `transform` with `params`.
fn smoke_scene(dir: &std::path::Path, transform: &str, params: &str) -> PathBuf {
    std::fs::write(dir.join("smoke.nvdb"), writer::file(&[smoke()], 0)).unwrap();
    let path = dir.join("s.pbrt");
    let text = format!(
        "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\nAttributeBegin\n\
         {transform}\nMakeNamedMedium \"smoke\" \"string type\" \"nanovdb\" \
         \"string filename\" \"smoke.nvdb\" {params}\nAttributeEnd\nShape \"sphere\"\n"
    );
    std::fs::write(&path, text).unwrap();
    path
}

/// The medium pbrt-v4's `nanovdb` makes: σa times the density at world points, the grid's
/// map composed with the transform current at the statement; trilinear between voxels.
#[test]
fn a_nanovdb_medium_has_the_density_of_its_voxels_in_the_world() {
    let dir = tempfile::tempdir().unwrap();
    let scene_path = smoke_scene(
        dir.path(),
        "Translate 1 2 3\nRotate 30 0 1 0",
        r#""rgb sigma_a" [2 2 2] "rgb sigma_s" [0 0 0]"#,
    );
    let scene = Scene::load(&scene_path).unwrap_or_else(|e| panic!("{e}"));
    let medium = scene.media[0].model();
    assert_eq!(medium.kind(), "uniformgrid");
    let s = smoke();
    let map = Mat4::from_cols_array(&[
        s.matrix[0] as f32,
        s.matrix[3] as f32,
        s.matrix[6] as f32,
        0.0,
        s.matrix[1] as f32,
        s.matrix[4] as f32,
        s.matrix[7] as f32,
        0.0,
        s.matrix[2] as f32,
        s.matrix[5] as f32,
        s.matrix[8] as f32,
        0.0,
        s.translation[0] as f32,
        s.translation[1] as f32,
        s.translation[2] as f32,
        1.0,
    ]);
    let ctm = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0))
        * Mat4::from_axis_angle(Vec3::Y, 30f32.to_radians());
    let world = |i: f32, j: f32, k: f32| (ctm * map).transform_point3(Vec3::new(i, j, k));
    let density = |p: Vec3| medium.at(p).sigma_a.x / 2.0;
    let cases = [
        ((0.0, 0.0, 0.0), 1.0),
        ((1.0, 2.0, 3.0), 2.5),
        ((10.0, 0.0, 0.0), 0.5),
        ((130.0, 5.0, -3.0), 3.0),
        // Halfway to a background voxel, and between two voxels.
        ((0.5, 0.0, 0.0), 0.5),
        ((131.0, 5.0, -3.0), 0.0),
        ((130.25, 5.0, -3.0), 2.25),
        ((5.0, 1.0, 1.0), 0.0),
    ];
    for ((i, j, k), want) in cases {
        let got = density(world(i, j, k));
        assert!(
            (got - want).abs() < 1e-3,
            "({i}, {j}, {k}): {got} against {want}"
        );
    }
    // Far outside the grid: nothing.
    assert_eq!(density(Vec3::new(-50.0, 0.0, 0.0)), 0.0);
}

/// A native `[media]` table of type nanovdb reads the file as pbrt-v4's statement does, and
/// names the key at fault when it cannot.
#[test]
fn a_native_nanovdb_medium_is_pbrts() {
    let dir = tempfile::tempdir().unwrap();
    let pbrt_path = smoke_scene(
        dir.path(),
        "Translate 1 2 3",
        r#""rgb sigma_a" [2 1 0.5] "float g" 0.5"#,
    );
    let toml = |medium: &str| {
        format!(
            "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\
             [materials.white]\ndiffuse = 0.5\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"white\"\n\
             [media.smoke]\n{medium}\n"
        )
    };
    let toml_path = dir.path().join("s.toml");
    std::fs::write(
        &toml_path,
        toml(
            "type = \"nanovdb\"\nfile = \"smoke.nvdb\"\nsigma_a = [2, 1, 0.5]\ng = 0.5\n\
             transform = { translate = [1, 2, 3] }",
        ),
    )
    .unwrap();
    let a = Scene::load(&pbrt_path).unwrap_or_else(|e| panic!("{e}"));
    let b = Scene::load(&toml_path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(a.media, b.media);
    for (medium, expect) in [
        (
            "type = \"nanovdb\"",
            "media.smoke.file: a nanovdb medium needs `file`",
        ),
        (
            "type = \"nanovdb\"\nfile = \"smoke.nvdb\"\ngrid = \"heat\"",
            "media.smoke.grid: ",
        ),
        (
            "type = \"nanovdb\"\nfile = \"none.nvdb\"",
            "media.smoke.file: ",
        ),
        (
            "type = \"nanovdb\"\nfile = \"smoke.nvdb\"\nresolution = [1, 1, 1]",
            "media.smoke.resolution: a nanovdb medium does not take it",
        ),
    ] {
        std::fs::write(&toml_path, toml(medium)).unwrap();
        let e = Scene::load(&toml_path).unwrap_err().to_string();
        assert!(e.contains(expect) && !e.contains('\n'), "{medium}: {e}");
    }
}

/// Damaged and foreign files: one line naming the file and the problem, never a panic.
#[test]
fn damaged_files_are_refused_with_one_line() {
    let valid = writer::file(&[smoke()], 0);
    let mut cases: Vec<(String, Vec<u8>, &str)> = Vec::new();
    let mut case = |name: &str, bytes: Vec<u8>, expect: &'static str| {
        cases.push((name.into(), bytes, expect));
    };
    case(
        "text",
        b"LookAt 0 0 0  0 0 -1  0 1 0\n".to_vec(),
        "is not a NanoVDB file",
    );
    let mut big = valid.clone();
    big[..8].reverse();
    case("big-endian", big, "is a big-endian NanoVDB file");
    let mut old = smoke();
    old.version = (31 << 21) | (2 << 10);
    case(
        "version",
        writer::file(&[old], 0),
        "of version 31.2.0; raylink reads version 32",
    );
    case(
        "blosc",
        writer::file(&[smoke()], 2),
        "is compressed with Blosc, which raylink does not read; re-save it with nanovdb_convert",
    );
    case(
        "unknown codec",
        writer::file(&[smoke()], 7),
        "is compressed with an unknown codec (7)",
    );
    let mut double = smoke();
    double.value_type = 2;
    case(
        "double",
        writer::file(&[double], 0),
        "holds double values; raylink reads float",
    );
    let mut level_set = smoke();
    level_set.class = 1;
    case(
        "level set",
        writer::file(&[level_set], 0),
        "is a level set, not a fog volume",
    );
    case(
        "empty",
        writer::file(&[Grid::new("density")], 0),
        "holds no active voxels",
    );
    case(
        "negative",
        writer::file(&[smoke().voxel([2, 2, 2], -1.0)], 0),
        "has -1 at voxel (2, 2, 2): densities must be finite",
    );
    case(
        "negative in a sparse grid",
        writer::file(&[smoke().voxel([1000, 1000, 200], -2.0)], 0),
        "has -2 at voxel (1000, 1000, 200): densities must be finite",
    );
    // The first root tile's child pointing past the end.
    let mut wild = valid.clone();
    let tile = valid.len() - smoke().bytes().len() + 672 + 64 + 64 + 8;
    wild[tile..tile + 8].copy_from_slice(&(1i64 << 40).to_le_bytes());
    case(
        "wild child",
        wild,
        "is corrupt: an upper node lies outside the grid's bytes",
    );
    // The second root tile's child made the first's: a node with two parents.
    let mut shared = valid.clone();
    let first: [u8; 8] = valid[tile..tile + 8].try_into().unwrap();
    shared[tile + 32..tile + 40].copy_from_slice(&first);
    case(
        "shared child",
        shared,
        "is corrupt: an upper node is the child of two parents",
    );
    // Truncations: inside the header, a record, the name, the grid.
    for cut in [3, 15, 16, 100, 192, 200, 1000, 100_000, valid.len() - 1] {
        case(
            &format!("cut at {cut}"),
            valid[..cut].to_vec(),
            "is truncated",
        );
    }
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes, expect) in cases {
        let path = dir.path().join("v.nvdb");
        std::fs::write(&path, &bytes).unwrap();
        let e = nanovdb::read(&path, &["density"], &Allowance::machine())
            .err()
            .unwrap_or_else(|| panic!("{name}: read"))
            .to_string();
        assert!(!e.contains('\n'), "{name}: {e}");
        assert!(e.starts_with(&path.display().to_string()), "{name}: {e}");
        assert!(e.contains(expect), "{name}: {e}");
    }
    // Every cut of a small file is refused (or reads what is whole), never a panic.
    let small = writer::file(&[Grid::new("density"), Grid::new("x")], 0);
    for cut in 0..small.len() {
        let path = dir.path().join("cut.nvdb");
        std::fs::write(&path, &small[..cut]).unwrap();
        if let Err(e) = nanovdb::read(&path, &["x"], &Allowance::machine()) {
            assert!(!e.to_string().contains('\n'));
        }
    }
}

/// The byte where the one grid of a one-grid file `bytes` starts, and its record.
fn grid_start(bytes: &[u8]) -> (usize, usize) {
    let name = u32::from_le_bytes(bytes[16 + 136..16 + 140].try_into().unwrap()) as usize;
    (16 + 176 + name, 16)
}

/// A ZIP-compressed file reads bit for bit as the uncompressed one, grids it skips and all.
#[test]
fn a_zip_file_reads_as_the_uncompressed_one() {
    let grids = [smoke(), Grid::new("other").voxel([5, 5, 5], 9.0)];
    let names = ["density", "temperature", "other"];
    let plain = read(&writer::file(&grids, 0), &names).unwrap();
    let zipped = writer::file(&grids, 1);
    assert!(
        zipped.len() * 10 < writer::file(&grids, 0).len(),
        "ZIP did not compress"
    );
    let zip = read(&zipped, &names).unwrap();
    assert!(zip[1].is_none());
    for (a, b) in plain.iter().zip(&zip) {
        let (Some(a), Some(b)) = (a, b) else { continue };
        assert_eq!(
            (a.res, a.origin, a.index_to_world),
            (b.res, b.origin, b.index_to_world)
        );
        let bits = |g: &nanovdb::FloatGrid| {
            g.dense()
                .unwrap()
                .iter()
                .map(|v| v.to_bits())
                .collect::<Vec<_>>()
        };
        assert!(bits(a) == bits(b), "the values differ");
    }
    let g = zip[0].as_ref().unwrap();
    for (ijk, v) in &smoke().voxels {
        assert_eq!(g.value(*ijk).to_bits(), v.to_bits(), "voxel {ijk:?}");
    }
}

/// Damaged ZIP data, and records or sizes that lie about it: one line, never a panic, and
/// never an allocation of what a lying record claims beyond the budget.
#[test]
fn damaged_zip_data_is_refused_with_one_line() {
    let valid = writer::file(&[smoke()], 1);
    let (start, record) = grid_start(&valid);
    let packed = valid.len() - start - 8;
    let raw = smoke().bytes().len() as u64;
    let mut cases: Vec<(String, Vec<u8>, &str)> = Vec::new();
    let mut case = |name: &str, bytes: Vec<u8>, expect: &'static str| {
        cases.push((name.into(), bytes, expect));
    };
    // The file and the record both cut: the stream ends early.
    let mut cut = valid[..valid.len() - 20].to_vec();
    cut[record + 8..record + 16].copy_from_slice(&(packed as u64 - 12).to_le_bytes());
    cut[start..start + 8].copy_from_slice(&(packed as u64 - 20).to_le_bytes());
    case("cut stream", cut, "its ZIP data is cut short");
    case(
        "cut file",
        valid[..valid.len() - 1].to_vec(),
        "is truncated: grid \"density\" needs",
    );
    let mut flipped = valid.clone();
    flipped[start + 8 + packed / 2] ^= 0x55;
    case("flipped byte", flipped, "grid \"density\" is corrupt: ");
    let mut sum = valid.clone();
    let last = sum.len() - 1;
    sum[last] ^= 1;
    case("checksum", sum, "its ZIP data fails its checksum");
    let mut more = valid.clone();
    more[record..record + 8].copy_from_slice(&(raw + 1).to_le_bytes());
    case("record says more", more, "it inflates to");
    let mut less = valid.clone();
    less[record..record + 8].copy_from_slice(&(raw - 1).to_le_bytes());
    case("record says less", less, "it inflates to more than the");
    let mut prefix = valid.clone();
    prefix[start..start + 8].copy_from_slice(&(1u64 << 40).to_le_bytes());
    case(
        "compressed size lies",
        prefix,
        "its ZIP data says 1099511627776 compressed bytes",
    );
    let mut empty = valid.clone();
    empty[record + 8..record + 16].copy_from_slice(&4u64.to_le_bytes());
    case("no size", empty, "too few for its compressed size");
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes, expect) in cases {
        let path = dir.path().join("v.nvdb");
        std::fs::write(&path, &bytes).unwrap();
        let e = nanovdb::read(&path, &["density"], &Allowance::machine())
            .err()
            .unwrap_or_else(|| panic!("{name}: read"))
            .to_string();
        assert!(!e.contains('\n'), "{name}: {e}");
        assert!(e.starts_with(&path.display().to_string()), "{name}: {e}");
        assert!(e.contains(expect), "{name}: {e}");
    }
    // A record claiming an exabyte is refused by the budget before any allocation.
    let mut huge = valid.clone();
    huge[record..record + 8].copy_from_slice(&(1u64 << 60).to_le_bytes());
    let path = dir.path().join("huge.nvdb");
    std::fs::write(&path, &huge).unwrap();
    let e = nanovdb::read(&path, &["density"], &Allowance::machine()).unwrap_err();
    assert!(matches!(e, raylink::Error::Memory { .. }), "{e}");
    // Every cut of a ZIP file is refused (or reads what is whole), never a panic.
    for cut in 0..valid.len() {
        std::fs::write(&path, &valid[..cut]).unwrap();
        if let Err(e) = nanovdb::read(&path, &["density"], &Allowance::machine()) {
            assert!(!e.to_string().contains('\n'));
        }
    }
}

/// The dense grid counts against the memory budget, beside the file's bytes.
#[test]
fn the_dense_grid_counts_against_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("v.nvdb");
    let bytes = writer::file(&[smoke()], 0);
    std::fs::write(&path, &bytes).unwrap();
    let dense = 133 * 8 * 9 * 4;
    let tight = Allowance::new(MemoryBudget::bytes(bytes.len() as u64 + dense - 1), 0);
    let e = nanovdb::read(&path, &["density"], &tight).unwrap_err();
    assert!(matches!(e, raylink::Error::Memory { .. }), "{e}");
    assert!(
        e.to_string().contains("the NanoVDB grid \"density\""),
        "{e}"
    );
    let enough = Allowance::new(MemoryBudget::bytes(bytes.len() as u64 + dense), 0);
    assert!(nanovdb::read(&path, &["density"], &enough).is_ok());
    // A ZIP grid's inflated bytes count too, while the dense grid is made from them.
    let zip = writer::file(&[smoke()], 1);
    std::fs::write(&path, &zip).unwrap();
    let inflated = smoke().bytes().len() as u64;
    let need = zip.len() as u64 + inflated + dense;
    let tight = Allowance::new(MemoryBudget::bytes(need - 1), 0);
    let e = nanovdb::read(&path, &["density"], &tight).unwrap_err();
    assert!(matches!(e, raylink::Error::Memory { .. }), "{e}");
    let enough = Allowance::new(MemoryBudget::bytes(need), 0);
    assert!(nanovdb::read(&path, &["density"], &enough).is_ok());
}

/// The committed files (the bad-input cases' volumes and the fuzz seeds) are the writer's:
/// `RAYLINK_WRITE_NANOVDB=1 cargo test --release --test nanovdb committed` writes them.
#[test]
fn committed_files_are_the_writers() {
    let mut old = Grid::new("density");
    old.version = (31 << 21) | (2 << 10);
    let mut double = Grid::new("density");
    double.value_type = 2;
    let empty = writer::file(&[Grid::new("density")], 0);
    let mut big_endian = empty.clone();
    big_endian[..8].reverse();
    let mut level_set = Grid::new("density");
    level_set.class = 1;
    let one_voxel = Grid::new("density").voxel([3, -2, 7], 0.75);
    // A ZIP grid whose checksum fails (its last byte flipped).
    let mut bad_zip = writer::file(std::slice::from_ref(&one_voxel), 1);
    *bad_zip.last_mut().unwrap() ^= 1;
    let files: Vec<(&str, Vec<u8>)> = vec![
        (
            "tests/bad_inputs/pbrt/volumes/other-grid.nvdb",
            writer::file(&[Grid::new("smoke")], 0),
        ),
        ("tests/bad_inputs/pbrt/volumes/zip.nvdb", bad_zip.clone()),
        (
            "tests/bad_inputs/pbrt/volumes/blosc.nvdb",
            writer::file(std::slice::from_ref(&one_voxel), 2),
        ),
        (
            "tests/bad_inputs/pbrt/volumes/version-31.nvdb",
            writer::file(&[old.clone()], 0),
        ),
        (
            "tests/bad_inputs/pbrt/volumes/double.nvdb",
            writer::file(&[double.clone()], 0),
        ),
        (
            "tests/bad_inputs/pbrt/volumes/truncated.nvdb",
            empty[..empty.len() / 2].to_vec(),
        ),
        (
            "tests/bad_inputs/pbrt/volumes/not-nanovdb.nvdb",
            b"#!nvdb\n".repeat(4),
        ),
        (
            "fuzz/corpus/nanovdb/valid_one_voxel",
            writer::file(&[one_voxel.clone(), Grid::new("temperature")], 0),
        ),
        ("fuzz/corpus/nanovdb/empty", empty.clone()),
        (
            "fuzz/corpus/nanovdb/other_grid",
            writer::file(&[Grid::new("smoke")], 0),
        ),
        (
            "fuzz/corpus/nanovdb/zip",
            writer::file(&[one_voxel.clone(), Grid::new("temperature")], 1),
        ),
        ("fuzz/corpus/nanovdb/zip_checksum", bad_zip),
        // Two voxels 600 apart: a box beyond a dense grid, kept sparse.
        (
            "fuzz/corpus/nanovdb/zip_sparse",
            writer::file(
                &[Grid::new("density")
                    .voxel([0, 0, 0], 1.0)
                    .voxel([600, 600, 600], 2.0)],
                1,
            ),
        ),
        ("fuzz/corpus/nanovdb/version_31", writer::file(&[old], 0)),
        ("fuzz/corpus/nanovdb/double", writer::file(&[double], 0)),
        (
            "fuzz/corpus/nanovdb/truncated",
            empty[..empty.len() / 2].to_vec(),
        ),
        ("fuzz/corpus/nanovdb/header_only", empty[..16].to_vec()),
        (
            "fuzz/corpus/nanovdb/two_segments",
            [empty.clone(), empty.clone()].concat(),
        ),
        ("fuzz/corpus/nanovdb/big_endian", big_endian),
        (
            "fuzz/corpus/nanovdb/level_set",
            writer::file(&[level_set], 0),
        ),
    ];
    let write = std::env::var_os("RAYLINK_WRITE_NANOVDB").is_some();
    for (name, bytes) in files {
        let path = root().join(name);
        if write {
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(&path, &bytes).unwrap();
        }
        let committed = std::fs::read(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(committed == bytes, "{name} is not the writer's");
    }
}

/// Coefficients of one unit of absorption at density 1.
fn absorbing(sigma_a: f32) -> MediumPoint {
    MediumPoint {
        sigma_a: Vec3::splat(sigma_a),
        sigma_s: Vec3::ZERO,
        le: Vec3::ZERO,
        g: 0.0,
    }
}

/// The medium of the grid "density" of `bytes`, kept as `layout` says, under `transform`.
fn medium_of(bytes: &[u8], layout: Layout, transform: Mat4, sigma_a: f32) -> MediumKind {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("v.nvdb");
    std::fs::write(&path, bytes).unwrap();
    let grid = nanovdb::read_as(&path, &["density"], &Allowance::machine(), layout)
        .unwrap()
        .remove(0)
        .unwrap();
    let source = SparseSource {
        file: path,
        grid: "density".into(),
        transform,
    };
    nanovdb::medium(grid, absorbing(sigma_a), source).unwrap()
}

/// A grid kept sparse reads bit for bit as the same grid kept dense, at random points in and
/// around its box, and its majorants bound it along random rays.
#[test]
fn a_sparse_grid_reads_as_the_dense_one() {
    let mut g = smoke();
    for i in 0..40 {
        g = g.voxel([i * 3 % 17, i % 7, -(i % 5)], 0.25 * i as f32);
    }
    g.background = 0.125;
    let bytes = writer::file(&[g], 0);
    let xf = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0)) * Mat4::from_rotation_y(0.5);
    let dense = medium_of(&bytes, Layout::Fitting, xf, 2.0);
    let sparse = medium_of(&bytes, Layout::Sparse, xf, 2.0);
    assert!(matches!(dense, MediumKind::UniformGrid(_)));
    assert!(matches!(sparse, MediumKind::SparseGrid(_)));
    let (dense, sparse) = (dense.model(), sparse.model());
    let s = smoke();
    let map = Mat4::from_cols_array(&[
        s.matrix[0] as f32,
        s.matrix[3] as f32,
        s.matrix[6] as f32,
        0.0,
        s.matrix[1] as f32,
        s.matrix[4] as f32,
        s.matrix[7] as f32,
        0.0,
        s.matrix[2] as f32,
        s.matrix[5] as f32,
        s.matrix[8] as f32,
        0.0,
        s.translation[0] as f32,
        s.translation[1] as f32,
        s.translation[2] as f32,
        1.0,
    ]);
    let mut rng = Rng::for_key(7, &[]);
    let mut u = || rng.uniform();
    let mut nonzero = 0;
    for _ in 0..200_000 {
        let ijk = Vec3::new(u() * 136.0 - 3.0, u() * 10.0 - 2.0, u() * 11.0 - 5.0);
        let p = (xf * map).transform_point3(ijk);
        let (a, b) = (dense.at(p).sigma_a.x, sparse.at(p).sigma_a.x);
        assert_eq!(a.to_bits(), b.to_bits(), "at index {ijk}: {a} against {b}");
        nonzero += usize::from(a > 0.25);
    }
    assert!(nonzero > 1000, "only {nonzero} points in the voxels");
    let lo = (xf * map).transform_point3(Vec3::new(-3.0, -2.0, -5.0));
    let hi = (xf * map).transform_point3(Vec3::new(133.0, 8.0, 6.0));
    for _ in 0..2000 {
        let mut v = || lo + (hi - lo) * Vec3::new(u(), u(), u());
        let ray = Ray::new(v(), v() - v());
        let mut stretches = Vec::new();
        sparse.segments(&ray, 1.0, &mut |s| {
            stretches.push(s);
            true
        });
        for k in 0..64 {
            let t = (k as f32 + 0.5) / 64.0;
            let d = sparse.at(ray.origin + ray.dir * t).sigma_a.x * ray.dir.length();
            let bound = stretches
                .iter()
                .find(|s| s.t0 <= t && t <= s.t1)
                .map_or(0.0, |s| s.sigma_maj.x);
            assert!(
                d <= bound * 1.0001 + 1e-6,
                "density {d} over the bound {bound}"
            );
        }
    }
}

/// Ratio tracking's transmittance along `ray` to `t_max` (the integrators' walk through the
/// majorants), averaged over `n` walks.
fn transmittance(medium: &dyn MediumModel, ray: &Ray, t_max: f32, n: usize) -> f64 {
    let mut rng = Rng::for_key(11, &[]);
    let mut sum = 0.0;
    for _ in 0..n {
        let mut t = 1.0f64;
        tracking::sample_majorant(medium, ray, t_max, 0, &mut rng, &mut |c| {
            t *= 1.0 - f64::from(c.point.sigma_a.x / c.sigma_maj.x);
            true
        });
        sum += t;
    }
    sum / n as f64
}

/// Blobs 200000 voxels apart: a box far beyond a dense grid, read sparse, and light
/// through each blob (and both) is attenuated as exp(-σa ∫density), the integral known from
/// the voxels (linear interpolation between samples 1 along a row of three: 3 voxels).
#[test]
fn far_apart_blobs_load_sparse_and_attenuate_as_their_density() {
    let mut g = Grid::new("density");
    for far in [[0, 0, 0], [200_000, 0, 0], [0, 200_000, 200_000]] {
        for x in 0..3 {
            for y in 0..3 {
                for z in 0..3 {
                    g = g.voxel([far[0] + x, far[1] + y, far[2] + z], 1.0);
                }
            }
        }
    }
    // Voxels 0.01 apart: the blobs are 2000 units apart.
    let voxel = 0.01f32;
    g.matrix = [0.01, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.01];
    let bytes = writer::file(&[g], 0);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("blobs.nvdb");
    std::fs::write(&path, &bytes).unwrap();
    let grid = nanovdb::read(&path, &["density"], &Allowance::machine()).unwrap()[0]
        .take()
        .unwrap();
    assert_eq!(grid.res, [200_005; 3]);
    let nanovdb::Values::Sparse(values) = &grid.values else {
        panic!("the grid is dense");
    };
    assert_eq!(values.leaf_count(), 3);
    assert!(grid.bytes() < 10_000, "{} bytes", grid.bytes());
    // Its leaves count against the budget, beside the file's bytes.
    let leaf = SparseValues::LEAF_BYTES;
    let tight = Allowance::new(MemoryBudget::bytes(bytes.len() as u64 + 3 * leaf - 1), 0);
    let e = nanovdb::read(&path, &["density"], &tight).unwrap_err();
    assert!(matches!(e, raylink::Error::Memory { .. }), "{e}");
    let enough = Allowance::new(MemoryBudget::bytes(bytes.len() as u64 + 3 * leaf), 0);
    assert!(nanovdb::read(&path, &["density"], &enough).is_ok());
    let sigma_a = 20.0;
    let medium = medium_of(&bytes, Layout::Fitting, Mat4::IDENTITY, sigma_a);
    let medium = medium.model();
    assert_eq!(medium.kind(), "nanovdb");
    // Along x through the blobs' middle row, from 5 voxels before to 5 voxels after.
    let row = |from: f32, to: f32| {
        let o = Vec3::new(from, 1.0, 1.0) * voxel;
        Ray::new(o, Vec3::new(to - from, 0.0, 0.0) * voxel)
    };
    let depth = f64::from(sigma_a * 3.0 * voxel);
    for (name, ray, n, want) in [
        ("near", row(-5.0, 8.0), 40_000, (-depth).exp()),
        ("far", row(199_995.0, 200_008.0), 40_000, (-depth).exp()),
        ("both", row(-5.0, 200_008.0), 2000, (-2.0 * depth).exp()),
    ] {
        let got = transmittance(medium, &ray, 1.0, n);
        // Each walk gives a number in [0, 1] (spread at most 1/2): five standard errors.
        let tolerance = 2.5 / (n as f64).sqrt() + 1e-3;
        assert!(
            (got - want).abs() < tolerance,
            "{name}: {got} against {want} (within {tolerance})"
        );
    }
    // Beside the blobs and between them: nothing.
    assert_eq!(transmittance(medium, &row(10.0, 199_990.0), 1.0, 100), 1.0);
    let beside = Ray::new(Vec3::new(-5.0, 4.0, 1.0) * voxel, Vec3::X * 15.0 * voxel);
    assert_eq!(transmittance(medium, &beside, 1.0, 100), 1.0);
    // The same file in a pbrt scene: a nanovdb medium kept sparse.
    std::fs::write(
        dir.path().join("s.pbrt"),
        "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\n\
         MakeNamedMedium \"blobs\" \"string type\" \"nanovdb\" \"string filename\" \
         \"blobs.nvdb\" \"rgb sigma_a\" [20 20 20]\nShape \"sphere\"\n",
    )
    .unwrap();
    let scene = Scene::load(&dir.path().join("s.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    assert!(matches!(scene.media[0].kind, MediumKind::SparseGrid(_)));
    // `convert` names the file again, and the scene reads back the same.
    let out = tempfile::tempdir().unwrap();
    let toml = out.path().join("s.toml");
    raylink::scene::convert::write_toml(&scene, &toml).unwrap();
    let back = Scene::load(&toml).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back.media, scene.media);
}
