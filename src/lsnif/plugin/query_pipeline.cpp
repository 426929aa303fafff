// query_pipeline.cpp -- the batched path of the plugin (lsnifCreateQueryPipeline,
// lsnifCmdIntersectModelRays, lsnifCmdQuery): the compute stages of src/lsnif/shaders/lsnif_batch.comp and
// src/lsnif/shaders/lsnif_query.comp and the ray-tracing broad phase (src/lsnif/shaders/lsnif_query_broad.*),
// embedded as SPIR-V, pipeline layouts of push constants only (every buffer is a device address), and
// the recording of the stages with barriers between them (clear -> narrow phase -> MLP -> decode for
// one model; for the TLAS query the broad phase, the counting sort, the per-model stages as indirect
// dispatches and the resolve).
#include <algorithm>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "lsnif/plugin/context.h"
#include "lsnif/plugin/device_support.h"

namespace {

#include "lsnif_batch_clear_spirv.h"
#include "lsnif_batch_decode_spirv.h"
#include "lsnif_batch_mlp_coopmat_spirv.h"
#include "lsnif_batch_mlp_spirv.h"
#include "lsnif_batch_narrow_spirv.h"
#include "lsnif_batch_order_spirv.h"
#include "lsnif_query_batch_args_spirv.h"
#include "lsnif_query_run_args_spirv.h"
#include "lsnif_query_broad_candidates_rgen_spirv.h"
#include "lsnif_query_broad_rchit_spirv.h"
#include "lsnif_query_broad_rint_spirv.h"
#include "lsnif_query_broad_rmiss_spirv.h"
#include "lsnif_query_broad_spirv.h"
#include "lsnif_query_broad_triangles_rgen_spirv.h"
#include "lsnif_query_clear_spirv.h"
#include "lsnif_query_decode_spirv.h"
#include "lsnif_query_mlp_coopmat_spirv.h"
#include "lsnif_query_mlp_spirv.h"
#include "lsnif_query_narrow_spirv.h"
#include "lsnif_query_order_spirv.h"
#include "lsnif_query_resolve_hits_spirv.h"
#include "lsnif_query_resolve_rays_spirv.h"
#include "lsnif_query_scan_spirv.h"
#include "lsnif_query_scatter_spirv.h"
#include "lsnif_query_status_spirv.h"
#include "lsnif_query_tie_spirv.h"

}  // namespace

