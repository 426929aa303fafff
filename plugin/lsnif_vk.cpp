// lsnif_vk.cpp -- the plugin context (lsnif_vk.h): model upload, AABB BLAS, release, model table.
#include "lsnif_vk.h"

#include <cmath>
#include <cstring>

#include "gpu_model.h"
#include "lsnif_plugin_paths.h"

namespace lsnif::plugin {

namespace {

#define LSNIF_PLUGIN_CHECK(call)                                                      \
  do {                                                                                \
    const VkResult result_ = (call);                                                  \
    if (result_ != VK_SUCCESS) return Status::error("%s failed (VkResult %d)", #call, \
                                                    static_cast<int>(result_));      \
  } while (0)

VkDeviceSize align_up(VkDeviceSize value, VkDeviceSize alignment) {
  return alignment == 0 ? value : (value + alignment - 1) / alignment * alignment;
}

}  // namespace

const char* intersection_shader_spirv_path() { return LSNIF_PLUGIN_RINT_SPV; }

Status create_context(const DeviceHandles& h, Context& out) {
  out.destroy();
  if (!h.instance || !h.physical || !h.device || !h.queue)
    return Status::error("create_context: null handle (instance %p, physical device %p, device %p, queue %p)",
                         static_cast<void*>(h.instance), static_cast<void*>(h.physical),
                         static_cast<void*>(h.device), static_cast<void*>(h.queue));
  Status s = check_device_support(h.physical);
  if (!s) return s.context("create_context");
  out.handles_ = h;
  volkLoadDeviceTable(&out.vk_, h.device);
  if (!out.vk_.vkCreateAccelerationStructureKHR || !out.vk_.vkCmdBuildAccelerationStructuresKHR)
    return Status::error("create_context: the device was created without VK_KHR_acceleration_structure "
                         "(vkCreateAccelerationStructureKHR not found)");
  out.device_ = h.device;
  vkGetPhysicalDeviceMemoryProperties(h.physical, &out.memory_);
  VkPhysicalDeviceAccelerationStructurePropertiesKHR as{};
  as.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_PROPERTIES_KHR;
  VkPhysicalDeviceProperties2 p2{};
  p2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
  p2.pNext = &as;
  vkGetPhysicalDeviceProperties2(h.physical, &p2);
  out.scratch_alignment_ = as.minAccelerationStructureScratchOffsetAlignment;

  VkCommandPoolCreateInfo pci{};
  pci.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  pci.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
  pci.queueFamilyIndex = h.queue_family;
  VkResult r = out.vk_.vkCreateCommandPool(h.device, &pci, nullptr, &out.pool_);
  VkFenceCreateInfo fci{};
  fci.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
  if (r == VK_SUCCESS) r = out.vk_.vkCreateFence(h.device, &fci, nullptr, &out.fence_);
  if (r != VK_SUCCESS) {
    out.destroy();
    return Status::error("create_context: command pool / fence creation failed (VkResult %d)", static_cast<int>(r));
  }
  return Status::ok();
}

Context::~Context() { destroy(); }

void Context::destroy() {
  if (!device_) return;
  vk_.vkQueueWaitIdle(handles_.queue);
  for (Slot& slot : slots_) release_slot(slot);
  slots_.clear();
  if (fence_) vk_.vkDestroyFence(device_, fence_, nullptr);
  if (pool_) vk_.vkDestroyCommandPool(device_, pool_, nullptr);
  fence_ = VK_NULL_HANDLE;
  pool_ = VK_NULL_HANDLE;
  device_ = VK_NULL_HANDLE;
  handles_ = DeviceHandles();
}

Status Context::allocate(VkDeviceSize bytes, VkBufferUsageFlags usage, bool host_visible, const void* data,
                         Allocation& out) {
  out = Allocation();
  VkBufferCreateInfo bci{};
  bci.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  bci.size = bytes > 0 ? bytes : 4;
  bci.usage = usage | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
  bci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  LSNIF_PLUGIN_CHECK(vk_.vkCreateBuffer(device_, &bci, nullptr, &out.buffer));
  VkMemoryRequirements req;
  vk_.vkGetBufferMemoryRequirements(device_, out.buffer, &req);
  // Host-visible coherent memory when the host writes it (device-local too when offered), else
  // device-local memory when offered, else any allowed type.
  const VkMemoryPropertyFlags need =
      host_visible ? VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT : 0;
  uint32_t type = UINT32_MAX;
  for (int pass = 0; pass < 2 && type == UINT32_MAX; ++pass) {
    const VkMemoryPropertyFlags want = need | (pass == 0 ? VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT : 0);
    for (uint32_t i = 0; i < memory_.memoryTypeCount && type == UINT32_MAX; ++i)
      if ((req.memoryTypeBits & (1u << i)) && (memory_.memoryTypes[i].propertyFlags & want) == want) type = i;
  }
  if (type == UINT32_MAX) {
    free(out);
    return Status::error("no %smemory type for a %llu-byte buffer", host_visible ? "host-visible coherent " : "",
                         static_cast<unsigned long long>(bytes));
  }
  VkMemoryAllocateFlagsInfo flags{};
  flags.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO;
  flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
  VkMemoryAllocateInfo mai{};
  mai.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
  mai.pNext = &flags;
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = type;
  out.bytes = bytes;
  out.allocated = req.size;
  VkResult r = vk_.vkAllocateMemory(device_, &mai, nullptr, &out.memory);
  if (r == VK_SUCCESS) r = vk_.vkBindBufferMemory(device_, out.buffer, out.memory, 0);
  if (r == VK_SUCCESS && data) {
    void* mapped = nullptr;
    r = vk_.vkMapMemory(device_, out.memory, 0, VK_WHOLE_SIZE, 0, &mapped);
    if (r == VK_SUCCESS) {
      std::memcpy(mapped, data, size_t(bytes));
      vk_.vkUnmapMemory(device_, out.memory);
    }
  }
  if (r != VK_SUCCESS) {
    free(out);
    return Status::error("allocating a %llu-byte buffer failed (VkResult %d)", static_cast<unsigned long long>(bytes),
                         static_cast<int>(r));
  }
  VkBufferDeviceAddressInfo ai{};
  ai.sType = VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO;
  ai.buffer = out.buffer;
  out.address = vk_.vkGetBufferDeviceAddress(device_, &ai);
  return Status::ok();
}

void Context::free(Allocation& a) {
  if (device_) {
    if (a.buffer) vk_.vkDestroyBuffer(device_, a.buffer, nullptr);
    if (a.memory) vk_.vkFreeMemory(device_, a.memory, nullptr);
  }
  a = Allocation();
}

Status Context::submit_and_wait(VkCommandBuffer cmd) {
  VkSubmitInfo si{};
  si.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
  si.commandBufferCount = 1;
  si.pCommandBuffers = &cmd;
  VkResult r = vk_.vkQueueSubmit(handles_.queue, 1, &si, fence_);
  if (r == VK_SUCCESS) r = vk_.vkWaitForFences(device_, 1, &fence_, VK_TRUE, UINT64_MAX);
  if (r == VK_SUCCESS) r = vk_.vkResetFences(device_, 1, &fence_);
  if (r != VK_SUCCESS) return Status::error("BLAS build submission failed (VkResult %d)", static_cast<int>(r));
  return Status::ok();
}

Status Context::build_blas(const Model& model, Slot& slot) {
  const Aabb& b = model.bounds();
  const float grow = 1e-4f * b.diagonal();
  const VkAabbPositionsKHR box{b.lo.x - grow, b.lo.y - grow, b.lo.z - grow,
                               b.hi.x + grow, b.hi.y + grow, b.hi.z + grow};
  for (const float v : {box.minX, box.minY, box.minZ, box.maxX, box.maxY, box.maxZ})
    if (!std::isfinite(v)) return Status::error("model bounds are not finite");
  if (!(box.minX <= box.maxX && box.minY <= box.maxY && box.minZ <= box.maxZ))
    return Status::error("model bounds are inverted");
  Allocation input;
  Status s = allocate(sizeof(box), VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR, true, &box,
                      input);
  if (!s) return s;

  VkAccelerationStructureGeometryKHR geometry{};
  geometry.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR;
  geometry.geometryType = VK_GEOMETRY_TYPE_AABBS_KHR;
  geometry.flags = VK_GEOMETRY_OPAQUE_BIT_KHR;
  geometry.geometry.aabbs.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_AABBS_DATA_KHR;
  geometry.geometry.aabbs.data.deviceAddress = input.address;
  geometry.geometry.aabbs.stride = sizeof(VkAabbPositionsKHR);
  VkAccelerationStructureBuildGeometryInfoKHR info{};
  info.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR;
  info.type = VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR;
  info.flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR;
  info.mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR;
  info.geometryCount = 1;
  info.pGeometries = &geometry;
  const uint32_t primitives = 1;
  VkAccelerationStructureBuildSizesInfoKHR sizes{};
  sizes.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR;
  vk_.vkGetAccelerationStructureBuildSizesKHR(device_, VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &info,
                                              &primitives, &sizes);
  Allocation scratch;
  s = allocate(sizes.accelerationStructureSize, VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR, false,
               nullptr, slot.blas_storage);
  if (s)
    s = allocate(sizes.buildScratchSize + scratch_alignment_, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, false, nullptr,
                 scratch);
  if (s) {
    VkAccelerationStructureCreateInfoKHR aci{};
    aci.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_KHR;
    aci.buffer = slot.blas_storage.buffer;
    aci.size = sizes.accelerationStructureSize;
    aci.type = VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR;
    const VkResult r = vk_.vkCreateAccelerationStructureKHR(device_, &aci, nullptr, &slot.blas);
    if (r != VK_SUCCESS)
      s = Status::error("vkCreateAccelerationStructureKHR failed (VkResult %d)", static_cast<int>(r));
  }
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  if (s) {
    VkAccelerationStructureDeviceAddressInfoKHR dai{};
    dai.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_DEVICE_ADDRESS_INFO_KHR;
    dai.accelerationStructure = slot.blas;
    slot.blas_address = vk_.vkGetAccelerationStructureDeviceAddressKHR(device_, &dai);
    VkCommandBufferAllocateInfo cai{};
    cai.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    cai.commandPool = pool_;
    cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cai.commandBufferCount = 1;
    const VkResult r = vk_.vkAllocateCommandBuffers(device_, &cai, &cmd);
    if (r != VK_SUCCESS) s = Status::error("vkAllocateCommandBuffers failed (VkResult %d)", static_cast<int>(r));
  }
  if (s) {
    info.dstAccelerationStructure = slot.blas;
    info.scratchData.deviceAddress = align_up(scratch.address, scratch_alignment_);
    VkAccelerationStructureBuildRangeInfoKHR range{};
    range.primitiveCount = primitives;
    const VkAccelerationStructureBuildRangeInfoKHR* ranges = &range;
    VkCommandBufferBeginInfo bi{};
    bi.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    vk_.vkBeginCommandBuffer(cmd, &bi);
    vk_.vkCmdBuildAccelerationStructuresKHR(cmd, 1, &info, &ranges);
    // The BLAS is read by later TLAS builds and traces (submitted after this one completes).
    VkMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    barrier.srcAccessMask = VK_ACCESS_ACCELERATION_STRUCTURE_WRITE_BIT_KHR;
    barrier.dstAccessMask = VK_ACCESS_ACCELERATION_STRUCTURE_READ_BIT_KHR;
    vk_.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR,
                             VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR |
                                 VK_PIPELINE_STAGE_RAY_TRACING_SHADER_BIT_KHR,
                             0, 1, &barrier, 0, nullptr, 0, nullptr);
    vk_.vkEndCommandBuffer(cmd);
    s = submit_and_wait(cmd);
  }
  if (cmd) vk_.vkFreeCommandBuffers(device_, pool_, 1, &cmd);
  free(scratch);
  free(input);
  return s;
}

