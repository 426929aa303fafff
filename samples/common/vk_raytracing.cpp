// vk_raytracing.cpp -- the harness of vk_raytracing.h.
#include "vk_raytracing.h"

#include <chrono>
#include <cstring>

namespace lsnif::vk {

namespace {

#define LSNIF_VK_CHECK(call)                                                          \
  do {                                                                                \
    const VkResult result_ = (call);                                                  \
    if (result_ != VK_SUCCESS) return Status::error("%s failed (VkResult %d)", #call, \
                                                    static_cast<int>(result_));      \
  } while (0)

VkDeviceSize align_up(VkDeviceSize value, VkDeviceSize alignment) {
  return alignment == 0 ? value : (value + alignment - 1) / alignment * alignment;
}

constexpr VkShaderStageFlags kPushStages = VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_MISS_BIT_KHR |
                                           VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR |
                                           VK_SHADER_STAGE_INTERSECTION_BIT_KHR;

// Makes acceleration-structure writes of earlier commands visible to later builds and traces.
void as_barrier(VkCommandBuffer cmd) {
  VkMemoryBarrier barrier{};
  barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
  barrier.srcAccessMask = VK_ACCESS_ACCELERATION_STRUCTURE_WRITE_BIT_KHR;
  barrier.dstAccessMask = VK_ACCESS_ACCELERATION_STRUCTURE_READ_BIT_KHR;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR,
                       VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR |
                           VK_PIPELINE_STAGE_RAY_TRACING_SHADER_BIT_KHR,
                       0, 1, &barrier, 0, nullptr, 0, nullptr);
}

}  // namespace

RayTracer::RayTracer(ComputeContext& context) : ctx_(context) {}

Status RayTracer::init() {
  if (!ctx_.device()) return Status::error("RayTracer::init: context not initialized");
  props_ = VkPhysicalDeviceRayTracingPipelinePropertiesKHR{};
  props_.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_PROPERTIES_KHR;
  as_props_ = VkPhysicalDeviceAccelerationStructurePropertiesKHR{};
  as_props_.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_PROPERTIES_KHR;
  props_.pNext = &as_props_;
  VkPhysicalDeviceProperties2 p2{};
  p2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
  p2.pNext = &props_;
  vkGetPhysicalDeviceProperties2(ctx_.physical_device(), &p2);
  props_.pNext = nullptr;
  as_props_.pNext = nullptr;
  if (props_.shaderGroupHandleSize == 0)
    return Status::error("device reports shaderGroupHandleSize 0 (no ray-tracing pipeline support)");
  return Status::ok();
}

Status RayTracer::build(VkAccelerationStructureTypeKHR type, const VkAccelerationStructureGeometryKHR& geometry,
                        uint32_t primitive_count, AccelerationStructure& out) {
  out = AccelerationStructure();
  VkAccelerationStructureBuildGeometryInfoKHR info{};
  info.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR;
  info.type = type;
  info.flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR;
  info.mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR;
  info.geometryCount = 1;
  info.pGeometries = &geometry;
  VkAccelerationStructureBuildSizesInfoKHR sizes{};
  sizes.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR;
  vkGetAccelerationStructureBuildSizesKHR(ctx_.device(), VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &info,
                                          &primitive_count, &sizes);
  Status s = ctx_.create_buffer(size_t(sizes.accelerationStructureSize), out.storage,
                                VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR);
  if (!s) return s;
  VkAccelerationStructureCreateInfoKHR aci{};
  aci.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_KHR;
  aci.buffer = out.storage.buffer;
  aci.size = sizes.accelerationStructureSize;
  aci.type = type;
  LSNIF_VK_CHECK(vkCreateAccelerationStructureKHR(ctx_.device(), &aci, nullptr, &out.handle));
  VkAccelerationStructureDeviceAddressInfoKHR dai{};
  dai.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_DEVICE_ADDRESS_INFO_KHR;
  dai.accelerationStructure = out.handle;
  out.address = vkGetAccelerationStructureDeviceAddressKHR(ctx_.device(), &dai);

  const VkDeviceSize scratch_align = as_props_.minAccelerationStructureScratchOffsetAlignment;
  Buffer scratch;
  s = ctx_.create_buffer(size_t(sizes.buildScratchSize + scratch_align), scratch);
  if (!s) return s;
  info.dstAccelerationStructure = out.handle;
  info.scratchData.deviceAddress = align_up(scratch.address, scratch_align);
  VkAccelerationStructureBuildRangeInfoKHR range{};
  range.primitiveCount = primitive_count;
  const VkAccelerationStructureBuildRangeInfoKHR* ranges = &range;
  s = ctx_.submit(type == VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR ? "TLAS build" : "BLAS build",
                  [&](VkCommandBuffer cmd) {
                    vkCmdBuildAccelerationStructuresKHR(cmd, 1, &info, &ranges);
                    as_barrier(cmd);
                  });
  ctx_.destroy_buffer(scratch);
  return s;
}

