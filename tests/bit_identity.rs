//! Bit identity: a fixed set of renders through the `raylink` binary, covering every
//! technique and path of the program (Whitted adaptive and uniform, path, light and
//! bidirectional tracing, auxiliary images, a box filter, the pure-Rust BVH, a pbrt scene, the
//! irradiance cache with and without a cache file, illumination networks built, saved, loaded,
//! hybrid and relit from a light basis, a reflectance series and a warm start, render-farm
//! tiles and merges, animations, and an interrupted render resumed), each image's pixels
//! hashed and compared with the table `tests/data/bit-identity.txt`, recorded from the code
//! before the engine moved into the library. A change that is meant not to alter images must
//! leave every hash as it is.
//!
//! - The hash is FNV-1a 64 over the width, the height and the bits of every f32 channel of
//!   every pixel as the image reader returns them, not over the file's bytes (EXR metadata
//!   holds render times).
//! - Images are only promised identical for the same Embree (and libm) on the same kind of
//!   processor (Embree picks its AVX-512, AVX2, AVX or SSE kernels at run time), so the table
//!   is keyed by the Embree version `raylink --version` prints and that instruction set: the
//!   lines under `[embree X.Y.Z ISA]` are theirs, `case output hash` each. Without a section
//!   for the running Embree and processor, the test says so and passes without rendering.
//! - Every differing, missing or unexpected line is printed before the test fails. A line
//!   whose hash is `-` is a render not yet recorded on that processor: it is rendered and its
//!   hash printed, not compared (a change of images recorded on one kind of processor leaves
//!   the others' lines to be recorded on theirs).
//! - `RAYLINK_RECORD_HASHES=1 cargo test --test bit_identity -- --nocapture` renders every
//!   case and rewrites the running Embree's section of the table (other sections are kept)
//!   instead of comparing. Record only from code whose images are known to be right.
//! - `RAYLINK_HASH_THREADS=N` renders with N worker threads instead of 2; the hashes must not
//!   change (images do not depend on the thread count).
//! - `RAYLINK_HASH_KEEP=DIR` copies every rendered image into DIR, a folder per case (to
//!   measure how two versions' images differ where their hashes do).
//! - The resumed render (SIGINT after the first checkpoint, then `--resume`) must hash as the
//!   table's uninterrupted render of the same command, and as this run's.

mod common;

// The one use of the library: reading images back. Kept here alone so that a rename of the
// module is a one-line change.
use raylink::image::output::read_image;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The table, relative to the repository root.
const TABLE: &str = "tests/data/bit-identity.txt";
const SEED: &str = "7";

/// FNV-1a 64 of an image file's size and pixels.
fn pixel_hash(path: &Path) -> Result<u64, String> {
    let (image, _) = read_image(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |bytes: [u8; 4]| {
        for b in bytes {
            hash ^= u64::from(b);
            hash = hash.wrapping_mul(0x0100_0000_01b3);
        }
    };
    eat(image.width.to_le_bytes());
    eat(image.height.to_le_bytes());
    for p in &image.pixels {
        for c in p.to_array() {
            eat(c.to_bits().to_le_bytes());
        }
    }
    Ok(hash)
}

/// The widest instruction set Embree's kernels use on this processor (it picks them at run
/// time; the AVX-512 and AVX2 kernels differ in the last bits of some hits).
fn embree_isa() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        if has!("avx512f")
            && has!("avx512cd")
            && has!("avx512dq")
            && has!("avx512bw")
            && has!("avx512vl")
        {
            return "avx512";
        }
        if has!("avx2") && has!("fma") && has!("bmi1") && has!("bmi2") && has!("lzcnt") {
            return "avx2";
        }
        if has!("avx") {
            return "avx";
        }
        if has!("sse4.2") {
            return "sse4.2";
        }
    }
    "other"
}

/// The Embree version the binary reports and the instruction set its kernels use here, as
/// the table's section key (`embree 3.13.5 avx2`).
fn embree_key() -> String {
    let out = common::raylink(&["--version"]);
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let version = text
        .split_once("Embree ")
        .map(|(_, rest)| rest.split([',', ')', ' ']).next().unwrap_or(""))
        .filter(|v| v.chars().next().is_some_and(|c| c.is_ascii_digit()));
    match version {
        Some(v) => format!("embree {v} {}", embree_isa()),
        None => panic!("no Embree version in `raylink --version`: {text:?}"),
    }
}

