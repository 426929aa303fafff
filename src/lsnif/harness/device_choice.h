// device_choice.h -- which Vulkan physical device the harness (vk_compute.h), and so every lsnif
// command and GPU test, runs on. Plain data in, an index out, no Vulkan calls, so that the ranking
// and the selector are testable without a device:
//   - a device qualifies when it offers what the harness needs (DeviceNeeds): a compute queue,
//     Vulkan 1.2, bufferDeviceAddress and shaderInt64; for ray tracing also the extensions
//     VK_KHR_acceleration_structure, VK_KHR_ray_tracing_pipeline, VK_KHR_deferred_host_operations,
//     VK_KHR_spirv_1_4 and the features accelerationStructure and rayTracingPipeline; for a window
//     VK_KHR_swapchain;
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

// What a physical device offers (not what is enabled); vk_compute.h query_device_info reads it.
struct DeviceInfo {
  std::string name;  // VkPhysicalDeviceProperties::deviceName
  DeviceType type = DeviceType::other;
  bool compute_queue = false;         // some queue family has VK_QUEUE_COMPUTE_BIT
  uint32_t compute_queue_family = 0;  // the first such family (when compute_queue)
  bool vulkan_1_2 = false;            // apiVersion >= 1.2
  bool buffer_device_address = false;
  bool shader_int64 = false;
  bool scalar_block_layout = false;   // enabled when offered, not required
  bool ext_acceleration_structure = false;    // VK_KHR_acceleration_structure
  bool ext_ray_tracing_pipeline = false;      // VK_KHR_ray_tracing_pipeline
  bool ext_deferred_host_operations = false;  // VK_KHR_deferred_host_operations
  bool ext_spirv_1_4 = false;                 // VK_KHR_spirv_1_4
  bool acceleration_structure = false;        // feature accelerationStructure
  bool ray_tracing_pipeline = false;          // feature rayTracingPipeline
  bool ext_swapchain = false;                 // VK_KHR_swapchain
};

// What the device is wanted for (ContextOptions::ray_tracing, ContextOptions::swapchain).
struct DeviceNeeds {
  bool ray_tracing = false;
  bool swapchain = false;
};

// What `device` lacks for `needs` ("a compute queue", "Vulkan 1.2", "extension VK_KHR_...",
// "feature ..."), in the order of the list at the top; empty when it qualifies.
std::vector<std::string> missing_for(const DeviceInfo& device, const DeviceNeeds& needs);

// The index into `devices` (enumeration order) of the device to use for `needs`: the automatic
// choice when `selector` is empty, else the one device the selector names (see the top of this
// file). Errors: no devices; no qualifying device (naming each device and what it lacks); an index
// out of range, a name matching no device or several (naming the devices); a selected device that
// does not qualify (naming what it lacks).
Status choose_device(const std::vector<DeviceInfo>& devices, const DeviceNeeds& needs,
                     const std::string& selector, size_t& chosen);

}  // namespace lsnif::vk
