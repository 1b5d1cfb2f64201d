//! The path tracer's light passes (Cycles' DiffDir, ..., Env and light groups), checked
//! against the image they decompose and against independent renders:
//! - the lobe passes recompose the image, (DiffDir + DiffInd)·DiffCol + (GlossDir +
//!   GlossInd)·GlossCol + (TransDir + TransInd)·TransCol + Emit + Env, pixel by pixel to
//!   1e-4 relative, on the Cornell box and on a scene with every kind of lobe and light,
//!   with either pixel reconstruction and with the sample clamp;
//! - on a diffuse scene the direct light is what a render of one bounce adds to the
//!   emission seen (the same samples: to 1e-4; other samples: the image means to 3%), and
//!   glossy and transmission passes are black;
//! - the light groups sum to the image less Emit and Env;
//! - the command line writes them as layers an EXR reader lists, leaves the image's pixels
//!   as they are without them, and refuses them (one line, exit 2, nothing written) where
//!   they cannot be had.

mod common;

use raylink::image::filter::Reconstruction;
use raylink::job::LightPasses;
use raylink::{Control, Image, Job, Renderer, Scene, Settings, Technique, TechniqueKind};
use std::path::Path;
use std::sync::Arc;

#[path = "common/render.rs"]
mod render;
use render::mean;

fn scene(path: &str) -> Arc<Scene> {
    Arc::new(Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join(path)).unwrap())
}

/// The path tracer's job at `size`, seed `seed`, with `edit` applied to its settings.
fn job(
    scene: &Scene,
    (spp, max_depth): (u32, u32),
    size: (u32, u32),
    seed: u64,
    edit: impl FnOnce(&mut raylink::job::MonteCarloSettings),
) -> Job {
    let settings = Settings {
        integrator: Some(TechniqueKind::Path),
        spp: Some(spp),
        max_depth: Some(max_depth),
        ..Settings::default()
    };
    let mut technique = Technique::create(&settings).unwrap();
    if let Technique::Path(mc) = &mut technique {
        edit(mc);
    }
    Job {
        width: size.0,
        height: size.1,
        seed,
        threads: Some(2),
        ..Job::new(scene, technique)
    }
}

/// The image and its light passes (with light groups).
fn render(scene: &Arc<Scene>, job: Job) -> (Image, LightPasses) {
    let control = Control::default();
    let mut renderer = Renderer::new(scene.clone(), job, &control).unwrap();
    let image = renderer.render(&control).unwrap().image;
    let passes = renderer
        .render_light_passes(true, &control)
        .unwrap()
        .unwrap();
    (image, passes)
}

fn layer<'a>(passes: &'a LightPasses, name: &str) -> &'a Image {
    &passes
        .layers
        .iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no layer {name}"))
        .1
}

/// The image the lobe passes recompose.
fn recomposed(p: &LightPasses) -> Image {
    let mut out = layer(p, "Emit").clone();
    for (i, px) in out.pixels.iter_mut().enumerate() {
        *px += layer(p, "Env").pixels[i];
        for kind in ["Diff", "Gloss", "Trans"] {
            let l = |s: &str| layer(p, &format!("{kind}{s}")).pixels[i];
            *px += (l("Dir") + l("Ind")) * l("Col");
        }
    }
    out
}

/// The sum of the light groups.
fn groups_sum(p: &LightPasses) -> Image {
    let groups: Vec<&Image> = p
        .layers
        .iter()
        .filter(|(n, _)| n.starts_with("Combined_"))
        .map(|(_, i)| i)
        .collect();
    assert!(!groups.is_empty());
    let mut out = groups[0].clone();
    for g in &groups[1..] {
        for (a, b) in out.pixels.iter_mut().zip(&g.pixels) {
            *a += *b;
        }
    }
    out
}

/// Every channel of `a` within `rel` of `b`'s (relative to the larger, or to 1e-3).
fn assert_close(case: &str, a: &Image, b: &Image, rel: f32) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let mut worst = (0.0f32, 0);
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        for c in 0..3 {
            let (x, y) = (p[c], q[c]);
            let e = (x - y).abs() / x.abs().max(y.abs()).max(1e-3);
            if e > worst.0 || e.is_nan() {
                worst = (e, i);
            }
        }
    }
    let i = worst.1;
    assert!(
        worst.0 <= rel,
        "{case}: pixel {i}: {:?} against {:?} ({:.2e} relative)",
        a.pixels[i],
        b.pixels[i],
        worst.0
    );
}

