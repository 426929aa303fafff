// lsnif_query.comp -- queries against the application's TLAS (lsnifCmdQuery): the paper's section 4
// pipeline over triangle and LSNIF instances together. Compiled once per stage (glslangValidator -D);
// the stages of one chunk of rays, in recording order (src/lsnif/plugin/query_pipeline.cpp):
//  LSNIF_QUERY_CLEAR    the candidate counter and every model's counters = 0 (the status
//                       accumulators too on the first chunk).
//  LSNIF_QUERY_BROAD    the ray-query broad phase (LSNIF_QUERY_BROAD_PHASE_RAY_QUERY, the default
//                       where ray queries are enabled; the ray-tracing one, for devices without
//                       them, is lsnif_query_broad.rgen with the same records):
//                       1 invocation per ray, GL_EXT_ray_query: a traversal committing triangles
//                       only (closest, or any with LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT) whose hit
//                       is written to the result; then, unless an any-hit ray is already answered, a
//                       traversal visiting the AABBs up to that hit, appending one candidate per LSNIF
//                       instance whose model box the ray crosses there (the object-space ray exactly
//                       as the intersection shader sees it). Candidates past the capacity are dropped
//                       and noted in the ray's state (the smallest t_enter dropped).
//  LSNIF_QUERY_SCAN     1 workgroup: exclusive prefix sum of the per-entry counts (counting sort by
//                       model-table entry), the indirect dispatch of the scatter.
//  The per-model stages run once per run of consecutive table entries of one model (pc.bucket ..
//  pc.bucket_last; the host finds the runs in pModels): a model instanced a thousand times is one
//  batch and three dispatches per round, not a thousand.
//  LSNIF_QUERY_RUN_ARGS per run, 1 invocation: the run's candidates (contiguous in the sorted order)
//                       and the indirect dispatch of its narrow phase.
//  LSNIF_QUERY_SCATTER  1 invocation per candidate: its index into its entry's sorted range.
//  Then two rounds of the per-model stages below: the first over the candidates nearest their
//  ray (LSNIF_QUERY_ROUND_NEAREST, host_device.h), the second over the others whose hit could still
//  win against the first round's (LSNIF_QUERY_ROUND_REST; query_narrow says why nothing else can).
//  LSNIF_QUERY_NARROW   per run, 1 invocation per candidate of its range, when the candidate's table
//                       entry holds the model recorded for it (else it stays not evaluated) and the
//                       round takes it: the walk and encoding (lsnif_batch_rows.glsl); candidates with
//                       boundary points take a slot of the run's dense batch (in the columns of its
//                       range, after the slots of the round before).
//  LSNIF_QUERY_BATCH_ARGS  1 invocation per entry: the round's slots and the indirect dispatch over them.
//  LSNIF_QUERY_ORDER    per run, 1 workgroup: the round's slots by walk length into the order row
//                       (lsnif_rows_order_by_points), the order the portable MLP takes them in.
//  LSNIF_QUERY_MLP      per run, 1 invocation per two slots of the round: the MLP (lsnif_rows_mlp_pair).
//  LSNIF_QUERY_DECODE   per run, 1 invocation per slot of the round: heads, acceptance and the texture
//                       coordinate of an accepted hit that reports one (lsnif_hit_uv); an accepted
//                       candidate lowers its ray's best t (atomicMin on the float bits).
//  LSNIF_QUERY_TIE      1 invocation per candidate: the accepted candidates at their ray's best t
//                       lower its best instance (atomicMin), so that equal t resolve by instance index;
//                       candidates not evaluated are noted in the ray's state (and counted).
//  LSNIF_QUERY_RESOLVE_HITS  1 invocation per candidate: the winner writes its LSNIF result.
//  LSNIF_QUERY_RESOLVE_RAYS  1 invocation per ray: rays a dropped or not evaluated candidate could
//                       have changed become LSNIF_QUERY_HIT_INCOMPLETE (and are counted).
//  LSNIF_QUERY_STATUS   1 invocation: the accumulated LsnifQueryStatus to the application's address.
// Layouts: LsnifQueryRay, LsnifQueryResult, LsnifQueryStatus, LsnifQueryPushConstants and the
// scratch (LsnifQueryModelCounters, LsnifQueryRayState, LsnifQueryCandidate) in host_device.h; what
// the stages share with the ray-tracing broad phase in lsnif_query_common.glsl.
#version 460
#extension GL_EXT_ray_query : require
#extension GL_GOOGLE_include_directive : require
#if defined(LSNIF_QUERY_ORDER)
#define LSNIF_ROWS_ORDER_STAGE
#endif
#include "lsnif/shaders/lsnif_query_common.glsl"
#define LSNIF_HIT_DECODE_ONLY  // a compute shader: the packers of lsnif_hit.glsl only
#include "lsnif/lsnif_hit.glsl"
#if defined(LSNIF_QUERY_MLP) && defined(LSNIF_MLP_COOPMAT_NV)
#include "lsnif/shaders/lsnif_mlp_coopmat.glsl"
#endif