namespace lsnif::plugin {
namespace {

// A shader module of `bytes` of SPIR-V at `code` (the caller destroys it); `what` names it in an error.
Outcome create_module(LsnifContext_T& ctx, const uint32_t* code, size_t bytes, const char* what, VkShaderModule& out) {
  VkShaderModuleCreateInfo mi{};
  mi.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  mi.codeSize = bytes;
  mi.pCode = code;
  if (VkResult r = ctx.vk.vkCreateShaderModule(ctx.info.device, &mi, ctx.info.pAllocator, &out); r != VK_SUCCESS)
    return Outcome::fail(LSNIF_ERROR_VULKAN, "vkCreateShaderModule (%s) failed (VkResult %d)", what, static_cast<int>(r));
  name_object(ctx, VK_OBJECT_TYPE_SHADER_MODULE, out, std::string("lsnif query pipeline: ") + what);
  return Outcome::ok();
}

Outcome create_stage(LsnifContext_T& ctx, VkPipelineCache cache, VkPipelineLayout layout, const uint32_t* code, size_t bytes,
                     const char* stage, VkPipeline& out) {
  const VkAllocationCallbacks* cb = ctx.info.pAllocator;
  VkShaderModule module = VK_NULL_HANDLE;
  if (Outcome o = create_module(ctx, code, bytes, (std::string(stage) + " stage").c_str(), module); !o) return o;
  VkComputePipelineCreateInfo pi{};
  pi.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
  pi.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  pi.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  pi.stage.module = module;
  pi.stage.pName = "main";
  pi.layout = layout;
  const VkResult r = ctx.vk.vkCreateComputePipelines(ctx.info.device, cache, 1, &pi, cb, &out);
  ctx.vk.vkDestroyShaderModule(ctx.info.device, module, cb);
  if (r != VK_SUCCESS)
    return Outcome::fail(LSNIF_ERROR_VULKAN, "vkCreateComputePipelines (%s stage) failed (VkResult %d)", stage,
                         static_cast<int>(r));
  name_object(ctx, VK_OBJECT_TYPE_PIPELINE, out, std::string("lsnif query pipeline: ") + stage + " stage");
  return Outcome::ok();
}

// Scratch rows of a model (host_device.h): slots, walk (3 + H), input pairs x 2, output blocks x 8, order.
uint64_t scratch_rows(const LsnifModel_T& m) {
  return 1u + 3u + m.max_points + 2u * LSNIF_GPU_ROW_WORDS(m.input_dim) +
         LSNIF_GPU_ROW_BLOCK * LSNIF_GPU_ROW_BLOCKS(m.output_dim) + 1u;
}

// A stride near 0.618 x `groups`, coprime to it: workgroup w takes block (w x step) mod groups, a
// permutation that spreads the first blocks (those with work) over all workgroups.
uint32_t block_step(uint32_t groups) {
  if (groups <= 2) return 1;
  uint32_t step = uint32_t(0.6180339887 * double(groups)) | 1u;
  auto gcd = [](uint32_t a, uint32_t b) {
    while (b) {
      const uint32_t t = a % b;
      a = b;
      b = t;
    }
    return a;
  };
  while (gcd(step, groups) != 1) step += 2;
  return step;
}


// The shaders of the ray-tracing broad phase.
struct TraceRaysModules {
  VkShaderModule triangles = VK_NULL_HANDLE, candidates = VK_NULL_HANDLE, miss = VK_NULL_HANDLE,
                 closest_hit = VK_NULL_HANDLE, intersection = VK_NULL_HANDLE;
};

// The pipeline of one launch of the ray-tracing broad phase: its ray generation shader, the miss
// shader and, as its one hit group, the triangle closest-hit shader (`triangles`: a pipeline that
// skips AABBs) or the candidate intersection shader (else: a pipeline that skips triangles).
Outcome create_trace_pipeline(LsnifContext_T& ctx, VkPipelineCache cache, VkPipelineLayout layout,
                              const TraceRaysModules& m, bool triangles, VkPipeline& out) {
  VkPipelineShaderStageCreateInfo stages[3]{};
  const VkShaderStageFlagBits kinds[3] = {
      VK_SHADER_STAGE_RAYGEN_BIT_KHR, VK_SHADER_STAGE_MISS_BIT_KHR,
      triangles ? VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR : VK_SHADER_STAGE_INTERSECTION_BIT_KHR};
  const VkShaderModule modules[3] = {triangles ? m.triangles : m.candidates, m.miss,
                                     triangles ? m.closest_hit : m.intersection};
  for (int i = 0; i < 3; ++i) {
    stages[i].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stages[i].stage = kinds[i];
    stages[i].module = modules[i];
    stages[i].pName = "main";
  }
  VkRayTracingShaderGroupCreateInfoKHR groups[3]{};
  for (uint32_t i = 0; i < 3; ++i) {
    groups[i].sType = VK_STRUCTURE_TYPE_RAY_TRACING_SHADER_GROUP_CREATE_INFO_KHR;
    groups[i].type = VK_RAY_TRACING_SHADER_GROUP_TYPE_GENERAL_KHR;
    groups[i].generalShader = i;
    groups[i].closestHitShader = groups[i].anyHitShader = groups[i].intersectionShader = VK_SHADER_UNUSED_KHR;
  }
  groups[2].generalShader = VK_SHADER_UNUSED_KHR;
  if (triangles) {
    groups[2].type = VK_RAY_TRACING_SHADER_GROUP_TYPE_TRIANGLES_HIT_GROUP_KHR;
    groups[2].closestHitShader = 2;
  } else {
    groups[2].type = VK_RAY_TRACING_SHADER_GROUP_TYPE_PROCEDURAL_HIT_GROUP_KHR;
    groups[2].intersectionShader = 2;
  }
  VkRayTracingPipelineCreateInfoKHR pi{};
  pi.sType = VK_STRUCTURE_TYPE_RAY_TRACING_PIPELINE_CREATE_INFO_KHR;
  pi.flags = triangles ? VK_PIPELINE_CREATE_RAY_TRACING_SKIP_AABBS_BIT_KHR
                       : VK_PIPELINE_CREATE_RAY_TRACING_SKIP_TRIANGLES_BIT_KHR;
  pi.stageCount = 3;
  pi.pStages = stages;
  pi.groupCount = 3;
  pi.pGroups = groups;
  pi.maxPipelineRayRecursionDepth = 1;
  pi.layout = layout;
  const VkResult r = ctx.vk.vkCreateRayTracingPipelinesKHR(ctx.info.device, VK_NULL_HANDLE, cache, 1, &pi,
                                                           ctx.info.pAllocator, &out);
  if (r != VK_SUCCESS)
    return Outcome::fail(LSNIF_ERROR_VULKAN, "vkCreateRayTracingPipelinesKHR (%s broad phase) failed (VkResult %d)",
                         triangles ? "triangle" : "candidate", static_cast<int>(r));
  name_object(ctx, VK_OBJECT_TYPE_PIPELINE, out,
              std::string("lsnif query pipeline: ") + (triangles ? "triangle" : "candidate") + " broad phase");
  return Outcome::ok();
}

// The shader binding tables of both launches in one host-visible buffer (device-local where the
// device has such memory, as on GPUs with a resizable BAR; else host memory): per launch three
// regions (raygen, miss, hit) of one record each, every region at a multiple of
// shaderGroupBaseAlignment. The hit region has stride 0: whatever SBT offset the application gave
// an instance, the launch uses its one hit group.
Outcome create_shader_binding_tables(LsnifContext_T& ctx, LsnifQueryPipeline_T& p) {
  const VkPhysicalDeviceRayTracingPipelinePropertiesKHR& rt = ctx.ray_tracing;
  const VkDeviceSize handle = rt.shaderGroupHandleSize;
  const VkDeviceSize record = align_up(handle, rt.shaderGroupHandleAlignment);
  const VkDeviceSize slot = align_up(record, rt.shaderGroupBaseAlignment);
  const VkDeviceSize bytes = 6 * slot + rt.shaderGroupBaseAlignment;
  const char* name = "lsnif query pipeline: broad-phase shader binding tables";
  Outcome o = allocate(ctx, bytes, VK_BUFFER_USAGE_SHADER_BINDING_TABLE_BIT_KHR, Placement::DeviceDirect, nullptr, name,
                       p.sbt);
  if (!o)
    o = allocate(ctx, bytes, VK_BUFFER_USAGE_SHADER_BINDING_TABLE_BIT_KHR, Placement::HostWrite, nullptr, name, p.sbt);
  if (!o) return o.context("shader binding table");
  const VkDeviceAddress base = align_up(p.sbt.address, rt.shaderGroupBaseAlignment);
  void* mapped = nullptr;
  if (VkResult r = ctx.vk.vkMapMemory(ctx.info.device, p.sbt.memory, 0, VK_WHOLE_SIZE, 0, &mapped); r != VK_SUCCESS)
    return Outcome::fail(LSNIF_ERROR_VULKAN, "vkMapMemory (shader binding table) failed (VkResult %d)", static_cast<int>(r));
  std::vector<uint8_t> handles(size_t(3 * handle));
  VkDeviceSize offset = base - p.sbt.address;
  for (LsnifQueryPipeline_T::TraceRays* launch : {&p.broad_triangles, &p.broad_candidates}) {
    const VkResult r = ctx.vk.vkGetRayTracingShaderGroupHandlesKHR(ctx.info.device, launch->pipeline, 0, 3,
                                                                   handles.size(), handles.data());
    if (r != VK_SUCCESS) {
      ctx.vk.vkUnmapMemory(ctx.info.device, p.sbt.memory);
      return Outcome::fail(LSNIF_ERROR_VULKAN, "vkGetRayTracingShaderGroupHandlesKHR failed (VkResult %d)",
                           static_cast<int>(r));
    }
    VkStridedDeviceAddressRegionKHR* regions[3] = {&launch->raygen, &launch->miss, &launch->hit};
    for (int g = 0; g < 3; ++g) {
      std::memcpy(static_cast<uint8_t*>(mapped) + offset, handles.data() + g * handle, size_t(handle));
      *regions[g] = VkStridedDeviceAddressRegionKHR{p.sbt.address + offset, g == 2 ? 0 : record, record};
      offset += slot;
    }
    launch->callable = VkStridedDeviceAddressRegionKHR{};
  }
  ctx.vk.vkUnmapMemory(ctx.info.device, p.sbt.memory);
  return Outcome::ok();
}

// The ray-tracing broad phase of `p`: its layout, both launches' pipelines and their shader binding
// tables.
Outcome create_trace_rays_broad_phase(LsnifContext_T& ctx, VkPipelineCache cache, LsnifQueryPipeline_T& p) {
  const VkAllocationCallbacks* cb = ctx.info.pAllocator;
  VkPushConstantRange range{VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_MISS_BIT_KHR |
                                VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR | VK_SHADER_STAGE_INTERSECTION_BIT_KHR,
                            0, uint32_t(sizeof(LsnifQueryPushConstants))};
  VkPipelineLayoutCreateInfo li{};
  li.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  li.pushConstantRangeCount = 1;
  li.pPushConstantRanges = &range;
  if (VkResult r = ctx.vk.vkCreatePipelineLayout(ctx.info.device, &li, cb, &p.trace_layout); r != VK_SUCCESS)
    return Outcome::fail(LSNIF_ERROR_VULKAN, "vkCreatePipelineLayout (broad phase) failed (VkResult %d)",
                         static_cast<int>(r));
  name_object(ctx, VK_OBJECT_TYPE_PIPELINE_LAYOUT, p.trace_layout, "lsnif query pipeline: broad-phase layout");
  TraceRaysModules m;
  Outcome o = create_module(ctx, lsnif_query_broad_triangles_rgen_spirv, sizeof lsnif_query_broad_triangles_rgen_spirv,
                            "broad phase triangle raygen", m.triangles);
  if (o)
    o = create_module(ctx, lsnif_query_broad_candidates_rgen_spirv, sizeof lsnif_query_broad_candidates_rgen_spirv,
                      "broad phase candidate raygen", m.candidates);
  if (o) o = create_module(ctx, lsnif_query_broad_rmiss_spirv, sizeof lsnif_query_broad_rmiss_spirv, "broad phase miss", m.miss);
  if (o)
    o = create_module(ctx, lsnif_query_broad_rchit_spirv, sizeof lsnif_query_broad_rchit_spirv,
                      "broad phase closest hit", m.closest_hit);
  if (o)
    o = create_module(ctx, lsnif_query_broad_rint_spirv, sizeof lsnif_query_broad_rint_spirv,
                      "broad phase intersection", m.intersection);
  if (o) o = create_trace_pipeline(ctx, cache, p.trace_layout, m, true, p.broad_triangles.pipeline);
  if (o) o = create_trace_pipeline(ctx, cache, p.trace_layout, m, false, p.broad_candidates.pipeline);
  for (VkShaderModule module : {m.triangles, m.candidates, m.miss, m.closest_hit, m.intersection})
    if (module) ctx.vk.vkDestroyShaderModule(ctx.info.device, module, cb);
  if (o) o = create_shader_binding_tables(ctx, p);
  return o;
}

uint32_t stride_of(uint32_t rays) {
  return (rays + LSNIF_BATCH_GROUP_SIZE - 1) / LSNIF_BATCH_GROUP_SIZE * LSNIF_BATCH_GROUP_SIZE;
}

uint32_t groups_of(uint64_t invocations) {
  return uint32_t((invocations + LSNIF_BATCH_GROUP_SIZE - 1) / LSNIF_BATCH_GROUP_SIZE);
}

void split(VkDeviceAddress a, lsnif_uint& lo, lsnif_uint& hi) {
  lo = lsnif_uint(a & 0xffffffffu);
  hi = lsnif_uint(a >> 32);
}

// The barrier between two passes: shader writes of stage `src` before shader reads and writes of
// stage `dst`, and before the indirect dispatches' reads of their arguments.
void between_stages(const DeviceDispatch& vk, VkCommandBuffer cmd, VkPipelineStageFlags src, VkPipelineStageFlags dst,
                    bool indirect) {
  VkMemoryBarrier barrier{};
  barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
  barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
  barrier.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                          (indirect ? VkAccessFlags(VK_ACCESS_INDIRECT_COMMAND_READ_BIT) : VkAccessFlags(0));
  if (indirect) dst |= VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT;
  vk.vkCmdPipelineBarrier(cmd, src, dst, 0, 1, &barrier, 0, nullptr, 0, nullptr);
}

// The barrier between two compute passes.
void between_passes(const DeviceDispatch& vk, VkCommandBuffer cmd, bool indirect) {
  between_stages(vk, cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, indirect);
}

// The scratch of lsnifCmdQuery in words (host_device.h; the offsets lsnif_query.comp computes).
struct QueryLayout {
  uint32_t chunk_rays = 0, capacity = 0, stride = 0;
  uint64_t rows_word = 0, total_words = 0;
};
QueryLayout query_layout(const std::vector<const LsnifModel_T*>& models, uint32_t table_entries, uint32_t rays,
                         uint32_t per_ray) {
  QueryLayout l;
  l.chunk_rays = std::min(rays, LSNIF_QUERY_CHUNK_RAYS);
  l.capacity = per_ray * l.chunk_rays;
  l.stride = stride_of(l.capacity);
  uint64_t rows = 0;
  for (const LsnifModel_T* m : models)
    if (m) rows = std::max(rows, scratch_rows(*m));
  l.rows_word = LSNIF_BATCH_HEADER_WORDS + uint64_t(LSNIF_QUERY_MODEL_COUNTERS_WORDS) * table_entries +
                uint64_t(LSNIF_QUERY_RAY_STATE_WORDS) * l.chunk_rays +
                uint64_t(LSNIF_QUERY_CANDIDATE_WORDS) * l.capacity + 2 * uint64_t(l.stride);
  l.total_words = l.rows_word + rows * l.stride;
  return l;
}

}  // namespace

// Whether a broad phase can run: what it needs (`what`, e.g. "feature rayQuery") offered by the
// physical device and, where the context knows the enabled features, enabled.
Outcome check_broad_phase_feature(const LsnifContext_T& ctx, bool offered, bool not_enabled, const char* offer,
                                  const char* feature, const char* phase) {
  if (!offered)
    return Outcome::fail(LSNIF_ERROR_DEVICE_UNSUPPORTED, "device '%s' does not offer %s (the %s broad phase needs it)",
                         ctx.device_name.c_str(), offer, phase);
  if (not_enabled)
    return Outcome::fail(LSNIF_ERROR_DEVICE_UNSUPPORTED,
                         "the device '%s' was created without feature %s enabled (the context's pEnabledFeatures; "
                         "the %s broad phase needs %s)",
                         ctx.device_name.c_str(), feature, phase, offer);
  return Outcome::ok();
}

// The broad phase of a TLAS pipeline created with `flags`: the forced one, else the ray-query one
// (on lavapipe its broad phase took half the time of the ray-tracing one: docs/batched-queries.md),
// else the ray-tracing one; an error naming what each lacks when none can run.
Outcome choose_broad_phase(const LsnifContext_T& ctx, LsnifQueryPipelineCreateFlags flags, LsnifQueryBroadPhase& out) {
  const Outcome trace_rays =
      check_broad_phase_feature(ctx, ctx.primitive_culling_offered, ctx.primitive_culling_not_enabled,
                                "feature rayTraversalPrimitiveCulling", "rayTraversalPrimitiveCulling", "ray-tracing");
  const Outcome ray_query =
      check_broad_phase_feature(ctx, ctx.ray_query_offered, ctx.ray_query_not_enabled,
                                "extension VK_KHR_ray_query with feature rayQuery", "rayQuery", "ray-query");
  if (flags & LSNIF_QUERY_PIPELINE_CREATE_TRACE_RAYS_BROAD_PHASE_BIT) {
    out = LSNIF_QUERY_BROAD_PHASE_TRACE_RAYS;
    return trace_rays;
  }
  if (flags & LSNIF_QUERY_PIPELINE_CREATE_RAY_QUERY_BROAD_PHASE_BIT) {
    out = LSNIF_QUERY_BROAD_PHASE_RAY_QUERY;
    return ray_query;
  }
  out = ray_query ? LSNIF_QUERY_BROAD_PHASE_RAY_QUERY : LSNIF_QUERY_BROAD_PHASE_TRACE_RAYS;
  if (trace_rays || ray_query) return Outcome::ok();
  return Outcome::fail(LSNIF_ERROR_DEVICE_UNSUPPORTED,
                       "LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT: no broad phase can run: %s; %s",
                       trace_rays.message.c_str(), ray_query.message.c_str());
}

Outcome create_query_pipeline(LsnifContext_T& ctx, LsnifQueryPipelineCreateFlags flags, VkPipelineCache cache,
                              std::unique_ptr<LsnifQueryPipeline_T>& out) {
  const LsnifQueryPipelineCreateFlags broad_bits = LSNIF_QUERY_PIPELINE_CREATE_RAY_QUERY_BROAD_PHASE_BIT |
                                                   LSNIF_QUERY_PIPELINE_CREATE_TRACE_RAYS_BROAD_PHASE_BIT;
  const LsnifQueryPipelineCreateFlags coopmat_bit = LSNIF_QUERY_PIPELINE_CREATE_COOPERATIVE_MATRIX_MLP_BIT_NV;
  if (flags & ~(LsnifQueryPipelineCreateFlags(LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT) | broad_bits | coopmat_bit))
    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "pCreateInfo->flags: unknown flags 0x%x", flags);
  const bool coopmat = (flags & coopmat_bit) != 0;
  if (coopmat && !ctx.coopmat_mlp_missing.empty()) {
    std::string list;
    for (const std::string& m : ctx.coopmat_mlp_missing) list += (list.empty() ? "" : ", ") + m;
    return Outcome::fail(LSNIF_ERROR_DEVICE_UNSUPPORTED,
                         "LSNIF_QUERY_PIPELINE_CREATE_COOPERATIVE_MATRIX_MLP_BIT_NV: device '%s' lacks: %s",
                         ctx.device_name.c_str(), list.c_str());
  }
  const bool tlas = (flags & LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT) != 0;
  if ((flags & broad_bits) == broad_bits)
    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                         "pCreateInfo->flags: LSNIF_QUERY_PIPELINE_CREATE_RAY_QUERY_BROAD_PHASE_BIT and "
                         "LSNIF_QUERY_PIPELINE_CREATE_TRACE_RAYS_BROAD_PHASE_BIT exclude each other");
  if ((flags & broad_bits) && !tlas)
    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                         "pCreateInfo->flags: a broad-phase bit without LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT");
  LsnifQueryBroadPhase broad_phase = LSNIF_QUERY_BROAD_PHASE_NONE;
  if (tlas) {
    if (Outcome o = choose_broad_phase(ctx, flags, broad_phase); !o) return o;
  }
  auto p = std::make_unique<LsnifQueryPipeline_T>();
  const VkAllocationCallbacks* cb = ctx.info.pAllocator;
  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0,
                            uint32_t(std::max(sizeof(LsnifBatchPushConstants), sizeof(LsnifQueryPushConstants)))};
  VkPipelineLayoutCreateInfo li{};
  li.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  li.pushConstantRangeCount = 1;
  li.pPushConstantRanges = &range;
  if (VkResult r = ctx.vk.vkCreatePipelineLayout(ctx.info.device, &li, cb, &p->layout); r != VK_SUCCESS)
    return Outcome::fail(LSNIF_ERROR_VULKAN, "vkCreatePipelineLayout failed (VkResult %d)", static_cast<int>(r));
  name_object(ctx, VK_OBJECT_TYPE_PIPELINE_LAYOUT, p->layout, "lsnif query pipeline: layout");
  Outcome o = create_stage(ctx, cache, p->layout, lsnif_batch_clear_spirv, sizeof lsnif_batch_clear_spirv, "clear", p->clear);
  if (o) o = create_stage(ctx, cache, p->layout, lsnif_batch_narrow_spirv, sizeof lsnif_batch_narrow_spirv, "narrow", p->narrow);
  if (o && coopmat)
    o = create_stage(ctx, cache, p->layout, lsnif_batch_mlp_coopmat_spirv, sizeof lsnif_batch_mlp_coopmat_spirv,
                     "MLP (cooperative matrix)", p->mlp);
  else if (o)
    o = create_stage(ctx, cache, p->layout, lsnif_batch_mlp_spirv, sizeof lsnif_batch_mlp_spirv, "MLP", p->mlp);
  if (o && !coopmat)
    o = create_stage(ctx, cache, p->layout, lsnif_batch_order_spirv, sizeof lsnif_batch_order_spirv, "order", p->order);
  if (o) o = create_stage(ctx, cache, p->layout, lsnif_batch_decode_spirv, sizeof lsnif_batch_decode_spirv, "decode", p->decode);
  if (tlas) {
    const struct {
      const uint32_t* code;
      size_t bytes;
      const char* name;
      VkPipeline* out;
    } stages[] = {
        {lsnif_query_clear_spirv, sizeof lsnif_query_clear_spirv, "query clear", &p->tlas.clear},
        {lsnif_query_broad_spirv, sizeof lsnif_query_broad_spirv, "query broad phase", &p->tlas.broad},
        {lsnif_query_scan_spirv, sizeof lsnif_query_scan_spirv, "query scan", &p->tlas.scan},
        {lsnif_query_scatter_spirv, sizeof lsnif_query_scatter_spirv, "query scatter", &p->tlas.scatter},
        {lsnif_query_run_args_spirv, sizeof lsnif_query_run_args_spirv, "query run args", &p->tlas.run_args},
        {lsnif_query_narrow_spirv, sizeof lsnif_query_narrow_spirv, "query narrow", &p->tlas.narrow},
        {lsnif_query_batch_args_spirv, sizeof lsnif_query_batch_args_spirv, "query batch args", &p->tlas.batch_args},
        {lsnif_query_order_spirv, sizeof lsnif_query_order_spirv, "query order", &p->tlas.order},
        {coopmat ? lsnif_query_mlp_coopmat_spirv : lsnif_query_mlp_spirv,
         coopmat ? sizeof lsnif_query_mlp_coopmat_spirv : sizeof lsnif_query_mlp_spirv, "query MLP", &p->tlas.mlp},
        {lsnif_query_decode_spirv, sizeof lsnif_query_decode_spirv, "query decode", &p->tlas.decode},
        {lsnif_query_tie_spirv, sizeof lsnif_query_tie_spirv, "query tie", &p->tlas.tie},
        {lsnif_query_resolve_hits_spirv, sizeof lsnif_query_resolve_hits_spirv, "query resolve hits",
         &p->tlas.resolve_hits},
        {lsnif_query_resolve_rays_spirv, sizeof lsnif_query_resolve_rays_spirv, "query resolve rays",
         &p->tlas.resolve_rays},
        {lsnif_query_status_spirv, sizeof lsnif_query_status_spirv, "query status", &p->tlas.status},
    };
    for (const auto& st : stages) {
      const bool ray_query_stage = st.out == &p->tlas.broad;
      if (ray_query_stage && broad_phase != LSNIF_QUERY_BROAD_PHASE_RAY_QUERY) continue;
      if (st.out == &p->tlas.order && coopmat) continue;  // the cooperative-matrix kernel takes slots in place
      if (o) o = create_stage(ctx, cache, p->layout, st.code, st.bytes, st.name, *st.out);
    }
    if (o && broad_phase == LSNIF_QUERY_BROAD_PHASE_TRACE_RAYS) o = create_trace_rays_broad_phase(ctx, cache, *p);
    p->broad_phase = broad_phase;
  }
  p->coopmat_mlp = coopmat;
  if (!o) {
    destroy_query_pipeline(ctx, *p);
    return o;
  }
  out = std::move(p);
  return Outcome::ok();
}

