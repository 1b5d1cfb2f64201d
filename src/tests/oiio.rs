//! The OpenImageIO wrapper (`image::oiio`): bad arguments are errors, never panics or
//! files.

use crate::image::oiio::*;
use crate::image::{MetaValue, Metadata};
use std::path::Path;

#[test]
fn version_looks_like_a_version() {
    let v = version().unwrap();
    let parts: Vec<&str> = v.split('.').collect();
    assert_eq!(parts.len(), 3, "{v}");
    assert!(parts.iter().all(|p| p.parse::<u32>().is_ok()), "{v}");
    assert!(parts[0].parse::<u32>().unwrap() >= 2, "{v}");
}

#[test]
fn nul_bytes_are_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    let ok = dir.path().join("a.exr");
    let rgb = ["R", "G", "B"];
    // A 1x1 float write where exactly one of the strings carries a NUL byte.
    let write_nul = |path: &Path, format: &str, channels: &[&str], meta: &Metadata| {
        let e = write(
            path,
            format,
            ImageToWrite {
                width: 1,
                height: 1,
                channels,
                data: &[0.0; 3],
                pixel_type: PixelType::Float,
                window: None,
                chromaticities: None,
            },
            meta,
        );
        assert!(e.unwrap_err().to_string().contains("NUL"));
    };
    let bad_path = Path::new("a\0b.exr");
    write_nul(bad_path, "exr", &rgb, &Metadata::new());
    assert!(read(bad_path).unwrap_err().to_string().contains("NUL"));
    write_nul(&ok, "ex\0r", &rgb, &Metadata::new());
    write_nul(&ok, "exr", &["R", "G\0", "B"], &Metadata::new());
    write_nul(
        &ok,
        "exr",
        &rgb,
        &vec![("a\0b".to_string(), MetaValue::Int(1))],
    );
    write_nul(
        &ok,
        "exr",
        &rgb,
        &vec![("a".to_string(), MetaValue::Str("x\0y".into()))],
    );
    assert!(!ok.exists());
}

#[test]
fn bad_sizes_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.exr");
    let meta = Metadata::new();
    let rgb = ["R", "G", "B"];
    let e = write(
        &path,
        "exr",
        ImageToWrite {
            width: 2,
            height: 2,
            channels: &rgb,
            data: &[0.0; 11],
            pixel_type: PixelType::Float,
            window: None,
            chromaticities: None,
        },
        &meta,
    );
    assert!(e.unwrap_err().to_string().contains("11 values"));
    let e = write(
        &path,
        "exr",
        ImageToWrite {
            width: 0,
            height: 2,
            channels: &rgb,
            data: &[],
            pixel_type: PixelType::Float,
            window: None,
            chromaticities: None,
        },
        &meta,
    );
    assert!(e.unwrap_err().to_string().contains("0x2"));
    let e = write(
        &path,
        "exr",
        ImageToWrite {
            width: 1,
            height: 1,
            channels: &[],
            data: &[],
            pixel_type: PixelType::Float,
            window: None,
            chromaticities: None,
        },
        &meta,
    );
    assert!(e.is_err());
    let huge = u32::MAX;
    let e = write(
        &path,
        "exr",
        ImageToWrite {
            width: huge,
            height: 1,
            channels: &rgb,
            data: &[0.0; 3],
            pixel_type: PixelType::Float,
            window: None,
            chromaticities: None,
        },
        &meta,
    );
    assert!(e.is_err());
    assert!(!path.exists());
}

#[test]
fn unknown_format_reports_oiio_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.exr");
    let e = write(
        &path,
        "nosuchformat",
        ImageToWrite {
            width: 1,
            height: 1,
            channels: &["Y"],
            data: &[0.5],
            pixel_type: PixelType::Float,
            window: None,
            chromaticities: None,
        },
        &Metadata::new(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("nosuchformat"), "{e}");
    assert!(e.starts_with(&path.display().to_string()), "{e}");
    assert!(!e.contains('\n'), "{e}");
    assert!(!path.exists());
}

#[test]
fn reading_a_missing_or_bad_file_fails_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.exr");
    let e = read(&missing).unwrap_err().to_string();
    assert!(e.starts_with(&missing.display().to_string()), "{e}");
    let garbage = dir.path().join("garbage.exr");
    std::fs::write(&garbage, b"this is not an image").unwrap();
    let e = read(&garbage).unwrap_err().to_string();
    assert!(e.starts_with(&garbage.display().to_string()), "{e}");
    assert!(!e.contains('\n'), "{e}");
}

#[test]
fn format_is_independent_of_the_extension() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(".x.png.tmp-1");
    let data = [0.0f32, 0.5, 1.0, 0.25];
    let meta = Metadata::new();
    write(
        &path,
        "png",
        ImageToWrite {
            width: 2,
            height: 2,
            channels: &["Y"],
            data: &data,
            pixel_type: PixelType::U8,
            window: None,
            chromaticities: None,
        },
        &meta,
    )
    .unwrap();
    let raw = read(&path).unwrap();
    assert_eq!(raw.format, "png");
    assert_eq!(raw.pixel_type, Some(PixelType::U8));
    assert_eq!((raw.width, raw.height), (2, 2));
    assert_eq!(raw.channels, vec!["Y".to_string()]);
    assert_eq!(raw.data[0], 0.0);
    assert_eq!(raw.data[2], 1.0);
    // 0.5 * 255 = 127.5 rounds to 128. (OIIO reads level k as k * (1/255), which may
    // differ from k / 255 in the last bit.)
    assert!(
        (raw.data[1] - 128.0 / 255.0).abs() < 1e-6,
        "{}",
        raw.data[1]
    );
    // "exr" as an extension-like name, "tiff" as a format name.
    let exr = dir.path().join("noext");
    write(
        &exr,
        "exr",
        ImageToWrite {
            width: 2,
            height: 2,
            channels: &["Y"],
            data: &data,
            pixel_type: PixelType::Float,
            window: None,
            chromaticities: None,
        },
        &meta,
    )
    .unwrap();
    assert_eq!(read(&exr).unwrap().format, "openexr");
    let tif = dir.path().join("tif.exr");
    write(
        &tif,
        "tiff",
        ImageToWrite {
            width: 2,
            height: 2,
            channels: &["Y"],
            data: &data,
            pixel_type: PixelType::U16,
            window: None,
            chromaticities: None,
        },
        &meta,
    )
    .unwrap();
    let raw = read(&tif).unwrap();
    assert_eq!(raw.format, "tiff");
    assert_eq!(raw.pixel_type, Some(PixelType::U16));
}
