//! Inputs that are not regular files or are too large, through the `raylink` binary: a FIFO or
//! a device given as any input (scene, include, texture, mesh, tabulated BRDF, cache, network
//! file, checkpoint, render part), a file past its reader's limit, an image whose header
//! declares more pixels than the memory budget allows, and thread counts from the environment.
//! Each is refused at once: exit code 2 and one line naming the file, nothing written, the
//! input left alone. (Needs FIFOs, devices or generated files, so it is not in the corpus of
//! tests/bad_inputs/.)
//!
//! Every run is bounded: killed after [`WAIT`] (a FIFO would block the reading for ever) and
//! under an address-space limit (`/dev/zero` would be read until memory runs out).

mod common;

use common::{assert_clean_failure_of, stderr};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// How long a refusal may take (it takes well under a second).
const WAIT: Duration = Duration::from_secs(10);

/// The address space a run may take: enough to start and read a small scene.
const ADDRESS_SPACE_KIB: u64 = 4 << 20;

/// A finished run and its peak resident memory in MiB.
struct Run {
    out: Output,
    peak_mib: f64,
}

/// `raylink ARGS` from the repository root with `env` set, under [`ADDRESS_SPACE_KIB`],
/// killed (and the test failed) if it runs past [`WAIT`].
// The child is reaped by wait4, which clippy does not see.
#[allow(clippy::zombie_processes)]
fn run_env(args: &[&str], env: &[(&str, &str)]) -> Run {
    let mut child = Command::new("sh")
        .args([
            "-c",
            &format!("ulimit -v {ADDRESS_SPACE_KIB} && exec \"$0\" \"$@\""),
        ])
        .arg(env!("CARGO_BIN_EXE_raylink"))
        .args(args)
        .envs(env.iter().copied())
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The pipes are small and the outputs one line: read them after the end.
    let pid = child.id() as libc::pid_t;
    let start = Instant::now();
    let (status, usage) = loop {
        let mut status = 0;
        // SAFETY: an all-zero rusage is a valid value for wait4 to fill.
        let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
        // SAFETY: `status` and `usage` are live locals; WNOHANG returns at once. The child is
        // reaped here, not by `Child::wait`, so that its own resource usage is read.
        let done = unsafe { libc::wait4(pid, &mut status, libc::WNOHANG, &mut usage) };
        assert!(done >= 0, "wait4: {}", std::io::Error::last_os_error());
        if done == pid {
            break (status, usage);
        }
        if start.elapsed() > WAIT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("raylink {args:?} still ran after {WAIT:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let read = |pipe: Option<Box<dyn std::io::Read>>| {
        let mut bytes = Vec::new();
        if let Some(mut p) = pipe {
            p.read_to_end(&mut bytes).unwrap();
        }
        bytes
    };
    let stdout = read(child.stdout.take().map(|p| Box::new(p) as _));
    let stderr = read(child.stderr.take().map(|p| Box::new(p) as _));
    use std::os::unix::process::ExitStatusExt;
    Run {
        out: Output {
            status: std::process::ExitStatus::from_raw(status),
            stdout,
            stderr,
        },
        // Linux counts ru_maxrss in KiB.
        peak_mib: usage.ru_maxrss as f64 / 1024.0,
    }
}

fn run(args: &[&str]) -> Run {
    run_env(args, &[])
}

fn mkfifo(path: &Path) {
    let status = Command::new("mkfifo").arg(path).status().unwrap();
    assert!(status.success(), "mkfifo {}", path.display());
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// The Cornell box with its floor's colour from the image `file`, written to `dir/name`.
fn textured_scene(dir: &Path, name: &str, file: &str) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("scenes/cornell-box.toml"))
        .unwrap()
        .replacen(
            "[materials.floor]\ndiffuse = [0.725, 0.71, 0.68]",
            &format!("[materials.floor]\ndiffuse = {{ image = {{ file = \"{file}\" }} }}"),
            1,
        );
    assert!(text.contains(file), "the floor material was not found");
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// A small scene whose one shape or material reads `file`: `kind` is `obj`, `ply` or `brdf`.
fn scene_reading(dir: &Path, name: &str, kind: &str, file: &str) -> PathBuf {
    let mut text = String::from(
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\
         [[lights]]\ntype = \"point\"\nposition = [0, 2, 4]\nintensity = [1, 1, 1]\n",
    );
    text += &match kind {
        "brdf" => format!(
            "[materials.m]\nbrdf = \"{file}\"\n[[shapes]]\ntype = \"sphere\"\n\
             center = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\n"
        ),
        _ => format!(
            "[materials.m]\ndiffuse = 0.5\n[[shapes]]\ntype = \"{kind}\"\nfile = \"{file}\"\n\
             material = \"m\"\n"
        ),
    };
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The command lines that read `input` (a file name in `dir`, or an absolute path) as each
/// kind of input, with what the message must name; the scenes they need are written to
/// `dir`. `input` itself is made by the caller, except the checkpoint, which is `dir/x.exr.
/// checkpoint` (`make_checkpoint` makes it).
fn cases(dir: &Path, input: &str) -> Vec<(String, Vec<String>, String)> {
    let d = |n: &str| dir.join(n).to_string_lossy().into_owned();
    let out = d("x.exr");
    let path = if input.starts_with('/') {
        input.to_string()
    } else {
        d(input)
    };
    let named = Path::new(&path).file_name().unwrap().to_string_lossy();
    let named = named.to_string();
    let render = |scene: &Path, extra: &[&str]| {
        let mut v: Vec<String> = ["render", scene.to_str().unwrap(), "-q", "-o", &out]
            .iter()
            .map(|s| s.to_string())
            .collect();
        v.extend(["--width", "8", "--height", "8"].map(String::from));
        v.extend(extra.iter().map(|s| s.to_string()));
        v
    };
    let include = dir.join("includes.pbrt");
    std::fs::write(
        &include,
        format!(
            "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\nWorldBegin\n\
             Include \"{path}\"\n"
        ),
    )
    .unwrap();
    let texture = textured_scene(dir, "textured.toml", &path);
    let obj = scene_reading(dir, "obj.toml", "obj", &path);
    let ply = scene_reading(dir, "ply.toml", "ply", &path);
    let brdf = scene_reading(dir, "brdf.toml", "brdf", &path);
    let cornell = Path::new("scenes/cornell-box.toml");
    let room = Path::new("scenes/network-room.toml");
    let ic = ["--integrator", "irradiance-cache", "--cache-file", &path];
    let net = [
        "--integrator",
        "network",
        "--slopes",
        "2",
        "--intercept-step",
        "0.5",
        "--network-file",
        &path,
    ];
    vec![
        ("include".into(), render(&include, &[]), named.clone()),
        ("texture".into(), render(&texture, &[]), named.clone()),
        ("OBJ".into(), render(&obj, &[]), named.clone()),
        ("PLY".into(), render(&ply, &[]), named.clone()),
        ("BRDF table".into(), render(&brdf, &[]), named.clone()),
        ("cache".into(), render(cornell, &ic), named.clone()),
        ("network".into(), render(room, &net), named.clone()),
        (
            "merge part".into(),
            vec!["merge".into(), "-o".into(), out.clone(), path.clone()],
            named.clone(),
        ),
        (
            "checkpoint".into(),
            render(cornell, &["--integrator", "path", "--spp", "4", "--resume"]),
            "x.exr.checkpoint".into(),
        ),
    ]
}

/// Runs every case of [`cases`] for `input`, and `scene` (a scene path, a FIFO or device
/// itself) as the scene: each must fail at once naming the file and `what` it is, leaving
/// `dir` as it was.
fn refuse_everywhere(dir: &Path, input: &str, scenes: &[PathBuf], what: &str) {
    let mut all = cases(dir, input);
    for scene in scenes {
        let render = ["render", scene.to_str().unwrap(), "-q", "-o"];
        let mut argv: Vec<String> = render.iter().map(|s| s.to_string()).collect();
        argv.push(dir.join("x.exr").to_string_lossy().into_owned());
        let name = scene.file_name().unwrap().to_string_lossy().into_owned();
        all.push(("scene".into(), argv, name));
    }
    let before = names(dir);
    for (kind, argv, named) in all {
        let argv: Vec<&str> = argv.iter().map(String::as_str).collect();
        let start = Instant::now();
        let r = run(&argv);
        let case = format!("{kind}: {}", argv.join(" "));
        assert_clean_failure_of(&case, &r.out, &[&format!("{named}: is {what}")]);
        assert!(start.elapsed() < WAIT, "{case}: took {:?}", start.elapsed());
        assert_eq!(names(dir), before, "{case}: files changed");
    }
}

/// A FIFO given as any input blocks nothing: refused with one line before it is opened.
#[test]
fn fifos_as_inputs_are_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["fifo", "fifo.toml", "fifo.pbrt", "x.exr.checkpoint"] {
        mkfifo(&dir.path().join(name));
    }
    let scenes = ["fifo.toml", "fifo.pbrt"].map(|n| dir.path().join(n));
    refuse_everywhere(dir.path(), "fifo", &scenes, "a FIFO (named pipe)");
}

/// `/dev/zero` given as any input (by name, or through a link with a scene's extension) is
/// refused with one line, not read for ever.
#[test]
fn devices_as_inputs_are_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let link = |name: &str| {
        let path = dir.path().join(name);
        std::os::unix::fs::symlink("/dev/zero", &path).unwrap();
        path
    };
    let scenes = [link("zero.toml"), link("zero.pbrt")];
    link("x.exr.checkpoint");
    let cases = cases(dir.path(), "/dev/zero");
    assert!(cases.iter().any(|c| c.0 == "texture"));
    refuse_everywhere(dir.path(), "/dev/zero", &scenes, "a character device");
}

