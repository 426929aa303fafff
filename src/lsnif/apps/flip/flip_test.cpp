// Tests of FLIP: the stages against the papers' formulas (color spaces, CSF and feature kernels,
// error redistribution, tone mapper, exposure range), and the properties the papers give or imply
// (identical images give 0, LDR-FLIP is symmetric while HDR-FLIP with the automatic exposure range
// is not, green vs blue is the largest color error, more noise gives a larger mean, a shifted edge
// gives feature error only along the edge, HDR-FLIP at one exposure is LDR-FLIP of the tone-mapped
// images), the statistics and the heatmap.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>

#include "lsnif/apps/flip/flip.h"
#include "lsnif/apps/flip/flip_detail.h"

namespace lsnif::flip {
namespace {

using detail::Vec3;
constexpr double kPi = std::numbers::pi;

Image make_image(uint32_t w, uint32_t h, float r, float g, float b) {
  Image img;
  img.width = w;
  img.height = h;
  img.rgb.resize(size_t(w) * h * 3);
  for (size_t i = 0; i < size_t(w) * h; ++i) {
    img.rgb[i * 3] = r;
    img.rgb[i * 3 + 1] = g;
    img.rgb[i * 3 + 2] = b;
  }
  return img;
}

Image random_image(uint32_t w, uint32_t h, uint32_t seed, float scale = 1.0f) {
  Image img = make_image(w, h, 0, 0, 0);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, scale);
  for (float& v : img.rgb) v = u(rng);
  return img;
}

// A smooth colourful image: gradients and a soft disc.
Image smooth_image(uint32_t w, uint32_t h) {
  Image img = make_image(w, h, 0, 0, 0);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      const float u = float(x) / float(w), v = float(y) / float(h);
      const float d = std::hypot(u - 0.5f, v - 0.5f);
      float* p = img.at(x, y);
      p[0] = 0.2f + 0.6f * u;
      p[1] = 0.3f + 0.4f * v;
      p[2] = d < 0.3f ? 0.8f : 0.2f + 0.5f * d;
    }
  return img;
}

float max_abs(const Vec3& a, const Vec3& b) {
  return std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])});
}

// ---- the papers' numbers ---------------------------------------------------------------------------

// Both papers' default: an observer 0.7 m from a 0.7 m wide 3840-pixel monitor sees 67 pixels per
// degree (pi * 3840 / 180 = 67.02).
TEST(FlipPaper, PixelsPerDegreeOfTheDefaultViewingCondition) {
  EXPECT_NEAR(pixels_per_degree(0.7, 0.7, 3840.0), 67.0206, 1e-4);
  EXPECT_NEAR(pixels_per_degree(0.7, 0.7, 3840.0), FlipSettings{}.pixels_per_degree, 0.05);
}

// The constants of the LDR-FLIP paper.
TEST(FlipPaper, Constants) {
  EXPECT_EQ(detail::kQc, 0.7);
  EXPECT_EQ(detail::kPc, 0.4);
  EXPECT_EQ(detail::kPt, 0.95);
  EXPECT_EQ(detail::kQf, 0.5);
  EXPECT_EQ(detail::kFeatureWidth, 0.082);
  EXPECT_EQ(detail::kCsf[0].a1, 1.0);
  EXPECT_EQ(detail::kCsf[0].b1, 0.0047);
  EXPECT_EQ(detail::kCsf[1].b1, 0.0053);
  EXPECT_EQ(detail::kCsf[2].a1, 34.1);
  EXPECT_EQ(detail::kCsf[2].b1, 0.04);
  EXPECT_EQ(detail::kCsf[2].a2, 13.5);
  EXPECT_EQ(detail::kCsf[2].b2, 0.025);
}

// ---- color spaces -----------------------------------------------------------------------------------

TEST(FlipColor, SrgbMatrixAndWhite) {
  // The luminance row of sRGB and the D65 white (Y = 1) from the primaries.
  const Vec3 r = detail::linear_rgb_to_xyz({1, 0, 0}), g = detail::linear_rgb_to_xyz({0, 1, 0}),
             b = detail::linear_rgb_to_xyz({0, 0, 1});
  EXPECT_NEAR(r[1], 0.2126, 1e-4);
  EXPECT_NEAR(g[1], 0.7152, 1e-4);
  EXPECT_NEAR(b[1], 0.0722, 1e-4);
  EXPECT_NEAR(r[0], 0.4124, 1e-4);
  EXPECT_NEAR(b[2], 0.9505, 1e-4);
  const Vec3 w = detail::white_xyz();
  EXPECT_NEAR(w[0], 0.95046, 1e-4);
  EXPECT_NEAR(w[1], 1.0, 1e-6);
  EXPECT_NEAR(w[2], 1.08906, 1e-4);
  EXPECT_NEAR(detail::luminance({1, 1, 1}), 1.0f, 1e-6);
}

