// raytracing.h -- ray tracing on the Vulkan context (context.h, initialized with init(true)) for
// the renderer, the tools, the benchmarks and the GPU tests: a TLAS of instance records built on the device
// (the LSNIF BLASes and instance records come from the plugin, src/lsnif/lsnif.h), a triangle BLAS
// (for mixed scenes), a ray-tracing pipeline of raygen, miss and one
// procedural hit group (closest hit + intersection) and optionally a triangle hit group with the TLAS at set 0 binding 0 (raygen) and
// one push-constant range visible to every stage, its shader binding table, and vkCmdTraceRaysKHR.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "lsnif/vulkan/context.h"

namespace lsnif::vk {

struct AccelerationStructure {
  VkAccelerationStructureKHR handle = VK_NULL_HANDLE;
  Buffer storage;
  VkDeviceAddress address = 0;  // vkGetAccelerationStructureDeviceAddressKHR
  bool updatable = false;       // built with ALLOW_UPDATE (update_tlas)
  uint32_t primitive_count = 0; // instances of a TLAS, triangles of a BLAS
};

// The shaders of a ray-tracing pipeline (create_pipeline) as SPIR-V in memory.
struct RtShaders {
  Spirv raygen, miss, closest_hit, intersection;
  Spirv triangle_closest_hit;  // optional (code null: no triangle hit group)
  // Optional, with triangle_closest_hit: the triangle hit group's any-hit shader, run on the
  // geometries built without VK_GEOMETRY_OPAQUE_BIT_KHR (build_triangle_blas with opaque false).
  Spirv triangle_any_hit;
  // Shader-record data of the procedural hit group's records (e.g. the model block address of
  // LSNIF_MODEL_LOOKUP_SHADER_RECORD); empty: one record without data.
  std::vector<std::vector<uint8_t>> procedural_records;
};

struct RtPipeline {
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  uint32_t push_size = 0;
  Buffer sbt;  // raygen | miss | hit group records, each region at shaderGroupBaseAlignment
  VkStridedDeviceAddressRegionKHR raygen_region{}, miss_region{}, hit_region{}, callable_region{};
  double create_seconds = 0;  // vkCreateRayTracingPipelinesKHR wall time
  uint32_t triangle_sbt_offset = 0;  // SBT record offset of the triangle hit group (when there is one)
};

// What the driver reports for a BLAS build (vkGetAccelerationStructureBuildSizesKHR, device build).
struct BlasSizes {
  VkDeviceSize acceleration_structure = 0;  // accelerationStructureSize
  VkDeviceSize build_scratch = 0;           // buildScratchSize
  VkDeviceSize update_scratch = 0;          // updateScratchSize
};

// A triangle BLAS built for compaction (build_compacted_triangle_blas).
struct CompactionReport {
  BlasSizes sizes;             // of the build (PREFER_FAST_TRACE | ALLOW_COMPACTION)
  VkDeviceSize compacted = 0;  // VK_QUERY_TYPE_ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR
  double build_seconds = 0;    // wall time of the build submission (lavapipe builds on the CPU)
  double compact_seconds = 0;  // wall time of the compacting copy
};

class RayTracer {
 public:
  // `context` must have been initialized with init(true) and outlive the tracer.
  explicit RayTracer(Context& context);
  // Reads the device's ray-tracing properties; fails if the context has no device.
  Status init();