layout(local_size_x = LSNIF_BATCH_GROUP_SIZE) in;

#if defined(LSNIF_QUERY_SCAN)
shared uint lsnif_query_lane_sums[LSNIF_BATCH_GROUP_SIZE];
#endif

#if defined(LSNIF_QUERY_CLEAR)
// LSNIF_QUERY_CLEAR: word `id` of the header (a status accumulator only on the first chunk) or of the
// model counters = 0.
void query_clear(uint id) {
  LsnifScratchRef scratch = lsnif_query_scratch();
  if (id < LSNIF_BATCH_HEADER_WORDS) {
    const bool status = id >= LSNIF_QUERY_STATUS_WORD && id < LSNIF_QUERY_STATUS_WORD + 6u;
    if (!status || pc.first_chunk != 0u) scratch.w[id] = 0u;
  } else if (id < lsnif_query_states_word()) {  // the model counters
    scratch.w[id] = 0u;
  }
}
#endif

#if defined(LSNIF_QUERY_BROAD)
// The closest (or, for an any-hit ray, any) triangle hit; false without one.
bool lsnif_query_triangles(uint64_t tlas, uint flags, vec3 origin, vec3 direction, float tmin,
                           float tmax, out LsnifQueryResult r) {
  rayQueryEXT rq;
  // Triangles forced opaque are committed by the traversal; AABB candidates are left uncommitted.
  uint rq_flags = gl_RayFlagsOpaqueEXT | (flags & (LSNIF_RAY_FLAG_CULL_BACK_FACING | LSNIF_RAY_FLAG_CULL_FRONT_FACING));
  if ((flags & LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT) != 0u) rq_flags |= gl_RayFlagsTerminateOnFirstHitEXT;
  rayQueryInitializeEXT(rq, accelerationStructureEXT(tlas), rq_flags, pc.cull_mask, origin, tmin, direction, tmax);
  while (rayQueryProceedEXT(rq)) {
  }
  r = lsnif_query_no_hit(LSNIF_QUERY_HIT_NONE);
  if (rayQueryGetIntersectionTypeEXT(rq, true) != gl_RayQueryCommittedIntersectionTriangleEXT) return false;
  r = lsnif_query_triangle_hit(
      rayQueryGetIntersectionTEXT(rq, true), uint(rayQueryGetIntersectionInstanceIdEXT(rq, true)),
      uint(rayQueryGetIntersectionInstanceCustomIndexEXT(rq, true)), uint(rayQueryGetIntersectionPrimitiveIndexEXT(rq, true)),
      uint(rayQueryGetIntersectionGeometryIndexEXT(rq, true)), rayQueryGetIntersectionBarycentricsEXT(rq, true),
      rayQueryGetIntersectionFrontFaceEXT(rq, true));
  return true;
}

