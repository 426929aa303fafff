// vk_dispatch.h -- one compute dispatch, waited for, for the GPU tests that run a shader over a
// few buffers: push constants, the buffers bound to the pipeline's storage-buffer bindings (a
// descriptor set made for the dispatch), vkCmdDispatch(groups_x, 1, 1), and the writes made
// visible to the host. Header-only (link lsnif_vk_app); include inside no namespace.
#pragma once
#include <cstdint>
#include <vector>

#include "lsnif/format/status.h"
#include "lsnif/vulkan/context.h"

namespace lsnif::gputest {

// `buffers` (whole buffers) are bound to the pipeline's storage-buffer bindings
// (vk::Pipeline::storage_buffers), one each, in order.
inline Status dispatch(vk::Context& ctx, const vk::Pipeline& pipeline, const void* push, uint32_t groups_x,
                       const std::vector<const vk::Buffer*>& buffers = {}) {
  const VkDevice device = ctx.device();
  if (!device || !pipeline.pipeline) return Status::error("dispatch: no device or pipeline");
  if (buffers.size() != pipeline.storage_buffers)
    return Status::error("dispatch: %zu buffers for a pipeline with %u storage-buffer bindings", buffers.size(),
                         pipeline.storage_buffers);
  for (size_t i = 0; i < buffers.size(); ++i)
    if (Status s = ctx.check_buffer_size(format("buffer of binding %zu", i), buffers[i]->size, true); !s)
      return s.context("dispatch");
  // A descriptor set for this dispatch only (pool destroyed after the wait).
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;
  if (pipeline.storage_buffers > 0) {
    const VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, pipeline.storage_buffers};
    VkDescriptorPoolCreateInfo pci{};
    pci.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    pci.maxSets = 1;
    pci.poolSizeCount = 1;
    pci.pPoolSizes = &size;
    LSNIF_VK_CHECK(vkCreateDescriptorPool(device, &pci, nullptr, &pool));
    VkDescriptorSetAllocateInfo ai{};
    ai.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    ai.descriptorPool = pool;
    ai.descriptorSetCount = 1;
    ai.pSetLayouts = &pipeline.set_layout;
    const VkResult r = vkAllocateDescriptorSets(device, &ai, &set);
    if (r != VK_SUCCESS) {
      vkDestroyDescriptorPool(device, pool, nullptr);
      return Status::error("vkAllocateDescriptorSets failed (VkResult %d)", static_cast<int>(r));
    }
    std::vector<VkDescriptorBufferInfo> infos(buffers.size());
    std::vector<VkWriteDescriptorSet> writes(buffers.size());
    for (size_t i = 0; i < buffers.size(); ++i) {
      infos[i] = VkDescriptorBufferInfo{buffers[i]->buffer, 0, VK_WHOLE_SIZE};
      writes[i] = VkWriteDescriptorSet{};
      writes[i].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
      writes[i].dstSet = set;
      writes[i].dstBinding = uint32_t(i);
      writes[i].descriptorCount = 1;
      writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      writes[i].pBufferInfo = &infos[i];
    }
    vkUpdateDescriptorSets(device, uint32_t(writes.size()), writes.data(), 0, nullptr);
  }
  const Status st = ctx.submit("compute dispatch", [&](VkCommandBuffer cmd) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.pipeline);
    if (set) vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.layout, 0, 1, &set, 0, nullptr);
    if (pipeline.push_size > 0)
      vkCmdPushConstants(cmd, pipeline.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, pipeline.push_size, push);
    vkCmdDispatch(cmd, groups_x, 1, 1);
    vk::Context::barrier_compute_to_host(cmd);
  });
  if (pool) vkDestroyDescriptorPool(device, pool, nullptr);
  return st;
}

}  // namespace lsnif::gputest
