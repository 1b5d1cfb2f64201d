//! Image files in pure Rust: OpenEXR through `exr`, PNG through `png`, JPEG and Radiance HDR
//! (RGBE) through `image`. These read and write
//! images in a build without OpenImageIO (the portable build, see [`super::io`]); with
//! OpenImageIO they are there too, so that each library can read what the other writes.
//!
//! EXR: any named float channels (so the extra layers of [`super::output::Layer`], as
//! `albedo.R`), half or 32-bit float, ZIP-compressed scanlines, the data window inside the
//! display window, string, integer and float header attributes. PNG: 1 to 4 channels (`Y`,
//! `Y A`, `R G B`, `R G B A`), 8 or 16 bits, metadata as text chunks. JPEG: 8-bit `Y` or
//! `R G B` read, `R G B` written at quality 95 (as OpenImageIO's `jpeg:95`), no metadata.
//! HDR: `R G B` floats in RGBE, no metadata.

use std::io::Cursor;
use std::path::Path;

use exr::prelude::{self as x, ReadChannels, ReadLayers, WritableImage};

use super::io::{check_declared, ImageToWrite, PixelType, RawImage, Window};
use super::{MetaValue, Metadata};
use crate::error::{Error, Result};
use crate::input_file::{self, Allowance};

/// The formats these codecs write, for messages.
const WRITES: &str = "without OpenImageIO raylink writes .exr, .png, .jpg and .hdr";

/// Encodes `image` as an EXR (`format` `"openexr"` or `"exr"`) or PNG (`"png"`) file in
/// memory; `path` only names the file in messages.
pub fn encode(
    path: &Path,
    format: &str,
    image: ImageToWrite,
    metadata: &Metadata,
) -> Result<Vec<u8>> {
    let nchannels = image.channels.len();
    let expected = (image.width as usize)
        .checked_mul(image.height as usize)
        .and_then(|n| n.checked_mul(nchannels));
    if image.width == 0 || image.height == 0 || nchannels == 0 || expected != Some(image.data.len())
    {
        return Err(Error::image(
            path,
            format!(
                "internal error: {} values given for {}x{} pixels of {nchannels} channels",
                image.data.len(),
                image.width,
                image.height
            ),
        ));
    }
    match format {
        "openexr" | "exr" => encode_exr(path, image, metadata),
        "png" | "jpeg" | "jpg" | "hdr" if image.window.is_some() => Err(Error::image(
            path,
            "a part of an image is written only as EXR",
        )),
        "png" => encode_png(path, image, metadata),
        "jpeg" | "jpg" => encode_jpeg(path, image),
        "hdr" => encode_hdr(path, image),
        other => Err(Error::image(
            path,
            format!("cannot write the {other} format: {WRITES}"),
        )),
    }
}

/// Header attributes OpenEXR itself defines (or `exr` writes from its own fields): metadata
/// of these names is not written as an extra attribute, which would clash with them.
const EXR_RESERVED: [&str; 14] = [
    "channels",
    "compression",
    "dataWindow",
    "displayWindow",
    "lineOrder",
    "pixelAspectRatio",
    "screenWindowCenter",
    "screenWindowWidth",
    "tiles",
    "type",
    "name",
    "version",
    "chunkCount",
    "maxSamplesPerPixel",
];

