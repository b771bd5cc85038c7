// ohm_oiio.cpp — the image functions of ohm_oiio.h over OpenImageIO 2.4
// (C++17), built as the module libohm_oiio.so that ohm_oiio_load.c opens on
// first use (ohm_oiio_module.h says why).
//
// The only translation unit of ohm that sees OpenImageIO.  Every function
// body the module's table points to runs inside OHM_OIIO_TRY ...
// OHM_OIIO_CATCH(err, path), so no C++ exception crosses into C; OIIO's own
// errors (geterror) are reported with the file name.

#include "ohm_oiio.h"
#include "ohm_oiio_module.h"

#include <OpenImageIO/imageio.h>

#include <cinttypes>
#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include <strings.h>

// One catch-all per exported function.  `err` may be NULL (ohm_fail allows it).
#define OHM_OIIO_TRY try {
#define OHM_OIIO_CATCH(err, path)                                                                 \
    }                                                                                             \
    catch (const std::bad_alloc &) {                                                              \
        return ohm_fail((err), OHM_ERR_NOMEM, "%s: OpenImageIO: out of memory", (path));          \
    }                                                                                             \
    catch (const std::exception &e_) {                                                            \
        return ohm_fail((err), OHM_ERR_INTERNAL, "%s: OpenImageIO wrapper: %s", (path), e_.what()); \
    }                                                                                             \
    catch (...) {                                                                                 \
        return ohm_fail((err), OHM_ERR_INTERNAL, "%s: OpenImageIO wrapper: unknown exception", (path)); \
    }

namespace {

enum class Format { none, png, exr };

Format format_of(const char *path)
{
    size_t n = std::strlen(path);
    if (n >= 4 && strcasecmp(path + n - 4, ".png") == 0) return Format::png;
    if (n >= 4 && strcasecmp(path + n - 4, ".exr") == 0) return Format::exr;
    return Format::none;
}

// The sRGB transfer curve (IEC 61966-2-1).
inline float srgb_encode(float v)
{
    if (!(v > 0.0f)) return 0.0f;
    if (v >= 1.0f) return 1.0f;
    return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

std::string one_line(std::string s)
{
    for (char &c : s)
        if (c == '\n' || c == '\r') c = ' ';
    while (!s.empty() && s.back() == ' ') s.pop_back();
    return s;
}

int write_to(const char *path, const char *write_path, const float *rgb, int width, int height, int channels,
             ohm_error *err)
{
    if (!path || !write_path) return ohm_fail(err, OHM_ERR_INVALID, "ohm_image_write_to: NULL path");
    OHM_OIIO_TRY
    Format fmt = format_of(path);
    if (fmt == Format::none)
        return ohm_fail(err, OHM_ERR_USAGE, "%s: unsupported image format: use .png or .exr", path);
    if (!rgb || width <= 0 || height <= 0 || (channels != 1 && channels != 3 && channels != 4))
        return ohm_fail(err, OHM_ERR_INVALID, "%s: bad image (%d x %d, %d channels)", path, width, height, channels);
    if ((double)width * height * channels > 1e9)
        return ohm_fail(err, OHM_ERR_INVALID, "%s: image of %d x %d is too large", path, width, height);
    const size_t count = (size_t)width * (size_t)height * (size_t)channels;

    std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(fmt == Format::png ? "png" : "openexr");
    if (!out)
        return ohm_fail(err, OHM_ERR_INTERNAL, "%s: OpenImageIO has no %s writer: %s", path,
                        fmt == Format::png ? "PNG" : "OpenEXR", one_line(OIIO::geterror()).c_str());
    bool ok;
    if (fmt == Format::png) {
        OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::UINT8);
        spec.attribute("oiio:ColorSpace", "sRGB");
        spec.attribute("Software", "ohm");
        std::vector<uint8_t> px(count);
        for (size_t i = 0; i < count; ++i) {
            bool alpha = channels == 4 && i % 4 == 3;
            float v = alpha ? std::fmin(std::fmax(rgb[i], 0.0f), 1.0f) : srgb_encode(rgb[i]);
            px[i] = (uint8_t)std::lround(v * 255.0f);
        }
        ok = out->open(write_path, spec) && out->write_image(OIIO::TypeDesc::UINT8, px.data());
    } else {
        OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::HALF);
        spec.attribute("oiio:ColorSpace", "linear");
        spec.attribute("compression", "zip");
        spec.attribute("Software", "ohm");
        ok = out->open(write_path, spec) && out->write_image(OIIO::TypeDesc::FLOAT, rgb);
    }
    if (ok) ok = out->close();
    if (!ok) {
        std::string msg = one_line(out->geterror());
        if (msg.empty()) msg = one_line(OIIO::geterror());
        return ohm_fail(err, OHM_ERR_IO, "%s: cannot write image: %s", path, msg.empty() ? "unknown error" : msg.c_str());
    }
    return OHM_OK;
    OHM_OIIO_CATCH(err, path)
}