/// Files past their reader's fixed limit, or past what `--max-memory` leaves, are refused
/// from their size before they are read (sparse files: no disk is taken).
#[test]
fn files_past_their_limits_are_refused_before_they_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let sparse = |name: &str, bytes: u64| {
        let path = dir.path().join(name);
        std::fs::File::create(&path)
            .unwrap()
            .set_len(bytes)
            .unwrap();
        path.to_string_lossy().into_owned()
    };
    let scene = sparse("huge.toml", 300 << 20);
    let big_scene = sparse("big.toml", 100 << 20);
    let obj = sparse("huge.obj", 3 << 30);
    let merl = sparse("huge.binary", 40 << 20);
    sparse("x.exr.checkpoint", 65 << 30);
    let obj_scene = scene_reading(dir.path(), "obj.toml", "obj", &obj);
    let merl_scene = scene_reading(dir.path(), "merl.toml", "brdf", &merl);
    let out = dir.path().join("x.exr").to_string_lossy().into_owned();
    let small = ["--width", "8", "--height", "8", "-q", "-o", &out];
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec!["render", &scene],
            vec!["huge.toml: is 300.0 MiB, more than raylink reads from TOML scene files"],
        ),
        (
            vec!["render", &big_scene, "--max-memory", "64M"],
            vec![
                "reading ",
                "big.toml would need 100.0 MiB",
                "set by --max-memory",
            ],
        ),
        (
            vec!["render", obj_scene.to_str().unwrap()],
            vec!["huge.obj: is 3.0 GiB, more than raylink reads from OBJ files"],
        ),
        (
            vec!["render", merl_scene.to_str().unwrap()],
            vec!["huge.binary: is 40.0 MiB, more than raylink reads from MERL"],
        ),
        (
            vec![
                "render",
                "scenes/cornell-box.toml",
                "--integrator",
                "path",
                "--resume",
            ],
            vec!["x.exr.checkpoint: is 65.0 GiB, more than raylink reads from checkpoints"],
        ),
    ];
    let before = names(dir.path());
    for (mut argv, needles) in cases {
        argv.extend(small);
        let r = run(&argv);
        assert_clean_failure_of(&argv.join(" "), &r.out, &needles);
        assert!(r.peak_mib < 400.0, "{argv:?}: peak {:.0} MiB", r.peak_mib);
        assert_eq!(names(dir.path()), before, "{argv:?}: files changed");
    }
}