TEST(FlipColor, RoundTripsAndFixedPoints) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 200; ++i) {
    const Vec3 rgb = {u(rng), u(rng), u(rng)};
    const Vec3 xyz = detail::linear_rgb_to_xyz(rgb);
    EXPECT_LT(max_abs(detail::xyz_to_linear_rgb(xyz), rgb), 1e-5f);
    EXPECT_LT(max_abs(detail::ycxcz_to_xyz(detail::xyz_to_ycxcz(xyz)), xyz), 1e-5f);
  }
  for (int i = 0; i <= 255; ++i) {
    const float c = float(i) / 255.0f;
    EXPECT_NEAR(detail::linear_to_srgb(detail::srgb_to_linear(c)), c, 1e-6f);
  }
  // White is L* = 100, a* = b* = 0 (and Y = 100 in YCxCz); black is 0 (-16 in YCxCz's Y).
  const Vec3 white = detail::xyz_to_lab(detail::linear_rgb_to_xyz({1, 1, 1}));
  EXPECT_NEAR(white[0], 100.0f, 1e-4f);
  EXPECT_NEAR(white[1], 0.0f, 1e-3f);
  EXPECT_NEAR(white[2], 0.0f, 1e-3f);
  const Vec3 wy = detail::xyz_to_ycxcz(detail::linear_rgb_to_xyz({1, 1, 1}));
  EXPECT_NEAR(wy[0], 100.0f, 1e-4f);
  EXPECT_NEAR(wy[1], 0.0f, 1e-3f);
  EXPECT_NEAR(wy[2], 0.0f, 1e-3f);
  EXPECT_NEAR(detail::xyz_to_lab({0, 0, 0})[0], 0.0f, 1e-5f);
  // CIELAB of sRGB green and blue (textbook values: L 87.7 / 32.3, a -86.2 / 79.2, b 83.2 / -107.9).
  const Vec3 green = detail::xyz_to_lab(detail::linear_rgb_to_xyz({0, 1, 0}));
  const Vec3 blue = detail::xyz_to_lab(detail::linear_rgb_to_xyz({0, 0, 1}));
  EXPECT_NEAR(green[0], 87.73f, 0.05f);
  EXPECT_NEAR(green[1], -86.18f, 0.1f);
  EXPECT_NEAR(green[2], 83.18f, 0.1f);
  EXPECT_NEAR(blue[0], 32.30f, 0.05f);
  EXPECT_NEAR(blue[1], 79.19f, 0.1f);
  EXPECT_NEAR(blue[2], -107.86f, 0.1f);
}

TEST(FlipColor, HuntAndHyab) {
  const Vec3 lab = {50.0f, 20.0f, -40.0f};
  const Vec3 h = detail::hunt_adjust(lab);
  EXPECT_FLOAT_EQ(h[0], 50.0f);
  EXPECT_FLOAT_EQ(h[1], 10.0f);
  EXPECT_FLOAT_EQ(h[2], -20.0f);
  EXPECT_FLOAT_EQ(detail::hyab({10, 0, 0}, {40, 3, 4}), 30.0f + 5.0f);
  EXPECT_FLOAT_EQ(detail::hyab({40, 3, 4}, {10, 0, 0}), 35.0f);
}

// The LDR-FLIP paper normalizes the color error by the HyAB distance between Hunt-adjusted green
// and blue, the largest in the sRGB gamut: check that no pair of colours on a grid of the RGB cube
// is farther apart.
TEST(FlipColor, GreenBlueIsTheLargestDistanceInTheGamut) {
  std::vector<Vec3> colors;
  const int n = 7;
  for (int r = 0; r < n; ++r)
    for (int g = 0; g < n; ++g)
      for (int b = 0; b < n; ++b)
        colors.push_back(detail::linear_rgb_to_hunt_lab({float(r) / (n - 1), float(g) / (n - 1), float(b) / (n - 1)}));
  const float green_blue =
      detail::hyab(detail::linear_rgb_to_hunt_lab({0, 1, 0}), detail::linear_rgb_to_hunt_lab({0, 0, 1}));
  float largest = 0;
  for (size_t i = 0; i < colors.size(); ++i)
    for (size_t j = i + 1; j < colors.size(); ++j) largest = std::max(largest, detail::hyab(colors[i], colors[j]));
  EXPECT_LE(largest, green_blue * (1.0f + 1e-6f));
  EXPECT_NEAR(largest, green_blue, green_blue * 1e-6f);
  EXPECT_NEAR(detail::max_color_error(), std::pow(double(green_blue), 0.7), 1e-9);
  EXPECT_NEAR(green_blue, 203.3f, 0.5f);
}

