//! Image files through OpenImageIO: round trips per format, metadata, error handling and the
//! atomic-write guarantees of `raylink::image::output`.
#![cfg(feature = "oiio")]

use std::fs;
use std::path::{Path, PathBuf};

use raylink::image::oiio::{self, PixelType};
use raylink::image::output::{
    check_output_path, read_image, srgb_decode, srgb_encode, write_image, OutputOptions,
};
use raylink::image::{Image, MetaValue, Metadata};
use raylink::math::Rgb;

/// A small deterministic generator (xorshift), so the tests need no extra crates.
struct Rng(u64);

impl Rng {
    fn next_u32(&mut self) -> u32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 32) as u32
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 / (1u32 << 24) as f32
    }
}

fn image_from(width: u32, height: u32, values: &[f32]) -> Image {
    let n = (width * height) as usize;
    let pixels = (0..n)
        .map(|i| {
            let v = |c: usize| values[(3 * i + c) % values.len()];
            Rgb::new(v(0), v(1), v(2))
        })
        .collect();
    Image {
        width,
        height,
        pixels,
    }
}

fn channels(image: &Image) -> Vec<f32> {
    image.pixels.iter().flat_map(|p| [p.x, p.y, p.z]).collect()
}

/// The names in `dir`, sorted.
fn dir_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn meta_get<'a>(metadata: &'a Metadata, name: &str) -> Option<&'a MetaValue> {
    metadata.iter().find(|(n, _)| n == name).map(|(_, v)| v)
}

fn no_options() -> OutputOptions {
    OutputOptions::new(0.0, false)
}

/// Values spanning the float range: both signs, exponents from 1e-38 to 1e38, subnormals,
/// signed zeros and infinities.
fn varied_values(count: usize) -> Vec<f32> {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut values = vec![
        0.0,
        -0.0,
        1.0,
        -1.0,
        0.5,
        f32::MAX,
        f32::MIN,
        f32::MIN_POSITIVE,
        1e-40, // subnormal
        -3e-42,
        f32::INFINITY,
        f32::NEG_INFINITY,
        65504.0,
        1e20,
        -7.25e-30,
    ];
    while values.len() < count {
        let exponent = (rng.next_u32() % 77) as i32 - 38;
        let sign = if rng.next_u32().is_multiple_of(2) {
            1.0
        } else {
            -1.0
        };
        values.push(sign * (1.0 + 9.0 * rng.unit()) * 10f32.powi(exponent));
    }
    values
}

#[test]
fn exr_float_round_trip_is_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("float.exr");
    let (w, h) = (17, 9);
    let values = varied_values(3 * w * h);
    let image = image_from(w as u32, h as u32, &values);
    write_image(&path, &image, &Metadata::new(), &no_options()).unwrap();

    let raw = oiio::read(&path).unwrap();
    assert_eq!(raw.format, "openexr");
    assert_eq!(raw.pixel_type, Some(PixelType::Float));
    assert_eq!(raw.channels, ["R", "G", "B"]);
    assert_eq!((raw.width, raw.height), (w as u32, h as u32));

    let (back, _) = read_image(&path).unwrap();
    let written = channels(&image);
    let read = channels(&back);
    assert_eq!(written.len(), read.len());
    for (i, (a, b)) in written.iter().zip(&read).enumerate() {
        assert_eq!(
            a.to_bits(),
            b.to_bits(),
            "value {i}: wrote {a:e}, read {b:e}"
        );
    }
}