/// A PNG of `width` x `height` 8-bit RGB pixels: its header, one IDAT chunk holding `zlib`
/// (a zlib stream of the filtered rows) and the end chunk, each with its CRC.
fn png_file(width: u32, height: u32, zlib: &[u8]) -> Vec<u8> {
    fn crc(bytes: &[u8]) -> u32 {
        let mut c = !0u32;
        for &b in bytes {
            c ^= b as u32;
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    0xedb8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }
    let chunk = |kind: &[u8], data: &[u8]| {
        let mut c = (data.len() as u32).to_be_bytes().to_vec();
        let body = [kind, data].concat();
        c.extend_from_slice(&body);
        c.extend_from_slice(&crc(&body).to_be_bytes());
        c
    };
    let mut ihdr = width.to_be_bytes().to_vec();
    ihdr.extend_from_slice(&height.to_be_bytes());
    ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(chunk(b"IHDR", &ihdr));
    png.extend(chunk(b"IDAT", zlib));
    png.extend(chunk(b"IEND", &[]));
    png
}

/// `data` as a zlib stream of one stored (uncompressed) deflate block.
fn stored_zlib(data: &[u8]) -> Vec<u8> {
    let len = data.len() as u16;
    let mut z = vec![0x78, 0x01, 0x01];
    z.extend_from_slice(&len.to_le_bytes());
    z.extend_from_slice(&(!len).to_le_bytes());
    z.extend_from_slice(data);
    let (mut a, mut b) = (1u32, 0u32);
    for &x in data {
        a = (a + x as u32) % 65521;
        b = (b + a) % 65521;
    }
    z.extend_from_slice(&((b << 16) | a).to_be_bytes());
    z
}

/// A tiny PNG whose header declares `width` x `height` RGB pixels (its pixels cut short).
fn declared_png(width: u32, height: u32) -> Vec<u8> {
    // Four zero bytes: far fewer than declared.
    png_file(width, height, &stored_zlib(&[0; 4]))
}

/// Damaged PNG textures (cut short, a chunk's CRC wrong in the header or the pixels, a row
/// with an unknown filter) are refused with exactly one line on stderr, raylink's, naming
/// the file: nothing of libpng's own printing comes before it. The same PNG undamaged
/// renders.
#[test]
fn a_damaged_png_gives_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.exr").to_string_lossy().into_owned();
    let (w, h) = (8u32, 8u32);
    let rows = |filter: u8| -> Vec<u8> {
        (0..h)
            .flat_map(|y| {
                std::iter::once(filter).chain((0..w * 3).map(move |i| (i * 7 + y * 31) as u8))
            })
            .collect()
    };
    let good = png_file(w, h, &stored_zlib(&rows(0)));
    // Offsets: the signature (8), IHDR (8 + 13 + 4), then IDAT's length, type and data.
    let ihdr_crc = 8 + 8 + 13;
    let idat_end = good.len() - 12;
    let flip = |at: usize| {
        let mut b = good.clone();
        b[at] ^= 0x5a;
        b
    };
    let cases: [(&str, Vec<u8>, &str); 5] = [
        (
            "cut-short.png",
            good[..good.len() - 40].to_vec(),
            "damaged PNG file",
        ),
        ("idat-crc.png", flip(idat_end - 1), "CRC error"),
        ("ihdr-crc.png", flip(ihdr_crc), "CRC error"),
        (
            "bad-filter.png",
            png_file(w, h, &stored_zlib(&rows(9))),
            "filter",
        ),
        (
            "no-end.png",
            good[..good.len() - 12].to_vec(),
            "damaged PNG file",
        ),
    ];
    let render = |scene: &Path| {
        let argv = [
            "render",
            scene.to_str().unwrap(),
            "--width",
            "8",
            "--height",
            "8",
            "-q",
            "-o",
            &out,
        ];
        run(&argv).out
    };
    std::fs::write(dir.path().join("good.png"), &good).unwrap();
    let r = render(&textured_scene(dir.path(), "good.toml", "good.png"));
    assert!(r.status.success(), "the undamaged PNG: {}", stderr(&r));
    std::fs::remove_file(&out).unwrap();
    for (name, bytes, needle) in cases {
        std::fs::write(dir.path().join(name), &bytes).unwrap();
        let scene = textured_scene(dir.path(), &format!("{name}.toml"), name);
        let before = names(dir.path());
        let r = render(&scene);
        assert_clean_failure_of(name, &r, &[name, needle]);
        assert!(!stderr(&r).contains("libpng"), "{name}: {}", stderr(&r));
        assert_eq!(names(dir.path()), before, "{name}: files changed");
    }
}