#[test]
fn the_lobe_passes_recompose_the_image() {
    let cases: [(&str, &str, u32); 2] = [
        ("the Cornell box", "scenes/cornell-box.toml", 8),
        ("every lobe", "tests/scenes/light-passes.toml", 6),
    ];
    for (name, path, depth) in cases {
        let s = scene(path);
        type Edit = fn(&mut raylink::job::MonteCarloSettings);
        let edits: [(&str, Edit); 3] = [
            ("splatted", |_| {}),
            ("importance", |m| {
                m.reconstruction = Reconstruction::Importance
            }),
            ("clamped", |m| m.max_component_value = Some(0.5)),
        ];
        for (how, edit) in edits {
            let (image, passes) = render(&s, job(&s, (8, depth), (48, 36), 5, edit));
            let case = format!("{name}, {how}");
            assert_close(&case, &recomposed(&passes), &image, 1e-4);
            assert!(
                image.pixels.iter().any(|p| p.max_element() > 0.01),
                "{case}"
            );
        }
    }
}

#[test]
fn every_pass_has_light_on_the_scene_of_every_lobe() {
    let s = scene("tests/scenes/light-passes.toml");
    let (_, passes) = render(&s, job(&s, (8, 6), (48, 36), 5, |_| {}));
    // Refraction reaches a light only after leaving the glass: the direct transmission is
    // the frosted glass's next-event estimation through its rough interface.
    for name in [
        "DiffDir", "DiffInd", "DiffCol", "GlossDir", "GlossInd", "GlossCol", "TransDir",
        "TransInd", "TransCol", "Emit", "Env",
    ] {
        let m = mean(layer(&passes, name));
        assert!(m.iter().all(|v| *v > 1e-5), "{name}: {m:?}");
    }
}

#[test]
fn direct_diffuse_light_is_one_bounce_less_what_the_camera_sees() {
    let s = scene("scenes/cornell-box.toml");
    let size = (40, 40);
    let (_, passes) = render(&s, job(&s, (16, 8), size, 9, |_| {}));
    let direct = |p: &LightPasses| {
        let mut d = layer(p, "DiffDir").clone();
        for (i, px) in d.pixels.iter_mut().enumerate() {
            *px = *px * layer(p, "DiffCol").pixels[i] + layer(p, "Emit").pixels[i];
        }
        d
    };
    // The same samples, one bounce: emission seen and direct light, nothing else.
    let (one, _) = render(&s, job(&s, (16, 1), size, 9, |_| {}));
    assert_close("same samples", &direct(&passes), &one, 1e-4);
    // Other samples: the same light, within noise.
    let (other, _) = render(&s, job(&s, (64, 1), size, 77, |_| {}));
    let (a, b) = (mean(&direct(&passes)), mean(&other));
    for c in 0..3 {
        assert!((a[c] - b[c]).abs() <= 0.03 * b[c], "{a:?} against {b:?}");
    }
    // Indirect light is there, and no glossy or transmission lobe is.
    assert!(mean(layer(&passes, "DiffInd"))[0] > 0.01);
    for name in [
        "GlossDir", "GlossInd", "GlossCol", "TransDir", "TransInd", "TransCol",
    ] {
        let zero = layer(&passes, name).pixels.iter().all(|p| *p == p * 0.0);
        assert!(zero, "{name} is not black on a diffuse scene");
    }
}

#[test]
fn the_light_groups_sum_to_the_image_less_what_the_camera_sees_of_the_lights() {
    for path in ["scenes/cornell-box.toml", "tests/scenes/light-passes.toml"] {
        let s = scene(path);
        let (image, passes) = render(&s, job(&s, (8, 6), (48, 36), 5, |_| {}));
        let mut lit = image.clone();
        for (i, px) in lit.pixels.iter_mut().enumerate() {
            *px -= layer(&passes, "Emit").pixels[i] + layer(&passes, "Env").pixels[i];
        }
        // The differences of near-equal values: relative to the image.
        let sum = groups_sum(&passes);
        let mut worst = 0.0f32;
        for ((a, b), full) in sum.pixels.iter().zip(&lit.pixels).zip(&image.pixels) {
            worst = worst.max((*a - *b).abs().max_element() / full.max_element().max(1e-3));
        }
        assert!(worst <= 1e-4, "{path}: {worst:.2e}");
    }
}