#[test]
fn exr_half_round_trip_within_half_precision() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("half.exr");
    let mut rng = Rng(12345);
    let mut values = vec![0.0, 1.0, -1.0, 0.5, 65504.0, -65504.0, 6.1e-5, 1e-6, -3e-7];
    while values.len() < 3 * 32 * 8 {
        // Magnitudes from 2^-14 (smallest normal half) to 2^15, both signs.
        let magnitude = (rng.unit() * 29.0 - 14.0).exp2();
        let sign = if rng.next_u32().is_multiple_of(2) {
            1.0
        } else {
            -1.0
        };
        values.push(sign * magnitude);
    }
    let image = image_from(32, 8, &values);
    let options = OutputOptions::new(0.0, true);
    write_image(&path, &image, &Metadata::new(), &options).unwrap();

    let raw = oiio::read(&path).unwrap();
    assert_eq!(raw.pixel_type, Some(PixelType::Half));
    let (back, _) = read_image(&path).unwrap();
    let mut inexact = 0;
    for (a, b) in channels(&image).iter().zip(channels(&back)) {
        // Half keeps 11 significant bits: rounding to nearest errs by at most 2^-11 relative
        // for normal values; below 2^-14 the spacing is fixed at 2^-24.
        let tolerance = if a.abs() >= 2f32.powi(-14) {
            a.abs() * 2f32.powi(-11)
        } else {
            2f32.powi(-25)
        };
        assert!((a - b).abs() <= tolerance, "wrote {a:e}, read {b:e}");
        if a != &b {
            inexact += 1;
        }
    }
    // Really stored as half, not float.
    assert!(
        inexact > 100,
        "only {inexact} values changed: stored as float?"
    );
}

#[test]
fn png_round_trip_within_8_bit_quantisation() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("srgb.png");
    // A ramp over [0, 1] (denser near 0, where the linear segment of sRGB is), then values
    // that must clamp.
    let mut values: Vec<f32> = (0..=600).map(|i| (i as f32 / 600.0).powi(2)).collect();
    values.extend([0.003_130_8, 1e-4, 0.001, 0.04, 0.18, 0.5, 0.99, 1.0]);
    let in_range = values.len();
    values.extend([1.0001, 1.5, 7.0, 1e6, f32::INFINITY]);
    while !values.len().is_multiple_of(3) {
        values.push(0.25);
    }
    let n = values.len() / 3;
    let image = image_from(n as u32, 1, &values);
    write_image(&path, &image, &Metadata::new(), &no_options()).unwrap();

    let raw = oiio::read(&path).unwrap();
    assert_eq!(raw.format, "png");
    assert_eq!(raw.pixel_type, Some(PixelType::U8));
    let (back, _) = read_image(&path).unwrap();
    let read = channels(&back);
    let half_step = 0.5 / 255.0;
    for (i, (&x, &y)) in values.iter().zip(&read).enumerate() {
        // Read-back values are 8-bit levels (OIIO returns level k as k * (1/255), which may
        // differ from k / 255 in the last bit).
        assert!(
            ((y * 255.0).round() - y * 255.0).abs() < 1e-4,
            "not an 8-bit level: {y}"
        );
        if i < in_range {
            // The encoded value is the nearest 8-bit level to sRGB(x) ...
            assert!(
                (srgb_encode(x) - y).abs() <= half_step + 1e-6,
                "linear {x}: sRGB {} but stored {y}",
                srgb_encode(x)
            );
            // ... so decoding it gives back x to within half a step in sRGB space.
            let decoded = srgb_decode(y);
            assert!(
                (srgb_encode(decoded) - srgb_encode(x)).abs() <= half_step + 1e-6,
                "linear {x} came back as {decoded}"
            );
        } else if x > 1.0 {
            assert_eq!(y, 1.0, "{x} should clamp to 1");
        }
    }
    // Not stored linearly: mid-grey encodes to level 188, not 128.
    let mid = read[values.iter().position(|&v| v == 0.5).unwrap()];
    assert!(
        (mid - 188.0 / 255.0).abs() < 1e-6,
        "0.5 stored as {}",
        mid * 255.0
    );
}

