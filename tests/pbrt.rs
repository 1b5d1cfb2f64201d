//! The pbrt-v4 reader end to end: Bitterli's Cornell box against the same scene written in
//! TOML, statements and transforms on small scenes, PLY in every encoding, and the bad-input
//! corpus in tests/bad_inputs/pbrt.

use raylink::image::Image;
use raylink::math::{Rgb, Vec3};
use raylink::scene::{Geometry, Light, Scene};
use raylink::{Backend, Control, Job, Renderer, Settings, Technique, TechniqueKind};
use std::path::{Path, PathBuf};

#[allow(dead_code)]
fn _unused(_: &Path, _: &Geometry) {}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn bitterli() -> PathBuf {
    root().join("scenes/cornell-box-bitterli/scene-v4.pbrt")
}

/// Whitted with its defaults and uniform 2x2 supersampling, at `size`x`size`.
fn whitted_render(scene: &Scene, size: u32) -> Image {
    let technique = Technique::create(&Settings {
        integrator: Some(TechniqueKind::Whitted),
        spp: Some(4),
        ..Settings::default()
    })
    .unwrap();
    let job = Job {
        width: size,
        height: size,
        region: None,
        seed: 7,
        threads: Some(2),
        accel: Backend::Embree,
        ..Job::new(scene, technique)
    };
    let control = Control::default();
    Renderer::new(scene.clone(), job, &control)
        .unwrap()
        .render(&control)
        .unwrap()
        .image
}

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

/// A camera whose image is not mirrored with respect to raylink's (pbrt's `Scale -1 1 1`
/// idiom), so the world is not mirrored either.
const HEADER: &str = "Scale -1 1 1\nLookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\nWorldBegin\n";
const TRI: &str =
    "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" [0 1 2]\n";

/// Loads pbrt text written to a file `main.pbrt` in `dir` (with `files` beside it).
fn load_in(dir: &Path, text: &str, files: &[(&str, &[u8])]) -> raylink::Result<Scene> {
    for (name, data) in files {
        let p = dir.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, data).unwrap();
    }
    let main = dir.join("main.pbrt");
    std::fs::write(&main, text).unwrap();
    Scene::load(&main)
}

fn load(text: &str) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    load_in(dir.path(), text, &[]).unwrap_or_else(|e| panic!("{e}"))
}

fn world(body: &str) -> Scene {
    load(&format!("{HEADER}{body}"))
}

/// The vertices of the scene's first triangle, in world space.
fn first_triangle(s: &Scene) -> [Vec3; 3] {
    s.shapes[0].geometry.triangles()[0]
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
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
    // ActiveTransform EndTime: transforms for the end of the shutter are ignored.
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
            Geometry::Sphere {
                center: Vec3::ZERO,
                radius: 2.0
            }
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
        Geometry::Sphere {
            center: Vec3::new(1.0, 2.0, 3.0),
            radius: 1.0
        }
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
    // Instances are world-space copies under each instance's transform.
    let s = world(&format!(
        "ObjectBegin \"tri\" Translate 0 0 1 {TRI} ObjectEnd\n\
         AttributeBegin Translate 10 0 0 ObjectInstance \"tri\" AttributeEnd\n\
         ObjectInstance \"tri\"\n"
    ));
    assert_eq!(s.shapes.len(), 2);
    assert!(close(first_triangle(&s)[0], Vec3::new(10.0, 0.0, 1.0)));
    assert!(close(
        s.shapes[1].geometry.triangles()[0][0],
        Vec3::new(0.0, 0.0, 1.0)
    ));
    // loopsubdiv: the base mesh, with a warning naming the line.
    let s = world("Shape \"loopsubdiv\" \"integer levels\" 3 \"point3 P\" [0 0 0 1 0 0 0 1 0]\n");
    assert_eq!(s.shapes.len(), 1);
    assert!(
        s.warnings[0].ends_with(
            ":5: Shape \"loopsubdiv\" is not supported; using its base mesh without subdivision"
        ),
        "{:?}",
        s.warnings
    );
}

