//! Writing render results: the format follows the output extension (case-insensitive),
//! 8-bit formats get exposure and the sRGB transfer function, and every write goes to a
//! temporary file in the target's directory that is renamed over the target only once it is
//! complete, so a failed write never leaves a partial file or clobbers an existing one.
//!
//! | extension | stored as |
//! |---|---|
//! | `.exr` | linear RGB, half or float ([`OutputOptions::half`]), metadata as header attributes, the colour space's `chromaticities`; optionally further [`Layer`]s (`albedo.R`, ...) |
//! | `.hdr` | linear RGB (RGBE: 8-bit mantissas, shared exponent; negatives and NaN become 0, values clamp at 1e38) |
//! | `.tif`, `.tiff` | linear RGB, 32-bit float |
//! | `.png` | `2^exposure`, sRGB-encoded, clamped to `[0, 1]`, 8 bits |
//! | `.jpg`, `.jpeg` | as PNG, JPEG quality 95 |
//!
//! The linear formats hold RGB in the output colour space ([`OutputOptions::color_space`]:
//! linear sRGB unless another is asked for); the 8-bit formats are always sRGB.
//!
//! A build without OpenImageIO (the portable build) writes `.exr`, `.hdr`, `.png` and `.jpg`.

use std::fs;
use std::io;
use std::path::Path;

use super::io::{self as image_io, PixelType};
use super::{Image, MetaValue, Metadata};
use crate::error::{Error, Result};
use crate::input_file::Allowance;
use crate::math::Rgb;
use crate::spectrum::ColorSpace;

/// The supported output formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Format {
    Exr,
    Hdr,
    Tiff,
    Png,
    Jpeg,
}

const SUPPORTED: &str = "use .exr, .hdr, .tif, .png or .jpg";

impl Format {
    /// The format for `path`'s extension (case-insensitive), or an error naming the path.
    pub(crate) fn from_path(path: &Path) -> Result<Format> {
        let Some(ext) = path.extension() else {
            return Err(Error::image(
                path,
                format!("no file extension to choose the output format from ({SUPPORTED})"),
            ));
        };
        let ext = ext.to_string_lossy();
        let format = match ext.to_ascii_lowercase().as_str() {
            "exr" => Format::Exr,
            "hdr" => Format::Hdr,
            "tif" | "tiff" => Format::Tiff,
            "png" => Format::Png,
            "jpg" | "jpeg" => Format::Jpeg,
            _ => {
                return Err(Error::image(
                    path,
                    format!("unsupported output format .{ext} ({SUPPORTED})"),
                ))
            }
        };
        if !cfg!(feature = "oiio") && format == Format::Tiff {
            return Err(Error::image(
                path,
                format!(
                    "output format .{ext} needs OpenImageIO, and this raylink was built \
                     without it (as the portable build is): use .exr, .hdr, .png or .jpg"
                ),
            ));
        }
        Ok(format)
    }

    /// The OpenImageIO writer's name.
    pub(crate) fn oiio_name(self) -> &'static str {
        match self {
            Format::Exr => "openexr",
            Format::Hdr => "hdr",
            Format::Tiff => "tiff",
            Format::Png => "png",
            Format::Jpeg => "jpeg",
        }
    }

    /// True for the 8-bit display formats (PNG, JPEG), which get exposure and sRGB encoding.
    pub(crate) fn is_display(self) -> bool {
        matches!(self, Format::Png | Format::Jpeg)
    }
}

/// How to encode an image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutputOptions {
    /// Exposure in stops for the 8-bit formats (PNG, JPEG): values are multiplied by
    /// `2^exposure` before sRGB encoding. The linear formats store the values unchanged.
    pub exposure: f32,
    /// Store EXR pixels as half floats instead of 32-bit floats.
    pub half: bool,
    /// The RGB primaries and white of the linear formats (EXR, HDR, TIFF): images are
    /// rendered in linear sRGB and converted on writing (pbrt-v4's film colour space; no
    /// chromatic adaptation, so ACES2065-1's D60 white sees sRGB's white as slightly blue).
    /// The 8-bit formats are always sRGB.
    pub color_space: &'static ColorSpace,
}

impl Default for OutputOptions {
    /// No exposure change, lossless 32-bit float EXR, linear sRGB.
    fn default() -> Self {
        OutputOptions {
            exposure: 0.0,
            half: false,
            color_space: ColorSpace::srgb(),
        }
    }
}

impl OutputOptions {
    /// The options of linear sRGB output with `exposure` and `half`.
    pub fn new(exposure: f32, half: bool) -> Self {
        OutputOptions {
            exposure,
            half,
            ..OutputOptions::default()
        }
    }
}

