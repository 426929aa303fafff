// hit_decode_test.cpp -- the hit decoders an application's closest-hit shader includes, GLSL
// (lsnif/lsnif_hit.glsl) and HLSL (lsnif/lsnif_hit.hlsl, compiled by glslang), run on the device over
// the same attribute records and instance matrices (hit_decode.comp, hit_decode.hlsl) and checked
// against a CPU decode of LsnifHitAttributes as host_device.h documents it: the world normal
// normalize((A^-1)^T n), unorm8 albedo and material byte, the surface channels, points and learned
// bit, the RGBE emission (src/lsnif/core/head.h unpack_rgbe), and the leaving tmin
// leaving_distance / |A^-1 d|. The GLSL packers (lsnif_pack_rgbe, lsnif_pack_surface, lsnif_pack_hit)
// against head.cpp's pack_rgbe and pack_surface, bit for bit, over random and edge values. Built
// into the gpu_reference_test executable (label `gpu`).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include <glm/glm.hpp>

#include "hit_decode_comp_spirv.h"
#include "hit_decode_hlsl_spirv.h"
#include "lsnif/core/head.h"
#include "lsnif/vulkan/context.h"
#include "lsnif/host_device.h"
#include "lsnif/testing/test_support.h"
#include "lsnif/testing/vk_dispatch.h"

namespace lsnif {
namespace {

// HitDecodeResult of the shaders (96 bytes, std430 / HLSL structured-buffer layout).
struct DecodeResult {
  float normal[3], leaving_tmin;
  float albedo[3], occlusion_logit;
  uint32_t material, points, leaving_bits, object_normal_x_bits;
  float surface[4];   // metallic, roughness, ambient occlusion, learned (1 or 0)
  float emission[4];  // rgb, 0
  uint32_t packed[4];  // GLSL only: pack_rgbe(colour), pack_surface(v, 1 - v, v / 2), pack_hit's two words
  uint32_t uv[4];      // reports_uv (1 or 0), u and v (float bits), 0
  uint32_t uv_packed[4];  // GLSL only: lsnif_pack_uv_hit of the colour's x and y: three words, 0
};
static_assert(sizeof(DecodeResult) == 128);
static_assert(sizeof(LsnifHitAttributes) == 32);

struct Record {
  LsnifHitAttributes attributes;
  glm::mat3 world_to_object;  // glm: m[column][row]
  glm::vec3 direction;
  glm::vec4 pack;             // the packers' input: a colour (xyz) and a channel value v (w)
};

uint32_t unorm8(float v) { return uint32_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)); }

// Colours for the RGBE packer: edge cases first (black, negative zero and negative channels, the
// smallest normal float and a few of its multiples, ties of the rounding (a mantissa of k + 1/2),
// a largest channel just below a power of two (rounds up to 256, kept at 255), fp16's largest
// finite 65504 and LSNIF_MAX_EMISSION_SCALE, mixed magnitudes whose small channels round to 0 or
// 1), then random colours of random magnitude 2^-100 .. 2^17 with channels 2^-12 .. 1 of it.
std::vector<glm::vec3> rgbe_colours(size_t count, std::mt19937& rng) {
  const float tiny = std::numeric_limits<float>::min();  // 2^-126
  std::vector<glm::vec3> c = {
      {0.0f, 0.0f, 0.0f},       {-0.0f, 0.0f, 0.0f},       {-1.0f, 0.5f, -3.0f},      {-2.0f, -2.0f, -2.0f},
      {tiny, 0.0f, 0.0f},       {tiny, tiny, tiny},        {2.0f * tiny, tiny, 0.0f}, {1e-37f, 3e-38f, 1.5e-38f},
      {1e-30f, 0.0f, 2e-31f},   {1.0f, 0.50390625f, 0.0f}, {1.0f, 0.50390625f, 0.25390625f},
      {2.0f, 1.0078125f, 0.0f}, {0.99999994f, 0.5f, 0.0f}, {0.99999994f, 0.99999994f, 0.99999994f},
      {65504.0f, 0.0f, 1.0f},   {65504.0f, 65504.0f, 65504.0f}, {float(LSNIF_MAX_EMISSION_SCALE), 256.0f, 255.5f},
      {1e4f, 1e-3f, 0.0f},      {1e4f, 19.53125f, 58.59375f}, {1.0f, 1.0f / 256.0f, 1.0f / 512.0f},
      {3.0f, 0.01171875f, 0.005859375f}, {0.75f, 0.0f, 0.0029296875f}, {1.0f, 2.0f, 4.0f}, {40.0f, 0.0f, 39.84375f},
  };
  std::uniform_real_distribution<float> magnitude(-100.0f, 17.0f), share(-12.0f, 0.0f), unit(0.0f, 1.0f);
  while (c.size() < count) {
    const float m = std::exp2(magnitude(rng));
    glm::vec3 v;
    for (int k = 0; k < 3; ++k) v[k] = unit(rng) < 0.1f ? 0.0f : m * std::exp2(share(rng));
    c.push_back(v);
  }
  return c;
}

