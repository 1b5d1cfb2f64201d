//! `raylink convert`: pbrt-v4 scenes (Bitterli's box, textures, environments, settings) and
//! every example scene written as TOML and read back the same.

use raylink::image::Image;
use raylink::math::Rgb;
use raylink::scene::{Classic, Coating, Geometry, Material, NormalDetail, Scene, Surface, Texture};
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[path = "common/pbrt.rs"]
mod pbrt_common;
use pbrt_common::*;

/// A material in the terms raylink's scenes had before materials had kinds, all of which a
/// conversion keeps: its name, classic terms, emission, normal detail, table, coat and mix.
/// (`convert` writes every kind but the coated, measured and mixed ones as its classic
/// terms, which read back as a classic material of the same lobes.)
#[derive(Debug, PartialEq)]
struct Terms<'a, T> {
    name: &'a str,
    classic: Classic,
    emission: Rgb,
    emission_map: &'a Option<Texture>,
    two_sided_emission: bool,
    normal_detail: &'a Option<NormalDetail>,
    table: Option<&'a T>,
    coating: Option<Coating>,
    mix: Option<([usize; 2], f32, Option<Arc<Texture>>)>,
}

fn terms(m: &Material) -> Terms<'_, impl PartialEq + std::fmt::Debug> {
    Terms {
        name: &m.name,
        classic: m.approximation().clone(),
        emission: m.emission,
        emission_map: &m.emission_map,
        two_sided_emission: m.two_sided_emission,
        normal_detail: &m.normal_detail,
        table: m.model().table(),
        coating: match &m.surface {
            Surface::CoatedDiffuse(c) => Some(*c.coating()),
            Surface::CoatedConductor(c) => Some(*c.coating()),
            _ => None,
        },
        mix: m
            .mix()
            .map(|x| (x.materials, x.amount, x.amount_map.clone())),
    }
}

/// [`terms`] of each of `materials`.
fn all_terms(materials: &[Material]) -> Vec<Terms<'_, impl PartialEq + std::fmt::Debug>> {
    materials.iter().map(terms).collect()
}

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
    assert_eq!(all_terms(&back.materials), all_terms(&original.materials));
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
    for (a, b) in back.materials.iter().zip(&s.materials) {
        match (&a.approximation().diffuse, &b.approximation().diffuse) {
            (Texture::Image(x), Texture::Image(y)) => {
                assert_eq!(x.file, Path::new("../t.png"));
                assert_eq!(
                    (x.image(), x.encoding, x.scale, x.mapping),
                    (y.image(), y.encoding, y.scale, y.mapping)
                );
                let mut a = terms(a);
                a.classic.diffuse = b.approximation().diffuse.clone();
                assert_eq!(a, terms(b));
            }
            _ => assert_eq!(terms(a), terms(b)),
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
        back.materials[0].approximation().diffuse,
        raylink::scene::Texture::UvChecker { .. }
    ));
    assert!(matches!(
        back.materials[1].approximation().diffuse,
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
        assert_eq!(
            all_terms(&back.materials),
            all_terms(&original.materials),
            "{name}"
        );
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
