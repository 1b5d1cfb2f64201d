//! The pbrt-v4 reader end to end: Bitterli's Cornell box against the same scene written in
//! TOML, statements and transforms on small scenes, PLY in every encoding, and the bad-input
//! corpus in tests/bad_inputs/pbrt.

use raylink::image::Image;
use raylink::math::{Rgb, Vec3};
use raylink::scene::{Geometry, Scene, Sphere};
use std::path::{Path, PathBuf};

#[path = "common/pbrt.rs"]
mod pbrt_common;
use pbrt_common::*;

#[test]
fn bitterli_cornell_box_loads_with_the_expected_contents() {
    let scene = Scene::load(&bitterli()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.shapes.len(), 8);
    assert_eq!(scene.materials.len(), 8);
    assert!(scene.lights.is_empty());
    let emitters: Vec<_> = scene.materials.iter().filter(|m| m.is_emissive()).collect();
    assert_eq!(emitters.len(), 1);
    assert_eq!(emitters[0].emission, Rgb::new(17.0, 12.0, 4.0));
    let cam = &scene.camera;
    assert!(
        (cam.position - Vec3::new(0.0, 1.0, 6.8)).length() < 1e-5,
        "{cam:?}"
    );
    assert!(((cam.look_at - cam.position).normalize() - Vec3::NEG_Z).length() < 1e-5);
    assert!((cam.up - Vec3::Y).length() < 1e-5);
    assert_eq!((cam.width, cam.height, cam.fov_deg), (1024, 1024, 19.5));
    assert_eq!(scene.settings.spp, Some(64));
    assert_eq!(scene.settings.max_depth, Some(65));
    assert_eq!(
        scene.settings.integrator,
        Some(raylink::TechniqueKind::Path)
    );
    assert_eq!(
        scene.settings.filter,
        Some(raylink::image::filter::Filter::Triangle { radius: 1.0 })
    );
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    // The light faces down, as pbrt's normals say.
    let light = scene
        .shapes
        .iter()
        .find(|s| scene.materials[s.material].is_emissive())
        .unwrap();
    for [a, b, c] in light.geometry.triangles() {
        assert!((b - a).cross(c - a).y < 0.0);
    }
}

/// Mean colour of a vertical band of the image (x in [x0, x1) as fractions of the width,
/// middle half of the height).
fn band(image: &Image, x0: f32, x1: f32) -> Rgb {
    let (w, h) = (image.width as f32, image.height as f32);
    let mut sum = Rgb::ZERO;
    let mut n = 0.0;
    for y in (h * 0.25) as u32..(h * 0.75) as u32 {
        for x in (w * x0) as u32..(w * x1) as u32 {
            sum += image.get(x, y);
            n += 1.0;
        }
    }
    sum / n
}

/// The pbrt file and scenes/cornell-box.toml (the same scene written by hand) give the same
/// Whitted image; with the same ambient term (pbrt has none, the TOML sets 0.05), the RMSE
/// is below 1% of the mean pixel value. The red wall is on the left as in Tungsten's
/// reference image (the linear 256x256 copy beside the scene), so the camera does not mirror.
#[test]
fn bitterli_pbrt_renders_like_the_toml_cornell_box_and_the_reference() {
    let mut from_pbrt = Scene::load(&bitterli()).unwrap();
    let toml = Scene::load(&root().join("scenes/cornell-box.toml")).unwrap();
    from_pbrt.ambient = toml.ambient;
    let a = whitted_render(&from_pbrt, 128);
    let b = whitted_render(&toml, 128);
    let mean: f32 =
        b.pixels.iter().map(|p| p.element_sum() / 3.0).sum::<f32>() / b.pixels.len() as f32;
    let rmse = a.rmse(&b);
    eprintln!("pbrt vs TOML Whitted RMSE {rmse} (mean {mean})");
    assert!(mean > 0.05);
    assert!(rmse < 0.01 * mean, "RMSE {rmse}, mean {mean}");

    let (reference, _) =
        raylink::image::output::read_image(&bitterli().with_file_name("TungstenRender-256.exr"))
            .unwrap();
    for image in [&a, &reference] {
        let (left, right) = (band(image, 0.0, 0.15), band(image, 0.85, 1.0));
        eprintln!(
            "{}x{}: left red/green {:.3}, right green/red {:.3}",
            image.width,
            image.height,
            left.x / left.y,
            right.y / right.x
        );
        assert!(
            left.x > 1.5 * left.y && right.y > 1.2 * right.x,
            "{left} {right}"
        );
    }
}