/// The colour space of `name` (pbrt-v4's names: "srgb", "rec2020", "dci-p3", "aces2065-1"),
/// or why not.
pub fn color_space_named(name: &str) -> std::result::Result<&'static ColorSpace, String> {
    ColorSpace::named(name).ok_or_else(|| {
        format!("\"{name}\" is not a colour space: use srgb, rec2020, dci-p3 or aces2065-1")
    })
}

/// The matrix taking linear sRGB to `space`'s linear RGB (through CIE XYZ), in f32.
pub fn matrix_from_srgb(space: &ColorSpace) -> glam::Mat3 {
    (space.rgb_from_xyz() * ColorSpace::srgb().xyz_from_rgb()).as_mat3()
}

/// `space`'s chromaticities as OpenEXR's `chromaticities` attribute holds them: red, green,
/// blue and white, x then y.
pub fn exr_chromaticities(space: &ColorSpace) -> [f32; 8] {
    let [r, g, b] = space.primaries;
    let w = space.white;
    [r.x, r.y, g.x, g.y, b.x, b.y, w.x, w.y].map(|v| v as f32)
}

/// The values of `image` in `space` (linear sRGB in).
fn in_color_space(image: &Image, space: &ColorSpace) -> Image {
    let m = matrix_from_srgb(space);
    let mut out = image.clone();
    for p in &mut out.pixels {
        *p = m * *p;
    }
    out
}

/// Checks, before rendering, that an image can be written to `path`: the extension is
/// supported, `path` is not a directory, and its parent directory exists, is a directory and
/// is writable (tested by creating and removing a temporary file).
pub fn check_output_path(path: &Path) -> Result<()> {
    if path.is_dir() {
        return Err(Error::image(path, "is a directory, not an image file"));
    }
    Format::from_path(path)?;
    let dir = parent_dir(path);
    match fs::metadata(dir) {
        Ok(meta) if meta.is_dir() => {}
        Ok(_) => {
            return Err(Error::image(
                path,
                format!("{} is not a directory", dir.display()),
            ))
        }
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            return Err(Error::image(
                path,
                format!("directory {} does not exist", dir.display()),
            ))
        }
        Err(e) => {
            return Err(Error::image(
                path,
                format!("cannot access directory {}: {e}", dir.display()),
            ))
        }
    }
    crate::atomic_file::remove_stale_temps(dir);
    match crate::atomic_file::Temporary::create(path) {
        // The probe is removed on drop (best effort: one that cannot be is harmless).
        Ok(probe) => {
            drop(probe);
            Ok(())
        }
        Err(e) => Err(Error::image(
            path,
            format!("directory {} is not writable ({e})", dir.display()),
        )),
    }
}

/// Writes `image` to `path` in the format its extension names, with `metadata` as file
/// attributes (EXR header attributes; other formats keep what they can). The file is encoded
/// in memory, written to a hidden temporary file next to `path`, synced, and renamed over
/// `path` only once complete ([`crate::atomic_file::write`]): on any failure the temporary
/// file is removed and an existing `path` is left untouched. A failure to write (a full disk)
/// is an [`Error::Io`] with the operating system's reason.
pub fn write_image(
    path: &Path,
    image: &Image,
    metadata: &[(String, MetaValue)],
    options: &OutputOptions,
) -> Result<()> {
    write_image_impl(path, image, None, &[], metadata, options)
}

/// An image stored as a layer of an EXR file beside the main image: channels
/// `NAME.CHANNEL`, one for each of `channels`, taken in order from the image's R, G and B.
#[derive(Clone, Copy, Debug)]
pub struct Layer<'a> {
    /// The layer's name, e.g. `albedo`.
    pub name: &'a str,
    /// Its channels' names, one to three, e.g. `["R", "G", "B"]` or `["Z"]`.
    pub channels: &'a [&'a str],
    pub image: &'a Image,
}

/// As [`write_image`], with `layers` as further channels of the same file (`albedo.R`,
/// `albedo.G`, ..., after the main image's `R`, `G`, `B`), the layout of a multilayer
/// OpenEXR file that compositors read as passes. Only `.exr` holds layers: other formats
/// get the main image alone. Every layer must be the size of `image`.
pub fn write_image_layers(
    path: &Path,
    image: &Image,
    layers: &[Layer],
    metadata: &[(String, MetaValue)],
    options: &OutputOptions,
) -> Result<()> {
    if Format::from_path(path)? != Format::Exr {
        return write_image_impl(path, image, None, &[], metadata, options);
    }
    write_image_impl(path, image, None, layers, metadata, options)
}

