//! Reading and writing image files, whichever library does it: OpenImageIO (the `oiio`
//! feature, on by default: EXR, HDR, TIFF, PNG, JPEG and every format it reads), else the
//! pure-Rust codecs of [`super::codecs`] (EXR, PNG, JPEG and HDR). Callers see one interface.

use std::path::Path;

use super::{MetaValue, Metadata};
use crate::error::{Error, Result};
use crate::input_file::Allowance;
use crate::scene::camera::MAX_RESOLUTION;

#[cfg(not(feature = "oiio"))]
use super::codecs as backend;
#[cfg(feature = "oiio")]
use super::oiio as backend;

/// How pixels are stored in a file. Data in memory is always `f32`; integers are mapped to
/// floats by scaling their full range to `[0, 1]` (and back, rounded and clamped).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelType {
    Float,
    Half,
    U8,
    U16,
}

/// An image as read from a file: all channels, converted to float.
#[derive(Clone, Debug, PartialEq)]
pub struct RawImage {
    pub width: u32,
    pub height: u32,
    /// Channel names, e.g. `["R", "G", "B"]`.
    pub channels: Vec<String>,
    /// `width * height * channels.len()` values, interleaved, row-major, top row first.
    pub data: Vec<f32>,
    /// Scalar string, integer (fitting `i32`) and floating-point attributes of the file
    /// (with OpenImageIO, also its own: `"compression"`, `"oiio:ColorSpace"`, ...). Arrays
    /// and other types are left out.
    pub metadata: Metadata,
    /// The format of the file, by OpenImageIO's names: `"openexr"`, `"png"`, `"jpeg"`, ...
    pub format: String,
    /// How the pixels are stored in the file, if it is one of the [`PixelType`]s.
    pub pixel_type: Option<PixelType>,
    /// Where the pixels lie in the full image (OpenEXR's data and display windows).
    pub window: Window,
}

/// Where the `width` x `height` pixels of a file lie in the full image: their top-left pixel
/// is (`x`, `y`) and the full image (OpenEXR's display window) is `full_width` x
/// `full_height` pixels from (`full_x`, `full_y`). A whole image is at (0, 0) in itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    pub x: i32,
    pub y: i32,
    pub full_x: i32,
    pub full_y: i32,
    pub full_width: u32,
    pub full_height: u32,
}

impl Window {
    /// The window of a whole `width` x `height` image: at (0, 0) in itself.
    pub fn whole(width: u32, height: u32) -> Window {
        Window {
            x: 0,
            y: 0,
            full_x: 0,
            full_y: 0,
            full_width: width,
            full_height: height,
        }
    }
}

impl RawImage {
    /// The value of metadata attribute `name`, if present.
    pub fn meta(&self, name: &str) -> Option<&MetaValue> {
        self.metadata
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, value)| value)
    }
}

/// An image to write: `width` x `height` pixels of `channels.len()` interleaved float
/// channels, stored in the file as `pixel_type`.
#[derive(Clone, Copy, Debug)]
pub struct ImageToWrite<'a> {
    pub width: u32,
    pub height: u32,
    /// Channel names, e.g. `["R", "G", "B"]`.
    pub channels: &'a [&'a str],
    /// `width * height * channels.len()` values, interleaved, row-major, top row first.
    pub data: &'a [f32],
    pub pixel_type: PixelType,
    /// `None` for a whole image. `Some` for a region of a larger image: the region's top-left
    /// pixel is (`window.x`, `window.y`) in a `window.full_width` x `window.full_height` image
    /// (`full_x` and `full_y` must be 0). OpenEXR keeps both windows; a region that does not
    /// fit in the full image is an error.
    pub window: Option<Window>,
    /// The RGB primaries and white (x, y of red, green, blue, white) to record, where the
    /// format has a place for them (OpenEXR's `chromaticities`); `None` for sRGB's, which
    /// readers assume.
    pub chromaticities: Option<[f32; 8]>,
}

/// The most values (width × height × channels) raylink reads from one image, 4 GiB as
/// floats: a fixed limit, checked against the file's header before its pixels are read.
pub const MAX_IMAGE_VALUES: u64 = 1 << 30;

/// The memory reading a `width` x `height` image of `channels` channels takes at its peak:
/// the library's float values, their copy here, and an RGB image made of them.
pub fn read_bytes(width: u32, height: u32, channels: u32) -> u64 {
    (width as u64 * height as u64).saturating_mul(8 * channels as u64 + 12)
}

