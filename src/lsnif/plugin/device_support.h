// device_support.h -- what the LSNIF ray-tracing path needs from a Vulkan physical device, queried
// once into a plain struct (so the message building is testable without a device), the check that
// names every missing extension or feature, and the feature-chain helpers of lsnif.h.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <vulkan/vulkan_core.h>

#include "lsnif/format/status.h"
#include "lsnif/lsnif.h"
#include "lsnif/plugin/vk_dispatch.h"

namespace lsnif::plugin {

// The device extensions LSNIF needs enabled (lsnifGetRequiredDeviceExtensions).
extern const char* const kRequiredDeviceExtensions[3];

// What a physical device offers (not what an application enabled). Filled by query_device_support.
struct DeviceSupport {
  std::string name;
  uint32_t api_version = 0;  // VkPhysicalDeviceProperties::apiVersion
  // Extensions required by the ray-tracing pipeline path.
  bool ext_acceleration_structure = false;    // VK_KHR_acceleration_structure
  bool ext_ray_tracing_pipeline = false;      // VK_KHR_ray_tracing_pipeline
  bool ext_deferred_host_operations = false;  // VK_KHR_deferred_host_operations
  // Features required by it.
  bool acceleration_structure = false;  // VkPhysicalDeviceAccelerationStructureFeaturesKHR
  bool ray_tracing_pipeline = false;    // VkPhysicalDeviceRayTracingPipelineFeaturesKHR
  bool buffer_device_address = false;   // VkPhysicalDeviceVulkan12Features
  bool shader_int64 = false;            // VkPhysicalDeviceFeatures
  // Other paths (reported by `lsnif devices`, not required by the plugin).
  bool ext_ray_query = false;               // VK_KHR_ray_query (lsnifCmdQuery)
  bool ray_query = false;                   // VkPhysicalDeviceRayQueryFeaturesKHR::rayQuery
  // VkPhysicalDeviceRayTracingPipelineFeaturesKHR::rayTraversalPrimitiveCulling (the ray-tracing
  // broad phase of lsnifCmdQuery)
  bool ray_traversal_primitive_culling = false;
  bool ext_nv_cooperative_matrix = false;   // VK_NV_cooperative_matrix
  // What the cooperative-matrix MLP kernel (src/lsnif/shaders/lsnif_mlp_coopmat.glsl) needs beyond
  // the extension: missing_for_coopmat_mlp.
  bool nv_cooperative_matrix = false;       // VkPhysicalDeviceCooperativeMatrixFeaturesNV::cooperativeMatrix
  bool shader_float16 = false;              // VkPhysicalDeviceVulkan12Features::shaderFloat16
  bool nv_matrix_16x8x16 = false;  // a subgroup shape 16x8x16, A and B fp16, C and D fp32
  uint32_t subgroup_size = 0;               // VkPhysicalDeviceSubgroupProperties
  bool subgroup_compute_basic = false;      // basic subgroup operations in compute shaders
  uint32_t max_compute_shared_memory = 0;   // VkPhysicalDeviceLimits::maxComputeSharedMemorySize
  bool ext_khr_cooperative_matrix = false;  // VK_KHR_cooperative_matrix
  bool ext_nv_cooperative_vector = false;   // VK_NV_cooperative_vector
};

// Reads the device's name, API version, extensions and features. Feature structs of Vulkan 1.2
// are queried only on a 1.2+ device (else the 1.2 features read as missing).
DeviceSupport query_device_support(const InstanceDispatch& vk, VkPhysicalDevice physical);

// The pieces of the ray-tracing pipeline path that `support` lacks, in the order listed below
// ("Vulkan 1.2", "extension VK_KHR_...", "feature ..."); empty when it has them all.
std::vector<std::string> missing_for_ray_tracing(const DeviceSupport& support);

// The shared memory of the cooperative-matrix MLP kernel's workgroup, in bytes.
constexpr uint32_t kCoopmatMlpSharedBytes = 49152;

// What the cooperative-matrix MLP kernel (LSNIF_QUERY_PIPELINE_CREATE_COOPERATIVE_MATRIX_MLP_BIT_NV)
// needs that `support` lacks, in this order: "extension VK_NV_cooperative_matrix", "feature
// cooperativeMatrix", "feature shaderFloat16", "a 16x8x16 fp16 x fp16 + fp32 subgroup shape",
// "subgroup size 32 or 64 with basic operations in compute", "49152 bytes of compute shared
// memory"; empty when it can run.
std::vector<std::string> missing_for_coopmat_mlp(const DeviceSupport& support);

// Ok when `support` has every extension and feature the LSNIF ray-tracing pipeline path needs
// (Vulkan 1.2, VK_KHR_acceleration_structure, VK_KHR_ray_tracing_pipeline,
// VK_KHR_deferred_host_operations, accelerationStructure, rayTracingPipeline, bufferDeviceAddress,
// shaderInt64); else an error naming the device and listing exactly the missing ones, comma
// separated, in that order.
Status describe_device_support(const DeviceSupport& support);

// The most structures a pNext chain may have here: every walk stops there.
constexpr size_t kMaxChainLength = 256;

// Why the chain starting at `chain` (a VkDeviceCreateInfo or a feature struct) cannot be walked or
// read, prefixed with `name`: it loops (a struct points back to one before it), it is longer than
// kMaxChainLength, a struct LSNIF reads (the feature structs below, VkDeviceCreateInfo) appears
// twice, or a VkDeviceCreateInfo with pEnabledFeatures also chains a VkPhysicalDeviceFeatures2.
// Empty when none of these. Every entry point that takes a chain checks it first; the walks below
// are bounded all the same (they stop at a loop).
std::string chain_problem(const void* chain, const std::string& name);

// The features LSNIF needs that the feature chain starting at `chain` (a VkDeviceCreateInfo or a
// feature struct, as given to vkCreateDevice) does not enable, as "feature NAME" in the order of
// missing_for_ray_tracing; a feature whose struct is absent from the chain counts as not enabled.
// `core`, when not null, holds the core features instead of the chain (LsnifContextCoreFeaturesInfo).
std::vector<std::string> features_not_enabled(const void* chain, const VkPhysicalDeviceFeatures* core = nullptr);

// True when the feature chain starting at `chain` enables VkPhysicalDeviceRayQueryFeaturesKHR::rayQuery.
bool ray_query_enabled(const void* chain);
// True when the feature chain starting at `chain` enables
// VkPhysicalDeviceRayTracingPipelineFeaturesKHR::rayTraversalPrimitiveCulling.
bool primitive_culling_enabled(const void* chain);
// The features of the cooperative-matrix MLP kernel the chain does not enable ("feature
// cooperativeMatrix", "feature shaderFloat16"), in that order.
std::vector<std::string> coopmat_mlp_features_not_enabled(const void* chain);

// lsnifEnableDeviceFeatures: sets LSNIF's features in the structs of the chain; returns the names
// of the structs it needed but did not find (empty: all set).
// With `core` (lsnifEnableDeviceFeaturesWithCore) shaderInt64 is set there, not looked for in the
// chain.
std::vector<std::string> enable_device_features(void* chain, VkPhysicalDeviceFeatures* core = nullptr);
// Whether the chain reaches core features: a VkPhysicalDeviceFeatures2, or a VkDeviceCreateInfo
// whose pEnabledFeatures is set.
bool has_core_features(const void* chain);
// The table of lsnifGetRequiredDeviceFeatures, kRequiredFeatureCount entries.
inline constexpr uint32_t kRequiredFeatureCount = 4;
const LsnifFeatureRequirement* required_device_features();

// lsnifEnableDeviceFeaturesInCreateInfo: sets LSNIF's features in the structs of create_info's
// chain and appends, at the chain's end, the structs of `storage` it needed but did not find
// (storage.features2 takes over create_info.pEnabledFeatures, which becomes null).
void enable_device_features_appending(VkDeviceCreateInfo& create_info, LsnifDeviceFeatureStorage& storage);

// A hint for a message naming "feature shaderInt64" as not enabled in `chain`: the core features
// are in a VkDeviceCreateInfo's pEnabledFeatures that the chain does not reach (empty when the chain
// has core features).
std::string core_features_hint(const void* chain);

// "1.3.278" from a VK_MAKE_API_VERSION value.
std::string api_version_string(uint32_t version);

}  // namespace lsnif::plugin
