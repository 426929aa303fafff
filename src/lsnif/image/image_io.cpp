// image_io.cpp -- OpenImageIO behind the small interface of image_io.h. The sRGB transfer
// functions are applied here (not by OpenImageIO) so that load and save are exact inverses on 8-bit
// code values.
#include "lsnif/image/image_io.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <exception>
#include <fstream>
#include <memory>

#include "lsnif/format/atomic_file.h"

namespace lsnif::image {
namespace {

// Larger images are refused before any pixel memory is allocated: a corrupt header can claim
// any size, and 2^26 pixels (8192 x 8192) of float RGB are already 768 MiB.
constexpr uint64_t kMaxPixels = uint64_t(1) << 26;

std::string lower_extension(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot + 1);
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// OpenImageIO keeps error messages per object and globally; one left unread is printed at exit,
// so every failure path collects both (`object` may be null).
template <class T>
std::string oiio_message(const T* object) {
  std::string msg = object ? object->geterror() : std::string();
  const std::string global = OIIO::geterror();
  if (msg.empty()) msg = global;
  while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
  return msg.empty() ? std::string("unknown OpenImageIO error") : msg;
}

// A PNG file must be a sequence of chunks (length, type, data, CRC) ending with IEND. Truncated or
// structurally broken files are refused here, before OpenImageIO reads them: its PNG reader leaks
// a message string (a longjmp past a std::string) when the file ends early. Files that do not start
// with the PNG signature pass unchecked.
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

bool is_integer_format(OIIO::TypeDesc t) {
  using B = OIIO::TypeDesc::BASETYPE;
  switch (B(t.basetype)) {
    case B::UINT8: case B::INT8: case B::UINT16: case B::INT16: case B::UINT32: case B::INT32:
      return true;
    default:
      return false;
  }
}

Status load_impl(const std::string& path, Image& out, bool raw) {
  if (Status s = check_png_structure(path); !s) return s;
  // Unassociated alpha: colours as stored, not multiplied by alpha (which is then dropped).
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in)
    return Status::error("cannot read image '%s': %s", path.c_str(), oiio_message<OIIO::ImageInput>(nullptr).c_str());
  const OIIO::ImageSpec spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) {
    in->close();
    return Status::error("image '%s' is empty (%d x %d, %d channels)", path.c_str(), spec.width, spec.height,
                         spec.nchannels);
  }
  if (spec.depth > 1) {
    in->close();
    return Status::error("image '%s' is a volume (depth %d); only 2D images are supported", path.c_str(), spec.depth);
  }
  const uint64_t pixels = uint64_t(spec.width) * uint64_t(spec.height);
  if (pixels > kMaxPixels) {
    in->close();
    return Status::error("image '%s' is too large (%d x %d; at most %llu pixels are read)", path.c_str(), spec.width,
                         spec.height, (unsigned long long)kMaxPixels);
  }
  // Gray (1 channel) and gray + alpha (2) read channel 0 and replicate it; 3 or more channels read
  // the first three (OpenImageIO puts R, G, B first, also for EXR files) and drop the rest.
  const int read_channels = spec.nchannels >= 3 ? 3 : 1;
  std::vector<float> data(size_t(pixels) * size_t(read_channels));
  if (!in->read_image(0, 0, 0, read_channels, OIIO::TypeFloat, data.data())) {
    const std::string msg = oiio_message(in.get());
    in->close();
    return Status::error("cannot read the pixels of '%s': %s", path.c_str(), msg.c_str());
  }
  const bool decode = !raw && is_integer_format(spec.format);
  in->close();

  Image img;
  img.width = uint32_t(spec.width);
  img.height = uint32_t(spec.height);
  img.rgb.resize(size_t(pixels) * 3);
  for (size_t i = 0; i < size_t(pixels); ++i) {
    for (int c = 0; c < 3; ++c) {
      float v = data[i * size_t(read_channels) + size_t(read_channels == 3 ? c : 0)];
      if (decode) v = srgb_to_linear(v);
      img.rgb[i * 3 + size_t(c)] = v;
    }
  }
  out = std::move(img);
  return Status::ok();
}

Status save_impl(const std::string& path, const Image& img) {
  if (img.width == 0 || img.height == 0)
    return Status::error("cannot write '%s': the image is empty (%u x %u)", path.c_str(), img.width, img.height);
  if (img.rgb.size() != size_t(img.width) * img.height * 3)
    return Status::error("cannot write '%s': the image holds %zu values, %u x %u x 3 = %zu expected", path.c_str(),
                         img.rgb.size(), img.width, img.height, size_t(img.width) * img.height * 3);
  if (img.width > uint32_t(INT32_MAX) || img.height > uint32_t(INT32_MAX))
    return Status::error("cannot write '%s': %u x %u is too large", path.c_str(), img.width, img.height);
  const std::string ext = lower_extension(path);
  const bool exr = ext == "exr", hdr = ext == "hdr", ldr = ext == "png" || ext == "jpg" || ext == "jpeg";
  if (!exr && !hdr && !ldr)
    return Status::error("cannot write '%s': unknown image extension '%s' (expected .exr, .hdr, .png, .jpg or .jpeg)",
                         path.c_str(), ext.c_str());

  // Encoded in memory first, then written by write_file_atomic: OpenImageIO's own file writes are
  // not all checked, and a failed one would leave a partial image in place of the old one.
  auto out = OIIO::ImageOutput::create(path);
  if (!out)
    return Status::error("cannot write '%s': %s", path.c_str(), oiio_message<OIIO::ImageOutput>(nullptr).c_str());
  std::vector<unsigned char> encoded;
  OIIO::Filesystem::IOVecOutput memory(encoded);
  if (!out->set_ioproxy(&memory))
    return Status::error("cannot write '%s': the %s writer cannot encode into memory", path.c_str(), ext.c_str());
  const int w = int(img.width), h = int(img.height);
  bool ok = false;
  if (ldr) {
    std::vector<uint8_t> bytes(img.rgb.size());
    for (size_t i = 0; i < img.rgb.size(); ++i) {
      bytes[i] = encode_srgb8(img.rgb[i]);
    }
    OIIO::ImageSpec spec(w, h, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("oiio:ColorSpace", "sRGB");
    ok = out->open(path, spec) && out->write_image(OIIO::TypeDesc::UINT8, bytes.data()) && out->close();
  } else {
    OIIO::ImageSpec spec(w, h, 3, exr ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::FLOAT);
    spec.attribute("oiio:ColorSpace", "Linear");
    ok = out->open(path, spec) && out->write_image(OIIO::TypeFloat, img.rgb.data()) && out->close();
  }
  if (!ok) return Status::error("cannot write '%s': %s", path.c_str(), oiio_message(out.get()).c_str());
  if (encoded.empty()) return Status::error("cannot write '%s': the encoder produced no bytes", path.c_str());
  return write_file_atomic(path, encoded.data(), encoded.size());
}

}  // namespace

bool is_hdr_path(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == "exr" || ext == "hdr";
}

Status load_image(const std::string& path, Image& out, bool raw) {
  try {
    return load_impl(path, out, raw);
  } catch (const std::exception& e) {
    OIIO::geterror();
    return Status::error("cannot read image '%s': %s", path.c_str(), e.what());
  }
}

Status save_image(const std::string& path, const Image& img) {
  try {
    return save_impl(path, img);
  } catch (const std::exception& e) {
    OIIO::geterror();
    return Status::error("cannot write '%s': %s", path.c_str(), e.what());
  }
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
