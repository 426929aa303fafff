// lsnif_intersect.glsl -- one object-space ray against one LSNIF model: walk (with tmax = inf, so
// the network input never depends on the query interval) -> encode -> MLP -> decode, accepted when
// occlusion >= 0.5, tmin <= t <= tmax and the hit's facing is not culled by `ray_flags`
// (LSNIF_RAY_FLAG_CULL_*_FACING, src/lsnif/host_device.h). The device twin of the per-ray part of
// src/lsnif/core/intersector.cpp; the caller maps world rays to object space (gl_ObjectRay*EXT in an
// intersection shader) and the normal back to world space (inverse transpose).
// Include this first in a shader (after #version and GL_GOOGLE_include_directive): it declares
// the extensions listed in lsnif_model.glsl.
#ifndef LSNIF_INTERSECT_GLSL
#define LSNIF_INTERSECT_GLSL

#include "lsnif/shaders/lsnif_head.glsl"
#include "lsnif/shaders/lsnif_uv_cells.glsl"

struct LsnifHitInfo {
  bool hit;               // accepted
  uint points;            // boundary points of the walk (0: network not evaluated, a miss)
  float occlusion_logit;  // raw occlusion output (0 when points == 0)
  float t;                // object-space ray parameter (= world ray parameter)
  vec3 normal;            // object space, normalized
  vec3 albedo;
  uint material;
  // The prediction's surface channels (LsnifPrediction; false and zero without them or a walk).
  bool surface_learned;
  float metallic, roughness, ambient_occlusion;
  vec3 emission;
  // A hit of a texture-coordinate material (lsnif_reports_uv): the texture coordinate from the uv
  // cells (lsnif_hit_uv) and true; else zero and false.
  bool reports_uv;
  vec2 uv;
};

// Facing of a prediction (host_device.h): true when a culling flag in `ray_flags` rejects it.
bool lsnif_facing_culled(vec3 object_normal, vec3 object_direction, uint ray_flags) {
  const float facing = dot(object_normal, object_direction);
  return ((ray_flags & LSNIF_RAY_FLAG_CULL_BACK_FACING) != 0u && facing > 0.0) ||
         ((ray_flags & LSNIF_RAY_FLAG_CULL_FRONT_FACING) != 0u && facing < 0.0);
}

// The hit kind of a prediction (host_device.h): LSNIF_HIT_KIND_FRONT_FACING when the normal points
// against the direction, LSNIF_HIT_KIND_BACK_FACING otherwise (LsnifQueryResult::front_face alike).
uint lsnif_hit_kind(vec3 object_normal, vec3 object_direction) {
  return dot(object_normal, object_direction) < 0.0 ? LSNIF_HIT_KIND_FRONT_FACING : LSNIF_HIT_KIND_BACK_FACING;
}

// The first half of lsnif_intersect: the walk of a valid ray (else 0 boundary points, a miss).
// Fills lsnif_walk; returns its point count.
uint lsnif_intersect_walk(LsnifModel m, vec3 origin, vec3 direction, float tmin, float tmax) {
  if (!lsnif_finite3(origin) || !lsnif_finite3(direction) || direction == vec3(0.0) || isnan(tmin) ||
      isnan(tmax))
    return 0u;
  return lsnif_walk_ray(m, origin, direction, tmin, LSNIF_INF);
}

// The second half: the decoded prediction of a walk with `points` > 0 accepted or not against the
// query interval and the culling flags.
LsnifHitInfo lsnif_intersect_accept(LsnifPrediction p, uint points, vec3 direction, float tmin, float tmax,
                                    uint ray_flags) {
  LsnifHitInfo r;
  r.points = points;
  r.occlusion_logit = p.occlusion_logit;
  r.t = p.t;
  r.hit = p.hit && p.t >= tmin && p.t <= tmax && !lsnif_facing_culled(p.normal, direction, ray_flags);
  r.normal = p.normal;
  r.albedo = p.albedo;
  r.material = p.material;
  r.surface_learned = p.surface_learned;
  r.metallic = p.metallic;
  r.roughness = p.roughness;
  r.ambient_occlusion = p.ambient_occlusion;
  r.emission = p.emission;
  r.reports_uv = false;
  r.uv = vec2(0.0);
  return r;
}

// The texture coordinate of an accepted hit `h` of a ray (object-space origin, direction) whose
// material reports it (intersector.cpp: UvCells::lookup at the predicted point).
void lsnif_hit_uv(LsnifModel m, inout LsnifHitInfo h, vec3 origin, vec3 direction) {
  if (h.hit && lsnif_reports_uv(m, h.material))
    h.reports_uv = lsnif_uv_lookup(m, origin + h.t * direction, h.normal, direction, h.uv);
}

// A miss before any network evaluation (points == 0).
LsnifHitInfo lsnif_intersect_none() {
  LsnifHitInfo r;
  r.hit = false;
  r.points = 0u;
  r.occlusion_logit = 0.0;
  r.t = 0.0;
  r.normal = vec3(0.0);
  r.albedo = vec3(0.0);
  r.material = 0u;
  r.surface_learned = false;
  r.metallic = 0.0;
  r.roughness = 0.0;
  r.ambient_occlusion = 0.0;
  r.emission = vec3(0.0);
  r.reports_uv = false;
  r.uv = vec2(0.0);
  return r;
}

// One ray, the whole way: walk -> encode -> MLP -> decode -> accept, and the texture coordinate of
// an accepted hit that reports one. The batched paths (lsnif_batch.comp, lsnif_query.comp) run the
// same steps in separate passes over many rays.
LsnifHitInfo lsnif_intersect(LsnifModel m, vec3 origin, vec3 direction, float tmin, float tmax,
                             uint ray_flags) {
  const uint points = lsnif_intersect_walk(m, origin, direction, tmin, tmax);
  if (points == 0u) return lsnif_intersect_none();
  lsnif_encode(m);
  LsnifHitInfo h =
      lsnif_intersect_accept(lsnif_decode(m, lsnif_mlp_forward(m, points)), points, direction, tmin, tmax, ray_flags);
  lsnif_hit_uv(m, h, origin, direction);
  return h;
}

#endif