/// The table file: its leading comment lines, then (section key, its `case output hash` lines)
/// in file order.
struct Table {
    header: Vec<String>,
    sections: Vec<(String, Vec<String>)>,
}

impl Table {
    fn read(path: &Path) -> Table {
        let text = std::fs::read_to_string(path).unwrap_or_default();
        let mut table = Table {
            header: Vec::new(),
            sections: Vec::new(),
        };
        for line in text.lines().map(str::trim) {
            if let Some(key) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
                table.sections.push((key.to_string(), Vec::new()));
            } else if let Some((_, lines)) = table.sections.last_mut() {
                if !line.is_empty() && !line.starts_with('#') {
                    lines.push(line.to_string());
                }
            } else if line.starts_with('#') {
                table.header.push(line.to_string());
            }
        }
        table
    }

    /// The hashes recorded for `key`, by (case, output), `None` for a render not recorded
    /// on that processor yet (`-`); None without a section.
    fn hashes(&self, key: &str) -> Option<BTreeMap<(String, String), Option<u64>>> {
        let (_, lines) = self.sections.iter().find(|(k, _)| k == key)?;
        let mut hashes = BTreeMap::new();
        for line in lines {
            let fields: Vec<&str> = line.split_whitespace().collect();
            let parsed = match fields[..] {
                [case, output, "-"] => Some(((case.to_string(), output.to_string()), None)),
                [case, output, hash] => u64::from_str_radix(hash, 16)
                    .ok()
                    .map(|h| ((case.to_string(), output.to_string()), Some(h))),
                _ => None,
            };
            let (k, h) = parsed.unwrap_or_else(|| panic!("{TABLE}: bad line {line:?}"));
            hashes.insert(k, h);
        }
        Some(hashes)
    }

    /// Replaces (or adds) the section `key` and writes the file.
    fn record(mut self, path: &Path, key: &str, hashes: &[Hash]) {
        let lines = hashes
            .iter()
            .map(|h| format!("{} {} {:016x}", h.case, h.output, h.hash))
            .collect();
        match self.sections.iter_mut().find(|(k, _)| k == key) {
            Some((_, old)) => *old = lines,
            None => self.sections.push((key.to_string(), lines)),
        }
        if self.header.is_empty() {
            self.header = [
                "# Pixel hashes of the renders of tests/bit_identity.rs (FNV-1a 64 of each image's",
                "# width, height and f32 channel bits), by the Embree version `raylink --version`",
                "# prints and the instruction set of its kernels; `case output hash` a line",
                "# (`-` for a render not recorded on that processor yet: not compared).",
                "# Rewrite the running Embree's section with",
                "#   RAYLINK_RECORD_HASHES=1 cargo test --test bit_identity -- --nocapture",
            ]
            .map(String::from)
            .to_vec();
        }
        let mut text = self.header.join("\n") + "\n";
        for (k, lines) in &self.sections {
            text += &format!("\n[{k}]\n");
            for l in lines {
                text += l;
                text += "\n";
            }
        }
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }
}

/// One hashed image: `output` of `case`. `same_as`, for the resumed render, names the
/// output of the same case whose recorded hash it must have (it has no line of its own).
struct Hash {
    case: String,
    output: String,
    hash: u64,
    same_as: Option<String>,
}

/// The cases' working state: a temporary directory with a folder per case, the hashes so
/// far, and every failure (a command or a read that failed), reported together at the end.
struct Run {
    dir: tempfile::TempDir,
    threads: String,
    hashes: Vec<Hash>,
    failures: Vec<String>,
}

impl Run {
    /// `name` in the folder of `case` (created).
    fn file(&self, case: &str, name: &str) -> String {
        let folder = self.dir.path().join(case);
        std::fs::create_dir_all(&folder).unwrap();
        folder.join(name).to_string_lossy().into_owned()
    }