void destroy_query_pipeline(LsnifContext_T& ctx, LsnifQueryPipeline_T& p) {
  const VkAllocationCallbacks* cb = ctx.info.pAllocator;
  LsnifQueryPipeline_T::Tlas& t = p.tlas;
  for (VkPipeline* stage : {&p.clear, &p.narrow, &p.order, &p.mlp, &p.decode, &t.clear, &t.broad, &t.scan, &t.scatter,
                            &t.run_args, &t.narrow, &t.batch_args, &t.order, &t.mlp, &t.decode, &t.tie, &t.resolve_hits,
                            &t.resolve_rays, &t.status}) {
    if (*stage) ctx.vk.vkDestroyPipeline(ctx.info.device, *stage, cb);
    *stage = VK_NULL_HANDLE;
  }
  for (VkPipeline* launch : {&p.broad_triangles.pipeline, &p.broad_candidates.pipeline}) {
    if (*launch) ctx.vk.vkDestroyPipeline(ctx.info.device, *launch, cb);
    *launch = VK_NULL_HANDLE;
  }
  for (VkPipelineLayout* layout : {&p.layout, &p.trace_layout}) {
    if (*layout) ctx.vk.vkDestroyPipelineLayout(ctx.info.device, *layout, cb);
    *layout = VK_NULL_HANDLE;
  }
  release(ctx, p.sbt);
}