Status Context::upload_model(const Model& model, ModelHandle& out) {
  out = ModelHandle();
  if (!device_) return Status::error("upload_model: context not created");
  std::vector<uint32_t> words;
  Status s = pack_gpu_model(model, words);
  if (!s) return s.context("upload_model");
  Slot slot;
  s = allocate(words.size() * sizeof(uint32_t), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, words.data(), slot.block);
  if (s && slot.block.address % 32 != 0)  // the shaders read the MLP in 32-byte loads
    s = Status::error("model block at device address 0x%llx is not 32-byte aligned",
                      static_cast<unsigned long long>(slot.block.address));
  if (s) s = build_blas(model, slot);
  if (!s) {
    release_slot(slot);
    return s.context("upload_model");
  }
  slot.id = next_id_++;
  out.id = slot.id;
  slots_.push_back(slot);
  return Status::ok();
}

void Context::release_slot(Slot& slot) {
  if (device_ && slot.blas) vk_.vkDestroyAccelerationStructureKHR(device_, slot.blas, nullptr);
  free(slot.blas_storage);
  free(slot.block);
  slot = Slot();
}

void Context::release_model(ModelHandle& handle) {
  for (size_t i = 0; i < slots_.size(); ++i) {
    if (slots_[i].id != handle.id || handle.id == 0) continue;
    vk_.vkQueueWaitIdle(handles_.queue);  // no trace may still read the model
    release_slot(slots_[i]);
    slots_.erase(slots_.begin() + static_cast<std::ptrdiff_t>(i));
    break;
  }
  handle = ModelHandle();
}