/// As [`write_image`], for `image` as the region at (`window.x`, `window.y`) of a
/// `window.full_width` x `window.full_height` image (a render tile): only OpenEXR, which keeps
/// the region as its data window and the full image as its display window.
pub fn write_image_window(
    path: &Path,
    image: &Image,
    window: image_io::Window,
    metadata: &[(String, MetaValue)],
    options: &OutputOptions,
) -> Result<()> {
    if Format::from_path(path)? != Format::Exr {
        return Err(Error::image(
            path,
            "a part of an image (tile or crop) is written only as .exr, which keeps where it lies",
        ));
    }
    write_image_impl(path, image, Some(window), &[], metadata, options)
}

fn write_image_impl(
    path: &Path,
    image: &Image,
    window: Option<image_io::Window>,
    layers: &[Layer],
    metadata: &[(String, MetaValue)],
    options: &OutputOptions,
) -> Result<()> {
    check_output_path(path)?;
    let format = Format::from_path(path)?;
    let expected = image.width as usize * image.height as usize;
    let bad_layer = layers.iter().any(|l| {
        (l.image.width, l.image.height) != (image.width, image.height)
            || l.image.pixels.len() != expected
            || !(1..=3).contains(&l.channels.len())
    });
    if image.width == 0 || image.height == 0 || image.pixels.len() != expected || bad_layer {
        return Err(Error::image(
            path,
            format!(
                "internal error: cannot write a {}x{} image with {} pixels",
                image.width,
                image.height,
                image.pixels.len()
            ),
        ));
    }

    let mut attributes = metadata.to_vec();
    // The linear formats take the output colour space; colour layers (R, G, B: albedo,
    // light passes) with the image, not the variance of its channels (which a change of
    // primaries mixes) nor single channels.
    let converted;
    let converted_layers: Vec<Image>;
    let mut layers = layers.to_vec();
    let mut chromaticities = None;
    let image = if !format.is_display() && options.color_space != ColorSpace::srgb() {
        let space = options.color_space;
        chromaticities = Some(exr_chromaticities(space));
        attributes.push((
            "raylink:color_space".into(),
            MetaValue::Str(space.name.into()),
        ));
        converted = in_color_space(image, space);
        let colour = |l: &Layer| l.channels == ["R", "G", "B"] && l.name != "variance";
        converted_layers = layers
            .iter()
            .filter(|l| colour(l))
            .map(|l| in_color_space(l.image, space))
            .collect();
        let mut next = converted_layers.iter();
        for l in layers.iter_mut().filter(|l| colour(l)) {
            l.image = next.next().expect("one converted image per colour layer");
        }
        &converted
    } else {
        image
    };
    let layers = &layers[..];
    let (data, pixel) = if format.is_display() {
        attributes.push(("oiio:ColorSpace".into(), MetaValue::Str("sRGB".into())));
        if format == Format::Jpeg {
            attributes.push(("Compression".into(), MetaValue::Str("jpeg:95".into())));
        }
        let scale = options.exposure.exp2();
        (display_values(path, &image.pixels, scale)?, PixelType::U8)
    } else {
        let pixel = if format == Format::Exr && options.half {
            PixelType::Half
        } else {
            PixelType::Float
        };
        let mut values = if layers.is_empty() {
            linear_values(path, &image.pixels)?
        } else {
            layered_values(path, image, layers)?
        };
        if format == Format::Hdr {
            // OpenImageIO's RGBE encoder mangles what RGBE cannot hold: a negative channel
            // comes back as garbage (-0.5 as 0.5), a channel above ~1.7e38 zeroes the pixel.
            for v in &mut values {
                *v = hdr_value(*v);
            }
        }
        (values, pixel)
    };

    let names: Vec<String> = layers
        .iter()
        .flat_map(|l| l.channels.iter().map(move |c| format!("{}.{c}", l.name)))
        .collect();
    let channels: Vec<&str> = ["R", "G", "B"]
        .into_iter()
        .chain(names.iter().map(String::as_str))
        .collect();
    let encoded = image_io::encode(
        path,
        format.oiio_name(),
        image_io::ImageToWrite {
            width: image.width,
            height: image.height,
            channels: &channels,
            data: &data,
            pixel_type: pixel,
            window,
            chromaticities,
        },
        &attributes,
    )?;
    // The encoded bytes replace `path` only once they are all on disk.
    drop(data);
    crate::atomic_file::write(path, encoded.bytes())
}

