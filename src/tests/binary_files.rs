//! Binary files whose checksum is right but whose contents no render writes: checkpoints
//! with impossible sample counts or sums, irradiance caches with impossible values. Each is
//! refused with a message naming the file and the reason, never used.

use crate::binary_file::checksum;
use crate::error::Error;
use crate::image::filter::{Filter, Reconstruction};
use crate::render::{checkpoint, Film};
use std::path::{Path, PathBuf};

/// Rewrites a file's bytes with `edit` applied to them and its checksum made right again.
fn reseal(path: &Path, edit: impl FnOnce(&mut Vec<u8>)) {
    let mut bytes = std::fs::read(path).unwrap();
    bytes.truncate(bytes.len() - 8);
    edit(&mut bytes);
    let sum = checksum(&bytes);
    bytes.extend_from_slice(&sum.to_le_bytes());
    std::fs::write(path, bytes).unwrap();
}

const SETTINGS: &str = "a test render";

/// A checkpoint of an empty 8x8 film, and where its counts start in the file.
fn empty_checkpoint(dir: &Path) -> (PathBuf, usize) {
    let path = dir.join("x.exr.checkpoint");
    let film = Film::new(8, 8, Filter::default(), Reconstruction::Splat).unwrap();
    checkpoint::save(&path, &film, SETTINGS, 0).unwrap();
    // Magic and version, the settings' length and text, then width and height.
    (path, 12 + 8 + SETTINGS.len() + 8)
}

fn load(path: &Path, target: u32) -> Result<(), String> {
    checkpoint::load(
        path,
        SETTINGS,
        Film::new(8, 8, Filter::default(), Reconstruction::Splat).unwrap(),
        target,
    )
    .map(drop)
    .map_err(|e| match e {
        Error::Input { detail, .. } => detail,
        other => panic!("not an input error: {other}"),
    })
}

fn set_u32(bytes: &mut [u8], at: usize, v: u32) {
    bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

#[test]
fn checkpoints_with_impossible_counts_or_sums_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (path, counts) = empty_checkpoint(dir.path());
    // The file as written is a fine start for a render of 256 samples per pixel.
    assert_eq!(load(&path, 256), Ok(()));
    type Edit<'a> = Box<dyn Fn(&mut Vec<u8>) + 'a>;
    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "a pass of 2^20 samples under way",
            Box::new(|b| {
                set_u32(b, counts + 4, 1 << 20);
                set_u32(b, counts + 8, 1);
            }),
            "sample counts",
        ),
        (
            "1000 of 256 samples",
            Box::new(|b| set_u32(b, counts, 1000)),
            "nothing to resume",
        ),
        (
            "3 samples, a count no render of 256 passes through",
            Box::new(|b| set_u32(b, counts, 3)),
            "not those of a render",
        ),
        (
            "a negative sum",
            Box::new(|b| {
                let sums = counts + 12 + 16;
                b[sums..sums + 8].copy_from_slice(&(-1e300f64).to_le_bytes());
            }),
            "negative",
        ),
        (
            "more samples than its passes hold",
            Box::new(|b| {
                let samples = counts + 12 + 8;
                b[samples..samples + 8].copy_from_slice(&1_000_000u64.to_le_bytes());
            }),
            "more samples",
        ),
    ];
    for (case, edit, expected) in cases {
        let (path, _) = empty_checkpoint(dir.path());
        reseal(&path, edit);
        match load(&path, 256) {
            Err(e) => assert!(e.contains(expected), "{case}: {e}"),
            Ok(()) => panic!("{case}: accepted"),
        }
    }
}

#[test]
fn checkpoints_of_other_renders_are_kept_apart() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("x.exr");
    let film = Film::new(8, 8, Filter::default(), Reconstruction::Splat).unwrap();
    // A first render leaves its checkpoint; a second, with another seed, must not replace it.
    let first = checkpoint::path_for(&output, "seed 1").unwrap();
    checkpoint::save(&first, &film, "seed 1", 0).unwrap();
    let second = checkpoint::path_for(&output, "seed 2").unwrap();
    assert_ne!(first, second);
    checkpoint::save(&second, &film, "seed 2", 0).unwrap();
    assert_eq!(checkpoint::path_for(&output, "seed 1").unwrap(), first);
    // Each resume finds its own.
    assert_eq!(checkpoint::find(&output, "seed 1").unwrap(), Some(first));
    assert_eq!(checkpoint::find(&output, "seed 2").unwrap(), Some(second));
    // A third render finds none of its own, and is told the one there is another's.
    let e = checkpoint::find(&output, "seed 3").unwrap_err().to_string();
    assert!(e.contains("other options"), "{e}");
}

#[test]
fn cache_records_no_render_computes_are_refused() {
    use crate::integrators::irradiance_cache::record::Record;
    use crate::integrators::irradiance_cache::{file, Cache, IcOptions};
    use crate::math::{Rgb, Vec3};
    let scene = crate::scene::Scene::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml"),
    )
    .unwrap();
    let options = IcOptions::default();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.rlic");
    let good = Record {
        p: Vec3::new(0.0, 0.5, 0.0),
        n: Vec3::Y,
        e: Rgb::splat(0.5),
        r: 0.1,
        grad: Default::default(),
    };
    let save = |rec: Record| {
        let mut cache = Cache::new(&scene, &options);
        cache.levels[0].insert(rec);
        file::save(&path, &cache, &scene, &options).unwrap();
        file::load(&path, &scene, &options).map(drop)
    };
    assert!(save(good).is_ok());
    for (case, rec) in [
        (
            "negative irradiance",
            Record {
                e: Rgb::splat(-1e30),
                ..good
            },
        ),
        (
            "a normal of length 2",
            Record {
                n: Vec3::Y * 2.0,
                ..good
            },
        ),
        (
            "a point far outside",
            Record {
                p: Vec3::splat(1e6),
                ..good
            },
        ),
        ("a huge radius", Record { r: 1e20, ..good }),
    ] {
        let e = save(rec).expect_err(case).to_string();
        assert!(
            e.contains("c.rlic") && e.contains("not one a render computes"),
            "{case}: {e}"
        );
    }
}