const Context::Slot* Context::find(ModelHandle handle) const {
  for (const Slot& slot : slots_)
    if (handle.id != 0 && slot.id == handle.id) return &slot;
  return nullptr;
}

VkDeviceAddress Context::model_address(ModelHandle handle) const {
  const Slot* s = find(handle);
  return s ? s->block.address : 0;
}

VkDeviceAddress Context::blas_address(ModelHandle handle) const {
  const Slot* s = find(handle);
  return s ? s->blas_address : 0;
}

size_t Context::model_count() const { return slots_.size(); }

Status Context::model_memory(ModelHandle handle, ModelMemory& out) const {
  const Slot* s = find(handle);
  if (!s) return Status::error("model_memory: unknown model handle %u", handle.id);
  out = ModelMemory();
  out.block_bytes = s->block.bytes;
  out.blas_bytes = s->blas_storage.bytes;
  out.allocated_bytes = s->block.allocated + s->blas_storage.allocated;
  return Status::ok();
}

Status check_instance_transform(const Transform3x4& xf) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c)
      if (!std::isfinite(xf.m[r][c]))
        return Status::error("instance transform entry [%d][%d] = %g is not finite", r, c, double(xf.m[r][c]));
  double a[3][3], norm = 1.0;
  for (int r = 0; r < 3; ++r) {
    double n2 = 0;
    for (int c = 0; c < 3; ++c) {
      a[r][c] = double(xf.m[r][c]);
      n2 += a[r][c] * a[r][c];
    }
    norm *= std::sqrt(n2);
  }
  const double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                     a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                     a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  if (!(std::fabs(det) > 1e-12 * norm))
    return Status::error("instance transform is singular (det %g, product of row norms %g)", det, norm);
  return Status::ok();
}

