//! Object instancing: a scene's objects stored once and placed by instances render as their
//! world-space copies do, through both backends, in pbrt and TOML scenes; 20,000 instances of
//! a 20,000-triangle object render within a gigabyte.

mod common;
#[path = "common/render.rs"]
mod render_common;

use common::{assert_clean_failure_of, raylink, stderr};
use raylink::image::output::read_image;
use raylink::image::Image;
use raylink::scene::Scene;
use raylink::settings::AntiAliasing;
use raylink::{Backend, Settings, Technique, TechniqueKind};
use render_common::{image, View};
use std::fmt::Write as _;
use std::path::Path;

const W: u32 = 96;
const H: u32 = 72;

/// A path-traced render of `scene` (16 samples per pixel, 3 bounces).
fn render(scene: &Scene, backend: Backend) -> Image {
    render_with(
        scene,
        backend,
        Settings {
            integrator: Some(TechniqueKind::Path),
            spp: Some(16),
            max_depth: Some(3),
            ..Settings::default()
        },
    )
}

fn render_with(scene: &Scene, backend: Backend, settings: Settings) -> Image {
    let view = View {
        size: (W, H),
        seed: 5,
        threads: None,
        accel: backend,
    };
    image(scene, Technique::create(&settings).unwrap(), view)
}

/// An object of smooth-shaded triangles (a pyramid whose unit vertex normals lean outwards)
/// and a quad, placed translated, rotated, scaled and mirrored; and a flat-shaded wedge
/// scaled unevenly and sheared. (A smooth mesh scaled unevenly is left out: its normals are
/// interpolated in the object's space, as pbrt-v4 does for instances, not after the copy.)
const OBJECT: &str = r#"
ObjectBegin "thing"
  Material "diffuse" "rgb reflectance" [0.7 0.3 0.2]
  Shape "trianglemesh" "point3 P" [-0.5 0 -0.5  0.5 0 -0.5  0 1.2 0  0 0 0.6]
      "normal N" [-0.6882 0.2294 -0.6882  0.6882 0.2294 -0.6882  0 1 0  0 0.1961 0.9806]
      "integer indices" [0 1 2 1 3 2 3 0 2 0 3 1]
  Material "conductor" "float roughness" 0.2
  Shape "bilinearmesh" "point3 P" [-0.3 0 0.7  0.3 0 0.7  -0.3 0.5 0.9  0.3 0.5 0.9]
      "integer indices" [0 1 2 3]
ObjectEnd
ObjectBegin "wedge"
  Material "diffuse" "rgb reflectance" [0.2 0.5 0.7]
  Shape "trianglemesh" "point3 P" [-0.4 0 -0.3  0.4 0 -0.3  0 0.8 -0.3  0 0 0.4]
      "integer indices" [0 1 2 1 3 2 3 0 2 0 3 1]
ObjectEnd
AttributeBegin Translate -2 0 0 ObjectInstance "thing" AttributeEnd
AttributeBegin Translate 0 0 -1 Rotate 35 0 1 0 Scale 1.4 1.4 1.4 ObjectInstance "thing" AttributeEnd
AttributeBegin Translate 2 0 0 Scale -1 1 1 ObjectInstance "thing" AttributeEnd
AttributeBegin Translate 0.8 0 1.5 Rotate -20 1 0 0 ObjectInstance "thing" AttributeEnd
AttributeBegin Translate -1 0 1.5 ConcatTransform [1 0 0 0  0.4 1 0 0  0 0 1 0  0 0 0 1]
  ObjectInstance "wedge" AttributeEnd
AttributeBegin Translate 1 0 2.5 Scale 1.5 0.6 1 ObjectInstance "wedge" AttributeEnd
"#;

