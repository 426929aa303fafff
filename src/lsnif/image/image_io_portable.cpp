// image_io_portable.cpp -- the portable backend of image_io.h (lsnif_image_portable): the stb
// single-header libraries compiled in, so a program that links it needs no image library at run time
// (the GPU check folder, scripts/gpu-check.sh). Reads PNG, JPEG, BMP, TGA (8 or 16 bits) and Radiance
// HDR; writes PNG, JPEG and HDR. EXR is refused with a message naming what to do instead.
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STBI_NO_PSD
#define STBI_NO_PIC
#define STBI_NO_PNM
#define STBI_NO_GIF
#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include <cstdio>
#include <memory>
#include <vector>

#include "lsnif/format/atomic_file.h"
#include "lsnif/image/image_io.h"
#include "lsnif/image/image_io_detail.h"

namespace lsnif::image {
namespace {

using detail::kMaxPixels;

// The reason stb gave for its last failure (never empty).
std::string stb_reason() {
  const char* r = stbi_failure_reason();
  return r && *r ? r : "unknown stb_image error";
}

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};

// Fills `out` from `channels`-channel pixels (1: gray replicated, 3: RGB) through `value(i)`.
template <class Value>
void fill(Image& out, int w, int h, Value value) {
  out.width = uint32_t(w);
  out.height = uint32_t(h);
  out.rgb.resize(size_t(w) * size_t(h) * 3);
  for (size_t i = 0; i < out.rgb.size(); ++i) out.rgb[i] = value(i);
}

Status load_impl(const std::string& path, Image& out, bool raw) {
  if (detail::lower_extension(path) == "exr")
    return Status::error("cannot read image '%s': this build reads no EXR (its image reader is the portable one: "
                         "PNG, JPEG, BMP, TGA, HDR); convert it, e.g. `oiiotool %s -o %s.hdr`",
                         path.c_str(), path.c_str(), path.substr(0, path.size() - 4).c_str());
  if (Status s = detail::check_png_structure(path); !s) return s;
  std::unique_ptr<std::FILE, FileCloser> f(std::fopen(path.c_str(), "rb"));
  if (!f) return Status::error("cannot read image '%s': cannot open the file", path.c_str());
  int w = 0, h = 0, n = 0;
  if (!stbi_info_from_file(f.get(), &w, &h, &n))
    return Status::error("cannot read image '%s': %s", path.c_str(), stb_reason().c_str());
  if (w <= 0 || h <= 0) return Status::error("image '%s' is empty (%d x %d)", path.c_str(), w, h);
  if (uint64_t(w) * uint64_t(h) > kMaxPixels)
    return Status::error("image '%s' is too large (%d x %d; at most %llu pixels are read)", path.c_str(), w, h,
                         (unsigned long long)kMaxPixels);
  Image img;
  if (stbi_is_hdr_from_file(f.get())) {
    std::unique_ptr<float, void (*)(void*)> px(stbi_loadf_from_file(f.get(), &w, &h, &n, 3), stbi_image_free);
    if (!px) return Status::error("cannot read the pixels of '%s': %s", path.c_str(), stb_reason().c_str());
    fill(img, w, h, [&](size_t i) { return px.get()[i]; });
  } else if (stbi_is_16_bit_from_file(f.get())) {
    std::unique_ptr<uint16_t, void (*)(void*)> px(stbi_load_from_file_16(f.get(), &w, &h, &n, 3), stbi_image_free);
    if (!px) return Status::error("cannot read the pixels of '%s': %s", path.c_str(), stb_reason().c_str());
    fill(img, w, h, [&](size_t i) {
      const float v = float(px.get()[i]) / 65535.0f;
      return raw ? v : srgb_to_linear(v);
    });
  } else {
    std::unique_ptr<uint8_t, void (*)(void*)> px(stbi_load_from_file(f.get(), &w, &h, &n, 3), stbi_image_free);
    if (!px) return Status::error("cannot read the pixels of '%s': %s", path.c_str(), stb_reason().c_str());
    fill(img, w, h, [&](size_t i) {
      const float v = float(px.get()[i]) / 255.0f;
      return raw ? v : srgb_to_linear(v);
    });
  }
  out = std::move(img);
  return Status::ok();
}

void append_bytes(void* context, void* data, int size) {
  auto* bytes = static_cast<std::vector<unsigned char>*>(context);
  const auto* p = static_cast<const unsigned char*>(data);
  bytes->insert(bytes->end(), p, p + size);
}

}  // namespace

Status load_image(const std::string& path, Image& out, bool raw) { return load_impl(path, out, raw); }

Status save_image(const std::string& path, const Image& img) {
  static const char* const kWritable[] = {"hdr", "png", "jpg", "jpeg", "exr"};
  std::string ext;
  if (Status s = detail::check_writable(path, img, kWritable, 5, ext); !s) return s;
  if (ext == "exr")
    return Status::error("cannot write '%s': this build writes no EXR (its image writer is the portable one: PNG, "
                         "JPEG, HDR)", path.c_str());
  const int w = int(img.width), h = int(img.height);
  std::vector<unsigned char> encoded;
  int ok = 0;
  if (ext == "hdr") {
    ok = stbi_write_hdr_to_func(append_bytes, &encoded, w, h, 3, img.rgb.data());
  } else {
    std::vector<uint8_t> bytes(img.rgb.size());
    for (size_t i = 0; i < img.rgb.size(); ++i) bytes[i] = encode_srgb8(img.rgb[i]);
    ok = ext == "png" ? stbi_write_png_to_func(append_bytes, &encoded, w, h, 3, bytes.data(), w * 3)
                      : stbi_write_jpg_to_func(append_bytes, &encoded, w, h, 3, bytes.data(), 95);
  }
  if (!ok || encoded.empty()) return Status::error("cannot write '%s': the %s encoder failed", path.c_str(), ext.c_str());
  return write_file_atomic(path, encoded.data(), encoded.size());
}

}  // namespace lsnif::image