fn encode_exr(path: &Path, image: ImageToWrite, metadata: &Metadata) -> Result<Vec<u8>> {
    let n = image.channels.len();
    let text = |what: &str, s: &str| {
        x::Text::new_or_none(s)
            .filter(|_| !s.is_empty())
            .ok_or_else(|| Error::image(path, format!("{what} {s:?} cannot be stored in EXR")))
    };
    let mut channels = x::SmallVec::new();
    for (c, name) in image.channels.iter().enumerate() {
        let values = image.data.iter().skip(c).step_by(n);
        let samples = match image.pixel_type {
            PixelType::Half => x::FlatSamples::F16(values.map(|&v| x::f16::from_f32(v)).collect()),
            _ => x::FlatSamples::F32(values.copied().collect()),
        };
        channels.push(x::AnyChannel::new(text("channel name", name)?, samples));
    }
    let (width, height) = (image.width as usize, image.height as usize);
    let mut attributes = x::LayerAttributes::default();
    let mut display = x::IntegerBounds::new((0, 0), (width, height));
    if let Some(window) = image.window {
        let full = (window.full_width as usize, window.full_height as usize);
        let fits = window.full_x == 0
            && window.full_y == 0
            && window.x >= 0
            && window.y >= 0
            && window.x as usize + width <= full.0
            && window.y as usize + height <= full.1;
        if !fits {
            return Err(Error::image(
                path,
                format!(
                    "a {width}x{height} region at ({}, {}) does not fit in a {}x{} image",
                    window.x, window.y, full.0, full.1
                ),
            ));
        }
        attributes.layer_position = x::Vec2(window.x, window.y);
        display = x::IntegerBounds::new((0, 0), full);
    }
    for (name, value) in metadata {
        if EXR_RESERVED.contains(&name.as_str()) || name.starts_with("oiio:") {
            continue;
        }
        let value = match value {
            MetaValue::Str(s) => x::AttributeValue::Text(text(&format!("metadata {name}"), s)?),
            MetaValue::Int(i) => x::AttributeValue::I32(*i),
            MetaValue::Float(f) => x::AttributeValue::F32(*f),
        };
        attributes.other.insert(text("metadata name", name)?, value);
    }
    let encoding = x::Encoding {
        compression: x::Compression::ZIP16,
        blocks: x::Blocks::ScanLines,
        line_order: x::LineOrder::Increasing,
    };
    let layer = x::Layer::new(
        (width, height),
        attributes,
        encoding,
        x::AnyChannels::sort(channels),
    );
    let mut exr_image = x::Image::from_layer(layer);
    exr_image.attributes.display_window = display;
    if let Some(c) = image.chromaticities {
        exr_image.attributes.chromaticities = Some(exr::meta::attribute::Chromaticities {
            red: x::Vec2(c[0], c[1]),
            green: x::Vec2(c[2], c[3]),
            blue: x::Vec2(c[4], c[5]),
            white: x::Vec2(c[6], c[7]),
        });
    }
    let mut bytes = Cursor::new(Vec::new());
    exr_image
        .write()
        .to_buffered(&mut bytes)
        .map_err(|e| Error::image(path, format!("cannot encode as EXR: {e}")))?;
    Ok(bytes.into_inner())
}

fn encode_png(path: &Path, image: ImageToWrite, metadata: &Metadata) -> Result<Vec<u8>> {
    let color = match image.channels.len() {
        1 => png::ColorType::Grayscale,
        2 => png::ColorType::GrayscaleAlpha,
        3 => png::ColorType::Rgb,
        4 => png::ColorType::Rgba,
        n => {
            return Err(Error::image(
                path,
                format!("PNG holds 1 to 4 channels, not {n}"),
            ))
        }
    };
    let sixteen = image.pixel_type == PixelType::U16;
    // Floats to integers as OpenImageIO converts them: [0, 1] scaled to the full range,
    // rounded half up, clamped (NaN becomes 0).
    let data: Vec<u8> = if sixteen {
        image
            .data
            .iter()
            .flat_map(|&v| ((v * 65535.0 + 0.5).clamp(0.0, 65535.0) as u16).to_be_bytes())
            .collect()
    } else {
        to_8_bit(image.data)
    };
    let failed = |e: png::EncodingError| Error::image(path, format!("cannot encode as PNG: {e}"));
    let mut bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut bytes, image.width, image.height);
        encoder.set_color(color);
        encoder.set_depth(if sixteen {
            png::BitDepth::Sixteen
        } else {
            png::BitDepth::Eight
        });
        if metadata
            .iter()
            .any(|(n, v)| n == "oiio:ColorSpace" && *v == MetaValue::Str("sRGB".into()))
        {
            encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        }
        for (name, value) in metadata {
            if name.starts_with("oiio:") || name == "Compression" {
                continue;
            }
            let text = match value {
                MetaValue::Str(s) => s.clone(),
                MetaValue::Int(i) => i.to_string(),
                MetaValue::Float(f) => f.to_string(),
            };
            encoder.add_text_chunk(name.clone(), text).map_err(failed)?;
        }
        let mut writer = encoder.write_header().map_err(failed)?;
        writer.write_image_data(&data).map_err(failed)?;
        writer.finish().map_err(failed)?;
    }
    Ok(bytes)
}

/// Floats to bytes as OpenImageIO converts them: [0, 1] scaled to the full range, rounded
/// half up, clamped (NaN becomes 0).
fn to_8_bit(values: &[f32]) -> Vec<u8> {
    values
        .iter()
        .map(|&v| (v * 255.0 + 0.5).clamp(0.0, 255.0) as u8)
        .collect()
}

/// Bytes to floats times the reciprocal, as OpenImageIO converts: the same floats from
/// either library.
fn from_8_bit(bytes: &[u8]) -> Vec<f32> {
    bytes.iter().map(|&b| b as f32 * (1.0 / 255.0)).collect()
}

/// The three channels `R G B` of `image`, or the refusal naming the format.
fn rgb_only(path: &Path, image: &ImageToWrite, format: &str) -> Result<()> {
    if image.channels != ["R", "G", "B"] {
        return Err(Error::image(
            path,
            format!(
                "{format} holds R, G and B, not {}",
                image.channels.join(", ")
            ),
        ));
    }
    Ok(())
}