Status RayTracer::build_triangle_blas(const std::vector<float>& positions, const std::vector<uint32_t>& indices,
                                      AccelerationStructure& out) {
  const size_t vertices = positions.size() / 3;
  if (vertices == 0 || positions.size() % 3 != 0 || indices.empty() || indices.size() % 3 != 0)
    return Status::error("build_triangle_blas: %zu position floats / %zu indices do not form a mesh",
                         positions.size(), indices.size());
  for (size_t i = 0; i < indices.size(); ++i)
    if (indices[i] >= vertices)
      return Status::error("build_triangle_blas: index %zu = %u >= %zu vertices", i, indices[i], vertices);
  Buffer vbuf, ibuf;
  const VkBufferUsageFlags usage = VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR;
  Status s = ctx_.create_buffer(positions.size() * sizeof(float), vbuf, usage);
  if (s) s = ctx_.create_buffer(indices.size() * sizeof(uint32_t), ibuf, usage);
  if (s) {
    std::memcpy(vbuf.mapped, positions.data(), positions.size() * sizeof(float));
    std::memcpy(ibuf.mapped, indices.data(), indices.size() * sizeof(uint32_t));
    VkAccelerationStructureGeometryKHR geometry{};
    geometry.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR;
    geometry.geometryType = VK_GEOMETRY_TYPE_TRIANGLES_KHR;
    geometry.flags = VK_GEOMETRY_OPAQUE_BIT_KHR;
    VkAccelerationStructureGeometryTrianglesDataKHR& t = geometry.geometry.triangles;
    t.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_TRIANGLES_DATA_KHR;
    t.vertexFormat = VK_FORMAT_R32G32B32_SFLOAT;
    t.vertexData.deviceAddress = vbuf.address;
    t.vertexStride = 3 * sizeof(float);
    t.maxVertex = uint32_t(vertices - 1);
    t.indexType = VK_INDEX_TYPE_UINT32;
    t.indexData.deviceAddress = ibuf.address;
    s = build(VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR, geometry, uint32_t(indices.size() / 3), out);
  }
  ctx_.destroy_buffer(vbuf);
  ctx_.destroy_buffer(ibuf);
  return s;
}

Status RayTracer::build_tlas(const std::vector<VkAccelerationStructureInstanceKHR>& records,
                             AccelerationStructure& out) {
  if (records.empty()) return Status::error("build_tlas: no instances");
  for (size_t i = 0; i < records.size(); ++i)
    if (!records[i].accelerationStructureReference) return Status::error("build_tlas: instance %zu has no BLAS", i);
  Buffer input;
  Status s = ctx_.create_buffer(records.size() * sizeof(VkAccelerationStructureInstanceKHR), input,
                                VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR);
  if (!s) return s;
  std::memcpy(input.mapped, records.data(), records.size() * sizeof(VkAccelerationStructureInstanceKHR));
  VkAccelerationStructureGeometryKHR geometry{};
  geometry.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR;
  geometry.geometryType = VK_GEOMETRY_TYPE_INSTANCES_KHR;
  geometry.geometry.instances.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_INSTANCES_DATA_KHR;
  geometry.geometry.instances.arrayOfPointers = VK_FALSE;
  geometry.geometry.instances.data.deviceAddress = input.address;
  s = build(VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR, geometry, uint32_t(records.size()), out);
  ctx_.destroy_buffer(input);
  return s;
}

void RayTracer::destroy(AccelerationStructure& as) {
  if (as.handle) vkDestroyAccelerationStructureKHR(ctx_.device(), as.handle, nullptr);
  ctx_.destroy_buffer(as.storage);
  as = AccelerationStructure();
}

Status RayTracer::load_module(const std::string& path, VkShaderModule& out) {
  return ctx_.load_shader_module(path, out);
}

