// Tests of the portable image backend (image_io_portable.cpp, what the GPU check folder carries)
// against OpenImageIO itself as the independent reader and writer: files OpenImageIO writes (8 and
// 16 bits, gray, gray + alpha, RGBA, HDR) read to the same values; files the portable backend writes
// (PNG, HDR) read back by OpenImageIO to the expected code values; EXR, truncated and missing files
// fail with messages that say so.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "lsnif/image/image_io.h"
#include "lsnif/testing/scoped_test_dir.h"

namespace lsnif::image {
namespace {

// The sRGB decoding written out again here, so the tests do not trust the library's.
double decode_srgb(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

class ImageIoPortable : public ::testing::Test {
 protected:
  std::string path(const std::string& name) const { return dir_.path(name); }

  static void write_oiio(const std::string& p, int w, int h, int channels, OIIO::TypeDesc type, const void* data) {
    auto out = OIIO::ImageOutput::create(p);
    ASSERT_TRUE(out) << OIIO::geterror();
    OIIO::ImageSpec spec(w, h, channels, type);
    spec.attribute("oiio:UnassociatedAlpha", 1);
    ASSERT_TRUE(out->open(p, spec)) << out->geterror();
    ASSERT_TRUE(out->write_image(type, data)) << out->geterror();
    ASSERT_TRUE(out->close()) << out->geterror();
  }
  // Reads every channel of `p` as float with OpenImageIO (no sRGB decoding).
  static std::vector<float> read_oiio(const std::string& p, int& w, int& h, int& channels) {
    auto in = OIIO::ImageInput::open(p);
    EXPECT_TRUE(in) << OIIO::geterror();
    if (!in) return {};
    const OIIO::ImageSpec spec = in->spec();
    w = spec.width, h = spec.height, channels = spec.nchannels;
    std::vector<float> px(size_t(w) * size_t(h) * size_t(channels));
    EXPECT_TRUE(in->read_image(0, 0, 0, channels, OIIO::TypeFloat, px.data())) << in->geterror();
    in->close();
    return px;
  }

  test::ScopedTestDir dir_{"lsnif_image_io_portable_test"};
};

TEST_F(ImageIoPortable, ReadsWhatOpenImageIoWrites) {
  const int w = 4, h = 3, n = w * h;
  uint8_t gray[n], ga[n * 2], rgba[n * 4];
  uint16_t g16[n];
  for (int i = 0; i < n; ++i) {
    gray[i] = uint8_t(i * 23 % 256);
    ga[i * 2] = gray[i], ga[i * 2 + 1] = uint8_t(i * 40);
    rgba[i * 4] = gray[i], rgba[i * 4 + 1] = uint8_t(255 - gray[i]), rgba[i * 4 + 2] = 77, rgba[i * 4 + 3] = 0;
    g16[i] = uint16_t(i * 5001 % 65536);
  }
  write_oiio(path("g1.png"), w, h, 1, OIIO::TypeDesc::UINT8, gray);
  write_oiio(path("g2.png"), w, h, 2, OIIO::TypeDesc::UINT8, ga);
  write_oiio(path("g4.png"), w, h, 4, OIIO::TypeDesc::UINT8, rgba);
  write_oiio(path("g16.png"), w, h, 1, OIIO::TypeDesc::UINT16, g16);
  for (const char* name : {"g1.png", "g2.png"}) {
    Image img;
    const Status s = load_image(path(name), img);
    ASSERT_TRUE(s.is_ok()) << name << ": " << s.message();
    ASSERT_EQ(img.width, uint32_t(w));
    ASSERT_EQ(img.height, uint32_t(h));
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(img.rgb[size_t(i) * 3 + c], decode_srgb(gray[i] / 255.0), 1e-6) << name;
  }
  Image img;
  ASSERT_TRUE(load_image(path("g4.png"), img).is_ok());
  for (int i = 0; i < n; ++i) {
    EXPECT_NEAR(img.rgb[size_t(i) * 3 + 0], decode_srgb(gray[i] / 255.0), 1e-6);
    EXPECT_NEAR(img.rgb[size_t(i) * 3 + 1], decode_srgb((255 - gray[i]) / 255.0), 1e-6);
    EXPECT_NEAR(img.rgb[size_t(i) * 3 + 2], decode_srgb(77 / 255.0), 1e-6);
  }
  ASSERT_TRUE(load_image(path("g16.png"), img).is_ok());
  for (int i = 0; i < n; ++i) EXPECT_NEAR(img.rgb[size_t(i) * 3], decode_srgb(g16[i] / 65535.0), 1e-6) << i;
  ASSERT_TRUE(load_image(path("g16.png"), img, /*raw=*/true).is_ok());
  for (int i = 0; i < n; ++i) EXPECT_NEAR(img.rgb[size_t(i) * 3], g16[i] / 65535.0, 1e-6) << i;

  // Radiance HDR: the portable reader gives what OpenImageIO reads from the same file.
  std::vector<float> hdr(size_t(n) * 3);
  for (size_t i = 0; i < hdr.size(); ++i) hdr[i] = 0.01f + 37.0f * float(i % 7) / 6.0f;
  write_oiio(path("e.hdr"), w, h, 3, OIIO::TypeDesc::FLOAT, hdr.data());
  int rw = 0, rh = 0, rc = 0;
  const std::vector<float> truth = read_oiio(path("e.hdr"), rw, rh, rc);
  ASSERT_EQ(rc, 3);
  ASSERT_TRUE(load_image(path("e.hdr"), img).is_ok());
  ASSERT_EQ(img.rgb.size(), truth.size());
  for (size_t i = 0; i < truth.size(); ++i) EXPECT_NEAR(img.rgb[i], truth[i], 1e-6f * std::max(1.0f, truth[i])) << i;
}

TEST_F(ImageIoPortable, WritesWhatOpenImageIoReads) {
  Image img;
  img.width = 7;
  img.height = 5;
  img.rgb.resize(size_t(7) * 5 * 3);
  for (size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = float(i % 11) / 10.0f;
  ASSERT_TRUE(save_image(path("a.png"), img).is_ok());
  int w = 0, h = 0, c = 0;
  std::vector<float> px = read_oiio(path("a.png"), w, h, c);
  ASSERT_EQ(w, 7);
  ASSERT_EQ(h, 5);
  ASSERT_EQ(c, 3);
  for (size_t i = 0; i < px.size(); ++i)
    EXPECT_NEAR(px[i] * 255.0f, float(encode_srgb8(img.rgb[i])), 1e-3f) << i;  // the 8-bit code values

  for (float& v : img.rgb) v *= 50.0f;
  ASSERT_TRUE(save_image(path("a.hdr"), img).is_ok());
  px = read_oiio(path("a.hdr"), w, h, c);
  ASSERT_EQ(px.size(), img.rgb.size());
  for (size_t p = 0; p < px.size() / 3; ++p) {
    const float m = std::max({img.rgb[p * 3], img.rgb[p * 3 + 1], img.rgb[p * 3 + 2]});
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(px[p * 3 + k], img.rgb[p * 3 + k], m / 128.0f) << p;
  }
}

TEST_F(ImageIoPortable, ClearErrorsAndNoExr) {
  Image img;
  img.width = 2;
  img.height = 2;
  img.rgb.assign(12, 0.5f);
  Status s = save_image(path("a.exr"), img);
  ASSERT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("EXR"), std::string::npos) << s.message();
  EXPECT_FALSE(std::ifstream(path("a.exr")).good());
  const float one[3] = {1, 2, 3};
  write_oiio(path("b.exr"), 1, 1, 3, OIIO::TypeDesc::FLOAT, one);
  s = load_image(path("b.exr"), img);
  ASSERT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("oiiotool"), std::string::npos) << s.message();
  s = load_image(path("missing.png"), img);
  ASSERT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("missing.png"), std::string::npos) << s.message();
  s = save_image(path("a.tiff"), img);
  ASSERT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("'tiff'"), std::string::npos) << s.message();

  ASSERT_TRUE(save_image(path("t.png"), img).is_ok());
  std::ifstream f(path("t.png"), std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  bytes.resize(bytes.size() / 2);
  std::ofstream(path("t.png"), std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(bytes.size()));
  s = load_image(path("t.png"), img);
  ASSERT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("truncated"), std::string::npos) << s.message();
  EXPECT_EQ(img.width, 2u);  // left untouched
}

}  // namespace
}  // namespace lsnif::image
