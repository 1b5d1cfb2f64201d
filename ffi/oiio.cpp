// A small C API over OpenImageIO; see oiio.h. Every entry point catches all exceptions.

#include "oiio.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/paramlist.h>
#include <OpenImageIO/typedesc.h>

#include <png.h>

#include <algorithm>
#include <climits>
#include <csetjmp>
#include <cstdio>
#include <cstdlib>
#include <cstdint>
#include <cstring>
#include <exception>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

namespace {

void set_error(char *err, size_t err_len, const std::string &message) {
    if (err == nullptr || err_len == 0) {
        return;
    }
    size_t n = std::min(err_len - 1, message.size());
    std::memcpy(err, message.data(), n);
    err[n] = '\0';
}

// Joins a context line with OpenImageIO's own messages, skipping empty ones.
std::string with_detail(const std::string &context, const std::string &a,
                        const std::string &b = std::string()) {
    std::string message = context;
    for (const std::string *detail : {&a, &b}) {
        if (!detail->empty()) {
            message += ": ";
            message += *detail;
        }
    }
    return message;
}

bool pixel_type_desc(int pixel_type, OIIO::TypeDesc *desc) {
    switch (pixel_type) {
    case RAYLINK_OIIO_FLOAT:
        *desc = OIIO::TypeDesc(OIIO::TypeDesc::FLOAT);
        return true;
    case RAYLINK_OIIO_HALF:
        *desc = OIIO::TypeDesc(OIIO::TypeDesc::HALF);
        return true;
    case RAYLINK_OIIO_UINT8:
        *desc = OIIO::TypeDesc(OIIO::TypeDesc::UINT8);
        return true;
    case RAYLINK_OIIO_UINT16:
        *desc = OIIO::TypeDesc(OIIO::TypeDesc::UINT16);
        return true;
    default:
        return false;
    }
}

int pixel_type_code(OIIO::TypeDesc desc) {
    if (desc.aggregate != OIIO::TypeDesc::SCALAR || desc.arraylen != 0) {
        return RAYLINK_OIIO_OTHER;
    }
    switch (desc.basetype) {
    case OIIO::TypeDesc::FLOAT:
        return RAYLINK_OIIO_FLOAT;
    case OIIO::TypeDesc::HALF:
        return RAYLINK_OIIO_HALF;
    case OIIO::TypeDesc::UINT8:
        return RAYLINK_OIIO_UINT8;
    case OIIO::TypeDesc::UINT16:
        return RAYLINK_OIIO_UINT16;
    default:
        return RAYLINK_OIIO_OTHER;
    }
}

struct Attr {
    std::string name;
    int type;
    std::string string_value;
    int int_value;
    float float_value;
};

template <typename T> bool int_value(const OIIO::ParamValue &p, int *out) {
    T value;
    std::memcpy(&value, p.data(), sizeof(T));
    // Compare in the wider of the two types; the signed/unsigned cases are kept apart.
    if constexpr (std::is_signed<T>::value) {
        if (static_cast<long long>(value) < INT_MIN || static_cast<long long>(value) > INT_MAX) {
            return false;
        }
    } else {
        if (static_cast<unsigned long long>(value) > static_cast<unsigned long long>(INT_MAX)) {
            return false;
        }
    }
    *out = static_cast<int>(value);
    return true;
}

// Converts one attribute to a string, int or float; false for anything else.
bool convert_attr(const OIIO::ParamValue &p, Attr *attr) {
    OIIO::TypeDesc t = p.type();
    if (p.nvalues() != 1 || t.aggregate != OIIO::TypeDesc::SCALAR || t.arraylen != 0) {
        return false;
    }
    attr->name = p.name().string();
    attr->int_value = 0;
    attr->float_value = 0.0f;
    switch (t.basetype) {
    case OIIO::TypeDesc::STRING:
        attr->type = RAYLINK_OIIO_ATTR_STRING;
        attr->string_value = p.get_string(0);
        return true;
    case OIIO::TypeDesc::HALF:
    case OIIO::TypeDesc::FLOAT:
    case OIIO::TypeDesc::DOUBLE:
        attr->type = RAYLINK_OIIO_ATTR_FLOAT;
        attr->float_value = p.get_float();
        return true;
    default:
        break;
    }
    attr->type = RAYLINK_OIIO_ATTR_INT;
    switch (t.basetype) {
    case OIIO::TypeDesc::INT8:
        return int_value<int8_t>(p, &attr->int_value);
    case OIIO::TypeDesc::UINT8:
        return int_value<uint8_t>(p, &attr->int_value);
    case OIIO::TypeDesc::INT16:
        return int_value<int16_t>(p, &attr->int_value);
    case OIIO::TypeDesc::UINT16:
        return int_value<uint16_t>(p, &attr->int_value);
    case OIIO::TypeDesc::INT32:
        return int_value<int32_t>(p, &attr->int_value);
    case OIIO::TypeDesc::UINT32:
        return int_value<uint32_t>(p, &attr->int_value);
    case OIIO::TypeDesc::INT64:
        return int_value<int64_t>(p, &attr->int_value);
    case OIIO::TypeDesc::UINT64:
        return int_value<uint64_t>(p, &attr->int_value);
    default:
        return false;
    }
}

} // namespace

