//! The output colour space: linear outputs hold the render's linear sRGB converted to the
//! colour space asked for, EXR files name its primaries, 8-bit outputs stay sRGB, and the
//! command line refuses what it cannot write.

mod common;
#[path = "common/pbrt.rs"]
mod pbrt_common;

use std::path::Path;

use glam::Vec3;
use raylink::image::output::{matrix_from_srgb, write_image, OutputOptions};
use raylink::image::Image;
use raylink::read_image;
use raylink::scene::{Scene, Texture};
use raylink::spectrum::ColorSpace;

/// A few colours: white, the sRGB primaries, a grey and a dim orange.
fn swatches() -> Image {
    let colours = [
        Vec3::ONE,
        Vec3::X,
        Vec3::Y,
        Vec3::Z,
        Vec3::splat(0.18),
        Vec3::new(0.8, 0.35, 0.05),
    ];
    let mut image = Image::new(colours.len() as u32, 1);
    for (x, c) in colours.iter().enumerate() {
        image.set(x as u32, 0, *c);
    }
    image
}

/// The chromaticities an EXR file's header records, if any.
fn exr_chromaticities(path: &Path) -> Option<[f32; 8]> {
    let meta = exr::meta::MetaData::read_from_file(path, false).unwrap();
    let c = meta.headers[0].shared_attributes.chromaticities?;
    Some([
        c.red.0, c.red.1, c.green.0, c.green.1, c.blue.0, c.blue.1, c.white.0, c.white.1,
    ])
}

/// Each colour written in every colour space reads back as the same CIE XYZ (through that
/// space's own matrix, derived from its published primaries), within 1e-5; the EXR header
/// names the primaries and white, and sRGB output leaves the header without them (readers
/// assume sRGB).
#[test]
fn linear_outputs_hold_the_same_colours_in_every_space() {
    let dir = tempfile::tempdir().unwrap();
    let image = swatches();
    let srgb = ColorSpace::srgb();
    for space in ColorSpace::all() {
        let path = dir.path().join(format!("{}.exr", space.name));
        let options = OutputOptions {
            color_space: space,
            ..OutputOptions::default()
        };
        write_image(&path, &image, &[], &options).unwrap();
        let (read, _) = read_image(&path).unwrap();
        for (written, original) in read.pixels.iter().zip(&image.pixels) {
            let xyz = space.rgb_to_xyz(written.as_dvec3());
            let expected = srgb.rgb_to_xyz(original.as_dvec3());
            assert!(
                (xyz - expected).abs().max_element() < 1e-5,
                "{}: {original} became {written}: XYZ {xyz} against {expected}",
                space.name
            );
        }
        let recorded = exr_chromaticities(&path);
        if space == srgb {
            assert_eq!(recorded, None);
        } else {
            let c = recorded.expect("chromaticities in the header");
            let [r, g, b] = space.primaries;
            let w = space.white;
            let published = [r.x, r.y, g.x, g.y, b.x, b.y, w.x, w.y];
            for (got, want) in c.iter().zip(published) {
                assert!((*got as f64 - want).abs() < 1e-6, "{}: {c:?}", space.name);
            }
        }
    }
}

/// sRGB's white written as ACES2065-1 has D65's chromaticity in ACES' own terms (no
/// chromatic adaptation, as pbrt-v4's film does by default), so its blue exceeds its red:
/// an independent check that the conversion goes through XYZ, not channel for channel.
#[test]
fn white_keeps_its_chromaticity_in_aces() {
    let aces = ColorSpace::aces2065_1();
    let white = matrix_from_srgb(aces) * Vec3::ONE;
    let xyz = aces.rgb_to_xyz(white.as_dvec3());
    let (x, y) = (xyz.x / xyz.element_sum(), xyz.y / xyz.element_sum());
    assert!(
        (x - 0.3127).abs() < 1e-4 && (y - 0.3290).abs() < 1e-4,
        "{x} {y}"
    );
    assert!((xyz.y - 1.0).abs() < 1e-5, "luminance {}", xyz.y);
    assert!(white.z > white.x, "{white}");
    // The same in a space of the same white: white stays (1, 1, 1).
    let rec = matrix_from_srgb(ColorSpace::rec2020()) * Vec3::ONE;
    assert!((rec - Vec3::ONE).abs().max_element() < 1e-5, "{rec}");
}