Status RayTracer::create_pipeline(const std::string& raygen, const std::string& miss,
                                  const std::string& closest_hit, const std::string& intersection,
                                  uint32_t push_size, RtPipeline& out, const std::string& triangle_closest_hit) {
  out = RtPipeline();
  if (!ctx_.device() || props_.shaderGroupHandleSize == 0)
    return Status::error("create_pipeline: RayTracer not initialized");
  const bool triangles = !triangle_closest_hit.empty();
  const uint32_t stage_count = triangles ? 5 : 4, group_count = triangles ? 4 : 3;
  const std::string* paths[5] = {&raygen, &miss, &closest_hit, &intersection, &triangle_closest_hit};
  const VkShaderStageFlagBits stages[5] = {VK_SHADER_STAGE_RAYGEN_BIT_KHR, VK_SHADER_STAGE_MISS_BIT_KHR,
                                           VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR,
                                           VK_SHADER_STAGE_INTERSECTION_BIT_KHR,
                                           VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR};
  VkShaderModule modules[5] = {};
  Status s = Status::ok();
  for (uint32_t i = 0; i < stage_count && s; ++i) s = load_module(*paths[i], modules[i]);
  auto release_modules = [&] {
    for (VkShaderModule m : modules)
      if (m) vkDestroyShaderModule(ctx_.device(), m, nullptr);
  };
  if (!s) {
    release_modules();
    return s;
  }

  VkDescriptorSetLayoutBinding binding{};
  binding.binding = 0;
  binding.descriptorType = VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR;
  binding.descriptorCount = 1;
  binding.stageFlags = VK_SHADER_STAGE_RAYGEN_BIT_KHR;
  VkDescriptorSetLayoutCreateInfo sli{};
  sli.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  sli.bindingCount = 1;
  sli.pBindings = &binding;
  VkPushConstantRange range{kPushStages, 0, push_size};
  VkDescriptorPoolSize pool_size{VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR, 1};
  VkDescriptorPoolCreateInfo dpi{};
  dpi.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  dpi.maxSets = 1;
  dpi.poolSizeCount = 1;
  dpi.pPoolSizes = &pool_size;
  VkResult r = vkCreateDescriptorSetLayout(ctx_.device(), &sli, nullptr, &out.set_layout);
  if (r == VK_SUCCESS) r = vkCreateDescriptorPool(ctx_.device(), &dpi, nullptr, &out.pool);
  if (r == VK_SUCCESS) {
    VkDescriptorSetAllocateInfo dsa{};
    dsa.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    dsa.descriptorPool = out.pool;
    dsa.descriptorSetCount = 1;
    dsa.pSetLayouts = &out.set_layout;
    r = vkAllocateDescriptorSets(ctx_.device(), &dsa, &out.set);
  }
  if (r == VK_SUCCESS) {
    VkPipelineLayoutCreateInfo lci{};
    lci.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    lci.setLayoutCount = 1;
    lci.pSetLayouts = &out.set_layout;
    lci.pushConstantRangeCount = push_size > 0 ? 1 : 0;
    lci.pPushConstantRanges = &range;
    r = vkCreatePipelineLayout(ctx_.device(), &lci, nullptr, &out.layout);
  }
  if (r != VK_SUCCESS) {
    release_modules();
    destroy(out);
    return Status::error("descriptor set / pipeline layout creation failed (VkResult %d)", static_cast<int>(r));
  }

  VkPipelineShaderStageCreateInfo stage_info[5] = {};
  for (uint32_t i = 0; i < stage_count; ++i) {
    stage_info[i].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stage_info[i].stage = stages[i];
    stage_info[i].module = modules[i];
    stage_info[i].pName = "main";
  }
  VkRayTracingShaderGroupCreateInfoKHR groups[4] = {};
  for (VkRayTracingShaderGroupCreateInfoKHR& g : groups) {
    g.sType = VK_STRUCTURE_TYPE_RAY_TRACING_SHADER_GROUP_CREATE_INFO_KHR;
    g.generalShader = g.closestHitShader = g.anyHitShader = g.intersectionShader = VK_SHADER_UNUSED_KHR;
  }
  groups[0].type = VK_RAY_TRACING_SHADER_GROUP_TYPE_GENERAL_KHR;
  groups[0].generalShader = 0;
  groups[1].type = VK_RAY_TRACING_SHADER_GROUP_TYPE_GENERAL_KHR;
  groups[1].generalShader = 1;
  groups[2].type = VK_RAY_TRACING_SHADER_GROUP_TYPE_PROCEDURAL_HIT_GROUP_KHR;
  groups[2].closestHitShader = 2;
  groups[2].intersectionShader = 3;
  groups[3].type = VK_RAY_TRACING_SHADER_GROUP_TYPE_TRIANGLES_HIT_GROUP_KHR;
  groups[3].closestHitShader = 4;
  VkRayTracingPipelineCreateInfoKHR pci{};
  pci.sType = VK_STRUCTURE_TYPE_RAY_TRACING_PIPELINE_CREATE_INFO_KHR;
  pci.stageCount = stage_count;
  pci.pStages = stage_info;
  pci.groupCount = group_count;
  pci.pGroups = groups;
  pci.maxPipelineRayRecursionDepth = 1;
  pci.layout = out.layout;
  const auto t0 = std::chrono::steady_clock::now();
  r = vkCreateRayTracingPipelinesKHR(ctx_.device(), VK_NULL_HANDLE, VK_NULL_HANDLE, 1, &pci, nullptr,
                                     &out.pipeline);
  out.create_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  release_modules();
  if (r != VK_SUCCESS) {
    destroy(out);
    return Status::error("vkCreateRayTracingPipelinesKHR(%s, %s, %s, %s) failed (VkResult %d)", raygen.c_str(),
                         miss.c_str(), closest_hit.c_str(), intersection.c_str(), static_cast<int>(r));
  }
  out.push_size = push_size;

  // Shader binding table: one record per group; each region starts at shaderGroupBaseAlignment,
  // records are handle-aligned; the raygen region's size equals its stride (a spec requirement).
  const uint32_t handle_size = props_.shaderGroupHandleSize;
  std::vector<uint8_t> handles(size_t(group_count) * handle_size);
  r = vkGetRayTracingShaderGroupHandlesKHR(ctx_.device(), out.pipeline, 0, group_count, handles.size(),
                                           handles.data());
  if (r != VK_SUCCESS) {
    destroy(out);
    return Status::error("vkGetRayTracingShaderGroupHandlesKHR failed (VkResult %d)", static_cast<int>(r));
  }
  const VkDeviceSize base_align = props_.shaderGroupBaseAlignment;
  const VkDeviceSize record_stride = align_up(handle_size, props_.shaderGroupHandleAlignment);
  const VkDeviceSize region = align_up(record_stride, base_align);
  s = ctx_.create_buffer(size_t(4 * region + base_align), out.sbt,
                         VK_BUFFER_USAGE_SHADER_BINDING_TABLE_BIT_KHR);
  if (!s) {
    destroy(out);
    return s;
  }
  const VkDeviceAddress base = align_up(out.sbt.address, base_align);
  auto* bytes = static_cast<uint8_t*>(out.sbt.mapped) + (base - out.sbt.address);
  for (size_t g = 0; g < 3; ++g) std::memcpy(bytes + g * region, handles.data() + g * handle_size, handle_size);
  // The hit region holds the hit groups back to back, record_stride apart.
  if (triangles)
    std::memcpy(bytes + 2 * region + record_stride, handles.data() + 3 * handle_size, handle_size);
  out.raygen_region = {base, region, region};
  out.miss_region = {base + region, record_stride, record_stride};
  out.hit_region = {base + 2 * region, record_stride, record_stride * (group_count - 2)};
  out.callable_region = {0, 0, 0};
  return Status::ok();
}