// The redistribution: 0 -> 0, pc * cmax -> pt (continuous there), cmax -> 1, increasing.
TEST(FlipColor, ErrorRedistribution) {
  const double cmax = detail::max_color_error();
  EXPECT_EQ(detail::redistribute_color_error(0.0f), 0.0f);
  const float knee = float(std::pow(0.4 * cmax, 1.0 / 0.7));
  EXPECT_NEAR(detail::redistribute_color_error(knee), 0.95f, 1e-5f);
  EXPECT_NEAR(detail::redistribute_color_error(knee * 0.9999f), 0.95f, 1e-3f);
  EXPECT_NEAR(detail::redistribute_color_error(float(std::pow(cmax, 1.0 / 0.7))), 1.0f, 1e-5f);
  float previous = -1;
  for (float d = 0; d <= 210; d += 0.5f) {
    const float e = detail::redistribute_color_error(d);
    EXPECT_GT(e, previous) << d;
    previous = e;
  }
}

// ---- filters ----------------------------------------------------------------------------------------

// The CSF kernels: radius ceil(3 sqrt(0.04 / (2 pi^2)) ppd), sum 1, equal to the papers' spatial
// formula sampled at pixel / ppd degrees (written out here independently), and the separable terms
// add up to the dense kernel.
TEST(FlipFilters, CsfKernelsAreTheNormalizedPaperFormula) {
  EXPECT_EQ(detail::csf_radius(67.0), 10);
  for (double ppd : {5.0, 30.0, 67.0, 120.0}) {
    const int r = detail::csf_radius(ppd);
    EXPECT_EQ(r, int(std::ceil(3.0 * std::sqrt(0.04 / (2.0 * kPi * kPi)) * ppd)));
    const size_t n = size_t(2 * r + 1);
    for (int c = 0; c < 3; ++c) {
      const std::vector<double> k = detail::csf_kernel_2d(c, ppd);
      ASSERT_EQ(k.size(), n * n);
      double sum = 0;
      for (double v : k) sum += v;
      EXPECT_NEAR(sum, 1.0, 1e-12) << c << " " << ppd;

      const detail::CsfParams p = detail::kCsf[c];
      std::vector<double> want(n * n);
      double want_sum = 0;
      for (int y = -r; y <= r; ++y)
        for (int x = -r; x <= r; ++x) {
          const double d2 = (double(x) * x + double(y) * y) / (ppd * ppd);
          const double s = p.a1 * std::sqrt(kPi / p.b1) * std::exp(-kPi * kPi * d2 / p.b1) +
                           p.a2 * std::sqrt(kPi / p.b2) * std::exp(-kPi * kPi * d2 / p.b2);
          want[size_t(y + r) * n + size_t(x + r)] = s;
          want_sum += s;
        }
      for (size_t i = 0; i < n * n; ++i) EXPECT_NEAR(k[i], want[i] / want_sum, 1e-12) << c << " " << i;

      const std::vector<detail::SeparableTerm> terms = detail::csf_kernel(c, ppd);
      EXPECT_EQ(terms.size(), c == 2 ? 2u : 1u);
      for (size_t y = 0; y < n; ++y)
        for (size_t x = 0; x < n; ++x) {
          double v = 0;
          for (const auto& t : terms) v += double(t.horizontal[x]) * double(t.vertical[y]);
          EXPECT_NEAR(v, k[y * n + x], 1e-7) << c;
        }
    }
  }
}

// Separable filtering with repeated borders equals a direct 2D correlation with the dense kernel.
TEST(FlipFilters, SeparableFilteringMatchesDirect2D) {
  const uint32_t w = 29, h = 17;
  detail::Plane in(w, h);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-20.0f, 100.0f);
  for (float& v : in.v) v = u(rng);
  const double ppd = 40.0;
  for (int c = 0; c < 3; ++c) {
    const detail::Plane out = detail::apply_separable(in, detail::csf_kernel(c, ppd));
    const std::vector<double> k = detail::csf_kernel_2d(c, ppd);
    const int r = detail::csf_radius(ppd), n = 2 * r + 1;
    for (int y = 0; y < int(h); ++y)
      for (int x = 0; x < int(w); ++x) {
        double want = 0;
        for (int j = -r; j <= r; ++j)
          for (int i = -r; i <= r; ++i)
            want += k[size_t((j + r) * n + (i + r))] * double(in.at(uint32_t(std::clamp(x + i, 0, int(w) - 1)),
                                                                    uint32_t(std::clamp(y + j, 0, int(h) - 1))));
        EXPECT_NEAR(out.at(uint32_t(x), uint32_t(y)), want, 1e-3) << c << " " << x << " " << y;
      }
  }
}