// The traversal of ray `id` (q, world-space origin and direction) visiting the AABBs up to tmax: appends one
// candidate per LSNIF instance whose model box the ray crosses (lowering st.first_t); those past the
// capacity lower st.missing_t.
void lsnif_query_append_candidates(uint id, LsnifQueryRay q, uint flags, uint64_t tlas, uint64_t table,
                                   vec3 origin, vec3 direction, float tmax, inout LsnifQueryRayState st) {
  rayQueryEXT rq;
  // Triangles forced non-opaque are candidates that are never confirmed: nothing is committed,
  // so every AABB up to the triangle hit is visited. (The Skip*Primitives flags would need the
  // primitive-culling capability.)
  rayQueryInitializeEXT(rq, accelerationStructureEXT(tlas), gl_RayFlagsNoOpaqueEXT, pc.cull_mask, origin, q.tmin,
                        direction, tmax);
  while (rayQueryProceedEXT(rq)) {
    if (rayQueryGetIntersectionTypeEXT(rq, false) != gl_RayQueryCandidateIntersectionAABBEXT) continue;
    uint kept_t;
    const uint dropped = lsnif_query_record_candidate(
        id, q, flags, table, uint(rayQueryGetIntersectionInstanceCustomIndexEXT(rq, false)),
        uint(rayQueryGetIntersectionInstanceIdEXT(rq, false)), rayQueryGetIntersectionObjectRayOriginEXT(rq, false),
        rayQueryGetIntersectionObjectRayDirectionEXT(rq, false), mat3(rayQueryGetIntersectionWorldToObjectEXT(rq, false)),
        tmax, kept_t);
    st.missing_t = min(st.missing_t, dropped);
    st.first_t = min(st.first_t, kept_t);
  }
}

// LSNIF_QUERY_BROAD: ray `id`'s triangle hit to its result, then (unless an any-hit ray is answered) its
// candidates up to that hit; its state to the scratch.
void query_broad(uint id) {
  if (id >= pc.ray_count) return;
  const LsnifQueryRay q = lsnif_query_ray(id);
  const vec3 origin = vec3(q.origin_x, q.origin_y, q.origin_z);
  const vec3 direction = vec3(q.direction_x, q.direction_y, q.direction_z);
  const uint flags = lsnif_query_flags(q);
  LsnifQueryRayState st = lsnif_query_initial_state();
  LsnifQueryResult result = lsnif_query_no_hit(LSNIF_QUERY_HIT_NONE);
  if (lsnif_query_ray_valid(origin, direction, q.tmin, q.tmax)) {
    const uint64_t tlas = lsnif_batch_address(pc.tlas_lo, pc.tlas_hi);
    float tmax = q.tmax;
    const bool triangle = lsnif_query_triangles(tlas, flags, origin, direction, q.tmin, q.tmax, result);
    if (triangle) {
      tmax = result.t;
      st.best_t = st.triangle_t = lsnif_query_t_key(result.t);
      st.triangle_instance = result.instance_index;
    }
    const uint64_t table = lsnif_batch_address(pc.table_lo, pc.table_hi);
    if (!(triangle && (flags & LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT) != 0u) && table != 0ul)
      lsnif_query_append_candidates(id, q, flags, tlas, table, origin, direction, tmax, st);
  }
  lsnif_query_states().s[id] = st;
  lsnif_query_results().r[id] = result;
}
#endif

