//! The output colour space: linear outputs hold the render's linear sRGB converted to the
//! colour space asked for, EXR files name its primaries, 8-bit outputs stay sRGB, and the
//! command line refuses what it cannot write.

mod common;

use std::path::Path;

use glam::Vec3;
use raylink::image::output::{matrix_from_srgb, write_image, OutputOptions};
use raylink::image::Image;
use raylink::read_image;
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
