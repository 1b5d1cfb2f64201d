//! Safe wrapper over the C API in `ffi/oiio.h` (compiled from `ffi/oiio.cpp` by `build.rs`).
//! This is the only module with unsafe OpenImageIO code. Every function validates its input
//! (sizes, NUL bytes) before crossing into C++, and reports failures naming the file, never
//! by panicking: a file that cannot be read as an image as [`Error::Input`] (bad input), a
//! failure to write as [`Error::Image`] or [`Error::Io`].

use std::ffi::{c_char, c_int, CStr, CString};
use std::path::Path;

use super::oiio_sys::{self as sys, Api};
use super::{MetaValue, Metadata};
use crate::error::{Error, Result};
use crate::input_file::{self, Allowance};

pub use super::io::{read_bytes, ImageToWrite, PixelType, RawImage, Window, MAX_IMAGE_VALUES};

fn pixel_code(pixel: PixelType) -> c_int {
    match pixel {
        PixelType::Float => sys::RAYLINK_OIIO_FLOAT,
        PixelType::Half => sys::RAYLINK_OIIO_HALF,
        PixelType::U8 => sys::RAYLINK_OIIO_UINT8,
        PixelType::U16 => sys::RAYLINK_OIIO_UINT16,
    }
}

fn pixel_from_code(code: c_int) -> Option<PixelType> {
    match code {
        sys::RAYLINK_OIIO_FLOAT => Some(PixelType::Float),
        sys::RAYLINK_OIIO_HALF => Some(PixelType::Half),
        sys::RAYLINK_OIIO_UINT8 => Some(PixelType::U8),
        sys::RAYLINK_OIIO_UINT16 => Some(PixelType::U16),
        _ => None,
    }
}

/// Writes `image` to `path`, encoded by the OpenImageIO writer for `format` (`"openexr"`,
/// `"png"`, `"jpeg"`, `"tiff"`, `"hdr"`, or an extension such as `"exr"`) whatever the
/// extension of `path`; `metadata` becomes file attributes where the format supports them.
/// The image is encoded in memory ([`encode`]) and written with the standard library, so a
/// failure to write has the operating system's reason ([`Error::Io`]). On failure a partly
/// written file may be left at `path`: the caller removes it (see
/// [`super::output::write_image`], which writes atomically).
pub fn write(path: &Path, format: &str, image: ImageToWrite, metadata: &Metadata) -> Result<()> {
    let encoded = encode(path, format, image, metadata)?;
    std::fs::write(path, encoded.bytes()).map_err(|e| Error::io(path, e))
}

/// An image file encoded in memory by [`encode`].
pub struct Encoded {
    buffer: std::ptr::NonNull<sys::RaylinkOiioEncoded>,
    api: &'static Api,
}

impl Encoded {
    /// The file's bytes.
    pub fn bytes(&self) -> &[u8] {
        // SAFETY: `self.buffer` is a live buffer owned by `self`; the accessors only read it, and
        // its `size` bytes stay valid and unchanged as long as `self`, which the returned
        // slice borrows.
        unsafe {
            let data = (self.api.raylink_oiio_encoded_data)(self.buffer.as_ptr());
            let size = (self.api.raylink_oiio_encoded_size)(self.buffer.as_ptr());
            if size == 0 || data.is_null() {
                return &[];
            }
            std::slice::from_raw_parts(data, size)
        }
    }
}

impl Drop for Encoded {
    fn drop(&mut self) {
        // SAFETY: `self.buffer` came non-null from `raylink_oiio_encode` and is freed only
        // here.
        unsafe { (self.api.raylink_oiio_encoded_free)(self.buffer.as_ptr()) }
    }
}

