// lsnif_query_common.glsl -- what the stages of lsnifCmdQuery share, whichever shader type runs
// them: the push constants, the buffers they address, the scratch sections, the ray checks and box
// clip, and the per-ray state and candidate records of the broad phase. Included by the compute
// stages (lsnif_query.comp) and by the ray-tracing broad phase (lsnif_query_broad.rgen, .rchit,
// .rmiss, .rint).
#ifndef LSNIF_QUERY_COMMON_GLSL
#define LSNIF_QUERY_COMMON_GLSL

#include "lsnif/shaders/lsnif_batch_rows.glsl"

layout(push_constant, std430) uniform LsnifQueryPush { LsnifQueryPushConstants pc; };

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer LsnifQueryRaysRef {
  LsnifQueryRay r[];
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer LsnifQueryResultsRef {
  LsnifQueryResult r[];
};
layout(buffer_reference, std430, buffer_reference_align = 4) writeonly buffer LsnifQueryStatusRef {
  LsnifQueryStatus s;
};
layout(buffer_reference, std430, buffer_reference_align = 8) readonly buffer LsnifQueryTableRef {
  uint64_t model[];
};
layout(buffer_reference, std430, buffer_reference_align = 4) coherent buffer LsnifQueryModelsRef {
  LsnifQueryModelCounters c[];
};
layout(buffer_reference, std430, buffer_reference_align = 4) coherent buffer LsnifQueryStatesRef {
  LsnifQueryRayState s[];
};
layout(buffer_reference, std430, buffer_reference_align = 4) coherent buffer LsnifQueryCandidatesRef {
  LsnifQueryCandidate c[];
};

const uint LSNIF_QUERY_INF_BITS = 0x7f800000u;  // +inf: greater than the bits of every finite t >= 0
const uint LSNIF_QUERY_NONE = 0xffffffffu;

// Scratch sections (host_device.h), in words from the scratch's start: per table entry a
// LsnifQueryModelCounters, per ray a LsnifQueryRayState, per candidate slot a LsnifQueryCandidate,
// then the sorted candidate indices and the batch rows.
uint lsnif_query_models_word() { return LSNIF_BATCH_HEADER_WORDS; }
uint lsnif_query_states_word() { return lsnif_query_models_word() + LSNIF_QUERY_MODEL_COUNTERS_WORDS * pc.model_count; }
uint lsnif_query_candidates_word() { return lsnif_query_states_word() + LSNIF_QUERY_RAY_STATE_WORDS * pc.ray_count; }
uint lsnif_query_sorted_word() { return lsnif_query_candidates_word() + LSNIF_QUERY_CANDIDATE_WORDS * pc.capacity; }
uint lsnif_query_rest_word() { return lsnif_query_sorted_word() + pc.stride; }
uint lsnif_query_rows_word() { return lsnif_query_rest_word() + pc.stride; }

uint64_t lsnif_query_scratch_address() { return lsnif_batch_address(pc.scratch_lo, pc.scratch_hi); }
LsnifScratchRef lsnif_query_scratch() { return LsnifScratchRef(lsnif_query_scratch_address()); }
LsnifQueryModelsRef lsnif_query_models() {
  return LsnifQueryModelsRef(lsnif_query_scratch_address() + 4ul * lsnif_query_models_word());
}
LsnifQueryStatesRef lsnif_query_states() {
  return LsnifQueryStatesRef(lsnif_query_scratch_address() + 4ul * lsnif_query_states_word());
}
LsnifQueryCandidatesRef lsnif_query_candidates() {
  return LsnifQueryCandidatesRef(lsnif_query_scratch_address() + 4ul * lsnif_query_candidates_word());
}
LsnifQueryRay lsnif_query_ray(uint ray) {
  return LsnifQueryRaysRef(lsnif_batch_address(pc.rays_lo, pc.rays_hi)).r[ray];
}
LsnifQueryResultsRef lsnif_query_results() {
  return LsnifQueryResultsRef(lsnif_batch_address(pc.results_lo, pc.results_hi));
}

// Candidates kept in the chunk (the counter may exceed the capacity).
uint lsnif_query_kept() { return min(lsnif_query_scratch().w[0], pc.capacity); }

// The ray flags lsnifCmdQuery honours.
uint lsnif_query_flags(LsnifQueryRay q) {
  return q.flags & (LSNIF_RAY_FLAG_CULL_BACK_FACING | LSNIF_RAY_FLAG_CULL_FRONT_FACING |
                    LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT);
}

// The ordering key of a hit distance t >= 0 (+0 for -0).
uint lsnif_query_t_key(float t) { return t == 0.0 ? 0u : floatBitsToUint(t); }

// A result without a hit (kind NONE or INCOMPLETE).
LsnifQueryResult lsnif_query_no_hit(uint kind) {
  LsnifQueryResult r;
  r.t = 0.0;
  r.normal_x = 0.0;
  r.normal_y = 0.0;
  r.normal_z = 0.0;
  r.albedo_r = 0.0;
  r.albedo_g = 0.0;
  r.albedo_b = 0.0;
  r.material = 0u;
  r.kind = kind;
  r.instance_index = LSNIF_QUERY_NONE;
  r.instance_custom_index = LSNIF_QUERY_NONE;
  r.primitive_index = LSNIF_QUERY_NONE;
  r.geometry_index = LSNIF_QUERY_NONE;
  r.barycentric_u = 0.0;
  r.barycentric_v = 0.0;
  r.front_face = 0u;
  r.surface = 0u;
  r.emission_r = 0.0;
  r.emission_g = 0.0;
  r.emission_b = 0.0;
  r.reports_uv = 0u;
  r.uv_u = 0.0;
  r.uv_v = 0.0;
  r.reserved = 0u;
  return r;
}

// The result of a committed triangle hit (the application shades it: normal, albedo, material,
// surface channels and emission stay zero).
LsnifQueryResult lsnif_query_triangle_hit(float t, uint instance_index, uint custom_index, uint primitive_index,
                                          uint geometry_index, vec2 barycentrics, bool front_face) {
  LsnifQueryResult r = lsnif_query_no_hit(LSNIF_QUERY_HIT_TRIANGLE);
  r.t = t;
  r.instance_index = instance_index;
  r.instance_custom_index = custom_index;
  r.primitive_index = primitive_index;
  r.geometry_index = geometry_index;
  r.barycentric_u = barycentrics.x;
  r.barycentric_v = barycentrics.y;
  r.front_face = front_face ? 1u : 0u;
  return r;
}

// A ray the traversal must not see (ray query rules): non-finite, zero direction, tmin < 0,
// tmin > tmax or NaN.
bool lsnif_query_ray_valid(vec3 origin, vec3 direction, float tmin, float tmax) {
  return lsnif_finite3(origin) && lsnif_finite3(direction) && direction != vec3(0.0) && !isnan(tmin) &&
         !isnan(tmax) && tmin >= 0.0 && tmin <= tmax && !isinf(tmin);
}

// [t_enter, t_exit] of the object-space ray inside the model's box within [tmin, tmax] (empty when
// t_enter > t_exit).
vec2 lsnif_query_clip(LsnifModel m, vec3 origin, vec3 direction, float tmin, float tmax) {
  const vec3 inv = 1.0 / direction;
  const vec3 a = (lsnif_bounds_lo(m) - origin) * inv, b = (lsnif_bounds_hi(m) - origin) * inv;
  const vec3 lo = min(a, b), hi = max(a, b);
  // A zero direction component gives nan where the origin lies on a face: such an axis does not clip.
  float t0 = tmin, t1 = tmax;
  for (int k = 0; k < 3; ++k) {
    if (!isnan(lo[k])) t0 = max(t0, lo[k]);
    if (!isnan(hi[k])) t1 = min(t1, hi[k]);
  }
  return vec2(t0, t1);
}

// A ray's state before its traversals: no hit, no triangle, nothing dropped.
LsnifQueryRayState lsnif_query_initial_state() {
  LsnifQueryRayState st;
  st.best_t = LSNIF_QUERY_INF_BITS;
  st.best_instance = LSNIF_QUERY_NONE;
  st.missing_t = LSNIF_QUERY_INF_BITS;
  st.triangle_t = LSNIF_QUERY_INF_BITS;
  st.triangle_instance = LSNIF_QUERY_NONE;
  st.first_t = LSNIF_QUERY_INF_BITS;
  st.reserved1 = 0u;
  st.reserved2 = 0u;
  return st;
}

// The candidate of ray `ray` at instance `instance_index` (custom index `custom`), not yet evaluated: the object-space
// ray o + t d within [tmin, tmax], crossing the model box over span = [t_enter, t_exit], and w2o for normals.
LsnifQueryCandidate lsnif_query_candidate(uint ray, uint instance_index, uint custom, uint flags, vec3 o, vec3 d,
                                          float tmin, float tmax, vec2 span, mat3 w2o) {
  LsnifQueryCandidate c;
  c.ray = ray;
  c.instance_index = instance_index;
  c.custom_index = custom;
  c.flags = flags;
  c.origin_x = o.x;
  c.origin_y = o.y;
  c.origin_z = o.z;
  c.tmin = tmin;
  c.direction_x = d.x;
  c.direction_y = d.y;
  c.direction_z = d.z;
  c.tmax = tmax;
  c.t_enter = span.x;
  c.t_exit = span.y;
  c.accepted = 0u;
  c.t = 0.0;
  for (int k = 0; k < 9; ++k) c.normal_matrix[k] = w2o[k / 3][k % 3];
  c.points = 0u;
  c.occlusion_logit = 0.0;
  c.material = 0u;
  c.normal_x = 0.0;
  c.normal_y = 0.0;
  c.normal_z = 0.0;
  c.albedo_r = 0.0;
  c.albedo_g = 0.0;
  c.albedo_b = 0.0;
  c.front_face = 0u;
  c.evaluated = 0u;
  c.surface = 0u;
  c.emission_r = 0.0;
  c.emission_g = 0.0;
  c.emission_b = 0.0;
  return c;
}

// The model-table entry of an instance (LsnifQueryPushConstants::model_index): its custom index less
// the base (one below the base wraps to a huge index, past the table), or its TLAS index.
uint lsnif_query_entry(uint instance_index, uint custom) {
  return pc.model_index == LSNIF_QUERY_MODEL_INDEX_BY_INSTANCE_INDEX ? instance_index : custom - pc.model_index_base;
}

// One AABB the broad phase meets on ray `id` (q, flags) within [q.tmin, tmax]: instance
// `instance_index` with custom index `custom`, the object-space ray o + t d and the world-to-object
// matrix w2o (for normals). The intersection shader's lookup decides whether it is an LSNIF
// instance (an index past the table, a hole or a block of another layout is not); when it is and
// the ray crosses the model box there, its candidate is appended. Returns the ordering key of the
// candidate's t_enter when it was dropped for lack of capacity (the caller lowers the ray's
// missing_t), else LSNIF_QUERY_INF_BITS; `kept_t`, the key of the t_enter of a candidate appended
// (the caller lowers the ray's first_t), else LSNIF_QUERY_INF_BITS.
uint lsnif_query_record_candidate(uint id, LsnifQueryRay q, uint flags, uint64_t table, uint custom,
                                  uint instance_index, vec3 o, vec3 d, mat3 w2o, float tmax, out uint kept_t) {
  kept_t = LSNIF_QUERY_INF_BITS;
  const uint entry = lsnif_query_entry(instance_index, custom);
  if (entry >= pc.model_count) return LSNIF_QUERY_INF_BITS;
  const uint64_t address = LsnifQueryTableRef(table).model[entry];
  if (address == 0ul || !lsnif_model_layout_matches(address)) return LSNIF_QUERY_INF_BITS;
  LsnifModel m = lsnif_load_model(address);
  const vec2 span = lsnif_query_clip(m, o, d, q.tmin, tmax);
  if (!(span.x <= span.y)) return LSNIF_QUERY_INF_BITS;
  const uint slot = atomicAdd(lsnif_query_scratch().w[0], 1u);
  if (slot >= pc.capacity) return lsnif_query_t_key(span.x);
  atomicAdd(lsnif_query_models().c[entry].count, 1u);
  lsnif_query_candidates().c[slot] = lsnif_query_candidate(id, instance_index, custom, flags, o, d, q.tmin, tmax, span, w2o);
  kept_t = lsnif_query_t_key(span.x);
  return LSNIF_QUERY_INF_BITS;
}

#endif  // LSNIF_QUERY_COMMON_GLSL