// Feature kernels: sigma = 0.5 * 0.082 * ppd, radius ceil(3 sigma); the Gaussian sums to 1; each
// derivative's positive weights sum to 1 and negative weights to -1; d1 is odd, d2 even.
TEST(FlipFilters, FeatureKernelsAreNormalized) {
  const detail::FeatureKernels k67 = detail::feature_kernels(67.0);
  EXPECT_NEAR(k67.sigma, 2.747, 1e-9);
  EXPECT_EQ(k67.radius, 9);
  for (double ppd : {1.0, 10.0, 67.0, 200.0}) {
    const detail::FeatureKernels k = detail::feature_kernels(ppd);
    EXPECT_EQ(k.radius, int(std::ceil(3.0 * 0.5 * 0.082 * ppd)));
    const size_t n = size_t(2 * k.radius + 1);
    ASSERT_EQ(k.gauss.size(), n);
    double g = 0, p1 = 0, n1 = 0, p2 = 0, n2 = 0;
    for (size_t i = 0; i < n; ++i) {
      g += k.gauss[i];
      (k.d1[i] > 0 ? p1 : n1) += k.d1[i];
      (k.d2[i] > 0 ? p2 : n2) += k.d2[i];
      EXPECT_FLOAT_EQ(k.d1[i], -k.d1[n - 1 - i]);
      EXPECT_FLOAT_EQ(k.d2[i], k.d2[n - 1 - i]);
      EXPECT_FLOAT_EQ(k.gauss[i], k.gauss[n - 1 - i]);
    }
    EXPECT_NEAR(g, 1.0, 1e-6) << ppd;
    EXPECT_NEAR(p1, 1.0, 1e-6) << ppd;
    EXPECT_NEAR(n1, -1.0, 1e-6) << ppd;
    EXPECT_NEAR(p2, 1.0, 1e-6) << ppd;
    EXPECT_NEAR(n2, -1.0, 1e-6) << ppd;
    // Shape: the edge kernel is -x g(x) up to scale, the point kernel (x^2 / s^2 - 1) g(x).
    const double s = k.sigma;
    const int i1 = std::max(1, k.radius / 3);
    const size_t c = size_t(k.radius);
    EXPECT_NEAR(k.d1[c - size_t(i1)] / k.d1[c - 1],
                double(i1) * std::exp(-double(i1) * i1 / (2 * s * s)) / std::exp(-1.0 / (2 * s * s)), 1e-4);
  }
}

// ---- LDR-FLIP properties --------------------------------------------------------------------------

TEST(LdrFlip, IdenticalImagesGiveExactlyZero) {
  for (const Image& img : {random_image(37, 23, 1), smooth_image(48, 40), make_image(8, 8, 0, 0, 0)}) {
    FlipResult r;
    ASSERT_TRUE(ldr_flip(img, img, FlipSettings{}, r).is_ok());
    ASSERT_EQ(r.error.size(), size_t(img.width) * img.height);
    for (float e : r.error) ASSERT_EQ(e, 0.0f);
    EXPECT_EQ(r.stats.mean, 0.0);
    EXPECT_EQ(r.stats.max, 0.0);
    EXPECT_EQ(r.stats.weighted_median, 0.0);
  }
}

// Every stage of LDR-FLIP treats the two images alike (HyAB and the feature difference are
// symmetric), so swapping reference and test gives the same map, bit for bit.
TEST(LdrFlip, IsSymmetric) {
  const Image a = random_image(41, 27, 2), b = smooth_image(41, 27);
  FlipResult ab, ba;
  ASSERT_TRUE(ldr_flip(a, b, FlipSettings{}, ab).is_ok());
  ASSERT_TRUE(ldr_flip(b, a, FlipSettings{}, ba).is_ok());
  EXPECT_EQ(ab.error, ba.error);
  EXPECT_GT(ab.stats.mean, 0.1);
}

// Uniform images have no features, so FLIP is the color error alone. Green vs blue is the largest
// color error, 1; black vs white (HyAB 100 after the Hunt adjustment, which leaves grays alone) is
// 0.95 + 0.05 * (100^0.7 - 0.4 cmax^0.7) / (0.6 cmax^0.7) = 0.967.
TEST(LdrFlip, UniformColorPairs) {
  FlipResult r;
  ASSERT_TRUE(ldr_flip(make_image(16, 16, 0, 1, 0), make_image(16, 16, 0, 0, 1), FlipSettings{}, r).is_ok());
  for (float e : r.error) EXPECT_NEAR(e, 1.0f, 1e-5f);
  ASSERT_TRUE(ldr_flip(make_image(16, 16, 0, 0, 0), make_image(16, 16, 1, 1, 1), FlipSettings{}, r).is_ok());
  const double cq = detail::max_color_error();
  const double want = 0.95 + 0.05 * (std::pow(100.0, 0.7) - 0.4 * cq) / (0.6 * cq);
  EXPECT_NEAR(want, 0.967, 0.001);
  for (float e : r.error) EXPECT_NEAR(e, want, 1e-4);
  EXPECT_NEAR(r.stats.mean, want, 1e-4);
  // Out-of-range values are clamped to [0, 1] first.
  FlipResult clamped;
  ASSERT_TRUE(ldr_flip(make_image(16, 16, -3, -1, 0), make_image(16, 16, 7, 2, 1.5f), FlipSettings{}, clamped).is_ok());
  EXPECT_EQ(clamped.error, r.error);
}