#if defined(LSNIF_QUERY_SCAN)
// LSNIF_QUERY_SCAN: every entry's start (exclusive prefix sum of the counts), the scatter's dispatch,
// and the chunk's candidates added to the status accumulators.
void query_scan() {
  LsnifScratchRef scratch = lsnif_query_scratch();
  LsnifQueryModelsRef models = lsnif_query_models();
  // One workgroup: lane l sums the counts of its contiguous share of the models, the lanes' sums are
  // scanned in shared memory, then each lane writes the starts of its share.
  const uint lane = gl_LocalInvocationID.x;
  const uint share = (pc.model_count + LSNIF_BATCH_GROUP_SIZE - 1u) / LSNIF_BATCH_GROUP_SIZE;
  const uint first = min(lane * share, pc.model_count), last = min(first + share, pc.model_count);
  uint sum = 0u;
  for (uint b = first; b < last; ++b) sum += models.c[b].count;
  lsnif_query_lane_sums[lane] = sum;
  barrier();
  uint start = 0u;
  for (uint l = 0u; l < lane; ++l) start += lsnif_query_lane_sums[l];
  for (uint b = first; b < last; ++b) {
    models.c[b].start = start;
    start += models.c[b].count;
  }
  if (lane == 0u) {
    const uint produced = scratch.w[0], kept = min(produced, pc.capacity);
    scratch.w[LSNIF_QUERY_SCATTER_ARGS_WORD] = (kept + LSNIF_BATCH_GROUP_SIZE - 1u) / LSNIF_BATCH_GROUP_SIZE;
    scratch.w[LSNIF_QUERY_SCATTER_ARGS_WORD + 1u] = 1u;
    scratch.w[LSNIF_QUERY_SCATTER_ARGS_WORD + 2u] = 1u;
    scratch.w[LSNIF_QUERY_STATUS_WORD] += produced;
    scratch.w[LSNIF_QUERY_STATUS_WORD + 1u] = pc.capacity;
    scratch.w[LSNIF_QUERY_STATUS_WORD + 2u] += produced - kept;
  }
}
#endif

#if defined(LSNIF_QUERY_RUN_ARGS)
// LSNIF_QUERY_RUN_ARGS: the candidates of the run pc.bucket .. pc.bucket_last (sorted slots from the
// first entry's start) and its narrow phase's indirect dispatch, in the first entry's counters.
void query_run_args(uint id) {
  if (id != 0u) return;
  LsnifQueryModelsRef models = lsnif_query_models();
  const uint count = models.c[pc.bucket_last].start + models.c[pc.bucket_last].count - models.c[pc.bucket].start;
  models.c[pc.bucket].run_count = count;
  models.c[pc.bucket].narrow_groups_x = (count + LSNIF_BATCH_GROUP_SIZE - 1u) / LSNIF_BATCH_GROUP_SIZE;
  models.c[pc.bucket].narrow_groups_y = 1u;
  models.c[pc.bucket].narrow_groups_z = 1u;
}
#endif

#if defined(LSNIF_QUERY_SCATTER)
// LSNIF_QUERY_SCATTER: candidate `id`'s index to the next place of its model's sorted range.
void query_scatter(uint id) {
  if (id >= lsnif_query_kept()) return;
  LsnifQueryModelsRef models = lsnif_query_models();
  const uint b = lsnif_query_entry(lsnif_query_candidates().c[id].instance_index,
                                   lsnif_query_candidates().c[id].custom_index);
  lsnif_query_scratch().w[lsnif_query_sorted_word() + models.c[b].start + atomicAdd(models.c[b].cursor, 1u)] = id;
}
#endif

#if defined(LSNIF_QUERY_BATCH_ARGS)
// LSNIF_QUERY_BATCH_ARGS: entry `id`'s round (used where a run starts): the slots its narrow phase just
// took, after those of the rounds before, and the indirect dispatches over them and over the
// candidates left to the next round.
void query_batch_args(uint id) {
  if (id >= pc.model_count) return;
  LsnifQueryModelsRef models = lsnif_query_models();
  const uint first = models.c[id].round_end, end = models.c[id].batch;
  models.c[id].round_start = first;
  models.c[id].round_end = end;
  // The next round's narrow phase: over the candidates the first one left (after the second, unused).
  models.c[id].narrow_groups_x = (models.c[id].rest_count + LSNIF_BATCH_GROUP_SIZE - 1u) / LSNIF_BATCH_GROUP_SIZE;
  models.c[id].batch_groups_x = (end - first + LSNIF_BATCH_GROUP_SIZE - 1u) / LSNIF_BATCH_GROUP_SIZE;
  models.c[id].batch_groups_y = 1u;
  models.c[id].batch_groups_z = 1u;
}
#endif