  // A BLAS with one triangle geometry (float3 positions, uint32 indices, 3 per triangle), built on
  // the device: OPAQUE, or with `opaque` false without that flag (its hits run the hit group's
  // any-hit shader: alpha cut-outs). Fails on an empty mesh or an index out of range.
  Status build_triangle_blas(const std::vector<float>& positions, const std::vector<uint32_t>& indices,
                             AccelerationStructure& out, bool opaque = true);
  // The build sizes of one OPAQUE triangle geometry (float3 positions, uint32 indices) of
  // `vertex_count` vertices and `triangle_count` triangles built with `flags`; no device work.
  // Fails on a zero count or when the context has no device.
  Status triangle_blas_sizes(uint32_t vertex_count, uint32_t triangle_count,
                             VkBuildAccelerationStructureFlagsKHR flags, BlasSizes& out);
  // Like build_triangle_blas, but built with PREFER_FAST_TRACE | ALLOW_COMPACTION; its compacted
  // size is read with a VK_QUERY_TYPE_ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR query and the BLAS
  // is copied (VK_COPY_ACCELERATION_STRUCTURE_MODE_COMPACT_KHR) into `out`, whose storage has
  // exactly that size. The uncompacted BLAS, the inputs and the scratch are freed before it
  // returns. Same input errors as build_triangle_blas; also fails, before building, when the
  // triangles exceed maxPrimitiveCount or the BLAS or its scratch exceeds the device's
  // maxMemoryAllocationSize. Nothing is left allocated on failure.
  Status build_compacted_triangle_blas(const std::vector<float>& positions, const std::vector<uint32_t>& indices,
                                       AccelerationStructure& out, CompactionReport& report);
  // A TLAS of instance records (at least one; each with a BLAS address), built on the device. With
  // `allow_update`, built with ALLOW_UPDATE so that update_tlas can refit it.
  Status build_tlas(const std::vector<VkAccelerationStructureInstanceKHR>& instances, AccelerationStructure& out,
                    bool allow_update = false);
  // Refits `tlas` in place (VK_BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE_KHR, source = destination)
  // to new instance records, e.g. moved transforms, on the device, and waits. `tlas` must come from
  // build_tlas with allow_update and the same number of records; an error otherwise.
  Status update_tlas(const std::vector<VkAccelerationStructureInstanceKHR>& instances, AccelerationStructure& tlas);
  void destroy(AccelerationStructure& as);

  // The pipeline of `shaders` (entry "main"); max recursion depth 1. The procedural hit group
  // (closest_hit + intersection) has one SBT record per entry of shaders.procedural_records (SBT
  // record offsets 0 .. n-1, the entry's bytes after the group handle), or one record without data
  // when that list is empty; with shaders.triangle_closest_hit set, a triangle hit group of that
  // closest-hit shader follows at SBT record offset RtPipeline::triangle_sbt_offset.
  Status create_pipeline(const RtShaders& shaders, uint32_t push_size, RtPipeline& out);
  void destroy(RtPipeline& pipeline);
  // Binds `tlas` to set 0 binding 0, pushes `push`, traces width x 1 x 1 rays and waits; shader
  // writes are visible to the host when it returns.
  Status trace(RtPipeline& pipeline, const AccelerationStructure& tlas, const void* push, uint32_t width);
  // trace(), also measuring the trace on the device: `device_seconds` receives the time between
  // timestamps written right before vkCmdTraceRaysKHR (top of pipe) and after it (bottom of pipe),
  // scaled by timestampPeriod, or -1 when the queue family has no timestamps (timestampValidBits 0).
  Status trace_timed(RtPipeline& pipeline, const AccelerationStructure& tlas, const void* push, uint32_t width,
                     double& device_seconds);

  uint32_t handle_size() const { return props_.shaderGroupHandleSize; }
  uint32_t base_alignment() const { return props_.shaderGroupBaseAlignment; }
  uint32_t max_hit_attribute_size() const { return props_.maxRayHitAttributeSize; }
  // VkPhysicalDeviceAccelerationStructurePropertiesKHR::maxPrimitiveCount (triangles per BLAS).
  uint64_t max_primitive_count() const { return as_props_.maxPrimitiveCount; }

 private:
  Status build(VkAccelerationStructureTypeKHR type, const VkAccelerationStructureGeometryKHR& geometry,
               uint32_t primitive_count, AccelerationStructure& out, bool allow_update = false);
  // trace() with, when `timestamps` is not null, timestamps 0 and 1 of that 2-query pool written
  // around vkCmdTraceRaysKHR (the pool is reset in the same command buffer).
  Status trace_with_timestamps(RtPipeline& pipeline, const AccelerationStructure& tlas, const void* push,
                               uint32_t width, VkQueryPool timestamps);
  Context& ctx_;
  VkPhysicalDeviceRayTracingPipelinePropertiesKHR props_{};
  VkPhysicalDeviceAccelerationStructurePropertiesKHR as_props_{};
};

}  // namespace lsnif::vk