/// Cache, network and checkpoint files within their fixed limits but past what
/// `--max-memory` leaves are refused from their size, before they are read, naming the
/// file (sparse files: no disk is taken); the file is left as it was.
#[test]
fn cache_network_and_checkpoint_files_count_against_the_memory_budget() {
    let dir = tempfile::tempdir().unwrap();
    let sparse = |name: &str, bytes: u64| {
        let path = dir.path().join(name);
        std::fs::File::create(&path)
            .unwrap()
            .set_len(bytes)
            .unwrap();
        path.to_string_lossy().into_owned()
    };
    let cache = sparse("big.rlic", 100 << 20);
    let network = sparse("big.rlnet", 100 << 20);
    // Within what a checkpoint of a 1200x1200 film holds (56 bytes a pixel and 1 MiB), past
    // what 256 MiB leaves beside the film and image (132 bytes a pixel).
    sparse("x.exr.checkpoint", 80_000_000);
    let out = dir.path().join("x.exr").to_string_lossy().into_owned();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![
                "scenes/cornell-box.toml",
                "--integrator",
                "irradiance-cache",
                "--cache-file",
                &cache,
                "--max-memory",
                "64M",
                "--width",
                "8",
                "--height",
                "8",
            ],
            "big.rlic would need 100.0 MiB",
        ),
        (
            vec![
                "scenes/network-room.toml",
                "--integrator",
                "network",
                "--network-file",
                &network,
                "--max-memory",
                "64M",
                "--width",
                "8",
                "--height",
                "8",
            ],
            "big.rlnet would need 100.0 MiB",
        ),
        (
            vec![
                "scenes/cornell-box.toml",
                "--integrator",
                "path",
                "--resume",
                "--max-memory",
                "256M",
                "--width",
                "1200",
                "--height",
                "1200",
            ],
            "x.exr.checkpoint would need",
        ),
    ];
    let before = names(dir.path());
    for (args, needle) in cases {
        let mut argv = vec!["render", "-q", "-o", &out];
        argv.extend(args);
        let r = run(&argv);
        assert_clean_failure_of(&argv.join(" "), &r.out, &[needle, "set by --max-memory"]);
        assert_eq!(names(dir.path()), before, "{argv:?}: files changed");
    }
    for (name, len) in [
        ("big.rlic", 100 << 20),
        ("big.rlnet", 100 << 20),
        ("x.exr.checkpoint", 80_000_000),
    ] {
        assert_eq!(std::fs::metadata(dir.path().join(name)).unwrap().len(), len);
    }
}

