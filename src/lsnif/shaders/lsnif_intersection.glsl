// lsnif_intersection.glsl -- the body of the LSNIF intersection shader (main()), for an application
// that builds the shader for its own layout. lsnif.rint is this file with the default layout, and
// the library's embedded SPIR-V (lsnifGetIntersectionShaderSpirv) is lsnif.rint compiled with and
// without LSNIF_MODEL_FROM_SHADER_RECORD. An application's own intersection shader is
//   #version 460
//   #extension GL_EXT_ray_tracing : require
//   #extension GL_GOOGLE_include_directive : require
//   #define ...                      // the macros below, or -D on the glslangValidator command line
//   #include "lsnif/shaders/lsnif_intersection.glsl"
// compiled with `glslangValidator --target-env vulkan1.2 -V -I<include dir of the package>`
// (lsnif_GLSL_INCLUDE_DIR of the CMake package). Its hit group's closest-hit shader decodes the hit
// with lsnif/lsnif_hit.glsl as with the library's shader.
//
// How the shader finds the instance's model: one of
//   (default)                        a model table reached through push constants: the 16 bytes
//                                    {uint64 table address, uint entry count} at byte
//                                    LSNIF_MODEL_TABLE_PUSH_OFFSET of the push constant range
//                                    (default 0, a multiple of 8; the pipeline layout's range for
//                                    VK_SHADER_STAGE_INTERSECTION_BIT_KHR must cover those bytes)
//   LSNIF_MODEL_TABLE_BINDING        a model table in a storage buffer at that binding of
//                                    descriptor set LSNIF_MODEL_TABLE_SET (default 0): the buffer
//                                    is the table (uint64 entries), its entry count the buffer's
//   LSNIF_MODEL_FROM_SHADER_RECORD   the hit group's shader record: the model's block address
//                                    (uint64) at byte LSNIF_SHADER_RECORD_OFFSET (default 0, a
//                                    multiple of 8) after the group handle
//   LSNIF_MODEL_ADDRESS_FUNCTION     a function the application defines before the include,
//                                    `uint64_t NAME()`, returning the block address (0: no model)
// A table (push constants or storage buffer) is what lsnifWriteModelTable writes, indexed by
// LSNIF_MODEL_INDEX: by default uint(gl_InstanceCustomIndexEXT) - LSNIF_MODEL_INDEX_BASE (base
// default 0u), so that an application whose custom indices number its own objects can place the
// LSNIF entries at a base, or define LSNIF_MODEL_INDEX as any uint expression of the shader's
// built-ins (e.g. uint(gl_InstanceID), the TLAS instance index, which leaves the custom index
// entirely to the application).
//
// Broken conventions are misses, never faults: a table address of 0, an index at or past the
// table's entry count (an index below the base wraps around to a huge one), an entry or address of
// 0, or a block whose header is not this layout's (LSNIF_GPU_MAGIC, LSNIF_GPU_VERSION).
//
// What the shader reports: lsnif_intersect (walk with tmax = inf; accepted when occlusion >= 0.5,
// gl_RayTminEXT <= t <= gl_RayTmaxEXT and the facing of the predicted normal is not culled by
// gl_IncomingRayFlagsEXT), the hit kind LSNIF_HIT_KIND_FRONT_FACING or LSNIF_HIT_KIND_BACK_FACING
// (host_device.h), and LsnifHitAttributes (lsnif_hit.glsl). The object-space ray parameter equals the
// world one (affine instance transform).
#ifndef LSNIF_INTERSECTION_GLSL
#define LSNIF_INTERSECTION_GLSL

#include "lsnif/shaders/lsnif_intersect.glsl"
#include "lsnif/lsnif_hit.glsl"

#if defined(LSNIF_MODEL_FROM_SHADER_RECORD) && defined(LSNIF_MODEL_TABLE_BINDING)
#error "lsnif_intersection.glsl: define at most one of LSNIF_MODEL_FROM_SHADER_RECORD, LSNIF_MODEL_TABLE_BINDING, LSNIF_MODEL_ADDRESS_FUNCTION"
#endif
#if defined(LSNIF_MODEL_ADDRESS_FUNCTION) && (defined(LSNIF_MODEL_FROM_SHADER_RECORD) || defined(LSNIF_MODEL_TABLE_BINDING))
#error "lsnif_intersection.glsl: define at most one of LSNIF_MODEL_FROM_SHADER_RECORD, LSNIF_MODEL_TABLE_BINDING, LSNIF_MODEL_ADDRESS_FUNCTION"
#endif