    /// `args` with the options every command but merge takes: seed, threads, quiet.
    fn full_args<'a>(&'a self, args: &[&'a str]) -> Vec<&'a str> {
        let mut all = args.to_vec();
        if args[0] != "merge" {
            all.extend(["--seed", SEED, "--threads", &self.threads, "--quiet"]);
        }
        all
    }

    /// Runs raylink; a failure is noted for `case` (and false returned).
    fn raylink(&mut self, case: &str, args: &[&str]) -> bool {
        let all = self.full_args(args);
        let out = common::raylink(&all);
        if !out.status.success() {
            let failure = format!(
                "{case}: `raylink {}` failed ({}): {}",
                all.join(" "),
                out.status,
                common::stderr(&out).trim()
            );
            self.failures.push(failure);
        }
        out.status.success()
    }

    /// Hashes the image `output` of `case`'s folder.
    fn hash(&mut self, case: &str, output: &str) {
        self.hash_as(case, output, None);
    }

    fn hash_as(&mut self, case: &str, output: &str, same_as: Option<&str>) -> Option<u64> {
        match pixel_hash(Path::new(&self.file(case, output))) {
            Ok(hash) => {
                self.hashes.push(Hash {
                    case: case.into(),
                    output: output.into(),
                    hash,
                    same_as: same_as.map(String::from),
                });
                Some(hash)
            }
            Err(e) => {
                self.failures.push(format!("{case}: {e}"));
                None
            }
        }
    }

    /// `render SCENE ARGS -o CASE/image.exr`, hashed.
    fn render(&mut self, case: &str, scene: &str, args: &[&str]) {
        let out = self.file(case, "image.exr");
        let mut all = vec!["render", scene, "-o", &out];
        all.extend_from_slice(args);
        if self.raylink(case, &all) {
            self.hash(case, "image.exr");
        }
    }

    /// `animate SCENE ARGS --frames A..B`, every frame hashed.
    fn animate(
        &mut self,
        case: &str,
        scene: &str,
        frames: std::ops::RangeInclusive<u32>,
        args: &[&str],
    ) {
        let pattern = self.file(case, "frame_%04d.exr");
        let range = format!("{}..{}", frames.start(), frames.end());
        let mut all = vec!["animate", scene, "-o", &pattern, "--frames", &range];
        all.extend_from_slice(args);
        if self.raylink(case, &all) {
            for f in frames {
                self.hash(case, &format!("frame_{f:04}.exr"));
            }
        }
    }

    /// A copy of `network-room.toml` in `case`'s folder with each edit's text replaced (its
    /// shapes are inline: nothing is read beside it).
    fn edited_room(&self, case: &str, name: &str, edits: &[(&str, &str)]) -> String {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut text = std::fs::read_to_string(root.join("scenes/network-room.toml")).unwrap();
        for (from, to) in edits {
            assert!(text.contains(from), "{from} not in network-room.toml");
            text = text.replace(from, to);
        }
        let path = self.file(case, name);
        std::fs::write(&path, text).unwrap();
        path
    }
}

/// A small, quick illumination network (docs/illumination-network.md: h = 1/16, 6 slopes).
const NETWORK: [&str; 6] = [
    "--slopes",
    "6",
    "--intercept-step",
    "0.0625",
    "--network-builder",
    "scan",
];
const NET_SIZE: [&str; 6] = ["--width", "32", "--height", "24", "--spp", "4"];

fn whitted_cases(run: &mut Run) {
    let size = ["--width", "48", "--height", "36"];
    let whitted = [&["--integrator", "whitted"][..], &size].concat();
    run.render("whitted-adaptive", "scenes/whitted.toml", &whitted);
    // Uniform supersampling, with an 8-bit output too (sRGB, exposure).
    let case = "whitted-uniform";
    let (exr, png) = (run.file(case, "image.exr"), run.file(case, "image.png"));
    let mut args = vec!["render", "scenes/whitted.toml", "-o", &exr, "-o", &png];
    args.extend_from_slice(&whitted);
    args.extend(["--spp", "4", "--exposure", "1"]);
    if run.raylink(case, &args) {
        run.hash(case, "image.exr");
        run.hash(case, "image.png");
    }
    run.render(
        "whitted-fresnel-bvh",
        "scenes/whitted.toml",
        &[&whitted[..], &["--fresnel", "--accel", "bvh"]].concat(),
    );
}

fn monte_carlo_cases(run: &mut Run) {
    let cornell = "scenes/cornell-box.toml";
    let size = ["--width", "48", "--height", "48"];
    let with = |integrator: &'static str, spp: &'static str| {
        [&["--integrator", integrator, "--spp", spp][..], &size].concat()
    };
    run.render("path", cornell, &with("path", "8"));
    run.render("light", cornell, &with("light", "8"));
    run.render("bdpt", cornell, &with("bdpt", "4"));
    run.render(
        "path-spheres",
        "scenes/cornell-spheres.toml",
        &with("path", "8"),
    );
    run.render(
        "bdpt-spheres",
        "scenes/cornell-spheres.toml",
        &with("bdpt", "2"),
    );
    run.render(
        "path-box-filter",
        cornell,
        &[
            &with("path", "4")[..],
            &["--filter", "box", "--max-depth", "3"],
        ]
        .concat(),
    );
    run.render(
        "path-bvh",
        cornell,
        &[&with("path", "4")[..], &["--accel", "bvh"]].concat(),
    );
    let case = "path-aov";
    run.render(
        case,
        cornell,
        &[&with("path", "4")[..], &["--aov"]].concat(),
    );
    for aov in ["albedo", "normal", "depth"] {
        run.hash(case, &format!("image.{aov}.exr"));
    }
    run.render(
        "pbrt",
        "scenes/pbrt-materials.pbrt",
        &["--width", "48", "--height", "32", "--spp", "4"],
    );
}

fn irradiance_cache_cases(run: &mut Run) {
    let room = "scenes/indirect-room.toml";
    let ic = [
        "--integrator",
        "irradiance-cache",
        "--width",
        "40",
        "--height",
        "30",
        "--spp",
        "2",
        "--ab",
        "2",
        "--ic-samples",
        "32",
        // The cache's defaults, over the settings the scene file recommends.
        "--ic-accuracy",
        "0.15",
        "--ar",
        "64",
    ];
    run.render("irradiance-cache", room, &ic);
    // The first run writes the file (marked with this view), the second only reads it.
    let case = "irradiance-cache-file";
    let cache = run.file(case, "room.ic");
    for name in ["write.exr", "read.exr"] {
        let out = run.file(case, name);
        let mut args = vec!["render", room, "-o", &out, "--cache-file", &cache];
        args.extend_from_slice(&ic);
        if run.raylink(case, &args) {
            run.hash(case, name);
        }
    }
}

fn network_cases(run: &mut Run) {
    let room = "scenes/network-room.toml";
    let net = [&["--integrator", "network"][..], &NETWORK, &NET_SIZE].concat();
    run.render("network-room", room, &net);
    // Directional nodes (a glossy floor): the sweeps instead of conjugate gradients.
    run.render("network-mirror", "scenes/network-mirror.toml", &net);
    run.render(
        "network-hybrid",
        room,
        &[&net[..], &["--network-hybrid"]].concat(),
    );
    // Adaptive anti-aliasing instead of the scene's 4 samples, and shooting.
    let adaptive = [
        &["--integrator", "network", "--aa", "adaptive"][..],
        &NETWORK,
    ]
    .concat();
    run.render(
        "network-adaptive-shoot",
        room,
        &[
            &adaptive[..],
            &[
                "--width",
                "32",
                "--height",
                "24",
                "--network-order",
                "shoot",
            ],
        ]
        .concat(),
    );
    // Built and saved, then a render from the file (no preprocess).
    let case = "network-file";
    let file = run.file(case, "room.net");
    for name in ["build.exr", "load.exr"] {
        let out = run.file(case, name);
        let mut args = vec!["render", room, "-o", &out, "--network-file", &file];
        args.extend_from_slice(&net);
        if run.raylink(case, &args) {
            run.hash(case, name);
        }
    }
    let pristine = run.file(case, "pristine.net");
    if let Err(e) = std::fs::copy(&file, &pristine) {
        run.failures.push(format!("{case}: {file}: {e}"));
        return;
    }
    relight_cases(run, &pristine);
}

/// `raylink relight` of the network saved by the case network-file (a copy per case).
fn relight_cases(run: &mut Run, pristine: &str) {
    let room = "scenes/network-room.toml";
    let relight =
        |run: &mut Run, case: &str, file: &str, scene: &str, name: &str, extra: &[&str]| {
            let out = run.file(case, name);
            let mut args = vec!["relight", scene, "-o", &out, "--network-file", file];
            args.extend_from_slice(&NETWORK);
            args.extend_from_slice(&NET_SIZE);
            args.extend_from_slice(extra);
            if run.raylink(case, &args) {
                run.hash(case, name);
            }
        };
    // The first relight distributes the light basis and stores it; the second superposes it
    // (no distribution); the hybrid one too, with its direct part.
    let case = "relight-lights";
    let file = run.file(case, "room.net");
    std::fs::copy(pristine, &file).unwrap();
    relight(
        run,
        case,
        &file,
        room,
        "basis.exr",
        &["--light", "lamp=0.5"],
    );
    relight(
        run,
        case,
        &file,
        room,
        "superposed.exr",
        &["--light", "lamp=2"],
    );
    relight(
        run,
        case,
        &file,
        room,
        "hybrid.exr",
        &["--light-scale", "1.5", "--network-hybrid"],
    );
    // A reflectance series for the red wall, then the wall recoloured: a sum of the series'
    // terms. Then another material changed too: the series does not apply, and the light is
    // distributed again from the stored basis (a warm start).
    let case = "relight-series";
    let file = run.file(case, "room.net");
    std::fs::copy(pristine, &file).unwrap();
    relight(
        run,
        case,
        &file,
        room,
        "stored.exr",
        &["--reflectance-series", "red"],
    );
    let red = "diffuse = [0.75, 0.1, 0.08]";
    let recoloured = run.edited_room(
        case,
        "recoloured.toml",
        &[(red, "diffuse = [0.2, 0.6, 0.3]")],
    );
    relight(run, case, &file, &recoloured, "series.exr", &[]);
    let blue = "diffuse = [0.1, 0.2, 0.75]";
    let both = run.edited_room(
        case,
        "both.toml",
        &[
            (red, "diffuse = [0.2, 0.6, 0.3]"),
            (blue, "diffuse = [0.6, 0.6, 0.1]"),
        ],
    );
    relight(run, case, &file, &both, "warm-start.exr", &[]);
    // --store-basis: the basis recomputed for the edited reflectances.
    relight(
        run,
        case,
        &file,
        &both,
        "store-basis.exr",
        &["--store-basis"],
    );
}

fn farm_cases(run: &mut Run) {
    // The irradiance cache: precomputed once, read by each tile.
    let case = "farm-irradiance-cache";
    let cache = run.file(case, "view.ic");
    let view = [
        "--integrator",
        "irradiance-cache",
        "--width",
        "32",
        "--height",
        "24",
        "--spp",
        "2",
        "--ab",
        "2",
        "--ic-samples",
        "32",
        "--ic-accuracy",
        "0.15",
        "--ar",
        "64",
        "--cache-file",
    ];
    let mut args = vec!["precompute", "scenes/indirect-room.toml"];
    args.extend_from_slice(&view);
    args.push(&cache);
    if run.raylink(case, &args) {
        let options = [&view[..], &[&cache]].concat();
        tiles(run, case, "scenes/indirect-room.toml", &options, &[]);
    }
    // The network: precomputed, then the tiles each distribute the light.
    let case = "farm-network";
    let file = run.file(case, "room.net");
    let options = [&["--network-file", &file][..], &NETWORK, &NET_SIZE].concat();
    let mut args = vec!["precompute", "scenes/network-room.toml"];
    args.extend_from_slice(&options);
    if run.raylink(case, &args) {
        let options = [&["--integrator", "network"][..], &options].concat();
        tiles(run, case, "scenes/network-room.toml", &options, &[]);
    }
    // The path tracer needs no precomputation; a crop with its auxiliary images.
    let case = "farm-path";
    let options = [
        "--integrator",
        "path",
        "--width",
        "32",
        "--height",
        "32",
        "--spp",
        "4",
        "--filter-radius",
        "2",
    ];
    tiles(run, case, "scenes/cornell-box.toml", &options, &[]);
    let crop = run.file(case, "crop.exr");
    let mut args = vec!["render", "scenes/cornell-box.toml", "-o", &crop];
    args.extend_from_slice(&options);
    args.extend(["--crop", "5,7,23,19", "--aov"]);
    if run.raylink(case, &args) {
        for name in [
            "crop.exr",
            "crop.albedo.exr",
            "crop.normal.exr",
            "crop.depth.exr",
        ] {
            run.hash(case, name);
        }
    }
    // Whitted's adaptive anti-aliasing (corners shared across the band edge), merged into
    // half floats.
    let size = ["--width", "40", "--height", "30"];
    tiles(
        run,
        "farm-whitted",
        "scenes/whitted.toml",
        &size,
        &["--half"],
    );
}

/// Tiles 0/2 and 1/2 of `scene` with `options`, then merged (with `merge_options`): all
/// three hashed.
fn tiles(run: &mut Run, case: &str, scene: &str, options: &[&str], merge_options: &[&str]) {
    let mut parts = Vec::new();
    for i in 0..2 {
        let tile = format!("{i}/2");
        let name = format!("tile_{i}.exr");
        let out = run.file(case, &name);
        let mut args = vec!["render", scene, "-o", &out, "--tile", &tile];
        args.extend_from_slice(options);
        if run.raylink(case, &args) {
            run.hash(case, &name);
        }
        parts.push(out);
    }
    merge(run, case, &parts, merge_options);
}

fn merge(run: &mut Run, case: &str, parts: &[String], options: &[&str]) {
    let merged = run.file(case, "merged.exr");
    let mut args = vec!["merge", "-o", &merged];
    args.extend_from_slice(options);
    args.extend(parts.iter().map(String::as_str));
    if run.raylink(case, &args) {
        run.hash(case, "merged.exr");
    }
}

fn animation_cases(run: &mut Run) {
    let size = ["--width", "40", "--height", "30"];
    // The ball falls through frames 0-3; coherent frames after the first.
    run.animate("animate-bounce", "scenes/anim-bounce.toml", 0..=3, &size);
    // The lamp flickers (frames 8-9), then starts to swing (10-11); the paper's voxel tables.
    run.animate(
        "animate-light-tables",
        "scenes/anim-light.toml",
        8..=11,
        &[&size[..], &["--records", "tables", "--spp", "4"]].concat(),
    );
    // The path tracer as the ball lands (7-8, a few blocks retraced) and rests (9, none).
    run.animate(
        "animate-bounce-path",
        "scenes/anim-bounce.toml",
        6..=9,
        &[&size[..], &["--integrator", "path", "--spp", "2"]].concat(),
    );
}

/// The path-traced render the resume case interrupts: long enough (many passes) to be
/// under way when the first checkpoint appears.
const RESUMED: [&str; 12] = [
    "scenes/cornell-box.toml",
    "--integrator",
    "path",
    "--width",
    "24",
    "--height",
    "24",
    "--spp",
    "512",
    "--max-depth",
    "4",
    "-o",
];

/// The uninterrupted render (a table line), then the same command interrupted by SIGINT
/// after its first checkpoint (exit 130) and resumed: the resumed image must hash the same.
fn resume_case(run: &mut Run) {
    let case = "path-resume";
    let full = run.file(case, "uninterrupted.exr");
    let part = run.file(case, "resumed.exr");
    let command = |out: &str| {
        let mut args = vec!["render"];
        args.extend_from_slice(&RESUMED);
        args.push(out);
        args.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let args = command(&full);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    if !run.raylink(case, &args) {
        return;
    }
    let Some(reference) = run.hash_as(case, "uninterrupted.exr", None) else {
        return;
    };
    let args = command(&part);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    // A checkpoint after every pass shows when the render is under way.
    let mut interrupted = run.full_args(&args);
    interrupted.extend(["--checkpoint-interval", "0"]);
    if let Err(e) = interrupt(&interrupted, Path::new(&format!("{part}.checkpoint"))) {
        run.failures
            .push(format!("{case}: the interrupted render: {e}"));
        return;
    }
    let mut resume = args.clone();
    resume.push("--resume");
    if !run.raylink(case, &resume) {
        return;
    }
    let resumed = run.hash_as(case, "resumed.exr", Some("uninterrupted.exr"));
    if resumed.is_some_and(|h| h != reference) {
        run.failures.push(format!(
            "{case}: the resumed image ({:016x}) differs from this run's uninterrupted one \
             ({reference:016x})",
            resumed.unwrap()
        ));
    }
}

/// Runs raylink with `args`, sends SIGINT once `checkpoint` exists, and expects exit 130
/// with the checkpoint kept.
fn interrupt(args: &[&str], checkpoint: &Path) -> Result<(), String> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_raylink"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| e.to_string())?;
    let start = Instant::now();
    while !checkpoint.exists() {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            return Err(format!("ended ({status}) before its first checkpoint"));
        }
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            return Err("no checkpoint after 120 s".into());
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let pid = nix::unistd::Pid::from_raw(child.id() as i32);
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGINT).map_err(|e| e.to_string())?;
    let out = child.wait_with_output().map_err(|e| e.to_string())?;
    if out.status.code() != Some(130) || !checkpoint.exists() {
        return Err(format!(
            "expected exit 130 and a checkpoint, got {} ({}): {}",
            out.status,
            if checkpoint.exists() {
                "checkpoint kept"
            } else {
                "no checkpoint: the render finished before the signal?"
            },
            common::stderr(&out).trim()
        ));
    }
    Ok(())
}

