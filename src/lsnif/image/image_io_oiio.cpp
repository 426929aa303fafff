// image_io_oiio.cpp -- the OpenImageIO backend of image_io.h: every format OpenImageIO reads; writes
// EXR, HDR, PNG and JPEG. Built as the shared module liblsnif_image_oiio.so (image_io_module.h), which
// the tools open at their first image call through image_io_oiio_loader.cpp; the portable build of the
// GPU check links image_io_portable.cpp instead (CMakeLists.txt beside this file).
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <memory>

#include "lsnif/format/atomic_file.h"
#include "lsnif/image/image_io.h"
#include "lsnif/image/image_io_detail.h"
#include "lsnif/image/image_io_module.h"

namespace lsnif::image {
namespace {

using detail::kMaxPixels;

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
  if (Status s = detail::check_png_structure(path); !s) return s;
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
  static const char* const kWritable[] = {"exr", "hdr", "png", "jpg", "jpeg"};
  std::string ext;
  if (Status s = detail::check_writable(path, img, kWritable, 5, ext); !s) return s;
  const bool exr = ext == "exr", ldr = ext == "png" || ext == "jpg" || ext == "jpeg";

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
    // Half floats end at 65504: brighter pixels (a visible sun, a strong environment) would be
    // stored as infinities, so such an image is written in 32-bit floats.
    const bool half = exr && std::all_of(img.rgb.begin(), img.rgb.end(),
                                         [](float v) { return !(std::abs(v) > 65504.0f); });
    OIIO::ImageSpec spec(w, h, 3, half ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::FLOAT);
    spec.attribute("oiio:ColorSpace", "Linear");
    ok = out->open(path, spec) && out->write_image(OIIO::TypeFloat, img.rgb.data()) && out->close();
  }
  if (!ok) return Status::error("cannot write '%s': %s", path.c_str(), oiio_message(out.get()).c_str());
  if (encoded.empty()) return Status::error("cannot write '%s': the encoder produced no bytes", path.c_str());
  return write_file_atomic(path, encoded.data(), encoded.size());
}

Status load_image_oiio(const std::string& path, Image& out, bool raw) {
  try {
    return load_impl(path, out, raw);
  } catch (const std::exception& e) {
    OIIO::geterror();
    return Status::error("cannot read image '%s': %s", path.c_str(), e.what());
  }
}

Status save_image_oiio(const std::string& path, const Image& img) {
  try {
    return save_impl(path, img);
  } catch (const std::exception& e) {
    OIIO::geterror();
    return Status::error("cannot write '%s': %s", path.c_str(), e.what());
  }
}

constexpr module::Codec kCodec = {module::kAbiVersion, &load_image_oiio, &save_image_oiio};

}  // namespace
}  // namespace lsnif::image

// The module's one exported symbol (image_io_module.h); everything else is hidden.
extern "C" __attribute__((visibility("default"))) const lsnif::image::module::Codec* lsnif_image_oiio_codec() {
  return &lsnif::image::kCodec;
}
