// loss.h -- LSNIF training losses (paper 5.3) for one ray, with their gradients w.r.t. the raw MLP
// outputs: binary cross-entropy on occlusion; mean absolute error on the distance output s (in the
// unit of the chosen hit parametrization, head.h); 1 - cosine similarity on the normal; relative L2
// on albedo (denominator treated as a constant, as in Noise2Noise); cross-entropy on the material;
// with surface channels (Config::surface_channels) squared error on metallic, roughness and ambient
// occlusion and relative L2 on the emission divided by the model's emission scale.
// Every loss but occlusion is zero where the reference misses.
//
// Normal loss: the paper uses 1 - cos(n, n*). Its gradient vanishes as the angle shrinks (it is
// ~theta^2 / 2), so the normal stops competing with the other heads for the shared grid and hidden
// layers. The default here is the angle itself, theta = acos(cos(n, n*)), whose gradient keeps its
// size: on the bunny at 2000 steps it halved the median normal error (7.7 -> 5.2 degrees) for a
// small cost in t and occlusion (docs/results.md). NormalLoss::Cosine restores the paper's.
#pragma once
#include <cstdint>
#include <string>

#include <glm/glm.hpp>

#include "lsnif/format/config.h"

namespace lsnif {

struct LossTarget {
  bool hit = false;
  float s = 0.0f;          // distance target in [0,1] (unit_from_distance)
  glm::vec3 normal{0.0f};  // non-zero when hit
  glm::vec3 albedo{0.0f};
  uint32_t material = 0;
  // Surface channels (used when config.surface_channels): in [0, 1], emission in
  // [0, config.emission_scale].
  float metallic = 0.0f, roughness = 0.0f, ambient_occlusion = 1.0f;
  glm::vec3 emission{0.0f};
};

enum class NormalLoss : uint32_t { Cosine = 0, Angle = 1 };
const char* to_string(NormalLoss l);

struct LossSettings {  // defaults: settings_table.h
  float occlusion = default_f32(SettingId::WOcclusion), distance = default_f32(SettingId::WDistance),
        normal = default_f32(SettingId::WNormal), albedo = default_f32(SettingId::WAlbedo),
        material = default_f32(SettingId::WMaterial), surface = default_f32(SettingId::WSurface);  // weights
  NormalLoss normal_loss = static_cast<NormalLoss>(default_u32(SettingId::NormalLoss));
  std::string describe() const;
};

struct LossTerms {
  double occlusion = 0, distance = 0, normal = 0, albedo = 0, material = 0, surface = 0;
  double total() const { return occlusion + distance + normal + albedo + material + surface; }
  LossTerms& operator+=(const LossTerms& o) {
    occlusion += o.occlusion; distance += o.distance; normal += o.normal;
    albedo += o.albedo; material += o.material; surface += o.surface;
    return *this;
  }
};

// Loss of one ray (weighted, unscaled) and d(scale * weighted loss)/d(raw) written to d_raw
// (config.output_dim() floats, overwritten). `scale` is normally 1 / batch size.
LossTerms ray_loss(const Config& config, const float* raw, const LossTarget& target,
                   const LossSettings& weights, float scale, float* d_raw);

}  // namespace lsnif
