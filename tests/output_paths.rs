//! Every file a run writes is checked against every file it reads and every other file it
//! writes, as files (not as strings), before any work: a collision exits with 2 and one
//! line naming it, and the folder is left exactly as it was (every file's bytes, no new
//! file). Each case below wrote over, moved or removed a file before the check.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;
use common::assert_clean_failure_of;

/// Runs the binary in `dir`, so that relative names are relative to it.
fn raylink_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_raylink"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the raylink binary runs")
}

/// Every file and folder under `dir`, with its bytes (a symbolic link: its target).
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut all = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            let meta = path.symlink_metadata().unwrap();
            let bytes = if meta.is_symlink() {
                let target = std::fs::read_link(&path).unwrap();
                target.to_string_lossy().as_bytes().to_vec()
            } else if meta.is_dir() {
                todo.push(path.clone());
                b"<dir>".to_vec()
            } else {
                std::fs::read(&path).unwrap()
            };
            all.insert(path.strip_prefix(dir).unwrap().to_path_buf(), bytes);
        }
    }
    all
}

/// Runs `args` in `dir` and asserts the clean refusal (exit 2, one line with `needles`)
/// and that `dir` is as it was.
fn refused(case: &str, dir: &Path, args: &[&str], needles: &[&str]) {
    let before = snapshot(dir);
    let out = raylink_in(dir, args);
    assert_clean_failure_of(case, &out, needles);
    assert!(snapshot(dir) == before, "{case}: the folder changed");
}

const PLY: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
-1 0 -1\n1 0 -1\n0 0 1\n3 0 1 2\n";

/// A small scene in `dir` reading the PLY mesh `mesh` (written there), lit by a point light.
fn scene_with_mesh(dir: &Path, mesh: &str) -> PathBuf {
    let path = dir.join(mesh);
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(&path, PLY).unwrap();
    let scene = dir.join("s.toml");
    std::fs::write(
        &scene,
        format!(
            "[camera]\nposition = [0, 2, 4]\nlook_at = [0, 0, 0]\nfov = 40\nwidth = 8\n\
             height = 8\n\n[materials.white]\ndiffuse = 0.8\n\n[[shapes]]\ntype = \"ply\"\n\
             file = \"{mesh}\"\nmaterial = \"white\"\n\n[[lights]]\ntype = \"point\"\n\
             position = [0, 3, 0]\nintensity = 10\n"
        ),
    )
    .unwrap();
    scene
}

const PATH: [&str; 5] = ["--integrator", "path", "--spp", "4", "-q"];

/// The checkpoint beside the output (`OUT.checkpoint`) is a file the scene reads: it used
/// to be overwritten and, once the render completed, removed.
#[test]
fn a_checkpoint_named_like_an_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scene_with_mesh(d, "out.exr.checkpoint");
    let mut args = vec!["render", "s.toml", "-o", "out.exr"];
    args.extend(PATH);
    refused(
        "checkpoint = mesh",
        d,
        &args,
        &["out.exr.checkpoint", "the checkpoint is one of the inputs"],
    );
    // The same through another spelling and through a hard link to the mesh.
    let mut args = vec!["render", "./s.toml", "-o", "./sub/../out.exr"];
    std::fs::create_dir(d.join("sub")).unwrap();
    args.extend(PATH);
    refused("spelled otherwise", d, &args, &["the checkpoint is one of"]);
    std::fs::hard_link(d.join("out.exr.checkpoint"), d.join("b.png.checkpoint")).unwrap();
    let mut args = vec!["render", "s.toml", "-o", "b.png"];
    args.extend(PATH);
    refused("hard link", d, &args, &["b.png.checkpoint", "is one of"]);
}

/// A file at the checkpoint's name that is not a checkpoint is not the render's to
/// overwrite or remove.
#[test]
fn a_foreign_file_where_the_checkpoint_goes_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scene_with_mesh(d, "m.ply");
    std::fs::write(d.join("out.exr.checkpoint"), b"my notes").unwrap();
    let mut args = vec!["render", "s.toml", "-o", "out.exr"];
    args.extend(PATH);
    refused(
        "notes at the checkpoint's name",
        d,
        &args,
        &[
            "out.exr.checkpoint",
            "keeps its checkpoint at this name",
            "move the file",
        ],
    );
}