/// Encodes `image` in memory as [`write()`] would write it to `name` (which only names the
/// file in messages; nothing is written).
pub fn encode(
    path: &Path,
    format: &str,
    image: ImageToWrite,
    metadata: &Metadata,
) -> Result<Encoded> {
    let ImageToWrite {
        width,
        height,
        channels,
        data,
        pixel_type: pixel,
        window,
        chromaticities,
    } = image;
    let fail = |detail: String| Error::image(path, detail);
    let api = sys::api().map_err(fail)?;
    let c_path = path_to_cstring(path)?;
    let c_format = cstring(path, "format name", format)?;
    let nchannels = c_int::try_from(channels.len())
        .ok()
        .filter(|&n| n > 0)
        .ok_or_else(|| fail(format!("cannot write {} channels", channels.len())))?;
    let (w, h) = match (c_int::try_from(width), c_int::try_from(height)) {
        (Ok(w), Ok(h)) if w > 0 && h > 0 => (w, h),
        _ => {
            return Err(fail(format!(
                "cannot write an image of {width}x{height} pixels"
            )))
        }
    };
    let expected = (width as usize)
        .checked_mul(height as usize)
        .and_then(|n| n.checked_mul(channels.len()));
    if expected != Some(data.len()) {
        return Err(fail(format!(
            "internal error: {} values given for {width}x{height} pixels of {} channels",
            data.len(),
            channels.len()
        )));
    }
    let c_channels = channels
        .iter()
        .map(|name| cstring(path, "channel name", name))
        .collect::<Result<Vec<_>>>()?;
    let channel_ptrs: Vec<*const c_char> = c_channels.iter().map(|c| c.as_ptr()).collect();

    // Owned C strings first, then the attribute structs borrowing them.
    let mut c_meta = Vec::with_capacity(metadata.len());
    for (name, value) in metadata {
        let c_name = cstring(path, "metadata name", name)?;
        let c_value = match value {
            MetaValue::Str(s) => Some(cstring(path, &format!("metadata {name}"), s)?),
            _ => None,
        };
        c_meta.push((c_name, c_value, value));
    }
    let attrs: Vec<sys::RaylinkOiioAttr> = c_meta
        .iter()
        .map(|(name, string, value)| sys::RaylinkOiioAttr {
            name: name.as_ptr(),
            type_: match value {
                MetaValue::Str(_) => sys::RAYLINK_OIIO_ATTR_STRING,
                MetaValue::Int(_) => sys::RAYLINK_OIIO_ATTR_INT,
                MetaValue::Float(_) => sys::RAYLINK_OIIO_ATTR_FLOAT,
            },
            string_value: string.as_ref().map_or(std::ptr::null(), |s| s.as_ptr()),
            int_value: match value {
                MetaValue::Int(i) => *i,
                _ => 0,
            },
            float_value: match value {
                MetaValue::Float(f) => *f,
                _ => 0.0,
            },
            float_values: std::ptr::null(),
        })
        .collect();
    let mut attrs = attrs;
    let chromaticities_name = c"chromaticities";
    if let Some(values) = &chromaticities {
        attrs.push(sys::RaylinkOiioAttr {
            name: chromaticities_name.as_ptr(),
            type_: sys::RAYLINK_OIIO_ATTR_FLOATS,
            string_value: std::ptr::null(),
            int_value: values.len() as c_int,
            float_value: 0.0,
            float_values: values.as_ptr(),
        });
    }

    let c_window = match window {
        None => None,
        Some(win) => {
            let (Ok(full_width), Ok(full_height)) = (
                c_int::try_from(win.full_width),
                c_int::try_from(win.full_height),
            ) else {
                return Err(fail(format!(
                    "cannot write a window of a {}x{} image",
                    win.full_width, win.full_height
                )));
            };
            if win.full_x != 0 || win.full_y != 0 {
                return Err(fail("the full image must start at (0, 0)".into()));
            }
            Some(sys::RaylinkOiioWindow {
                x: win.x,
                y: win.y,
                full_width,
                full_height,
            })
        }
    };
    let window_ptr = c_window
        .as_ref()
        .map_or(std::ptr::null(), |w| w as *const sys::RaylinkOiioWindow);

    let mut err = ErrorBuffer::new();
    // SAFETY: every pointer is valid for the duration of the call: `c_path`, `c_format` and
    // the strings behind `channel_ptrs` and `attrs` are owned CStrings (or a static one)
    // that outlive it, as does `chromaticities`, whose 8 floats an attribute points to;
    // `channel_ptrs` holds exactly `nchannels` pointers, `attrs` `attrs.len()` structs, and
    // `data` exactly `w * h * nchannels` floats (checked above); `window_ptr` is null or
    // points to `c_window`, alive here (plain integers, which the C side checks against the
    // image size). The C side only reads them, writes at most `err.len()` bytes into `err`,
    // and catches every C++ exception; it returns null or a buffer that we own and free
    // exactly once (by `Encoded`'s Drop).
    let encoded = unsafe {
        (api.raylink_oiio_encode)(
            c_path.as_ptr(),
            c_format.as_ptr(),
            w,
            h,
            nchannels,
            data.as_ptr(),
            channel_ptrs.as_ptr(),
            attrs.as_ptr(),
            attrs.len(),
            pixel_code(pixel),
            window_ptr,
            err.as_mut_ptr(),
            err.len(),
        )
    };
    std::ptr::NonNull::new(encoded)
        .map(|buffer| Encoded { buffer, api })
        .ok_or_else(|| fail(err.message()))
}