const HEADER: &str = r#"LookAt 0 3 8  0 0.5 0  0 1 0
Camera "perspective" "float fov" 40
WorldBegin
LightSource "infinite" "rgb L" [0.6 0.6 0.6]
LightSource "distant" "point3 from" [1 4 2] "point3 to" [0 0 0] "rgb L" [2 2 2]
AttributeBegin
  Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
  Shape "trianglemesh" "point3 P" [-10 0 -10 10 0 -10 10 0 10 -10 0 10] "integer indices" [0 1 2 0 2 3]
AttributeEnd
"#;

fn instanced_scene(dir: &Path) -> Scene {
    let path = dir.join("things.pbrt");
    std::fs::write(&path, format!("{HEADER}{OBJECT}")).unwrap();
    Scene::load(&path).unwrap()
}

/// Mean absolute difference over all channels, relative to the mean, and the fraction of
/// pixels whose every channel agrees within `tolerance` (absolute, radiance about 0.1–1).
fn compare(a: &Image, b: &Image, tolerance: f32) -> (f64, f64) {
    let n = a.pixels.len() as f64;
    let diff: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| f64::from((*p - *q).abs().element_sum()))
        .sum();
    let mean: f64 = a.pixels.iter().map(|p| f64::from(p.element_sum())).sum();
    let same = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(p, q)| (**p - **q).abs().max_element() <= tolerance)
        .count();
    (diff / mean, same as f64 / n)
}

/// Instances render as their world-space copies (`Scene::flattened`, what the readers made
/// before instancing) with the same backend: the same pixels up to float noise, except where
/// a path's bounce lands a float's width apart on an edge. Wrong normals (a placement's
/// rotation or mirror not carried to the normal) or uvs would shade whole faces apart.
#[test]
fn instances_render_as_their_world_space_copies() {
    let dir = tempfile::tempdir().unwrap();
    let scene = instanced_scene(dir.path());
    assert_eq!((scene.prototypes.len(), scene.instances.len()), (2, 6));
    let flat = scene.flattened();
    assert!(!flat.has_instances());
    assert_eq!(flat.shapes.len(), scene.shapes.len() + 10);
    for backend in Backend::ALL {
        let (a, b) = (render(&scene, backend), render(&flat, backend));
        let (mean, same) = compare(&a, &b, 1e-3);
        eprintln!(
            "{backend}: instanced vs copies: mean difference {mean:.2e} relative, {:.2}% of \
             pixels within 1e-3",
            100.0 * same
        );
        assert!(mean < 1e-5, "{backend}: mean difference {mean}");
        assert!(same > 0.999, "{backend}: only {same} of the pixels agree");
    }
}

/// Whitted's adaptive anti-aliasing subdivides where the corners of a square see different
/// objects: each shape of each instance is an object, as each copy is, so the instanced
/// render subdivides where the copies' does and gives the same image.
#[test]
fn whitted_subdivides_instances_as_their_copies() {
    let dir = tempfile::tempdir().unwrap();
    let scene = instanced_scene(dir.path());
    let whitted = || Settings {
        integrator: Some(TechniqueKind::Whitted),
        aa: Some(AntiAliasing::Adaptive),
        ..Settings::default()
    };
    let a = render_with(&scene, Backend::Embree, whitted());
    let b = render_with(&scene.flattened(), Backend::Embree, whitted());
    let (mean, same) = compare(&a, &b, 1e-3);
    eprintln!(
        "Whitted adaptive, instanced vs copies: {mean:.2e}, {:.2}%",
        100.0 * same
    );
    assert!(mean < 1e-4 && same > 0.995, "{mean} {same}");
}

/// Both backends trace instances alike: Embree's instance geometry and the BVH's second level.
#[test]
fn backends_agree_on_instances() {
    let dir = tempfile::tempdir().unwrap();
    let scene = instanced_scene(dir.path());
    let (a, b) = (
        render(&scene, Backend::Embree),
        render(&scene, Backend::Bvh),
    );
    let (mean, same) = compare(&a, &b, 1e-3);
    eprintln!(
        "embree vs bvh on instances: mean difference {mean:.2e}, {:.2}% within 1e-3",
        100.0 * same
    );
    assert!(mean < 1e-5 && same > 0.999, "{mean} {same}");
}