void RayTracer::destroy(RtPipeline& p) {
  VkDevice d = ctx_.device();
  if (d) {
    if (p.pipeline) vkDestroyPipeline(d, p.pipeline, nullptr);
    if (p.layout) vkDestroyPipelineLayout(d, p.layout, nullptr);
    if (p.pool) vkDestroyDescriptorPool(d, p.pool, nullptr);  // frees the set
    if (p.set_layout) vkDestroyDescriptorSetLayout(d, p.set_layout, nullptr);
  }
  ctx_.destroy_buffer(p.sbt);
  p = RtPipeline();
}

Status RayTracer::trace(RtPipeline& p, const AccelerationStructure& tlas, const void* push, uint32_t width) {
  if (!p.pipeline || !tlas.handle) return Status::error("trace: no pipeline or TLAS");
  VkWriteDescriptorSetAccelerationStructureKHR as_write{};
  as_write.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET_ACCELERATION_STRUCTURE_KHR;
  as_write.accelerationStructureCount = 1;
  as_write.pAccelerationStructures = &tlas.handle;
  VkWriteDescriptorSet write{};
  write.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
  write.pNext = &as_write;
  write.dstSet = p.set;
  write.dstBinding = 0;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR;
  vkUpdateDescriptorSets(ctx_.device(), 1, &write, 0, nullptr);
  return ctx_.submit("vkCmdTraceRaysKHR", [&](VkCommandBuffer cmd) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR, p.pipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR, p.layout, 0, 1, &p.set, 0, nullptr);
    if (p.push_size > 0) vkCmdPushConstants(cmd, p.layout, kPushStages, 0, p.push_size, push);
    vkCmdTraceRaysKHR(cmd, &p.raygen_region, &p.miss_region, &p.hit_region, &p.callable_region, width, 1, 1);
    VkMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_RAY_TRACING_SHADER_BIT_KHR, VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                         &barrier, 0, nullptr, 0, nullptr);
  });
}

}  // namespace lsnif::vk