#[test]
fn png_clamps_negatives_and_applies_exposure() {
    let dir = tempfile::tempdir().unwrap();
    let plain = dir.path().join("plain.png");
    let exposed = dir.path().join("exposed.png");
    let values = [0.05, 0.1, 0.2, 0.4, -0.5, -1e9, 0.3, 0.01, 0.6];
    let image = image_from(3, 1, &values);
    write_image(&plain, &image, &Metadata::new(), &no_options()).unwrap();
    let brighter = OutputOptions::new(1.0, false);
    write_image(&exposed, &image, &Metadata::new(), &brighter).unwrap();

    let (a, _) = read_image(&plain).unwrap();
    let (b, _) = read_image(&exposed).unwrap();
    let (a, b) = (channels(&a), channels(&b));
    assert_eq!(a[4], 0.0);
    assert_eq!(a[5], 0.0);
    // One stop up: value v at exposure 1 is stored like 2v at exposure 0.
    assert_eq!(b[0], a[1]);
    assert_eq!(b[1], a[2]);
    assert_eq!(b[2], a[3]);
    for (x, y) in values.iter().zip(&b) {
        if *x >= 0.0 {
            assert!((srgb_encode(2.0 * x).min(1.0) - y).abs() <= 0.5 / 255.0 + 1e-6);
        }
    }
}

#[test]
fn jpeg_is_srgb_with_quality_95() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("grey.JPG");
    let image = image_from(16, 16, &[0.18]);
    write_image(&path, &image, &Metadata::new(), &no_options()).unwrap();

    let raw = oiio::read(&path).unwrap();
    assert_eq!(raw.format, "jpeg");
    let (back, _) = read_image(&path).unwrap();
    let expected = srgb_encode(0.18);
    for v in channels(&back) {
        assert!((v - expected).abs() <= 2.0 / 255.0, "{v} vs {expected}");
    }

    // libjpeg scales its standard tables by quality: at 95 the first luminance entry
    // (16 at quality 50) becomes (16 * 10 + 50) / 100 = 2; at OIIO's default 98 it is 1.
    let bytes = fs::read(&path).unwrap();
    let dqt = bytes
        .windows(2)
        .position(|w| w == [0xFF, 0xDB])
        .expect("no quantisation table");
    // Marker (2), length (2), precision/table id (1), then the table in zigzag order.
    assert_eq!(bytes[dqt + 4] & 0xF0, 0, "8-bit table expected");
    assert_eq!(bytes[dqt + 5], 2, "first quantiser says quality is not 95");
}

#[test]
fn tiff_is_float_and_hdr_is_linear() {
    let dir = tempfile::tempdir().unwrap();
    let tif = dir.path().join("linear.tiff");
    let hdr = dir.path().join("linear.hdr");
    let values = varied_values(3 * 8 * 4);
    let image = image_from(8, 4, &values);
    write_image(&tif, &image, &Metadata::new(), &no_options()).unwrap();
    let raw = oiio::read(&tif).unwrap();
    assert_eq!(raw.format, "tiff");
    assert_eq!(raw.pixel_type, Some(PixelType::Float));
    let (back, _) = read_image(&tif).unwrap();
    for (a, b) in channels(&image).iter().zip(channels(&back)) {
        assert_eq!(a.to_bits(), b.to_bits(), "tiff: wrote {a:e}, read {b:e}");
    }

    // RGBE: 8-bit mantissas with a shared exponent, so relative to the largest channel of a
    // pixel the error is below 2^-7 (truncation in some encoders). Negatives and NaN become
    // 0 (OpenImageIO alone would turn -0.5 into 0.5), huge values clamp instead of zeroing
    // the pixel.
    let mut rng = Rng(7);
    let mut values: Vec<f32> = (0..3 * 8 * 4)
        .map(|i| match i % 11 {
            5 => -0.5,
            7 => -3.0,
            _ => (rng.unit() * 20.0 - 10.0).exp2(),
        })
        .collect();
    values[..6].copy_from_slice(&[3e38, f32::INFINITY, 1e30, f32::NAN, 2.0, f32::NEG_INFINITY]);
    let image = image_from(8, 4, &values);
    write_image(&hdr, &image, &Metadata::new(), &no_options()).unwrap();
    assert_eq!(oiio::read(&hdr).unwrap().format, "hdr");
    let (back, _) = read_image(&hdr).unwrap();
    let huge = back.pixels[0];
    assert!((huge.x / 1e38 - 1.0).abs() < 0.01, "{huge}");
    assert!((huge.y / 1e38 - 1.0).abs() < 0.01, "{huge}");
    // Shared exponent: 1e30 next to 1e38 is below the pixel's precision.
    assert!(huge.z <= 1e38 * 2f32.powi(-7), "{huge}");
    assert_eq!(back.pixels[1].x, 0.0, "NaN");
    assert!((back.pixels[1].y - 2.0).abs() < 2.0 * 2f32.powi(-7));
    assert_eq!(back.pixels[1].z, 0.0, "-inf");
    for (p, q) in image.pixels.iter().zip(&back.pixels).skip(2) {
        let scale = p.max_element();
        for (a, b) in p.to_array().iter().zip(q.to_array()) {
            if *a < 0.0 {
                assert_eq!(b, 0.0, "hdr: negative {a} read back as {b}");
            } else {
                assert!((a - b).abs() <= scale * 2f32.powi(-7), "hdr: {a} vs {b}");
            }
        }
    }
    // Exposure is not applied to linear formats.
    let brighter = OutputOptions::new(3.0, false);
    write_image(&tif, &image, &Metadata::new(), &brighter).unwrap();
    let (back, _) = read_image(&tif).unwrap();
    let bits = |image: &Image| {
        channels(image)
            .iter()
            .map(|v| v.to_bits())
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&back), bits(&image));
}