// Records covering the cases: a zero normal, the identity, a mirror, a non-uniform scale with
// rotation, random well-conditioned matrices, every material and point count range.
std::vector<Record> make_records(size_t count) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), unit(0.0f, 1.0f);
  const std::vector<glm::vec3> colours = rgbe_colours(count, rng);
  std::vector<Record> out(count);
  for (size_t i = 0; i < count; ++i) {
    Record& r = out[i];
    glm::vec3 n(u(rng), u(rng), u(rng));
    n = i == 0 ? glm::vec3(0.0f) : glm::normalize(n);
    r.attributes.normal_x = n.x;
    r.attributes.normal_y = n.y;
    r.attributes.normal_z = n.z;
    const float a[3] = {unit(rng), unit(rng), i == 3 ? 1.0f : unit(rng)};
    const uint32_t material = uint32_t(i % LSNIF_MAX_MATERIALS), points = 1 + uint32_t(i % LSNIF_MAX_POINTS);
    r.attributes.albedo_material = unorm8(a[0]) | (unorm8(a[1]) << 8) | (unorm8(a[2]) << 16) | (material << 24);
    // Every third record without surface channels (the word's channels 0, the bit clear).
    const bool learned = i % 3 != 0;
    const uint32_t channels = learned ? uint32_t(rng()) & 0xffffffu : 0u;
    r.attributes.surface_points = channels | (points << 24) | (learned ? LSNIF_HIT_SURFACE_LEARNED_BIT : 0u);
    r.attributes.emission_rgbe = pack_rgbe(colours[i]);
    // Every fifth record a hit reporting a texture coordinate (head.cpp pack_uv): u up to +-2100
    // (tiling, and clamped to +-LSNIF_MAX_UV), v in [-4, 4].
    if (i % 5 == 4) {
      const uint64_t uv = pack_uv(glm::vec2(2100.0f * u(rng), 4.0f * u(rng)));
      r.attributes.emission_rgbe = uint32_t(uv);
      r.attributes.albedo_material = uint32_t(uv >> 32) | (material << 24);
      r.attributes.surface_points = (points << 24) | LSNIF_HIT_UV_BIT;
    }
    r.pack = glm::vec4(colours[i], i == 4 ? 0.5f / 255.0f : i == 5 ? 1.0f : i == 6 ? -0.25f : unit(rng));
    r.attributes.occlusion_logit = 4.0f * unit(rng);
    r.attributes.leaving_distance = 0.001f + 0.05f * unit(rng);
    if (i == 1) {
      r.world_to_object = glm::mat3(1.0f);
    } else if (i == 2) {
      r.world_to_object = glm::mat3(glm::vec3(-1, 0, 0), glm::vec3(0, 1, 0), glm::vec3(0, 0, 1));
    } else if (i == 3) {
      // The inverse of (rotation about +y by 53 deg) x diag(1.25, 0.8, 1): rows scaled by 1/s.
      const glm::mat3 rotation(glm::vec3(0.6f, 0, -0.8f), glm::vec3(0, 1, 0), glm::vec3(0.8f, 0, 0.6f));
      const glm::mat3 scale(glm::vec3(1.25f, 0, 0), glm::vec3(0, 0.8f, 0), glm::vec3(0, 0, 1));
      r.world_to_object = glm::inverse(rotation * scale);
    } else {
      for (int c = 0; c < 3; ++c)
        for (int row = 0; row < 3; ++row) r.world_to_object[c][row] = 0.5f * u(rng) + (c == row ? 1.5f : 0.0f);
    }
    r.direction = glm::vec3(u(rng), u(rng), u(rng)) + glm::vec3(0.0f, 0.0f, 0.1f);
  }
  return out;
}

