// query_pipeline.cpp -- the batched path of the plugin (lsnifCreateQueryPipeline,
// lsnifCmdIntersectModelRays): the four compute stages of shaders/lsnif_batch.comp, embedded as
// SPIR-V, one pipeline layout (push constants only: every buffer is a device address), and the
// recording of clear -> narrow phase -> MLP -> decode with compute-to-compute barriers.
#include <algorithm>

#include "context.h"

namespace {

#include "lsnif_batch_clear_spirv.h"
#include "lsnif_batch_decode_spirv.h"
#include "lsnif_batch_mlp_spirv.h"
#include "lsnif_batch_narrow_spirv.h"

}  // namespace

namespace lsnif::plugin {
namespace {

Outcome create_stage(LsnifContext_T& ctx, VkPipelineCache cache, VkPipelineLayout layout, const uint32_t* code, size_t bytes,
                     const char* stage, VkPipeline& out) {
  const VkAllocationCallbacks* cb = ctx.info.pAllocator;
  VkShaderModuleCreateInfo mi{};
  mi.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  mi.codeSize = bytes;
  mi.pCode = code;
  VkShaderModule module = VK_NULL_HANDLE;
  if (VkResult r = ctx.vk.vkCreateShaderModule(ctx.info.device, &mi, cb, &module); r != VK_SUCCESS)
    return Outcome::fail(LSNIF_ERROR_VULKAN, "vkCreateShaderModule (%s stage) failed (VkResult %d)", stage,
                         static_cast<int>(r));
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
  return Outcome::ok();
}

// Scratch rows of a model (host_device.h): slots, walk (3 + H), input pairs x 2, output blocks x 8.
uint64_t scratch_rows(const LsnifModel_T& m) {
  return 1u + 3u + m.max_points + 2u * LSNIF_GPU_ROW_WORDS(m.input_dim) +
         LSNIF_GPU_ROW_BLOCK * LSNIF_GPU_ROW_BLOCKS(m.output_dim);
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

uint32_t stride_of(uint32_t rays) {
  return (rays + LSNIF_BATCH_GROUP_SIZE - 1) / LSNIF_BATCH_GROUP_SIZE * LSNIF_BATCH_GROUP_SIZE;
}

}  // namespace

Outcome create_query_pipeline(LsnifContext_T& ctx, VkPipelineCache cache, std::unique_ptr<LsnifQueryPipeline_T>& out) {
  auto p = std::make_unique<LsnifQueryPipeline_T>();
  const VkAllocationCallbacks* cb = ctx.info.pAllocator;
  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(LsnifBatchPushConstants)};
  VkPipelineLayoutCreateInfo li{};
  li.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  li.pushConstantRangeCount = 1;
  li.pPushConstantRanges = &range;
  if (VkResult r = ctx.vk.vkCreatePipelineLayout(ctx.info.device, &li, cb, &p->layout); r != VK_SUCCESS)
    return Outcome::fail(LSNIF_ERROR_VULKAN, "vkCreatePipelineLayout failed (VkResult %d)", static_cast<int>(r));
  Outcome o = create_stage(ctx, cache, p->layout, lsnif_batch_clear_spirv, sizeof lsnif_batch_clear_spirv, "clear", p->clear);
  if (o) o = create_stage(ctx, cache, p->layout, lsnif_batch_narrow_spirv, sizeof lsnif_batch_narrow_spirv, "narrow", p->narrow);
  if (o) o = create_stage(ctx, cache, p->layout, lsnif_batch_mlp_spirv, sizeof lsnif_batch_mlp_spirv, "MLP", p->mlp);
  if (o) o = create_stage(ctx, cache, p->layout, lsnif_batch_decode_spirv, sizeof lsnif_batch_decode_spirv, "decode", p->decode);
  if (!o) {
    destroy_query_pipeline(ctx, *p);
    return o;
  }
  out = std::move(p);
  return Outcome::ok();
}

void destroy_query_pipeline(LsnifContext_T& ctx, LsnifQueryPipeline_T& p) {
  const VkAllocationCallbacks* cb = ctx.info.pAllocator;
  for (VkPipeline* stage : {&p.clear, &p.narrow, &p.mlp, &p.decode}) {
    if (*stage) ctx.vk.vkDestroyPipeline(ctx.info.device, *stage, cb);
    *stage = VK_NULL_HANDLE;
  }
  if (p.layout) ctx.vk.vkDestroyPipelineLayout(ctx.info.device, p.layout, cb);
  p.layout = VK_NULL_HANDLE;
}

VkDeviceSize intersect_scratch_bytes(const LsnifModel_T& m, uint32_t rays) {
  rays = std::min(rays, LSNIF_BATCH_CHUNK_RAYS);  // larger batches reuse it chunk after chunk
  return 4u * (LSNIF_BATCH_HEADER_WORDS + scratch_rows(m) * uint64_t(stride_of(rays)));
}

void record_intersect_model_rays(LsnifContext_T& ctx, const LsnifQueryPipeline_T& p, VkCommandBuffer cmd,
                                 const LsnifModel_T& m, const LsnifIntersectModelRaysInfo& info) {
  const DeviceDispatch& vk = ctx.vk;
  auto split = [](VkDeviceAddress a, lsnif_uint& lo, lsnif_uint& hi) {
    lo = lsnif_uint(a & 0xffffffffu);
    hi = lsnif_uint(a >> 32);
  };
  VkMemoryBarrier barrier{};
  barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
  barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
  barrier.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
  auto between_stages = [&]() {
    vk.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 1,
                            &barrier, 0, nullptr, 0, nullptr);
  };
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
    run(p.mlp, groups);
    between_stages();
    if (base == 0) timestamp(2);
    run(p.decode, groups);
  }
  timestamp(3);
}

}  // namespace lsnif::plugin
