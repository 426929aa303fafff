// Tests of image_io: round trips through EXR (exact for half values), HDR (RGBE precision) and PNG
// (8-bit sRGB code values exact), gray / alpha inputs, and clear errors on missing, corrupt and
// unknown files, including a mutation test on the bytes of real PNG and EXR files.
#include "lsnif/image/image_io.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <algorithm>
#include <csignal>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "lsnif/testing/test_support.h"

namespace lsnif::image {
namespace {

namespace fs = std::filesystem;

// The sRGB transfer functions written out again here, so the tests do not trust the library's.
double decode_srgb(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }
double encode_srgb(double c) { return c <= 0.0031308 ? c * 12.92 : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055; }

class ImageIo : public ::testing::Test {
 protected:
  std::string path(const std::string& name) const { return dir_.path(name); }

  static std::vector<char> read_bytes(const std::string& p) {
    std::ifstream f(p, std::ios::binary);
    return std::vector<char>(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  }
  static void write_bytes(const std::string& p, const std::vector<char>& bytes) {
    std::ofstream f(p, std::ios::binary | std::ios::trunc);
    f.write(bytes.data(), std::streamsize(bytes.size()));
  }
  // Writes raw channel data with OpenImageIO directly (gray, gray + alpha, RGBA inputs).
  static void write_raw(const std::string& p, int w, int h, int channels, OIIO::TypeDesc type, const void* data) {
    auto out = OIIO::ImageOutput::create(p);
    ASSERT_TRUE(out) << OIIO::geterror();
    OIIO::ImageSpec spec(w, h, channels, type);
    spec.attribute("oiio:UnassociatedAlpha", 1);  // store the colours as given, not divided by alpha
    ASSERT_TRUE(out->open(p, spec)) << out->geterror();
    ASSERT_TRUE(out->write_image(type, data)) << out->geterror();
    ASSERT_TRUE(out->close()) << out->geterror();
  }

  static Image gradient(uint32_t w, uint32_t h) {
    Image img;
    img.width = w;
    img.height = h;
    img.rgb.resize(size_t(w) * h * 3);
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x) {
        float* p = img.at(x, y);
        p[0] = float(x) / float(w - 1);
        p[1] = float(y) / float(h - 1);
        p[2] = float((x * 7 + y * 13) % 17) / 16.0f;
      }
    return img;
  }