Status Context::make_instance(ModelHandle handle, const Transform3x4& xf, uint32_t custom_index, uint8_t mask,
                              uint32_t sbt_offset, VkAccelerationStructureInstanceKHR& out) const {
  const Slot* slot = find(handle);
  if (!slot) return Status::error("make_instance: unknown model handle %u", handle.id);
  if (custom_index >= (1u << 24))
    return Status::error("make_instance: custom index %u does not fit the 24 bits of instanceCustomIndex",
                         custom_index);
  if (sbt_offset >= (1u << 24))
    return Status::error("make_instance: SBT record offset %u does not fit 24 bits", sbt_offset);
  Status s = check_instance_transform(xf);
  if (!s) return s.context("make_instance");
  out = VkAccelerationStructureInstanceKHR{};
  std::memcpy(out.transform.matrix, xf.m, sizeof(out.transform.matrix));
  out.instanceCustomIndex = custom_index & 0xFFFFFFu;
  out.mask = mask;
  out.instanceShaderBindingTableRecordOffset = sbt_offset & 0xFFFFFFu;
  out.flags = 0;
  out.accelerationStructureReference = slot->blas_address;
  return Status::ok();
}

Status Context::model_table(const std::vector<ModelHandle>& models, std::vector<uint64_t>& table) const {
  std::vector<uint64_t> t(models.size());
  for (size_t i = 0; i < models.size(); ++i) {
    t[i] = model_address(models[i]);
    if (t[i] == 0) return Status::error("model_table: entry %zu holds unknown model handle %u", i, models[i].id);
  }
  table.swap(t);
  return Status::ok();
}

}  // namespace lsnif::plugin