/// Reads the first subimage of the file at `path`, all channels converted to float, within
/// the machine's default memory budget ([`read_within`]).
pub fn read(path: &Path) -> Result<RawImage> {
    read_within(path, &Allowance::machine())
}

/// Reads the first subimage of the file at `path`, all channels converted to float. The
/// path must name a regular file within the limit on images (checked before the library
/// opens it), and the size its header declares must be within [`MAX_IMAGE_VALUES`], the
/// largest image size ([`MAX_RESOLUTION`](crate::scene::camera::MAX_RESOLUTION) a side) and what `allowance` leaves of the
/// budget ([`read_bytes`]): all checked before any pixel is read.
pub fn read_within(path: &Path, allowance: &Allowance) -> Result<RawImage> {
    // A file that cannot be read as an image is bad input, as a malformed scene is.
    let size = input_file::check(path, &input_file::IMAGE).map_err(|e| match e {
        Error::Io { source, .. } => {
            Error::input(path, format!("cannot open for reading: {source}"))
        }
        e => e,
    })?;
    if size == 0 {
        return Err(Error::input(path, "empty file (0 bytes), not an image"));
    }
    let api = sys::api().map_err(|e| Error::image(path, e))?;
    let c_path = path_to_cstring(path)?;
    let mut err = ErrorBuffer::new();
    let (mut width, mut height, mut channels) = (0, 0, 0);
    // SAFETY: `c_path` is a NUL-terminated string alive for the call; the three size
    // pointers are to distinct live locals; `err` is a writable buffer of `err.len()` bytes.
    // The C side catches every C++ exception.
    let failed = unsafe {
        (api.raylink_oiio_read_size)(
            c_path.as_ptr(),
            &mut width,
            &mut height,
            &mut channels,
            err.as_mut_ptr(),
            err.len(),
        )
    };
    if failed != 0 {
        return Err(Error::input(path, err.message()));
    }
    let to_u32 = |v: c_int| u32::try_from(v).unwrap_or(u32::MAX);
    let (width, height, channels) = (to_u32(width), to_u32(height), to_u32(channels));
    let values = super::io::check_declared(path, width, height, channels, allowance)?;
    let mut err = ErrorBuffer::new();
    // SAFETY: `c_path` is a NUL-terminated string alive for the call; `err` is a writable
    // buffer of `err.len()` bytes. The C side catches every C++ exception and returns either
    // null or an image that we own and free exactly once (by `Handle`'s Drop). `values`
    // re-checks the header in case the file changed since it was read above.
    let ptr = unsafe {
        (api.raylink_oiio_read)(
            c_path.as_ptr(),
            values as usize,
            err.as_mut_ptr(),
            err.len(),
        )
    };
    if ptr.is_null() {
        return Err(Error::input(path, err.message()));
    }
    Ok(Handle { image: ptr, api }.to_raw())
}