#ifndef LSNIF_MODEL_INDEX_BASE
#define LSNIF_MODEL_INDEX_BASE 0u
#endif
#ifndef LSNIF_MODEL_INDEX
#define LSNIF_MODEL_INDEX (uint(gl_InstanceCustomIndexEXT) - (LSNIF_MODEL_INDEX_BASE))
#endif

#if defined(LSNIF_MODEL_ADDRESS_FUNCTION)
// The application's function, defined before this file.
uint64_t lsnif_model_address() { return LSNIF_MODEL_ADDRESS_FUNCTION(); }

#elif defined(LSNIF_MODEL_FROM_SHADER_RECORD)
#ifndef LSNIF_SHADER_RECORD_OFFSET
#define LSNIF_SHADER_RECORD_OFFSET 0
#endif
layout(shaderRecordEXT, std430) buffer LsnifShaderRecord {
  layout(offset = LSNIF_SHADER_RECORD_OFFSET) uint64_t model;
} lsnif_record;
uint64_t lsnif_model_address() { return lsnif_record.model; }

#elif defined(LSNIF_MODEL_TABLE_BINDING)
#ifndef LSNIF_MODEL_TABLE_SET
#define LSNIF_MODEL_TABLE_SET 0
#endif
layout(set = LSNIF_MODEL_TABLE_SET, binding = LSNIF_MODEL_TABLE_BINDING, std430) readonly buffer LsnifModelTable {
  uint64_t model[];
} lsnif_model_table;
uint64_t lsnif_model_address() {
  const uint index = LSNIF_MODEL_INDEX;
  return index < uint(lsnif_model_table.model.length()) ? lsnif_model_table.model[index] : 0ul;
}

#else
#ifndef LSNIF_MODEL_TABLE_PUSH_OFFSET
#define LSNIF_MODEL_TABLE_PUSH_OFFSET 0
#endif
layout(buffer_reference, std430, buffer_reference_align = 8) readonly buffer LsnifModelTableRef {
  uint64_t model[];
};
layout(push_constant) uniform LsnifRtPush {
  layout(offset = LSNIF_MODEL_TABLE_PUSH_OFFSET) uint64_t model_table;
  uint model_count;
} lsnif_rt_push;
uint64_t lsnif_model_address() {
  const uint index = LSNIF_MODEL_INDEX;
  if (lsnif_rt_push.model_table == 0ul || index >= lsnif_rt_push.model_count) return 0ul;
  return LsnifModelTableRef(lsnif_rt_push.model_table).model[index];
}
#endif

hitAttributeEXT LsnifHitAttributes lsnif_attributes;

void main() {
  const uint64_t address = lsnif_model_address();
  if (address == 0ul || !lsnif_model_layout_matches(address)) return;
  LsnifModel m = lsnif_load_model(address);
  const LsnifHitInfo h = lsnif_intersect(m, gl_ObjectRayOriginEXT, gl_ObjectRayDirectionEXT, gl_RayTminEXT,
                                         gl_RayTmaxEXT, gl_IncomingRayFlagsEXT);
  if (!h.hit) return;
  if (h.reports_uv)
    lsnif_attributes = lsnif_pack_uv_hit(h.normal, h.material, h.points, h.uv, h.occlusion_logit,
                                         lsnif_leaving_distance(m));
  else
    lsnif_attributes = lsnif_pack_hit(h.normal, h.albedo, h.material, h.points,
                                      lsnif_pack_surface(h.surface_learned, h.metallic, h.roughness, h.ambient_occlusion),
                                      h.emission, h.occlusion_logit, lsnif_leaving_distance(m));
  reportIntersectionEXT(h.t, lsnif_hit_kind(h.normal, gl_ObjectRayDirectionEXT));
}

#endif