TEST(LdrFlip, MoreNoiseGivesALargerMean) {
  const Image ref = smooth_image(64, 64);
  std::mt19937 rng(7);
  std::normal_distribution<float> gauss(0.0f, 1.0f);
  std::vector<float> noise(ref.rgb.size());
  for (float& n : noise) n = gauss(rng);
  double previous = 0;
  for (float amplitude : {0.005f, 0.02f, 0.05f, 0.1f, 0.2f, 0.4f}) {
    Image test = ref;
    for (size_t i = 0; i < test.rgb.size(); ++i)
      test.rgb[i] = std::clamp(ref.rgb[i] + amplitude * noise[i], 0.0f, 1.0f);
    FlipResult r;
    ASSERT_TRUE(ldr_flip(ref, test, FlipSettings{}, r).is_ok());
    EXPECT_GT(r.stats.mean, previous) << amplitude;
    EXPECT_GE(r.stats.weighted_median, r.stats.weighted_quartile1);
    EXPECT_GE(r.stats.weighted_quartile3, r.stats.weighted_median);
    previous = r.stats.mean;
  }
}

// A vertical black/white edge moved by one pixel (from between columns 31|32 to 32|33): the
// feature error is the same in every row, i.e. it runs along the whole edge; across the edge it is
// large within the feature filter's radius r of column 32 and exactly 0 beyond. It is symmetric
// about column 32, where it vanishes: that column is equally far from both edge positions, so it
// sees the same edge and point magnitudes in both images. The combined FLIP value is 0 away from
// the edge too.
TEST(LdrFlip, ShiftedEdgeGivesFeatureErrorAlongTheEdgeOnly) {
  const uint32_t w = 64, h = 48, edge = 32;
  Image ref = make_image(w, h, 0, 0, 0), test = ref;
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      if (x >= edge) std::fill_n(ref.at(x, y), 3, 1.0f);
      if (x >= edge + 1) std::fill_n(test.at(x, y), 3, 1.0f);
    }
  const double ppd = 67.0;
  const std::vector<float> feature = detail::feature_error_map(ref, test, ppd);
  const int r = detail::feature_kernels(ppd).radius;
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) ASSERT_EQ(feature[size_t(y) * w + x], feature[x]) << x << " " << y;
  for (int x = 0; x < int(w); ++x) {
    const int d = std::abs(x - int(edge));
    const float f = feature[size_t(x)];
    if (d > r) {
      EXPECT_EQ(f, 0.0f) << x;
    } else if (d >= 1) {
      EXPECT_GT(f, 0.05f) << x;
      EXPECT_NEAR(f, feature[size_t(2 * int(edge) - x)], 1e-5f) << x;
    }
    if (d >= 1 && d <= 3) {
      EXPECT_GT(f, 0.3f) << x;
    }
  }
  EXPECT_LT(feature[edge], 0.01f);
  const int reach = r;
  FlipResult result;
  ASSERT_TRUE(ldr_flip(ref, test, FlipSettings{}, result).is_ok());
  const int csf_reach = detail::csf_radius(ppd);
  for (uint32_t x = 0; x < w; ++x) {
    const float e = result.error[size_t(h / 2) * w + x];
    if (x + uint32_t(std::max(reach, csf_reach)) < edge || x > edge + 1 + uint32_t(std::max(reach, csf_reach))) {
      EXPECT_EQ(e, 0.0f) << x;
    }
  }
  EXPECT_GT(result.error[size_t(h / 2) * w + edge], 0.3f);
}

// Everything is in [0, 1] and the statistics are those of the map.
TEST(LdrFlip, RangeAndStatistics) {
  FlipResult r;
  ASSERT_TRUE(ldr_flip(random_image(33, 21, 4), random_image(33, 21, 5), FlipSettings{}, r).is_ok());
  for (float e : r.error) {
    EXPECT_GE(e, 0.0f);
    EXPECT_LE(e, 1.0f);
  }
  const FlipStatistics s = pool_errors(r.error);
  EXPECT_EQ(s.mean, r.stats.mean);
  EXPECT_EQ(s.weighted_median, r.stats.weighted_median);
  EXPECT_EQ(r.stats.min, double(*std::min_element(r.error.begin(), r.error.end())));
  EXPECT_EQ(r.stats.max, double(*std::max_element(r.error.begin(), r.error.end())));
  EXPECT_EQ(r.heatmap.width, 33u);
  EXPECT_EQ(r.heatmap.rgb.size(), r.error.size() * 3);
  FlipSettings no_heatmap;
  no_heatmap.heatmap = false;
  ASSERT_TRUE(ldr_flip(random_image(33, 21, 4), random_image(33, 21, 5), no_heatmap, r).is_ok());
  EXPECT_TRUE(r.heatmap.rgb.empty());
  EXPECT_FALSE(r.hdr);
}