/// Outputs of one run that are one file under two names: the last written would replace
/// the first.
#[test]
fn outputs_that_are_one_file_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scene_with_mesh(d, "m.ply");
    refused(
        "two -o",
        d,
        &["render", "s.toml", "-o", "a.png", "-o", "./a.png", "-q"],
        &["-o is the same file as -o"],
    );
    let mut args = vec![
        "render",
        "s.toml",
        "-o",
        "x.exr",
        "-o",
        "x.albedo.exr",
        "--aov",
    ];
    args.extend(PATH);
    refused(
        "an AOV over an output",
        d,
        &args,
        &["x.albedo.exr", "--aov"],
    );
    refused(
        "a cache over a mesh",
        d,
        &[
            "precompute",
            "s.toml",
            "--cache-file",
            "m.ply",
            "--integrator",
            "irradiance-cache",
        ],
        &["--cache-file is one of the inputs", "m.ply"],
    );
}

/// `convert` replaces its `NAME.meshes` folder: not when a mesh it reads lies there, when
/// the folder holds other files, or when the name is taken by something else.
#[test]
fn convert_keeps_what_it_did_not_write() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scene_with_mesh(d, "out.meshes/mesh_0000.ply");
    refused(
        "input inside the mesh folder",
        d,
        &["convert", "s.toml", "-o", "out.toml"],
        &[
            "out.meshes",
            "the mesh folder would replace the folder holding one of the inputs",
        ],
    );
    // Another file beside convert's own meshes.
    let other = tempfile::tempdir().unwrap();
    let o = other.path();
    scene_with_mesh(o, "m.ply");
    std::fs::create_dir(o.join("out.meshes")).unwrap();
    std::fs::write(o.join("out.meshes/mesh_0000.ply"), PLY).unwrap();
    std::fs::write(o.join("out.meshes/notes.txt"), b"keep me").unwrap();
    refused(
        "a foreign file in the folder",
        o,
        &["convert", "s.toml", "-o", "out.toml"],
        &["out.meshes", "holds notes.txt, which convert did not write"],
    );
    std::fs::remove_file(o.join("out.meshes/notes.txt")).unwrap();
    std::fs::create_dir(o.join("out.meshes/sub")).unwrap();
    refused(
        "a folder in the folder",
        o,
        &["convert", "s.toml", "-o", "out.toml"],
        &["holds sub"],
    );
    std::fs::remove_dir_all(o.join("out.meshes")).unwrap();
    // A regular file, and a link to a folder, named like the mesh folder.
    std::fs::write(o.join("out.meshes"), b"not a folder").unwrap();
    refused(
        "a file named like the folder",
        o,
        &["convert", "s.toml", "-o", "out.toml"],
        &["out.meshes: is not a folder"],
    );
    std::fs::remove_file(o.join("out.meshes")).unwrap();
    std::fs::create_dir(o.join("elsewhere")).unwrap();
    std::os::unix::fs::symlink("elsewhere", o.join("out.meshes")).unwrap();
    refused(
        "a link named like the folder",
        o,
        &["convert", "s.toml", "-o", "out.toml"],
        &["out.meshes: is not a folder"],
    );
    // With a folder of convert's own meshes it converts, replacing them and nothing else.
    std::fs::remove_file(o.join("out.meshes")).unwrap();
    std::fs::create_dir(o.join("out.meshes")).unwrap();
    std::fs::write(o.join("out.meshes/mesh_0007.ply"), PLY).unwrap();
    let out = raylink_in(o, &["convert", "s.toml", "-o", "out.toml", "-q"]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let names: Vec<String> = std::fs::read_dir(o.join("out.meshes"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["mesh_0000.ply"]);
    let mut left: Vec<String> = std::fs::read_dir(o)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(
        left,
        ["elsewhere", "m.ply", "out.meshes", "out.toml", "s.toml"]
    );
}

/// The frames, the CSV and the retrace maps of `animate`, spelled differently.
#[test]
fn animation_files_spelled_differently_are_one_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    std::fs::copy(root.join("scenes/anim-bounce.toml"), d.join("a.toml")).unwrap();
    std::fs::create_dir(d.join("sub")).unwrap();
    let base = [
        "animate", "a.toml", "--frames", "1..2", "--width", "8", "--height", "8", "-q",
    ];
    for (case, extra, needles) in [
        (
            "csv",
            vec!["-o", "f_%d.png", "--csv", "./f_2.png"],
            vec!["--csv is the same file as frame 2 of -o", "./f_2.png"],
        ),
        (
            "retrace map",
            vec!["-o", "f_%d.png", "--retrace-map", "./f_%d.png"],
            vec![
                "frame 1 of --retrace-map is the same file as frame 1 of -o",
                "./f_1.png",
            ],
        ),
        (
            "map through a folder",
            vec!["-o", "sub/../f_%d.png", "--retrace-map", "f_%d.png"],
            vec!["--retrace-map is the same file as frame 1 of -o", "f_1.png"],
        ),
        (
            "csv in a folder still to make",
            vec!["-o", "new/f_%d.png", "--csv", "new/./f_1.png"],
            vec!["--csv is the same file as frame 1 of -o", "new/./f_1.png"],
        ),
        (
            "csv over a map",
            vec![
                "-o",
                "f_%d.png",
                "--retrace-map",
                "m_%d.png",
                "--csv",
                "./m_1.png",
            ],
            vec![
                "--csv is the same file as frame 1 of --retrace-map",
                "./m_1.png",
            ],
        ),
    ] {
        let mut args = base.to_vec();
        args.extend(extra);
        refused(case, d, &args, &needles);
    }
}

