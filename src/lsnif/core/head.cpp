#include "lsnif/core/head.h"

#include <algorithm>
#include <cmath>

namespace lsnif {

float distance_from_unit(const Config& config, const RayWalk& walk, float s) {
  if (config.hit_param == HitParam::AabbInterval)
    return walk.t_enter + s * (walk.t_exit - walk.t_enter);
  const uint32_t n = walk.count;
  if (n == 0) return walk.t_enter;
  float u = std::clamp(s * float(config.max_points), 0.0f, float(n));
  uint32_t j = std::min(uint32_t(u), n - 1);
  float k0 = j == 0 ? walk.t_enter : walk.t[j - 1];
  float k1 = walk.t[j];
  return k0 + (u - float(j)) * (k1 - k0);
}

float unit_from_distance(const Config& config, const RayWalk& walk, float t) {
  if (config.hit_param == HitParam::AabbInterval) {
    float len = walk.t_exit - walk.t_enter;
    return len > 0.0f ? std::clamp((t - walk.t_enter) / len, 0.0f, 1.0f) : 0.0f;
  }
  const uint32_t n = walk.count;
  float u = 0.0f;
  if (n > 0) {
    u = float(n);  // beyond the last knot (only when the walk was truncated): clamp
    float k0 = walk.t_enter;
    for (uint32_t j = 0; j < n; ++j) {
      float k1 = walk.t[j];
      if (t <= k1) {
        float len = k1 - k0;
        u = float(j) + (len > 0.0f ? std::clamp((t - k0) / len, 0.0f, 1.0f) : 1.0f);
        break;
      }
      k0 = k1;
    }
  }
  return u / float(config.max_points);
}

Prediction decode(const Config& config, const float* raw, const RayWalk& walk) {
  Prediction p;
  p.occlusion = sigmoid(raw[LSNIF_OUT_OCCLUSION]);
  p.hit = raw[LSNIF_OUT_OCCLUSION] >= 0.0f;  // sigmoid >= 0.5
  p.t = distance_from_unit(config, walk, sigmoid(raw[LSNIF_OUT_DISTANCE]));
  glm::vec3 n(raw[LSNIF_OUT_NORMAL], raw[LSNIF_OUT_NORMAL + 1], raw[LSNIF_OUT_NORMAL + 2]);
  float len = glm::length(n);
  p.normal = len > 0.0f ? n / len : glm::vec3(0.0f);
  for (int c = 0; c < 3; ++c) p.albedo[c] = sigmoid(raw[LSNIF_OUT_ALBEDO + c]);
  uint32_t best = 0;
  for (uint32_t m = 1; m < config.material_count; ++m)
    if (raw[LSNIF_OUT_MATERIAL + m] > raw[LSNIF_OUT_MATERIAL + best]) best = m;
  p.material = best;
  if (config.surface_channels) {
    const float* surface = raw + config.surface_output();
    p.surface_learned = true;
    p.metallic = sigmoid(surface[LSNIF_OUT_SURFACE_METALLIC]);
    p.roughness = sigmoid(surface[LSNIF_OUT_SURFACE_ROUGHNESS]);
    p.ambient_occlusion = sigmoid(surface[LSNIF_OUT_SURFACE_AMBIENT_OCCLUSION]);
    for (int c = 0; c < 3; ++c) p.emission[c] = config.emission_scale * sigmoid(surface[LSNIF_OUT_SURFACE_EMISSION + c]);
  }
  return p;
}

namespace {
constexpr uint32_t kUvBits = 28;
constexpr uint64_t kUvMask = (uint64_t(1) << kUvBits) - 1;
}  // namespace

uint64_t pack_uv(glm::vec2 uv) {
  uint64_t packed = 0;
  for (int a = 0; a < 2; ++a) {
    const float x = std::isnan(uv[a]) ? 0.0f : std::clamp(uv[a], -float(LSNIF_MAX_UV), float(LSNIF_MAX_UV));
    const int64_t fixed = std::llround(double(x) * double(1u << LSNIF_UV_FRACTION_BITS));
    packed |= (uint64_t(fixed) & kUvMask) << (kUvBits * a);
  }
  return packed;
}

glm::vec2 unpack_uv(uint64_t packed) {
  glm::vec2 uv;
  for (int a = 0; a < 2; ++a) {
    int64_t fixed = int64_t((packed >> (kUvBits * a)) & kUvMask);
    if (fixed & (int64_t(1) << (kUvBits - 1))) fixed -= int64_t(1) << kUvBits;  // sign
    uv[a] = float(double(fixed) / double(1u << LSNIF_UV_FRACTION_BITS));
  }
  return uv;
}

namespace {
uint32_t unorm8(float x) { return uint32_t(std::lround(std::clamp(x, 0.0f, 1.0f) * 255.0f)); }
}  // namespace

uint32_t pack_surface(const Prediction& p) {
  if (!p.surface_learned) return 0;
  return unorm8(p.metallic) | unorm8(p.roughness) << 8 | unorm8(p.ambient_occlusion) << 16 | LSNIF_SURFACE_LEARNED << 24;
}

uint32_t pack_rgbe(glm::vec3 c) {
  float largest = 0.0f;
  for (int k = 0; k < 3; ++k) {
    if (!(c[k] > 0.0f)) c[k] = 0.0f;  // negative or NaN
    largest = std::max(largest, c[k]);
  }
  int x = 0;
  std::frexp(largest, &x);  // largest = f 2^x, f in [0.5, 1)
  if (largest == 0.0f || x < 1 - 128 || !std::isfinite(largest)) return 0;
  x = std::min(x, 127);
  uint32_t out = uint32_t(x + 128) << 24;
  for (int k = 0; k < 3; ++k) {
    const float m = std::round(std::ldexp(c[k], 8 - x));
    out |= uint32_t(std::min(m, 255.0f)) << (8 * k);
  }
  return out;
}

glm::vec3 unpack_rgbe(uint32_t rgbe) {
  const int e = int(rgbe >> 24);
  if (e == 0) return glm::vec3(0.0f);
  glm::vec3 c;
  for (int k = 0; k < 3; ++k) c[k] = std::ldexp(float((rgbe >> (8 * k)) & 0xffu), e - LSNIF_RGBE_BIAS);
  return c;
}

}  // namespace lsnif