  test::ScopedTestDir dir_{"lsnif_image_io_test"};
};

TEST_F(ImageIo, IsHdrPath) {
  EXPECT_TRUE(is_hdr_path("a.exr"));
  EXPECT_TRUE(is_hdr_path("dir.png/a.EXR"));
  EXPECT_TRUE(is_hdr_path("x.hdr"));
  EXPECT_FALSE(is_hdr_path("a.png"));
  EXPECT_FALSE(is_hdr_path("a.jpg"));
  EXPECT_FALSE(is_hdr_path("dir.exr/noext"));
  EXPECT_FALSE(is_hdr_path("exr"));
}

// Half-representable values (including negative, tiny and large ones) survive EXR exactly, and
// row 0 stays the top row.
TEST_F(ImageIo, ExrRoundTripIsExactForHalfValues) {
  Image img;
  img.width = 7;
  img.height = 5;
  const float values[] = {0.0f, 1.0f, 0.5f, 0.25f, 3.75f, -2.5f, 1024.0f, 65504.0f, 0.000061035156f, 1.0f / 1024.0f,
                          0.333251953125f, 100.5f};
  for (size_t i = 0; i < size_t(img.width) * img.height * 3; ++i) img.rgb.push_back(values[(i * 5 + i / 3) % 12]);
  ASSERT_TRUE(save_image(path("a.exr"), img).is_ok());
  Image back;
  Status s = load_image(path("a.exr"), back);
  ASSERT_TRUE(s.is_ok()) << s.message();
  ASSERT_EQ(back.width, img.width);
  ASSERT_EQ(back.height, img.height);
  ASSERT_EQ(back.rgb.size(), img.rgb.size());
  for (size_t i = 0; i < img.rgb.size(); ++i) EXPECT_EQ(back.rgb[i], img.rgb[i]) << i;
  // HDR data are never sRGB-decoded, raw or not.
  Image raw;
  ASSERT_TRUE(load_image(path("a.exr"), raw, true).is_ok());
  EXPECT_EQ(raw.rgb, img.rgb);
}

// Values past the half range (a visible sun, a strong environment) are not written as infinities:
// such an image is stored in 32-bit floats, exactly.
TEST_F(ImageIo, ExrBeyondTheHalfRangeKeepsItsValues) {
  Image img = gradient(6, 3);
  img.rgb[4] = 65520.0f;  // rounds to infinity as a half
  img.rgb[7] = -1e10f;
  img.rgb[11] = 3.0e38f;
  img.rgb[12] = 0.1f;     // not a half: kept exactly too
  ASSERT_TRUE(save_image(path("bright.exr"), img).is_ok());
  Image back;
  ASSERT_TRUE(load_image(path("bright.exr"), back).is_ok());
  ASSERT_EQ(back.rgb.size(), img.rgb.size());
  for (size_t i = 0; i < img.rgb.size(); ++i) EXPECT_EQ(back.rgb[i], img.rgb[i]) << i;
}

// Values that are not half-representable are rounded to the nearest half (relative error 2^-11).
TEST_F(ImageIo, ExrRoundsToHalf) {
  Image img = gradient(9, 4);
  for (float& v : img.rgb) v = v * 3.1f + 0.01f;
  ASSERT_TRUE(save_image(path("b.exr"), img).is_ok());
  Image back;
  ASSERT_TRUE(load_image(path("b.exr"), back).is_ok());
  for (size_t i = 0; i < img.rgb.size(); ++i) EXPECT_NEAR(back.rgb[i], img.rgb[i], std::abs(img.rgb[i]) * 0.0005) << i;
}

// Radiance RGBE: one shared exponent and 8-bit mantissas, so each channel is within 1/128 of the
// pixel's largest channel; powers of two are exact.
TEST_F(ImageIo, HdrRoundTripWithinRgbePrecision) {
  Image img = gradient(11, 6);
  for (size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = img.rgb[i] * 40.0f + 0.001f * float(i % 5);
  img.at(0, 0)[0] = 1.0f;
  img.at(0, 0)[1] = 0.5f;
  img.at(0, 0)[2] = 0.25f;
  ASSERT_TRUE(save_image(path("c.hdr"), img).is_ok());
  Image back;
  Status s = load_image(path("c.hdr"), back);
  ASSERT_TRUE(s.is_ok()) << s.message();
  ASSERT_EQ(back.width, img.width);
  ASSERT_EQ(back.height, img.height);
  for (size_t p = 0; p < size_t(img.width) * img.height; ++p) {
    const float m = std::max({img.rgb[p * 3], img.rgb[p * 3 + 1], img.rgb[p * 3 + 2]});
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(back.rgb[p * 3 + c], img.rgb[p * 3 + c], m / 128.0f) << p << " " << c;
  }
  EXPECT_EQ(back.at(0, 0)[0], 1.0f);
  EXPECT_EQ(back.at(0, 0)[1], 0.5f);
  EXPECT_EQ(back.at(0, 0)[2], 0.25f);
}

// Every 8-bit sRGB code value: decode -> save -> load gives the code value back exactly, and the
// loaded linear value is the decoded code value.
TEST_F(ImageIo, PngRoundTripKeepsEveryCodeValue) {
  Image img;
  img.width = 256;
  img.height = 2;
  for (uint32_t y = 0; y < 2; ++y)
    for (uint32_t k = 0; k < 256; ++k) {
      const float v = float(decode_srgb(double(y == 0 ? k : 255 - k) / 255.0));
      img.rgb.insert(img.rgb.end(), {v, v, v});
    }
  ASSERT_TRUE(save_image(path("d.png"), img).is_ok());
  Image raw, lin;
  ASSERT_TRUE(load_image(path("d.png"), raw, true).is_ok());
  ASSERT_TRUE(load_image(path("d.png"), lin).is_ok());
  ASSERT_EQ(raw.width, 256u);
  ASSERT_EQ(raw.height, 2u);
  for (uint32_t y = 0; y < 2; ++y)
    for (uint32_t k = 0; k < 256; ++k) {
      const uint32_t code = y == 0 ? k : 255 - k;
      for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(std::lround(raw.at(k, y)[c] * 255.0f), long(code)) << k;
        EXPECT_NEAR(lin.at(k, y)[c], decode_srgb(code / 255.0), 1e-6) << k;
      }
    }
}

// Arbitrary linear values: re-encoding what comes back is within 1/255 (in fact half a code) of
// the sRGB encoding of the clamped input; out-of-range values and NaN are clamped.
TEST_F(ImageIo, PngRoundTripOfArbitraryValuesWithinOneCode) {
  Image img = gradient(37, 23);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-0.2f, 1.3f);
  for (float& v : img.rgb) v = u(rng);
  img.rgb[0] = std::nanf("");
  ASSERT_TRUE(save_image(path("e.png"), img).is_ok());
  Image back;
  ASSERT_TRUE(load_image(path("e.png"), back).is_ok());
  ASSERT_EQ(back.rgb.size(), img.rgb.size());
  for (size_t i = 0; i < img.rgb.size(); ++i) {
    const double want = std::isnan(img.rgb[i]) ? 0.0 : encode_srgb(std::clamp(double(img.rgb[i]), 0.0, 1.0));
    EXPECT_NEAR(encode_srgb(back.rgb[i]), want, 0.5 / 255.0 + 1e-6) << i;
  }
}

TEST_F(ImageIo, JpegRoundTripIsClose) {
  Image img;
  img.width = 16;
  img.height = 16;
  img.rgb.assign(16 * 16 * 3, float(decode_srgb(0.5)));
  ASSERT_TRUE(save_image(path("f.jpg"), img).is_ok());
  ASSERT_TRUE(save_image(path("f2.JPEG"), img).is_ok());
  Image back;
  ASSERT_TRUE(load_image(path("f.jpg"), back).is_ok());
  for (float v : back.rgb) EXPECT_NEAR(encode_srgb(v), 0.5, 3.0 / 255.0);
}

// Gray is replicated into R, G and B; alpha is dropped; 16-bit PNG data are sRGB-decoded too.
TEST_F(ImageIo, GrayAlphaAndSixteenBitInputs) {
  const int w = 3, h = 2;
  const uint8_t gray[w * h] = {0, 64, 128, 192, 255, 10};
  write_raw(path("g1.png"), w, h, 1, OIIO::TypeDesc::UINT8, gray);
  uint8_t ga[w * h * 2];
  for (int i = 0; i < w * h; ++i) ga[i * 2] = gray[i], ga[i * 2 + 1] = uint8_t(i * 40);
  write_raw(path("g2.png"), w, h, 2, OIIO::TypeDesc::UINT8, ga);
  uint8_t rgba[w * h * 4];
  for (int i = 0; i < w * h; ++i)
    rgba[i * 4] = gray[i], rgba[i * 4 + 1] = uint8_t(255 - gray[i]), rgba[i * 4 + 2] = 77, rgba[i * 4 + 3] = 0;
  write_raw(path("g4.png"), w, h, 4, OIIO::TypeDesc::UINT8, rgba);
  uint16_t g16[w * h];
  for (int i = 0; i < w * h; ++i) g16[i] = uint16_t(gray[i] * 257);
  write_raw(path("g16.png"), w, h, 1, OIIO::TypeDesc::UINT16, g16);
  const float fgray[w * h] = {0.0f, 0.5f, 2.0f, 8.0f, 0.125f, 1.0f};
  write_raw(path("g1.exr"), w, h, 1, OIIO::TypeDesc::FLOAT, fgray);

  for (const char* name : {"g1.png", "g2.png", "g16.png"}) {
    Image img;
    Status s = load_image(path(name), img);
    ASSERT_TRUE(s.is_ok()) << name << ": " << s.message();
    ASSERT_EQ(img.width, uint32_t(w));
    ASSERT_EQ(img.height, uint32_t(h));
    for (int i = 0; i < w * h; ++i)
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(img.rgb[size_t(i) * 3 + c], decode_srgb(gray[i] / 255.0), 1e-6) << name;
  }
  Image img;
  ASSERT_TRUE(load_image(path("g4.png"), img).is_ok());
  for (int i = 0; i < w * h; ++i) {
    EXPECT_NEAR(img.rgb[size_t(i) * 3 + 0], decode_srgb(gray[i] / 255.0), 1e-6);
    EXPECT_NEAR(img.rgb[size_t(i) * 3 + 1], decode_srgb((255 - gray[i]) / 255.0), 1e-6);
    EXPECT_NEAR(img.rgb[size_t(i) * 3 + 2], decode_srgb(77 / 255.0), 1e-6);
  }
  ASSERT_TRUE(load_image(path("g1.exr"), img).is_ok());
  for (int i = 0; i < w * h; ++i)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(img.rgb[size_t(i) * 3 + c], fgray[i]);
}

// Failures name the file and say what went wrong; the output image is left untouched.
TEST_F(ImageIo, ClearErrors) {
  Image img = gradient(4, 4);
  const Image before = img;

  Status s = load_image(path("missing.png"), img);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("missing.png"), std::string::npos) << s.message();
  EXPECT_EQ(img.rgb, before.rgb);

