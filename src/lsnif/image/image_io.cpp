// image_io.cpp -- what does not depend on the image backend: file-name checks, the sRGB transfer
// functions (applied here, not by a codec, so that load and save are exact inverses on 8-bit code
// values) and the checks image_io_detail.h shares between image_io_oiio.cpp and image_io_portable.cpp.
#include "lsnif/image/image_io.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <iterator>

#include "lsnif/image/image_io_detail.h"

namespace lsnif::image {

namespace detail {

std::string lower_extension(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot + 1);
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

Status check_png_structure(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return Status::ok();  // OpenImageIO reports the missing or unreadable file
  unsigned char sig[8] = {};
  f.read(reinterpret_cast<char*>(sig), 8);
  const unsigned char png_sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (f.gcount() != 8 || !std::equal(sig, sig + 8, png_sig)) return Status::ok();
  f.seekg(0, std::ios::end);
  const uint64_t size = uint64_t(f.tellg());
  uint64_t at = 8;
  for (;;) {
    if (at + 12 > size)
      return Status::error("cannot read image '%s': truncated PNG file (%llu bytes; a chunk header at byte %llu "
                           "runs past the end, and no IEND chunk)", path.c_str(), (unsigned long long)size,
                           (unsigned long long)at);
    unsigned char head[8];
    f.seekg(std::streamoff(at));
    f.read(reinterpret_cast<char*>(head), 8);
    if (f.gcount() != 8) return Status::error("cannot read image '%s': read error at byte %llu", path.c_str(),
                                              (unsigned long long)at);
    const uint64_t length = (uint64_t(head[0]) << 24) | (uint64_t(head[1]) << 16) | (uint64_t(head[2]) << 8) | head[3];
    if (length > 0x7fffffffu)
      return Status::error("cannot read image '%s': corrupt PNG file (chunk length %llu at byte %llu)", path.c_str(),
                           (unsigned long long)length, (unsigned long long)at);
    if (at + 12 + length > size)
      return Status::error("cannot read image '%s': truncated or corrupt PNG file (the %llu-byte chunk at byte %llu "
                           "runs past the end of the %llu-byte file)", path.c_str(), (unsigned long long)length,
                           (unsigned long long)at, (unsigned long long)size);
    if (std::equal(head + 4, head + 8, "IEND")) return Status::ok();
    at += 12 + length;
  }
}

Status check_writable(const std::string& path, const Image& img, const char* const* extensions, size_t count,
                      std::string& ext) {
  if (img.width == 0 || img.height == 0)
    return Status::error("cannot write '%s': the image is empty (%u x %u)", path.c_str(), img.width, img.height);
  if (img.rgb.size() != size_t(img.width) * img.height * 3)
    return Status::error("cannot write '%s': the image holds %zu values, %u x %u x 3 = %zu expected", path.c_str(),
                         img.rgb.size(), img.width, img.height, size_t(img.width) * img.height * 3);
  if (img.width > uint32_t(INT32_MAX) || img.height > uint32_t(INT32_MAX))
    return Status::error("cannot write '%s': %u x %u is too large", path.c_str(), img.width, img.height);
  return check_extension(path, extensions, count, ext);
}

Status check_extension(const std::string& path, const char* const* extensions, size_t count, std::string& ext) {
  ext = lower_extension(path);
  std::string list;
  for (size_t i = 0; i < count; ++i) {
    if (ext == extensions[i]) return Status::ok();
    list += std::string(i == 0 ? "." : i + 1 == count ? " or ." : ", .") + extensions[i];
  }
  return Status::error("cannot write '%s': unknown image extension '%s' (expected %s)", printable(path).c_str(),
                       printable(ext).c_str(), list.c_str());
}

}  // namespace detail

Status check_image_extension(const std::string& path) {
  static const char* const kWritable[] = {"exr", "hdr", "png", "jpg", "jpeg"};
  std::string ext;
  return detail::check_extension(path, kWritable, std::size(kWritable), ext);
}

bool is_hdr_path(const std::string& path) {
  const std::string ext = detail::lower_extension(path);
  return ext == "exr" || ext == "hdr";
}

float srgb_to_linear(float c) {
  if (c <= 0.04045f) return c / 12.92f;
  return float(std::pow((double(c) + 0.055) / 1.055, 2.4));
}

uint8_t encode_srgb8(float linear) {
  const float v = std::isnan(linear) ? 0.0f : std::clamp(linear, 0.0f, 1.0f);
  return uint8_t(std::lround(linear_to_srgb(v) * 255.0f));
}

float linear_to_srgb(float c) {
  if (c <= 0.0031308f) return c * 12.92f;
  return float(1.055 * std::pow(double(c), 1.0 / 2.4) - 0.055);
}

}  // namespace lsnif::image
