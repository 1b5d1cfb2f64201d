//! The portable build (`--no-default-features --features portable`: the pure-Rust BVH and
//! image codecs, no system library): it renders the Cornell box as the default build does,
//! within noise, and reads and writes EXR, PNG, JPEG and HDR. The tests run in any build; those that
//! are about a missing library run only without it, and the cross-check of the two image
//! libraries only with OpenImageIO.

mod common;

use std::path::Path;

#[cfg(not(all(feature = "embree", feature = "oiio")))]
use common::assert_clean_failure_of;
use common::raylink;
use raylink::image::io::{self, ImageToWrite, PixelType, RawImage, Window};
use raylink::image::output::{write_image_layers, Layer, OutputOptions};
use raylink::image::{Image, MetaValue, Metadata};
use raylink::math::Rgb;

/// The default build's image (Embree, OpenImageIO): `tests/data/README.md` says how it was made.
const REFERENCE: &str = "tests/data/cornell-box-default-path-32.exr";

/// Renders the Cornell box as the reference was, at 64 spp with `seed` and `extra` options,
/// through the BVH, and returns its RGB values.
fn render_cornell(dir: &Path, seed: u32, extra: &[&str]) -> Vec<f32> {
    let out = dir.join(format!("cornell-{seed}.exr"));
    let seed = seed.to_string();
    let mut args = vec![
        "render",
        "scenes/cornell-box.toml",
        "--accel",
        "bvh",
        "--integrator",
        "path",
        "--spp",
        "64",
        "--width",
        "32",
        "--height",
        "32",
        "--filter",
        "box",
        "--seed",
        &seed,
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let run = raylink(&args);
    assert!(run.status.success(), "{}", common::stderr(&run));
    rgb(&io::read(&out).unwrap())
}

fn rgb(raw: &RawImage) -> Vec<f32> {
    assert_eq!(&raw.channels[..3], ["R", "G", "B"]);
    raw.data
        .chunks_exact(raw.channels.len())
        .flat_map(|p| p[..3].to_vec())
        .collect()
}

/// Per channel, the mean of `a - b` over the pixels in standard errors (the spread of the
/// per-pixel differences over √pixels; the box filter keeps pixels independent).
fn mean_difference_in_standard_errors(a: &[f32], b: &[f32]) -> [f64; 3] {
    std::array::from_fn(|c| {
        let d: Vec<f64> = a
            .iter()
            .zip(b)
            .skip(c)
            .step_by(3)
            .map(|(x, y)| *x as f64 - *y as f64)
            .collect();
        let n = d.len() as f64;
        let mean = d.iter().sum::<f64>() / n;
        let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        mean / (var / n).sqrt()
    })
}

fn mean_squared_difference(a: &[f32], b: &[f32]) -> f64 {
    let sum: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| (*x as f64 - *y as f64).powi(2))
        .sum();
    sum / a.len() as f64
}

/// The build's render agrees with the default build's 4096-spp image: per channel, the mean
/// difference is within 4 standard errors; per pixel, the squared difference to the
/// reference is within 30% of the image's own noise (half the squared difference of two
/// seeds), which a bias confined to some pixels would exceed. The same statistics reject an
/// image without indirect light (`--max-depth 1`), so the test can tell.
#[test]
fn cornell_box_matches_the_default_build_within_noise() {
    let dir = tempfile::tempdir().unwrap();
    let reference = rgb(&io::read(Path::new(REFERENCE)).unwrap());
    let a = render_cornell(dir.path(), 11, &[]);
    let b = render_cornell(dir.path(), 12, &[]);
    let noise = mean_squared_difference(&a, &b) / 2.0;
    let agree = |image: &[f32]| {
        let z = mean_difference_in_standard_errors(image, &reference);
        let ratio = mean_squared_difference(image, &reference) / noise;
        (z, ratio, z.iter().all(|z| z.abs() < 4.0) && ratio < 1.3)
    };
    let (z, ratio, ok) = agree(&a);
    eprintln!("means {z:?} standard errors apart, squared difference {ratio:.3}× the noise");
    assert!(
        ok,
        "means {z:?} standard errors apart, squared difference {ratio:.3}× the noise"
    );
    let direct = render_cornell(dir.path(), 13, &["--max-depth", "1"]);
    let (z, ratio, ok) = agree(&direct);
    eprintln!("direct light alone: {z:?}, {ratio:.3}");
    assert!(!ok, "direct light alone passed: {z:?}, {ratio:.3}");
}

