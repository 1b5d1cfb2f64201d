//! Safe wrapper over the C API in ffi/oiio.h.