#[test]
fn materials_map_to_raylink_fields() {
    let s = world(&format!(
        "Material \"conductor\" {TRI}\
         Material \"conductor\" \"spectrum eta\" \"metal-Au-eta\" \"spectrum k\" \"metal-Au-k\" \"float roughness\" 0.25 {TRI}\
         Material \"dielectric\" \"float eta\" 1.33 {TRI}\
         Material \"coateddiffuse\" \"rgb reflectance\" [0.2 0.3 0.4] \"float roughness\" 0.04 \"bool remaproughness\" false {TRI}\
         Material \"diffuse\" {TRI}\
         MakeNamedMaterial \"m\" \"string type\" \"diffuse\" \"rgb reflectance\" [0.1 0.2 0.3]\n\
         NamedMaterial \"m\" {TRI}"
    ));
    let m = &s.materials;
    assert_eq!(m.len(), 6);
    // Copper (pbrt's default conductor) with its complex Fresnel: reddish at normal
    // incidence.
    let cu = m[0].specular_at_normal();
    assert!(cu.x > 0.9 && cu.z < 0.6, "{cu}");
    assert_eq!(m[0].conductor, raylink::scene::Conductor::named("Cu"));
    assert_eq!(m[0].diffuse, raylink::scene::Texture::Constant(Rgb::ZERO));
    assert!(!m[0].fresnel);
    // Gold, roughness remapped to alpha = sqrt(0.25).
    assert_eq!(m[1].conductor, raylink::scene::Conductor::named("Au"));
    assert!((m[1].roughness - 0.5).abs() < 1e-6 && m[1].roughness_v.is_none());
    assert_eq!(
        (m[2].specular, m[2].transmission, m[2].ior, m[2].fresnel),
        (Rgb::ONE, Rgb::ONE, 1.33, true)
    );
    assert_eq!(
        m[3].diffuse,
        raylink::scene::Texture::Constant(Rgb::new(0.2, 0.3, 0.4))
    );
    assert!((m[3].roughness - 0.04).abs() < 1e-6 && m[3].fresnel && m[3].specular == Rgb::ONE);
    assert_eq!(
        m[4].diffuse,
        raylink::scene::Texture::Constant(Rgb::splat(0.5))
    );
    assert_eq!(m[5].name, "m");
    // Anisotropic conductors keep α_x and α_y; `reflectance` gives the index with that
    // normal-incidence reflectance (pbrt-v4: η = 1, k = 2√r/√(1−r)).
    let s = world(&format!(
        "Material \"conductor\" \"float uroughness\" 0.04 \"float vroughness\" 0.16 {TRI}\
         Material \"conductor\" \"rgb reflectance\" [0.9 0.5 0.2] \"float roughness\" 0.3 \"bool remaproughness\" false {TRI}"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let m = &s.materials;
    assert!((m[0].roughness - 0.2).abs() < 1e-6);
    assert!((m[0].roughness_v.unwrap() - 0.4).abs() < 1e-6);
    let r = m[1].specular_at_normal();
    assert!(
        (r - Rgb::new(0.9, 0.5, 0.2)).abs().max_element() < 1e-4,
        "{r}"
    );
    assert!((m[1].roughness - 0.3).abs() < 1e-6);
    // A rough dielectric is glass with GGX reflection and refraction, without a warning:
    // isotropic, or anisotropic (u along the tangent, v along the bitangent), remapped
    // unless `remaproughness` is false.
    let s = world(&format!(
        "Material \"dielectric\" \"float roughness\" 0.09 {TRI}\
         Material \"dielectric\" \"float uroughness\" 0.04 \"float vroughness\" 0.25 {TRI}\
         Material \"dielectric\" \"float roughness\" 0.2 \"bool remaproughness\" false {TRI}"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let m = &s.materials;
    for g in m {
        assert_eq!(
            (g.specular, g.transmission, g.ior, g.fresnel),
            (Rgb::ONE, Rgb::ONE, 1.5, true)
        );
    }
    assert!((m[0].roughness - 0.3).abs() < 1e-6 && m[0].roughness_v.is_none());
    assert!((m[1].roughness - 0.2).abs() < 1e-6);
    assert!((m[1].roughness_v.unwrap() - 0.5).abs() < 1e-6);
    assert!((m[2].roughness - 0.2).abs() < 1e-6 && m[2].roughness_v.is_none());
    // Diffuse transmission: reflectance and transmittance (0.25 each by default) times
    // `scale`, without a warning.
    let s = world(&format!(
        "Material \"diffusetransmission\" {TRI}\
         Material \"diffusetransmission\" \"rgb reflectance\" [0.2 0.4 0.1] \"rgb transmittance\" [0.3 0.5 0.1] \"float scale\" 2 {TRI}"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let m = &s.materials;
    assert_eq!(
        m[0].diffuse,
        raylink::scene::Texture::Constant(Rgb::splat(0.25))
    );
    assert_eq!(
        m[0].diffuse_transmission,
        raylink::scene::Texture::Constant(Rgb::splat(0.25))
    );
    assert_eq!(
        m[1].diffuse,
        raylink::scene::Texture::Constant(Rgb::new(0.4, 0.8, 0.2))
    );
    assert_eq!(
        m[1].diffuse_transmission,
        raylink::scene::Texture::Constant(Rgb::new(0.6, 1.0, 0.2))
    );
    assert_eq!((m[1].specular, m[1].transmission), (Rgb::ZERO, Rgb::ZERO));
    // A textured transmittance stays a texture (a leaf's veins), without a warning.
    let s = world(&format!(
        "Texture \"c\" \"spectrum\" \"checkerboard\" \"rgb tex1\" [0.5 0.5 0.5] \"rgb tex2\" [0.1 0.2 0.3]\n\
         Material \"diffusetransmission\" \"texture transmittance\" \"c\" {TRI}"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let t = &s.materials[0].diffuse_transmission;
    assert!(
        matches!(t, raylink::scene::Texture::UvChecker { .. }),
        "{t:?}"
    );
    // A thin dielectric is a thin sheet of index `eta` (1.5), without a warning.
    let s = world(&format!(
        "Material \"thindielectric\" {TRI}\
         Material \"thindielectric\" \"float eta\" 1.33 {TRI}"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let m = &s.materials;
    for (g, eta) in m.iter().zip([1.5, 1.33]) {
        assert_eq!(
            (g.specular, g.transmission, g.ior, g.fresnel, g.thin),
            (Rgb::ONE, Rgb::ONE, eta, true, true)
        );
        assert_eq!((g.roughness, g.roughness_v), (0.0, None));
    }
    assert!(!world(&format!("Material \"dielectric\" {TRI}")).materials[0].thin);
    // Unsupported material types: a warning and a substitute.
    let s = world(&format!("Material \"hair\" \"float eumelanin\" 1.3 {TRI}"));
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].contains(":5: material \"hair\" is not supported"));
}

#[test]
fn lights_and_environment() {
    let s = world(&format!(
        "AttributeBegin Translate 0 1 0 LightSource \"point\" \"rgb I\" [1 2 3] \"float scale\" 2 \"point3 from\" [1 0 0] AttributeEnd\n\
         LightSource \"distant\" \"point3 from\" [0 0 0] \"point3 to\" [0 -1 0] \"blackbody L\" 6500\n\
         LightSource \"infinite\" \"rgb L\" [0.1 0.2 0.3]\n{TRI}"
    ));
    assert_eq!(
        s.lights[0],
        raylink::scene::Light::Point {
            position: Vec3::new(1.0, 1.0, 0.0),
            intensity: Rgb::new(2.0, 4.0, 6.0)
        }
    );
    let raylink::scene::Light::Directional {
        direction,
        irradiance,
    } = s.lights[1]
    else {
        panic!()
    };
    assert!(close(direction, Vec3::NEG_Y));
    assert!((raylink::math::luminance(irradiance) - 1.0).abs() < 0.03);
    assert_eq!(s.background, Rgb::new(0.1, 0.2, 0.3));

    // An equal-area environment map: the texel of +z (the centre) is read back for +z.
    let dir = tempfile::tempdir().unwrap();
    let mut image = Image::new(8, 8);
    for p in &mut image.pixels {
        *p = Rgb::splat(0.25);
    }
    image.set(4, 4, Rgb::new(4.0, 5.0, 6.0));
    raylink::image::output::write_image(
        &dir.path().join("sky.exr"),
        &image,
        &[],
        &Default::default(),
    )
    .unwrap();
    let s = load_in(
        dir.path(),
        &format!("{HEADER}LightSource \"infinite\" \"string filename\" \"sky.exr\" \"float scale\" 2\n{TRI}"),
        &[],
    )
    .unwrap();
    let env = s.environment.as_ref().expect("environment map");
    assert_eq!(env.eval(Vec3::Z), Rgb::new(8.0, 10.0, 12.0));
    assert_eq!(env.eval(Vec3::X), Rgb::splat(0.5));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);

    // A 2:1 lat-long map (an extension: pbrt-v4 needs `imgtool makeequiarea`) is converted,
    // with a warning, in makeequiarea's orientation: texel (12, 3) of 32x16 is φ = 140.6°
    // from +x towards +y, θ = 36.6° from +z.
    let mut image = Image::new(32, 16);
    image.pixels.fill(Rgb::splat(0.25));
    image.set(12, 3, Rgb::splat(1000.0));
    raylink::image::output::write_image(
        &dir.path().join("latlong.exr"),
        &image,
        &[],
        &Default::default(),
    )
    .unwrap();
    let s = load_in(
        dir.path(),
        &format!("{HEADER}LightSource \"infinite\" \"string filename\" \"latlong.exr\"\n{TRI}"),
        &[],
    )
    .unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(
        s.warnings[0].contains("\"latlong.exr\" is a lat-long image"),
        "{:?}",
        s.warnings
    );
    let env = s.environment.as_ref().expect("environment map");
    assert_eq!((env.image.width, env.image.height), (32, 32));
    let (theta, phi) = (
        std::f32::consts::PI * 3.5 / 16.0,
        std::f32::consts::TAU * 12.5 / 32.0,
    );
    let d = Vec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    );
    assert!(env.eval(d).x > 100.0, "{}", env.eval(d));
    assert!(env.eval(Vec3::new(d.x, -d.y, d.z)).x < 0.3);
    // `convert` names the lat-long file, which reads back to the same converted map.
    let out = dir.path().join("latlong.toml");
    raylink::scene::convert::write_toml(&s, &out).unwrap();
    let back = Scene::load(&out).unwrap_or_else(|e| panic!("{e}"));
    let x = back.environment.as_ref().unwrap();
    assert_eq!(x.file, Path::new("latlong.exr"));
    assert_eq!(
        (&x.image, x.transform, x.scale),
        (&env.image, env.transform, env.scale)
    );
}

#[test]
fn textures_checkerboard_and_imagemap() {
    let dir = tempfile::tempdir().unwrap();
    // 2x1 sRGB PNG: left texel mid-grey (sRGB 0.5 -> linear 0.214), right white.
    let mut image = Image::new(2, 1);
    image.set(
        0,
        0,
        Rgb::splat(raylink::image::output::srgb_decode(128.0 / 255.0)),
    );
    image.set(1, 0, Rgb::ONE);
    raylink::image::output::write_image(
        &dir.path().join("t.png"),
        &image,
        &[],
        &Default::default(),
    )
    .unwrap();
    let s = load_in(
        dir.path(),
        &format!(
            "{HEADER}Texture \"c\" \"spectrum\" \"checkerboard\" \"float uscale\" 4 \"float vscale\" 4 \
             \"rgb tex1\" [1 0 0] \"rgb tex2\" [0 0 1]\n\
             Texture \"img\" \"spectrum\" \"imagemap\" \"string filename\" \"t.png\"\n\
             Material \"diffuse\" \"texture reflectance\" \"c\" {TRI}\
             Material \"diffuse\" \"texture reflectance\" \"img\" {TRI}"
        ),
        &[],
    )
    .unwrap();
    let uv = raylink::math::Vec2::new;
    let checker = &s.materials[0].diffuse;
    assert_eq!(checker.eval(Vec3::ZERO, uv(0.1, 0.1)), Rgb::X);
    assert_eq!(checker.eval(Vec3::ZERO, uv(0.3, 0.1)), Rgb::Z);
    let img = &s.materials[1].diffuse;
    let left = img.eval(Vec3::ZERO, uv(0.25, 0.5));
    assert!(
        (left.x - raylink::image::output::srgb_decode(128.0 / 255.0)).abs() < 1e-3,
        "{left}"
    );
    assert!((img.eval(Vec3::ZERO, uv(0.75, 0.5)).x - 1.0).abs() < 1e-3);
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

/// Converting Bitterli's pbrt file and reading the TOML back gives the same scene (meshes
/// round-trip exactly through binary PLY) and the same Whitted image.
#[test]
fn converted_bitterli_box_is_the_same_scene() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("box.toml");
    let original = raylink::scene::convert::convert(&bitterli(), &out).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("type = \"ply\"") && !text.contains("positions"),
        "meshes are referenced"
    );
    assert_eq!(
        std::fs::read_dir(dir.path().join("box.meshes"))
            .unwrap()
            .count(),
        8
    );
    let back = Scene::load(&out).unwrap();
    assert_eq!(back.camera, original.camera);
    assert_eq!(back.materials, original.materials);
    // Equal up to float round-trip: positions, indices and uvs exactly; normals are
    // renormalised by the TOML reader (a last-bit difference).
    assert_eq!(back.shapes.len(), original.shapes.len());
    for (x, y) in back.shapes.iter().zip(&original.shapes) {
        assert_eq!(x.material, y.material);
        match (&x.geometry, &y.geometry) {
            (Geometry::Triangles(a), Geometry::Triangles(b)) => {
                assert_eq!(
                    (&a.positions, &a.indices, &a.uvs),
                    (&b.positions, &b.indices, &b.uvs)
                );
                let (na, nb) = (a.normals.as_ref().unwrap(), b.normals.as_ref().unwrap());
                assert!(na.iter().zip(nb).all(|(p, q)| (*p - *q).length() < 1e-6));
            }
            (a, b) => assert_eq!(a, b),
        }
    }
    assert_eq!(back.lights, original.lights);
    assert_eq!(
        (back.ambient, back.background),
        (original.ambient, original.background)
    );
    assert_eq!(back.settings, original.settings);
    // The last-bit normal differences may move a shadow ray's fate; the images agree to
    // well within a thousandth.
    let (a, b) = (whitted_render(&back, 64), whitted_render(&original, 64));
    let rmse = a.rmse(&b);
    eprintln!("converted vs original Whitted RMSE {rmse}");
    assert!(rmse < 1e-4, "converted vs original Whitted RMSE {rmse}");
    // Converting again over the same files works and changes nothing.
    raylink::scene::convert::convert(&bitterli(), &out).unwrap();
    assert_eq!(std::fs::read_to_string(&out).unwrap(), text);
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
}

/// Textures and environment maps survive `convert`: the TOML's uv_checker, image and
/// environment tables read back to the same values; warnings come once per kind.
#[test]
fn converted_textures_environment_and_settings_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let mut sky = Image::new(4, 4);
    sky.set(1, 2, Rgb::new(3.0, 2.0, 1.0));
    raylink::image::output::write_image(
        &dir.path().join("sky.exr"),
        &sky,
        &[],
        &Default::default(),
    )
    .unwrap();
    let mut tex = Image::new(2, 2);
    tex.set(1, 1, Rgb::ONE);
    raylink::image::output::write_image(&dir.path().join("t.png"), &tex, &[], &Default::default())
        .unwrap();
    let s = load_in(
        dir.path(),
        &format!(
            "Sampler \"halton\" \"integer pixelsamples\" 16\nPixelFilter \"gaussian\" \"float xradius\" 2 \"float sigma\" 0.7\n\
             Integrator \"bdpt\" \"integer maxdepth\" 7\n{HEADER}\
             AttributeBegin Rotate 90 1 0 0 LightSource \"infinite\" \"string filename\" \"sky.exr\" AttributeEnd\n\
             Texture \"c\" \"spectrum\" \"checkerboard\" \"float uscale\" 3 \"rgb tex1\" [1 0 0]\n\
             Texture \"i\" \"spectrum\" \"imagemap\" \"string filename\" \"t.png\" \"float vscale\" 2\n\
             Material \"diffuse\" \"texture reflectance\" \"c\" {TRI}\
             Material \"coateddiffuse\" \"texture reflectance\" \"i\" \"float roughness\" 0.1 {TRI}\
             Shape \"curve\" \"point3 P\" [0 0 0 1 1 1 2 2 2 3 3 3]\nShape \"curve\" \"point3 P\" [0 0 0 1 1 1 2 2 2 3 3 3]\n"
        ),
        &[],
    )
    .unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert_eq!(s.settings.integrator, Some(raylink::TechniqueKind::Bdpt));
    assert_eq!((s.settings.spp, s.settings.max_depth), (Some(16), Some(7)));
    let out = dir.path().join("out/scene.toml");
    std::fs::create_dir(dir.path().join("out")).unwrap();
    raylink::scene::convert::write_toml(&s, &out).unwrap();
    let back = Scene::load(&out).unwrap_or_else(|e| panic!("{e}"));
    // Files are named relative to each scene file (`t.png` from the pbrt file, `../t.png`
    // from out/scene.toml); everything else is equal.
    use raylink::scene::Texture;
    for (a, b) in back.materials.iter().zip(&s.materials) {
        match (&a.diffuse, &b.diffuse) {
            (Texture::Image(x), Texture::Image(y)) => {
                assert_eq!(x.file, Path::new("../t.png"));
                assert_eq!(
                    (x.image(), x.encoding, x.scale, x.mapping),
                    (y.image(), y.encoding, y.scale, y.mapping)
                );
                let mut a = a.clone();
                a.diffuse = b.diffuse.clone();
                assert_eq!(&a, b);
            }
            _ => assert_eq!(a, b),
        }
    }
    let (x, y) = (
        back.environment.as_ref().unwrap(),
        s.environment.as_ref().unwrap(),
    );
    assert_eq!(x.file, Path::new("../sky.exr"));
    assert_eq!(
        (&x.image, x.transform, x.scale),
        (&y.image, y.transform, y.scale)
    );
    assert_eq!(back.settings, s.settings);
    assert!(matches!(
        back.materials[0].diffuse,
        raylink::scene::Texture::UvChecker { .. }
    ));
    assert!(matches!(
        back.materials[1].diffuse,
        raylink::scene::Texture::Image(_)
    ));
}

/// Every example scene in scenes/ (TOML, the animations' first frames, and pbrt) converts
/// to a TOML scene that reads back to the same scene, field by field: spheres, positions,
/// indices and uvs exactly (floats are written as the shortest decimals that read back to
/// the same bits), normals up to the reader's renormalisation; and gives the same Whitted
/// image.
#[test]
fn every_example_scene_converts_and_reads_back_the_same() {
    let dir = tempfile::tempdir().unwrap();
    let mut files: Vec<PathBuf> = std::fs::read_dir(root().join("scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml" || e == "pbrt"))
        .collect();
    files.sort();
    assert!(files.len() >= 10, "{files:?}");
    for path in files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let out = dir.path().join(format!("{name}.toml"));
        let original =
            raylink::scene::convert::convert(&path, &out).unwrap_or_else(|e| panic!("{name}: {e}"));
        let back = Scene::load(&out).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(back.camera, original.camera, "{name}");
        assert_eq!(back.materials, original.materials, "{name}");
        assert_eq!(back.lights, original.lights, "{name}");
        assert_eq!(
            (back.ambient, back.background, &back.settings),
            (original.ambient, original.background, &original.settings),
            "{name}"
        );
        match (&back.environment, &original.environment) {
            (Some(x), Some(y)) => assert_eq!(
                (&x.image, x.transform, x.scale),
                (&y.image, y.transform, y.scale),
                "{name}"
            ),
            (x, y) => assert_eq!(x.is_none(), y.is_none(), "{name}"),
        }
        assert_eq!(back.shapes.len(), original.shapes.len(), "{name}");
        for (i, (x, y)) in back.shapes.iter().zip(&original.shapes).enumerate() {
            assert_eq!(x.material, y.material, "{name}: shape {i}");
            match (&x.geometry, &y.geometry) {
                (Geometry::Triangles(a), Geometry::Triangles(b)) => {
                    assert_eq!(
                        (&a.positions, &a.indices, &a.uvs),
                        (&b.positions, &b.indices, &b.uvs),
                        "{name}: shape {i}"
                    );
                    assert_eq!(
                        a.normals.is_some(),
                        b.normals.is_some(),
                        "{name}: shape {i}"
                    );
                    let (na, nb) = (a.normals.iter().flatten(), b.normals.iter().flatten());
                    assert!(
                        na.zip(nb).all(|(p, q)| (*p - *q).length() < 1e-6),
                        "{name}: shape {i}"
                    );
                }
                (a, b) => assert_eq!(a, b, "{name}: shape {i}"),
            }
        }
        let (a, b) = (whitted_render(&back, 16), whitted_render(&original, 16));
        let rmse = a.rmse(&b);
        assert!(
            rmse < 1e-4,
            "{name}: converted vs original Whitted RMSE {rmse}"
        );
    }
}

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

/// Spot lights as pbrt-v4 defines them (`from`, `to`, `coneangle` 30, `conedelta` 5, `I`,
/// `scale`, `power` = I·k_e with k_e = 2π((1 − cos start) + (cos start − cos end)/2)), and
/// two-sided diffuse area lights, both without warnings.
#[test]
fn spot_lights_and_two_sided_area_lights() {
    let s = world(&format!(
        "LightSource \"spot\" \"point3 from\" [0 2 0] \"point3 to\" [0 0 0] \"rgb I\" [1 2 3] \"float scale\" 2\n\
         LightSource \"spot\" \"float coneangle\" 40 \"float conedelta\" 10 \"float power\" 100\n\
         AttributeBegin AreaLightSource \"diffuse\" \"bool twosided\" true {TRI} AttributeEnd\n"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let Light::Spot {
        position,
        direction,
        intensity,
        cone_angle,
        cone_delta,
    } = s.lights[0]
    else {
        panic!("{:?}", s.lights[0])
    };
    // The header's `Scale -1 1 1` mirrors nothing on the y axis.
    assert!(close(position, Vec3::new(0.0, 2.0, 0.0)), "{position}");
    assert!(close(direction, Vec3::new(0.0, -1.0, 0.0)), "{direction}");
    assert_eq!(
        (intensity, cone_angle, cone_delta),
        (Rgb::new(2.0, 4.0, 6.0), 30.0, 5.0)
    );
    let Light::Spot { intensity, .. } = s.lights[1] else {
        panic!("{:?}", s.lights[1])
    };
    let (cs, ce) = (30f64.to_radians().cos(), 40f64.to_radians().cos());
    let k_e = std::f64::consts::TAU * ((1.0 - cs) + (cs - ce) / 2.0);
    assert!(
        (intensity.x as f64 - 100.0 / k_e).abs() < 1e-4,
        "{intensity}"
    );
    let emitter = s.materials.iter().find(|m| m.is_emissive()).unwrap();
    assert!(emitter.two_sided_emission);
}

/// `mix` chooses its second material with probability `amount` at each hit: read without a
/// warning as a mix of the two named materials, which are kept (before it) even when no
/// shape uses them; under an area light, both its materials emit.
#[test]
fn mix_materials_keep_both_materials() {
    let named = "MakeNamedMaterial \"white\" \"string type\" \"diffuse\" \"rgb reflectance\" [1 1 1]\n\
                 MakeNamedMaterial \"glass\" \"string type\" \"dielectric\"\n\
                 MakeNamedMaterial \"both\" \"string type\" \"mix\" \"string materials\" [\"white\" \"glass\"] \"float amount\" 0.3\n";
    let s = world(&format!("{named}NamedMaterial \"both\"\n{TRI}"));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let i = s.shapes[0].material;
    let mix = s.materials[i].mix.expect("a mix");
    assert!((mix.amount - 0.3).abs() < 1e-6);
    let [a, b] = mix.materials;
    assert!(a < i && b < i, "the mixed materials come before the mix");
    assert_eq!(
        s.materials[a].diffuse,
        raylink::scene::Texture::Constant(Rgb::ONE)
    );
    assert!(s.materials[b].fresnel && s.materials[b].transmission == Rgb::ONE);
    // The mix's own fields are those of the material with the larger weight.
    assert_eq!(s.materials[i].diffuse, s.materials[a].diffuse);
    // Under an area light both mixed materials emit, as the mix does.
    let s = world(&format!(
        "{named}AttributeBegin AreaLightSource \"diffuse\" \"rgb L\" [2 2 2]\nNamedMaterial \"both\"\n{TRI}AttributeEnd\n"
    ));
    let m = &s.materials[s.shapes[0].material];
    assert_eq!(m.emission, Rgb::splat(2.0));
    for j in m.mix.unwrap().materials {
        assert_eq!(s.materials[j].emission, Rgb::splat(2.0));
        assert!(s.materials[j].mix.is_none());
    }
    // Two names are needed.
    let dir = tempfile::tempdir().unwrap();
    let bad = load_in(
        dir.path(),
        &format!("{HEADER}{named}MakeNamedMaterial \"x\" \"string type\" \"mix\" \"string materials\" [\"white\"]\nNamedMaterial \"x\"\n{TRI}"),
        &[],
    );
    assert!(bad.is_err());
}