fn read_raw(path: &Path) -> raylink::image::io::RawImage {
    raylink::image::io::read_within(path, &raylink::input_file::Allowance::machine()).unwrap()
}

#[test]
fn the_command_line_writes_the_passes_as_layers_and_leaves_the_image_alone() {
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name).to_string_lossy().into_owned();
    let common = [
        "render",
        "tests/scenes/light-passes.toml",
        "--spp",
        "4",
        "--seed",
        "3",
        "--aov",
        "-q",
    ];
    let run = |extra: &[&str], o: &str| {
        let mut args = common.to_vec();
        args.extend(["-o", o]);
        args.extend(extra);
        let r = common::raylink(&args);
        assert!(r.status.success(), "{}", common::stderr(&r));
    };
    let (plain, with) = (out("plain.exr"), out("with.exr"));
    run(&[], &plain);
    run(&["--light-passes", "--light-groups"], &with);
    let (a, b) = (read_raw(Path::new(&plain)), read_raw(Path::new(&with)));
    let mut names = LIGHT_LAYERS
        .iter()
        .map(|l| format!("{l}.R"))
        .collect::<Vec<_>>();
    names.extend(
        [
            "Combined_light0.B",
            "Combined_light1.G",
            "Combined_light2.R",
        ]
        .map(String::from),
    );
    for n in &names {
        assert!(b.channels.contains(n), "{n} not in {:?}", b.channels);
        assert!(!a.channels.contains(n), "{n} without --light-passes");
    }
    assert!(!b.channels.iter().any(|c| c.starts_with("Combined_light3")));
    // The image's own channels, bit for bit.
    let rgb = |r: &raylink::image::io::RawImage| {
        let n = r.channels.len();
        let at = |c: &str| r.channels.iter().position(|x| x == c).unwrap();
        let idx = [at("R"), at("G"), at("B")];
        r.data
            .chunks_exact(n)
            .flat_map(|p| idx.map(|i| p[i].to_bits()))
            .collect::<Vec<u32>>()
    };
    assert_eq!(rgb(&a), rgb(&b));
}

const LIGHT_LAYERS: [&str; 11] = [
    "DiffDir", "DiffInd", "DiffCol", "GlossDir", "GlossInd", "GlossCol", "TransDir", "TransInd",
    "TransCol", "Emit", "Env",
];

#[test]
fn the_passes_are_refused_where_they_cannot_be_had() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("x.exr").to_string_lossy().into_owned();
    let png = dir.path().join("x.png").to_string_lossy().into_owned();
    let scene = "tests/scenes/light-passes.toml";
    let cases: [(&str, Vec<&str>, &[&str]); 6] = [
        (
            "another technique",
            vec![scene, "--integrator", "bdpt", "-o", &o],
            &["--light-passes", "bdpt"],
        ),
        (
            "guiding",
            vec![scene, "--guiding", "true", "-o", &o],
            &["--light-passes", "guiding"],
        ),
        (
            "a time limit",
            vec![scene, "--time-limit", "1", "-o", &o],
            &["--light-passes", "time limit"],
        ),
        (
            "no EXR output",
            vec![scene, "-o", &png],
            &["--light-passes", ".exr"],
        ),
        (
            "a part",
            vec![scene, "--crop", "0,0,8,8", "-o", &o],
            &["--light-passes", "part"],
        ),
        (
            "media",
            vec![
                "tests/scenes/media-box.toml",
                "--integrator",
                "path",
                "-o",
                &o,
            ],
            &["--light-passes", "media"],
        ),
    ];
    for (case, args, needles) in cases {
        let mut all = vec!["render", "--spp", "1", "--aov", "--light-passes"];
        all.extend(args);
        let r = common::raylink(&all);
        common::assert_clean_failure_of(case, &r, needles);
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert!(left.is_empty(), "{case}: wrote {left:?}");
    }
    // Without --aov the option is refused by the parser.
    let r = common::raylink(&["render", scene, "--light-passes", "-o", &o]);
    assert_eq!(r.status.code(), Some(2));
}
