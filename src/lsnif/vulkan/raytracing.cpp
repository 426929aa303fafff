// raytracing.cpp -- the acceleration structures and ray-tracing pipelines of raytracing.h.
#include "lsnif/vulkan/raytracing.h"

#include <algorithm>
#include <chrono>
#include <cstring>

namespace lsnif::vk {

namespace {

VkDeviceSize align_up(VkDeviceSize value, VkDeviceSize alignment) {
  return alignment == 0 ? value : (value + alignment - 1) / alignment * alignment;
}

constexpr VkShaderStageFlags kPushStages = VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_MISS_BIT_KHR |
                                           VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR |
                                           VK_SHADER_STAGE_INTERSECTION_BIT_KHR | VK_SHADER_STAGE_ANY_HIT_BIT_KHR;

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

// An acceleration structure of `type` occupying `size` bytes at the start of `buffer`.
Status create_acceleration_structure(VkDevice device, VkBuffer buffer, VkDeviceSize size,
                                     VkAccelerationStructureTypeKHR type, VkAccelerationStructureKHR& out) {
  VkAccelerationStructureCreateInfoKHR aci{};
  aci.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_KHR;
  aci.buffer = buffer;
  aci.size = size;
  aci.type = type;
  LSNIF_VK_CHECK(vkCreateAccelerationStructureKHR(device, &aci, nullptr, &out));
  return Status::ok();
}

}  // namespace

RayTracer::RayTracer(Context& context) : ctx_(context) {}

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
                        uint32_t primitive_count, AccelerationStructure& out, bool allow_update) {
  out = AccelerationStructure();
  out.updatable = allow_update;
  out.primitive_count = primitive_count;
  VkAccelerationStructureBuildGeometryInfoKHR info{};
  info.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR;
  info.type = type;
  info.flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR |
               (allow_update ? VK_BUILD_ACCELERATION_STRUCTURE_ALLOW_UPDATE_BIT_KHR : 0);
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
  s = create_acceleration_structure(ctx_.device(), out.storage.buffer, sizes.accelerationStructureSize, type,
                                    out.handle);
  if (!s) return s;
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

namespace {

// The input checks of build_triangle_blas, for `what`.
Status check_triangles(const char* what, const std::vector<float>& positions, const std::vector<uint32_t>& indices) {
  const size_t vertices = positions.size() / 3;
  if (vertices == 0 || positions.size() % 3 != 0 || indices.empty() || indices.size() % 3 != 0)
    return Status::error("%s: %zu position floats / %zu indices do not form a mesh", what, positions.size(),
                         indices.size());
  if (vertices > UINT32_MAX || indices.size() / 3 > UINT32_MAX)
    return Status::error("%s: %zu vertices / %zu triangles exceed 32-bit counts", what, vertices, indices.size() / 3);
  for (size_t i = 0; i < indices.size(); ++i)
    if (indices[i] >= vertices)
      return Status::error("%s: index %zu = %u >= %zu vertices", what, i, indices[i], vertices);
  return Status::ok();
}

// One triangle geometry, OPAQUE unless `opaque` is false: float3 positions at `vertices`
// (`vertex_count` of them), uint32 indices at `indices`.
VkAccelerationStructureGeometryKHR triangle_geometry(VkDeviceAddress vertices, uint32_t vertex_count,
                                                     VkDeviceAddress indices, bool opaque = true) {
  VkAccelerationStructureGeometryKHR geometry{};
  geometry.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR;
  geometry.geometryType = VK_GEOMETRY_TYPE_TRIANGLES_KHR;
  geometry.flags = opaque ? VK_GEOMETRY_OPAQUE_BIT_KHR : 0;
  VkAccelerationStructureGeometryTrianglesDataKHR& t = geometry.geometry.triangles;
  t.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_TRIANGLES_DATA_KHR;
  t.vertexFormat = VK_FORMAT_R32G32B32_SFLOAT;
  t.vertexData.deviceAddress = vertices;
  t.vertexStride = 3 * sizeof(float);
  t.maxVertex = vertex_count - 1;
  t.indexType = VK_INDEX_TYPE_UINT32;
  t.indexData.deviceAddress = indices;
  return geometry;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

Status RayTracer::build_triangle_blas(const std::vector<float>& positions, const std::vector<uint32_t>& indices,
                                      AccelerationStructure& out, bool opaque) {
  if (Status s = check_triangles("build_triangle_blas", positions, indices); !s) return s;
  Buffer vbuf, ibuf;
  const VkBufferUsageFlags usage = VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR;
  Status s = ctx_.create_buffer(positions.size() * sizeof(float), vbuf, usage);
  if (s) s = ctx_.create_buffer(indices.size() * sizeof(uint32_t), ibuf, usage);
  if (s) {
    std::memcpy(vbuf.mapped, positions.data(), positions.size() * sizeof(float));
    std::memcpy(ibuf.mapped, indices.data(), indices.size() * sizeof(uint32_t));
    const VkAccelerationStructureGeometryKHR geometry =
        triangle_geometry(vbuf.address, uint32_t(positions.size() / 3), ibuf.address, opaque);
    s = build(VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR, geometry, uint32_t(indices.size() / 3), out);
  }
  ctx_.destroy_buffer(vbuf);
  ctx_.destroy_buffer(ibuf);
  return s;
}


Status RayTracer::triangle_blas_sizes(uint32_t vertex_count, uint32_t triangle_count,
                                      VkBuildAccelerationStructureFlagsKHR flags, BlasSizes& out) {
  out = BlasSizes();
  if (!ctx_.device()) return Status::error("triangle_blas_sizes: context not initialized");
  if (vertex_count == 0 || triangle_count == 0)
    return Status::error("triangle_blas_sizes: %u vertices, %u triangles", vertex_count, triangle_count);
  // Addresses are ignored by the size query.
  const VkAccelerationStructureGeometryKHR geometry = triangle_geometry(0, vertex_count, 0);
  VkAccelerationStructureBuildGeometryInfoKHR info{};
  info.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR;
  info.type = VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR;
  info.flags = flags;
  info.mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR;
  info.geometryCount = 1;
  info.pGeometries = &geometry;
  VkAccelerationStructureBuildSizesInfoKHR sizes{};
  sizes.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR;
  vkGetAccelerationStructureBuildSizesKHR(ctx_.device(), VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &info,
                                          &triangle_count, &sizes);
  out.acceleration_structure = sizes.accelerationStructureSize;
  out.build_scratch = sizes.buildScratchSize;
  out.update_scratch = sizes.updateScratchSize;
  return Status::ok();
}

Status RayTracer::build_compacted_triangle_blas(const std::vector<float>& positions,
                                                const std::vector<uint32_t>& indices, AccelerationStructure& out,
                                                CompactionReport& report) {
  out = AccelerationStructure();
  report = CompactionReport();
  Status s = check_triangles("build_compacted_triangle_blas", positions, indices);
  if (!s) return s;
  const uint32_t vertex_count = uint32_t(positions.size() / 3), triangle_count = uint32_t(indices.size() / 3);
  const VkBuildAccelerationStructureFlagsKHR flags =
      VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR |
      VK_BUILD_ACCELERATION_STRUCTURE_ALLOW_COMPACTION_BIT_KHR;
  if (triangle_count > as_props_.maxPrimitiveCount)
    return Status::error("build_compacted_triangle_blas: %u triangles exceed the device's maxPrimitiveCount %llu",
                         triangle_count, static_cast<unsigned long long>(as_props_.maxPrimitiveCount));
  s = triangle_blas_sizes(vertex_count, triangle_count, flags, report.sizes);
  if (!s) return s;
  const uint64_t max_allocation = ctx_.buffer_limits().max_allocation;
  const VkDeviceSize largest = std::max(report.sizes.acceleration_structure, report.sizes.build_scratch);
  if (largest > max_allocation)
    return Status::error("build_compacted_triangle_blas: the BLAS of %u triangles needs a %llu-byte buffer, more "
                         "than the device's maxMemoryAllocationSize %llu", triangle_count,
                         static_cast<unsigned long long>(largest), static_cast<unsigned long long>(max_allocation));

  Buffer vbuf, ibuf, scratch;
  AccelerationStructure full;
  VkQueryPool query = VK_NULL_HANDLE;
  const VkBufferUsageFlags input_usage = VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR;
  const VkDeviceSize scratch_align = as_props_.minAccelerationStructureScratchOffsetAlignment;
  s = ctx_.create_buffer(positions.size() * sizeof(float), vbuf, input_usage);
  if (s) s = ctx_.create_buffer(indices.size() * sizeof(uint32_t), ibuf, input_usage);
  if (s) s = ctx_.create_buffer(size_t(report.sizes.build_scratch + scratch_align), scratch);
  if (s)
    s = ctx_.create_buffer(size_t(report.sizes.acceleration_structure), full.storage,
                           VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR);
  VkResult r = VK_SUCCESS;
  if (s) {
    std::memcpy(vbuf.mapped, positions.data(), positions.size() * sizeof(float));
    std::memcpy(ibuf.mapped, indices.data(), indices.size() * sizeof(uint32_t));
    s = create_acceleration_structure(ctx_.device(), full.storage.buffer, report.sizes.acceleration_structure,
                                      VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR, full.handle);
  }
  if (s) {
    VkQueryPoolCreateInfo qpi{};
    qpi.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
    qpi.queryType = VK_QUERY_TYPE_ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR;
    qpi.queryCount = 1;
    r = vkCreateQueryPool(ctx_.device(), &qpi, nullptr, &query);
    if (r != VK_SUCCESS)
      s = Status::error("vkCreateQueryPool(compacted size) failed (VkResult %d)", static_cast<int>(r));
  }
  if (s) {
    const VkAccelerationStructureGeometryKHR geometry = triangle_geometry(vbuf.address, vertex_count, ibuf.address);
    VkAccelerationStructureBuildGeometryInfoKHR info{};
    info.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR;
    info.type = VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR;
    info.flags = flags;
    info.mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR;
    info.geometryCount = 1;
    info.pGeometries = &geometry;
    info.dstAccelerationStructure = full.handle;
    info.scratchData.deviceAddress = align_up(scratch.address, scratch_align);
    VkAccelerationStructureBuildRangeInfoKHR range{};
    range.primitiveCount = triangle_count;
    const VkAccelerationStructureBuildRangeInfoKHR* ranges = &range;
    const auto t0 = std::chrono::steady_clock::now();
    s = ctx_.submit("BLAS build with compaction", [&](VkCommandBuffer cmd) {
      vkCmdResetQueryPool(cmd, query, 0, 1);
      vkCmdBuildAccelerationStructuresKHR(cmd, 1, &info, &ranges);
      as_barrier(cmd);
      vkCmdWriteAccelerationStructuresPropertiesKHR(cmd, 1, &full.handle,
                                                    VK_QUERY_TYPE_ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR, query, 0);
    });
    report.build_seconds = seconds_since(t0);
  }
  ctx_.destroy_buffer(scratch);
  ctx_.destroy_buffer(vbuf);
  ctx_.destroy_buffer(ibuf);
  if (s) {
    uint64_t compacted = 0;
    r = vkGetQueryPoolResults(ctx_.device(), query, 0, 1, sizeof(compacted), &compacted, sizeof(compacted),
                              VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
    if (r != VK_SUCCESS)
      s = Status::error("vkGetQueryPoolResults(compacted size) failed (VkResult %d)", static_cast<int>(r));
    else if (compacted == 0 || compacted > report.sizes.acceleration_structure)
      s = Status::error("the driver reports a compacted size of %llu bytes for a %llu-byte BLAS",
                        static_cast<unsigned long long>(compacted),
                        static_cast<unsigned long long>(report.sizes.acceleration_structure));
    report.compacted = compacted;
  }
  if (query) vkDestroyQueryPool(ctx_.device(), query, nullptr);
  if (s) s = ctx_.create_buffer(size_t(report.compacted), out.storage,
                                VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR);
  if (s)
    s = create_acceleration_structure(ctx_.device(), out.storage.buffer, report.compacted,
                                      VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR, out.handle);
  if (s) {
    VkCopyAccelerationStructureInfoKHR copy{};
    copy.sType = VK_STRUCTURE_TYPE_COPY_ACCELERATION_STRUCTURE_INFO_KHR;
    copy.src = full.handle;
    copy.dst = out.handle;
    copy.mode = VK_COPY_ACCELERATION_STRUCTURE_MODE_COMPACT_KHR;
    const auto t0 = std::chrono::steady_clock::now();
    s = ctx_.submit("BLAS compaction", [&](VkCommandBuffer cmd) {
      vkCmdCopyAccelerationStructureKHR(cmd, &copy);
      as_barrier(cmd);
    });
    report.compact_seconds = seconds_since(t0);
  }
  destroy(full);
  if (!s) {
    destroy(out);
    return s;
  }
  VkAccelerationStructureDeviceAddressInfoKHR dai{};
  dai.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_DEVICE_ADDRESS_INFO_KHR;
  dai.accelerationStructure = out.handle;
  out.address = vkGetAccelerationStructureDeviceAddressKHR(ctx_.device(), &dai);
  out.primitive_count = triangle_count;
  return Status::ok();
}

namespace {

// The instances geometry of a TLAS build over records at device address `input`.
VkAccelerationStructureGeometryKHR instances_geometry(VkDeviceAddress input) {
  VkAccelerationStructureGeometryKHR geometry{};
  geometry.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR;
  geometry.geometryType = VK_GEOMETRY_TYPE_INSTANCES_KHR;
  geometry.geometry.instances.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_INSTANCES_DATA_KHR;
  geometry.geometry.instances.arrayOfPointers = VK_FALSE;
  geometry.geometry.instances.data.deviceAddress = input;
  return geometry;
}

}  // namespace

Status RayTracer::update_tlas(const std::vector<VkAccelerationStructureInstanceKHR>& records,
                              AccelerationStructure& tlas) {
  if (!tlas.handle || !tlas.updatable) return Status::error("update_tlas: the TLAS was not built with allow_update");
  if (records.size() != tlas.primitive_count)
    return Status::error("update_tlas: %zu instances, the TLAS was built with %u", records.size(),
                         tlas.primitive_count);
  for (size_t i = 0; i < records.size(); ++i)
    if (!records[i].accelerationStructureReference) return Status::error("update_tlas: instance %zu has no BLAS", i);
  Buffer input, scratch;
  Status s = ctx_.create_buffer(records.size() * sizeof(VkAccelerationStructureInstanceKHR), input,
                                VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR);
  if (!s) return s;
  std::memcpy(input.mapped, records.data(), records.size() * sizeof(VkAccelerationStructureInstanceKHR));
  const VkAccelerationStructureGeometryKHR geometry = instances_geometry(input.address);
  VkAccelerationStructureBuildGeometryInfoKHR info{};
  info.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR;
  info.type = VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR;
  info.flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR |
               VK_BUILD_ACCELERATION_STRUCTURE_ALLOW_UPDATE_BIT_KHR;
  info.mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE_KHR;
  info.srcAccelerationStructure = tlas.handle;
  info.dstAccelerationStructure = tlas.handle;
  info.geometryCount = 1;
  info.pGeometries = &geometry;
  const uint32_t count = tlas.primitive_count;
  VkAccelerationStructureBuildSizesInfoKHR sizes{};
  sizes.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR;
  vkGetAccelerationStructureBuildSizesKHR(ctx_.device(), VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &info,
                                          &count, &sizes);
  const VkDeviceSize scratch_align = as_props_.minAccelerationStructureScratchOffsetAlignment;
  s = ctx_.create_buffer(size_t(sizes.updateScratchSize + scratch_align), scratch);
  if (s) {
    info.scratchData.deviceAddress = align_up(scratch.address, scratch_align);
    VkAccelerationStructureBuildRangeInfoKHR range{};
    range.primitiveCount = count;
    const VkAccelerationStructureBuildRangeInfoKHR* ranges = &range;
    s = ctx_.submit("TLAS update", [&](VkCommandBuffer cmd) {
      vkCmdBuildAccelerationStructuresKHR(cmd, 1, &info, &ranges);
      as_barrier(cmd);
    });
  }
  ctx_.destroy_buffer(scratch);
  ctx_.destroy_buffer(input);
  return s;
}

Status RayTracer::build_tlas(const std::vector<VkAccelerationStructureInstanceKHR>& records,
                             AccelerationStructure& out, bool allow_update) {
  if (records.empty()) return Status::error("build_tlas: no instances");
  for (size_t i = 0; i < records.size(); ++i)
    if (!records[i].accelerationStructureReference) return Status::error("build_tlas: instance %zu has no BLAS", i);
  Buffer input;
  Status s = ctx_.create_buffer(records.size() * sizeof(VkAccelerationStructureInstanceKHR), input,
                                VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR);
  if (!s) return s;
  std::memcpy(input.mapped, records.data(), records.size() * sizeof(VkAccelerationStructureInstanceKHR));
  const VkAccelerationStructureGeometryKHR geometry = instances_geometry(input.address);
  s = build(VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR, geometry, uint32_t(records.size()), out, allow_update);
  ctx_.destroy_buffer(input);
  return s;
}

void RayTracer::destroy(AccelerationStructure& as) {
  if (as.handle) vkDestroyAccelerationStructureKHR(ctx_.device(), as.handle, nullptr);
  ctx_.destroy_buffer(as.storage);
  as = AccelerationStructure();
}

namespace {

// Raygen, miss, closest hit, intersection, triangle closest hit, triangle any hit.
constexpr uint32_t kMaxStages = 6;

// Destroys the shader modules that were created (null entries are skipped).
void destroy_shader_modules(VkDevice device, const VkShaderModule (&modules)[kMaxStages]) {
  for (VkShaderModule m : modules)
    if (m) vkDestroyShaderModule(device, m, nullptr);
}

// The modules of the first `stage_count` shaders of raygen, miss, closest hit, intersection, triangle
// closest hit and triangle any hit, into `modules`; on failure none is left.
Status create_shader_modules(Context& ctx, const RtShaders& shaders, uint32_t stage_count,
                             VkShaderModule (&modules)[kMaxStages]) {
  const Spirv* code[kMaxStages] = {&shaders.raygen, &shaders.miss, &shaders.closest_hit, &shaders.intersection,
                                   &shaders.triangle_closest_hit, &shaders.triangle_any_hit};
  const char* stage_names[kMaxStages] = {"raygen", "miss", "closest hit", "intersection", "triangle closest hit",
                                         "triangle any hit"};
  Status s = Status::ok();
  for (uint32_t i = 0; i < stage_count && s; ++i)
    s = ctx.create_shader_module(*code[i], modules[i]).context(std::string("create_pipeline: ") + stage_names[i]);
  if (!s) destroy_shader_modules(ctx.device(), modules);
  return s;
}

// The set layout (the TLAS at binding 0, for raygen), a pool with its one set, and the pipeline layout
// (with a push-constant range of `push_size` bytes when not 0), into `out`; stops at the first failure.
VkResult create_layouts(VkDevice device, uint32_t push_size, RtPipeline& out) {
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
  VkResult r = vkCreateDescriptorSetLayout(device, &sli, nullptr, &out.set_layout);
  if (r == VK_SUCCESS) r = vkCreateDescriptorPool(device, &dpi, nullptr, &out.pool);
  if (r == VK_SUCCESS) {
    VkDescriptorSetAllocateInfo dsa{};
    dsa.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    dsa.descriptorPool = out.pool;
    dsa.descriptorSetCount = 1;
    dsa.pSetLayouts = &out.set_layout;
    r = vkAllocateDescriptorSets(device, &dsa, &out.set);
  }
  if (r == VK_SUCCESS) {
    VkPipelineLayoutCreateInfo lci{};
    lci.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    lci.setLayoutCount = 1;
    lci.pSetLayouts = &out.set_layout;
    lci.pushConstantRangeCount = push_size > 0 ? 1 : 0;
    lci.pPushConstantRanges = &range;
    r = vkCreatePipelineLayout(device, &lci, nullptr, &out.layout);
  }
  return r;
}

// The pipeline of the first `stage_count` modules (entry "main") in the first `group_count` groups of
// raygen, miss, the procedural hit group and the triangle hit group, with out.layout, into out.pipeline
// (its creation timed in out.create_seconds).
VkResult create_rt_pipeline(VkDevice device, const VkShaderModule (&modules)[kMaxStages], uint32_t stage_count,
                            uint32_t group_count, RtPipeline& out) {
  const VkShaderStageFlagBits stages[kMaxStages] = {VK_SHADER_STAGE_RAYGEN_BIT_KHR, VK_SHADER_STAGE_MISS_BIT_KHR,
                                                    VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR,
                                                    VK_SHADER_STAGE_INTERSECTION_BIT_KHR,
                                                    VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR, VK_SHADER_STAGE_ANY_HIT_BIT_KHR};
  VkPipelineShaderStageCreateInfo stage_info[kMaxStages] = {};
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
  if (stage_count > 5) groups[3].anyHitShader = 5;
  VkRayTracingPipelineCreateInfoKHR pci{};
  pci.sType = VK_STRUCTURE_TYPE_RAY_TRACING_PIPELINE_CREATE_INFO_KHR;
  pci.stageCount = stage_count;
  pci.pStages = stage_info;
  pci.groupCount = group_count;
  pci.pGroups = groups;
  pci.maxPipelineRayRecursionDepth = 1;
  pci.layout = out.layout;
  const auto t0 = std::chrono::steady_clock::now();
  VkResult r = vkCreateRayTracingPipelinesKHR(device, VK_NULL_HANDLE, VK_NULL_HANDLE, 1, &pci, nullptr,
                                              &out.pipeline);
  out.create_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

// The shader binding table of out.pipeline's `group_count` groups (with the triangle hit group when
// `triangles`), into out.sbt and out's regions.
Status create_sbt(Context& ctx, const VkPhysicalDeviceRayTracingPipelinePropertiesKHR& props,
                  const RtShaders& shaders, bool triangles, uint32_t group_count, RtPipeline& out) {
  // Shader binding table: one record per group; each region starts at shaderGroupBaseAlignment,
  // records are handle-aligned; the raygen region's size equals its stride (a spec requirement).
  const uint32_t handle_size = props.shaderGroupHandleSize;
  std::vector<uint8_t> handles(size_t(group_count) * handle_size);
  VkResult r = vkGetRayTracingShaderGroupHandlesKHR(ctx.device(), out.pipeline, 0, group_count, handles.size(),
                                                    handles.data());
  if (r != VK_SUCCESS)
    return Status::error("vkGetRayTracingShaderGroupHandlesKHR failed (VkResult %d)", static_cast<int>(r));
  // The hit region: the procedural records (each handle + its data), then the triangle group's.
  const size_t procedural = std::max<size_t>(1, shaders.procedural_records.size());
  size_t data_bytes = 0;
  for (const std::vector<uint8_t>& d : shaders.procedural_records) data_bytes = std::max(data_bytes, d.size());
  const VkDeviceSize base_align = props.shaderGroupBaseAlignment;
  const VkDeviceSize record_stride = align_up(handle_size, props.shaderGroupHandleAlignment);
  const VkDeviceSize hit_stride = align_up(handle_size + data_bytes, props.shaderGroupHandleAlignment);
  if (hit_stride > props.maxShaderGroupStride)
    return Status::error("create_pipeline: hit record stride %llu exceeds maxShaderGroupStride %u",
                         static_cast<unsigned long long>(hit_stride), props.maxShaderGroupStride);
  const VkDeviceSize region = align_up(record_stride, base_align);
  const size_t hit_records = procedural + (triangles ? 1 : 0);
  const VkDeviceSize hit_region = align_up(hit_stride * hit_records, base_align);
  Status s = ctx.create_buffer(size_t(2 * region + hit_region + base_align), out.sbt,
                               VK_BUFFER_USAGE_SHADER_BINDING_TABLE_BIT_KHR);
  if (!s) return s;
  const VkDeviceAddress base = align_up(out.sbt.address, base_align);
  auto* bytes = static_cast<uint8_t*>(out.sbt.mapped) + (base - out.sbt.address);
  for (size_t g = 0; g < 2; ++g) std::memcpy(bytes + g * region, handles.data() + g * handle_size, handle_size);
  uint8_t* hits = bytes + 2 * region;
  for (size_t i = 0; i < procedural; ++i) {
    std::memcpy(hits + i * hit_stride, handles.data() + 2 * handle_size, handle_size);
    if (i < shaders.procedural_records.size() && !shaders.procedural_records[i].empty())
      std::memcpy(hits + i * hit_stride + handle_size, shaders.procedural_records[i].data(),
                  shaders.procedural_records[i].size());
  }
  if (triangles) std::memcpy(hits + procedural * hit_stride, handles.data() + 3 * handle_size, handle_size);
  out.triangle_sbt_offset = uint32_t(procedural);
  out.raygen_region = {base, region, region};
  out.miss_region = {base + region, record_stride, record_stride};
  out.hit_region = {base + 2 * region, hit_stride, hit_stride * hit_records};
  out.callable_region = {0, 0, 0};
  return Status::ok();
}

}  // namespace

Status RayTracer::create_pipeline(const RtShaders& shaders, uint32_t push_size, RtPipeline& out) {
  out = RtPipeline();
  if (!ctx_.device() || props_.shaderGroupHandleSize == 0)
    return Status::error("create_pipeline: RayTracer not initialized");
  const bool triangles = shaders.triangle_closest_hit.code != nullptr;
  if (shaders.triangle_any_hit.code && !triangles)
    return Status::error("create_pipeline: a triangle any-hit shader needs a triangle closest-hit shader");
  const uint32_t stage_count = triangles ? (shaders.triangle_any_hit.code ? 6 : 5) : 4, group_count = triangles ? 4 : 3;
  VkShaderModule modules[kMaxStages] = {};
  Status s = create_shader_modules(ctx_, shaders, stage_count, modules);
  if (!s) return s;

  VkResult r = create_layouts(ctx_.device(), push_size, out);
  if (r != VK_SUCCESS) {
    destroy_shader_modules(ctx_.device(), modules);
    destroy(out);
    return Status::error("descriptor set / pipeline layout creation failed (VkResult %d)", static_cast<int>(r));
  }

  r = create_rt_pipeline(ctx_.device(), modules, stage_count, group_count, out);
  destroy_shader_modules(ctx_.device(), modules);
  if (r != VK_SUCCESS) {
    destroy(out);
    return Status::error("vkCreateRayTracingPipelinesKHR failed (VkResult %d)", static_cast<int>(r));
  }
  out.push_size = push_size;

  s = create_sbt(ctx_, props_, shaders, triangles, group_count, out);
  if (!s) destroy(out);
  return s;
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
  return trace_with_timestamps(p, tlas, push, width, VK_NULL_HANDLE);
}

Status RayTracer::trace_timed(RtPipeline& p, const AccelerationStructure& tlas, const void* push, uint32_t width,
                              double& device_seconds) {
  device_seconds = -1.0;
  if (!ctx_.device()) return Status::error("trace_timed: context not initialized");
  uint32_t family_count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(ctx_.physical_device(), &family_count, nullptr);
  std::vector<VkQueueFamilyProperties> families(family_count);
  vkGetPhysicalDeviceQueueFamilyProperties(ctx_.physical_device(), &family_count, families.data());
  const uint32_t valid_bits =
      ctx_.queue_family() < family_count ? families[ctx_.queue_family()].timestampValidBits : 0u;
  if (valid_bits == 0) return trace(p, tlas, push, width);
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(ctx_.physical_device(), &props);

  VkQueryPoolCreateInfo qci{};
  qci.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
  qci.queryType = VK_QUERY_TYPE_TIMESTAMP;
  qci.queryCount = 2;
  VkQueryPool pool = VK_NULL_HANDLE;
  LSNIF_VK_CHECK(vkCreateQueryPool(ctx_.device(), &qci, nullptr, &pool));
  Status s = trace_with_timestamps(p, tlas, push, width, pool);
  if (s) {
    uint64_t ticks[2] = {};
    const VkResult r = vkGetQueryPoolResults(ctx_.device(), pool, 0, 2, sizeof(ticks), ticks, sizeof(uint64_t),
                                             VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
    if (r != VK_SUCCESS) {
      s = Status::error("vkGetQueryPoolResults (trace timestamps) failed (VkResult %d)", static_cast<int>(r));
    } else {
      const uint64_t mask = valid_bits >= 64 ? ~uint64_t(0) : (uint64_t(1) << valid_bits) - 1;
      device_seconds = double((ticks[1] - ticks[0]) & mask) * double(props.limits.timestampPeriod) * 1e-9;
    }
  }
  vkDestroyQueryPool(ctx_.device(), pool, nullptr);
  return s;
}

Status RayTracer::trace_with_timestamps(RtPipeline& p, const AccelerationStructure& tlas, const void* push,
                                        uint32_t width, VkQueryPool timestamps) {
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
    if (timestamps) {
      vkCmdResetQueryPool(cmd, timestamps, 0, 2);
      vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, timestamps, 0);
    }
    vkCmdTraceRaysKHR(cmd, &p.raygen_region, &p.miss_region, &p.hit_region, &p.callable_region, width, 1, 1);
    if (timestamps) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, timestamps, 1);
    VkMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_RAY_TRACING_SHADER_BIT_KHR, VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                         &barrier, 0, nullptr, 0, nullptr);
  });
}

}  // namespace lsnif::vk