/// `merge` writing over one of its parts, reached through a hard link.
#[test]
fn merge_onto_a_part_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scene_with_mesh(d, "m.ply");
    let part = raylink_in(
        d,
        &["render", "s.toml", "--tile", "0/1", "-o", "p0.exr", "-q"],
    );
    assert!(part.status.success(), "{}", common::stderr(&part));
    std::fs::hard_link(d.join("p0.exr"), d.join("whole.exr")).unwrap();
    refused(
        "hard link",
        d,
        &["merge", "p0.exr", "-o", "whole.exr"],
        &["whole.exr: -o is one of the inputs (a part to merge p0.exr)"],
    );
}

/// An output that is a symbolic link is written through it: the file it names gets the
/// image and the link stays (it used to be replaced by a file).
#[test]
fn an_output_that_is_a_link_is_written_through() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scene_with_mesh(d, "m.ply");
    std::fs::create_dir(d.join("renders")).unwrap();
    std::fs::write(d.join("renders/take-1.exr"), b"the previous take").unwrap();
    std::os::unix::fs::symlink("renders/take-1.exr", d.join("latest.exr")).unwrap();
    let mut args = vec!["render", "s.toml", "-o", "latest.exr"];
    args.extend(PATH);
    let out = raylink_in(d, &args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let link = d.join("latest.exr").symlink_metadata().unwrap();
    assert!(link.is_symlink(), "the link was replaced");
    let written = std::fs::read(d.join("renders/take-1.exr")).unwrap();
    assert!(written.starts_with(&[0x76, 0x2f, 0x31, 0x01]), "not an EXR");
    // Nothing else appeared beside the link or the file.
    let names: Vec<_> = snapshot(d).into_keys().collect();
    let expected = [
        "latest.exr",
        "m.ply",
        "renders",
        "renders/take-1.exr",
        "s.toml",
    ];
    assert_eq!(names, expected.map(PathBuf::from));
}