  write_bytes(path("empty.png"), {});
  s = load_image(path("empty.png"), img);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("empty.png"), std::string::npos) << s.message();

  const std::string text = "this is not an image at all\n";
  write_bytes(path("text.png"), std::vector<char>(text.begin(), text.end()));
  s = load_image(path("text.png"), img);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("text.png"), std::string::npos) << s.message();

  write_bytes(path("text.xyz"), std::vector<char>(text.begin(), text.end()));
  s = load_image(path("text.xyz"), img);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("text.xyz"), std::string::npos) << s.message();

  std::vector<char> junk(4096);
  std::mt19937 rng(1);
  for (char& c : junk) c = char(rng() & 0xff);
  write_bytes(path("junk.exr"), junk);
  s = load_image(path("junk.exr"), img);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("junk.exr"), std::string::npos) << s.message();
  EXPECT_EQ(img.rgb, before.rgb);

  s = save_image(path("out.xyz"), img);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("out.xyz"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("unknown image extension"), std::string::npos) << s.message();
  EXPECT_FALSE(fs::exists(path("out.xyz")));
  s = save_image(path("noextension"), img);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("noextension"), std::string::npos) << s.message();

  s = save_image(path("empty_out.png"), Image{});
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("empty"), std::string::npos) << s.message();

  Image bad = img;
  bad.rgb.pop_back();
  s = save_image(path("bad.exr"), bad);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("bad.exr"), std::string::npos) << s.message();

  for (const char* name : {"no/such/dir/a.png", "no/such/dir/a.exr"}) {
    s = save_image(path(name), img);
    EXPECT_FALSE(s.is_ok()) << name;
    EXPECT_NE(s.message().find(name), std::string::npos) << s.message();
  }
}