#[test]
fn metadata_survives_in_exr() {
    let dir = tempfile::tempdir().unwrap();
    let metadata: Metadata = vec![
        ("Software".into(), MetaValue::Str("raylink 0.1.0".into())),
        (
            "raylink:scene".into(),
            MetaValue::Str("scenes/cornell box.toml".into()),
        ),
        (
            "raylink:integrator".into(),
            MetaValue::Str("whitted".into()),
        ),
        ("raylink:samples".into(), MetaValue::Int(64)),
        ("raylink:seed".into(), MetaValue::Int(-123_456_789)),
        ("raylink:renderSeconds".into(), MetaValue::Float(12.375)),
        ("raylink:tiny".into(), MetaValue::Float(-1.5e-20)),
        (
            "raylink:unicode".into(),
            MetaValue::Str("Grüße, 光線".into()),
        ),
    ];
    for half in [false, true] {
        let path = dir.path().join(format!("meta-{half}.exr"));
        let image = image_from(4, 4, &[0.25, 0.5, 0.75]);
        let options = OutputOptions::new(0.0, half);
        write_image(&path, &image, &metadata, &options).unwrap();
        let (_, read) = read_image(&path).unwrap();
        for (name, value) in &metadata {
            assert_eq!(
                meta_get(&read, name),
                Some(value),
                "attribute {name} (half: {half}); read {read:?}"
            );
        }
    }
}

#[test]
fn write_to_missing_directory_fails_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let missing_dir = dir.path().join("out");
    let path = missing_dir.join("x.exr");
    let image = image_from(2, 2, &[1.0]);
    let message = write_image(&path, &image, &Metadata::new(), &no_options())
        .unwrap_err()
        .to_string();
    assert_eq!(
        message,
        format!(
            "{}: directory {} does not exist",
            path.display(),
            missing_dir.display()
        )
    );
    assert!(!path.exists());
    assert!(!missing_dir.exists());
    assert!(dir_names(dir.path()).is_empty());
}