// A 2-D image of at most 2^28 pixels and 64 channels.
int check_slice_spec(const char *path, const OIIO::ImageSpec &spec, ohm_error *err)
{
    const int64_t pw = spec.width, ph = spec.height, nc = spec.nchannels;
    if (pw <= 0 || ph <= 0 || nc <= 0 || spec.depth > 1)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: image is %" PRId64 " x %" PRId64 " x %d with %" PRId64
                        " channels, expected a 2-D image", path, pw, ph, spec.depth, nc);
    if (pw * ph > (int64_t(1) << 28) || nc > 64)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: image %" PRId64 " x %" PRId64 " x %" PRId64
                        " channels is larger than the limit of 2^28 pixels", path, pw, ph, nc);
    return OHM_OK;
}

int open_failure(const char *path, ohm_error *err)
{
    std::string msg = one_line(OIIO::geterror());
    return ohm_fail(err, OHM_ERR_IO, "%s: cannot read image: %s", path, msg.empty() ? "unknown error" : msg.c_str());
}

// The image opened and its spec checked (check_slice_spec); null, with *rc
// the error, when either fails.
OIIO::ImageInput::unique_ptr open_slice(const char *path, int *rc, ohm_error *err)
{
    auto in = OIIO::ImageInput::open(path);
    *rc = in ? check_slice_spec(path, in->spec(), err) : open_failure(path, err);
    if (*rc) in.reset();
    return in;
}

int image_size(const char *path, int *w, int *h, int *channels, ohm_error *err)
{
    if (!path || !w || !h || !channels) return ohm_fail(err, OHM_ERR_INVALID, "ohm_image_size: NULL argument");
    *w = *h = *channels = 0;
    OHM_OIIO_TRY
    int rc;
    auto in = open_slice(path, &rc, err);
    if (!in) return rc;
    const OIIO::ImageSpec &spec = in->spec();
    *w = spec.width;
    *h = spec.height;
    *channels = spec.nchannels;
    return OHM_OK;
    OHM_OIIO_CATCH(err, path)
}

// The first `use` channels of every pixel as floats, into buf; the image closed.
int read_floats(const char *path, OIIO::ImageInput *in, int use, std::vector<float> &buf, ohm_error *err)
{
    const OIIO::ImageSpec &spec = in->spec();
    buf.resize(size_t(int64_t(spec.width) * spec.height * use));
    // A decoder that meets a short strip (libtiff's TIFFReadEncodedStrip on a
    // truncated file) still returns true from read_image, with the rest of
    // the slice left as it was: an error recorded on the way is a failed read.
    const bool read = in->read_image(0, 0, 0, use, OIIO::TypeDesc::FLOAT, buf.data());
    if (!read || in->has_error()) {
        std::string msg = one_line(in->geterror());
        return ohm_fail(err, OHM_ERR_PARSE, "%s: cannot read pixels (%s): %s", path,
                        read ? "the image is incomplete" : "the decoder failed",
                        msg.empty() ? "unknown error" : msg.c_str());
    }
    in->close();
    return OHM_OK;
}