/// Reads an image as RGB: `R`, `G`, `B` channels if present, otherwise one channel is
/// replicated, two (grey and alpha) use the first, and more use the first three (dropping
/// alpha). Values are returned as stored: PNG and JPEG values are sRGB-encoded (apply
/// [`srgb_decode`] for linear values). Also returns the file's metadata. The machine's
/// default memory budget bounds the reading ([`read_image_within`]).
pub fn read_image(path: &Path) -> Result<(Image, Metadata)> {
    read_image_within(path, &Allowance::machine())
}

/// [`read_image`] within `allowance`: the file and the size its header declares are checked
/// ([`image_io::read_within`]) before any pixel is read.
pub fn read_image_within(path: &Path, allowance: &Allowance) -> Result<(Image, Metadata)> {
    let raw = image_io::read_within(path, allowance)?;
    let n = raw.channels.len();
    let find = |name: &str| raw.channels.iter().position(|c| c == name);
    let picks = match (find("R"), find("G"), find("B")) {
        (Some(r), Some(g), Some(b)) => [r, g, b],
        _ if n < 3 => [0, 0, 0],
        _ => [0, 1, 2],
    };
    let pixels = raw
        .data
        .chunks_exact(n)
        .map(|p| Rgb::new(p[picks[0]], p[picks[1]], p[picks[2]]))
        .collect();
    let image = Image {
        width: raw.width,
        height: raw.height,
        pixels,
    };
    Ok((image, raw.metadata))
}

/// The sRGB transfer function (IEC 61966-2-1), linear to encoded; values outside `[0, 1]`
/// follow the same formula (negative values stay on the linear segment), NaN stays NaN.
pub fn srgb_encode(linear: f32) -> f32 {
    if linear <= 0.003_130_8 {
        linear * 12.92
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// The inverse of [`srgb_encode`], encoded to linear.
pub fn srgb_decode(encoded: f32) -> f32 {
    if encoded <= 0.040_45 {
        encoded / 12.92
    } else {
        ((encoded + 0.055) / 1.055).powf(2.4)
    }
}

/// One channel for an 8-bit display format: scaled, sRGB-encoded, clamped and quantised to
/// a multiple of 1/255 (round to nearest), so the conversion to 8 bits is exact. NaN gives 0.
pub(crate) fn display_value(linear: f32, scale: f32) -> f32 {
    let encoded = srgb_encode(linear * scale);
    if encoded.is_nan() {
        return 0.0;
    }
    (encoded.clamp(0.0, 1.0) * 255.0).round() / 255.0
}

/// One channel for RGBE (`.hdr`): negatives and NaN become 0, large values clamp to 1e38.
pub(crate) fn hdr_value(linear: f32) -> f32 {
    if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, HDR_MAX)
    }
}

/// Below 2^127, the largest power of two RGBE's exponent byte can hold.
const HDR_MAX: f32 = 1.0e38;

/// The values to encode, three a pixel; [`Error::OutOfMemory`] if there is no room for them.
fn channel_values(path: &Path, pixels: &[Rgb], f: impl Fn(f32) -> f32) -> Result<Vec<f32>> {
    let mut values = Vec::new();
    crate::platform::try_reserve(&mut values, pixels.len() * 3, || {
        format!("the pixels of {}", path.display())
    })?;
    values.extend(pixels.iter().flat_map(|p| [p.x, p.y, p.z]).map(f));
    Ok(values)
}

/// The main image's R, G, B and then each layer's channels, pixel by pixel.
fn layered_values(path: &Path, image: &Image, layers: &[Layer]) -> Result<Vec<f32>> {
    let per_pixel = 3 + layers.iter().map(|l| l.channels.len()).sum::<usize>();
    let mut values = Vec::new();
    crate::platform::try_reserve(&mut values, image.pixels.len() * per_pixel, || {
        format!("the pixels of {}", path.display())
    })?;
    for (i, p) in image.pixels.iter().enumerate() {
        values.extend([p.x, p.y, p.z]);
        for l in layers {
            let q = l.image.pixels[i];
            values.extend(&[q.x, q.y, q.z][..l.channels.len()]);
        }
    }
    Ok(values)
}

fn display_values(path: &Path, pixels: &[Rgb], scale: f32) -> Result<Vec<f32>> {
    channel_values(path, pixels, |v| display_value(v, scale))
}

fn linear_values(path: &Path, pixels: &[Rgb]) -> Result<Vec<f32>> {
    channel_values(path, pixels, |v| v)
}