#[test]
fn failed_write_does_not_clobber_an_existing_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.png");
    let original = b"not really a png, but precious".to_vec();
    fs::write(&path, &original).unwrap();

    // Passes check_output_path, then fails inside the PNG writer after it has created the
    // temporary file: libpng refuses rows wider than 1,000,000 pixels.
    let too_wide = Image::new(1_000_001, 1);
    let message = write_image(&path, &too_wide, &Metadata::new(), &no_options())
        .unwrap_err()
        .to_string();
    assert!(
        message.starts_with(&format!("{}: ", path.display())),
        "{message}"
    );
    // OpenImageIO 2.4 says "PNG", 2.5 (Debian 13) "png image resolution may not exceed".
    assert!(message.to_lowercase().contains("png"), "{message}");
    assert!(!message.contains('\n'), "{message}");
    assert_eq!(fs::read(&path).unwrap(), original);
    assert_eq!(dir_names(dir.path()), ["x.png"]);

    // An unsupported extension fails before anything is written.
    let bmp = dir.path().join("x.bmp");
    fs::write(&bmp, &original).unwrap();
    let message = write_image(&bmp, &Image::new(2, 2), &Metadata::new(), &no_options())
        .unwrap_err()
        .to_string();
    assert_eq!(
        message,
        format!(
            "{}: unsupported output format .bmp (use .exr, .hdr, .tif, .png or .jpg)",
            bmp.display()
        )
    );
    assert_eq!(fs::read(&bmp).unwrap(), original);

    // A JPEG too large for libjpeg is refused cleanly (OIIO 2.4 would let libjpeg exit()).
    let jpg = dir.path().join("x.jpg");
    fs::write(&jpg, &original).unwrap();
    let message = write_image(
        &jpg,
        &Image::new(70_000, 1),
        &Metadata::new(),
        &no_options(),
    )
    .unwrap_err()
    .to_string();
    assert!(message.contains("65500"), "{message}");
    assert_eq!(fs::read(&jpg).unwrap(), original);

    // An image whose pixel count does not match its size is refused.
    let mut bad = Image::new(2, 2);
    bad.pixels.pop();
    assert!(write_image(&path, &bad, &Metadata::new(), &no_options()).is_err());
    assert_eq!(fs::read(&path).unwrap(), original);

    assert_eq!(dir_names(dir.path()), ["x.bmp", "x.jpg", "x.png"]);
}

#[test]
fn successful_writes_replace_the_target_and_leave_no_temporary_files() {
    let dir = tempfile::tempdir().unwrap();
    let names = [
        "a.exr", "b.HDR", "c.tif", "d.tiff", "e.png", "f.jpg", "g.jpeg",
    ];
    for name in names {
        let path = dir.path().join(name);
        fs::write(&path, b"old contents").unwrap();
        let image = image_from(5, 3, &[0.1, 0.2, 0.3, 0.9]);
        write_image(&path, &image, &Metadata::new(), &no_options()).unwrap();
        let (back, _) = read_image(&path).unwrap();
        assert_eq!((back.width, back.height), (5, 3), "{name}");
    }
    assert_eq!(dir_names(dir.path()), names.map(String::from));
}

#[test]
fn concurrent_writes_to_one_target_do_not_collide() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("same.exr");
    std::thread::scope(|scope| {
        for t in 0..4 {
            let path = path.clone();
            scope.spawn(move || {
                let image = image_from(16, 16, &[t as f32]);
                write_image(&path, &image, &Metadata::new(), &no_options()).unwrap();
            });
        }
    });
    let (back, _) = read_image(&path).unwrap();
    let first = back.pixels[0];
    assert!(back.pixels.iter().all(|&p| p == first), "mixed contents");
    assert_eq!(dir_names(dir.path()), ["same.exr"]);
}

