// vk_raytracing.h -- a minimal Vulkan ray-tracing harness for the GPU tests and benchmarks, on top of
// ComputeContext (initialized with init(true)): a TLAS of instance records built on the device
// (the LSNIF BLASes and instance records come from the plugin, plugin/lsnif_vk.h), a triangle BLAS
// (for mixed scenes), a ray-tracing pipeline of raygen, miss and one
// procedural hit group (closest hit + intersection) and optionally a triangle hit group with the TLAS at set 0 binding 0 (raygen) and
// one push-constant range visible to every stage, its shader binding table, and vkCmdTraceRaysKHR.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "vk_compute.h"

namespace lsnif::vk {

struct AccelerationStructure {
  VkAccelerationStructureKHR handle = VK_NULL_HANDLE;
  Buffer storage;
  VkDeviceAddress address = 0;  // vkGetAccelerationStructureDeviceAddressKHR
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
};

class RayTracer {
 public:
  // `context` must have been initialized with init(true) and outlive the tracer.
  explicit RayTracer(ComputeContext& context);
  // Reads the device's ray-tracing properties; fails if the context has no device.
  Status init();

  // A BLAS with one OPAQUE triangle geometry (float3 positions, uint32 indices, 3 per triangle),
  // built on the device. Fails on an empty mesh or an index out of range.
  Status build_triangle_blas(const std::vector<float>& positions, const std::vector<uint32_t>& indices,
                             AccelerationStructure& out);
  // A TLAS of instance records (at least one; each with a BLAS address), built on the device.
  Status build_tlas(const std::vector<VkAccelerationStructureInstanceKHR>& instances, AccelerationStructure& out);
  void destroy(AccelerationStructure& as);

  // The pipeline from SPIR-V files (entry "main"); max recursion depth 1. Hit group 0 (SBT record
  // offset 0) is the procedural one (closest_hit + intersection); with a non-empty
  // `triangle_closest_hit`, hit group 1 (SBT record offset 1) is a triangle hit group of that
  // closest-hit shader.
  Status create_pipeline(const std::string& raygen, const std::string& miss, const std::string& closest_hit,
                         const std::string& intersection, uint32_t push_size, RtPipeline& out,
                         const std::string& triangle_closest_hit = "");
  void destroy(RtPipeline& pipeline);
  // Binds `tlas` to set 0 binding 0, pushes `push`, traces width x 1 x 1 rays and waits; shader
  // writes are visible to the host when it returns.
  Status trace(RtPipeline& pipeline, const AccelerationStructure& tlas, const void* push, uint32_t width);

  uint32_t handle_size() const { return props_.shaderGroupHandleSize; }
  uint32_t base_alignment() const { return props_.shaderGroupBaseAlignment; }
  uint32_t max_hit_attribute_size() const { return props_.maxRayHitAttributeSize; }

 private:
  Status build(VkAccelerationStructureTypeKHR type, const VkAccelerationStructureGeometryKHR& geometry,
               uint32_t primitive_count, AccelerationStructure& out);
  Status load_module(const std::string& path, VkShaderModule& out);
  ComputeContext& ctx_;
  VkPhysicalDeviceRayTracingPipelinePropertiesKHR props_{};
  VkPhysicalDeviceAccelerationStructurePropertiesKHR as_props_{};
};

}  // namespace lsnif::vk
