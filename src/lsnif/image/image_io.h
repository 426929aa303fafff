// image_io.h -- reading and writing images through OpenImageIO for the renderer, FLIP and the
// viewer's screenshots. In memory an image is linear-light float RGB; 8-bit formats (PNG, JPEG) are
// sRGB-encoded on disk and converted on the way in and out; HDR formats (EXR, HDR) are linear.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "lsnif/format/status.h"

namespace lsnif::image {

struct Image {
  uint32_t width = 0, height = 0;
  std::vector<float> rgb;  // width * height * 3, row 0 = top
  float* at(uint32_t x, uint32_t y) { return rgb.data() + (size_t(y) * width + x) * 3; }
  const float* at(uint32_t x, uint32_t y) const { return rgb.data() + (size_t(y) * width + x) * 3; }
};

// True for file names whose format stores linear HDR values (.exr, .hdr), false for 8-bit ones.
bool is_hdr_path(const std::string& path);

// Reads `path` (any format OpenImageIO reads; 1-4 channels: gray is replicated, alpha dropped).
// 8-bit / 16-bit integer data are decoded from sRGB to linear unless `raw` is true. Fails with the
// file name and OpenImageIO's message on a missing, unreadable or empty file.
Status load_image(const std::string& path, Image& out, bool raw = false);

// Writes `img` to `path`, the format chosen by the extension: .exr (half float, or 32-bit float
// when a value lies beyond the half range, +-65504), .hdr, .png / .jpg
// (sRGB-encoded, clamped to [0, 1], rounded). Fails on an unknown extension, an empty or
// inconsistent image or a write error, naming the file.
Status save_image(const std::string& path, const Image& img);

// Ok when save_image would take the extension of `path` (.exr, .hdr, .png, .jpg, .jpeg), else the
// error it would give: what a command checks before the work whose result it writes. (Builds with
// the portable writer refuse .exr only when writing.)
Status check_image_extension(const std::string& path);

// The sRGB transfer function (IEC 61966-2-1), used by load_image / save_image and by FLIP:
// srgb_to_linear decodes an sRGB-encoded value (linear segment below 0.04045, else
// ((c + 0.055) / 1.055)^2.4), linear_to_srgb encodes a linear one (12.92 c below 0.0031308, else
// 1.055 c^(1/2.4) - 0.055). Computed in double, rounded to float once; no clamping.
float srgb_to_linear(float c);
float linear_to_srgb(float c);
// A linear value as a displayed 8-bit sRGB byte: NaN -> 0, clamped to [0, 1], encoded, rounded
// (what save_image writes to .png and the viewer shows).
uint8_t encode_srgb8(float linear);

}  // namespace lsnif::image
