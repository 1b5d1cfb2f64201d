//! The C API of `ffi/oiio.h`, loaded on first use. `build.rs` compiles `ffi/oiio.cpp` into a
//! shared object linked against OpenImageIO, and the binary carries a copy of it; the
//! program itself does not link OpenImageIO, whose ~260 shared libraries would otherwise be
//! loaded (0.25 s and 130 MB) by every start, even one that only prints its version or
//! refuses an option. The first image read or written loads the object: the one installed
//! beside the program (`../lib/raylink/libraylink_oiio.so`, as the Debian package does,
//! so that its dependencies are the package's), else the copy carried inside.

use std::ffi::{c_char, c_float, c_int};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

pub const RAYLINK_OIIO_FLOAT: c_int = 0;
pub const RAYLINK_OIIO_HALF: c_int = 1;
pub const RAYLINK_OIIO_UINT8: c_int = 2;
pub const RAYLINK_OIIO_UINT16: c_int = 3;

pub const RAYLINK_OIIO_ATTR_STRING: c_int = 0;
pub const RAYLINK_OIIO_ATTR_INT: c_int = 1;
pub const RAYLINK_OIIO_ATTR_FLOAT: c_int = 2;
pub const RAYLINK_OIIO_ATTR_FLOATS: c_int = 3;

#[repr(C)]
pub struct RaylinkOiioAttr {
    pub name: *const c_char,
    pub type_: c_int,
    pub string_value: *const c_char,
    pub int_value: c_int,
    pub float_value: c_float,
    pub float_values: *const c_float,
}

#[repr(C)]
pub struct RaylinkOiioWindow {
    pub x: c_int,
    pub y: c_int,
    pub full_width: c_int,
    pub full_height: c_int,
}

/// Opaque.
#[repr(C)]
pub struct RaylinkOiioEncoded {
    _private: [u8; 0],
}

/// Opaque.
#[repr(C)]
pub struct RaylinkOiioImage {
    _private: [u8; 0],
}

/// The shared object the build made, carried in the program.
pub const EMBEDDED: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/libraylink_oiio.so"));

/// The file name of the shared object where it is installed.
pub const FILE_NAME: &str = "libraylink_oiio.so";

/// Declares the table of the C API's functions and how each is looked up.
macro_rules! api {
    ($( fn $name:ident($($arg:ty),*) $(-> $ret:ty)?; )*) => {
        /// The C API's functions, resolved in the loaded object (which the table keeps
        /// loaded for as long as the process runs).
        pub struct Api {
            $( pub $name: unsafe extern "C" fn($($arg),*) $(-> $ret)?, )*
            _library: libloading::Library,
        }

        impl Api {
            /// # Safety
            /// `library` must be a build of `ffi/oiio.cpp` matching `ffi/oiio.h` (checked
            /// by `raylink_oiio_abi`).
            unsafe fn resolve(library: libloading::Library) -> Result<Api, String> {
                Ok(Api {
                    $(
                        // SAFETY: the symbol has this signature in `ffi/oiio.h`.
                        $name: *unsafe {
                            library.get::<unsafe extern "C" fn($($arg),*) $(-> $ret)?>(
                                concat!(stringify!($name), "\0").as_bytes(),
                            )
                        }
                        .map_err(|e| e.to_string())?,
                    )*
                    _library: library,
                })
            }
        }
    };
}

api! {
    fn raylink_oiio_abi() -> c_int;
    fn raylink_oiio_encode(
        *const c_char,
        *const c_char,
        c_int,
        c_int,
        c_int,
        *const c_float,
        *const *const c_char,
        *const RaylinkOiioAttr,
        usize,
        c_int,
        *const RaylinkOiioWindow,
        *mut c_char,
        usize
    ) -> *mut RaylinkOiioEncoded;
    fn raylink_oiio_encoded_data(*const RaylinkOiioEncoded) -> *const u8;
    fn raylink_oiio_encoded_size(*const RaylinkOiioEncoded) -> usize;
    fn raylink_oiio_encoded_free(*mut RaylinkOiioEncoded);
    fn raylink_oiio_image_window(
        *const RaylinkOiioImage,
        *mut c_int,
        *mut c_int,
        *mut c_int,
        *mut c_int,
        *mut c_int,
        *mut c_int
    );
    fn raylink_oiio_read_size(
        *const c_char,
        *mut c_int,
        *mut c_int,
        *mut c_int,
        *mut c_char,
        usize
    ) -> c_int;
    fn raylink_oiio_read(*const c_char, usize, *mut c_char, usize) -> *mut RaylinkOiioImage;
    fn raylink_oiio_image_free(*mut RaylinkOiioImage);
    fn raylink_oiio_image_width(*const RaylinkOiioImage) -> c_int;
    fn raylink_oiio_image_height(*const RaylinkOiioImage) -> c_int;
    fn raylink_oiio_image_nchannels(*const RaylinkOiioImage) -> c_int;
    fn raylink_oiio_image_pixel_type(*const RaylinkOiioImage) -> c_int;
    fn raylink_oiio_image_format(*const RaylinkOiioImage) -> *const c_char;
    fn raylink_oiio_image_channel_name(*const RaylinkOiioImage, c_int) -> *const c_char;
    fn raylink_oiio_image_pixels(*const RaylinkOiioImage) -> *const c_float;
    fn raylink_oiio_image_nattrs(*const RaylinkOiioImage) -> usize;
    fn raylink_oiio_image_attr(*const RaylinkOiioImage, usize, *mut RaylinkOiioAttr) -> c_int;
    fn raylink_oiio_version() -> *const c_char;
}