VkDeviceSize intersect_scratch_bytes(const LsnifModel_T& m, uint32_t rays) {
  rays = std::min(rays, LSNIF_BATCH_CHUNK_RAYS);  // larger batches reuse it chunk after chunk
  return 4u * (LSNIF_BATCH_HEADER_WORDS + scratch_rows(m) * uint64_t(stride_of(rays)));
}

void record_intersect_model_rays(LsnifContext_T& ctx, const LsnifQueryPipeline_T& p, VkCommandBuffer cmd,
                                 const LsnifModel_T& m, const LsnifIntersectModelRaysInfo& info) {
  const DeviceDispatch& vk = ctx.vk;
  auto between_stages = [&]() { between_passes(vk, cmd, false); };
  auto timestamp = [&](uint32_t k) {
    if (info.timestampPool)
      vk.vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, info.timestampPool, info.firstTimestamp + k);
  };
  LsnifBatchPushConstants pc{};
  auto run = [&](VkPipeline stage, uint32_t group_count) {
    vk.vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, stage);
    vk.vkCmdPushConstants(cmd, p.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof pc, &pc);
    vk.vkCmdDispatch(cmd, group_count, 1, 1);
  };

  // The stages run once per chunk of at most LSNIF_BATCH_CHUNK_RAYS rays, every chunk in the same
  // scratch (the barrier after a chunk's decode orders its reads before the next chunk's writes).
  // The first and last timestamps bracket all chunks, the middle two the first chunk's stages.
  split(m.block.address, pc.model_lo, pc.model_hi);
  split(info.scratch, pc.scratch_lo, pc.scratch_hi);
  timestamp(0);
  for (uint32_t base = 0; base < info.rayCount; base += LSNIF_BATCH_CHUNK_RAYS) {
    const uint32_t n = std::min(info.rayCount - base, LSNIF_BATCH_CHUNK_RAYS);
    split(info.rays + VkDeviceAddress(base) * sizeof(LsnifQueryRay), pc.rays_lo, pc.rays_hi);
    split(info.hits + VkDeviceAddress(base) * sizeof(LsnifQueryHit), pc.hits_lo, pc.hits_hi);
    pc.ray_count = n;
    pc.stride = stride_of(n);
    const uint32_t groups = pc.stride / LSNIF_BATCH_GROUP_SIZE;
    pc.block_step = block_step(groups);
    if (base > 0) between_stages();
    run(p.clear, 1);
    between_stages();
    run(p.narrow, groups);
    between_stages();
    if (base == 0) timestamp(1);
    if (p.order) {  // the portable MLP kernel takes the slots by walk length
      run(p.order, 1);
      between_stages();
    }
    run(p.mlp, groups);
    between_stages();
    if (base == 0) timestamp(2);
    run(p.decode, groups);
  }
  timestamp(3);
}