TEST(LdrFlip, ClearErrors) {
  FlipResult r;
  Status s = ldr_flip(make_image(8, 8, 0, 0, 0), make_image(8, 9, 0, 0, 0), FlipSettings{}, r);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("differ in size: reference 8 x 8, test 8 x 9"), std::string::npos) << s.message();
  Image nan = make_image(8, 8, 0, 0, 0);
  nan.at(3, 5)[1] = std::nanf("");
  s = ldr_flip(make_image(8, 8, 0, 0, 0), nan, FlipSettings{}, r);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("test image has a non-finite value (nan) at pixel (3, 5)"), std::string::npos)
      << s.message();
  s = ldr_flip(Image{}, Image{}, FlipSettings{}, r);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("empty"), std::string::npos) << s.message();
  FlipSettings bad;
  bad.pixels_per_degree = 0.0;
  s = ldr_flip(make_image(8, 8, 0, 0, 0), make_image(8, 8, 0, 0, 0), bad, r);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("pixels per degree"), std::string::npos) << s.message();
  Image short_image = make_image(8, 8, 0, 0, 0);
  short_image.rgb.pop_back();
  s = hdr_flip(short_image, make_image(8, 8, 0, 0, 0), FlipSettings{}, r);
  EXPECT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("HDR-FLIP: the reference image holds 191 values"), std::string::npos) << s.message();
}

// ---- HDR-FLIP -------------------------------------------------------------------------------------

// The tone mapper is Narkowicz's ACES fit applied to 0.6 x, and x_0.85 is where it reaches 0.85.
TEST(HdrFlip, ToneMapperAndItsInverse) {
  for (double x : {0.0, 0.01, 0.2, 1.0, 3.0, 50.0}) {
    const double y = 0.6 * x;
    EXPECT_NEAR(detail::tone_map(x), (y * (2.51 * y + 0.03)) / (y * (2.43 * y + 0.59) + 0.14), 1e-12);
  }
  const double x085 = detail::tone_map_inverse(0.85);
  EXPECT_NEAR(detail::tone_map(x085), 0.85, 1e-12);
  EXPECT_NEAR(x085, 2.1189, 1e-3);
  EXPECT_NEAR(detail::tone_map_inverse(0.0), 0.0, 1e-12);
  for (double t : {0.1, 0.5, 0.99, 1.02}) EXPECT_NEAR(detail::tone_map(detail::tone_map_inverse(t)), t, 1e-9) << t;
}

// Start exposure: the brightest reference luminance tone maps to 0.85; stop: the median does. The
// number of exposures is max(2, ceil(stop - start)).
TEST(HdrFlip, AutomaticExposureRange) {
  Image ref = make_image(5, 1, 0, 0, 0);
  const float gray[5] = {16.0f, 0.5f, 2.0f, 1.0f, 4.0f};  // median 2, max 16
  for (uint32_t x = 0; x < 5; ++x) std::fill_n(ref.at(x, 0), 3, gray[x]);
  float start = 0, stop = 0;
  detail::auto_exposure_range(ref, start, stop);
  const double x085 = detail::tone_map_inverse(0.85);
  EXPECT_NEAR(start, std::log2(x085 / 16.0), 1e-5);
  EXPECT_NEAR(stop, std::log2(x085 / 2.0), 1e-5);
  FlipResult r;
  ASSERT_TRUE(hdr_flip(ref, ref, FlipSettings{}, r).is_ok());
  EXPECT_TRUE(r.hdr);
  EXPECT_FLOAT_EQ(r.start_exposure, start);
  EXPECT_FLOAT_EQ(r.stop_exposure, stop);
  EXPECT_EQ(r.num_exposures, 3u);  // stop - start = log2(16 / 2) = 3
  for (float e : r.error) EXPECT_EQ(e, 0.0f);

  // A reference that is mostly black: the median of the positive luminances is used.
  Image dark = make_image(5, 1, 0, 0, 0);
  std::fill_n(dark.at(0, 0), 3, 8.0f);
  std::fill_n(dark.at(1, 0), 3, 1.0f);
  detail::auto_exposure_range(dark, start, stop);
  EXPECT_NEAR(start, std::log2(x085 / 8.0), 1e-5);
  EXPECT_NEAR(stop, std::log2(x085 / 8.0), 1e-5);  // positives {1, 8}: element n/2 = 8
  // All black: a single exposure 0.
  detail::auto_exposure_range(make_image(4, 4, 0, 0, 0), start, stop);
  EXPECT_EQ(start, 0.0f);
  EXPECT_EQ(stop, 0.0f);
  // One given bound: the other is still automatic.
  FlipSettings s;
  s.stop_exposure = 5.0f;
  ASSERT_TRUE(hdr_flip(ref, ref, s, r).is_ok());
  EXPECT_NEAR(r.start_exposure, std::log2(x085 / 16.0), 1e-5);
  EXPECT_EQ(r.stop_exposure, 5.0f);
  s.start_exposure = 6.0f;
  EXPECT_FALSE(hdr_flip(ref, ref, s, r).is_ok());
}