/// The version of the OpenImageIO library in use, e.g. `"2.4.7"`; an error if it cannot be
/// loaded.
pub fn version() -> Result<String> {
    let api = sys::api().map_err(Error::Library)?;
    // SAFETY: the function takes no arguments, catches all exceptions, and returns a pointer
    // to a static NUL-terminated string (never null).
    let ptr = unsafe { (api.raylink_oiio_version)() };
    // SAFETY: `ptr` is non-null, NUL-terminated and static (see above).
    Ok(unsafe { CStr::from_ptr(ptr) }
        .to_string_lossy()
        .into_owned())
}

/// Loads OpenImageIO now, if it is not yet loaded (it is loaded by the first image read or
/// written): a program about to do long work before writing its image finds out first
/// whether it will be able to.
pub fn load() -> Result<()> {
    sys::api().map(|_| ()).map_err(Error::Library)
}

/// The version of OpenImageIO raylink was built against (without loading it).
pub fn built_with() -> &'static str {
    env!("RAYLINK_OIIO_BUILD_VERSION")
}

/// The shared object that holds raylink's interface to OpenImageIO (the copy carried in the
/// program), for installing beside the program as `../lib/raylink/` [`OBJECT_NAME`].
pub fn object() -> &'static [u8] {
    sys::EMBEDDED
}

/// The file name of [`object`] where it is installed.
pub const OBJECT_NAME: &str = sys::FILE_NAME;

/// Owns a `RaylinkOiioImage`; frees it on drop.
struct Handle {
    image: *mut sys::RaylinkOiioImage,
    api: &'static Api,
}

impl Drop for Handle {
    fn drop(&mut self) {
        // SAFETY: `self.image` came non-null from `raylink_oiio_read` and is freed only here,
        // once.
        unsafe { (self.api.raylink_oiio_image_free)(self.image) }
    }
}

impl Handle {
    fn to_raw(&self) -> RawImage {
        let (h, api) = (self.image, self.api);
        // SAFETY (all the accessor calls below): `h` is a live image owned by `self`, and the
        // accessors only read it. Returned strings and the pixel array live as long as the
        // image, and are copied into owned Rust values before `self` is dropped.
        let (width, height, nchannels, pixel_type, format) = unsafe {
            (
                (api.raylink_oiio_image_width)(h),
                (api.raylink_oiio_image_height)(h),
                (api.raylink_oiio_image_nchannels)(h),
                (api.raylink_oiio_image_pixel_type)(h),
                owned_string((api.raylink_oiio_image_format)(h)),
            )
        };
        // The C side guarantees positive sizes; convert without trusting it blindly.
        let to_u32 = |v: c_int| u32::try_from(v).unwrap_or(0);
        let (width, height) = (to_u32(width), to_u32(height));
        let nchannels = usize::try_from(nchannels).unwrap_or(0);
        let channels = (0..nchannels)
            // SAFETY: see above; `c` < nchannels, and a null return is handled.
            .map(|c| unsafe { owned_string((api.raylink_oiio_image_channel_name)(h, c as c_int)) })
            .collect();
        let len = width as usize * height as usize * nchannels;
        let data = if len == 0 {
            Vec::new()
        } else {
            // SAFETY: the C side holds exactly width * height * nchannels floats, alive as
            // long as `self`; we copy them out immediately.
            unsafe { std::slice::from_raw_parts((api.raylink_oiio_image_pixels)(h), len) }.to_vec()
        };
        let (mut x, mut y, mut full_x, mut full_y, mut full_width, mut full_height) =
            (0, 0, 0, 0, 0, 0);
        // SAFETY: see above; the six pointers are to distinct live locals the call fills.
        unsafe {
            (api.raylink_oiio_image_window)(
                h,
                &mut x,
                &mut y,
                &mut full_x,
                &mut full_y,
                &mut full_width,
                &mut full_height,
            )
        };
        let window = Window {
            x,
            y,
            full_x,
            full_y,
            full_width: to_u32(full_width),
            full_height: to_u32(full_height),
        };
        // SAFETY: see above.
        let nattrs = unsafe { (api.raylink_oiio_image_nattrs)(h) };
        let mut metadata = Metadata::with_capacity(nattrs);
        for index in 0..nattrs {
            let mut attr = sys::RaylinkOiioAttr {
                name: std::ptr::null(),
                type_: 0,
                string_value: std::ptr::null(),
                int_value: 0,
                float_value: 0.0,
                float_values: std::ptr::null(),
            };
            // SAFETY: `index` < nattrs and `attr` is a valid struct to fill; on success its
            // string pointers are null or NUL-terminated strings owned by the image.
            if unsafe { (api.raylink_oiio_image_attr)(h, index, &mut attr) } != 0 {
                continue;
            }
            // SAFETY: as just said.
            let name = unsafe { owned_string(attr.name) };
            let value = match attr.type_ {
                // SAFETY: as just said.
                sys::RAYLINK_OIIO_ATTR_STRING => {
                    MetaValue::Str(unsafe { owned_string(attr.string_value) })
                }
                sys::RAYLINK_OIIO_ATTR_INT => MetaValue::Int(attr.int_value),
                sys::RAYLINK_OIIO_ATTR_FLOAT => MetaValue::Float(attr.float_value),
                _ => continue,
            };
            metadata.push((name, value));
        }
        RawImage {
            width,
            height,
            channels,
            data,
            metadata,
            format,
            pixel_type: pixel_from_code(pixel_type),
            window,
        }
    }
}