/// A PNG is sRGB whatever the colour space: the same bytes as with the default options.
#[test]
fn eight_bit_outputs_stay_srgb() {
    let dir = tempfile::tempdir().unwrap();
    let image = swatches();
    let a = dir.path().join("a.png");
    let b = dir.path().join("b.png");
    write_image(&a, &image, &[], &OutputOptions::default()).unwrap();
    let wide = OutputOptions {
        color_space: ColorSpace::rec2020(),
        ..OutputOptions::default()
    };
    write_image(&b, &image, &[], &wide).unwrap();
    let (pa, pb) = (read_image(&a).unwrap().0, read_image(&b).unwrap().0);
    assert_eq!(pa.pixels, pb.pixels);
}

/// The command line renders to a colour space: the EXR holds the sRGB render's colours
/// converted (the same render written twice, as sRGB and Rec.2020), and says which.
#[test]
fn the_command_line_writes_the_colour_space_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let srgb = dir.path().join("srgb.exr");
    let wide = dir.path().join("wide.exr");
    for (out, space) in [(&srgb, "srgb"), (&wide, "rec2020")] {
        let out = out.to_str().unwrap();
        let run = common::raylink(&[
            "render",
            "scenes/cornell-box.toml",
            "--spp",
            "2",
            "--width",
            "24",
            "--height",
            "24",
            "--quiet",
            "--color-space",
            space,
            "-o",
            out,
        ]);
        assert!(run.status.success(), "{}", common::stderr(&run));
    }
    let (a, _) = read_image(&srgb).unwrap();
    let (b, meta) = read_image(&wide).unwrap();
    let m = matrix_from_srgb(ColorSpace::rec2020());
    for (pa, pb) in a.pixels.iter().zip(&b.pixels) {
        let want = m * *pa;
        assert!((want - *pb).abs().max_element() <= 1e-5 * (1.0 + want.abs().max_element()));
    }
    assert!(meta.iter().any(
        |(n, v)| n == "raylink:color_space" && *v == raylink::MetaValue::Str("rec2020".into())
    ));
}

/// The diffuse colour of the material named `name`.
fn diffuse_of(scene: &Scene, name: &str) -> Vec3 {
    let m = scene.materials.iter().find(|m| m.name == name).unwrap();
    match &m.approximation().diffuse {
        Texture::Constant(c) => *c,
        t => panic!("{t:?}"),
    }
}

