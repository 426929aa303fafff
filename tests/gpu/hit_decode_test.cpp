// hit_decode_test.cpp -- the hit decoders an application's closest-hit shader includes, GLSL
// (lsnif/lsnif_hit.glsl) and HLSL (lsnif/lsnif_hit.hlsl, compiled by glslang), run on the device over
// the same attribute records and instance matrices (hit_decode.comp, hit_decode.hlsl) and checked
// against a CPU decode of LsnifHitAttributes as host_device.h documents it: the world normal
// normalize((A^-1)^T n), unorm16 albedo, the material and point bits, and the leaving tmin
// leaving_distance / |A^-1 d|. Built into the gpu_reference_test executable (label `gpu`).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include <glm/glm.hpp>

#include "hit_decode_comp_spirv.h"
#include "hit_decode_hlsl_spirv.h"
#include "lsnif/harness/vk_compute.h"
#include "lsnif/host_device.h"
#include "lsnif/testing/test_support.h"

namespace lsnif {
namespace {

// HitDecodeResult of the shaders (48 bytes, std430 / HLSL structured-buffer layout).
struct DecodeResult {
  float normal[3], leaving_tmin;
  float albedo[3], occlusion_logit;
  uint32_t material, points, leaving_bits, object_normal_x_bits;
};
static_assert(sizeof(DecodeResult) == 48);
static_assert(sizeof(LsnifHitAttributes) == 28);

struct Record {
  LsnifHitAttributes attributes;
  glm::mat3 world_to_object;  // glm: m[column][row]
  glm::vec3 direction;
};

uint32_t unorm16(float v) { return uint32_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 65535.0f)); }

// Records covering the cases: a zero normal, the identity, a mirror, a non-uniform scale with
// rotation, random well-conditioned matrices, every material and point count range.
std::vector<Record> make_records(size_t count) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), unit(0.0f, 1.0f);
  std::vector<Record> out(count);
  for (size_t i = 0; i < count; ++i) {
    Record& r = out[i];
    glm::vec3 n(u(rng), u(rng), u(rng));
    n = i == 0 ? glm::vec3(0.0f) : glm::normalize(n);
    r.attributes.normal_x = n.x;
    r.attributes.normal_y = n.y;
    r.attributes.normal_z = n.z;
    const float a[3] = {unit(rng), unit(rng), i == 3 ? 1.0f : unit(rng)};
    r.attributes.albedo_rg = unorm16(a[0]) | (unorm16(a[1]) << 16);
    const uint32_t material = uint32_t(i % LSNIF_MAX_MATERIALS), points = 1 + uint32_t(i % LSNIF_MAX_POINTS);
    r.attributes.albedo_b_material_points = unorm16(a[2]) | (material << 16) | (points << 24);
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
  d.albedo[0] = float(a.albedo_rg & 0xffffu) / 65535.0f;
  d.albedo[1] = float(a.albedo_rg >> 16) / 65535.0f;
  d.albedo[2] = float(a.albedo_b_material_points & 0xffffu) / 65535.0f;
  d.occlusion_logit = a.occlusion_logit;
  d.material = (a.albedo_b_material_points >> 16) & 0xffu;
  d.points = a.albedo_b_material_points >> 24;
  std::memcpy(&d.leaving_bits, &a.leaving_distance, 4);
  std::memcpy(&d.object_normal_x_bits, &a.normal_x, 4);
  return d;
}

