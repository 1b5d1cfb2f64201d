//! The scene readers: the bad-input corpus in tests/bad_inputs/scenes and the scenes in scenes/.

use raylink::math::{Vec2, Vec3};
use raylink::scene::{Geometry, Light, Scene, Sphere, Texture};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn toml_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
}

/// The substring a bad scene's message must contain, from its first line `# expect: ...`.
fn expectation(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    let first = text.lines().next().unwrap_or("");
    first
        .strip_prefix("# expect: ")
        .unwrap_or_else(|| panic!("{}: first line must be `# expect: ...`", path.display()))
        .trim_end()
        .to_string()
}

#[test]
fn bad_scenes_fail_with_one_line_messages_naming_the_file_and_the_problem() {
    let files = toml_files(&root().join("tests/bad_inputs/scenes"));
    assert!(files.len() >= 15, "only {} bad scenes", files.len());
    let mut failures = Vec::new();
    for path in &files {
        let expect = expectation(path);
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        match Scene::load(path) {
            Ok(_) => failures.push(format!("{name}: loaded, expected an error")),
            Err(e) => {
                let msg = e.to_string();
                if msg.contains('\n') || msg.contains('\r') {
                    failures.push(format!("{name}: message spans lines: {msg:?}"));
                }
                if !msg.contains(&name) {
                    failures.push(format!("{name}: message does not name the file: {msg}"));
                }
                if !msg.contains(&expect) {
                    failures.push(format!("{name}: message lacks `{expect}`:\n      {msg}"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "\n  {}", failures.join("\n  "));
}

#[test]
fn every_scene_in_scenes_loads() {
    let files = toml_files(&root().join("scenes"));
    assert!(files.len() >= 3);
    for path in files {
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        assert!(!scene.shapes.is_empty());
        for shape in &scene.shapes {
            assert!(shape.material < scene.materials.len());
            assert!(shape.geometry.area() > 0.0, "{}", path.display());
        }
    }
}

fn load(name: &str) -> Scene {
    Scene::load(&root().join("scenes").join(name)).unwrap_or_else(|e| panic!("{e}"))
}

/// A TOML scene given as text, read as if it were a file in tests/bad_inputs/scenes (for meshes).
fn parse(text: &str) -> raylink::Result<Scene> {
    let path = root().join("tests/bad_inputs/scenes/inline.toml");
    raylink::scene::toml::from_str(text, &path)
}

const CAMERA: &str = "[camera]\nposition = [0, 1, 5]\nlook_at = [0, 1, 0]\n\
                      [materials.white]\ndiffuse = 0.8\n";

fn normal(tri: [Vec3; 3]) -> Vec3 {
    let [a, b, c] = tri;
    (b - a).cross(c - a).normalize()
}

#[test]
fn cornell_box_matches_the_pbrt_reference() {
    let s = load("cornell-box.toml");
    assert_eq!(s.shapes.len(), 8);
    assert_eq!(s.camera.position, Vec3::new(0.0, 1.0, 6.8));
    assert_eq!(s.camera.look_at, Vec3::new(0.0, 1.0, 0.0));
    assert_eq!(s.camera.up, Vec3::Y);
    assert_eq!(s.camera.fov_deg, 19.5);
    assert_eq!((s.camera.width, s.camera.height), (512, 512));
    assert!(s.lights.is_empty());

    let diffuse = |name: &str| {
        let m = s.materials.iter().find(|m| m.name == name).unwrap();
        match m.approximation().diffuse {
            Texture::Constant(c) => c,
            _ => panic!("{name} is textured"),
        }
    };
    assert_eq!(diffuse("left_wall"), Vec3::new(0.63, 0.065, 0.05));
    assert_eq!(diffuse("right_wall"), Vec3::new(0.14, 0.45, 0.091));
    for white in ["floor", "ceiling", "back_wall", "short_box", "tall_box"] {
        assert_eq!(diffuse(white), Vec3::new(0.725, 0.71, 0.68));
    }

    // Triangle counts per shape, in file order: five walls, two boxes, the light.
    let counts: Vec<usize> = s
        .shapes
        .iter()
        .map(|x| x.geometry.triangles().len())
        .collect();
    assert_eq!(counts, [2, 2, 2, 2, 2, 12, 12, 2]);

    let emissive: Vec<_> = s
        .shapes
        .iter()
        .filter(|x| s.materials[x.material].is_emissive())
        .collect();
    assert_eq!(emissive.len(), 1);
    let light = emissive[0];
    assert_eq!(
        s.materials[light.material].emission,
        Vec3::new(17.0, 12.0, 4.0)
    );
    for tri in light.geometry.triangles() {
        assert!(tri.iter().all(|p| p.y == 1.98));
        assert!((normal(tri) - Vec3::NEG_Y).length() < 1e-5, "{tri:?}");
    }
    assert!((light.geometry.area() - 0.47 * 0.38).abs() < 1e-5);

    // Orientation as in pbrt's file (its diffuse surfaces are two-sided): the floor faces up
    // and the ceiling down, into the box; the back, right and left walls face out of it.
    let facing = |i: usize| {
        let tris = s.shapes[i].geometry.triangles();
        assert!(tris
            .iter()
            .all(|t| (normal(*t) - normal(tris[0])).length() < 1e-5));
        normal(tris[0])
    };
    let expected = [Vec3::Y, Vec3::NEG_Y, Vec3::NEG_Z, Vec3::X, Vec3::NEG_X];
    for (i, n) in expected.into_iter().enumerate() {
        assert!((facing(i) - n).length() < 1e-5, "shape {i}: {}", facing(i));
    }
}

#[test]
fn whitted_scene_has_glass_over_a_mirror_and_a_checkered_floor() {
    let s = load("whitted.toml");
    assert_eq!((s.camera.width, s.camera.height), (640, 480));
    assert!(matches!(
        s.materials[0].approximation().diffuse,
        Texture::Checker { size, .. } if size == 0.5
    ));
    let glass = s.materials.iter().find(|m| m.name == "glass").unwrap();
    assert!(glass.is_transmissive());
    assert_eq!(glass.approximation().ior, 1.5);
    assert!(s.ambient.max_element() > 0.0);
    assert!(s.background.z > s.background.x);
    assert!(!s.lights.is_empty());
    assert!(s.lights.iter().all(|l| matches!(l, Light::Point(_))));
    let Geometry::Sphere(Sphere { center: g, .. }) = s.shapes[1].geometry else {
        panic!("shape 1 is the glass sphere")
    };
    let Geometry::Sphere(Sphere { center: m, .. }) = s.shapes[2].geometry else {
        panic!("shape 2 is the mirror sphere")
    };
    // In front of (closer to the camera) and above the mirror sphere.
    assert!(g.z > m.z && g.y > m.y);
}

#[test]
fn transforms_are_baked_into_spheres() {
    let s = parse(&format!(
        "{CAMERA}[[shapes]]\ntype = \"sphere\"\nmaterial = \"white\"\ncenter = [1, 0, 0]\n\
         radius = 0.5\ntransform = [{{ scale = 2 }}, {{ translate = [0, 3, 0] }}]\n"
    ))
    .unwrap();
    assert_eq!(
        s.shapes[0].geometry,
        Geometry::Sphere(Sphere {
            center: Vec3::new(2.0, 3.0, 0.0),
            radius: 1.0
        })
    );
    // A rotation and a row-major matrix (translation in the last column).
    let s = parse(&format!(
        "{CAMERA}[[shapes]]\ntype = \"sphere\"\nmaterial = \"white\"\ncenter = [1, 0, 0]\n\
         transform = [{{ rotate = {{ axis = [0, 0, 1], degrees = 90 }} }},\n\
         {{ matrix = [[1, 0, 0, 5], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]] }}]\n"
    ))
    .unwrap();
    let Geometry::Sphere(Sphere { center, radius }) = s.shapes[0].geometry else {
        panic!()
    };
    assert!(
        (center - Vec3::new(5.0, 1.0, 0.0)).length() < 1e-5,
        "{center}"
    );
    assert!((radius - 1.0).abs() < 1e-6);
}

#[test]
fn a_rotated_quad_has_a_rotated_normal() {
    let quad = "vertices = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]\n";
    let n = |transform: &str| {
        let s = parse(&format!(
            "{CAMERA}[[shapes]]\ntype = \"quad\"\nmaterial = \"white\"\n{quad}{transform}"
        ))
        .unwrap();
        let Geometry::Quads(q) = &s.shapes[0].geometry else {
            panic!("not quads")
        };
        let tris = s.shapes[0].geometry.triangles();
        assert!(tris
            .iter()
            .all(|t| (normal(*t) - normal(tris[0])).length() < 1e-5));
        (normal(tris[0]), q.positions.clone())
    };
    assert!((n("").0 - Vec3::Z).length() < 1e-6);
    // +90 degrees about +x takes +z to -y.
    let (rotated, _) = n("transform = { rotate = { axis = [1, 0, 0], degrees = 90 } }\n");
    assert!((rotated - Vec3::NEG_Y).length() < 1e-5, "{rotated}");
    // A mirror keeps the face's side: the normal of a quad in the xy plane stays +z.
    let (mirrored, positions) = n("transform = { scale = [-1, 1, 1] }\n");
    assert!((mirrored - Vec3::Z).length() < 1e-5, "{mirrored}");
    assert!(positions.contains(&Vec3::new(-1.0, 1.0, 0.0)));
}

#[test]
fn mesh_normals_use_the_inverse_transpose() {
    // A triangle in the plane x + y = 1 with its normal, stretched along x.
    let s = parse(&format!(
        "{CAMERA}[[shapes]]\ntype = \"mesh\"\nmaterial = \"white\"\n\
         positions = [[1, 0, 0], [0, 1, 0], [1, 0, 1]]\nindices = [[0, 1, 2]]\n\
         normals = [[1, 1, 0], [1, 1, 0], [1, 1, 0]]\nuvs = [[0, 0], [1, 0], [0, 1]]\n\
         transform = {{ scale = [2, 1, 1] }}\n"
    ))
    .unwrap();
    let Geometry::Triangles(mesh) = &s.shapes[0].geometry else {
        panic!()
    };
    let expected = Vec3::new(0.5, 1.0, 0.0).normalize();
    let n = mesh.normals.as_ref().unwrap()[0];
    assert!((n - expected).length() < 1e-5, "{n}");
    // The shading normal agrees with the transformed geometry's normal.
    assert!((normal(mesh.triangle(0)) - expected).length() < 1e-5);
    assert_eq!(mesh.uvs.as_ref().unwrap()[1], Vec2::new(1.0, 0.0));
}

#[test]
fn a_polygon_is_fan_triangulated() {
    let s = parse(&format!(
        "{CAMERA}[[shapes]]\ntype = \"polygon\"\nmaterial = \"white\"\n\
         vertices = [[0, 0, 0], [2, 0, 0], [3, 0, -1], [2, 0, -2], [0, 0, -2]]\n"
    ))
    .unwrap();
    let tris = s.shapes[0].geometry.triangles();
    assert_eq!(tris.len(), 3);
    assert!((s.shapes[0].geometry.area() - 5.0).abs() < 1e-5);
    assert!(tris.iter().all(|t| (normal(*t) - Vec3::Y).length() < 1e-5));
}

#[test]
fn obj_scene_loads_triangles_and_mtl_colours() {
    let s = load("obj-demo.toml");
    let triangles = |name: &str| -> usize {
        s.shapes
            .iter()
            .filter(|x| s.materials[x.material].name == name)
            .map(|x| x.geometry.triangles().len())
            .sum()
    };
    // The icosahedron with the MTL's gold, the pyramid (a quad base and four sides) with
    // jade, then both again with the override material.
    assert_eq!(triangles("gold"), 20);
    assert_eq!(triangles("jade"), 6);
    assert_eq!(triangles("white"), 26);
    let gold = s
        .materials
        .iter()
        .find(|m| m.name == "gold")
        .unwrap()
        .approximation();
    assert_eq!(gold.diffuse, Texture::Constant(Vec3::new(0.75, 0.55, 0.15)));
    assert_eq!(gold.specular, Vec3::new(0.25, 0.2, 0.1));
    assert_eq!(gold.phong_exponent, 80.0);
    let jade = s
        .materials
        .iter()
        .find(|m| m.name == "jade")
        .unwrap()
        .approximation();
    assert_eq!(jade.ambient, Some(Vec3::new(0.1, 0.2, 0.15)));
    assert_eq!(jade.specular, Vec3::ZERO);
    // Each MTL material is added once.
    assert_eq!(s.materials.iter().filter(|m| m.name == "gold").count(), 1);

    // The icosahedron's faces point outwards and it rests on the floor.
    let ico = s
        .shapes
        .iter()
        .find(|x| s.materials[x.material].name == "gold")
        .unwrap();
    let tris = ico.geometry.triangles();
    let centre = tris.iter().flatten().copied().sum::<Vec3>() / (3 * tris.len()) as f32;
    for t in &tris {
        assert!(normal(*t).dot((t[0] + t[1] + t[2]) / 3.0 - centre) > 0.0);
    }
    let lowest = tris.iter().flatten().map(|p| p.y).fold(f32::MAX, f32::min);
    assert!(lowest.abs() < 1e-5);
}

#[test]
fn an_obj_with_a_missing_mtl_loads_when_the_scene_gives_a_material() {
    let s = parse(&format!(
        "{CAMERA}[[shapes]]\ntype = \"obj\"\nfile = \"meshes/missing-mtl.obj\"\n\
         material = \"white\"\n"
    ))
    .unwrap();
    assert_eq!(s.shapes.len(), 1);
    assert_eq!(s.materials[s.shapes[0].material].name, "white");
}

#[test]
fn a_missing_scene_file_is_a_one_line_error() {
    let path = root().join("tests/bad_inputs/scenes/no-such-scene.toml");
    let msg = Scene::load(&path).unwrap_err().to_string();
    assert!(
        msg.contains("no-such-scene.toml") && !msg.contains('\n'),
        "{msg}"
    );
}

/// A small deterministic generator for the mutation test.
struct Lcg(u64);

impl Lcg {
    fn below(&mut self, n: usize) -> usize {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 33) as usize) % n.max(1)
    }
}

/// Damaged scenes and meshes give errors, never panics.
#[test]
fn mutated_inputs_never_panic() {
    const PIECES: [&str; 16] = [
        "-1", "0", "nan", "inf", "1e39", "[", "]", "\"", "=", ",", "\n", "{", "}", "/", " ", "99",
    ];
    let mutate = |rng: &mut Lcg, text: &str| -> String {
        let mut s: Vec<char> = text.chars().collect();
        for _ in 0..1 + rng.below(3) {
            let at = rng.below(s.len() + 1).min(s.len());
            match rng.below(3) {
                0 if at < s.len() => {
                    let end = (at + 1 + rng.below(8)).min(s.len());
                    s.drain(at..end);
                }
                _ => {
                    let piece = PIECES[rng.below(PIECES.len())];
                    s.splice(at..at, piece.chars());
                }
            }
        }
        s.into_iter().collect()
    };
    let dir = tempfile::tempdir().unwrap();
    let scenes = root().join("scenes");
    let obj = std::fs::read_to_string(scenes.join("meshes/shapes.obj")).unwrap();
    let mtl = std::fs::read_to_string(scenes.join("meshes/shapes.mtl")).unwrap();
    std::fs::create_dir(dir.path().join("meshes")).unwrap();
    let mut rng = Lcg(7);
    let mut errors = 0;
    for name in ["cornell-box.toml", "whitted.toml", "obj-demo.toml"] {
        let text = std::fs::read_to_string(scenes.join(name)).unwrap();
        for _ in 0..300 {
            let scene = mutate(&mut rng, &text);
            let (o, m) = if name == "obj-demo.toml" {
                (mutate(&mut rng, &obj), mutate(&mut rng, &mtl))
            } else {
                (obj.clone(), mtl.clone())
            };
            std::fs::write(dir.path().join("meshes/shapes.obj"), &o).unwrap();
            std::fs::write(dir.path().join("meshes/shapes.mtl"), &m).unwrap();
            let path = dir.path().join(name);
            let result = std::panic::catch_unwind(|| raylink::scene::toml::from_str(&scene, &path));
            match result {
                Ok(Ok(_)) => {}
                Ok(Err(e)) => {
                    errors += 1;
                    let msg = e.to_string();
                    assert!(!msg.contains('\n'), "{msg}");
                }
                Err(_) => panic!("panicked on:\n{scene}\n--- obj:\n{o}\n--- mtl:\n{m}"),
            }
        }
    }
    assert!(errors > 100, "only {errors} mutations were rejected");
}

/// A nested table may be written as a `[a.b.c]` header as well as inline: both read the same
/// (toml 0.8 rejected the header form inside spanned tables with "expected a borrowed
/// string"), and errors name the line of the table's header.
#[test]
fn nested_tables_read_the_same_as_headers_or_inline() {
    let shape = "[[shapes]]\ntype = \"sphere\"\ncenter = [0, 1, 0]\nradius = 1\nmaterial = \"c\"\n";
    let camera = "[camera]\nposition = [0, 1, 5]\nlook_at = [0, 1, 0]\n";
    let inline = format!(
        "{camera}[materials.c]\ndiffuse = {{ checker = {{ even = 0.2, odd = 0.8, size = 0.5 }} }}\n{shape}"
    );
    let header = format!(
        "{camera}[materials.c.diffuse.checker]\neven = 0.2\nodd = 0.8\nsize = 0.5\n{shape}"
    );
    let (a, b) = (parse(&inline).unwrap(), parse(&header).unwrap());
    assert_eq!(a.materials, b.materials);
    let bad = header.replace("size = 0.5", "size = -1");
    let err = parse(&bad).unwrap_err().to_string();
    // The line of the header that opened the table holding the bad value.
    assert!(
        err.contains("line 4: materials.c.diffuse.checker.size"),
        "{err}"
    );
}

/// Whether a TOML file is an animation is decided on the parsed document (a top-level
/// `[animation]` table, or keyframes), not on its text: a static scene that merely mentions
/// the word (a comment, a material named `animation`) is read by the static reader, whose
/// messages give the lines of the file itself.
#[test]
fn a_static_scene_that_mentions_animation_is_read_as_static() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("still.toml");
    let text = "# No animation here, and no keyframes either.\n\
                [camera]\nposition = [0, 1, 5]\nlook_at = [0, 1, 0]\n\
                [materials.animation]\ndiffuse = 0.8\n\
                [[shapes]]\ntype = \"sphere\"\nmaterial = \"animation\"\nradius = 1\n";
    std::fs::write(&path, text).unwrap();
    let s = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.materials[0].name, "animation");
    assert_eq!(s.shapes.len(), 1);
    // Line 10 of the file (read as an animation, the file would be rewritten before reading,
    // and the message would give the line of the rewritten text).
    std::fs::write(&path, text.replace("radius = 1", "radius = -1")).unwrap();
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(
        e.ends_with("still.toml: line 10: shapes[0].radius: must be positive, got -1"),
        "{e}"
    );
}

/// Keyframes make a file an animation even without an `[animation]` table (one frame, as
/// `raylink animate` reads it): `Scene::load` gives that frame.
#[test]
fn keyframes_without_an_animation_table_give_their_first_frame() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("keyed.toml");
    let text = format!(
        "{CAMERA}[[shapes]]\ntype = \"sphere\"\nmaterial = \"white\"\n\
         [[shapes.keyframes]]\nframe = 0\ntranslate = [2, 0, 0]\n"
    );
    std::fs::write(&path, text).unwrap();
    let s = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        s.shapes[0].geometry,
        Geometry::Sphere(Sphere {
            center: Vec3::new(2.0, 0.0, 0.0),
            radius: 1.0
        })
    );
}

