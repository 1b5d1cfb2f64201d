/* A small C API over OpenImageIO (2.2 or later), implemented in oiio.cpp.
 *
 * Rules for every function here:
 * - no C++ exception escapes (each entry point catches everything);
 * - failures are reported by the return value, with a NUL-terminated one-or-more-line message
 *   written to the caller's buffer `err` of `err_len` bytes (truncated to fit; `err` may be
 *   NULL when `err_len` is 0);
 * - strings passed in are NUL-terminated UTF-8 and only borrowed for the duration of the call.
 */
#pragma once

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* How pixels are stored in the file (the data passed in or read out is always float). */
enum {
    RAYLINK_OIIO_FLOAT = 0,
    RAYLINK_OIIO_HALF = 1,
    RAYLINK_OIIO_UINT8 = 2,
    RAYLINK_OIIO_UINT16 = 3,
    /* Only returned by raylink_oiio_image_pixel_type: any other stored type. */
    RAYLINK_OIIO_OTHER = -1
};

/* Kinds of metadata attribute. */
enum {
    RAYLINK_OIIO_ATTR_STRING = 0,
    RAYLINK_OIIO_ATTR_INT = 1,
    RAYLINK_OIIO_ATTR_FLOAT = 2,
    RAYLINK_OIIO_ATTR_FLOATS = 3
};

/* One metadata attribute to write: `name` and, depending on `type`, `string_value`,
 * `int_value`, `float_value`, or (RAYLINK_OIIO_ATTR_FLOATS, written only) `int_value` floats
 * at `float_values` (OpenEXR's `chromaticities`: 8). */
typedef struct RaylinkOiioAttr {
    const char *name;
    int type;
    const char *string_value;
    int int_value;
    float float_value;
    const float *float_values;
} RaylinkOiioAttr;

/* Where the pixels of a region lie in the full image: the region's top-left pixel is (x, y)
 * in a `full_width` x `full_height` image. */
typedef struct RaylinkOiioWindow {
    int x;
    int y;
    int full_width;
    int full_height;
} RaylinkOiioWindow;

/* An image file encoded in memory; free it with raylink_oiio_encoded_free. */
typedef struct RaylinkOiioEncoded RaylinkOiioEncoded;

/* Encodes a `width` x `height` image of `nchannels` interleaved float channels (`data` holds
 * width * height * nchannels floats, row-major, top row first) into memory, as the file the
 * OpenImageIO writer for `format` (a format name such as "openexr", "png", "jpeg", "tiff",
 * "hdr", or an extension such as "exr") would write; the caller writes the bytes to disk
 * itself, so that a failure there has its operating system's reason. No file is touched:
 * `name` only names the file in messages. `channel_names` holds `nchannels` names. The
 * attributes become file metadata where the format supports them. `pixel_type`
 * (RAYLINK_OIIO_FLOAT/HALF/UINT8/UINT16) is the type stored in the file. With a `window`
 * (NULL for a whole image), the image is that region of a larger one: the file's data window
 * is the region and its display window the full image (OpenEXR keeps both; formats without
 * data windows may not); the region must lie inside the full image. Returns NULL on failure
 * (message in `err`). */
RaylinkOiioEncoded *raylink_oiio_encode(const char *name, const char *format, int width,
                                        int height, int nchannels, const float *data,
                                        const char *const *channel_names,
                                        const RaylinkOiioAttr *attrs, size_t nattrs,
                                        int pixel_type, const RaylinkOiioWindow *window,
                                        char *err, size_t err_len);

/* The encoded file's bytes (raylink_oiio_encoded_size of them); they live as long as it. */
const unsigned char *raylink_oiio_encoded_data(const RaylinkOiioEncoded *encoded);
size_t raylink_oiio_encoded_size(const RaylinkOiioEncoded *encoded);
void raylink_oiio_encoded_free(RaylinkOiioEncoded *encoded);

/* An image read from a file; free it with raylink_oiio_image_free. */
typedef struct RaylinkOiioImage RaylinkOiioImage;

/* Reads the header of the file at `path`, none of its pixels: the size of its first subimage
 * (top mip level) in *width, *height and *nchannels, for the caller to decide whether to read
 * it. Returns 0, or nonzero on failure (message in `err`), as raylink_oiio_read would fail
 * before its pixels. */
int raylink_oiio_read_size(const char *path, int *width, int *height, int *nchannels, char *err,
                           size_t err_len);

/* Reads the first subimage (top mip level) of the file at `path`, all channels, converted to
 * float. An image whose header declares more than `max_values` values (width * height *
 * nchannels) is refused before any pixel is read or memory is taken for them. Returns NULL on
 * failure (message in `err`). */
RaylinkOiioImage *raylink_oiio_read(const char *path, size_t max_values, char *err,
                                    size_t err_len);

void raylink_oiio_image_free(RaylinkOiioImage *image);

int raylink_oiio_image_width(const RaylinkOiioImage *image);
int raylink_oiio_image_height(const RaylinkOiioImage *image);
int raylink_oiio_image_nchannels(const RaylinkOiioImage *image);

/* Where the pixels read (width x height, the data window) lie: their top-left pixel is
 * (*x, *y), and the display window is *full_width x *full_height from (*full_x, *full_y).
 * For a file without windows: 0, 0, 0, 0, width, height. */
void raylink_oiio_image_window(const RaylinkOiioImage *image, int *x, int *y, int *full_x,
                               int *full_y, int *full_width, int *full_height);

/* The stored pixel type (RAYLINK_OIIO_FLOAT etc., RAYLINK_OIIO_OTHER for anything else). */
int raylink_oiio_image_pixel_type(const RaylinkOiioImage *image);

/* The name of the OpenImageIO reader that read the file ("openexr", "png", ...). The string
 * lives as long as the image. */
const char *raylink_oiio_image_format(const RaylinkOiioImage *image);

/* The name of channel `index` (0 <= index < nchannels), or NULL if out of range. The string
 * lives as long as the image. */
const char *raylink_oiio_image_channel_name(const RaylinkOiioImage *image, int index);

/* width * height * nchannels floats, interleaved, row-major, top row first; they live as long
 * as the image. */
const float *raylink_oiio_image_pixels(const RaylinkOiioImage *image);

/* The number of metadata attributes kept: scalar strings, integers that fit in an int, and
 * scalar floating-point values (converted to float). Arrays, matrices and other types are
 * skipped. */
size_t raylink_oiio_image_nattrs(const RaylinkOiioImage *image);

/* Attribute `index`: fills `*attr` (the strings live as long as the image). Returns 0, or
 * nonzero if `index` is out of range. */
int raylink_oiio_image_attr(const RaylinkOiioImage *image, size_t index, RaylinkOiioAttr *attr);

/* The version of the OpenImageIO library in use at run time, e.g. "2.4.7". The string is
 * static. */
const char *raylink_oiio_version(void);

/* The version of this interface, RAYLINK_OIIO_ABI: the program loads this library at run
 * time and checks it was built from the same header. Raise it with every change here. */
#define RAYLINK_OIIO_ABI 3
int raylink_oiio_abi(void);

#ifdef __cplusplus
}
#endif