fn image_with(data: &[f32], channels: &[&str], width: u32, pixel_type: PixelType) -> RawImage {
    let dir = tempfile::tempdir().unwrap();
    let ext = if pixel_type == PixelType::U8 || pixel_type == PixelType::U16 {
        "png"
    } else {
        "exr"
    };
    let path = dir.path().join(format!("image.{ext}"));
    let image = ImageToWrite {
        width,
        height: (data.len() / channels.len()) as u32 / width,
        channels,
        data,
        pixel_type,
        window: None,
        chromaticities: None,
    };
    let metadata: Metadata = vec![
        ("raylink:seed".into(), MetaValue::Str("42".into())),
        ("raylink:spp".into(), MetaValue::Int(16)),
        ("raylink:seconds".into(), MetaValue::Float(1.5)),
    ];
    io::write(&path, ext, image, &metadata).unwrap();
    io::read(&path).unwrap()
}

/// Floats whose bits must survive: signs, zeros, denormals, huge, infinite, NaN.
fn awkward_floats(n: usize) -> Vec<f32> {
    let special = [
        0.0,
        -0.0,
        1.0,
        -2.5,
        f32::MIN_POSITIVE / 8.0,
        3.0e38,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        0.1,
    ];
    (0..n)
        .map(|i| match i % 13 {
            0..=9 => special[i % 13],
            k => (i as f32).sqrt() * k as f32 * 0.37,
        })
        .collect()
}

/// 32-bit float EXR: every channel's bits come back as written (NaN as NaN), with the
/// channels by name, extra layers beside RGB, and the metadata.
#[test]
fn exr_float_round_trip_is_exact() {
    let names = ["R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "depth.Z"];
    let (width, height) = (7, 5);
    let data = awkward_floats(width * height * names.len());
    let back = image_with(&data, &names, width as u32, PixelType::Float);
    assert_eq!((back.width, back.height), (width as u32, height as u32));
    assert_eq!(back.pixel_type, Some(PixelType::Float));
    assert_eq!(back.format, "openexr");
    for (c, name) in names.iter().enumerate() {
        let k = back.channels.iter().position(|n| n == name).expect(name);
        for p in 0..width * height {
            let (w, r) = (data[p * names.len() + c], back.data[p * names.len() + k]);
            assert!(
                w.to_bits() == r.to_bits() || (w.is_nan() && r.is_nan()),
                "{name} pixel {p}: wrote {w}, read {r}"
            );
        }
    }
    assert_eq!(
        back.meta("raylink:seed"),
        Some(&MetaValue::Str("42".into()))
    );
    assert_eq!(back.meta("raylink:spp"), Some(&MetaValue::Int(16)));
    assert_eq!(back.meta("raylink:seconds"), Some(&MetaValue::Float(1.5)));
}

/// Half-float EXR: values a half holds come back exactly, others to the nearest half
/// (relative error at most 2^-11).
#[test]
fn exr_half_round_trip_rounds_to_half() {
    let data: Vec<f32> = (0..60).map(|i| (i as f32 - 20.0) * 0.173).collect();
    let back = image_with(&data, &["R", "G", "B"], 4, PixelType::Half);
    assert_eq!(back.pixel_type, Some(PixelType::Half));
    for (w, r) in data.iter().zip(&back.data) {
        assert!((w - r).abs() <= w.abs() * 2f32.powi(-11), "{w} read as {r}");
    }
    let exact = [0.5f32, -1.0, 2048.0];
    let back = image_with(&exact, &["R", "G", "B"], 1, PixelType::Half);
    assert_eq!(back.data, exact);
}

/// A render tile keeps where it lies: its data window inside the full image.
#[test]
fn exr_region_keeps_its_window() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tile.exr");
    let data: Vec<f32> = (0..2 * 3 * 3).map(|i| i as f32).collect();
    let window = Window {
        x: 5,
        y: 7,
        full_x: 0,
        full_y: 0,
        full_width: 20,
        full_height: 10,
    };
    let image = ImageToWrite {
        width: 2,
        height: 3,
        channels: &["R", "G", "B"],
        data: &data,
        pixel_type: PixelType::Float,
        window: Some(window),
        chromaticities: None,
    };
    io::write(&path, "openexr", image, &Metadata::new()).unwrap();
    let back = io::read(&path).unwrap();
    assert_eq!((back.width, back.height, back.window), (2, 3, window));
    assert_eq!(back.data, data);
}