/// The same objects and instances written as TOML (`raylink convert`) read back as
/// instances and render the same image.
#[test]
fn converted_instances_stay_instances() {
    let dir = tempfile::tempdir().unwrap();
    let scene = instanced_scene(dir.path());
    let toml = dir.path().join("things.toml");
    let out = raylink(&[
        "convert",
        dir.path().join("things.pbrt").to_str().unwrap(),
        "--output",
        toml.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = std::fs::read_to_string(&toml).unwrap();
    assert_eq!(text.matches("[[instances]]").count(), 6, "{text}");
    let back = Scene::load(&toml).unwrap();
    assert_eq!((back.prototypes.len(), back.instances.len()), (2, 6));
    let (mean, same) = compare(
        &render(&scene, Backend::Embree),
        &render(&back, Backend::Embree),
        1e-4,
    );
    assert!(mean < 1e-4 && same > 0.995, "{mean} {same}");
}

/// TOML objects and instances: shapes in an object's space, placed by each instance's
/// transform, agree with the same shapes written in place; emitting shapes are copied.
#[test]
fn toml_instances_place_objects() {
    let dir = tempfile::tempdir().unwrap();
    let common = r#"
[camera]
position = [0, 2, 6]
look_at = [0, 0.5, 0]
width = 96
height = 72

[world]
background = [0.3, 0.3, 0.3]

[materials.grey]
diffuse = 0.6

[materials.lamp]
diffuse = 0
emission = 4

[[shapes]]
type = "quad"
material = "grey"
vertices = [[-5, 0, 5], [5, 0, 5], [5, 0, -5], [-5, 0, -5]]
"#;
    let placed = format!(
        "{common}
[[objects]]
name = \"post\"
[[objects.shapes]]
type = \"sphere\"
material = \"grey\"
center = [0, 0.5, 0]
radius = 0.5
[[objects.shapes]]
type = \"quad\"
material = \"lamp\"
vertices = [[-0.2, 1.2, -0.2], [-0.2, 1.2, 0.2], [0.2, 1.2, 0.2], [0.2, 1.2, -0.2]]

[[instances]]
object = \"post\"
transform = {{ translate = [-1.5, 0, 0] }}

[[instances]]
object = \"post\"
transform = [{{ scale = 0.5 }}, {{ translate = [1.5, 0, 0] }}]
"
    );
    let inline = format!(
        "{common}
[[shapes]]
type = \"sphere\"
material = \"grey\"
center = [-1.5, 0.5, 0]
radius = 0.5
[[shapes]]
type = \"quad\"
material = \"lamp\"
vertices = [[-1.7, 1.2, -0.2], [-1.7, 1.2, 0.2], [-1.3, 1.2, 0.2], [-1.3, 1.2, -0.2]]
[[shapes]]
type = \"sphere\"
material = \"grey\"
center = [1.5, 0.25, 0]
radius = 0.25
[[shapes]]
type = \"quad\"
material = \"lamp\"
vertices = [[1.4, 0.6, -0.1], [1.4, 0.6, 0.1], [1.6, 0.6, 0.1], [1.6, 0.6, -0.1]]
"
    );
    let (a, b) = (
        dir.path().join("placed.toml"),
        dir.path().join("inline.toml"),
    );
    std::fs::write(&a, placed).unwrap();
    std::fs::write(&b, inline).unwrap();
    let (placed, inline) = (Scene::load(&a).unwrap(), Scene::load(&b).unwrap());
    // The lamps are copied (light sampling sees them); the spheres are instanced.
    assert_eq!(placed.instances.len(), 2);
    assert_eq!(placed.shapes.len(), 3);
    let (mean, same) = compare(
        &render(&placed, Backend::Embree),
        &render(&inline, Backend::Embree),
        1e-3,
    );
    eprintln!(
        "TOML instances vs inline shapes: {mean:.2e}, {:.2}%",
        100.0 * same
    );
    assert!(mean < 1e-5 && same > 0.999, "{mean} {same}");
}

/// Bad objects and instances: one line naming the file, the line and the table.
#[test]
fn bad_instances_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let head = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\n[materials.m]\n\n";
    let object =
        "[[objects]]\nname = \"a\"\n[[objects.shapes]]\ntype = \"sphere\"\nmaterial = \"m\"\n";
    let cases: [(&str, String, &[&str]); 4] = [
        (
            "unknown object",
            format!("{head}{object}\n[[instances]]\nobject = \"b\"\n"),
            &[
                "line 14",
                "instances[0]",
                "no [[objects]] table is named \"b\"",
            ],
        ),
        (
            "two objects of one name",
            format!("{head}{object}{object}\n[[instances]]\nobject = \"a\"\n"),
            &["objects[1]", "another object is named \"a\""],
        ),
        (
            "empty object",
            format!("{head}[[objects]]\nname = \"a\"\n\n[[instances]]\nobject = \"a\"\n"),
            &["objects[0]", "at least one [[objects.shapes]]"],
        ),
        (
            "unknown key",
            format!("{head}{object}\n[[instances]]\nobject = \"a\"\nscale = 2\n"),
            &["scale"],
        ),
    ];
    for (case, text, needles) in cases {
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, text).unwrap();
        let out = raylink(&[
            "render",
            path.to_str().unwrap(),
            "-o",
            dir.path().join("out.exr").to_str().unwrap(),
        ]);
        let mut all = vec!["bad.toml"];
        all.extend(needles);
        assert_clean_failure_of(case, &out, &all);
        assert!(
            !dir.path().join("out.exr").exists(),
            "{case}: wrote an image"
        );
    }
}

