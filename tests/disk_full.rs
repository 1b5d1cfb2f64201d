//! A full disk (issue 39): every write that does not fit fails with exit code 1 and the
//! operating system's reason, leaves no temporary file, and replaces no existing file; an
//! interrupted render whose checkpoint does not fit still writes its partial image. The
//! outputs go to a 64 KiB tmpfs, which needs root (CI runs as root): without it the tests
//! say so and pass.

use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::process::{catches, cpu_seconds, finish, signal, spawn, temporaries, wait_until};
use common::{raylink, stderr};

/// A small tmpfs mounted on a temporary directory, unmounted on drop.
struct SmallDisk {
    dir: tempfile::TempDir,
}

impl SmallDisk {
    /// `None` (with a note) when this process may not mount.
    fn mount() -> Option<SmallDisk> {
        let dir = tempfile::tempdir().unwrap();
        let status = std::process::Command::new("mount")
            .args(["-t", "tmpfs", "-o", "size=64k", "tmpfs"])
            .arg(dir.path())
            .stderr(std::process::Stdio::null())
            .status();
        match status {
            Ok(s) if s.success() => Some(SmallDisk { dir }),
            _ => {
                eprintln!("skipped: cannot mount a tmpfs (needs root)");
                None
            }
        }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        let _ = std::process::Command::new("umount")
            .arg(self.dir.path())
            .status();
    }
}

/// Exit code 1, one error line with the OS's reason naming `file`, no temporary file left.
fn assert_disk_full(case: &str, out: &Output, file: &Path, dir: &Path) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(1), "{case}: {err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "{case}: {err}");
    assert!(lines[0].starts_with("raylink: error: "), "{case}: {err}");
    assert!(
        lines[0].contains("No space left on device"),
        "{case}: {err}"
    );
    assert!(lines[0].contains(&*file.to_string_lossy()), "{case}: {err}");
    assert!(!err.contains("panicked"), "{case}: {err}");
    assert_eq!(temporaries(dir), Vec::<String>::new(), "{case}");
}

/// Images of every format that do not fit: exit 1, "No space left on device", the image
/// that was there before unchanged. (A 200x200 image is 100-500 KB in the linear formats
/// and about 30 KB as PNG, so 40 KB already on the disk leave it too little room.)
#[test]
fn images_that_do_not_fit_fail_with_the_reason_and_replace_nothing() {
    let Some(disk) = SmallDisk::mount() else {
        return;
    };
    let before: Vec<u8> = (0..40_000u32).map(|i| (i * 7 % 251) as u8).collect();
    for name in ["a.exr", "a.png", "a.tif", "a.hdr"] {
        let target = disk.path(name);
        std::fs::write(&target, &before).unwrap();
        let out = raylink(&[
            "render",
            "scenes/cornell-box.toml",
            "--width",
            "200",
            "--height",
            "200",
            "-q",
            "-o",
            target.to_str().unwrap(),
        ]);
        assert_disk_full(name, &out, &target, disk.dir.path());
        assert!(std::fs::read(&target).unwrap() == before, "{name} changed");
        std::fs::remove_file(&target).unwrap();
    }
}

/// An irradiance cache (--cache-file) and an illumination network (--network-file) that do
/// not fit: exit 1 with the reason, no temporary file, and the image is not written either.
#[test]
fn caches_and_networks_that_do_not_fit_fail_with_the_reason() {
    let Some(disk) = SmallDisk::mount() else {
        return;
    };
    let elsewhere = tempfile::tempdir().unwrap();
    let image = elsewhere.path().join("i.exr");
    std::fs::write(&image, b"an earlier image").unwrap();
    for (integrator, option, name) in [
        ("irradiance-cache", "--cache-file", "c.cache"),
        ("network", "--network-file", "n.network"),
    ] {
        let file = disk.path(name);
        let out = raylink(&[
            "render",
            "scenes/cornell-box.toml",
            "--integrator",
            integrator,
            option,
            file.to_str().unwrap(),
            "--width",
            "64",
            "--height",
            "64",
            "-q",
            "-o",
            image.to_str().unwrap(),
        ]);
        assert_disk_full(option, &out, &file, disk.dir.path());
        assert!(!file.exists(), "{option}: a partial file");
        assert_eq!(std::fs::read(&image).unwrap(), b"an earlier image");
    }
}

/// SIGINT to a path-traced render whose checkpoint (48 bytes a pixel: 196 KB) does not fit
/// beside its PNG (a few KB): the partial image is written all the same, and the run exits
/// with 1 saying that the checkpoint could not be saved and why.
#[test]
fn an_interrupted_render_whose_checkpoint_does_not_fit_keeps_its_image() {
    let Some(disk) = SmallDisk::mount() else {
        return;
    };
    let image = disk.path("p.png");
    let mut child = spawn(&[
        "render",
        "scenes/cornell-box.toml",
        "--integrator",
        "path",
        "--width",
        "64",
        "--height",
        "64",
        "--spp",
        "100000",
        "-q",
        "-o",
        image.to_str().unwrap(),
    ]);
    // Under way: the handler is installed and the process has rendered for a CPU second.
    wait_until(&mut child, |pid| catches(pid, 2) && cpu_seconds(pid) > 1.0);
    signal(&child, nix::sys::signal::Signal::SIGINT);
    let out = finish(child);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    let last = err.lines().last().unwrap_or_default();
    for needle in [
        "interrupted by SIGINT",
        "wrote the partial image",
        "p.png.checkpoint",
        "No space left on device",
    ] {
        assert!(last.contains(needle), "{needle:?} not in {err}");
    }
    let (partial, _) = raylink::read_image(&image).unwrap();
    assert_eq!((partial.width, partial.height), (64, 64));
    assert!(partial.pixels.iter().any(|p| p.max_element() > 0.0));
    assert!(!disk.path("p.png.checkpoint").exists());
    assert_eq!(temporaries(disk.dir.path()), Vec::<String>::new());
}