/// A PNG of a few dozen bytes whose header declares 20000x20000 (or 6000x6000) pixels, as a
/// texture under `--max-memory 64M`: refused from its header with one line, the process's
/// peak memory far below what its pixels would take (4.8 GB, 432 MB as floats).
#[test]
fn an_image_declaring_huge_sizes_is_refused_from_its_header() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.exr").to_string_lossy().into_owned();
    for (w, h, needles) in [
        (
            20000,
            20000,
            vec!["declares a 20000x20000 image of 3 channels"],
        ),
        (6000, 6000, vec!["reading the 6000x6000 image", "64.0 MiB"]),
    ] {
        let png = format!("declares-{w}x{h}.png");
        let bytes = declared_png(w, h);
        assert!(bytes.len() < 100);
        std::fs::write(dir.path().join(&png), &bytes).unwrap();
        let scene = textured_scene(dir.path(), &format!("{w}.toml"), &png);
        let before = names(dir.path());
        let argv = [
            "render",
            scene.to_str().unwrap(),
            "--max-memory",
            "64M",
            "--width",
            "8",
            "--height",
            "8",
            "-q",
            "-o",
            &out,
        ];
        let r = run(&argv);
        let mut needles = needles;
        needles.push(&png);
        assert_clean_failure_of(&png, &r.out, &needles);
        eprintln!("{png}: peak {:.0} MiB", r.peak_mib);
        assert!(r.peak_mib < 300.0, "{png}: peak {:.0} MiB", r.peak_mib);
        assert_eq!(names(dir.path()), before, "{png}: files changed");
    }
}