/// The directory holding `path` (`.` for a bare file name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atomic_file::temp_path;

    #[test]
    fn formats_by_extension_case_insensitive() {
        let f = |p: &str| Format::from_path(Path::new(p));
        assert_eq!(f("a.exr").unwrap(), Format::Exr);
        assert_eq!(f("dir/a.EXR").unwrap(), Format::Exr);
        assert_eq!(f("a.Hdr").unwrap(), Format::Hdr);
        assert_eq!(f("a.tif").unwrap(), Format::Tiff);
        assert_eq!(f("a.TIFF").unwrap(), Format::Tiff);
        assert_eq!(f("a.png").unwrap(), Format::Png);
        assert_eq!(f("a.jpg").unwrap(), Format::Jpeg);
        assert_eq!(f("a.JPEG").unwrap(), Format::Jpeg);
        assert_eq!(
            f("x.bmp").unwrap_err().to_string(),
            "x.bmp: unsupported output format .bmp (use .exr, .hdr, .tif, .png or .jpg)"
        );
        assert!(f("x")
            .unwrap_err()
            .to_string()
            .starts_with("x: no file extension"));
        assert!(f("x.png.gz").is_err());
    }

    #[test]
    fn srgb_known_values() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        // Reference values from the IEC 61966-2-1 formula evaluated in double precision.
        assert!((srgb_encode(0.5) - 0.735_357).abs() < 1e-6);
        assert!((srgb_encode(0.18) - 0.461_356_1).abs() < 1e-6);
        assert!((srgb_encode(0.002) - 0.025_84).abs() < 1e-7);
        assert!((srgb_decode(0.5) - 0.214_041_14).abs() < 1e-6);
    }

    #[test]
    fn srgb_round_trips_and_is_monotonic() {
        let mut previous = -1.0;
        for i in 0..=1000 {
            let x = i as f32 / 1000.0;
            let e = srgb_encode(x);
            assert!(e > previous, "not increasing at {x}");
            previous = e;
            assert!((srgb_decode(e) - x).abs() < 1e-5, "{x}");
        }
        // The two pieces meet (continuity at the breakpoint).
        let b = 0.003_130_8f32;
        assert!((b * 12.92 - (1.055 * b.powf(1.0 / 2.4) - 0.055)).abs() < 1e-5);
    }

    #[test]
    fn display_values_clamp_and_quantise() {
        assert_eq!(display_value(0.0, 1.0), 0.0);
        assert_eq!(display_value(1.0, 1.0), 1.0);
        assert_eq!(display_value(7.0, 1.0), 1.0);
        assert_eq!(display_value(-3.0, 1.0), 0.0);
        assert_eq!(display_value(f32::NAN, 1.0), 0.0);
        assert_eq!(display_value(f32::INFINITY, 1.0), 1.0);
        // 0.5 linear -> 0.7354 encoded -> 187.52 -> 188.
        assert_eq!(display_value(0.5, 1.0), 188.0 / 255.0);
        // One stop of exposure doubles the linear value.
        assert_eq!(display_value(0.25, 2.0), display_value(0.5, 1.0));
    }

    #[test]
    fn temp_paths_are_hidden_unique_and_alongside() {
        let a = temp_path(Path::new("out/x.exr"));
        let b = temp_path(Path::new("out/x.exr"));
        assert_ne!(a, b);
        assert_eq!(a.parent(), Some(Path::new("out")));
        let name = a.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            name.starts_with(".raylink-tmp-") && name.ends_with(".exr"),
            "{name}"
        );
        assert_eq!(temp_path(Path::new("x.png")).parent(), Some(Path::new(".")));
    }

    #[test]
    fn check_output_path_messages() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("out").join("x.exr");
        let e = check_output_path(&missing).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "{}: directory {} does not exist",
                missing.display(),
                dir.path().join("out").display()
            )
        );
        let file = dir.path().join("file");
        fs::write(&file, b"x").unwrap();
        let under_file = file.join("x.png");
        let e = check_output_path(&under_file).unwrap_err().to_string();
        assert!(e.ends_with("file is not a directory"), "{e}");
        let as_dir = dir.path().join("d.exr");
        fs::create_dir(&as_dir).unwrap();
        let e = check_output_path(&as_dir).unwrap_err().to_string();
        assert!(e.ends_with("is a directory, not an image file"), "{e}");
        check_output_path(&dir.path().join("ok.PNG")).unwrap();
        // No probe files are left behind.
        let mut names: Vec<_> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        names.sort();
        assert_eq!(names, vec!["d.exr", "file"]);
    }
}
