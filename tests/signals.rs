//! Signals and limits as a user's environment sends them: two SIGTERMs at once (`timeout`
//! signals the process and its group), a file-size limit (`ulimit -f`, SIGXFSZ), two
//! SIGINTs while `convert` writes its meshes, SIGINT while `relight` stores a light basis.

use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::process::{finish, spawn, temporaries, wait_for, wait_until};
use common::stderr;
use nix::sys::signal::{kill, killpg, Signal};
use nix::unistd::Pid;

/// The names in `dir`.
fn names(dir: &Path) -> Vec<String> {
    let mut all: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    all.sort();
    all
}

/// Two SIGTERMs back to back, as `timeout` sends them (to the process, then to its
/// group), are one request to stop: every trial keeps the partial image and the checkpoint.
/// (Two sent at the same instant often arrive as one; a few milliseconds apart, they did
/// not.)
#[test]
fn two_sigterms_at_once_count_as_one() {
    let dir = tempfile::tempdir().unwrap();
    for trial in 0..20 {
        let out = dir.path().join(format!("t{trial}.exr"));
        let checkpoint = dir.path().join(format!("t{trial}.exr.checkpoint"));
        let mut child = Command::new(env!("CARGO_BIN_EXE_raylink"))
            .args([
                "render",
                "scenes/cornell-box.toml",
                "--integrator",
                "path",
                "--width",
                "24",
                "--height",
                "24",
                "--spp",
                "4096",
                "--checkpoint-interval",
                "0",
                "-q",
                "-o",
                out.to_str().unwrap(),
            ])
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .process_group(0)
            .spawn()
            .unwrap();
        wait_for(&mut child, &checkpoint);
        let pid = Pid::from_raw(child.id() as i32);
        kill(pid, Signal::SIGTERM).unwrap();
        // Back to back, or the second as much as 80 ms later (after the first was handled).
        std::thread::sleep(Duration::from_millis(20 * (trial % 5)));
        if trial % 2 == 0 {
            kill(pid, Signal::SIGTERM).unwrap();
        } else {
            killpg(pid, Signal::SIGTERM).unwrap();
        }
        let run = finish(child);
        let err = stderr(&run);
        assert_eq!(run.status.code(), Some(143), "trial {trial}: {err}");
        assert!(
            err.contains("wrote the partial image"),
            "trial {trial}: {err}"
        );
        assert!(out.exists() && checkpoint.exists(), "trial {trial}");
        assert!(temporaries(dir.path()).is_empty(), "trial {trial}");
    }
}

/// The binary run under `ulimit -f BLOCKS` (512-byte blocks), in `dir`.
fn limited(blocks: u32, dir: &Path, args: &[&str]) -> std::process::Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -f {blocks} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_raylink"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// A file-size limit makes a write fail (`File too large`): exit 1 with the system's
/// reason, one line, and no temporary file; an existing output is kept.
#[test]
fn a_file_size_limit_is_a_write_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let root = env!("CARGO_MANIFEST_DIR");
    let scene = format!("{root}/scenes/cornell-box.toml");
    std::fs::write(d.join("kept.exr"), b"an older image").unwrap();
    let cases: [(&str, Vec<&str>, &str); 3] = [
        (
            "image",
            vec![
                "render",
                &scene,
                "--integrator",
                "path",
                "--spp",
                "1",
                "--width",
                "640",
                "--height",
                "640",
                "-q",
                "-o",
                "kept.exr",
            ],
            "kept.exr: File too large",
        ),
        (
            "checkpoint",
            vec![
                "render",
                &scene,
                "--integrator",
                "path",
                "--width",
                "256",
                "--height",
                "256",
                "--spp",
                "16",
                "--checkpoint-interval",
                "0",
                "-q",
                "-o",
                "c.png",
            ],
            "c.png.checkpoint: File too large",
        ),
        (
            "converted scene",
            vec!["convert", "big.toml", "-o", "s.toml", "-q"],
            "mesh_0000.ply: File too large",
        ),
    ];
    big_mesh(d);
    // Above the 1.5 MB OpenImageIO's interface takes, written at start-up, below the files.
    for (case, args, needle) in cases {
        let run = limited(3200, d, &args);
        let err = stderr(&run);
        assert_eq!(run.status.code(), Some(1), "{case}: {err} {:?}", run.status);
        let lines: Vec<&str> = err.lines().collect();
        assert_eq!(lines.len(), 1, "{case}: {err}");
        assert!(lines[0].starts_with("raylink: error: "), "{case}: {err}");
        assert!(lines[0].contains(needle), "{case}: {err}");
        let hidden: Vec<String> = names(d)
            .into_iter()
            .filter(|n| n.starts_with('.'))
            .collect();
        assert!(hidden.is_empty(), "{case}: left {hidden:?}");
    }
    assert_eq!(
        std::fs::read(d.join("kept.exr")).unwrap(),
        b"an older image"
    );
    assert!(!d.join("c.png").exists() && !d.join("s.toml").exists());
    assert!(!d.join("s.meshes").exists());
}

