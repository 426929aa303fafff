// device_choice.h -- which Vulkan physical device the Vulkan context (context.h), and so every lsnif
// command and GPU test, runs on. Plain data in, an index out, no Vulkan calls, so that the ranking
// and the selector are testable without a device:
//   - a device qualifies when it offers what the context needs (DeviceNeeds): a compute queue and
//     the parts of LSNIF's own requirements that every context's device is created with (Vulkan 1.2,
//     bufferDeviceAddress, shaderInt64); for ray tracing everything LSNIF needs, as the plugin
//     answers it (lsnifQueryDeviceSupport of lsnif.h: Vulkan 1.2, its extensions and features), so
//     that the tools and the plugin have one definition of "LSNIF can run on this device"; for a
//     window also VK_KHR_swapchain;
//   - automatic choice (empty selector): the first qualifying discrete GPU, else integrated GPU,
//     else virtual GPU, else CPU device (lavapipe), else any other qualifying device;
//   - a selector picks one device: all digits is an index in enumeration order (vkEnumeratePhysicalDevices,
//     the order of `lsnif devices`); anything else a case-insensitive part of the device name (or
//     one of the type words cpu, discrete, integrated, virtual). It must match exactly one device,
//     and that device must qualify: there is no fallback to another device.
// Errors name the selector, the devices and what each one lacks.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "lsnif/format/status.h"

namespace lsnif::vk {

enum class DeviceType { other, integrated_gpu, discrete_gpu, virtual_gpu, cpu };

// "discrete GPU", "integrated GPU", "virtual GPU", "CPU" or "other".
const char* device_type_name(DeviceType type);

// What a physical device offers (not what is enabled); context.h query_device_info fills it: the
// plugin's answer for what LSNIF needs, the context's own probe for the rest.
struct DeviceInfo {
  std::string name;  // VkPhysicalDeviceProperties::deviceName
  DeviceType type = DeviceType::other;
  // LSNIF's verdict, from the plugin (LsnifDeviceSupport::missing of lsnifQueryDeviceSupport): what
  // LSNIF needs that the device lacks, one item each in the plugin's wording and order ("Vulkan 1.2",
  // "extension VK_KHR_...", "feature accelerationStructure", ..., "feature shaderInt64"); empty
  // when LSNIF can run on the device.
  std::vector<std::string> lsnif_missing;
  bool ray_query = false;  // LsnifDeviceSupport::rayQuery: VK_KHR_ray_query with feature rayQuery
  // LsnifDeviceSupport::rayTraversalPrimitiveCulling (lsnifCmdQuery's ray-tracing broad phase)
  bool primitive_culling = false;
  // LsnifDeviceSupport::cooperativeMatrixMlpNV: the cooperative-matrix MLP kernel could run (the
  // context then enables VK_NV_cooperative_matrix, cooperativeMatrix and shaderFloat16)
  bool coopmat_mlp = false;
  // The context's own, beyond what LSNIF needs.
  bool compute_queue = false;         // some queue family has VK_QUEUE_COMPUTE_BIT
  uint32_t compute_queue_family = 0;  // the first such family (when compute_queue)
  bool scalar_block_layout = false;   // enabled when offered, not required
  bool ext_swapchain = false;         // VK_KHR_swapchain
  bool ext_spirv_1_4 = false;         // enabled with ray tracing when offered, not required (core in 1.2)
};

// The items of the plugin's list LsnifDeviceSupport::missing ("a, b, c" -> {"a", "b", "c"}; "" -> {}).
std::vector<std::string> missing_items(const std::string& list);

// What the device is wanted for (ContextOptions::ray_tracing, ContextOptions::swapchain).
struct DeviceNeeds {
  bool ray_tracing = false;
  bool swapchain = false;
};

// What `device` lacks for `needs`, empty when it qualifies: "a compute queue"; then of the plugin's
// items (DeviceInfo::lsnif_missing) first those every context's device needs ("Vulkan 1.2",
// "feature bufferDeviceAddress", "feature shaderInt64"), then, for ray tracing, the others in the
// plugin's order ("extension VK_KHR_...", "feature ..."); then "extension VK_KHR_swapchain".
std::vector<std::string> missing_for(const DeviceInfo& device, const DeviceNeeds& needs);

// The index into `devices` (enumeration order) of the device to use for `needs`: the automatic
// choice when `selector` is empty, else the one device the selector names (see the top of this
// file). Errors: no devices; no qualifying device (naming each device and what it lacks); an index
// out of range, a name matching no device or several (naming the devices); a selected device that
// does not qualify (naming what it lacks).
Status choose_device(const std::vector<DeviceInfo>& devices, const DeviceNeeds& needs,
                     const std::string& selector, size_t& chosen);

}  // namespace lsnif::vk