// The CPU decode: what host_device.h and lsnif_hit.glsl document.
DecodeResult cpu_decode(const Record& r) {
  DecodeResult d{};
  const LsnifHitAttributes& a = r.attributes;
  const glm::vec3 n(a.normal_x, a.normal_y, a.normal_z);
  const glm::vec3 w = glm::transpose(r.world_to_object) * n;
  const float len = glm::length(w);
  const glm::vec3 world = len > 0.0f ? w / len : glm::vec3(0.0f);
  for (int k = 0; k < 3; ++k) d.normal[k] = world[k];
  const float dir_len = glm::length(r.world_to_object * r.direction);
  d.leaving_tmin = dir_len > 0.0f ? a.leaving_distance / dir_len : 0.0f;
  for (int k = 0; k < 3; ++k) {
    d.albedo[k] = float((a.albedo_material >> (8 * k)) & 0xffu) / 255.0f;
    d.surface[k] = float((a.surface_points >> (8 * k)) & 0xffu) / 255.0f;
  }
  d.occlusion_logit = a.occlusion_logit;
  d.material = a.albedo_material >> 24;
  d.points = (a.surface_points >> 24) & 0x3fu;
  d.surface[3] = (a.surface_points & LSNIF_HIT_SURFACE_LEARNED_BIT) != 0 ? 1.0f : 0.0f;
  const glm::vec3 emission = unpack_rgbe(a.emission_rgbe);
  for (int k = 0; k < 3; ++k) d.emission[k] = emission[k];
  if (a.surface_points & LSNIF_HIT_UV_BIT) {
    // The coordinate in the emission word and albedo's bytes; no albedo, no emission.
    const glm::vec2 uv = unpack_uv(uint64_t(a.emission_rgbe) | uint64_t(a.albedo_material & 0xffffffu) << 32);
    d.uv[0] = 1;
    std::memcpy(&d.uv[1], &uv.x, 4);
    std::memcpy(&d.uv[2], &uv.y, 4);
    for (int k = 0; k < 3; ++k) d.albedo[k] = d.emission[k] = 0.0f;
  }
  // The packers, from head.cpp and the layout of host_device.h.
  const glm::vec3 colour(r.pack);
  const float v = r.pack.w;
  Prediction p;
  p.surface_learned = true;
  p.metallic = v;
  p.roughness = 1.0f - v;
  p.ambient_occlusion = 0.5f * v;
  d.packed[0] = pack_rgbe(colour);
  d.packed[1] = pack_surface(p);
  d.packed[2] = unorm8(colour.r) | (unorm8(colour.g) << 8) | (unorm8(colour.b) << 16) | (d.material << 24);
  d.packed[3] = (d.packed[1] & 0xffffffu) | (d.points << 24) | LSNIF_HIT_SURFACE_LEARNED_BIT;
  const uint64_t uv = pack_uv(glm::vec2(colour));
  d.uv_packed[0] = uint32_t(uv);
  d.uv_packed[1] = uint32_t(uv >> 32) | (d.material << 24);
  d.uv_packed[2] = (d.points << 24) | LSNIF_HIT_UV_BIT;
  std::memcpy(&d.leaving_bits, &a.leaving_distance, 4);
  std::memcpy(&d.object_normal_x_bits, &a.normal_x, 4);
  return d;
}

