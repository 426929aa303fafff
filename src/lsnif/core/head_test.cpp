// Output heads: the two hit-distance parametrizations invert each other on random walks, map the
// ends of [0,1] to the right knots, and decode() applies the documented activations, the surface
// channels' included; the packers of the surface channels (pack_surface) and of the emission
// (pack_rgbe, unpack_rgbe) against the layout host_device.h documents.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "lsnif/core/head.h"

namespace lsnif {
namespace {

RayWalk random_walk(std::mt19937& rng, uint32_t count) {
  std::uniform_real_distribution<float> u(0.01f, 0.3f);
  RayWalk w;
  w.t_enter = 1.0f;
  float t = w.t_enter;
  w.count = count;
  for (uint32_t j = 0; j < count; ++j) {
    t += u(rng);
    w.t[j] = t;
  }
  w.t_exit = t + u(rng);
  w.hits_aabb = true;
  return w;
}

TEST(Head, DistanceMapsInvertEachOther) {
  std::mt19937 rng(8);
  for (HitParam param : {HitParam::AabbInterval, HitParam::VoxelSegments}) {
    Config c;
    c.hit_param = param;
    for (int trial = 0; trial < 2000; ++trial) {
      RayWalk w = random_walk(rng, 1 + uint32_t(trial) % c.max_points);
      const float end = param == HitParam::AabbInterval ? w.t_exit : w.t[w.count - 1];
      std::uniform_real_distribution<float> ut(w.t_enter, end);
      float t = ut(rng);
      float s = unit_from_distance(c, w, t);
      ASSERT_GE(s, 0.0f);
      ASSERT_LE(s, 1.0f);
      ASSERT_NEAR(distance_from_unit(c, w, s), t, 2e-5f) << to_string(param);
    }
  }
}

TEST(Head, SegmentKnots) {
  Config c;  // H = 18, segments
  RayWalk w;
  w.t_enter = 2.0f;
  w.count = 3;
  w.t[0] = 3.0f;
  w.t[1] = 3.5f;
  w.t[2] = 5.0f;
  w.t_exit = 9.0f;
  const float H = float(c.max_points);
  EXPECT_FLOAT_EQ(distance_from_unit(c, w, 0.0f), 2.0f);
  EXPECT_FLOAT_EQ(distance_from_unit(c, w, 1.0f / H), 3.0f);
  EXPECT_FLOAT_EQ(distance_from_unit(c, w, 1.5f / H), 3.25f);
  EXPECT_FLOAT_EQ(distance_from_unit(c, w, 3.0f / H), 5.0f);
  EXPECT_FLOAT_EQ(distance_from_unit(c, w, 1.0f), 5.0f);  // clamped to the last knot
  EXPECT_FLOAT_EQ(unit_from_distance(c, w, 3.25f), 1.5f / H);
  EXPECT_FLOAT_EQ(unit_from_distance(c, w, 4.25f), 2.5f / H);
  c.hit_param = HitParam::AabbInterval;
  EXPECT_FLOAT_EQ(distance_from_unit(c, w, 0.5f), 5.5f);
}

TEST(Head, DecodeActivations) {
  Config c;
  c.material_count = 3;
  std::vector<float> raw(c.output_dim(), 0.0f);
  raw[LSNIF_OUT_OCCLUSION] = 0.0f;  // probability exactly 0.5 -> hit (threshold is >= 0.5)
  raw[LSNIF_OUT_NORMAL + 1] = -3.0f;
  raw[LSNIF_OUT_ALBEDO + 2] = 100.0f;
  raw[LSNIF_OUT_MATERIAL + 2] = 1.0f;
  RayWalk w;
  w.count = 1;
  w.t_enter = 0.0f;
  w.t[0] = 1.0f;
  w.t_exit = 2.0f;
  Prediction p = decode(c, raw.data(), w);
  EXPECT_TRUE(p.hit);
  EXPECT_FLOAT_EQ(p.occlusion, 0.5f);
  EXPECT_FLOAT_EQ(p.normal.y, -1.0f);
  EXPECT_FLOAT_EQ(p.albedo.x, 0.5f);
  EXPECT_NEAR(p.albedo.z, 1.0f, 1e-6f);
  EXPECT_EQ(p.material, 2u);
  raw[LSNIF_OUT_OCCLUSION] = -0.01f;
  EXPECT_FALSE(decode(c, raw.data(), w).hit);
  // Without surface channels they are not learned, zero, and not in the output.
  EXPECT_EQ(c.output_dim(), LSNIF_OUT_FIXED + 3u);
  EXPECT_FALSE(p.surface_learned);
  EXPECT_EQ(p.metallic + p.roughness + p.ambient_occlusion, 0.0f);
  EXPECT_EQ(p.emission, glm::vec3(0.0f));
  EXPECT_EQ(pack_surface(p), 0u);
}

double sigmoid_of(double x) { return 1.0 / (1.0 + std::exp(-x)); }

TEST(Head, DecodeSurfaceChannels) {
  Config c;
  c.material_count = 3;
  c.surface_channels = 1;
  c.emission_scale = 20.0f;
  ASSERT_TRUE(c.validate()) << c.validate().message();
  ASSERT_EQ(c.output_dim(), LSNIF_OUT_FIXED + 3u + LSNIF_OUT_SURFACE_COUNT);
  ASSERT_EQ(c.surface_output(), LSNIF_OUT_MATERIAL + 3u);
  std::vector<float> raw(c.output_dim(), 0.0f);
  raw[LSNIF_OUT_MATERIAL + 1] = 2.0f;  // the material argmax ignores the surface outputs after it
  const float surface[LSNIF_OUT_SURFACE_COUNT] = {-2.0f, 0.0f, 3.5f, 1.0f, -40.0f, 9.0f};
  for (uint32_t k = 0; k < LSNIF_OUT_SURFACE_COUNT; ++k) raw[c.surface_output() + k] = surface[k];
  RayWalk w;
  w.count = 1;
  w.t_enter = 0.0f;
  w.t[0] = 1.0f;
  w.t_exit = 2.0f;
  const Prediction p = decode(c, raw.data(), w);
  EXPECT_EQ(p.material, 1u);
  EXPECT_TRUE(p.surface_learned);
  EXPECT_NEAR(p.metallic, sigmoid_of(-2.0), 1e-6);
  EXPECT_EQ(p.roughness, 0.5f);
  EXPECT_NEAR(p.ambient_occlusion, sigmoid_of(3.5), 1e-6);
  EXPECT_NEAR(p.emission.r, 20.0 * sigmoid_of(1.0), 2e-5);
  EXPECT_NEAR(p.emission.g, 20.0 * sigmoid_of(-40.0), 1e-20);
  EXPECT_NEAR(p.emission.b, 20.0 * sigmoid_of(9.0), 2e-5);
  // pack_surface: round(x 255) per channel (0.1192 -> 30, 0.5 -> 128 (127.5 rounds up), 0.9707 ->
  // 248) and the learned flag in byte 3.
  EXPECT_EQ(pack_surface(p), 30u | 128u << 8 | 248u << 16 | LSNIF_SURFACE_LEARNED << 24);
  Prediction q = p;
  q.metallic = -0.5f;       // clamped
  q.roughness = 2.0f;
  q.ambient_occlusion = 0.5f / 255.0f;
  EXPECT_EQ(pack_surface(q) & 0xffffffu, 0u | 255u << 8 | uint32_t(std::lround(0.5f / 255.0f * 255.0f)) << 16);
  q.surface_learned = false;
  EXPECT_EQ(pack_surface(q), 0u);
}

// The value of channel k of an RGBE word as host_device.h documents it: m x 2^(e - LSNIF_RGBE_BIAS).
double rgbe_channel(uint32_t rgbe, int k) {
  const uint32_t e = rgbe >> 24, m = (rgbe >> (8 * k)) & 0xffu;
  return e == 0 ? 0.0 : std::ldexp(double(m), int(e) - LSNIF_RGBE_BIAS);
}

TEST(Head, RgbeEdgeCases) {
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(pack_rgbe(glm::vec3(0.0f)), 0u);
  EXPECT_EQ(pack_rgbe(glm::vec3(-1.0f, -0.0f, -5.0f)), 0u);
  EXPECT_EQ(pack_rgbe(glm::vec3(nan, nan, nan)), 0u);
  EXPECT_EQ(pack_rgbe(glm::vec3(inf, 1.0f, 1.0f)), 0u);
  EXPECT_EQ(unpack_rgbe(0u), glm::vec3(0.0f));
  EXPECT_EQ(unpack_rgbe(0x00ffffffu), glm::vec3(0.0f));  // exponent 0 is black whatever the mantissas
  // 1 = 128 x 2^-7: exponent byte 1 + 128, mantissa 128; negative and NaN channels are 0.
  EXPECT_EQ(pack_rgbe(glm::vec3(1.0f, -2.0f, nan)), 129u << 24 | 128u);
  EXPECT_EQ(unpack_rgbe(129u << 24 | 128u), glm::vec3(1.0f, 0.0f, 0.0f));
  // Halves round away from zero: 0.50390625 x 2^7 = 64.5 -> 65 (not to even 64).
  EXPECT_EQ((pack_rgbe(glm::vec3(1.0f, 0.50390625f, 0.0f)) >> 8) & 0xffu, 65u);
  // Just below a power of two the largest mantissa rounds to 256 and is kept at 255.
  EXPECT_EQ(pack_rgbe(glm::vec3(0.99999994f, 0.0f, 0.0f)), 128u << 24 | 255u);
  // fp16's largest finite value, the largest emission scale: 65504 = 255.875 x 2^8 rounds to 256,
  // kept at 255 (65280, 0.34% low: within 2^-8); 65280 itself is exact.
  EXPECT_EQ(pack_rgbe(glm::vec3(float(LSNIF_MAX_EMISSION_SCALE), 0.0f, 0.0f)), 144u << 24 | 255u);
  EXPECT_EQ(unpack_rgbe(pack_rgbe(glm::vec3(65504.0f))), glm::vec3(65280.0f));
  EXPECT_EQ(unpack_rgbe(pack_rgbe(glm::vec3(65280.0f, 1.0f, 0.0f))), glm::vec3(65280.0f, 0.0f, 0.0f));
  // The smallest normal float: 2^-126 = 128 x 2^-133, exponent byte 3.
  const float tiny = std::numeric_limits<float>::min();
  EXPECT_EQ(pack_rgbe(glm::vec3(tiny, 0.0f, 0.0f)), 3u << 24 | 128u);
  EXPECT_EQ(unpack_rgbe(3u << 24 | 128u).r, tiny);
  // Below 2^-128 (largest channel) the colour is black.
  EXPECT_EQ(pack_rgbe(glm::vec3(std::ldexp(1.0f, -129), 0.0f, 0.0f)), 0u);
  // Every word with a non-zero exponent decodes to what the layout says.
  for (const uint32_t w : {0x01010203u, 0x80ff0001u, 0xfffffffeu, 0x88000080u})
    for (int k = 0; k < 3; ++k) EXPECT_EQ(double(unpack_rgbe(w)[k]), rgbe_channel(w, k)) << std::hex << w;
}

TEST(Head, RgbeRoundTripOfRandomColours) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> magnitude(-110.0f, 16.0f), share(-14.0f, 0.0f);
  for (int trial = 0; trial < 20000; ++trial) {
    const float m = std::exp2(magnitude(rng));
    glm::vec3 c;
    for (int k = 0; k < 3; ++k) c[k] = trial % 7 == k ? 0.0f : m * std::exp2(share(rng));
    const uint32_t w = pack_rgbe(c);
    const glm::vec3 back = unpack_rgbe(w);
    const float largest = std::max({c.r, c.g, c.b});
    ASSERT_NE(w >> 24, 0u) << trial;
    // The largest channel keeps 8 significant bits: its mantissa is in [128, 255] (or 255 from a
    // value rounding up to the next power of two), its error at most half a step, 2^-8 of itself.
    const uint32_t top = std::max({w & 0xffu, (w >> 8) & 0xffu, (w >> 16) & 0xffu});
    EXPECT_GE(top, 128u) << trial;
    for (int k = 0; k < 3; ++k) {
      EXPECT_LE(std::fabs(double(back[k]) - double(c[k])), std::ldexp(double(largest), -8)) << trial << " " << k;
      EXPECT_EQ(double(back[k]), rgbe_channel(w, k));
    }
    // Packing what was unpacked gives the same word (the decoded colour is exactly representable).
    EXPECT_EQ(pack_rgbe(back), w) << trial;
  }
}

// The texture coordinate of a hit's attributes (host_device.h LSNIF_HIT_UV_BIT): 16 fractional
// bits, rounded to nearest with halves away from zero, clamped to +-LSNIF_MAX_UV, NaN as 0, the
// 28-bit fields' signs kept.
TEST(Head, PackedTextureCoordinatesKeepSixteenFractionalBits) {
  const float step = 1.0f / 65536.0f;
  struct Case {
    glm::vec2 in, out;
  } cases[] = {
      {{0.0f, 1.0f}, {0.0f, 1.0f}},
      {{0.25f, -0.75f}, {0.25f, -0.75f}},
      {{0.5f * step, -0.5f * step}, {step, -step}},          // halves away from zero
      {{0.49f * step, 1.49f * step}, {0.0f, step}},
      {{2047.0f, -2047.0f}, {2047.0f, -2047.0f}},
      {{5000.0f, -1e30f}, {2047.0f, -2047.0f}},              // clamped
      {{std::nanf(""), 3.1f}, {0.0f, std::round(3.1f * 65536.0f) / 65536.0f}},
  };
  for (const Case& c : cases) {
    const uint64_t packed = pack_uv(c.in);
    EXPECT_EQ(packed >> 56, 0u);
    EXPECT_EQ(unpack_uv(packed), c.out) << c.in.x << ", " << c.in.y;
  }
  for (int i = 0; i < 1000; ++i) {
    const glm::vec2 uv(float(i) * 0.37f - 180.0f, float(i * i % 977) / 977.0f * 8.0f - 4.0f);
    const glm::vec2 back = unpack_uv(pack_uv(uv));
    EXPECT_LE(std::fabs(back.x - uv.x), 0.5f * step + std::fabs(uv.x) * 1e-7f);
    EXPECT_LE(std::fabs(back.y - uv.y), 0.5f * step);
  }
}

}  // namespace
}  // namespace lsnif