struct RaylinkOiioImage {
    int width = 0;
    int height = 0;
    int nchannels = 0;
    int pixel_type = RAYLINK_OIIO_OTHER;
    int x = 0, y = 0, full_x = 0, full_y = 0, full_width = 0, full_height = 0;
    std::string format;
    std::vector<std::string> channel_names;
    std::vector<float> pixels;
    std::vector<Attr> attrs;
};

namespace {

} // namespace

struct RaylinkOiioEncoded {
    std::vector<unsigned char> bytes;
};

namespace {

// raylink_oiio_encode: fills `encoded->bytes`; returns 0, or 1 with a message in `err`.
int encode_impl(RaylinkOiioEncoded *encoded, const char *path, const char *format, int width,
                int height, int nchannels, const float *data, const char *const *channel_names,
                const RaylinkOiioAttr *attrs, size_t nattrs, int pixel_type,
                const RaylinkOiioWindow *window, char *err, size_t err_len) {
    if (path == nullptr || format == nullptr || data == nullptr ||
        channel_names == nullptr || (attrs == nullptr && nattrs != 0)) {
        set_error(err, err_len, "internal error: null pointer passed to raylink_oiio_encode");
        return 1;
    }
    if (width <= 0 || height <= 0 || nchannels <= 0) {
        set_error(err, err_len,
                  "invalid image size " + std::to_string(width) + "x" +
                      std::to_string(height) + " with " + std::to_string(nchannels) +
                      " channels");
        return 1;
    }
    OIIO::TypeDesc stored;
    if (!pixel_type_desc(pixel_type, &stored)) {
        set_error(err, err_len, "invalid pixel type code " + std::to_string(pixel_type));
        return 1;
    }

    // The writer writes into `proxy`, which must outlive it (its destructor may close).
    OIIO::Filesystem::IOVecOutput proxy(encoded->bytes);
    auto out = OIIO::ImageOutput::create(format);
    if (!out) {
        set_error(err, err_len,
                  with_detail(std::string("no OpenImageIO writer for format \"") + format +
                                  "\"",
                              OIIO::geterror()));
        return 1;
    }

    // OpenImageIO 2.4's JPEG writer keeps libjpeg's default error handler, which calls
    // exit(): reject what libjpeg would refuse before it gets the chance.
    const int jpeg_max_dimension = 65500;
    if (std::strcmp(out->format_name(), "jpeg") == 0 &&
        (width > jpeg_max_dimension || height > jpeg_max_dimension)) {
        set_error(err, err_len,
                  "JPEG images are limited to " + std::to_string(jpeg_max_dimension) +
                      " pixels per side, not " + std::to_string(width) + "x" +
                      std::to_string(height));
        return 1;
    }

    OIIO::ImageSpec spec(width, height, nchannels, stored);
    if (window != nullptr) {
        if (window->x < 0 || window->y < 0 || window->full_width <= 0 ||
            window->full_height <= 0 || window->x > window->full_width - width ||
            window->y > window->full_height - height) {
            set_error(err, err_len,
                      "data window " + std::to_string(width) + "x" +
                          std::to_string(height) + " at (" + std::to_string(window->x) +
                          ", " + std::to_string(window->y) + ") does not fit in " +
                          std::to_string(window->full_width) + "x" +
                          std::to_string(window->full_height));
            return 1;
        }
        spec.x = window->x;
        spec.y = window->y;
        spec.full_x = 0;
        spec.full_y = 0;
        spec.full_width = window->full_width;
        spec.full_height = window->full_height;
    }
    spec.channelnames.clear();
    spec.alpha_channel = -1;
    for (int c = 0; c < nchannels; ++c) {
        const char *name = channel_names[c] != nullptr ? channel_names[c] : "";
        spec.channelnames.emplace_back(name);
        if (std::strcmp(name, "A") == 0 || std::strcmp(name, "Alpha") == 0) {
            spec.alpha_channel = c;
        }
    }
    for (size_t i = 0; i < nattrs; ++i) {
        const RaylinkOiioAttr &a = attrs[i];
        if (a.name == nullptr) {
            set_error(err, err_len, "internal error: attribute without a name");
            return 1;
        }
        switch (a.type) {
        case RAYLINK_OIIO_ATTR_STRING:
            spec.attribute(a.name, a.string_value != nullptr ? a.string_value : "");
            break;
        case RAYLINK_OIIO_ATTR_INT:
            spec.attribute(a.name, a.int_value);
            break;
        case RAYLINK_OIIO_ATTR_FLOAT:
            spec.attribute(a.name, a.float_value);
            break;
        case RAYLINK_OIIO_ATTR_FLOATS:
            if (a.float_values == nullptr || a.int_value <= 0) {
                set_error(err, err_len,
                          std::string("internal error: attribute \"") + a.name +
                              "\" has no values");
                return 1;
            }
            spec.attribute(a.name, OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, a.int_value),
                           a.float_values);
            break;
        default:
            set_error(err, err_len,
                      std::string("internal error: attribute \"") + a.name +
                          "\" has invalid type code " + std::to_string(a.type));
            return 1;
        }
    }

