// image_io_detail.h -- what the two backends of image_io.h (image_io_oiio.cpp: OpenImageIO;
// image_io_portable.cpp: the stb single-header libraries) share: extensions, the pixel limit, the PNG
// structure check and the checks of an image before it is written.
#pragma once
#include <cstdint>
#include <string>

#include "lsnif/format/status.h"
#include "lsnif/image/image_io.h"

namespace lsnif::image::detail {

// Larger images are refused before any pixel memory is allocated: a corrupt header can claim
// any size, and 2^26 pixels (8192 x 8192) of float RGB are already 768 MiB.
constexpr uint64_t kMaxPixels = uint64_t(1) << 26;

// The extension of `path` in lower case, without the dot ("" when there is none).
std::string lower_extension(const std::string& path);

// A PNG file must be a sequence of chunks (length, type, data, CRC) ending with IEND. Truncated or
// structurally broken files are refused before a decoder reads them. Files that do not start with
// the PNG signature, or cannot be opened, pass unchecked (the decoder reports them).
Status check_png_structure(const std::string& path);

// Ok when `img` can be written to `path`: not empty, rgb of width x height x 3 values, a size that
// fits an int, and an extension of `writable` (a list like ".exr, .hdr, .png"), which `ext` receives.
Status check_writable(const std::string& path, const Image& img, const char* const* extensions, size_t count,
                      std::string& ext);
// The extension part of check_writable: ok when the extension of `path` is one of `extensions`.
Status check_extension(const std::string& path, const char* const* extensions, size_t count, std::string& ext);

}  // namespace lsnif::image::detail