// A file truncated anywhere, or with bytes overwritten anywhere, never crashes the loader: it
// either fails with a message naming the file or returns an image of the original size.
TEST_F(ImageIo, CorruptedFilesFailCleanly) {
  const Image img = gradient(24, 16);
  for (const char* name : {"real.png", "real.exr", "real.hdr"}) {
    const std::string src = path(name);
    ASSERT_TRUE(save_image(src, img).is_ok());
    const std::vector<char> good = read_bytes(src);
    ASSERT_GT(good.size(), 32u);
    const std::string ext = fs::path(name).extension().string();
    const std::string target = path(std::string("mutant") + ext);
    std::mt19937 rng(1234);
    int failures = 0, loads = 0;
    for (int iter = 0; iter < 250; ++iter) {
      std::vector<char> bytes = good;
      switch (iter % 4) {
        case 0:  // truncate
          bytes.resize(rng() % bytes.size());
          break;
        case 1:  // flip a few bits
          for (int k = 0; k < 1 + int(rng() % 4); ++k) bytes[rng() % bytes.size()] ^= char(1u << (rng() % 8));
          break;
        case 2:  // overwrite a header byte with an extreme value
          bytes[rng() % std::min<size_t>(bytes.size(), 64)] = char((rng() & 1) ? 0xff : 0x00);
          break;
        default:  // overwrite a run of random bytes
        {
          const size_t at = rng() % bytes.size();
          const size_t n = std::min<size_t>(bytes.size() - at, 1 + rng() % 16);
          for (size_t k = 0; k < n; ++k) bytes[at + k] = char(rng() & 0xff);
        }
      }
      write_bytes(target, bytes);
      Image out;
      Status s = load_image(target, out);
      if (s.is_ok()) {
        ++loads;
        EXPECT_EQ(out.rgb.size(), size_t(out.width) * out.height * 3);
        EXPECT_GT(out.width, 0u);
        EXPECT_GT(out.height, 0u);
      } else {
        ++failures;
        EXPECT_NE(s.message().find(target), std::string::npos) << s.message();
        EXPECT_GT(s.message().size(), target.size() + 10) << s.message();
      }
    }
    EXPECT_GT(failures, 30) << name;  // the truncations alone fail
    RecordProperty(std::string(name) + "_loads", loads);
  }
}

// Every format is written whole or not at all: under a file size limit (a full disk for the
// writer) the save fails with the reason and the previous image stays as it was, in each format.
TEST_F(ImageIo, AFailingWriteKeepsThePreviousImage) {
  for (const char* name : {"full.png", "full.exr", "full.hdr", "full.jpg"}) {
    const std::string file = path(name);
    ASSERT_TRUE(save_image(file, gradient(8, 8)));
    std::ifstream in(file, std::ios::binary);
    const std::string before((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    // The limit is set on this process for the one call (OpenImageIO's threads forbid a fork):
    // the soft limit goes down and back up to the hard one.
    struct rlimit saved;
    ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &saved), 0);
    const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
    struct rlimit limit = {64, saved.rlim_max};
    ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &limit), 0);
    const Status s = save_image(file, gradient(256, 256));
    ::setrlimit(RLIMIT_FSIZE, &saved);
    std::signal(SIGXFSZ, old_handler);
    ASSERT_FALSE(s) << name;
    EXPECT_NE(s.message().find("File too large"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find(file), std::string::npos) << s.message();
    std::ifstream again(file, std::ios::binary);
    EXPECT_EQ(std::string((std::istreambuf_iterator<char>(again)), std::istreambuf_iterator<char>()), before) << name;
  }
  for (const auto& e : std::filesystem::directory_iterator(dir_.path()))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
}

}  // namespace
}  // namespace lsnif::image