    if (!out->supports("ioproxy") || !out->set_ioproxy(&proxy)) {
        set_error(err, err_len,
                  std::string("the OpenImageIO writer for ") + out->format_name() +
                      " cannot write to memory");
        return 1;
    }
    if (!out->open(path, spec)) {
        set_error(err, err_len,
                  with_detail(std::string("cannot open for writing as ") + out->format_name(),
                              out->geterror(), OIIO::geterror()));
        return 1;
    }
    if (!out->write_image(OIIO::TypeDesc(OIIO::TypeDesc::FLOAT), data)) {
        std::string message = with_detail(std::string("writing ") + out->format_name() +
                                              " pixels failed",
                                          out->geterror(), OIIO::geterror());
        out->close();
        set_error(err, err_len, message);
        return 1;
    }
    if (!out->close()) {
        set_error(err, err_len,
                  with_detail(std::string("finishing the ") + out->format_name() +
                                  " file failed",
                              out->geterror(), OIIO::geterror()));
        return 1;
    }
    // A writer may leave a warning it did not fail on (OpenImageIO 2.4's TIFF writer about
    // an Exif directory it had nothing for): retrieve it, so that it is not printed.
    (void)out->geterror();
    return 0;
}

} // namespace

extern "C" RaylinkOiioEncoded *raylink_oiio_encode(const char *name, const char *format,
                                                   int width, int height, int nchannels,
                                                   const float *data,
                                                   const char *const *channel_names,
                                                   const RaylinkOiioAttr *attrs, size_t nattrs,
                                                   int pixel_type,
                                                   const RaylinkOiioWindow *window, char *err,
                                                   size_t err_len) {
    try {
        std::unique_ptr<RaylinkOiioEncoded> encoded(new RaylinkOiioEncoded);
        if (encode_impl(encoded.get(), name, format, width, height, nchannels, data,
                        channel_names, attrs, nattrs, pixel_type, window, err, err_len) != 0) {
            return nullptr;
        }
        return encoded.release();
    } catch (const std::bad_alloc &) {
        set_error(err, err_len, "out of memory while encoding the image");
        return nullptr;
    } catch (const std::exception &e) {
        set_error(err, err_len, std::string("OpenImageIO raised an exception: ") + e.what());
        return nullptr;
    } catch (...) {
        set_error(err, err_len, "OpenImageIO raised an unknown exception");
        return nullptr;
    }
}