/// pbrt text: an object of a `cells`×`cells` grid (2·cells² triangles) placed `count` times
/// on a 200-wide lattice facing the camera, each turned a little.
fn lattice(cells: usize, count: usize) -> String {
    let mut s = String::from(
        "LookAt 50 -25 30  50 -25 0  0 1 0\nCamera \"perspective\" \"float fov\" 90\nWorldBegin\n\
         LightSource \"distant\" \"point3 from\" [0 0 1] \"point3 to\" [0 0 0] \"rgb L\" [3 3 3]\n\
         ObjectBegin \"grid\"\nShape \"trianglemesh\" \"point3 P\" [",
    );
    for j in 0..=cells {
        for i in 0..=cells {
            let (x, y) = (i as f32 / cells as f32, j as f32 / cells as f32);
            // A gentle bump, so the grid is not flat.
            let z = 0.1 * (x * 6.0).sin() * (y * 6.0).sin();
            write!(s, " {x} {y} {z}").unwrap();
        }
    }
    s.push_str(" ] \"integer indices\" [");
    let at = |i: usize, j: usize| j * (cells + 1) + i;
    for j in 0..cells {
        for i in 0..cells {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            write!(s, " {a} {b} {c} {a} {c} {d}").unwrap();
        }
    }
    s.push_str(" ]\nObjectEnd\n");
    for k in 0..count {
        writeln!(
            s,
            "AttributeBegin Translate {} {} 0 Rotate {} 0 0 1 Scale 0.5 0.5 0.5 \
             ObjectInstance \"grid\" AttributeEnd",
            (k % 200) as f32 * 0.5,
            -((k / 200) as f32) * 0.5,
            (k % 7) as f32 * 5.0
        )
        .unwrap();
    }
    s
}