// Runs one decoder (SPIR-V `code`) over `records`.
Status run_decoder(vk::ComputeContext& ctx, const vk::Spirv& code, const std::vector<Record>& records,
                   std::vector<DecodeResult>& out) {
  vk::Pipeline pipeline;
  if (Status s = ctx.create_pipeline(code, sizeof(uint32_t), pipeline, 3); !s) return s;
  vk::Buffer attributes, inputs, results;
  Status s = ctx.create_buffer(records.size() * sizeof(LsnifHitAttributes), attributes);
  if (s) s = ctx.create_buffer(records.size() * 4 * sizeof(glm::vec4), inputs);
  if (s) s = ctx.create_buffer(records.size() * sizeof(DecodeResult), results);
  if (s) {
    auto* a = static_cast<LsnifHitAttributes*>(attributes.mapped);
    auto* in = static_cast<glm::vec4*>(inputs.mapped);
    for (size_t i = 0; i < records.size(); ++i) {
      a[i] = records[i].attributes;
      for (int row = 0; row < 3; ++row) {
        const glm::mat3& m = records[i].world_to_object;
        in[4 * i + size_t(row)] = glm::vec4(m[0][row], m[1][row], m[2][row], 0.0f);
      }
      in[4 * i + 3] = glm::vec4(records[i].direction, 0.0f);
    }
    const uint32_t count = uint32_t(records.size());
    s = ctx.dispatch(pipeline, &count, (count + 63) / 64, {&attributes, &inputs, &results});
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

// Field by field: bits exactly, floats within `tolerance` (absolute; values are O(1)).
void expect_same(const DecodeResult& got, const DecodeResult& want, float tolerance, const char* what, size_t i) {
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(got.normal[k], want.normal[k], tolerance) << what << " record " << i << " normal " << k;
    EXPECT_NEAR(got.albedo[k], want.albedo[k], tolerance) << what << " record " << i << " albedo " << k;
  }
  EXPECT_NEAR(got.leaving_tmin, want.leaving_tmin, tolerance * want.leaving_tmin) << what << " record " << i;
  EXPECT_EQ(got.occlusion_logit, want.occlusion_logit) << what << " record " << i;
  EXPECT_EQ(got.material, want.material) << what << " record " << i;
  EXPECT_EQ(got.points, want.points) << what << " record " << i;
  EXPECT_EQ(got.leaving_bits, want.leaving_bits) << what << " record " << i;
  EXPECT_EQ(got.object_normal_x_bits, want.object_normal_x_bits) << what << " record " << i;
}

TEST(HitDecode, HlslAndGlslDecodeTheSameHitsAsTheCpu) {
  vk::ComputeContext ctx;
  const Status init = ctx.init(/*ray_tracing=*/false, test::test_validation(), test::test_device());
  ASSERT_TRUE(init) << init.message();
  const std::vector<Record> records = make_records(300);
  std::vector<DecodeResult> glsl, hlsl;
  Status s = run_decoder(ctx, vk::Spirv{hit_decode_comp_spirv, sizeof hit_decode_comp_spirv}, records, glsl);
  ASSERT_TRUE(s) << "GLSL decoder: " << s.message();
  s = run_decoder(ctx, vk::Spirv{hit_decode_hlsl_spirv, sizeof hit_decode_hlsl_spirv}, records, hlsl);
  ASSERT_TRUE(s) << "HLSL decoder: " << s.message();
  for (size_t i = 0; i < records.size(); ++i) {
    const DecodeResult want = cpu_decode(records[i]);
    expect_same(glsl[i], want, 2e-6f, "GLSL vs CPU", i);
    expect_same(hlsl[i], want, 2e-6f, "HLSL vs CPU", i);
    expect_same(hlsl[i], glsl[i], 2e-6f, "HLSL vs GLSL", i);
    if (::testing::Test::HasFailure()) break;  // one record's report is enough
  }
  // Not vacuous: the zero normal stays zero, a mirror flips x, the others are unit vectors.
  EXPECT_EQ(glsl[0].normal[0], 0.0f);
  EXPECT_NEAR(glsl[2].normal[0], -records[2].attributes.normal_x, 1e-6);
  EXPECT_NEAR(std::sqrt(glsl[5].normal[0] * glsl[5].normal[0] + glsl[5].normal[1] * glsl[5].normal[1] +
                        glsl[5].normal[2] * glsl[5].normal[2]),
              1.0, 1e-5);
  EXPECT_EQ(ctx.validation_errors(), 0u) << "Vulkan validation errors (printed above)";
  EXPECT_EQ(ctx.validation_warnings(), 0u) << "Vulkan validation warnings (printed above)";
}

}  // namespace
}  // namespace lsnif