extern "C" const unsigned char *raylink_oiio_encoded_data(const RaylinkOiioEncoded *encoded) {
    return encoded->bytes.data();
}

extern "C" size_t raylink_oiio_encoded_size(const RaylinkOiioEncoded *encoded) {
    return encoded->bytes.size();
}

extern "C" void raylink_oiio_encoded_free(RaylinkOiioEncoded *encoded) { delete encoded; }

namespace {

// libpng reports an error by calling the handler it was given and, if that returns, printing
// `libpng error: ...` on stderr itself before unwinding. OpenImageIO's PNG reader (2.4 and
// later alike) installs a handler that records the message and returns, so every damaged PNG
// it reads prints that line, and no attribute of OpenImageIO turns it off. So a PNG is first
// read here, by libpng with a handler that keeps the message and unwinds at once: a file
// libpng refuses is refused with its reason and OpenImageIO never sees it. Nothing is printed,
// and nothing global is touched, so it is safe on any thread.
struct PngCheck {
    char message[256];
};

void png_check_error(png_structp png, png_const_charp message) {
    PngCheck *check = static_cast<PngCheck *>(png_get_error_ptr(png));
    if (check != nullptr && check->message[0] == '\0') {
        std::snprintf(check->message, sizeof check->message, "%s",
                      message != nullptr ? message : "unknown libpng error");
    }
    png_longjmp(png, 1);
}

void png_check_warning(png_structp, png_const_charp) {}

// Reads `file` (positioned after the 8-byte signature) through libpng: its header, and with
// `whole` every row and the chunks after them. Returns false with libpng's reason in `check`.
// Only plain C data lives across the setjmp.
bool png_check_stream(FILE *file, bool whole, PngCheck *check) {
    png_structp png =
        png_create_read_struct(PNG_LIBPNG_VER_STRING, check, png_check_error, png_check_warning);
    if (png == nullptr) {
        std::snprintf(check->message, sizeof check->message, "libpng could not start");
        return false;
    }
    png_infop info = png_create_info_struct(png);
    unsigned char *volatile row = nullptr;
    volatile bool ok = false;
    if (info != nullptr && setjmp(png_jmpbuf(png)) == 0) {
        png_init_io(png, file);
        png_set_sig_bytes(png, 8);
        png_read_info(png, info);
        if (whole) {
            const int passes = png_set_interlace_handling(png);
            png_read_update_info(png, info);
            const png_uint_32 height = png_get_image_height(png, info);
            const size_t row_bytes = png_get_rowbytes(png, info);
            row = static_cast<unsigned char *>(std::malloc(row_bytes > 0 ? row_bytes : 1));
            if (row == nullptr) {
                std::snprintf(check->message, sizeof check->message,
                              "out of memory for a row of %zu bytes", row_bytes);
            } else {
                for (int pass = 0; pass < passes; ++pass) {
                    for (png_uint_32 y = 0; y < height; ++y) {
                        png_read_row(png, row, nullptr);
                    }
                }
                png_read_end(png, nullptr);
                ok = true;
            }
        } else {
            ok = true;
        }
    } else if (info == nullptr) {
        std::snprintf(check->message, sizeof check->message, "libpng could not start");
    }
    std::free(row);
    png_destroy_read_struct(&png, info != nullptr ? &info : nullptr, nullptr);
    return ok;
}

// If `path` is a PNG file (by its signature), reads it through libpng as above: returns false
// with the reason in `err` for a file libpng refuses. Any other file, or one that cannot be
// opened, is left to OpenImageIO.
bool png_check(const char *path, bool whole, char *err, size_t err_len) {
    FILE *file = std::fopen(path, "rb");
    if (file == nullptr) {
        return true;
    }
    unsigned char signature[8];
    bool ok = true;
    if (std::fread(signature, 1, 8, file) == 8 && png_sig_cmp(signature, 0, 8) == 0) {
        PngCheck check;
        check.message[0] = '\0';
        if (!png_check_stream(file, whole, &check)) {
            // libpng's reader says "Read Error" when the file ends before what it reads.
            const std::string reason = std::strcmp(check.message, "Read Error") == 0
                                           ? std::string("the file ends before its image does")
                                           : std::string(check.message);
            set_error(err, err_len, "damaged PNG file: " + reason);
            ok = false;
        }
    }
    std::fclose(file);
    return ok;
}

} // namespace