int read_gray(const char *path, float **pixels, int *w, int *h, ohm_error *err)
{
    if (!path || !pixels || !w || !h) return ohm_fail(err, OHM_ERR_INVALID, "ohm_image_read_gray: NULL argument");
    *pixels = nullptr;
    *w = *h = 0;
    OHM_OIIO_TRY
    int rc;
    auto in = open_slice(path, &rc, err);
    if (!in) return rc;
    const OIIO::ImageSpec &spec = in->spec();
    const int64_t pw = spec.width, ph = spec.height, nc = spec.nchannels;
    double scale = 1.0;
    switch (spec.format.basetype) {
    case OIIO::TypeDesc::UINT8: scale = 255.0; break;
    case OIIO::TypeDesc::INT8: scale = 127.0; break;
    case OIIO::TypeDesc::UINT16: scale = 65535.0; break;
    case OIIO::TypeDesc::INT16: scale = 32767.0; break;
    case OIIO::TypeDesc::UINT32: scale = 4294967295.0; break;
    case OIIO::TypeDesc::INT32: scale = 2147483647.0; break;
    default: break;
    }
    const int use = nc >= 3 ? 3 : 1; // grey, or R, G and B: never alpha nor extra channels
    std::vector<float> buf;
    rc = read_floats(path, in.get(), use, buf, err);
    if (rc) return rc;
    float *out = static_cast<float *>(std::malloc(size_t(pw * ph) * sizeof(float)));
    if (!out) return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory for %" PRId64 " pixels", path, pw * ph);
    for (size_t i = 0; i < size_t(pw * ph); ++i) {
        double s = 0;
        for (int c = 0; c < use; ++c) {
            const double v = double(buf[i * size_t(use) + size_t(c)]) * scale;
            s += scale != 1.0 ? std::nearbyint(v) : v; // integers come back exact
        }
        out[i] = float(s / use);
    }
    *pixels = out;
    *w = int(pw);
    *h = int(ph);
    return OHM_OK;
    OHM_OIIO_CATCH(err, path)
}

// Linear RGB as OpenImageIO converts it to float (integer pixels scaled to
// [0, 1]); a grey image (with or without alpha) repeats its channel.
int read_rgb(const char *path, float **pixels, int *w, int *h, ohm_error *err)
{
    if (!path || !pixels || !w || !h) return ohm_fail(err, OHM_ERR_INVALID, "ohm_image_read_rgb: NULL argument");
    *pixels = nullptr;
    *w = *h = 0;
    OHM_OIIO_TRY
    int rc;
    auto in = open_slice(path, &rc, err);
    if (!in) return rc;
    const OIIO::ImageSpec &spec = in->spec();
    const int64_t pw = spec.width, ph = spec.height;
    const int use = spec.nchannels >= 3 ? 3 : 1;
    std::vector<float> buf;
    rc = read_floats(path, in.get(), use, buf, err);
    if (rc) return rc;
    float *out = static_cast<float *>(std::malloc(size_t(pw * ph) * 3 * sizeof(float)));
    if (!out) return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory for %" PRId64 " pixels", path, pw * ph);
    for (size_t i = 0; i < size_t(pw * ph); ++i)
        for (int c = 0; c < 3; ++c) out[3 * i + size_t(c)] = buf[i * size_t(use) + size_t(use == 3 ? c : 0)];
    *pixels = out;
    *w = int(pw);
    *h = int(ph);
    return OHM_OK;
    OHM_OIIO_CATCH(err, path)
}

} // namespace

extern "C" __attribute__((visibility("default"))) const ohm_oiio_api *ohm_oiio_module(void)
{
    static const ohm_oiio_api api = {write_to, read_gray, image_size, read_rgb};
    return &api;
}