/// The version of the C API this program was built with: `RAYLINK_OIIO_ABI` in `ffi/oiio.h`.
const ABI: c_int = 3;

/// The loaded API, or why it could not be loaded (one line).
pub fn api() -> Result<&'static Api, String> {
    static API: OnceLock<Result<Api, String>> = OnceLock::new();
    API.get_or_init(load).as_ref().map_err(Clone::clone)
}

fn load() -> Result<Api, String> {
    if let Some(installed) = installed() {
        // An installed object of another build (a stale file) is passed over.
        if let Ok(api) = open(&installed) {
            return Ok(api);
        }
    }
    // The carried copy, through an anonymous in-memory file; without one (no /proc), a
    // private temporary file removed once loaded.
    // The same reason twice (a library OpenImageIO needs that cannot be mapped) is said once.
    #[cfg(not(target_os = "linux"))]
    return from_temporary_file();
    #[cfg(target_os = "linux")]
    from_memory().or_else(|memory| {
        from_temporary_file().map_err(|file| match file == memory {
            true => file,
            false => format!("{memory}; {file}"),
        })
    })
}

#[cfg(target_os = "linux")]
fn from_memory() -> Result<Api, String> {
    use std::os::fd::AsRawFd;
    let fd = rustix::fs::memfd_create("raylink-oiio", rustix::fs::MemfdFlags::CLOEXEC)
        .map_err(|e| format!("cannot load OpenImageIO: memfd_create: {e}"))?;
    let mut file = std::fs::File::from(fd);
    std::io::Write::write_all(&mut file, EMBEDDED)
        .map_err(|e| format!("cannot load OpenImageIO: {e}"))?;
    // The mapping outlives the descriptor, closed when `file` drops.
    open(Path::new(&format!("/proc/self/fd/{}", file.as_raw_fd())))
}

fn from_temporary_file() -> Result<Api, String> {
    let path = std::env::temp_dir().join(format!("raylink-oiio-{}.so", std::process::id()));
    let failed = |e: std::io::Error| format!("cannot load OpenImageIO: {}: {e}", path.display());
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&path)
        .map_err(failed)?;
    // Ours from here on: removed whatever happens.
    let api = std::io::Write::write_all(&mut file, EMBEDDED)
        .map_err(failed)
        .and_then(|()| open(&path));
    let _ = std::fs::remove_file(&path);
    api
}

/// `../lib/raylink/libraylink_oiio.so` from the running program, if there is one.
fn installed() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let path = exe.parent()?.parent()?.join("lib/raylink").join(FILE_NAME);
    path.is_file().then_some(path)
}

fn open(path: &Path) -> Result<Api, String> {
    // SAFETY: loading runs the object's initialisers: OpenImageIO's and its libraries',
    // which only set up their own state.
    let library = unsafe { crate::platform::load_library(path) }
        .map_err(|e| format!("cannot load OpenImageIO: {e}"))?;
    // SAFETY: the symbols are looked up by the names and types of `ffi/oiio.h`; the ABI
    // number confirms the object was built from that header.
    let api = unsafe { Api::resolve(library) }
        .map_err(|e| format!("cannot load OpenImageIO from {}: {e}", path.display()))?;
    // SAFETY: takes nothing, returns a constant.
    let abi = unsafe { (api.raylink_oiio_abi)() };
    if abi != ABI {
        return Err(format!(
            "{} is for another raylink (its interface is version {abi}, this program's {ABI})",
            path.display()
        ));
    }
    Ok(api)
}