/// Inputs and outputs that the file system refuses by their names are bad input (exit 2),
/// and an output name too long for any file system is refused before the render.
#[test]
fn link_loops_and_overlong_names_are_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scene_with_mesh(d, "m.ply");
    std::os::unix::fs::symlink("loop-b.toml", d.join("loop-a.toml")).unwrap();
    std::os::unix::fs::symlink("loop-a.toml", d.join("loop-b.toml")).unwrap();
    let mut args = vec!["render", "loop-a.toml", "-o", "out.exr"];
    args.extend(PATH);
    refused("a link loop", d, &args, &["loop-a.toml", "symbolic links"]);
    let long = format!("{}.exr", "a".repeat(300));
    let mut args = vec!["render", "s.toml", "-o", &long];
    args.extend(PATH);
    // Large enough that rendering first would take seconds.
    args.extend(["--width", "2000", "--height", "2000"]);
    let start = std::time::Instant::now();
    refused(
        "a 304-byte name",
        d,
        &args,
        &["has a name of 304 bytes", "at most 255"],
    );
    assert!(
        start.elapsed().as_secs() < 5,
        "refused only after rendering"
    );
    // The checkpoint's name (OUT.checkpoint) is checked too.
    let long = format!("{}.exr", "b".repeat(248));
    let mut args = vec!["render", "s.toml", "-o", &long];
    args.extend(PATH);
    refused(
        "a 263-byte checkpoint",
        d,
        &args,
        &["has a name of 263 bytes"],
    );
}

/// `bench --out` names a folder: a file there is refused before measuring, and the files
/// bench writes are checked against the scenes it reads.
#[test]
fn bench_out_is_checked_before_measuring() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("notes.txt"), b"my notes").unwrap();
    let quick = [
        "--quick",
        "--scenes",
        "cornell",
        "--backends",
        "bvh",
        "--threads",
        "1",
    ];
    let mut args = vec!["bench", "--out", "notes.txt"];
    args.extend(quick);
    refused(
        "--out a file",
        d,
        &args,
        &["notes.txt", "--out must name a folder"],
    );
    // One of bench's outputs is a link to the scene it reads: written through, it would
    // overwrite the scene.
    scene_with_mesh(d, "m.ply");
    std::fs::create_dir(d.join("out")).unwrap();
    std::os::unix::fs::symlink("../s.toml", d.join("out/bench.md")).unwrap();
    let mut args = vec!["bench", "--out", "out", "--scenes", "s.toml"];
    args.extend(["--quick", "--backends", "bvh", "--threads", "1"]);
    refused(
        "an output over a scene",
        d,
        &args,
        &["bench.md", "one of the inputs"],
    );
}

/// `generate-assets` writes through the same check: a man page or completion script that is
/// (or links to) the program itself is refused before anything is written; otherwise every
/// file is replaced whole, an existing one by a new file (a new inode), no temporary left.
#[test]
fn generate_assets_never_overwrites_the_program() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let program = Path::new(env!("CARGO_BIN_EXE_raylink"));
    let before = std::fs::metadata(program).unwrap();
    std::fs::create_dir(d.join("completions")).unwrap();
    std::os::unix::fs::symlink(program, d.join("completions/raylink.bash")).unwrap();
    refused(
        "a completion script linking to the program",
        d,
        &["generate-assets", "."],
        &["raylink.bash", "is one of the inputs (the program"],
    );
    let after = std::fs::metadata(program).unwrap();
    assert_eq!(
        (before.len(), before.modified().unwrap()),
        (after.len(), after.modified().unwrap()),
        "the program was changed"
    );

    std::fs::remove_file(d.join("completions/raylink.bash")).unwrap();
    std::fs::create_dir(d.join("man")).unwrap();
    std::fs::write(d.join("man/raylink.1"), b"an old page").unwrap();
    let kept = d.join("kept-link.1");
    std::fs::hard_link(d.join("man/raylink.1"), &kept).unwrap();
    let out = raylink_in(d, &["generate-assets", "."]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    // The old page's other name still holds the old bytes: the page was replaced, not
    // written over.
    assert_eq!(std::fs::read(&kept).unwrap(), b"an old page");
    let page = std::fs::read_to_string(d.join("man/raylink.1")).unwrap();
    assert!(
        page.starts_with(".ie") || page.contains(".TH"),
        "{page:.80}"
    );
    for file in [
        "man/raylink-render.1",
        "completions/raylink.bash",
        "completions/_raylink",
        "completions/raylink.fish",
        "lib/libraylink_oiio.so",
    ] {
        let len = std::fs::metadata(d.join(file))
            .map(|m| m.len())
            .unwrap_or(0);
        assert!(len > 0, "{file} was not written");
    }
    for sub in ["man", "completions", "lib"] {
        assert!(
            common::process::temporaries(&d.join(sub)).is_empty(),
            "temporary files left in {sub}"
        );
    }
}