// With the exposure range collapsed to one exposure c, HDR-FLIP is LDR-FLIP of the images exposed
// by 2^c and tone mapped (the tone mapping written out here again).
TEST(HdrFlip, SingleExposureIsLdrFlipOfTheToneMappedImages) {
  const Image ref = random_image(36, 28, 8, 6.0f), test = random_image(36, 28, 9, 6.0f);
  for (float c : {-2.0f, 0.0f, 1.5f}) {
    FlipSettings s;
    s.start_exposure = c;
    s.stop_exposure = c;
    FlipResult hdr;
    ASSERT_TRUE(hdr_flip(ref, test, s, hdr).is_ok());
    EXPECT_EQ(hdr.num_exposures, 2u);
    auto tone_map = [c](const Image& img) {
      Image out = img;
      for (float& v : out.rgb) {
        const double x = 0.6 * std::exp2(double(c)) * double(v);
        v = float(std::clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0));
      }
      return out;
    };
    FlipResult ldr;
    ASSERT_TRUE(ldr_flip(tone_map(ref), tone_map(test), FlipSettings{}, ldr).is_ok());
    ASSERT_EQ(hdr.error.size(), ldr.error.size());
    for (size_t i = 0; i < ldr.error.size(); ++i) ASSERT_NEAR(hdr.error[i], ldr.error[i], 2e-5) << i;
    EXPECT_NEAR(hdr.stats.mean, ldr.stats.mean, 1e-6);
    // And bit for bit against the library's own tone mapping.
    FlipResult same;
    ASSERT_TRUE(
        ldr_flip(detail::expose_and_tone_map(ref, c), detail::expose_and_tone_map(test, c), FlipSettings{}, same)
            .is_ok());
    EXPECT_EQ(hdr.error, same.error);
  }
}

// The HDR-FLIP value is the per-pixel maximum over the exposures, and exposure_index names the one.
TEST(HdrFlip, MaximumOverExposures) {
  const Image ref = random_image(30, 20, 12, 10.0f), test = random_image(30, 20, 13, 10.0f);
  FlipSettings s;
  s.start_exposure = -3.0f;
  s.stop_exposure = 1.0f;
  s.num_exposures = 3;
  FlipResult r;
  ASSERT_TRUE(hdr_flip(ref, test, s, r).is_ok());
  EXPECT_EQ(r.num_exposures, 3u);
  std::vector<std::vector<float>> per;
  for (float c : {-3.0f, -1.0f, 1.0f}) {
    FlipSettings one;
    one.start_exposure = one.stop_exposure = c;
    one.num_exposures = 1;
    FlipResult e;
    ASSERT_TRUE(hdr_flip(ref, test, one, e).is_ok());
    per.push_back(e.error);
  }
  for (size_t i = 0; i < r.error.size(); ++i) {
    const float m = std::max({per[0][i], per[1][i], per[2][i]});
    ASSERT_EQ(r.error[i], m) << i;
    ASSERT_EQ(per[r.exposure_index[i]][i], m) << i;
  }
}

// HDR-FLIP with a given exposure range is symmetric like LDR-FLIP; with the automatic range it is
// not, because the range is computed from the reference alone.
TEST(HdrFlip, SymmetricOnlyWithAGivenExposureRange) {
  const Image dim = random_image(32, 24, 14, 0.5f), bright = random_image(32, 24, 15, 20.0f);
  FlipResult ab, ba;
  ASSERT_TRUE(hdr_flip(dim, bright, FlipSettings{}, ab).is_ok());
  ASSERT_TRUE(hdr_flip(bright, dim, FlipSettings{}, ba).is_ok());
  EXPECT_NE(ab.start_exposure, ba.start_exposure);
  EXPECT_NE(ab.error, ba.error);
  FlipSettings fixed;
  fixed.start_exposure = -4.0f;
  fixed.stop_exposure = 2.0f;
  ASSERT_TRUE(hdr_flip(dim, bright, fixed, ab).is_ok());
  ASSERT_TRUE(hdr_flip(bright, dim, fixed, ba).is_ok());
  EXPECT_EQ(ab.error, ba.error);
  EXPECT_EQ(ab.num_exposures, 6u);
}

