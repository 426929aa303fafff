// environment_test.cpp -- the environment map's importance sampling (environment.h): the pdf is a
// density over the sphere, sample() and pdf() agree, samples follow luminance x sin(theta), a
// constant map is the uniform sphere, a single bright pixel takes the samples, the rotation is
// applied the same way everywhere, and the packed GPU layout is what the header says.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <random>
#include <unistd.h>

#include "lsnif/scene/environment.h"

namespace lsnif::scene {
namespace {

constexpr double kPi = std::numbers::pi;

image::Image make_image(uint32_t w, uint32_t h, float value = 1.0f) {
  image::Image img;
  img.width = w;
  img.height = h;
  img.rgb.assign(size_t(w) * h * 3, value);
  return img;
}

void set_pixel(image::Image& img, uint32_t x, uint32_t y, glm::vec3 c) {
  float* p = img.at(x, y);
  p[0] = c.x;
  p[1] = c.y;
  p[2] = c.z;
}

// A map with structure: random luminance, a few black pixels and a black row.
image::Image random_image(uint32_t w, uint32_t h, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  image::Image img = make_image(w, h);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      const float s = u(rng) < 0.1f ? 0.0f : std::pow(u(rng), 3.0f) * 10.0f;
      set_pixel(img, x, y, glm::vec3(s * u(rng), s * u(rng), s * u(rng)));
    }
  for (uint32_t x = 0; x < w; ++x) set_pixel(img, x, h / 3, glm::vec3(0.0f));
  return img;
}

// Midpoint rule over (theta, phi) on a grid that does not align with the pixels.
double integrate_pdf(const EnvironmentMap& m, int n_theta, int n_phi) {
  double sum = 0.0;
  const double dt = kPi / n_theta, dp = 2.0 * kPi / n_phi;
  for (int i = 0; i < n_theta; ++i) {
    const double theta = (i + 0.5) * dt;
    for (int j = 0; j < n_phi; ++j) {
      const double phi = (j + 0.5) * dp;
      const glm::vec3 d(float(std::sin(theta) * std::cos(phi)), float(std::cos(theta)),
                        float(std::sin(theta) * std::sin(phi)));
      sum += double(m.pdf(d)) * std::sin(theta) * dt * dp;
    }
  }
  return sum;
}

TEST(Environment, DirectionMappingConvention) {
  const float eps = 1e-5f;
  auto near = [&](glm::vec3 a, glm::vec3 b) { return glm::distance(a, b) < eps; };
  EXPECT_TRUE(near(uv_to_direction({0.5f, 0.5f}, 0.0f), {0, 0, -1}));   // image centre: -z
  EXPECT_TRUE(near(uv_to_direction({0.75f, 0.5f}, 0.0f), {1, 0, 0}));   // right of centre: +x
  EXPECT_TRUE(near(uv_to_direction({0.0f, 0.5f}, 0.0f), {0, 0, 1}));    // left edge: +z
  EXPECT_TRUE(near(uv_to_direction({0.3f, 0.0f}, 0.0f), {0, 1, 0}));    // top row: +y
  EXPECT_TRUE(near(uv_to_direction({0.5f, 0.5f}, float(kPi / 2)), {-1, 0, 0}));  // Ry(90 deg) -z = -x
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.001f, 0.999f);
  for (int i = 0; i < 1000; ++i) {
    const glm::vec2 uv(u(rng), u(rng));
    const float rot = u(rng) * 10.0f - 5.0f;
    const glm::vec2 back = direction_to_uv(uv_to_direction(uv, rot), rot);
    EXPECT_NEAR(back.x, uv.x, 1e-4f);
    EXPECT_NEAR(back.y, uv.y, 1e-4f);
  }
}

TEST(Environment, PackedLayout) {
  EnvironmentMap m;
  ASSERT_TRUE(build_environment_map(random_image(7, 5, 1), glm::vec3(1.0f), 0.0f, m));
  ASSERT_EQ(m.marginal_cdf.size(), 6u);
  ASSERT_EQ(m.conditional_cdf.size(), 5u * 8u);
  ASSERT_EQ(m.pdf_table.size(), 35u);
  const std::vector<float> p = m.packed();
  ASSERT_EQ(p.size(), 6u + 40u + 35u);
  EXPECT_EQ(m.conditional_offset(), 6u);
  EXPECT_EQ(m.pdf_offset(), 46u);
  EXPECT_EQ(p[0], 0.0f);
  EXPECT_EQ(p[5], 1.0f);
  for (uint32_t y = 0; y < 5; ++y) {
    EXPECT_LE(p[y], p[y + 1]);
    EXPECT_EQ(p[6 + y * 8], 0.0f);
    EXPECT_EQ(p[6 + y * 8 + 7], 1.0f);
    for (uint32_t x = 0; x < 7; ++x) {
      EXPECT_LE(p[6 + y * 8 + x], p[6 + y * 8 + x + 1]);
      EXPECT_EQ(p[46 + y * 7 + x], m.pdf_table[y * 7 + x]);
    }
  }
  // The black row has zero marginal probability and a uniform conditional.
  EXPECT_EQ(m.marginal_cdf[5 / 3], m.marginal_cdf[5 / 3 + 1]);
  EXPECT_FLOAT_EQ(m.conditional_cdf[(5 / 3) * 8 + 3], 3.0f / 7.0f);
}