/// 20,000 instances of a 20,000-triangle object (400 million triangles placed) render under
/// `--max-memory 1G`, and the process's peak memory stays under a gigabyte; the image
/// shows the lattice. Its copies would need about 100 GB.
#[test]
fn twenty_thousand_instances_render_within_a_gigabyte() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("lattice.pbrt");
    std::fs::write(&scene, lattice(100, 20_000)).unwrap();
    let out_path = dir.path().join("lattice.exr");
    let out = raylink(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        out_path.to_str().unwrap(),
        "--width",
        "200",
        "--height",
        "100",
        "--spp",
        "1",
        "--integrator",
        "path",
        "--max-memory",
        "1G",
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    // The largest peak of this process's children so far: an upper bound on this one's.
    let usage =
        nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_CHILDREN).unwrap();
    let peak_mib = usage.max_rss() as f64 / 1024.0;
    eprintln!("20,000 instances of 20,000 triangles: peak RSS {peak_mib:.0} MiB");
    assert!(peak_mib < 1024.0, "peak RSS {peak_mib:.0} MiB");
    let (image, _) = read_image(&out_path).unwrap();
    let lit = image
        .pixels
        .iter()
        .filter(|p| p.max_element() > 0.0)
        .count();
    assert!(
        lit > image.pixels.len() / 2,
        "the lattice covers only {lit} of {} pixels",
        image.pixels.len()
    );
}

/// Instances of a 20,000-triangle object render as their copies, pixel for pixel up to float
/// noise, at a count whose copies still fit (100 instances, two million triangles).
#[test]
fn a_hundred_instances_of_a_big_object_match_their_copies() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lattice.pbrt");
    std::fs::write(&path, lattice(100, 100)).unwrap();
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.instances.len(), 100);
    let flat = scene.flattened();
    assert_eq!(flat.primitive_count(), 100 * 20_000);
    for backend in Backend::ALL {
        let (mean, same) = compare(&render(&scene, backend), &render(&flat, backend), 1e-3);
        eprintln!(
            "{backend}: 100 instances vs copies: {mean:.2e}, {:.2}%",
            100.0 * same
        );
        assert!(mean < 2e-4 && same > 0.995, "{backend}: {mean} {same}");
    }
}

/// A moving shape in an object is copied at each placement, its motion placed with it: the
/// instanced scene renders as the same moving shapes written in place.
#[test]
fn moving_shapes_in_objects_move_at_every_placement() {
    let dir = tempfile::tempdir().unwrap();
    let head = r#"
[camera]
position = [0, 1, 6]
look_at = [0, 0.5, 0]
width = 96
height = 72

[world]
background = [0.4, 0.4, 0.4]

[materials.grey]
diffuse = 0.6
"#;
    let placed = format!(
        "{head}
[[objects]]
name = \"ball\"
[[objects.shapes]]
type = \"sphere\"
material = \"grey\"
center = [0, 0.5, 0]
radius = 0.4
motion = {{ translate = [0.5, 0, 0] }}

[[instances]]
object = \"ball\"
transform = {{ translate = [-1.5, 0, 0] }}

[[instances]]
object = \"ball\"
transform = [{{ scale = 2 }}, {{ translate = [1, -0.5, 0] }}]
"
    );
    let inline = format!(
        "{head}
[[shapes]]
type = \"sphere\"
material = \"grey\"
center = [-1.5, 0.5, 0]
radius = 0.4
motion = {{ translate = [0.5, 0, 0] }}

[[shapes]]
type = \"sphere\"
material = \"grey\"
center = [1, 0.5, 0]
radius = 0.8
motion = {{ translate = [1, 0, 0] }}
"
    );
    let (a, b) = (
        dir.path().join("placed.toml"),
        dir.path().join("inline.toml"),
    );
    std::fs::write(&a, placed).unwrap();
    std::fs::write(&b, inline).unwrap();
    let (placed, inline) = (Scene::load(&a).unwrap(), Scene::load(&b).unwrap());
    assert!(placed.instances.is_empty());
    assert_eq!(placed.shapes.len(), 2);
    assert!(placed.shapes.iter().all(|s| s.motion.is_some()));
    let (mean, same) = compare(
        &render(&placed, Backend::Embree),
        &render(&inline, Backend::Embree),
        1e-3,
    );
    assert!(mean < 1e-4 && same > 0.995, "{mean} {same}");
}