TEST(HdrFlip, IdenticalImagesGiveZeroAndNegativeValuesCountAsZero) {
  const Image img = random_image(20, 20, 16, 100.0f);
  FlipResult r;
  ASSERT_TRUE(hdr_flip(img, img, FlipSettings{}, r).is_ok());
  for (float e : r.error) ASSERT_EQ(e, 0.0f);
  Image negative = img;
  for (size_t i = 0; i < negative.rgb.size(); i += 7) negative.rgb[i] = -1.0f;
  Image zero = negative;
  for (float& v : zero.rgb) v = std::max(v, 0.0f);
  FlipSettings s;
  s.start_exposure = -6.0f;
  s.stop_exposure = -2.0f;
  FlipResult with_negative, with_zero;
  ASSERT_TRUE(hdr_flip(img, negative, s, with_negative).is_ok());
  ASSERT_TRUE(hdr_flip(img, zero, s, with_zero).is_ok());
  EXPECT_EQ(with_negative.error, with_zero.error);
}

// ---- statistics and heatmap -------------------------------------------------------------------------

// Weighted percentiles: each value weighs itself; the p-percentile is the first value (ascending)
// whose running sum exceeds p times the total.
TEST(FlipPooling, WeightedPercentiles) {
  const FlipStatistics s = pool_errors({0.3f, 0.0f, 0.4f, 0.1f, 0.2f});  // running sums .1 .3 .6 1.0
  EXPECT_NEAR(s.mean, 0.2, 1e-7);
  EXPECT_EQ(s.min, 0.0);
  EXPECT_NEAR(s.max, 0.4, 1e-7);
  EXPECT_NEAR(s.weighted_quartile1, 0.2, 1e-7);
  EXPECT_NEAR(s.weighted_median, 0.3, 1e-7);
  EXPECT_NEAR(s.weighted_quartile3, 0.4, 1e-7);
  // Many small errors and a few large ones: the plain median is small, the weighted one large.
  std::vector<float> v(1000, 0.01f);
  for (int i = 0; i < 30; ++i) v[size_t(i)] = 0.9f;
  const FlipStatistics w = pool_errors(v);
  EXPECT_NEAR(w.weighted_median, 0.9, 1e-6);
  EXPECT_NEAR(w.weighted_quartile1, 0.01, 1e-6);
  const FlipStatistics same = pool_errors(std::vector<float>(10, 0.25f));
  EXPECT_FLOAT_EQ(float(same.weighted_quartile1), 0.25f);
  EXPECT_FLOAT_EQ(float(same.weighted_quartile3), 0.25f);
  const FlipStatistics zero = pool_errors(std::vector<float>(10, 0.0f));
  EXPECT_EQ(zero.weighted_median, 0.0);
  const FlipStatistics empty = pool_errors({});
  EXPECT_EQ(empty.mean, 0.0);
}

// Magma's end points are matplotlib's; the heatmap indexes it at round(255 e); saved as PNG it
// gives magma's 8-bit colours.
TEST(FlipHeatmap, MagmaColors) {
  const auto& t = detail::magma_table();
  EXPECT_FLOAT_EQ(t[0][0], 0.001462f);
  EXPECT_FLOAT_EQ(t[0][2], 0.013866f);
  EXPECT_FLOAT_EQ(t[128][0], 0.716387f);
  EXPECT_FLOAT_EQ(t[255][0], 0.987053f);
  EXPECT_FLOAT_EQ(t[255][1], 0.991438f);
  EXPECT_FLOAT_EQ(t[255][2], 0.749504f);
  for (size_t i = 1; i < 256; ++i) EXPECT_GT(t[i][1] + t[i][0], t[i - 1][1] + t[i - 1][0] - 0.01f);

  const std::vector<float> errors = {0.0f, 1.0f, 0.5f, 2.0f, -1.0f, 0.25f};
  const Image h = magma_heatmap(errors, 3, 2);
  ASSERT_EQ(h.width, 3u);
  ASSERT_EQ(h.height, 2u);
  const size_t index[6] = {0, 255, 128, 255, 0, 64};
  const std::string dir =
      (std::filesystem::temp_directory_path() / ("lsnif_flip_test_" + std::to_string(::getpid()))).string();
  std::filesystem::create_directories(dir);
  ASSERT_TRUE(image::save_image(dir + "/magma.png", h).is_ok());
  Image raw;
  ASSERT_TRUE(image::load_image(dir + "/magma.png", raw, true).is_ok());
  std::filesystem::remove_all(dir);
  for (size_t i = 0; i < 6; ++i)
    for (size_t c = 0; c < 3; ++c) {
      EXPECT_NEAR(detail::linear_to_srgb(h.rgb[i * 3 + c]), t[index[i]][c], 1e-5f) << i;
      EXPECT_EQ(std::lround(raw.rgb[i * 3 + c] * 255.0f), std::lround(t[index[i]][c] * 255.0f)) << i;
    }
  EXPECT_TRUE(magma_heatmap(errors, 4, 2).rgb.empty());
}

}  // namespace
}  // namespace lsnif::flip