/// `big.toml` in `dir`, reading `big.ply`: a mesh of 60000 triangles (2.9 MB as binary PLY).
fn big_mesh(dir: &Path) {
    let n = 60_000;
    let mut ply = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nelement face {n}\nproperty list uchar int vertex_indices\n\
         end_header\n",
        3 * n
    );
    for i in 0..n {
        let x = i as f32 * 1e-4;
        ply.push_str(&format!("{x} 0 0\n{x} 1 0\n{x} 0 1\n"));
    }
    for i in 0..n {
        ply.push_str(&format!("3 {} {} {}\n", 3 * i, 3 * i + 1, 3 * i + 2));
    }
    std::fs::write(dir.join("big.ply"), ply).unwrap();
    std::fs::write(
        dir.join("big.toml"),
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\nwidth = 8\n\
         height = 8\n\n[materials.white]\ndiffuse = 0.8\n\n[[shapes]]\ntype = \"ply\"\n\
         file = \"big.ply\"\nmaterial = \"white\"\n",
    )
    .unwrap();
}

/// A scene of `n` separate triangle meshes, for a `convert` that takes a while to write.
fn many_meshes(dir: &Path, n: usize) -> std::path::PathBuf {
    let mut text = String::from(
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\nwidth = 8\nheight = 8\n\n\
         [materials.white]\ndiffuse = 0.8\n",
    );
    for i in 0..n {
        let x = i as f32 * 0.001;
        text.push_str(&format!(
            "\n[[shapes]]\ntype = \"mesh\"\nmaterial = \"white\"\npositions = [[{x}, 0, 0], \
             [{x}, 1, 0], [{x}, 0, 1]]\nindices = [[0, 1, 2]]\n"
        ));
    }
    let path = dir.join("many.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// SIGINT while `convert` writes its meshes: it stops (exit 130), and neither that nor a
/// second SIGINT leaves its temporary mesh folder (nor a mesh folder or scene half made).
#[test]
fn convert_interrupted_leaves_no_temporary_folder() {
    for twice in [false, true] {
        interrupt_convert(twice);
    }
}

fn interrupt_convert(twice: bool) {
    let input = tempfile::tempdir().unwrap();
    let scene = many_meshes(input.path(), 1000);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c.toml");
    let mut child = spawn(&[
        "convert",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    // Under way: the temporary mesh folder is there.
    let start = Instant::now();
    while !names(dir.path()).iter().any(|n| n.starts_with('.')) {
        assert!(child.try_wait().unwrap().is_none(), "convert ended first");
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no temporary folder"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    let pid = Pid::from_raw(child.id() as i32);
    kill(pid, Signal::SIGINT).unwrap();
    if twice {
        // Past the half second within which a second signal is the same request; the
        // first may have stopped it already.
        std::thread::sleep(Duration::from_millis(700));
        let _ = kill(pid, Signal::SIGINT);
    }
    let run = finish(child);
    let err = stderr(&run);
    let left = names(dir.path());
    assert!(left.is_empty(), "left {left:?}: {err}");
    if !twice {
        assert_eq!(run.status.code(), Some(130), "{err}");
        assert!(err.contains("during writing the converted scene"), "{err}");
    }
}

/// SIGINT while `relight --store-basis` distributes the basis: it stops within a second
/// and the network file is as it was.
#[test]
fn relight_storing_a_basis_stops_promptly_and_keeps_the_network() {
    let dir = tempfile::tempdir().unwrap();
    let net = dir.path().join("n.rlnet");
    let img = dir.path().join("a.png");
    let (net_s, img_s) = (net.to_str().unwrap(), img.to_str().unwrap());
    let base = [
        "scenes/network-office.toml",
        "--width",
        "16",
        "--height",
        "12",
        "-q",
        "--network-file",
        net_s,
        "-o",
        img_s,
    ];
    let mut args = vec!["render", "--integrator", "network"];
    args.extend(base);
    let made = common::raylink(&args);
    assert!(made.status.success(), "{}", stderr(&made));
    let before = std::fs::read(&net).unwrap();
    // Shooting one node at a time to a tight tolerance: a basis of some ten seconds.
    let mut args = vec![
        "relight",
        "--store-basis",
        "--network-order",
        "shoot",
        "--tolerance",
        "1e-9",
    ];
    args.extend(base);
    let mut child = spawn(&args);
    // Well into the basis: the file is loaded and distributing takes seconds.
    wait_until(&mut child, |pid| common::process::cpu_seconds(pid) > 1.0);
    let sent = Instant::now();
    kill(Pid::from_raw(child.id() as i32), Signal::SIGINT).unwrap();
    let run = finish(child);
    let stopped = sent.elapsed();
    let err = stderr(&run);
    assert_eq!(run.status.code(), Some(130), "{err}");
    assert!(
        stopped < Duration::from_secs(1),
        "stopped after {stopped:?}"
    );
    assert!(
        std::fs::read(&net).unwrap() == before,
        "the network file changed"
    );
    assert!(temporaries(dir.path()).is_empty());
}