TEST(Environment, PdfIntegratesToOne) {
  for (uint64_t seed : {1, 2, 3}) {
    EnvironmentMap m;
    ASSERT_TRUE(build_environment_map(random_image(32, 16, seed), glm::vec3(1.0f, 0.5f, 2.0f),
                                      float(seed), m));
    // Exactly, per pixel (pdf x solid angle) ...
    double exact = 0.0;
    for (uint32_t y = 0; y < m.height; ++y) {
      const double omega = 2.0 * kPi / m.width * (std::cos(kPi * y / m.height) - std::cos(kPi * (y + 1) / m.height));
      for (uint32_t x = 0; x < m.width; ++x) exact += double(m.pdf_table[y * m.width + x]) * omega;
    }
    EXPECT_NEAR(exact, 1.0, 1e-5);
    // ... and numerically through pdf(direction) on a grid unrelated to the pixels.
    EXPECT_NEAR(integrate_pdf(m, 701, 1403), 1.0, 5e-3) << seed;
  }
}

TEST(Environment, SampleAndPdfAgree) {
  EnvironmentMap m;
  ASSERT_TRUE(build_environment_map(random_image(64, 32, 5), glm::vec3(1.0f), 0.7f, m));
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int mismatches = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const EnvironmentSample s = m.sample(u(rng), u(rng));
    ASSERT_NEAR(glm::length(s.direction), 1.0f, 1e-4f);
    ASSERT_GT(s.pdf, 0.0f);  // zero-luminance pixels are never sampled
    ASSERT_EQ(s.pdf, m.pdf_table[s.y * m.width + s.x]);
    const float p = m.pdf(s.direction);
    if (p != s.pdf) {
      // Only a direction on a pixel edge may round into the neighbour.
      ++mismatches;
      const glm::uvec2 px = m.pixel(s.direction);
      const int dx = std::abs(int(px.x) - int(s.x)), dy = std::abs(int(px.y) - int(s.y));
      EXPECT_TRUE((dx <= 1 || dx == int(m.width) - 1) && dy <= 1) << px.x << "," << px.y << " vs " << s.x << "," << s.y;
    }
  }
  std::printf("[ info ] %d of %d sampled directions map back to a neighbouring pixel\n", mismatches, n);
  EXPECT_LT(mismatches, n / 1000) << mismatches;
  // The end points of [0, 1) and out-of-range inputs stay valid.
  for (float a : {0.0f, 0.9999999f, 1.0f, -1.0f, 2.0f, std::nanf("")})
    for (float b : {0.0f, 0.5f, 1.0f}) {
      const EnvironmentSample s = m.sample(a, b);
      EXPECT_TRUE(std::isfinite(s.direction.x) && std::isfinite(s.pdf) && s.pdf > 0.0f) << a << " " << b;
    }
}

TEST(Environment, HistogramFollowsLuminanceTimesSinTheta) {
  const uint32_t W = 16, H = 8;
  image::Image img = random_image(W, H, 9);
  EnvironmentMap m;
  ASSERT_TRUE(build_environment_map(img, glm::vec3(1.0f), 0.0f, m));
  // Expected probabilities, computed here from the image: luminance x sin(theta at row centre).
  std::vector<double> expected(W * H);
  double total = 0.0;
  for (uint32_t y = 0; y < H; ++y)
    for (uint32_t x = 0; x < W; ++x) {
      const float* p = img.at(x, y);
      const double lum = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
      expected[y * W + x] = lum * std::sin(kPi * (y + 0.5) / H);
      total += expected[y * W + x];
    }
  for (double& e : expected) e /= total;
  const int n = 400000;
  std::vector<int> counts(W * H, 0);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < n; ++i) {
    const glm::uvec2 px = m.pixel(m.sample(u(rng), u(rng)).direction);
    counts[px.y * W + px.x]++;
  }
  double chi2 = 0.0;
  int dof = -1, zero_hits = 0;
  for (size_t i = 0; i < counts.size(); ++i) {
    const double e = expected[i] * n;
    if (expected[i] == 0.0) {
      zero_hits += counts[i];
      continue;
    }
    chi2 += (counts[i] - e) * (counts[i] - e) / e;
    ++dof;
  }
  std::printf("[ info ] chi2 %.1f with %d degrees of freedom, %d samples in black pixels\n", chi2, dof,
              zero_hits);
  // Directions on a pixel edge can round into a black neighbour, very rarely.
  EXPECT_LE(zero_hits, n / 10000);
  // Mean dof, sd sqrt(2 dof): 6 sd is far outside chance for a fixed seed, well inside a wrong
  // distribution (e.g. dropping sin(theta) gives chi2 in the tens of thousands).
  EXPECT_LT(chi2, dof + 6.0 * std::sqrt(2.0 * dof)) << "chi2 " << chi2 << " dof " << dof;
  // The pdf of each pixel is its probability over its solid angle.
  for (uint32_t y = 0; y < H; ++y) {
    const double omega = 2.0 * kPi / W * (std::cos(kPi * y / H) - std::cos(kPi * (y + 1) / H));
    for (uint32_t x = 0; x < W; ++x)
      EXPECT_NEAR(m.pdf_table[y * W + x] * omega, expected[y * W + x], 1e-6);
  }
}