VkDeviceSize query_scratch_bytes(const std::vector<const LsnifModel_T*>& models, uint32_t table_entries, uint32_t rays,
                                 uint32_t per_ray) {
  return 4u * query_layout(models, table_entries, rays, per_ray).total_words;
}

void record_query_timestamps(LsnifContext_T& ctx, VkCommandBuffer cmd, const LsnifQueryTimestampsInfo& timestamps) {
  for (uint32_t k = 0; k < LSNIF_QUERY_TIMESTAMP_COUNT; ++k)
    ctx.vk.vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, timestamps.timestampPool,
                               timestamps.firstQuery + k);
}

void record_query(LsnifContext_T& ctx, const LsnifQueryPipeline_T& p, VkCommandBuffer cmd,
                  const std::vector<const LsnifModel_T*>& models, const LsnifQueryInfo& info,
                  const LsnifQueryTimestampsInfo* timestamps, const LsnifQueryModelIndexInfo* model_index) {
  const DeviceDispatch& vk = ctx.vk;
  // Stage timestamp k (1 .. LSNIF_QUERY_TIMESTAMPS_PER_CHUNK) of the chunk starting at ray `base`
  // (timestamp 0, the start, with k = 0 and base = 0).
  auto timestamp = [&](uint32_t k, uint32_t base) {
    if (timestamps)
      vk.vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, timestamps->timestampPool,
                             timestamps->firstQuery + LSNIF_QUERY_TIMESTAMPS_PER_CHUNK * (base / LSNIF_QUERY_CHUNK_RAYS) + k);
  };
  const LsnifQueryPipeline_T::Tlas& st = p.tlas;
  const QueryLayout layout = query_layout(models, info.modelCount, info.rayCount, info.candidatesPerRay);
  VkBufferDeviceAddressInfo ai{};
  ai.sType = VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO;
  ai.buffer = info.scratchBuffer;
  const VkDeviceAddress scratch = vk.vkGetBufferDeviceAddress(ctx.info.device, &ai) + info.scratchOffset;

  LsnifQueryPushConstants pc{};
  split(info.tlas, pc.tlas_lo, pc.tlas_hi);
  split(info.modelTable, pc.table_lo, pc.table_hi);
  split(scratch, pc.scratch_lo, pc.scratch_hi);
  split(info.status, pc.status_lo, pc.status_hi);
  pc.model_count = info.modelCount;
  pc.capacity = layout.capacity;
  pc.stride = layout.stride;
  pc.cull_mask = info.cullMask;
  if (model_index) {
    pc.model_index = model_index->modelIndex == LSNIF_QUERY_MODEL_INDEX_INSTANCE_INDEX
                         ? LSNIF_QUERY_MODEL_INDEX_BY_INSTANCE_INDEX
                         : LSNIF_QUERY_MODEL_INDEX_BY_CUSTOM_INDEX;
    pc.model_index_base = model_index->customIndexBase;
  }
  auto bind = [&](VkPipeline stage) {
    vk.vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, stage);
    vk.vkCmdPushConstants(cmd, p.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof pc, &pc);
  };
  auto run = [&](VkPipeline stage, uint32_t group_count) {
    bind(stage);
    vk.vkCmdDispatch(cmd, group_count, 1, 1);
  };
  // One launch of the ray-tracing broad phase over the chunk's `rays` rays.
  constexpr VkPipelineStageFlags kTraceStage = VK_PIPELINE_STAGE_RAY_TRACING_SHADER_BIT_KHR;
  auto trace = [&](const LsnifQueryPipeline_T::TraceRays& launch, uint32_t rays) {
    vk.vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR, launch.pipeline);
    vk.vkCmdPushConstants(cmd, p.trace_layout,
                          VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_MISS_BIT_KHR |
                              VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR | VK_SHADER_STAGE_INTERSECTION_BIT_KHR,
                          0, sizeof pc, &pc);
    vk.vkCmdTraceRaysKHR(cmd, &launch.raygen, &launch.miss, &launch.hit, &launch.callable, rays, 1, 1);
  };
  // An indirect dispatch whose VkDispatchIndirectCommand is at scratch word `word`.
  auto run_indirect = [&](VkPipeline stage, uint64_t word) {
    bind(stage);
    vk.vkCmdDispatchIndirect(cmd, info.scratchBuffer, info.scratchOffset + 4u * word);
  };
  const uint64_t counters_words = LSNIF_QUERY_MODEL_COUNTERS_WORDS;
  auto counters_word = [&](uint32_t b) { return LSNIF_BATCH_HEADER_WORDS + counters_words * b; };
  const uint64_t narrow_args = offsetof(LsnifQueryModelCounters, narrow_groups_x) / 4;
  const uint64_t batch_args = offsetof(LsnifQueryModelCounters, batch_groups_x) / 4;
  // The runs of consecutive table entries of one model (holes have no candidates): the per-model
  // stages run once per run, over the sorted candidates of its entries (contiguous: the counting sort
  // orders them by entry), so that many instances of a model cost one batch, not one per instance.
  std::vector<std::pair<uint32_t, uint32_t>> runs;  // first and last entry
  for (uint32_t b = 0; b < info.modelCount; ++b) {
    if (!models[b]) continue;
    if (!runs.empty() && runs.back().second + 1 == b && models[runs.back().first] == models[b])
      runs.back().second = b;
    else
      runs.emplace_back(b, b);
  }
  // `stage` once per run, its dispatch the VkDispatchIndirectCommand at `args` of the run's first
  // entry's counters, or one workgroup without `args`.
  auto per_model = [&](VkPipeline stage, std::optional<uint64_t> args) {
    for (const auto& [first, last] : runs) {
      pc.bucket = first;
      pc.bucket_last = last;
      split(models[first]->block.address, pc.model_lo, pc.model_hi);
      if (args)
        run_indirect(stage, counters_word(first) + *args);
      else
        run(stage, 1);
    }
  };

  // The stages run once per chunk of at most LSNIF_QUERY_CHUNK_RAYS rays, every chunk in the same
  // scratch; the status accumulators start at 0 with the first chunk and are written after the last.
  // Timestamp 0 precedes every chunk, each chunk writes its five (the last one's fifth after the status).
  timestamp(0, 0);
  for (uint32_t base = 0; base < info.rayCount; base += LSNIF_QUERY_CHUNK_RAYS) {
    const uint32_t n = std::min(info.rayCount - base, LSNIF_QUERY_CHUNK_RAYS);
    split(info.rays + VkDeviceAddress(base) * sizeof(LsnifQueryRay), pc.rays_lo, pc.rays_hi);
    split(info.results + VkDeviceAddress(base) * sizeof(LsnifQueryResult), pc.results_lo, pc.results_hi);
    pc.ray_count = n;
    pc.first_chunk = base == 0 ? 1u : 0u;
    run(st.clear, groups_of(LSNIF_BATCH_HEADER_WORDS + counters_words * info.modelCount));
    if (p.broad_phase == LSNIF_QUERY_BROAD_PHASE_TRACE_RAYS) {
      between_stages(vk, cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, kTraceStage, false);
      trace(p.broad_triangles, n);
      between_stages(vk, cmd, kTraceStage, kTraceStage, false);
      trace(p.broad_candidates, n);
      between_stages(vk, cmd, kTraceStage, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, false);
    } else {
      between_passes(vk, cmd, false);
      run(st.broad, groups_of(n));
      between_passes(vk, cmd, false);
    }
    timestamp(1, base);
    run(st.scan, 1);
    between_passes(vk, cmd, false);
    per_model(st.run_args, std::nullopt);
    between_passes(vk, cmd, true);
    run_indirect(st.scatter, LSNIF_QUERY_SCATTER_ARGS_WORD);
    between_passes(vk, cmd, false);
    timestamp(2, base);
    // The rounds (lsnif_query.comp): the candidates nearest their ray, then those that can still win.
    for (uint32_t round = 0; round < LSNIF_QUERY_ROUNDS; ++round) {
      pc.query_round = round == 0 ? LSNIF_QUERY_ROUND_NEAREST : LSNIF_QUERY_ROUND_REST;
      per_model(st.narrow, narrow_args);
      between_passes(vk, cmd, false);
      timestamp(3 + 3 * round, base);
      run(st.batch_args, groups_of(info.modelCount));
      between_passes(vk, cmd, true);
      if (st.order) {  // the portable MLP kernel takes the slots by walk length
        per_model(st.order, std::nullopt);
        between_passes(vk, cmd, false);
      }
      per_model(st.mlp, batch_args);
      between_passes(vk, cmd, false);
      timestamp(4 + 3 * round, base);
      per_model(st.decode, batch_args);
      between_passes(vk, cmd, false);
      if (round + 1 < LSNIF_QUERY_ROUNDS) timestamp(5 + 3 * round, base);
    }
    run_indirect(st.tie, LSNIF_QUERY_SCATTER_ARGS_WORD);
    between_passes(vk, cmd, false);
    run_indirect(st.resolve_hits, LSNIF_QUERY_SCATTER_ARGS_WORD);
    between_passes(vk, cmd, false);
    run(st.resolve_rays, groups_of(n));
    if (base + n < info.rayCount) {  // the next chunk reuses the scratch
      between_passes(vk, cmd, true);
      timestamp(LSNIF_QUERY_TIMESTAMPS_PER_CHUNK, base);
    }
  }
  between_passes(vk, cmd, false);
  run(st.status, 1);
  timestamp(LSNIF_QUERY_TIMESTAMPS_PER_CHUNK,
            (LSNIF_QUERY_CHUNK_COUNT(info.rayCount) - 1) * LSNIF_QUERY_CHUNK_RAYS);  // the last chunk's base
}

}  // namespace lsnif::plugin