/// Metals: a named metal or an explicit complex index, a default ks of 1 for a metal (its
/// Fresnel does the colouring) or a tint, isotropic or anisotropic roughness; `raylink
/// convert` writes them back so that they read the same.
#[test]
fn conductors_read_named_or_explicit_with_anisotropic_roughness() {
    let text = format!(
        "{CAMERA}[materials.cu]\nconductor = \"Cu\"\nroughness = [0.1, 0.3]\n\
         [materials.custom]\nconductor = {{ eta = [1.5, 1, 0.5], k = 3 }}\nspecular = 0.5\nroughness = 0.2\n\
         diffuse = 0.25\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"cu\"\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"custom\"\n"
    );
    let s = parse(&text).unwrap_or_else(|e| panic!("{e}"));
    let m = |name: &str| {
        let m = s.materials.iter().find(|m| m.name == name).unwrap();
        m.approximation().clone()
    };
    let cu = m("cu");
    assert_eq!(cu.conductor, raylink::scene::Conductor::named("Cu"));
    assert_eq!(cu.specular, Vec3::ONE);
    // A metal has no diffuse lobe unless it is given one.
    assert_eq!(cu.diffuse, Texture::Constant(Vec3::ZERO));
    assert_eq!((cu.roughness, cu.roughness_v), (0.1, Some(0.3)));
    let custom = m("custom");
    let c = custom.conductor.unwrap();
    assert_eq!((c.eta, c.k), (Vec3::new(1.5, 1.0, 0.5), Vec3::splat(3.0)));
    assert_eq!(custom.specular, Vec3::splat(0.5));
    assert_eq!(custom.diffuse, Texture::Constant(Vec3::splat(0.25)));
    assert_eq!((custom.roughness, custom.roughness_v), (0.2, None));
    let dir = std::env::temp_dir().join(format!("raylink-conductors-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("metals.toml");
    raylink::scene::convert::write_toml(&s, &out).unwrap();
    let again = Scene::load(&out).unwrap_or_else(|e| panic!("{e}"));
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(again.materials, s.materials);
}

/// `diffuse_transmission` is a colour (one number or three) or a texture, zero by default,
/// and survives a conversion to TOML and back.
#[test]
fn diffuse_transmission_reads_and_round_trips() {
    let text = format!(
        "{CAMERA}[materials.leaf]\ndiffuse = [0.2, 0.4, 0.1]\ndiffuse_transmission = [0.3, 0.5, 0.1]\n\
         [materials.paper]\ndiffuse_transmission = 0.25\n\
         [materials.veined]\ndiffuse_transmission = {{ checker = {{ even = 0.5, odd = 0.1 }} }}\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"leaf\"\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"paper\"\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"veined\"\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"white\"\n"
    );
    let s = parse(&text).unwrap_or_else(|e| panic!("{e}"));
    let m = |name: &str| {
        let m = s.materials.iter().find(|m| m.name == name).unwrap();
        m.approximation().clone()
    };
    let constant = raylink::scene::Texture::Constant;
    assert_eq!(
        m("leaf").diffuse_transmission,
        constant(Vec3::new(0.3, 0.5, 0.1))
    );
    assert_eq!(m("paper").diffuse_transmission, constant(Vec3::splat(0.25)));
    assert_eq!(
        m("veined").diffuse_transmission,
        raylink::scene::Texture::Checker {
            even: Vec3::splat(0.5),
            odd: Vec3::splat(0.1),
            size: 1.0
        }
    );
    assert_eq!(m("white").diffuse_transmission, constant(Vec3::ZERO));
    let bad = parse(&format!(
        "{CAMERA}[materials.bad]\ndiffuse_transmission = {{ checker = {{ even = -1, odd = 0 }} }}\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"bad\"\n"
    ));
    let e = bad.unwrap_err().to_string();
    assert!(e.contains("bad.diffuse_transmission.checker.even"), "{e}");
    let bad = parse(&format!(
        "{CAMERA}[materials.bad]\ndiffuse_transmission = -1\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"bad\"\n"
    ));
    assert!(bad.is_err());
    let dir = std::env::temp_dir().join(format!("raylink-leaf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("leaf.toml");
    raylink::scene::convert::write_toml(&s, &out).unwrap();
    let again = Scene::load(&out).unwrap_or_else(|e| panic!("{e}"));
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(again.materials, s.materials);
}

/// `thin` is a boolean, false by default, refused with a roughness (a thin sheet is smooth),
/// and survives a conversion to TOML and back.
#[test]
fn thin_sheets_read_and_round_trip() {
    let text = format!(
        "{CAMERA}[materials.pane]\ndiffuse = 0\nspecular = 1\ntransmission = 1\nfresnel = true\nthin = true\nior = 1.33\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"pane\"\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"white\"\n"
    );
    let s = parse(&text).unwrap_or_else(|e| panic!("{e}"));
    let m = |name: &str| {
        let m = s.materials.iter().find(|m| m.name == name).unwrap();
        m.approximation().clone()
    };
    assert!(m("pane").thin && m("pane").fresnel && m("pane").ior == 1.33);
    assert!(!m("white").thin);
    for roughness in ["0.2", "[0, 0.1]"] {
        let bad = parse(&format!(
            "{CAMERA}[materials.bad]\nthin = true\nroughness = {roughness}\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"bad\"\n"
        ));
        let Err(e) = bad else {
            panic!("a rough thin sheet is accepted")
        };
        let e = e.to_string();
        assert!(e.contains("roughness") && e.contains("thin"), "{e}");
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pane.toml");
    raylink::scene::convert::write_toml(&s, &out).unwrap();
    let again = Scene::load(&out).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(again.materials, s.materials);
}

/// `mix = { materials = [a, b], amount }` names two materials defined before it; it takes
/// no other key, its materials must emit alike, and it survives a conversion to TOML and
/// back.
#[test]
fn mixes_read_refuse_bad_input_and_round_trip() {
    let head = format!(
        "{CAMERA}[materials.glass]\nspecular = 1\ntransmission = 1\nfresnel = true\ndiffuse = 0\n\
         [materials.lamp]\nemission = 2\n"
    );
    let shape = "[[shapes]]\ntype = \"sphere\"\nmaterial = \"both\"\n";
    let s = parse(&format!(
        "{head}[materials.both]\nmix = {{ materials = [\"white\", \"glass\"], amount = 0.25 }}\n{shape}"
    ))
    .unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = s.materials.iter().map(|m| m.name.as_str()).collect();
    let both = &s.materials[s.shapes[0].material];
    let mix = both.mix().cloned().expect("a mix");
    assert_eq!(mix.materials.map(|i| names[i]), ["white", "glass"]);
    assert_eq!(mix.amount, 0.25);
    assert_eq!(
        both.approximation().diffuse,
        s.materials[mix.materials[0]].approximation().diffuse
    );
    for (text, want) in [
        (
            "mix = { materials = [\"white\", \"nothing\"] }",
            "not a material",
        ),
        ("mix = { materials = [\"white\"] }", "two materials"),
        (
            "mix = { materials = [\"white\", \"glass\"], amount = 1.5 }",
            "[0, 1]",
        ),
        ("mix = { materials = [\"white\", \"lamp\"] }", "emit"),
        (
            "mix = { materials = [\"white\", \"glass\"] }\ndiffuse = 1",
            "no other key",
        ),
        (
            "mix = { materials = [\"white\", \"both\"] }",
            "not a material",
        ),
    ] {
        let e = match parse(&format!("{head}[materials.both]\n{text}\n{shape}")) {
            Ok(_) => panic!("{text}: accepted"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains(want), "{text}: {e}");
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("mix.toml");
    raylink::scene::convert::write_toml(&s, &out).unwrap();
    let again = Scene::load(&out).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(again.materials, s.materials);
}