#if defined(LSNIF_QUERY_NARROW) || defined(LSNIF_QUERY_ORDER) || defined(LSNIF_QUERY_MLP) || defined(LSNIF_QUERY_DECODE)
// The model of pc.bucket, the batch rows, and the start of the model's sorted range; its batch occupies
// the columns of its sorted range.
void lsnif_query_bucket(out LsnifModel m, out LsnifBatchRows rows, out uint start) {
  m = lsnif_load_model(lsnif_batch_address(pc.model_lo, pc.model_hi));
  rows.scratch = lsnif_query_scratch();
  rows.base = lsnif_query_rows_word();
  rows.stride = pc.stride;
  start = lsnif_query_models().c[pc.bucket].start;
}

// The current round's batch slots of pc.bucket (MLP, decode): `count` of them from column `first`.
void lsnif_query_round(uint start, out uint first, out uint count) {
  LsnifQueryModelsRef models = lsnif_query_models();
  first = start + models.c[pc.bucket].round_start;
  count = models.c[pc.bucket].round_end - models.c[pc.bucket].round_start;
}
#endif

#if defined(LSNIF_QUERY_NARROW)
// LSNIF_QUERY_NARROW: the walk and encoding of candidate `id` of the round (pc.query_round) of the run
// pc.bucket; with boundary points, it takes a slot of the run's batch.
//  - LSNIF_QUERY_ROUND_NEAREST, over the run's sorted candidates: those entering their box at their
//    ray's first_t (the nearest box of the ray; usually where its hit is); the others are listed for
//    the second round (from the run's start in the rest list).
//  - LSNIF_QUERY_ROUND_REST, over that list: each unless its hit could not win: an accepted hit lies
//    at or after the start of its walk (lsnif_distance_from_unit interpolates from there), so a
//    candidate whose walk starts beyond its ray's best t after the first round is marked evaluated
//    and left (culled). Nothing that could change an answer is skipped: the answers are those of
//    evaluating every candidate, at a cost that follows the boxes a ray crosses before its hit.
void query_narrow(uint id) {
  LsnifModel m;
  LsnifBatchRows rows;
  uint start;
  lsnif_query_bucket(m, rows, start);
  LsnifQueryModelsRef models = lsnif_query_models();
  LsnifQueryCandidatesRef candidates = lsnif_query_candidates();
  LsnifScratchRef scratch = lsnif_query_scratch();
  const bool nearest = pc.query_round == LSNIF_QUERY_ROUND_NEAREST;
  if (id >= (nearest ? models.c[pc.bucket].run_count : models.c[pc.bucket].rest_count)) return;
  const uint ci = scratch.w[(nearest ? lsnif_query_sorted_word() : lsnif_query_rest_word()) + start + id];
  const LsnifQueryCandidate c = candidates.c[ci];
  const vec3 origin = vec3(c.origin_x, c.origin_y, c.origin_z), direction = vec3(c.direction_x, c.direction_y, c.direction_z);
  if (nearest) {
    // The table entry the broad phase read must be the model recorded for it; otherwise the
    // candidate stays not evaluated (and its ray incomplete where it matters).
    const uint64_t entry = LsnifQueryTableRef(lsnif_batch_address(pc.table_lo, pc.table_hi))
                               .model[lsnif_query_entry(c.instance_index, c.custom_index)];
    if (entry != lsnif_batch_address(pc.model_lo, pc.model_hi)) return;
    if (lsnif_query_t_key(c.t_enter) != lsnif_query_states().s[c.ray].first_t) {
      scratch.w[lsnif_query_rest_word() + start + atomicAdd(models.c[pc.bucket].rest_count, 1u)] = ci;
      return;
    }
  } else {
    LsnifWalkStart walk_start;
    const bool walks = lsnif_start_walk(m, origin, direction, c.tmin, LSNIF_INF, walk_start);
    if (walks && lsnif_query_t_key(walk_start.t_enter) > lsnif_query_states().s[c.ray].best_t) {
      candidates.c[ci].evaluated = 1u;
      atomicAdd(scratch.w[LSNIF_QUERY_STATUS_WORD + 5u], 1u);  // culled
      return;
    }
  }
  candidates.c[ci].evaluated = 1u;
  const uint points = lsnif_intersect_walk(m, origin, direction, c.tmin, c.tmax);
  if (points == 0u) return;  // a miss before the network (the candidate stays not accepted)
  lsnif_encode(m);
  lsnif_rows_store_narrow(rows, m, start + atomicAdd(models.c[pc.bucket].batch, 1u), ci, points);
}
#endif