fn encode_jpeg(path: &Path, image: ImageToWrite) -> Result<Vec<u8>> {
    rgb_only(path, &image, "JPEG")?;
    let data = to_8_bit(image.data);
    let mut bytes = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, 95)
        .encode(
            &data,
            image.width,
            image.height,
            image::ExtendedColorType::Rgb8,
        )
        .map_err(|e| Error::image(path, format!("cannot encode as JPEG: {e}")))?;
    Ok(bytes)
}

fn encode_hdr(path: &Path, image: ImageToWrite) -> Result<Vec<u8>> {
    use image::ImageEncoder;
    rgb_only(path, &image, "HDR")?;
    let floats: Vec<u8> = image.data.iter().flat_map(|v| v.to_ne_bytes()).collect();
    let mut bytes = Vec::new();
    image::codecs::hdr::HdrEncoder::new(&mut bytes)
        .write_image(
            &floats,
            image.width,
            image.height,
            image::ExtendedColorType::Rgb32F,
        )
        .map_err(|e| Error::image(path, format!("cannot encode as HDR: {e}")))?;
    Ok(bytes)
}

/// Reads the EXR or PNG file at `path` (told apart by their first bytes) as
/// [`super::io::read_within`] says: the file is bad input unless it is a regular file within
/// the limit on images whose header declares a size within the limits and `allowance`.
pub fn read_within(path: &Path, allowance: &Allowance) -> Result<RawImage> {
    let bytes =
        input_file::read(path, &input_file::IMAGE, Some(allowance)).map_err(|e| match e {
            Error::Io { source, .. } => {
                Error::input(path, format!("cannot open for reading: {source}"))
            }
            e => e,
        })?;
    if bytes.is_empty() {
        return Err(Error::input(path, "empty file (0 bytes), not an image"));
    }
    if bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        read_exr(path, &bytes, allowance)
    } else if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        read_png(path, &bytes, allowance)
    } else if bytes.starts_with(&[0xff, 0xd8, 0xff]) {
        read_jpeg(path, &bytes, allowance)
    } else if bytes.starts_with(b"#?") {
        read_hdr(path, &bytes, allowance)
    } else {
        Err(Error::input(
            path,
            "not an EXR, PNG, JPEG or HDR file (without OpenImageIO raylink reads only these)",
        ))
    }
}

fn read_exr(path: &Path, bytes: &[u8], allowance: &Allowance) -> Result<RawImage> {
    let bad = |e: x::Error| Error::input(path, format!("cannot read as EXR: {e}"));
    let meta = x::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(bad)?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| Error::input(path, "an EXR file with no image in it"))?;
    let to_u32 = |v: usize| u32::try_from(v).unwrap_or(u32::MAX);
    check_declared(
        path,
        to_u32(header.layer_size.0),
        to_u32(header.layer_size.1),
        to_u32(header.channels.list.len()),
        allowance,
    )?;
    let image = x::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(bad)?;
    let layer = image.layer_data;
    let (width, height) = (layer.size.0, layer.size.1);
    // R, G, B and A first, as OpenImageIO orders them, then the rest in the file's order.
    let rank = |name: &str| {
        ["R", "G", "B", "A"]
            .iter()
            .position(|&c| c == name)
            .unwrap_or(4)
    };
    let mut list: Vec<_> = layer.channel_data.list.iter().collect();
    list.sort_by_key(|c| rank(&c.name.to_string()));
    let n = list.len();
    let mut data = vec![0.0f32; width * height * n];
    for (c, channel) in list.iter().enumerate() {
        for (i, v) in channel.sample_data.values_as_f32().enumerate() {
            data[i * n + c] = v;
        }
    }
    let pixel_type = match list.first().map(|c| &c.sample_data) {
        Some(x::FlatSamples::F16(_)) => Some(PixelType::Half),
        Some(x::FlatSamples::F32(_)) => Some(PixelType::Float),
        _ => None,
    };
    let mut metadata = Metadata::new();
    let others = image.attributes.other.iter().chain(&layer.attributes.other);
    for (name, value) in others {
        let value = match value {
            x::AttributeValue::Text(t) => MetaValue::Str(t.to_string()),
            x::AttributeValue::I32(i) => MetaValue::Int(*i),
            x::AttributeValue::F32(f) => MetaValue::Float(*f),
            x::AttributeValue::F64(f) => MetaValue::Float(*f as f32),
            _ => continue,
        };
        metadata.push((name.to_string(), value));
    }
    metadata.sort_by(|a, b| a.0.cmp(&b.0));
    let display = image.attributes.display_window;
    Ok(RawImage {
        width: width as u32,
        height: height as u32,
        channels: list.iter().map(|c| c.name.to_string()).collect(),
        data,
        metadata,
        format: "openexr".into(),
        pixel_type,
        window: Window {
            x: layer.attributes.layer_position.0,
            y: layer.attributes.layer_position.1,
            full_x: display.position.0,
            full_y: display.position.1,
            full_width: to_u32(display.size.0),
            full_height: to_u32(display.size.1),
        },
    })
}