/// 8-bit PNG: within half a step of 1/255 of the values written (clamped to [0, 1]); 16-bit
/// within half a step of 1/65535.
#[test]
fn png_round_trip_is_within_quantisation() {
    let data: Vec<f32> = (0..3 * 40).map(|i| i as f32 / 100.0 - 0.1).collect();
    for (pixel, step) in [(PixelType::U8, 255.0), (PixelType::U16, 65535.0)] {
        let back = image_with(&data, &["R", "G", "B"], 8, pixel);
        assert_eq!(back.pixel_type, Some(pixel));
        assert_eq!(back.channels, ["R", "G", "B"]);
        for (w, r) in data.iter().zip(&back.data) {
            let expected = w.clamp(0.0, 1.0);
            assert!((expected - r).abs() <= 0.5 / step + 1e-7, "{w} read as {r}");
        }
        assert_eq!(
            back.meta("raylink:seed"),
            Some(&MetaValue::Str("42".into()))
        );
    }
}

/// A smooth RGB ramp, `width` x `height`, values in [0, 1.2].
fn ramp(width: u32, height: u32) -> Vec<f32> {
    (0..width * height * 3)
        .map(|i| {
            let (p, c) = (i / 3, i % 3);
            let (x, y) = ((p % width) as f32, (p / width) as f32);
            (0.1 + 0.3 * c as f32 + x / width as f32 * 0.5 + y / height as f32 * 0.3).min(1.2)
        })
        .collect()
}

/// The pure-Rust codecs write and read JPEG and Radiance HDR: HDR within RGBE's precision
/// (8 bits of mantissa shared by the three channels: a relative error below 1/128 of the
/// largest channel), JPEG at quality 95 within a few levels of 1/255 on a smooth image.
#[test]
fn jpeg_and_hdr_round_trip_within_their_precision() {
    use raylink::image::codecs;
    let dir = tempfile::tempdir().unwrap();
    let allowance = raylink::input_file::Allowance::machine();
    let (width, height) = (48, 32);
    let data = ramp(width, height);
    let image = ImageToWrite {
        width,
        height,
        channels: &["R", "G", "B"],
        data: &data,
        pixel_type: PixelType::Float,
        window: None,
        chromaticities: None,
    };
    let hdr = dir.path().join("ramp.hdr");
    std::fs::write(&hdr, codecs::encode(&hdr, "hdr", image, &vec![]).unwrap()).unwrap();
    let back = io::read(&hdr).unwrap();
    assert_eq!((back.width, back.height), (width, height));
    assert_eq!(back.channels, ["R", "G", "B"]);
    assert_eq!(back.format, "hdr");
    for (px, (w, r)) in data.chunks(3).zip(back.data.chunks(3)).enumerate() {
        let largest = w.iter().copied().fold(0.0, f32::max);
        for c in 0..3 {
            assert!(
                (w[c] - r[c]).abs() <= largest / 128.0,
                "pixel {px}: {w:?} read as {r:?}"
            );
        }
    }
    let jpg = dir.path().join("ramp.jpg");
    let image = ImageToWrite {
        pixel_type: PixelType::U8,
        ..image
    };
    std::fs::write(&jpg, codecs::encode(&jpg, "jpeg", image, &vec![]).unwrap()).unwrap();
    let back = codecs::read_within(&jpg, &allowance).unwrap();
    assert_eq!(
        (back.width, back.height, back.format.as_str()),
        (width, height, "jpeg")
    );
    let (mut sum, mut worst) = (0.0f64, 0.0f32);
    for (w, r) in data.iter().zip(&back.data) {
        let e = (w.clamp(0.0, 1.0) - r).abs();
        sum += e as f64;
        worst = worst.max(e);
    }
    let mean = sum / data.len() as f64;
    assert!(
        mean < 1.5 / 255.0 && worst < 8.0 / 255.0,
        "mean {mean}, worst {worst}"
    );
    // A file that is neither is refused by name.
    let bad = dir.path().join("bad.jpg");
    std::fs::write(&bad, [0xff, 0xd8, 0xff, 0x00, 0x01]).unwrap();
    let message = io::read(&bad).unwrap_err().to_string();
    assert!(
        message.contains("bad.jpg") && message.lines().count() == 1,
        "{message}"
    );
}