#if defined(LSNIF_QUERY_ORDER)
// LSNIF_QUERY_ORDER: the round's slots of pc.bucket's batch by walk length (one workgroup).
void query_order() {
  LsnifModel m;
  LsnifBatchRows rows;
  uint start;
  lsnif_query_bucket(m, rows, start);
  uint first, batch;
  lsnif_query_round(start, first, batch);
  lsnif_rows_order_by_points(rows, m, first, batch);
}
#endif

#if defined(LSNIF_QUERY_MLP)
// LSNIF_QUERY_MLP: the MLP on slot `id` of pc.bucket's batch (with LSNIF_MLP_COOPMAT_NV: the
// workgroup's 64 slots together, lsnif_mlp_coopmat.glsl).
void query_mlp(uint id) {
  LsnifModel m;
  LsnifBatchRows rows;
  uint start;
  lsnif_query_bucket(m, rows, start);
  uint first, batch;
  lsnif_query_round(start, first, batch);
#if defined(LSNIF_MLP_COOPMAT_NV)
  LsnifBatchRows shifted = rows;
  shifted.base += first;  // slot s of the round is column first + s
  lsnif_rows_mlp_block(shifted, m, id - gl_LocalInvocationID.x, batch);
#else
  // The workgroup's columns of the order row two per invocation, by its first half of lanes: every
  // workgroup keeps its share of the work (a CPU driver runs contiguous ranges of them per thread).
  const uint pair = id - gl_LocalInvocationID.x + 2u * gl_LocalInvocationID.x;
  if (gl_LocalInvocationID.x >= LSNIF_BATCH_GROUP_SIZE / 2u || pair >= batch) return;
  lsnif_rows_mlp_ordered_pair(rows, m, first + pair, pair + 1u < batch);
#endif
}
#endif

#if defined(LSNIF_QUERY_DECODE)
// LSNIF_QUERY_DECODE: heads and acceptance of slot `id` of pc.bucket's batch to its candidate; an accepted
// candidate lowers its ray's best t.
void query_decode(uint id) {
  LsnifModel m;
  LsnifBatchRows rows;
  uint start;
  lsnif_query_bucket(m, rows, start);
  LsnifQueryCandidatesRef candidates = lsnif_query_candidates();
  uint first, batch;
  lsnif_query_round(start, first, batch);
  if (id >= batch) return;
  const uint ci = lsnif_rows_load_item(rows, first + id);
  const LsnifQueryCandidate c = candidates.c[ci];
  const vec3 o = vec3(c.origin_x, c.origin_y, c.origin_z), d = vec3(c.direction_x, c.direction_y, c.direction_z);
  LsnifHitInfo h = lsnif_rows_decode(rows, m, first + id, d, c.tmin, c.tmax, c.flags);
  lsnif_hit_uv(m, h, o, d);
  mat3 w2o;
  for (int k = 0; k < 9; ++k) w2o[k / 3][k % 3] = c.normal_matrix[k];
  const vec3 n = transpose(w2o) * h.normal;  // A^-T n
  candidates.c[ci].accepted = h.hit ? 1u : 0u;
  candidates.c[ci].t = h.t;
  candidates.c[ci].points = h.points;
  candidates.c[ci].occlusion_logit = h.occlusion_logit;
  candidates.c[ci].material = h.material;
  const vec3 nw = dot(n, n) > 0.0 ? normalize(n) : vec3(0.0);
  candidates.c[ci].normal_x = nw.x;
  candidates.c[ci].normal_y = nw.y;
  candidates.c[ci].normal_z = nw.z;
  candidates.c[ci].albedo_r = h.albedo.r;
  candidates.c[ci].albedo_g = h.albedo.g;
  candidates.c[ci].albedo_b = h.albedo.b;
  candidates.c[ci].front_face = lsnif_hit_kind(h.normal, d) == LSNIF_HIT_KIND_FRONT_FACING ? 1u : 0u;
  candidates.c[ci].surface = lsnif_pack_surface(h.surface_learned, h.metallic, h.roughness, h.ambient_occlusion);
  candidates.c[ci].emission_r = h.emission.r;
  candidates.c[ci].emission_g = h.emission.g;
  candidates.c[ci].emission_b = h.emission.b;
  candidates.c[ci].reports_uv = h.reports_uv ? 1u : 0u;
  candidates.c[ci].uv_u = h.uv.x;
  candidates.c[ci].uv_v = h.uv.y;
  if (h.hit) atomicMin(lsnif_query_states().s[c.ray].best_t, lsnif_query_t_key(h.t));
}
#endif