/// Checks the size a file's header declares (`width` x `height` pixels of `channels`
/// channels) against [`MAX_IMAGE_VALUES`], [`MAX_RESOLUTION`] a side and what `allowance`
/// leaves of the budget, before any pixel is read. Returns the number of values.
pub(crate) fn check_declared(
    path: &Path,
    width: u32,
    height: u32,
    channels: u32,
    allowance: &Allowance,
) -> Result<u64> {
    let values = (width as u64 * height as u64).saturating_mul(channels as u64);
    if width > MAX_RESOLUTION || height > MAX_RESOLUTION || values > MAX_IMAGE_VALUES {
        return Err(Error::input(
            path,
            format!(
                "declares a {width}x{height} image of {channels} channels, more than raylink \
                 reads: at most {MAX_RESOLUTION} pixels a side and {MAX_IMAGE_VALUES} values \
                 (width × height × channels), fixed limits"
            ),
        ));
    }
    allowance.check(
        &format!("reading the {width}x{height} image {}", path.display()),
        read_bytes(width, height, channels),
    )?;
    Ok(values)
}

/// Reads the first subimage of the file at `path`, all channels converted to float, within
/// the machine's default memory budget ([`read_within`]).
pub fn read(path: &Path) -> Result<RawImage> {
    read_within(path, &Allowance::machine())
}

/// Reads the first subimage (EXR: the first part) of the file at `path`, all channels
/// converted to float. The path must name a regular file within the limit on images, and
/// the size its header declares must be within [`MAX_IMAGE_VALUES`], [`MAX_RESOLUTION`] a
/// side and what `allowance` leaves of the budget ([`read_bytes`]): all checked before any
/// pixel is read. A file that cannot be read as an image is [`Error::Input`].
pub fn read_within(path: &Path, allowance: &Allowance) -> Result<RawImage> {
    backend::read_within(path, allowance)
}

/// An image file encoded in memory by [`encode`].
pub struct Encoded(EncodedBytes);

#[cfg(feature = "oiio")]
type EncodedBytes = super::oiio::Encoded;
#[cfg(not(feature = "oiio"))]
type EncodedBytes = Vec<u8>;

impl Encoded {
    /// The file's bytes.
    pub fn bytes(&self) -> &[u8] {
        #[cfg(feature = "oiio")]
        return self.0.bytes();
        #[cfg(not(feature = "oiio"))]
        &self.0
    }
}

/// Encodes `image` in memory as the file `path` (which only names the file in messages;
/// nothing is written) in `format` (`"openexr"`, `"png"`, `"jpeg"`, `"tiff"`, `"hdr"`, or an
/// extension such as `"exr"`), whatever the extension of `path`; `metadata` becomes file
/// attributes where the format holds them. A format this build cannot write is
/// [`Error::Image`].
pub fn encode(
    path: &Path,
    format: &str,
    image: ImageToWrite,
    metadata: &Metadata,
) -> Result<Encoded> {
    backend::encode(path, format, image, metadata).map(Encoded)
}

/// Writes `image` to `path` as [`encode`] encodes it. On failure a partly written file may
/// be left at `path`: the caller removes it (see [`super::output::write_image`], which
/// writes atomically).
pub fn write(path: &Path, format: &str, image: ImageToWrite, metadata: &Metadata) -> Result<()> {
    let encoded = encode(path, format, image, metadata)?;
    std::fs::write(path, encoded.bytes()).map_err(|e| Error::io(path, e))
}

/// Loads the image library now, if it is not yet loaded (OpenImageIO is loaded by the first
/// image read or written): a program about to do long work before writing its image finds
/// out first whether it will be able to. Nothing to do for the pure-Rust codecs.
pub fn load() -> Result<()> {
    #[cfg(feature = "oiio")]
    return super::oiio::load();
    #[cfg(not(feature = "oiio"))]
    Ok(())
}

/// What reads and writes images in this build, for version strings: `"OpenImageIO 2.4.7"`
/// (the version built against) or the pure-Rust codecs.
pub fn library() -> String {
    #[cfg(feature = "oiio")]
    return format!("OpenImageIO {}", super::oiio::built_with());
    #[cfg(not(feature = "oiio"))]
    "no OpenImageIO: EXR, PNG, JPEG and HDR in pure Rust".into()
}
