// lsnif_intersect.glsl -- one object-space ray against one LSNIF model: walk (with tmax = inf, so
// the network input never depends on the query interval) -> encode -> MLP -> decode, accepted when
// occlusion >= 0.5 and tmin <= t <= tmax. The device twin of the per-ray part of
// host/intersector.cpp; the caller maps world rays to object space (gl_ObjectRay*EXT in an
// intersection shader) and the normal back to world space (inverse transpose).
// Include this first in a shader (after #version and GL_GOOGLE_include_directive): it declares
// the extensions listed in lsnif_model.glsl.
#ifndef LSNIF_INTERSECT_GLSL
#define LSNIF_INTERSECT_GLSL

#include "lsnif_head.glsl"

struct LsnifHitInfo {
  bool hit;               // accepted
  uint points;            // boundary points of the walk (0: network not evaluated, a miss)
  float occlusion_logit;  // raw occlusion output (0 when points == 0)
  float t;                // object-space ray parameter (= world ray parameter)
  vec3 normal;            // object space, normalized
  vec3 albedo;
  uint material;
};

LsnifHitInfo lsnif_intersect(LsnifModel m, vec3 origin, vec3 direction, float tmin, float tmax) {
  LsnifHitInfo r;
  r.hit = false;
  r.points = 0u;
  r.occlusion_logit = 0.0;
  r.t = 0.0;
  r.normal = vec3(0.0);
  r.albedo = vec3(0.0);
  r.material = 0u;
  if (!lsnif_finite3(origin) || !lsnif_finite3(direction) || direction == vec3(0.0) || isnan(tmin) ||
      isnan(tmax))
    return r;
  r.points = lsnif_walk_ray(m, origin, direction, tmin, LSNIF_INF);
  if (r.points == 0u) return r;
  lsnif_encode(m);
  const LsnifPrediction p = lsnif_decode(m, lsnif_mlp_forward(m));
  r.occlusion_logit = p.occlusion_logit;
  r.t = p.t;
  r.hit = p.hit && p.t >= tmin && p.t <= tmax;
  r.normal = p.normal;
  r.albedo = p.albedo;
  r.material = p.material;
  return r;
}

#endif