TEST(Environment, ConstantMapIsTheUniformSphere) {
  for (auto [w, h] : {std::pair<uint32_t, uint32_t>{1, 1}, {64, 32}, {5, 3}}) {
    EnvironmentMap m;
    ASSERT_TRUE(build_environment_map(make_image(w, h, 0.25f), glm::vec3(2.0f), 0.3f, m));
    EXPECT_NEAR(m.integral, 4.0 * kPi * 0.5, 1e-4);
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    glm::dvec3 mean(0.0);
    double mean_y2 = 0.0;
    const int n = 100000;
    for (int i = 0; i < n; ++i) {
      const EnvironmentSample s = m.sample(u(rng), u(rng));
      EXPECT_NEAR(s.pdf, 1.0 / (4.0 * kPi), 1e-6);
      mean += glm::dvec3(s.direction);
      mean_y2 += double(s.direction.y) * s.direction.y;
      glm::vec3 d = glm::normalize(glm::vec3(u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f));
      EXPECT_NEAR(m.pdf(d), 1.0 / (4.0 * kPi), 1e-6);
    }
    mean /= n;
    EXPECT_LT(glm::length(mean), 0.01);
    EXPECT_NEAR(mean_y2 / n, 1.0 / 3.0, 0.01);
  }
  // Black: the same uniform fallback, with integral 0.
  EnvironmentMap black;
  ASSERT_TRUE(build_environment_map(make_image(8, 4, 0.0f), glm::vec3(1.0f), 0.0f, black));
  EXPECT_EQ(black.integral, 0.0);
  EXPECT_NEAR(black.sample(0.3f, 0.6f).pdf, 1.0 / (4.0 * kPi), 1e-6);
  // The scene's constant environment (no file).
  Environment env;
  env.color = glm::vec3(0.5f, 1.0f, 2.0f);
  EnvironmentMap c;
  ASSERT_TRUE(load_environment_map(env, c));
  EXPECT_EQ(c.width, 1u);
  EXPECT_EQ(c.lookup(glm::vec3(0, 0, 1)), env.color);
  EXPECT_NEAR(c.pdf(glm::vec3(1, 0, 0)), 1.0 / (4.0 * kPi), 1e-7);
}

TEST(Environment, SingleBrightPixelGetsAlmostAllSamples) {
  const uint32_t W = 64, H = 32, bx = 40, by = 10;
  image::Image img = make_image(W, H, 0.001f);
  set_pixel(img, bx, by, glm::vec3(1e4f));
  EnvironmentMap m;
  ASSERT_TRUE(build_environment_map(img, glm::vec3(1.0f), 0.0f, m));
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int inside = 0;
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    const EnvironmentSample s = m.sample(u(rng), u(rng));
    const glm::uvec2 px = m.pixel(s.direction);
    inside += px.x == bx && px.y == by;
  }
  EXPECT_GT(inside, int(0.99 * n));
  // The bright pixel's direction has a huge pdf, the rest a tiny one.
  const glm::vec3 centre = uv_to_direction({(bx + 0.5f) / W, (by + 0.5f) / H}, 0.0f);
  EXPECT_GT(m.pdf(centre), 1000.0f * m.pdf(-centre));
  EXPECT_EQ(m.lookup(centre), glm::vec3(1e4f));
}