/// Copies a C string (lossily as UTF-8); null gives an empty string.
///
/// # Safety
/// `ptr` must be null or point to a NUL-terminated string valid for the call.
unsafe fn owned_string(ptr: *const c_char) -> String {
    if ptr.is_null() {
        return String::new();
    }
    // SAFETY: non-null and NUL-terminated by the caller's contract.
    unsafe { CStr::from_ptr(ptr) }
        .to_string_lossy()
        .into_owned()
}

fn cstring(path: &Path, what: &str, s: &str) -> Result<CString> {
    CString::new(s).map_err(|_| Error::image(path, format!("{what} {s:?} contains a NUL byte")))
}

fn path_to_cstring(path: &Path) -> Result<CString> {
    #[cfg(unix)]
    let bytes = {
        use std::os::unix::ffi::OsStrExt;
        path.as_os_str().as_bytes().to_vec()
    };
    #[cfg(not(unix))]
    let bytes = path
        .to_str()
        .ok_or_else(|| Error::image(path, "the path is not valid UTF-8"))?
        .as_bytes()
        .to_vec();
    if bytes.is_empty() {
        return Err(Error::image(path, "empty path"));
    }
    CString::new(bytes).map_err(|_| Error::image(path, "the path contains a NUL byte"))
}

/// A buffer for the C side's error messages.
struct ErrorBuffer(Vec<u8>);

impl ErrorBuffer {
    fn new() -> Self {
        ErrorBuffer(vec![0; 2048])
    }

    fn as_mut_ptr(&mut self) -> *mut c_char {
        self.0.as_mut_ptr().cast()
    }

    fn len(&self) -> usize {
        self.0.len()
    }

    /// The message as one line: OpenImageIO's messages may span several.
    fn message(&self) -> String {
        let end = self.0.iter().position(|&b| b == 0).unwrap_or(self.0.len());
        let text = String::from_utf8_lossy(&self.0[..end]);
        let line = text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .collect::<Vec<_>>()
            .join("; ");
        if line.is_empty() {
            "OpenImageIO failed without a message".to_string()
        } else {
            line
        }
    }
}
