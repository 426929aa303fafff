// lsnif_head.glsl -- the LSNIF output heads on the device (src/lsnif/core/head.cpp decode and
// distance_from_unit): occlusion (hit when the logit >= 0, i.e. sigmoid >= 0.5), distance for both
// hit parametrizations, normalized normal, sigmoid albedo, argmax material and, for a model with
// surface channels, sigmoid metallic, roughness and ambient occlusion and emission_scale x sigmoid
// emission.
#ifndef LSNIF_HEAD_GLSL
#define LSNIF_HEAD_GLSL

#include "lsnif/shaders/lsnif_mlp.glsl"

float lsnif_sigmoid(float x) { return 1.0 / (1.0 + exp(-x)); }

// distance_from_unit: s in [0,1] -> object-space ray parameter, from lsnif_walk.
float lsnif_distance_from_unit(LsnifModel m, float s) {
  if (m.h.hit_param == LSNIF_HIT_PARAM_AABB_INTERVAL)
    return lsnif_walk.t_enter + s * (lsnif_walk.t_exit - lsnif_walk.t_enter);
  const uint n = lsnif_walk.count;
  if (n == 0u) return lsnif_walk.t_enter;
  const float u = clamp(s * float(m.h.max_points), 0.0, float(n));
  const uint j = min(uint(u), n - 1u);
  const float k0 = j == 0u ? lsnif_walk.t_enter : lsnif_walk.t[j - 1u];
  const float k1 = lsnif_walk.t[j];
  return k0 + (u - float(j)) * (k1 - k0);
}

struct LsnifPrediction {
  float occlusion_logit;  // raw; a hit when >= 0
  bool hit;
  float t;        // object-space ray parameter
  vec3 normal;    // object space, normalized (zero if the raw normal is zero)
  vec3 albedo;
  uint material;  // argmax of the material logits
  // Surface channels (LsnifGpuModelHeader::surface_channels; else false and zero).
  bool surface_learned;
  float metallic, roughness, ambient_occlusion;
  vec3 emission;  // linear RGB: emission_scale x sigmoid
};

// decode: raw outputs at lsnif_act[base, base + output_dim). Only for walks with count > 0.
LsnifPrediction lsnif_decode(LsnifModel m, uint base) {
  LsnifPrediction p;
  p.occlusion_logit = lsnif_act[base + LSNIF_OUT_OCCLUSION];
  p.hit = p.occlusion_logit >= 0.0;
  p.t = lsnif_distance_from_unit(m, lsnif_sigmoid(lsnif_act[base + LSNIF_OUT_DISTANCE]));
  const vec3 n = vec3(lsnif_act[base + LSNIF_OUT_NORMAL], lsnif_act[base + LSNIF_OUT_NORMAL + 1u],
                      lsnif_act[base + LSNIF_OUT_NORMAL + 2u]);
  const float len = length(n);
  p.normal = len > 0.0 ? n / len : vec3(0.0);
  p.albedo = vec3(lsnif_sigmoid(lsnif_act[base + LSNIF_OUT_ALBEDO]),
                  lsnif_sigmoid(lsnif_act[base + LSNIF_OUT_ALBEDO + 1u]),
                  lsnif_sigmoid(lsnif_act[base + LSNIF_OUT_ALBEDO + 2u]));
  uint best = 0u;
  for (uint k = 1u; k < m.h.material_count; ++k)
    if (lsnif_act[base + LSNIF_OUT_MATERIAL + k] > lsnif_act[base + LSNIF_OUT_MATERIAL + best]) best = k;
  p.material = best;
  p.surface_learned = m.h.surface_channels != 0u;
  p.metallic = 0.0;
  p.roughness = 0.0;
  p.ambient_occlusion = 0.0;
  p.emission = vec3(0.0);
  if (p.surface_learned) {
    const uint s = base + lsnif_surface_output(m);
    p.metallic = lsnif_sigmoid(lsnif_act[s + LSNIF_OUT_SURFACE_METALLIC]);
    p.roughness = lsnif_sigmoid(lsnif_act[s + LSNIF_OUT_SURFACE_ROUGHNESS]);
    p.ambient_occlusion = lsnif_sigmoid(lsnif_act[s + LSNIF_OUT_SURFACE_AMBIENT_OCCLUSION]);
    for (uint c = 0u; c < 3u; ++c)
      p.emission[c] = m.h.emission_scale * lsnif_sigmoid(lsnif_act[s + LSNIF_OUT_SURFACE_EMISSION + c]);
  }
  return p;
}

#endif
