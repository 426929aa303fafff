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
  return p;
}

}  // namespace lsnif