#[test]
fn every_technique_renders_the_recorded_pixels() {
    let start = Instant::now();
    let key = embree_key();
    let table_path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(TABLE);
    let table = Table::read(&table_path);
    let record = std::env::var("RAYLINK_RECORD_HASHES").is_ok_and(|v| v == "1");
    let recorded = table.hashes(&key);
    if recorded.is_none() && !record {
        eprintln!(
            "bit_identity: {TABLE} has no hashes for {key} (only for: {}); nothing compared. \
             Record them with RAYLINK_RECORD_HASHES=1 on code whose images are right.",
            table
                .sections
                .iter()
                .map(|(k, _)| k.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
        return;
    }
    let mut run = Run {
        dir: tempfile::tempdir().unwrap(),
        threads: std::env::var("RAYLINK_HASH_THREADS").unwrap_or_else(|_| "2".into()),
        hashes: Vec::new(),
        failures: Vec::new(),
    };
    whitted_cases(&mut run);
    monte_carlo_cases(&mut run);
    irradiance_cache_cases(&mut run);
    network_cases(&mut run);
    farm_cases(&mut run);
    animation_cases(&mut run);
    resume_case(&mut run);
    if let Some(keep) = std::env::var_os("RAYLINK_HASH_KEEP") {
        copy_tree(run.dir.path(), Path::new(&keep));
    }
    let seconds = start.elapsed().as_secs_f64();
    let images = run.hashes.len();

    let mut failures = std::mem::take(&mut run.failures);
    if record {
        let own: Vec<&Hash> = run.hashes.iter().filter(|h| h.same_as.is_none()).collect();
        let mut seen = std::collections::BTreeSet::new();
        for h in &own {
            assert!(
                seen.insert((&h.case, &h.output)),
                "{} {} twice",
                h.case,
                h.output
            );
        }
        assert!(
            failures.is_empty(),
            "not recorded:\n{}",
            failures.join("\n")
        );
        let own: Vec<Hash> = run
            .hashes
            .into_iter()
            .filter(|h| h.same_as.is_none())
            .collect();
        let lines = own.len();
        table.record(&table_path, &key, &own);
        eprintln!("bit_identity: recorded {lines} hashes for {key} in {TABLE} ({images} images, {seconds:.1} s)");
        return;
    }
    let recorded = recorded.unwrap();
    let mut unrendered: BTreeMap<_, _> = recorded.clone();
    let mut checked = 0;
    for h in &run.hashes {
        let own = (h.case.clone(), h.output.clone());
        let line = (
            h.case.clone(),
            h.same_as.clone().unwrap_or(h.output.clone()),
        );
        let want = recorded.get(&line).copied();
        unrendered.remove(&own);
        match want {
            Some(Some(w)) if w == h.hash => checked += 1,
            Some(None) => eprintln!(
                "bit_identity: {} {}: {:016x}, not recorded for {key} yet (not compared)",
                own.0, own.1, h.hash
            ),
            Some(Some(w)) => failures.push(format!(
                "{} {}: {:016x}, recorded {w:016x}{}",
                own.0,
                own.1,
                h.hash,
                h.same_as
                    .as_ref()
                    .map(|s| format!(" (as {s})"))
                    .unwrap_or_default()
            )),
            None => failures.push(format!(
                "{} {}: {:016x}, no line in {TABLE} [{key}]",
                own.0, own.1, h.hash
            )),
        }
    }
    for ((case, output), hash) in &unrendered {
        let hash = hash.map_or("-".to_string(), |h| format!("{h:016x}"));
        failures.push(format!("{case} {output}: recorded {hash}, not rendered"));
    }
    eprintln!("bit_identity: {checked} of {images} images as recorded for {key} ({seconds:.1} s)");
    if !failures.is_empty() {
        for f in &failures {
            eprintln!("bit_identity: DIFFERS: {f}");
        }
        panic!(
            "{} of the recorded images differ or failed (listed above); if the change is \
             meant to alter images, record again with RAYLINK_RECORD_HASHES=1",
            failures.len()
        );
    }
}

/// Copies the files of `from` into `to`, folders included (for `RAYLINK_HASH_KEEP`).
fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_tree(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).unwrap();
        }
    }
}