// Opens `path` and checks its header: an input whose spec() raylink_oiio_read can read, or
// null with the message in `err`. A PNG file's header is read through libpng first
// (png_check).
static OIIO::ImageInput::unique_ptr open_input(const char *path, char *err, size_t err_len) {
    if (path == nullptr) {
        set_error(err, err_len, "internal error: null path passed to raylink_oiio_read");
        return nullptr;
    }
    if (!png_check(path, false, err, err_len)) {
        return nullptr;
    }
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
        set_error(err, err_len, with_detail("cannot open for reading", OIIO::geterror()));
        return nullptr;
    }
    const OIIO::ImageSpec &spec = in->spec();
    if (spec.deep) {
        set_error(err, err_len, "deep images are not supported");
        return nullptr;
    }
    if (spec.width <= 0 || spec.height <= 0 || spec.depth != 1 || spec.nchannels <= 0) {
        set_error(err, err_len,
                  "unsupported image size " + std::to_string(spec.width) + "x" +
                      std::to_string(spec.height) + "x" + std::to_string(spec.depth) + " with " +
                      std::to_string(spec.nchannels) + " channels");
        return nullptr;
    }
    return in;
}

extern "C" int raylink_oiio_read_size(const char *path, int *width, int *height, int *nchannels,
                                      char *err, size_t err_len) {
    try {
        auto in = open_input(path, err, err_len);
        if (!in) {
            return 1;
        }
        const OIIO::ImageSpec &spec = in->spec();
        *width = spec.width;
        *height = spec.height;
        *nchannels = spec.nchannels;
        in->close();
        return 0;
    } catch (const std::exception &e) {
        set_error(err, err_len, std::string("OpenImageIO raised an exception: ") + e.what());
        return 1;
    } catch (...) {
        set_error(err, err_len, "OpenImageIO raised an unknown exception");
        return 1;
    }
}