#[test]
fn check_output_path_accepts_and_rejects() {
    let dir = tempfile::tempdir().unwrap();
    for name in [
        "a.exr", "a.EXR", "a.hdr", "a.tif", "a.TIFF", "a.png", "a.jpg", "a.Jpeg",
    ] {
        check_output_path(&dir.path().join(name)).unwrap();
    }
    // A bare file name is checked against the current directory.
    check_output_path(Path::new("relative-name-that-is-never-created.exr")).unwrap();

    for name in ["a.bmp", "a.exr.gz", "a.gif", "noextension"] {
        let path = dir.path().join(name);
        let message = check_output_path(&path).unwrap_err().to_string();
        assert!(
            message.starts_with(&format!("{}: ", path.display())),
            "{message}"
        );
        assert!(
            message.contains(".exr, .hdr, .tif, .png or .jpg"),
            "{message}"
        );
    }

    let missing = dir.path().join("no").join("such").join("dir.png");
    let message = check_output_path(&missing).unwrap_err().to_string();
    assert!(message.starts_with(&format!("{}: ", missing.display())));
    assert!(message.ends_with("does not exist"), "{message}");

    let file = dir.path().join("plain-file");
    fs::write(&file, b"").unwrap();
    let message = check_output_path(&file.join("x.exr"))
        .unwrap_err()
        .to_string();
    assert!(
        message.ends_with("plain-file is not a directory"),
        "{message}"
    );

    let subdir = dir.path().join("image.png");
    fs::create_dir(&subdir).unwrap();
    let message = check_output_path(&subdir).unwrap_err().to_string();
    assert!(message.contains("is a directory"), "{message}");

    // Nothing was created along the way (the writability probe is removed).
    assert_eq!(dir_names(dir.path()), ["image.png", "plain-file"]);
}

#[test]
fn check_output_path_rejects_unwritable_directories() {
    let dir = tempfile::tempdir().unwrap();
    let locked = dir.path().join("locked");
    fs::create_dir(&locked).unwrap();
    let unwritable: Option<PathBuf> = {
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            fs::set_permissions(&locked, fs::Permissions::from_mode(0o555)).unwrap();
            // Privileged users (root in a container) ignore the mode bits; fall back to
            // /sys, which nobody can create files in.
            if fs::write(locked.join("probe"), b"").is_err() {
                Some(locked.clone())
            } else if fs::write("/sys/raylink-probe", b"").is_err() && Path::new("/sys").is_dir() {
                Some(PathBuf::from("/sys"))
            } else {
                None
            }
        }
        #[cfg(not(unix))]
        {
            None
        }
    };
    match unwritable {
        Some(dir) => {
            let path = dir.join("x.exr");
            let message = check_output_path(&path).unwrap_err().to_string();
            assert!(message.contains("is not writable"), "{message}");
            assert!(message.starts_with(&format!("{}: ", path.display())));
        }
        None => eprintln!("skipped: no unwritable directory available to this user"),
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        fs::set_permissions(&locked, fs::Permissions::from_mode(0o755)).unwrap();
    }
}

#[test]
fn read_image_maps_channels_to_rgb() {
    let dir = tempfile::tempdir().unwrap();
    let none = Metadata::new();

    let grey = dir.path().join("grey.exr");
    oiio::write(
        &grey,
        "openexr",
        oiio::ImageToWrite {
            width: 2,
            height: 1,
            channels: &["Y"],
            data: &[0.25, 4.0],
            pixel_type: PixelType::Float,
            window: None,
            chromaticities: None,
        },
        &none,
    )
    .unwrap();
    let (image, _) = read_image(&grey).unwrap();
    assert_eq!(image.pixels, [Rgb::splat(0.25), Rgb::splat(4.0)]);

    let rgba = dir.path().join("rgba.exr");
    let data = [1.0, 2.0, 3.0, 0.5, 4.0, 5.0, 6.0, 1.0];
    oiio::write(
        &rgba,
        "exr",
        oiio::ImageToWrite {
            width: 2,
            height: 1,
            channels: &["R", "G", "B", "A"],
            data: &data,
            pixel_type: PixelType::Float,
            window: None,
            chromaticities: None,
        },
        &none,
    )
    .unwrap();
    let raw = oiio::read(&rgba).unwrap();
    assert_eq!(raw.channels, ["R", "G", "B", "A"]);
    assert_eq!(raw.data, data);
    let (image, _) = read_image(&rgba).unwrap();
    assert_eq!(
        image.pixels,
        [Rgb::new(1.0, 2.0, 3.0), Rgb::new(4.0, 5.0, 6.0)]
    );

    let grey_alpha = dir.path().join("ya.png");
    oiio::write(
        &grey_alpha,
        "png",
        oiio::ImageToWrite {
            width: 1,
            height: 1,
            channels: &["Y", "A"],
            data: &[0.6, 1.0],
            pixel_type: PixelType::U8,
            window: None,
            chromaticities: None,
        },
        &none,
    )
    .unwrap();
    let (image, _) = read_image(&grey_alpha).unwrap();
    let level = (0.6f32 * 255.0).round() / 255.0;
    assert_eq!(image.pixels.len(), 1);
    assert!((image.pixels[0] - Rgb::splat(level)).abs().max_element() < 1e-6);

    // 16-bit PNG, stored values as written.
    let deep = dir.path().join("deep.png");
    oiio::write(
        &deep,
        "png",
        oiio::ImageToWrite {
            width: 1,
            height: 1,
            channels: &["R", "G", "B"],
            data: &[0.0, 0.5, 1.0],
            pixel_type: PixelType::U16,
            window: None,
            chromaticities: None,
        },
        &none,
    )
    .unwrap();
    let raw = oiio::read(&deep).unwrap();
    assert_eq!(raw.pixel_type, Some(PixelType::U16));
    assert!((raw.data[1] - 0.5).abs() <= 0.5 / 65535.0);
}