#if defined(LSNIF_QUERY_TIE)
// LSNIF_QUERY_TIE: candidate `id`, accepted at its ray's best t, lowers the ray's best instance; not
// evaluated, it lowers the ray's missing t (and is counted).
void query_tie(uint id) {
  if (id >= lsnif_query_kept()) return;
  LsnifQueryStatesRef states = lsnif_query_states();
  const LsnifQueryCandidate c = lsnif_query_candidates().c[id];
  if (c.evaluated == 0u) {
    atomicMin(states.s[c.ray].missing_t, lsnif_query_t_key(c.t_enter));
    atomicAdd(lsnif_query_scratch().w[LSNIF_QUERY_STATUS_WORD + 4u], 1u);
    return;
  }
  if (c.accepted != 0u && lsnif_query_t_key(c.t) == states.s[c.ray].best_t)
    atomicMin(states.s[c.ray].best_instance, c.instance_index);
}
#endif

#if defined(LSNIF_QUERY_RESOLVE_HITS)
// LSNIF_QUERY_RESOLVE_HITS: candidate `id`, when it wins its ray (best t, best instance, not behind an
// equal-t triangle of a lower instance), writes the ray's LSNIF result.
void query_resolve_hits(uint id) {
  if (id >= lsnif_query_kept()) return;
  const LsnifQueryCandidate c = lsnif_query_candidates().c[id];
  if (c.accepted == 0u) return;
  const LsnifQueryRayState st = lsnif_query_states().s[c.ray];
  if (lsnif_query_t_key(c.t) != st.best_t || c.instance_index != st.best_instance) return;
  if (st.triangle_t == st.best_t && st.triangle_instance < st.best_instance) return;  // the triangle wins
  LsnifQueryResult r;
  r.t = c.t;
  r.normal_x = c.normal_x;
  r.normal_y = c.normal_y;
  r.normal_z = c.normal_z;
  r.albedo_r = c.albedo_r;
  r.albedo_g = c.albedo_g;
  r.albedo_b = c.albedo_b;
  r.material = c.material;
  r.kind = LSNIF_QUERY_HIT_LSNIF;
  r.instance_index = c.instance_index;
  r.instance_custom_index = c.custom_index;
  r.primitive_index = 0u;
  r.geometry_index = 0u;
  r.barycentric_u = 0.0;
  r.barycentric_v = 0.0;
  r.front_face = c.front_face;
  r.surface = c.surface;
  r.emission_r = c.emission_r;
  r.emission_g = c.emission_g;
  r.emission_b = c.emission_b;
  r.reports_uv = c.reports_uv;
  r.uv_u = c.uv_u;
  r.uv_v = c.uv_v;
  r.reserved = 0u;
  lsnif_query_results().r[c.ray] = r;
}
#endif