extern "C" RaylinkOiioImage *raylink_oiio_read(const char *path, size_t max_values, char *err,
                                               size_t err_len) {
    try {
        auto in = open_input(path, err, err_len);
        if (!in) {
            return nullptr;
        }
        const OIIO::ImageSpec &spec = in->spec();
        // Positive ints: width * height fits in 64 bits; the channels are compared by division,
        // so nothing overflows.
        const unsigned long long pixels =
            (unsigned long long)spec.width * (unsigned long long)spec.height;
        if (pixels > max_values || (unsigned long long)spec.nchannels > max_values / pixels) {
            set_error(err, err_len,
                      "the image declares " + std::to_string(spec.width) + "x" +
                          std::to_string(spec.height) + " pixels of " +
                          std::to_string(spec.nchannels) + " channels, more than " +
                          std::to_string(max_values) + " values");
            return nullptr;
        }
        // Every row of a PNG through libpng before OpenImageIO decodes it (png_check), once
        // its size is known to be one raylink reads.
        if (!png_check(path, true, err, err_len)) {
            return nullptr;
        }

        std::unique_ptr<RaylinkOiioImage> image(new RaylinkOiioImage);
        image->width = spec.width;
        image->height = spec.height;
        image->nchannels = spec.nchannels;
        image->x = spec.x;
        image->y = spec.y;
        image->full_x = spec.full_x;
        image->full_y = spec.full_y;
        image->full_width = spec.full_width;
        image->full_height = spec.full_height;
        image->pixel_type = pixel_type_code(spec.format);
        image->format = in->format_name();
        for (int c = 0; c < spec.nchannels; ++c) {
            image->channel_names.push_back(c < int(spec.channelnames.size())
                                               ? spec.channelnames[c]
                                               : std::string());
        }
        image->pixels.resize(size_t(spec.width) * size_t(spec.height) * size_t(spec.nchannels));
        if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc(OIIO::TypeDesc::FLOAT),
                            image->pixels.data())) {
            set_error(err, err_len,
                      with_detail("reading pixels failed", in->geterror(), OIIO::geterror()));
            return nullptr;
        }
        for (const OIIO::ParamValue &p : spec.extra_attribs) {
            Attr attr;
            if (convert_attr(p, &attr)) {
                image->attrs.push_back(std::move(attr));
            }
        }
        in->close();
        return image.release();
    } catch (const std::exception &e) {
        set_error(err, err_len, std::string("OpenImageIO raised an exception: ") + e.what());
        return nullptr;
    } catch (...) {
        set_error(err, err_len, "OpenImageIO raised an unknown exception");
        return nullptr;
    }
}

extern "C" void raylink_oiio_image_free(RaylinkOiioImage *image) { delete image; }

extern "C" int raylink_oiio_image_width(const RaylinkOiioImage *image) { return image->width; }

extern "C" int raylink_oiio_image_height(const RaylinkOiioImage *image) { return image->height; }

extern "C" int raylink_oiio_image_nchannels(const RaylinkOiioImage *image) {
    return image->nchannels;
}

extern "C" void raylink_oiio_image_window(const RaylinkOiioImage *image, int *x, int *y,
                                         int *full_x, int *full_y, int *full_width,
                                         int *full_height) {
    *x = image->x;
    *y = image->y;
    *full_x = image->full_x;
    *full_y = image->full_y;
    *full_width = image->full_width;
    *full_height = image->full_height;
}

extern "C" int raylink_oiio_image_pixel_type(const RaylinkOiioImage *image) {
    return image->pixel_type;
}

extern "C" const char *raylink_oiio_image_format(const RaylinkOiioImage *image) {
    return image->format.c_str();
}

extern "C" const char *raylink_oiio_image_channel_name(const RaylinkOiioImage *image,
                                                       int index) {
    if (index < 0 || index >= image->nchannels) {
        return nullptr;
    }
    return image->channel_names[size_t(index)].c_str();
}

extern "C" const float *raylink_oiio_image_pixels(const RaylinkOiioImage *image) {
    return image->pixels.data();
}

extern "C" size_t raylink_oiio_image_nattrs(const RaylinkOiioImage *image) {
    return image->attrs.size();
}

extern "C" int raylink_oiio_image_attr(const RaylinkOiioImage *image, size_t index,
                                       RaylinkOiioAttr *attr) {
    if (index >= image->attrs.size() || attr == nullptr) {
        return 1;
    }
    const Attr &a = image->attrs[index];
    attr->name = a.name.c_str();
    attr->type = a.type;
    attr->string_value = a.string_value.c_str();
    attr->int_value = a.int_value;
    attr->float_value = a.float_value;
    attr->float_values = nullptr;
    return 0;
}

extern "C" int raylink_oiio_abi(void) { return RAYLINK_OIIO_ABI; }

extern "C" const char *raylink_oiio_version(void) {
    try {
        // Function-local statics are initialised once, thread-safely (C++11).
        static const std::string version = [] {
            int v = OIIO::openimageio_version(); // e.g. 20407 for 2.4.7
            return std::to_string(v / 10000) + "." + std::to_string(v / 100 % 100) + "." +
                   std::to_string(v % 100);
        }();
        return version.c_str();
    } catch (...) {
        return "unknown";
    }
}
