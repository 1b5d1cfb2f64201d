//! Textures everywhere in pbrt-v4 scenes: float textures (roughness, mix amounts, bump
//! displacement), `mix`, `directionmix` and `scale` textures, and normal maps; what each
//! becomes, its values against pbrt-v4's definitions, and its way through `raylink convert`.

use raylink::image::Image;
use raylink::math::{Rgb, Vec2, Vec3};
use raylink::scene::{NormalDetail, Scene, Texture};
use std::path::Path;

#[path = "common/pbrt.rs"]
mod pbrt_common;
use pbrt_common::*;

const RED: Rgb = Rgb::new(1.0, 0.0, 0.0);
const BLUE: Rgb = Rgb::new(0.0, 0.0, 1.0);

fn close(a: Rgb, b: Rgb) -> bool {
    (a - b).abs().max_element() < 1e-6
}

/// A float checkerboard varies a conductor's and a dielectric's roughness: α = √r per
/// cell (pbrt-v4's remapping), both cells' values reach the BSDF's α, and nothing warns.
#[test]
fn a_float_texture_varies_roughness() {
    let s = world(&format!(
        "Texture \"r\" \"float\" \"checkerboard\" \"float uscale\" 2 \"float vscale\" 2 \
         \"float tex1\" 0.04 \"float tex2\" 0.25\n\
         Material \"conductor\" \"texture roughness\" \"r\" {TRI}\
         Material \"dielectric\" \"texture uroughness\" \"r\" \"float vroughness\" 0.09 {TRI}\
         Material \"conductor\" \"texture roughness\" \"r\" \"bool remaproughness\" false {TRI}"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let at = |m: usize, u: f32, v: f32| {
        let map = s.materials[m]
            .approximation()
            .roughness_map
            .as_ref()
            .expect("a roughness map");
        map.alphas(Vec3::ZERO, Vec2::new(u, v), Vec3::Z)
    };
    let near = |(a, b): (f32, f32), (c, d): (f32, f32)| (a - c).abs() + (b - d).abs() < 1e-6;
    assert!(near(at(0, 0.1, 0.1), (0.2, 0.2)), "{:?}", at(0, 0.1, 0.1));
    assert!(near(at(0, 0.6, 0.1), (0.5, 0.5)));
    assert!(near(at(1, 0.1, 0.1), (0.2, 0.3)), "{:?}", at(1, 0.1, 0.1));
    assert!(near(at(1, 0.6, 0.1), (0.5, 0.3)));
    assert!(near(at(2, 0.6, 0.1), (0.25, 0.25)));
    // The techniques that take one roughness see the largest.
    assert!((s.materials[0].approximation().roughness - 0.5).abs() < 1e-6);
}

/// `mix`, `directionmix` and `scale` as pbrt-v4 defines them: (1 − amount)·tex1 +
/// amount·tex2; |n·dir|·tex1 + (1 − |n·dir|)·tex2 with `dir` in the texture's space; tex ×
/// scale, for spectrum and float textures.
#[test]
fn mix_direction_mix_and_scale_textures() {
    let s = world(&format!(
        "Texture \"a\" \"spectrum\" \"constant\" \"rgb value\" [1 0 0]\n\
         Texture \"b\" \"spectrum\" \"constant\" \"rgb value\" [0 0 1]\n\
         Texture \"amt\" \"float\" \"checkerboard\" \"float tex1\" 0.25 \"float tex2\" 0.75\n\
         Texture \"m\" \"spectrum\" \"mix\" \"texture tex1\" \"a\" \"texture tex2\" \"b\" \"texture amount\" \"amt\"\n\
         AttributeBegin Rotate 90 1 0 0\n\
         Texture \"d\" \"spectrum\" \"directionmix\" \"texture tex1\" \"a\" \"texture tex2\" \"b\" \"vector3 dir\" [0 1 0]\n\
         AttributeEnd\n\
         Texture \"s\" \"spectrum\" \"scale\" \"texture tex\" \"m\" \"texture scale\" \"amt\"\n\
         Texture \"fm\" \"float\" \"mix\" \"float tex1\" 0.1 \"float tex2\" 0.3 \"texture amount\" \"amt\"\n\
         Material \"diffuse\" \"texture reflectance\" \"m\" {TRI}\
         Material \"diffuse\" \"texture reflectance\" \"d\" {TRI}\
         Material \"diffuse\" \"texture reflectance\" \"s\" {TRI}\
         Material \"conductor\" \"texture roughness\" \"fm\" \"bool remaproughness\" false {TRI}"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let (even, odd) = (Vec2::new(0.5, 0.5), Vec2::new(1.5, 0.5));
    let eval = |m: usize, uv: Vec2, n: Vec3| {
        s.materials[m]
            .approximation()
            .diffuse
            .eval(Vec3::ZERO, uv, n)
    };
    assert!(close(eval(0, even, Vec3::Z), RED * 0.75 + BLUE * 0.25));
    assert!(close(eval(0, odd, Vec3::Z), RED * 0.25 + BLUE * 0.75));
    // `dir` +y under a 90° turn about x is +z in the world.
    assert!(close(eval(1, even, Vec3::Z), RED));
    assert!(close(eval(1, even, Vec3::Y), BLUE));
    let n = Vec3::new(0.0, 0.6, 0.8);
    assert!(close(eval(1, even, n), RED * 0.8 + BLUE * 0.2));
    assert!(close(
        eval(2, odd, Vec3::Z),
        (RED * 0.25 + BLUE * 0.75) * 0.75
    ));
    let map = s.materials[3]
        .approximation()
        .roughness_map
        .as_ref()
        .unwrap();
    let (ax, _) = map.alphas(Vec3::ZERO, odd, Vec3::Z);
    assert!((ax - (0.1 * 0.25 + 0.3 * 0.75)).abs() < 1e-6, "{ax}");
}

fn write(dir: &Path, name: &str, image: &Image) {
    raylink::image::output::write_image(&dir.join(name), image, &[], &Default::default()).unwrap();
}

/// `normalmap` (read linear, whatever the file's format) and a textured `displacement`
/// become the material's normal detail; a constant displacement is none. A scene with
/// both, and every texture class above, converts to TOML and reads back the same.
#[test]
fn normal_maps_and_bump_maps_read_and_convert() {
    let dir = tempfile::tempdir().unwrap();
    let mut n = Image::new(2, 2);
    n.pixels.fill(Rgb::new(0.5, 0.5, 1.0));
    n.set(1, 0, Rgb::new(0.8, 0.5, 0.9));
    write(dir.path(), "n.exr", &n);
    let mut h = Image::new(2, 2);
    h.set(0, 0, Rgb::splat(0.25));
    write(dir.path(), "h.exr", &h);
    let s = load_in(
        dir.path(),
        &format!(
            "{HEADER}Texture \"h\" \"float\" \"imagemap\" \"string filename\" \"h.exr\"\n\
             Texture \"amt\" \"float\" \"checkerboard\" \"float tex1\" 0.25 \"float tex2\" 0.75\n\
             Texture \"m\" \"spectrum\" \"mix\" \"rgb tex1\" [1 0 0] \"rgb tex2\" [0 0 1] \"texture amount\" \"amt\"\n\
             Texture \"d\" \"spectrum\" \"directionmix\" \"texture tex1\" \"m\" \"rgb tex2\" [0 1 0]\n\
             Texture \"s\" \"spectrum\" \"scale\" \"texture tex\" \"d\" \"texture scale\" \"amt\"\n\
             Material \"diffuse\" \"string normalmap\" \"n.exr\" {TRI}\
             Material \"diffuse\" \"texture displacement\" \"h\" \"texture reflectance\" \"s\" {TRI}\
             Material \"diffuse\" \"float displacement\" 0.5 {TRI}\
             Material \"conductor\" \"texture roughness\" \"amt\" {TRI}"
        ),
        &[],
    )
    .unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let Some(NormalDetail::Map(map)) = &s.materials[0].normal_detail else {
        panic!("no normal map");
    };
    assert_eq!(map.eval(Vec2::new(0.75, 0.75)), Rgb::new(0.8, 0.5, 0.9));
    let Some(NormalDetail::Bump(Texture::Image(bump))) = &s.materials[1].normal_detail else {
        panic!("no bump map");
    };
    assert_eq!(bump.eval(Vec2::new(0.25, 0.75)).x, 0.25);
    assert_eq!(s.materials[2].normal_detail, None);

    let out = dir.path().join("out/scene.toml");
    std::fs::create_dir(dir.path().join("out")).unwrap();
    raylink::scene::convert::write_toml(&s, &out).unwrap();
    let back = Scene::load(&out).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back.materials.len(), s.materials.len());
    for (a, b) in back.materials.iter().zip(&s.materials) {
        let (ac, bc) = (a.approximation(), b.approximation());
        // Image files are named from each scene file; compare what they hold and how the
        // textures evaluate.
        for uv in [
            Vec2::new(0.1, 0.2),
            Vec2::new(0.7, 0.4),
            Vec2::new(1.3, 0.9),
        ] {
            for n in [Vec3::Z, Vec3::new(0.0, 0.6, 0.8)] {
                let (x, y) = (
                    ac.diffuse.eval(Vec3::ZERO, uv, n),
                    bc.diffuse.eval(Vec3::ZERO, uv, n),
                );
                assert!(close(x, y), "{}: {x} vs {y}", a.name);
                if let (Some(p), Some(q)) = (&ac.roughness_map, &bc.roughness_map) {
                    assert_eq!(p.alphas(Vec3::ZERO, uv, n), q.alphas(Vec3::ZERO, uv, n));
                }
            }
        }
        assert_eq!(
            ac.roughness_map.is_some(),
            bc.roughness_map.is_some(),
            "{}",
            a.name
        );
        assert_eq!(
            (ac.roughness, ac.roughness_v),
            (bc.roughness, bc.roughness_v)
        );
        match (&a.normal_detail, &b.normal_detail) {
            (Some(NormalDetail::Map(x)), Some(NormalDetail::Map(y))) => {
                assert_eq!(x.file, Path::new("../n.exr"));
                assert_eq!(x.image(), y.image());
            }
            (Some(NormalDetail::Bump(x)), Some(NormalDetail::Bump(y))) => {
                let uv = Vec2::new(0.25, 0.75);
                assert_eq!(
                    x.eval_float(Vec3::ZERO, uv, Vec3::Z),
                    y.eval_float(Vec3::ZERO, uv, Vec3::Z)
                );
            }
            (None, None) => {}
            (x, y) => panic!("{}: {x:?} vs {y:?}", a.name),
        }
    }
}