/// `RAYON_NUM_THREADS` (which sizes rayon's pools when `--threads` is not given) past the
/// limit of `--threads` is refused with one line instead of starting that many threads; a
/// count within it renders.
#[test]
fn thread_counts_from_the_environment_are_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.exr").to_string_lossy().into_owned();
    let argv = [
        "render",
        "scenes/whitted.toml",
        "--width",
        "8",
        "--height",
        "8",
        "-q",
        "-o",
        &out,
    ];
    for var in ["RAYON_NUM_THREADS", "RAYON_RS_NUM_CPUS"] {
        let r = run_env(&argv, &[(var, "100000")]);
        let needle = format!("{var} must be between 1 and");
        assert_clean_failure_of(var, &r.out, &[&needle, "got 100000"]);
        assert!(names(dir.path()).is_empty(), "{var}: something was written");
    }
    let r = run_env(&argv, &[("RAYON_NUM_THREADS", "2")]);
    assert!(r.out.status.success(), "{}", stderr(&r.out));
    assert!(Path::new(&out).exists());
}

/// A TOML scene of many instances: parsing it holds toml's tree of the text, many times the
/// text (3.7 KB an instance for 75 bytes of text), and that is what `--max-memory` is
/// checked against before it is parsed. The estimate is honest: no lower than the memory
/// the parse takes, and less than twice it. (The scenes end with an instance of no object,
/// so that each run ends once its file is parsed: the peak is the parse's.)
#[test]
fn a_scene_of_many_instances_counts_its_parse_against_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.exr").to_string_lossy().into_owned();
    let scene = |name: &str, n: usize| {
        let mut text = String::from(
            "[camera]\nposition = [0, 0, 50]\nlook_at = [0, 0, 0]\n[materials.white]\n\
             diffuse = 0.8\n[[objects]]\nname = \"tri\"\n[[objects.shapes]]\ntype = \"mesh\"\n\
             material = \"white\"\nindices = [[0, 1, 2]]\npositions = [[0, 0, 0], [0, 1, 0], \
             [0, 0, 1]]\n",
        );
        for i in 0..n {
            let x = i as f32 * 1e-3;
            text += &format!(
                "\n[[instances]]\nobject = \"tri\"\ntransform = [{{ translate = [{x}, 0, 0] }}]\n"
            );
        }
        text += "\n[[instances]]\nobject = \"nothing\"\n";
        let path = dir.path().join(name);
        std::fs::write(&path, &text).unwrap();
        path.to_string_lossy().into_owned()
    };
    let many = scene("many.toml", 60_000);
    let few = scene("few.toml", 1);
    let small = [
        "--width", "8", "--height", "8", "--spp", "1", "-q", "-o", &out,
    ];
    let argv = |scene: &str, budget: &[&'static str]| {
        let mut v = vec!["render".to_string(), scene.to_string()];
        v.extend(budget.iter().chain(&small).map(|s| s.to_string()));
        v
    };
    let run_args = |v: Vec<String>| run(&v.iter().map(String::as_str).collect::<Vec<_>>());
    let refused = run_args(argv(&many, &["--max-memory", "128M"]));
    assert_clean_failure_of(
        "many.toml",
        &refused.out,
        &["reading ", "many.toml would need"],
    );
    let err = stderr(&refused.out);
    let needed: f64 = err
        .split("would need ")
        .nth(1)
        .and_then(mib_at_start)
        .unwrap_or_else(|| panic!("no size in: {err}"));

    let no_object = "no [[objects]] table is named \"nothing\"";
    let base = run_args(argv(&few, &[]));
    assert_clean_failure_of("few.toml", &base.out, &[no_object]);
    let parsed = run_args(argv(&many, &[]));
    assert_clean_failure_of("many.toml", &parsed.out, &[no_object]);
    assert!(
        names(dir.path()) == ["few.toml", "many.toml"],
        "something was written"
    );
    let taken = parsed.peak_mib - base.peak_mib;
    eprintln!("60000 instances: parsing took {taken:.0} MiB, estimated {needed:.0} MiB");
    assert!(
        needed >= taken && needed < 2.0 * taken,
        "estimated {needed:.0} MiB, took {taken:.0} MiB"
    );
}

/// The MiB of a size printed as `12.3 MiB` (or KiB, GiB) at the start of `text`.
fn mib_at_start(text: &str) -> Option<f64> {
    let (number, rest) = text.split_once(' ')?;
    let scale = match rest.get(..3)? {
        "KiB" => 1.0 / 1024.0,
        "MiB" => 1.0,
        "GiB" => 1024.0,
        _ => return None,
    };
    Some(number.parse::<f64>().ok()? * scale)
}