#if defined(LSNIF_QUERY_RESOLVE_RAYS)
// LSNIF_QUERY_RESOLVE_RAYS: ray `id`, when a dropped or not evaluated candidate could have changed it,
// becomes LSNIF_QUERY_HIT_INCOMPLETE (and is counted).
void query_resolve_rays(uint id) {
  if (id >= pc.ray_count) return;
  const LsnifQueryRayState st = lsnif_query_states().s[id];
  if (st.missing_t == LSNIF_QUERY_INF_BITS) return;
  // A candidate dropped or not evaluated matters when it could hold a closer hit (t >= its
  // t_enter), or, for an any-hit ray, when no hit was found at all.
  const bool any_hit = (lsnif_query_flags(lsnif_query_ray(id)) & LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT) != 0u;
  const bool found = st.best_t != LSNIF_QUERY_INF_BITS;
  if (any_hit ? found : st.missing_t > st.best_t) return;
  lsnif_query_results().r[id] = lsnif_query_no_hit(LSNIF_QUERY_HIT_INCOMPLETE);
  atomicAdd(lsnif_query_scratch().w[LSNIF_QUERY_STATUS_WORD + 3u], 1u);
}
#endif

#if defined(LSNIF_QUERY_STATUS)
// LSNIF_QUERY_STATUS: invocation 0 writes the accumulated LsnifQueryStatus to the application's address
// (when it gave one).
void query_status(uint id) {
  if (id != 0u || (pc.status_lo == 0u && pc.status_hi == 0u)) return;
  LsnifScratchRef scratch = lsnif_query_scratch();
  LsnifQueryStatus s;
  s.candidates = scratch.w[LSNIF_QUERY_STATUS_WORD];
  s.capacity = scratch.w[LSNIF_QUERY_STATUS_WORD + 1u];
  s.dropped = scratch.w[LSNIF_QUERY_STATUS_WORD + 2u];
  s.incomplete_rays = scratch.w[LSNIF_QUERY_STATUS_WORD + 3u];
  s.unevaluated = scratch.w[LSNIF_QUERY_STATUS_WORD + 4u];
  s.culled = scratch.w[LSNIF_QUERY_STATUS_WORD + 5u];
  LsnifQueryStatusRef(lsnif_batch_address(pc.status_lo, pc.status_hi)).s = s;
}
#endif

// Runs the one stage this source was compiled for (LSNIF_QUERY_*).
void main() {
  const uint id = gl_GlobalInvocationID.x;
#if defined(LSNIF_QUERY_CLEAR)
  query_clear(id);
#elif defined(LSNIF_QUERY_BROAD)
  query_broad(id);
#elif defined(LSNIF_QUERY_SCAN)
  query_scan();
#elif defined(LSNIF_QUERY_RUN_ARGS)
  query_run_args(id);
#elif defined(LSNIF_QUERY_SCATTER)
  query_scatter(id);
#elif defined(LSNIF_QUERY_NARROW)
  query_narrow(id);
#elif defined(LSNIF_QUERY_BATCH_ARGS)
  query_batch_args(id);
#elif defined(LSNIF_QUERY_ORDER)
  query_order();
#elif defined(LSNIF_QUERY_MLP)
  query_mlp(id);
#elif defined(LSNIF_QUERY_DECODE)
  query_decode(id);
#elif defined(LSNIF_QUERY_TIE)
  query_tie(id);
#elif defined(LSNIF_QUERY_RESOLVE_HITS)
  query_resolve_hits(id);
#elif defined(LSNIF_QUERY_RESOLVE_RAYS)
  query_resolve_rays(id);
#elif defined(LSNIF_QUERY_STATUS)
  query_status(id);
#else
#error "compile with one of the LSNIF_QUERY_* stages"
#endif
}