#[test]
fn read_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.exr");
    let message = read_image(&missing).unwrap_err().to_string();
    assert!(
        message.starts_with(&format!("{}: ", missing.display())),
        "{message}"
    );
    let truncated = dir.path().join("truncated.exr");
    write_image(
        &truncated,
        &Image::new(64, 64),
        &Metadata::new(),
        &no_options(),
    )
    .unwrap();
    let bytes = fs::read(&truncated).unwrap();
    fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let message = read_image(&truncated).unwrap_err().to_string();
    assert!(
        message.starts_with(&format!("{}: ", truncated.display())),
        "{message}"
    );
    assert!(!message.contains('\n'), "{message}");
}

#[test]
fn version_is_the_installed_library() {
    let version = oiio::version().unwrap();
    let mut parts = version.split('.').map(|p| p.parse::<u32>().unwrap());
    let major = parts.next().unwrap();
    assert!(major >= 2, "{version}");
    assert_eq!(parts.count(), 2, "{version}");
    // `raylink --version` names the version built against without loading the library:
    // the same release series as the one loaded.
    let series = |v: &str| v.split('.').take(2).collect::<Vec<_>>().join(".");
    assert_eq!(series(oiio::built_with()), series(&version));
}

/// An independent check of the sRGB encoding: OpenImageIO's own linear-to-sRGB conversion
/// (via oiiotool) must give the same 8-bit levels. Skipped when oiiotool is not installed.
#[test]
fn png_matches_oiiotool_srgb_conversion() {
    let available = std::process::Command::new("oiiotool")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !available {
        eprintln!("skipped: oiiotool not found (apt-get install openimageio-tools)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mut rng = Rng(99);
    let values: Vec<f32> = (0..3 * 32 * 32).map(|_| rng.unit().powi(3)).collect();
    let image = image_from(32, 32, &values);
    let linear = dir.path().join("linear.exr");
    let ours = dir.path().join("ours.png");
    let theirs = dir.path().join("theirs.png");
    write_image(&linear, &image, &Metadata::new(), &no_options()).unwrap();
    write_image(&ours, &image, &Metadata::new(), &no_options()).unwrap();
    let status = std::process::Command::new("oiiotool")
        .arg(&linear)
        .args(["--colorconvert", "linear", "sRGB", "-d", "uint8", "-o"])
        .arg(&theirs)
        .status()
        .unwrap();
    assert!(status.success());
    let (a, _) = read_image(&ours).unwrap();
    let (b, _) = read_image(&theirs).unwrap();
    // Allow one level where float rounding lands either side of a half-level boundary.
    let mut differ = 0;
    for (x, y) in channels(&a).iter().zip(channels(&b)) {
        assert!((x - y).abs() <= 1.0 / 255.0 + 1e-6, "{x} vs {y}");
        if *x != y {
            differ += 1;
        }
    }
    assert!(
        differ <= values.len() / 100,
        "{differ} values differ by one level"
    );
}