fn read_png(path: &Path, bytes: &[u8], allowance: &Allowance) -> Result<RawImage> {
    let bad = |e: png::DecodingError| Error::input(path, format!("cannot read as PNG: {e}"));
    let mut decoder = png::Decoder::new(Cursor::new(bytes));
    // Palettes and bit depths below 8 become 8-bit channels; 16 bits stay 16.
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(bad)?;
    let (color, depth) = reader.output_color_type();
    let channels: &[&str] = match color {
        png::ColorType::Grayscale => &["Y"],
        png::ColorType::GrayscaleAlpha => &["Y", "A"],
        png::ColorType::Rgba => &["R", "G", "B", "A"],
        _ => &["R", "G", "B"],
    };
    let (width, height) = (reader.info().width, reader.info().height);
    check_declared(path, width, height, channels.len() as u32, allowance)?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| Error::input(path, "a PNG image too large to hold"))?;
    let mut buffer = vec![0u8; size];
    let frame = reader.next_frame(&mut buffer).map_err(bad)?;
    buffer.truncate(frame.buffer_size());
    let sixteen = depth == png::BitDepth::Sixteen;
    // Times the reciprocal, as OpenImageIO converts: the same floats from either library.
    let data: Vec<f32> = if sixteen {
        buffer
            .chunks_exact(2)
            .map(|b| u16::from_be_bytes([b[0], b[1]]) as f32 * (1.0 / 65535.0))
            .collect()
    } else {
        from_8_bit(&buffer)
    };
    let expected = width as usize * height as usize * channels.len();
    if data.len() != expected {
        return Err(Error::input(
            path,
            "a PNG image whose pixels do not fill it",
        ));
    }
    let info = reader.info();
    let metadata = info
        .uncompressed_latin1_text
        .iter()
        .map(|t| (t.keyword.clone(), MetaValue::Str(t.text.clone())))
        .collect();
    Ok(RawImage {
        width,
        height,
        channels: channels.iter().map(|c| c.to_string()).collect(),
        data,
        metadata,
        format: "png".into(),
        pixel_type: Some(if sixteen {
            PixelType::U16
        } else {
            PixelType::U8
        }),
        window: Window::whole(width, height),
    })
}

/// A decoded JPEG or HDR file's values as floats, after checking its declared size.
fn read_decoded(
    path: &Path,
    decoder: impl image::ImageDecoder,
    format: &str,
    allowance: &Allowance,
) -> Result<RawImage> {
    let (width, height) = decoder.dimensions();
    let (channels, pixel_type): (&[&str], _) = match decoder.color_type() {
        image::ColorType::L8 => (&["Y"], Some(PixelType::U8)),
        image::ColorType::Rgb8 => (&["R", "G", "B"], Some(PixelType::U8)),
        image::ColorType::Rgb32F => (&["R", "G", "B"], Some(PixelType::Float)),
        other => {
            return Err(Error::input(
                path,
                format!("a {format} file of {other:?} pixels, which raylink does not read"),
            ))
        }
    };
    check_declared(path, width, height, channels.len() as u32, allowance)?;
    let mut buffer = vec![0u8; decoder.total_bytes() as usize];
    decoder
        .read_image(&mut buffer)
        .map_err(|e| Error::input(path, format!("cannot read as {format}: {e}")))?;
    let data: Vec<f32> = match pixel_type {
        Some(PixelType::U8) => from_8_bit(&buffer),
        _ => buffer
            .chunks_exact(4)
            .map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
            .collect(),
    };
    Ok(RawImage {
        width,
        height,
        channels: channels.iter().map(|c| c.to_string()).collect(),
        data,
        metadata: Vec::new(),
        format: format.to_ascii_lowercase(),
        pixel_type,
        window: Window::whole(width, height),
    })
}

fn read_jpeg(path: &Path, bytes: &[u8], allowance: &Allowance) -> Result<RawImage> {
    let decoder = image::codecs::jpeg::JpegDecoder::new(Cursor::new(bytes))
        .map_err(|e| Error::input(path, format!("cannot read as JPEG: {e}")))?;
    read_decoded(path, decoder, "JPEG", allowance)
}

fn read_hdr(path: &Path, bytes: &[u8], allowance: &Allowance) -> Result<RawImage> {
    let decoder = image::codecs::hdr::HdrDecoder::new(Cursor::new(bytes))
        .map_err(|e| Error::input(path, format!("cannot read as HDR: {e}")))?;
    read_decoded(path, decoder, "HDR", allowance)
}