TEST(Environment, RotationIsAppliedConsistently) {
  const uint32_t W = 32, H = 16;
  image::Image img = random_image(W, H, 21);
  set_pixel(img, 5, 6, glm::vec3(500.0f));
  const float rot = 1.1f;
  EnvironmentMap m0, m1;
  ASSERT_TRUE(build_environment_map(img, glm::vec3(1.0f), 0.0f, m0));
  ASSERT_TRUE(build_environment_map(img, glm::vec3(1.0f), rot, m1));
  auto ry = [](glm::vec3 d, float a) {
    return glm::vec3(std::cos(a) * d.x + std::sin(a) * d.z, d.y, -std::sin(a) * d.x + std::cos(a) * d.z);
  };
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 10000; ++i) {
    const float a = u(rng), b = u(rng);
    const EnvironmentSample s0 = m0.sample(a, b), s1 = m1.sample(a, b);
    // The same sample, rotated about +y by `rot`, with the same pdf.
    ASSERT_LT(glm::distance(s1.direction, ry(s0.direction, rot)), 1e-5f);
    ASSERT_EQ(s0.pdf, s1.pdf);
    // Lookups and pdf of a world direction see the unrotated map at the inverse-rotated direction.
    const glm::vec3 d = glm::normalize(glm::vec3(u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f));
    const glm::vec3 back = ry(d, -rot);
    if (m1.pixel(d) == m0.pixel(back)) {  // (not when rounding puts them on either side of an edge)
      EXPECT_EQ(m1.pdf(d), m0.pdf(back));
      EXPECT_EQ(m1.lookup(d), m0.lookup(back));
    }
  }
  // The bright pixel is seen where the rotation put it.
  const glm::vec3 bright0 = uv_to_direction({5.5f / W, 6.5f / H}, 0.0f);
  EXPECT_EQ(m1.lookup(ry(bright0, rot)), glm::vec3(500.0f));
  EXPECT_NE(m1.lookup(bright0), glm::vec3(500.0f));
  // Within rounding: the library and this test may contract multiply-adds differently.
  EXPECT_LT(glm::distance(uv_to_direction({5.5f / W, 6.5f / H}, rot), ry(bright0, rot)), 1e-6f);
}

TEST(Environment, LoadsAnHdrFileThroughImageIo) {
  const std::string path = std::filesystem::temp_directory_path() /
                           ("lsnif_env_test_" + std::to_string(::getpid()) + ".hdr");
  image::Image img = random_image(16, 8, 4);
  ASSERT_TRUE(image::save_image(path, img));
  Environment env;
  env.path = path;
  env.color = glm::vec3(2.0f);
  env.rotation = 0.5f;
  EnvironmentMap m;
  Status s = load_environment_map(env, m);
  std::filesystem::remove(path);
  ASSERT_TRUE(s) << s.message();
  ASSERT_EQ(m.width, 16u);
  ASSERT_EQ(m.height, 8u);
  EXPECT_EQ(m.rotation, 0.5f);
  for (size_t i = 0; i < img.rgb.size(); ++i) {  // RGBE: 8 bits of mantissa below the pixel's largest channel
    const float* px = &img.rgb[i / 3 * 3];
    const float largest = std::max(px[0], std::max(px[1], px[2]));
    EXPECT_NEAR(m.radiance[i], 2.0f * img.rgb[i], 2.0f * largest / 64.0f + 1e-6f) << i;
  }
  double exact = 0.0;
  for (uint32_t y = 0; y < 8; ++y)
    for (uint32_t x = 0; x < 16; ++x)
      exact += double(m.pdf_table[y * 16 + x]) * 2.0 * kPi / 16 * (std::cos(kPi * y / 8) - std::cos(kPi * (y + 1) / 8));
  EXPECT_NEAR(exact, 1.0, 1e-5);
}

TEST(Environment, InvalidInputs) {
  EnvironmentMap m;
  EXPECT_FALSE(build_environment_map(make_image(0, 4), glm::vec3(1.0f), 0.0f, m));
  image::Image bad = make_image(4, 4);
  bad.rgb.pop_back();
  EXPECT_FALSE(build_environment_map(bad, glm::vec3(1.0f), 0.0f, m));
  image::Image nan = make_image(4, 4);
  nan.rgb[7] = std::nanf("");
  Status s = build_environment_map(nan, glm::vec3(1.0f), 0.0f, m);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message().find("(2, 0)"), std::string::npos) << s.message();
  EXPECT_FALSE(build_environment_map(make_image(4, 4), glm::vec3(-1.0f), 0.0f, m));
  EXPECT_FALSE(build_environment_map(make_image(4, 4), glm::vec3(1.0f), INFINITY, m));
  // Negative pixels count as black for sampling.
  image::Image neg = make_image(4, 2, 1.0f);
  set_pixel(neg, 1, 1, glm::vec3(-5.0f));
  ASSERT_TRUE(build_environment_map(neg, glm::vec3(1.0f), 0.0f, m));
  EXPECT_EQ(m.pdf_table[1 * 4 + 1], 0.0f);
  Environment env;
  env.path = "/nonexistent/sky.hdr";
  s = load_environment_map(env, m);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message().find("sky.hdr"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace lsnif::scene
