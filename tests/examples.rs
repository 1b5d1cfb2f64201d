//! The examples build with the tests (cargo builds them for `cargo test`) and run here: each
//! must do what its comment promises.

use std::path::PathBuf;
use std::process::Command;

/// The example binaries sit in target/PROFILE/examples, beside this test's deps folder.
fn example(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("the test knows where it runs");
    let profile = exe
        .parent()
        .and_then(|deps| deps.parent())
        .expect("tests run from target/PROFILE/deps");
    profile.join("examples").join(name)
}

fn run(name: &str, args: &[&str]) -> String {
    let out = Command::new(example(name))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("the {name} example runs: {e}"));
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{name} failed: {stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// A number after `key` in the example's output.
fn number(text: &str, key: &str) -> f64 {
    let rest = &text[text.find(key).unwrap_or_else(|| panic!("{key} in {text}")) + key.len()..];
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .unwrap_or(rest.len());
    rest[..end]
        .parse()
        .unwrap_or_else(|_| panic!("a number after {key} in {text}"))
}

#[test]
fn embed_cancels_a_render_from_the_caller_and_keeps_the_partial_image() {
    let out = run("embed", &[]);
    assert!(out.contains("partial true"), "{out}");
    // Stopped promptly, with some but not all of the 65,536 samples per pixel.
    assert!(number(&out, "stopped ") < 1.0, "{out}");
    let spp = number(&out, "samples (");
    assert!(spp > 0.0 && spp < 65536.0, "{out}");
    assert!(number(&out, "mean value ") > 0.0, "{out}");
}

#[test]
fn network_relight_renders_two_views_and_doubles_the_lamp() {
    let dir = tempfile::tempdir().unwrap();
    let out = run("network_relight", &[dir.path().to_str().unwrap()]);
    for f in ["network-front.exr", "network-side.exr", "network-relit.exr"] {
        assert!(dir.path().join(f).exists(), "{f} missing: {out}");
    }
    // Lit by the lamp alone, the scene's radiance is linear in its emission.
    let ratio = number(&out, "relit / front = ");
    assert!((ratio - 2.0).abs() < 1e-3, "{out}");
    assert!(number(&out, "side ") != number(&out, "front "), "{out}");
}

#[test]
fn flux_agreement_finds_gathering_and_shooting_alike() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-spheres.toml");
    let out = run("flux_agreement", &[scene, "20000"]);
    // Three sets, each with a positive flux both ways within 4 standard errors.
    let rows: Vec<&str> = out.lines().filter(|l| l.contains(" ± ")).collect();
    assert_eq!(rows.len(), 3, "{out}");
    for row in rows {
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        let sigmas: f64 = cells[4].parse().unwrap_or_else(|_| panic!("{row}"));
        assert!(sigmas < 4.0, "{row}");
        for estimate in &cells[2..4] {
            assert!(number(estimate, "") > 0.0, "{row}");
        }
    }
}