// Runs one decoder (SPIR-V `code`) over `records`.
Status run_decoder(vk::Context& ctx, const vk::Spirv& code, const std::vector<Record>& records,
                   std::vector<DecodeResult>& out) {
  vk::Pipeline pipeline;
  if (Status s = ctx.create_pipeline(code, sizeof(uint32_t), pipeline, 3); !s) return s;
  vk::Buffer attributes, inputs, results;
  Status s = ctx.create_buffer(records.size() * sizeof(LsnifHitAttributes), attributes);
  if (s) s = ctx.create_buffer(records.size() * 5 * sizeof(glm::vec4), inputs);
  if (s) s = ctx.create_buffer(records.size() * sizeof(DecodeResult), results);
  if (s) {
    auto* a = static_cast<LsnifHitAttributes*>(attributes.mapped);
    auto* in = static_cast<glm::vec4*>(inputs.mapped);
    for (size_t i = 0; i < records.size(); ++i) {
      a[i] = records[i].attributes;
      for (int row = 0; row < 3; ++row) {
        const glm::mat3& m = records[i].world_to_object;
        in[5 * i + size_t(row)] = glm::vec4(m[0][row], m[1][row], m[2][row], 0.0f);
      }
      in[5 * i + 3] = glm::vec4(records[i].direction, 0.0f);
      in[5 * i + 4] = records[i].pack;
    }
    const uint32_t count = uint32_t(records.size());
    s = gputest::dispatch(ctx, pipeline, &count, (count + 63) / 64, {&attributes, &inputs, &results});
  }
  if (s) {
    const auto* r = static_cast<const DecodeResult*>(results.mapped);
    out.assign(r, r + records.size());
  }
  ctx.destroy_buffer(attributes);
  ctx.destroy_buffer(inputs);
  ctx.destroy_buffer(results);
  ctx.destroy_pipeline(pipeline);
  return s;
}

// An RGBE channel decoded on the device against the CPU's: equal, except that a device may flush a
// subnormal result (below 2^-126, only from the edge colours' small channels) to 0.
bool same_rgbe_channel(float got, float want) {
  return got == want || (want < std::numeric_limits<float>::min() && got == 0.0f);
}

// Field by field: bits exactly, floats within `tolerance` (absolute; values are O(1)), emission
// exactly (powers of two times integers < 256); the packers' words when `packers`.
void expect_same(const DecodeResult& got, const DecodeResult& want, float tolerance, const char* what, size_t i,
                 bool packers) {
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(got.normal[k], want.normal[k], tolerance) << what << " record " << i << " normal " << k;
    EXPECT_NEAR(got.albedo[k], want.albedo[k], tolerance) << what << " record " << i << " albedo " << k;
    EXPECT_NEAR(got.surface[k], want.surface[k], tolerance) << what << " record " << i << " surface " << k;
    EXPECT_PRED2(same_rgbe_channel, got.emission[k], want.emission[k]) << what << " record " << i << " emission " << k;
  }
  EXPECT_EQ(got.surface[3], want.surface[3]) << what << " record " << i << " learned";
  for (int k = 0; k < 3; ++k) EXPECT_EQ(got.uv[k], want.uv[k]) << what << " record " << i << " uv " << k;
  if (packers) {
    EXPECT_EQ(got.packed[0], want.packed[0]) << what << " record " << i << " pack_rgbe";
    for (int k = 1; k < 4; ++k) EXPECT_EQ(got.packed[k], want.packed[k]) << what << " record " << i << " packed " << k;
    for (int k = 0; k < 3; ++k) EXPECT_EQ(got.uv_packed[k], want.uv_packed[k]) << what << " record " << i << " pack_uv " << k;
  }
  EXPECT_NEAR(got.leaving_tmin, want.leaving_tmin, tolerance * want.leaving_tmin) << what << " record " << i;
  EXPECT_EQ(got.occlusion_logit, want.occlusion_logit) << what << " record " << i;
  EXPECT_EQ(got.material, want.material) << what << " record " << i;
  EXPECT_EQ(got.points, want.points) << what << " record " << i;
  EXPECT_EQ(got.leaving_bits, want.leaving_bits) << what << " record " << i;
  EXPECT_EQ(got.object_normal_x_bits, want.object_normal_x_bits) << what << " record " << i;
}