/// pbrt-v4's `ColorSpace`: RGB values after it are in that space (read as the same XYZ in
/// linear sRGB, within 1e-5), an emitter's (1, 1, 1) is its space's white, colours outside
/// sRGB are clipped with a warning, the space in effect at the `Film` becomes the scene's
/// output space, and an unknown name is a one-line error naming the line.
#[test]
fn pbrt_colour_spaces_are_read_as_the_same_colours() {
    let text = r#"ColorSpace "rec2020"
Film "rgb" "string filename" "x.exr"
LookAt 0 0 5  0 0 0  0 1 0
Camera "perspective" "float fov" 40
WorldBegin
MakeNamedMaterial "warm" "string type" "diffuse" "rgb reflectance" [0.6 0.4 0.2]
MakeNamedMaterial "green" "string type" "diffuse" "rgb reflectance" [0.1 0.8 0.1]
NamedMaterial "warm"
Shape "sphere" "float radius" 0.2
NamedMaterial "green"
Shape "sphere" "float radius" 0.3
ColorSpace "aces2065-1"
AttributeBegin
AreaLightSource "diffuse" "rgb L" [1 1 1]
Shape "sphere" "float radius" 0.5
AttributeEnd
ColorSpace "srgb"
MakeNamedMaterial "plain" "string type" "diffuse" "rgb reflectance" [0.6 0.4 0.2]
NamedMaterial "plain"
Shape "sphere" "float radius" 0.4
"#;
    let scene = pbrt_common::load(text);
    let rec2020 = ColorSpace::rec2020();
    assert_eq!(scene.color_space, Some(rec2020));
    let warm = diffuse_of(&scene, "warm");
    let xyz = ColorSpace::srgb().rgb_to_xyz(warm.as_dvec3());
    let want = rec2020.rgb_to_xyz(glam::DVec3::new(0.6, 0.4, 0.2));
    assert!((xyz - want).abs().max_element() < 1e-5, "{warm}");
    assert_eq!(diffuse_of(&scene, "plain"), Vec3::new(0.6, 0.4, 0.2));
    // Rec.2020's saturated green has no sRGB reflectance: clipped, and said.
    assert!(diffuse_of(&scene, "green").min_element() == 0.0);
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("outside sRGB's gamut")),
        "{:?}",
        scene.warnings
    );
    // ACES' white light: the ACES white point's chromaticity, luminance 1.
    let light = scene.materials.iter().find(|m| m.is_emissive()).unwrap();
    let xyz = ColorSpace::srgb().rgb_to_xyz(light.emission.as_dvec3());
    let (x, y) = raylink::spectrum::cie::chromaticity(xyz);
    let white = ColorSpace::aces2065_1().white;
    assert!(
        (x - white.x).abs() < 1e-4 && (y - white.y).abs() < 1e-4,
        "({x}, {y})"
    );
    assert!((xyz.y - 1.0).abs() < 1e-4);

    let dir = tempfile::tempdir().unwrap();
    let err = pbrt_common::load_in(dir.path(), "ColorSpace \"adobe\"\n", &[]).unwrap_err();
    let message = err.to_string();
    assert!(message.contains("line 1") && message.contains("\"adobe\" is not a colour space"));
}

/// A scene's colour space (`[render] color_space`) is the command line's default: the
/// EXR is in it unless `--color-space` says otherwise; a TOML scene converted keeps it.
#[test]
fn a_scene_names_its_output_colour_space() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string("scenes/cornell-box.toml")
        .unwrap()
        .replacen("[render]", "[render]\ncolor_space = \"dci-p3\"", 1);
    assert!(
        text.contains("dci-p3"),
        "the Cornell box has a [render] table"
    );
    let scene_path = dir.path().join("box.toml");
    std::fs::write(&scene_path, text).unwrap();
    let scene = Scene::load(&scene_path).unwrap();
    assert_eq!(scene.color_space, Some(ColorSpace::dci_p3()));
    let converted = dir.path().join("converted.toml");
    raylink::scene::convert::write_toml(&scene, &converted).unwrap();
    assert_eq!(
        Scene::load(&converted).unwrap().color_space,
        Some(ColorSpace::dci_p3())
    );
    for (name, extra) in [("scene.exr", None), ("srgb.exr", Some("srgb"))] {
        let out = dir.path().join(name);
        let mut args = vec![
            "render",
            scene_path.to_str().unwrap(),
            "--spp",
            "1",
            "--width",
            "8",
            "--height",
            "8",
            "-q",
            "-o",
            out.to_str().unwrap(),
        ];
        if let Some(space) = extra {
            args.extend(["--color-space", space]);
        }
        let run = common::raylink(&args);
        assert!(run.status.success(), "{}", common::stderr(&run));
        let recorded = exr_chromaticities(&out);
        match extra {
            None => assert_eq!(recorded.map(|c| c[0]), Some(0.68)),
            Some(_) => assert_eq!(recorded, None),
        }
    }
}
