// head.h -- LSNIF output heads (paper 5.3): turns the MLP's raw outputs for one ray into occlusion,
// hit distance, normal, albedo and material, and for a model with surface channels metallic,
// roughness, ambient occlusion and emission. The one C++ definition of the decoding and of the
// packed surface channels; mirrored by src/lsnif/shaders/lsnif_head.glsl and src/lsnif/lsnif_hit.glsl.
//
// Hit distance. The network's distance output s = sigmoid(raw) in (0, 1) is mapped to a ray
// parameter t in one of two ways (Config::hit_param):
//  * AabbInterval (paper): t = t_enter + s * (t_far - t_enter), the ray's interval inside the AABB.
//  * VoxelSegments (ours): the knots k_0 = t_enter, k_1..k_n = the n boundary points' t split the ray
//    into segments; u = s * H counts segments, t = k_j + (u - j) (k_{j+1} - k_j) with j = floor(u),
//    u clamped to [0, n]. The network names the crossed voxel segment the hit lies in and where in
//    it, instead of a fraction of the whole box.
// The walk must be made with tmax = inf: the network input never depends on the query's tmax.
#pragma once
#include <cstdint>

#include <glm/glm.hpp>

#include "lsnif/format/config.h"
#include "lsnif/core/ray_walk.h"

namespace lsnif {

inline float sigmoid(float x) { return 1.0f / (1.0f + std::exp(-x)); }

// s in [0,1] -> ray parameter t (see above).
float distance_from_unit(const Config& config, const RayWalk& walk, float s);
// Inverse map, used for training targets: ray parameter t -> s in [0,1].
float unit_from_distance(const Config& config, const RayWalk& walk, float t);

struct Prediction {
  float occlusion = 0.0f;  // probability in (0,1); a hit when >= LSNIF_OCCLUSION_THRESHOLD
  bool hit = false;
  float t = 0.0f;
  glm::vec3 normal{0.0f};  // object space, normalized (zero if the raw normal is zero)
  glm::vec3 albedo{0.0f};
  uint32_t material = 0;   // argmax of the material logits
  // Surface channels (config.surface_channels; else false and zero): sigmoid of the raw outputs,
  // emission times config.emission_scale.
  bool surface_learned = false;
  float metallic = 0.0f, roughness = 0.0f, ambient_occlusion = 0.0f;
  glm::vec3 emission{0.0f};
};

// The texture coordinate of a hit as the hit attributes carry it (LsnifHitAttributes): each
// coordinate as 28-bit two's complement fixed point with LSNIF_UV_FRACTION_BITS fractional bits
// (round to nearest, clamped to +-LSNIF_MAX_UV; NaN as 0), u in bits 0-27, v in bits 28-55.
uint64_t pack_uv(glm::vec2 uv);
glm::vec2 unpack_uv(uint64_t packed);

// Packed surface channels of a hit (host_device.h, LSNIF_SURFACE_LEARNED): metallic, roughness and
// ambient occlusion as unorm8 (round to nearest, as packUnorm4x8) and the learned flag; 0 when
// !p.surface_learned.
uint32_t pack_surface(const Prediction& p);
// Shared-exponent RGBE of a non-negative colour (LsnifHitAttributes::emission_rgbe): bytes 0-2 the
// mantissas m, byte 3 the exponent e, each channel m x 2^(e - LSNIF_RGBE_BIAS). The largest channel
// keeps 8 significant bits (relative error <= 2^-8); channels below 2^-127 of the largest, negative
// or NaN ones are 0; colours whose largest channel is below 2^-128 are 0.
uint32_t pack_rgbe(glm::vec3 c);
glm::vec3 unpack_rgbe(uint32_t rgbe);

// Decodes one ray's raw outputs (config.output_dim() floats). Rays with walk.count == 0 are misses
// and must not be passed here (the network is never evaluated for them).
Prediction decode(const Config& config, const float* raw, const RayWalk& walk);

}  // namespace lsnif