TEST(HitDecode, HlslAndGlslDecodeTheSameHitsAsTheCpu) {
  vk::Context ctx;
  const Status init = ctx.init(/*ray_tracing=*/false, test::test_validation(), test::test_device());
  ASSERT_TRUE(init) << init.message();
  const std::vector<Record> records = make_records(4000);
  std::vector<DecodeResult> glsl, hlsl;
  Status s = run_decoder(ctx, vk::Spirv{hit_decode_comp_spirv, sizeof hit_decode_comp_spirv}, records, glsl);
  ASSERT_TRUE(s) << "GLSL decoder: " << s.message();
  s = run_decoder(ctx, vk::Spirv{hit_decode_hlsl_spirv, sizeof hit_decode_hlsl_spirv}, records, hlsl);
  ASSERT_TRUE(s) << "HLSL decoder: " << s.message();
  for (size_t i = 0; i < records.size(); ++i) {
    const DecodeResult want = cpu_decode(records[i]);
    expect_same(glsl[i], want, 2e-6f, "GLSL vs CPU", i, true);
    expect_same(hlsl[i], want, 2e-6f, "HLSL vs CPU", i, false);
    expect_same(hlsl[i], glsl[i], 2e-6f, "HLSL vs GLSL", i, false);
    if (::testing::Test::HasFailure()) {  // one record's report is enough
      std::printf("record %zu: colour (%a, %a, %a), v %a, emission_rgbe 0x%08x\n", i, double(records[i].pack.x),
                  double(records[i].pack.y), double(records[i].pack.z), double(records[i].pack.w),
                  records[i].attributes.emission_rgbe);
      break;
    }
  }
  // Not vacuous: the zero normal stays zero, a mirror flips x, the others are unit vectors.
  EXPECT_EQ(glsl[0].normal[0], 0.0f);
  EXPECT_NEAR(glsl[2].normal[0], -records[2].attributes.normal_x, 1e-6);
  EXPECT_NEAR(std::sqrt(glsl[5].normal[0] * glsl[5].normal[0] + glsl[5].normal[1] * glsl[5].normal[1] +
                        glsl[5].normal[2] * glsl[5].normal[2]),
              1.0, 1e-5);
  // Not vacuous: most colours pack to a non-zero word, the learned and the plain records both occur.
  size_t coloured = 0, learned = 0;
  for (size_t i = 0; i < records.size(); ++i) {
    coloured += glsl[i].packed[0] != 0;
    learned += glsl[i].surface[3] == 1.0f;
  }
  EXPECT_GT(coloured, records.size() * 9 / 10);
  // Not vacuous: every fifth record reports a texture coordinate, most of them not zero.
  size_t uv_hits = 0, uv_nonzero = 0;
  for (size_t i = 0; i < records.size(); ++i) {
    uv_hits += glsl[i].uv[0];
    uv_nonzero += glsl[i].uv[0] && (glsl[i].uv[1] | glsl[i].uv[2]) != 0;
  }
  EXPECT_EQ(uv_hits, records.size() / 5);
  EXPECT_GT(uv_nonzero, uv_hits * 8 / 10);
  EXPECT_GT(learned, records.size() / 2);
  EXPECT_LT(learned, records.size());
  EXPECT_EQ(ctx.validation_errors(), 0u) << ctx.validation_log();
  EXPECT_EQ(ctx.validation_warnings(), 0u) << ctx.validation_log();
}

}  // namespace
}  // namespace lsnif