/// The auxiliary images of `--aov` go into the EXR as named layers and come back per name.
#[test]
fn exr_layers_of_the_output_come_back_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("layers.exr");
    let (w, h) = (3u32, 2u32);
    let pixels = |k: f32| (0..w * h).map(|i| Rgb::new(i as f32, k, -k)).collect();
    let image = Image {
        width: w,
        height: h,
        pixels: pixels(1.0),
    };
    let albedo = Image {
        width: w,
        height: h,
        pixels: pixels(2.0),
    };
    let layers = [Layer {
        name: "albedo",
        channels: &["R", "G", "B"],
        image: &albedo,
    }];
    write_image_layers(&path, &image, &layers, &[], &OutputOptions::default()).unwrap();
    let back = io::read(&path).unwrap();
    let n = back.channels.len();
    let channel = |name: &str| {
        let k = back.channels.iter().position(|c| c == name).expect(name);
        back.data
            .iter()
            .skip(k)
            .step_by(n)
            .copied()
            .collect::<Vec<f32>>()
    };
    let of = |im: &Image, f: fn(&Rgb) -> f32| im.pixels.iter().map(f).collect::<Vec<f32>>();
    assert_eq!(channel("R"), of(&image, |p| p.x));
    assert_eq!(channel("B"), of(&image, |p| p.z));
    assert_eq!(channel("albedo.G"), of(&albedo, |p| p.y));
    assert_eq!(channel("albedo.B"), of(&albedo, |p| p.z));
}

/// A file that is not a readable image is bad input: one line naming the file.
#[test]
fn bad_image_files_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let good = image_with(&[0.25; 12], &["R", "G", "B"], 2, PixelType::Float);
    assert_eq!(good.data, vec![0.25; 12]);
    let exr = dir.path().join("cut.exr");
    let data = [0.5f32; 48];
    let image = ImageToWrite {
        width: 4,
        height: 4,
        channels: &["R", "G", "B"],
        data: &data,
        pixel_type: PixelType::Float,
        window: None,
        chromaticities: None,
    };
    io::write(&exr, "exr", image, &Metadata::new()).unwrap();
    let bytes = std::fs::read(&exr).unwrap();
    std::fs::write(&exr, &bytes[..bytes.len() / 2]).unwrap();
    let text = dir.path().join("text.png");
    std::fs::write(&text, "not an image\n").unwrap();
    let empty = dir.path().join("empty.exr");
    std::fs::write(&empty, "").unwrap();
    for path in [&exr, &text, &empty] {
        let err = io::read(path).unwrap_err();
        let message = err.to_string();
        assert!(matches!(err, raylink::Error::Input { .. }), "{message}");
        assert!(message.contains(path.to_str().unwrap()), "{message}");
        assert_eq!(message.lines().count(), 1, "{message}");
    }
}

/// Without OpenImageIO, the format only it writes (TIFF) is refused before rendering: one
/// line, exit status 2, nothing written.
#[cfg(not(feature = "oiio"))]
#[test]
fn formats_that_need_openimageio_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.tif");
    let run = raylink(&[
        "render",
        "scenes/cornell-box.toml",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_clean_failure_of("tif", &run, &[".tif", "OpenImageIO", ".png"]);
    assert!(!out.exists());
}

/// Without Embree, `--accel embree` is refused with one line; the default is the BVH.
#[cfg(not(feature = "embree"))]
#[test]
fn embree_is_refused_and_the_bvh_is_the_default() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.exr");
    let path = out.to_str().unwrap();
    let run = raylink(&[
        "render",
        "scenes/cornell-box.toml",
        "--accel",
        "embree",
        "-o",
        path,
    ]);
    assert_clean_failure_of("--accel embree", &run, &["--accel", "embree", "bvh"]);
    assert!(!out.exists());
    let run = raylink(&[
        "render",
        "scenes/cornell-box.toml",
        "--width",
        "8",
        "--height",
        "8",
        "-o",
        path,
    ]);
    assert!(run.status.success(), "{}", common::stderr(&run));
    let settings = io::read(&out).unwrap();
    let Some(MetaValue::Str(s)) = settings.meta("raylink:settings") else {
        panic!("no settings in {path}")
    };
    assert!(s.contains("accel=bvh"), "{s}");
}

