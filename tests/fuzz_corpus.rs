//! The fuzzers' corpora (fuzz/corpus/TARGET/, kept minimised in the repository) replayed
//! through the same entry points the fuzz targets call: every input must be read or rejected
//! with a one-line error, never a panic. Crashes the fuzzers found are in these corpora, so
//! this is their regression test, run without libFuzzer or the nightly toolchain.

use std::path::Path;

fn replay(target: &str, read: fn(&[u8])) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fuzz/corpus")
        .join(target);
    let mut inputs: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    inputs.sort();
    assert!(inputs.len() >= 10, "{target}: only {} inputs", inputs.len());
    for input in inputs {
        let data = std::fs::read(&input).unwrap();
        let result = std::panic::catch_unwind(|| read(&data));
        assert!(result.is_ok(), "{} panicked", input.display());
    }
}

#[test]
fn scene_toml_corpus() {
    replay("scene_toml", raylink::fuzzing::scene_toml);
}

#[test]
fn camera_corpus() {
    replay("camera", raylink::fuzzing::camera);
}

#[test]
fn pbrt_corpus() {
    replay("pbrt", raylink::fuzzing::pbrt);
}

#[test]
fn obj_corpus() {
    replay("obj", raylink::fuzzing::obj);
}

#[test]
fn ply_corpus() {
    replay("ply", raylink::fuzzing::ply);
}

#[test]
fn nanovdb_corpus() {
    replay("nanovdb", raylink::fuzzing::nanovdb);
}

#[test]
fn irradiance_cache_corpus() {
    replay("irradiance_cache", raylink::fuzzing::irradiance_cache);
}

#[test]
fn network_corpus() {
    replay("network", raylink::fuzzing::network);
}

#[test]
fn network_sealed_corpus() {
    replay("network_sealed", raylink::fuzzing::network_sealed);
}

#[test]
fn checkpoint_corpus() {
    replay("checkpoint", |data| {
        raylink::fuzzing::checkpoint(data);
    });
}

/// The checkpoint seeds are named for what they are: `valid_*` films a 64-sample render
/// passes through are accepted; the crafted ones (a pass of 2^20 under way, counts past the
/// target, negative or NaN sums, samples the passes cannot hold, ...) are refused.
#[test]
fn checkpoint_seeds_accepted_and_refused_by_meaning() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/checkpoint");
    let (mut valid, mut refused) = (0, 0);
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.len() == 40 && name.bytes().all(|b| b.is_ascii_hexdigit()) {
            continue; // added by the fuzzer: no meaning in its name
        }
        let accepted = raylink::fuzzing::checkpoint(&std::fs::read(&path).unwrap());
        assert_eq!(accepted, name.starts_with("valid_"), "{name}");
        if accepted {
            valid += 1;
        } else {
            refused += 1;
        }
    }
    assert!(
        valid >= 4 && refused >= 10,
        "{valid} valid, {refused} refused seeds"
    );
}