/// The substring a bad case's message must contain, from its first line `# expect: ...`.
fn expectation(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .next()
        .and_then(|l| l.strip_prefix("# expect: "))
        .unwrap_or_else(|| panic!("{}: first line must be `# expect: ...`", path.display()))
        .trim_end()
        .to_string()
}

fn bad_cases() -> Vec<PathBuf> {
    let dir = root().join("tests/bad_inputs/pbrt");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "pbrt"))
        .collect();
    files.sort();
    files
}

#[test]
fn bad_pbrt_files_fail_with_one_line_naming_file_line_and_problem() {
    let files = bad_cases();
    assert!(files.len() >= 20, "only {} cases", files.len());
    let mut failures = Vec::new();
    for path in &files {
        let expect = expectation(path);
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        match std::panic::catch_unwind(|| Scene::load(path)) {
            Err(_) => failures.push(format!("{name}: panicked")),
            Ok(Ok(_)) => failures.push(format!("{name}: loaded, expected an error")),
            Ok(Err(e)) => {
                let msg = e.to_string();
                if msg.contains('\n') || !msg.contains(&name) || !msg.contains(&expect) {
                    failures.push(format!("{name}: `{expect}` not in:\n      {msg}"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "\n  {}", failures.join("\n  "));
}

// ------------------------------------------------------------------------------------------
// Statements on small scenes.

/// The vertices of the scene's first triangle, in world space.
fn first_triangle(s: &Scene) -> [Vec3; 3] {
    s.shapes[0].geometry.triangles()[0]
}

fn assert_maps(body: &str, expected: [Vec3; 3]) {
    let s = world(&format!("{body}\n{TRI}"));
    let got = first_triangle(&s);
    // The winding may have been reversed (a mirroring transform): compare as sets.
    for e in expected {
        assert!(
            got.iter().any(|g| close(*g, e)),
            "{body}: {e} not in {got:?}"
        );
    }
}

#[test]
fn transforms_match_hand_computed_matrices() {
    let v = Vec3::new;
    assert_maps(
        "Translate 1 2 3",
        [v(1., 2., 3.), v(2., 2., 3.), v(1., 3., 3.)],
    );
    assert_maps("Scale 2 3 4", [v(0., 0., 0.), v(2., 0., 0.), v(0., 3., 0.)]);
    assert_maps(
        "Rotate 90 0 0 1",
        [v(0., 0., 0.), v(0., 1., 0.), v(-1., 0., 0.)],
    );
    assert_maps(
        "Rotate 90 1 0 0",
        [v(0., 0., 0.), v(1., 0., 0.), v(0., 0., 1.)],
    );
    // Later statements act first: p' = T (R p).
    assert_maps(
        "Translate 1 0 0 Rotate 90 0 0 1",
        [v(1., 0., 0.), v(1., 1., 0.), v(0., 0., 0.)],
    );
    // LookAt is world-to-camera: eye (0,0,5) looking down -z puts world +x at camera -x.
    assert_maps(
        "LookAt 0 0 5  0 0 0  0 1 0",
        [v(0., 0., 5.), v(-1., 0., 5.), v(0., 1., 5.)],
    );
    // Matrices are given column by column; both syntaxes (bracketed or bare).
    assert_maps(
        "ConcatTransform [1 0 0 0  0 1 0 0  0 0 1 0  5 6 7 1]",
        [v(5., 6., 7.), v(6., 6., 7.), v(5., 7., 7.)],
    );
    assert_maps(
        "Translate 9 9 9 Transform 2 0 0 0  0 2 0 0  0 0 2 0  0 0 0 1",
        [v(0., 0., 0.), v(2., 0., 0.), v(0., 2., 0.)],
    );
    assert_maps(
        "Translate 1 0 0 CoordinateSystem \"a\" Identity Translate 0 5 0 CoordSysTransform \"a\"",
        [v(1., 0., 0.), v(2., 0., 0.), v(1., 1., 0.)],
    );
    assert_maps(
        "AttributeBegin Translate 1 0 0 AttributeEnd TransformBegin Scale 3 3 3 TransformEnd",
        [v(0., 0., 0.), v(1., 0., 0.), v(0., 1., 0.)],
    );
    // "camera" is the camera's space: the eye is at (0,0,5), looking down -z, with camera
    // +x along world +x (the LookAt's -x, mirrored by the Scale -1 1 1).
    assert_maps(
        "CoordSysTransform \"camera\"",
        [v(0., 0., 5.), v(1., 0., 5.), v(0., 1., 5.)],
    );
    // ActiveTransform EndTime: transforms for the end of the shutter leave the shape at
    // shutter open as it was (they move it by shutter close).
    assert_maps(
        "ActiveTransform EndTime Translate 5 5 5 ActiveTransform All",
        [v(0., 0., 0.), v(1., 0., 0.), v(0., 1., 0.)],
    );
}

#[test]
fn both_parameter_syntaxes_and_comments() {
    let a = world("Shape \"sphere\" \"float radius\" 2 # a comment\n");
    let b = world("Shape \"sphere\" \"float radius\" [ 2 ]\n");
    for s in [&a, &b] {
        assert_eq!(
            s.shapes[0].geometry,
            Geometry::Sphere(Sphere {
                center: Vec3::ZERO,
                radius: 2.0
            })
        );
    }
    let s = world(
        "AreaLightSource \"diffuse\" \"rgb L\" [1 2 3] \"bool twosided\" \"false\" \"float scale\" 2\n\
         Shape \"sphere\"\n",
    );
    assert_eq!(s.materials[0].emission, Rgb::new(2.0, 4.0, 6.0));
}

#[test]
fn orientation_follows_pbrt() {
    let normal = |s: &Scene| {
        let [a, b, c] = first_triangle(s);
        (b - a).cross(c - a).normalize()
    };
    assert!(close(normal(&world(TRI)), Vec3::Z));
    assert!(close(
        normal(&world(&format!("ReverseOrientation {TRI}"))),
        Vec3::NEG_Z
    ));
    // A mirroring transform keeps the normal's side (normals transform as normals).
    assert!(close(
        normal(&world(&format!("Scale 1 1 -1 {TRI}"))),
        Vec3::NEG_Z
    ));
    assert!(close(
        normal(&world(&format!("Scale -1 1 1 {TRI}"))),
        Vec3::Z
    ));
    // With per-vertex normals, the geometric normal faces them.
    let with_n = "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \
                  \"integer indices\" [0 1 2] \"normal N\" [0 0 -1 0 0 -1 0 0 -1]\n";
    assert!(close(normal(&world(with_n)), Vec3::NEG_Z));
    assert!(close(
        normal(&world(&format!("ReverseOrientation {with_n}"))),
        Vec3::Z
    ));
    // Quadrics: a disk faces +z, turned by ReverseOrientation.
    assert!(close(normal(&world("Shape \"disk\"\n")), Vec3::Z));
    assert!(close(
        normal(&world("ReverseOrientation Shape \"disk\"\n")),
        Vec3::NEG_Z
    ));
}

#[test]
fn shapes_spheres_disks_bilinear_patches_and_instances() {
    let s = world("Translate 1 2 3 Scale 2 2 2 Shape \"sphere\" \"float radius\" 0.5\n");
    assert_eq!(
        s.shapes[0].geometry,
        Geometry::Sphere(Sphere {
            center: Vec3::new(1.0, 2.0, 3.0),
            radius: 1.0
        })
    );
    // A non-uniform scale makes an ellipsoid: tessellated, with about its area.
    let s = world("Scale 1 1 2 Shape \"sphere\"\n");
    assert!(matches!(s.shapes[0].geometry, Geometry::Triangles(_)));
    let area = s.shapes[0].geometry.area();
    assert!((area - 21.48).abs() < 0.3, "ellipsoid area {area}");
    let s =
        world("Shape \"disk\" \"float radius\" 2 \"float innerradius\" 1 \"float height\" 0.5\n");
    let area = s.shapes[0].geometry.area();
    assert!((area / (3.0 * std::f32::consts::PI) - 1.0).abs() < 0.01);
    // A planar bilinear patch is a quad; its vertex order (p00 p10 p01 p11) becomes a polygon.
    let s = world("Shape \"bilinearmesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 1 1 0]\n");
    let Geometry::Quads(q) = &s.shapes[0].geometry else {
        panic!("{:?}", s.shapes[0].geometry)
    };
    assert_eq!(q.indices, vec![[0, 1, 3, 2]]);
    assert!((s.shapes[0].geometry.area() - 1.0).abs() < 1e-6);
    // Instances place one stored object under each instance's transform; as copies, they
    // are where the transforms put them.
    let placed = world(&format!(
        "ObjectBegin \"tri\" Translate 0 0 1 {TRI} ObjectEnd\n\
         AttributeBegin Translate 10 0 0 ObjectInstance \"tri\" AttributeEnd\n\
         ObjectInstance \"tri\"\n"
    ));
    assert_eq!(placed.shapes.len(), 0);
    assert_eq!((placed.prototypes.len(), placed.instances.len()), (1, 2));
    let s = placed.flattened();
    assert_eq!(s.shapes.len(), 2);
    assert!(close(first_triangle(&s)[0], Vec3::new(10.0, 0.0, 1.0)));
    assert!(close(
        s.shapes[1].geometry.triangles()[0][0],
        Vec3::new(0.0, 0.0, 1.0)
    ));
    // loopsubdiv: a tetrahedron subdivided 3 times, 4·4³ triangles on its limit surface
    // (each corner at a fifth of the way from the centre), without a warning; bad levels
    // are errors naming the line and the parameter.
    let tetra = "\"point3 P\" [1 1 1  1 -1 -1  -1 1 -1  -1 -1 1] \
                 \"integer indices\" [0 1 2  0 3 1  0 2 3  1 3 2]";
    let s = world(&format!(
        "Shape \"loopsubdiv\" \"integer levels\" 3 {tetra}\n"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let Geometry::Triangles(m) = &s.shapes[0].geometry else {
        panic!("{:?}", s.shapes[0].geometry)
    };
    assert_eq!(m.indices.len(), 4 * 64);
    let corner = m.positions[0].abs();
    assert!(close(corner, Vec3::splat(0.2)), "{corner}");
    for levels in ["-1", "13"] {
        let dir = tempfile::tempdir().unwrap();
        let text = format!("{HEADER}Shape \"loopsubdiv\" \"integer levels\" {levels} {tetra}\n");
        let e = load_in(dir.path(), &text, &[]).unwrap_err().to_string();
        assert!(e.contains("line 5") && e.contains("\"levels\""), "{e}");
    }
}

#[test]
fn include_import_and_cycles() {
    let dir = tempfile::tempdir().unwrap();
    let s = load_in(
        dir.path(),
        &format!("{HEADER}Include \"parts/tri.pbrt\"\nImport \"parts/tri.pbrt\"\n"),
        &[("parts/tri.pbrt", TRI.as_bytes())],
    )
    .unwrap();
    assert_eq!(s.shapes.len(), 2);
    let e = load_in(
        dir.path(),
        &format!("{HEADER}{TRI}Include \"parts/a.pbrt\"\n"),
        &[
            ("parts/a.pbrt", b"Include \"b.pbrt\"\n"),
            ("parts/b.pbrt", b"\n\nInclude \"a.pbrt\"\n"),
        ],
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains(
            "b.pbrt: line 3, column 1: include cycle: a.pbrt includes b.pbrt includes a.pbrt"
        ),
        "{e}"
    );
}

/// pbrt's camera space is left-handed; a plain LookAt shows world +x (seen from +z) on the
/// left of the image, the `Scale -1 1 1` idiom on the right. raylink reproduces both.
#[test]
fn camera_handedness_is_pbrt_s() {
    let lamp = "AreaLightSource \"diffuse\" \"rgb L\" [5 5 5]\n\
                Shape \"trianglemesh\" \"point3 P\" [0.5 -0.5 0  1.5 -0.5 0  1.5 0.5 0  0.5 0.5 0] \
                \"integer indices\" [0 1 2 0 2 3]\n";
    for (prefix, lit_side_left) in [("", true), ("Scale -1 1 1\n", false)] {
        let s = load(&format!(
            "{prefix}LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n\
             Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\nWorldBegin\n{lamp}"
        ));
        let image = whitted_render(&s, 32);
        let (left, right) = (band(&image, 0.0, 0.5), band(&image, 0.5, 1.0));
        assert_eq!(
            left.x > right.x,
            lit_side_left,
            "{prefix:?}: left {left}, right {right}"
        );
        assert!(left.x.max(right.x) > 1.0);
    }
}

// ------------------------------------------------------------------------------------------
// PLY meshes.

/// A unit square (as one quad) and a triangle beside it, with normals and uvs, as PLY bytes
/// in `format` ("ascii", "binary_little_endian" or "binary_big_endian").
fn ply_fixture(format: &str) -> Vec<u8> {
    let verts: [[f32; 8]; 5] = [
        [0., 0., 0., 0., 0., 1., 0., 0.],
        [1., 0., 0., 0., 0., 1., 1., 0.],
        [1., 1., 0., 0., 0., 1., 1., 1.],
        [0., 1., 0., 0., 0., 1., 0., 1.],
        [2., 0., 0., 0., 0., 1., 0.5, 0.5],
    ];
    let faces: [&[i32]; 2] = [&[0, 1, 2, 3], &[1, 4, 2]];
    let mut out = format!(
        "ply\nformat {format} 1.0\ncomment raylink test\nelement vertex 5\n\
         property float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         property float s\nproperty float t\n\
         element face 2\nproperty list uchar int vertex_index\nend_header\n"
    )
    .into_bytes();
    for v in verts {
        for x in v {
            match format {
                "ascii" => out.extend(format!("{x} ").as_bytes()),
                "binary_little_endian" => out.extend(x.to_le_bytes()),
                _ => out.extend(x.to_be_bytes()),
            }
        }
        if format == "ascii" {
            out.push(b'\n');
        }
    }
    for f in faces {
        match format {
            "ascii" => {
                let ix: Vec<String> = f.iter().map(|i| i.to_string()).collect();
                out.extend(format!("{} {}\n", f.len(), ix.join(" ")).as_bytes());
            }
            _ => {
                out.push(f.len() as u8);
                for &i in f {
                    out.extend(if format == "binary_little_endian" {
                        i.to_le_bytes()
                    } else {
                        i.to_be_bytes()
                    });
                }
            }
        }
    }
    out
}

#[test]
fn ply_in_every_encoding_reads_the_same_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let mut meshes = Vec::new();
    for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
        let path = dir.path().join(format!("{format}.ply"));
        std::fs::write(&path, ply_fixture(format)).unwrap();
        let mesh = raylink::scene::ply::read(&path).unwrap_or_else(|e| panic!("{format}: {e}"));
        assert_eq!(mesh.positions.len(), 5, "{format}");
        assert_eq!(mesh.positions[4], Vec3::new(2.0, 0.0, 0.0));
        assert_eq!(mesh.normals.as_ref().unwrap()[2], Vec3::Z);
        assert_eq!(
            mesh.uvs.as_ref().unwrap()[4],
            raylink::math::Vec2::new(0.5, 0.5)
        );
        assert_eq!(mesh.quads, vec![[0, 1, 2, 3]]);
        assert_eq!(mesh.triangles, vec![[1, 4, 2]]);
        meshes.push(mesh);
    }
    assert_eq!(meshes[0], meshes[1]);
    assert_eq!(meshes[1], meshes[2]);
    // Through pbrt's plymesh (quads split: the mesh has normals) and TOML's ply shape.
    let s = load_in(
        dir.path(),
        &format!("{HEADER}Translate 0 0 1 Shape \"plymesh\" \"string filename\" \"binary_big_endian.ply\"\n"),
        &[],
    )
    .unwrap();
    let Geometry::Triangles(m) = &s.shapes[0].geometry else {
        panic!()
    };
    assert_eq!(m.indices.len(), 3);
    assert!((s.shapes[0].geometry.area() - 1.5).abs() < 1e-6);
    assert!(m.positions.iter().all(|p| p.z == 1.0));
    let toml = dir.path().join("s.toml");
    std::fs::write(
        &toml,
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n[materials.m]\n\
         [[shapes]]\ntype = \"ply\"\nfile = \"ascii.ply\"\nmaterial = \"m\"\ntransform = { translate = [0, 0, 1] }\n",
    )
    .unwrap();
    let t = Scene::load(&toml).unwrap();
    assert_eq!(t.shapes[0].geometry, s.shapes[0].geometry);
}

#[test]
fn ply_quads_without_attributes_stay_quads_and_bad_files_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("q.ply");
    let text = "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\n\
                property double z\nelement face 1\nproperty list uchar uint vertex_indices\n\
                end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
    std::fs::write(&path, text).unwrap();
    let mesh = raylink::scene::ply::read(&path).unwrap();
    let g = mesh.into_geometry();
    assert!(matches!(&g[..], [Geometry::Quads(q)] if q.indices == vec![[0, 1, 2, 3]]));
    for (bad, expect) in [
        (
            text.replace("4 0 1 2 3", "3 0 1 9"),
            "vertex index 9 out of range",
        ),
        (text.replace("1 1 0\n", "1 x 0\n"), "line 12"),
        (text.replace("property double z\n", ""), "lack x, y or z"),
        (
            text.replace("format ascii", "format binary_little_endian")
                .replace("0 0 0\n1 0 0", "\u{1}"),
            "malformed PLY",
        ),
        (text[..60].to_string(), "malformed PLY"),
    ] {
        std::fs::write(&path, bad).unwrap();
        let e = raylink::scene::ply::read(&path).unwrap_err().to_string();
        assert!(
            e.contains("q.ply") && e.contains(expect) && !e.contains('\n'),
            "{expect}: {e}"
        );
    }
}

// ------------------------------------------------------------------------------------------
// Conversion to TOML.

/// The pbrt examples in scenes/ load without warnings and render.
#[test]
fn pbrt_examples_in_scenes_load_cleanly() {
    let mut n = 0;
    for entry in std::fs::read_dir(root().join("scenes")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "pbrt") {
            let s = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
            assert!(s.warnings.is_empty(), "{:?}", s.warnings);
            let image = whitted_render(&s, 24);
            assert!(image.pixels.iter().all(|p| p.is_finite()));
            n += 1;
        }
    }
    assert!(n >= 1);
}

/// Cameras: `lensradius`/`focaldistance` make a thin lens (pbrt-v4's defaults: no lens,
/// focus at 10⁶); `orthographic` takes its `screenwindow`'s width, by default 2 units along
/// the shorter image axis; an off-centre window warns with the line.
#[test]
fn thin_lens_and_orthographic_cameras() {
    use raylink::scene::Projection;
    let camera = |cam: &str| {
        load(&format!(
            "Film \"rgb\" \"integer xresolution\" 200 \"integer yresolution\" 100\n\
             Scale -1 1 1\nLookAt 0 0 5  0 0 0  0 1 0\n{cam}\nWorldBegin\n{TRI}"
        ))
    };
    let s = camera("Camera \"perspective\" \"float lensradius\" 0.1 \"float focaldistance\" 4");
    assert_eq!(
        s.camera.projection,
        Projection::ThinLens {
            radius: 0.1,
            focal_distance: 4.0
        }
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let s = camera("Camera \"perspective\" \"float lensradius\" 0.1");
    assert_eq!(
        s.camera.projection,
        Projection::ThinLens {
            radius: 0.1,
            focal_distance: 1e6
        }
    );
    let s = camera("Camera \"orthographic\"");
    assert_eq!(s.camera.projection, Projection::Orthographic { size: 4.0 });
    let s = camera("Camera \"orthographic\" \"float screenwindow\" [-3 3 -1.5 1.5]");
    assert_eq!(s.camera.projection, Projection::Orthographic { size: 6.0 });
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let s = camera("Camera \"orthographic\" \"float screenwindow\" [0 3 -1.5 1.5]");
    assert_eq!(s.camera.projection, Projection::Orthographic { size: 3.0 });
    assert!(
        s.warnings.len() == 1
            && s.warnings[0].contains(":4: Camera \"orthographic\": a screenwindow off the centre"),
        "{:?}",
        s.warnings
    );
}