/// With OpenImageIO too, each library reads what the other writes, to the bit: EXR (float,
/// extra layers and metadata by name, a tile's window) and 8-bit PNG (and its text).
#[cfg(feature = "oiio")]
#[test]
fn openimageio_and_the_rust_codecs_read_each_other() {
    use raylink::image::{codecs, oiio};
    let dir = tempfile::tempdir().unwrap();
    let allowance = raylink::input_file::Allowance::machine();
    let names = ["R", "G", "B", "normal.X", "normal.Y", "normal.Z"];
    let data = awkward_floats(6 * 4 * names.len());
    let window = Window {
        x: 2,
        y: 1,
        full_x: 0,
        full_y: 0,
        full_width: 9,
        full_height: 8,
    };
    let metadata: Metadata = vec![
        ("raylink:seed".into(), MetaValue::Str("7".into())),
        ("raylink:parts".into(), MetaValue::Int(3)),
    ];
    let exr = |window| ImageToWrite {
        width: 6,
        height: 4,
        channels: &names,
        data: &data,
        pixel_type: PixelType::Float,
        window,
        chromaticities: None,
    };
    let pixels: Vec<f32> = (0..6 * 4 * 3).map(|i| (i % 17) as f32 / 16.0).collect();
    let png = ImageToWrite {
        width: 6,
        height: 4,
        channels: &["R", "G", "B"],
        data: &pixels,
        pixel_type: PixelType::U8,
        window: None,
        chromaticities: None,
    };
    let same = |a: &RawImage, b: &RawImage| {
        assert_eq!((a.width, a.height, a.window), (b.width, b.height, b.window));
        for name in &b.channels {
            let (ka, kb) = (
                a.channels.iter().position(|c| c == name).expect(name),
                b.channels.iter().position(|c| c == name).unwrap(),
            );
            let (na, nb) = (a.channels.len(), b.channels.len());
            for p in 0..(a.width * a.height) as usize {
                let (x, y) = (a.data[p * na + ka], b.data[p * nb + kb]);
                assert!(
                    x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()),
                    "{name} {p}: {x} {y}"
                );
            }
        }
        // EXR keeps every attribute with its type; PNG's text chunks, the strings (OpenImageIO
        // writes no others there).
        for (name, value) in &metadata {
            if a.format == "openexr" || matches!(value, MetaValue::Str(_)) {
                assert_eq!(a.meta(name), Some(value), "{name}");
                assert_eq!(b.meta(name), Some(value), "{name}");
            }
        }
    };
    for (ext, image) in [("exr", exr(None)), ("exr", exr(Some(window))), ("png", png)] {
        let by_rust = dir.path().join(format!("rust.{ext}"));
        let by_oiio = dir.path().join(format!("oiio.{ext}"));
        std::fs::write(
            &by_rust,
            codecs::encode(&by_rust, ext, image, &metadata).unwrap(),
        )
        .unwrap();
        oiio::write(&by_oiio, ext, image, &metadata).unwrap();
        // Each file read by both libraries: the same values.
        for file in [&by_rust, &by_oiio] {
            let (a, b) = (
                oiio::read(file).unwrap(),
                codecs::read_within(file, &allowance).unwrap(),
            );
            assert_eq!(a.format, b.format, "{}", file.display());
            assert_eq!(a.pixel_type, b.pixel_type, "{}", file.display());
            same(&a, &b);
        }
        same(
            &oiio::read(&by_rust).unwrap(),
            &oiio::read(&by_oiio).unwrap(),
        );
    }
    // JPEG and HDR: each library reads the other's file to within the format's precision
    // (JPEG decoders round their transforms differently; RGBE decoders place a value at its
    // step's bottom or middle).
    let (width, height) = (24, 16);
    let data = ramp(width, height);
    for (ext, pixel_type, tolerance) in [
        ("jpeg", PixelType::U8, 3.0 / 255.0),
        ("hdr", PixelType::Float, 1.0 / 64.0),
    ] {
        let image = ImageToWrite {
            width,
            height,
            channels: &["R", "G", "B"],
            data: &data,
            pixel_type,
            window: None,
            chromaticities: None,
        };
        let by_rust = dir.path().join(format!("rust.{ext}"));
        let by_oiio = dir.path().join(format!("oiio.{ext}"));
        std::fs::write(
            &by_rust,
            codecs::encode(&by_rust, ext, image, &vec![]).unwrap(),
        )
        .unwrap();
        oiio::write(&by_oiio, ext, image, &vec![]).unwrap();
        for file in [&by_rust, &by_oiio] {
            let (a, b) = (
                oiio::read(file).unwrap(),
                codecs::read_within(file, &allowance).unwrap(),
            );
            assert_eq!(
                (a.width, a.height),
                (b.width, b.height),
                "{}",
                file.display()
            );
            assert_eq!(a.channels, b.channels, "{}", file.display());
            for (k, (x, y)) in a.data.iter().zip(&b.data).enumerate() {
                let scale = if ext == "hdr" { x.abs().max(0.1) } else { 1.0 };
                assert!(
                    (x - y).abs() <= tolerance * scale,
                    "{} {k}: {x} {y}",
                    file.display()
                );
            }
        }
    }
}
