// device_support.cpp -- query_device_support and the missing-piece message (device_support.h).
#include "device_support.h"

#include <cstring>
#include <vector>

namespace lsnif::plugin {

DeviceSupport query_device_support(VkPhysicalDevice physical) {
  DeviceSupport s;
  if (!physical || !vkGetPhysicalDeviceProperties) return s;
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(physical, &props);
  s.name = props.deviceName;
  s.api_version = props.apiVersion;

  uint32_t count = 0;
  vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, nullptr);
  std::vector<VkExtensionProperties> extensions(count);
  vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, extensions.data());
  auto has = [&](const char* name) {
    for (const VkExtensionProperties& e : extensions)
      if (std::strcmp(e.extensionName, name) == 0) return true;
    return false;
  };
  s.ext_acceleration_structure = has("VK_KHR_acceleration_structure");
  s.ext_ray_tracing_pipeline = has("VK_KHR_ray_tracing_pipeline");
  s.ext_deferred_host_operations = has("VK_KHR_deferred_host_operations");
  s.ext_ray_query = has("VK_KHR_ray_query");
  s.ext_nv_cooperative_matrix = has("VK_NV_cooperative_matrix");
  s.ext_khr_cooperative_matrix = has("VK_KHR_cooperative_matrix");
  s.ext_nv_cooperative_vector = has("VK_NV_cooperative_vector");
  s.ext_spirv_1_4 = has("VK_KHR_spirv_1_4");
  s.ext_swapchain = has("VK_KHR_swapchain");

  VkPhysicalDeviceFeatures2 f2{};
  f2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
  VkPhysicalDeviceVulkan12Features f12{};
  f12.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES;
  VkPhysicalDeviceAccelerationStructureFeaturesKHR as{};
  as.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR;
  VkPhysicalDeviceRayTracingPipelineFeaturesKHR rt{};
  rt.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR;
  // Chain only structs the device knows (an unknown struct in pNext is invalid usage).
  void** tail = &f2.pNext;
  const bool v12 = VK_API_VERSION_MAJOR(s.api_version) > 1 || VK_API_VERSION_MINOR(s.api_version) >= 2;
  if (v12) {
    *tail = &f12;
    tail = &f12.pNext;
  }
  if (s.ext_acceleration_structure) {
    *tail = &as;
    tail = &as.pNext;
  }
  if (s.ext_ray_tracing_pipeline) {
    *tail = &rt;
    tail = &rt.pNext;
  }
  vkGetPhysicalDeviceFeatures2(physical, &f2);
  s.shader_int64 = f2.features.shaderInt64 == VK_TRUE;
  s.buffer_device_address = v12 && f12.bufferDeviceAddress == VK_TRUE;
  s.scalar_block_layout = v12 && f12.scalarBlockLayout == VK_TRUE;
  s.acceleration_structure = s.ext_acceleration_structure && as.accelerationStructure == VK_TRUE;
  s.ray_tracing_pipeline = s.ext_ray_tracing_pipeline && rt.rayTracingPipeline == VK_TRUE;
  return s;
}

std::vector<std::string> missing_for_ray_tracing(const DeviceSupport& s) {
  std::vector<std::string> missing;
  auto need = [&](bool present, const char* what) {
    if (!present) missing.emplace_back(what);
  };
  need(VK_API_VERSION_MAJOR(s.api_version) > 1 || VK_API_VERSION_MINOR(s.api_version) >= 2, "Vulkan 1.2");
  need(s.ext_acceleration_structure, "extension VK_KHR_acceleration_structure");
  need(s.ext_ray_tracing_pipeline, "extension VK_KHR_ray_tracing_pipeline");
  need(s.ext_deferred_host_operations, "extension VK_KHR_deferred_host_operations");
  need(s.acceleration_structure, "feature accelerationStructure");
  need(s.ray_tracing_pipeline, "feature rayTracingPipeline");
  need(s.buffer_device_address, "feature bufferDeviceAddress");
  need(s.shader_int64, "feature shaderInt64");
  return missing;
}

Status describe_device_support(const DeviceSupport& s) {
  const std::vector<std::string> missing = missing_for_ray_tracing(s);
  if (missing.empty()) return Status::ok();
  std::string list;
  for (const std::string& m : missing) list += (list.empty() ? "" : ", ") + m;
  return Status::error("device '%s' (Vulkan %s) cannot run the LSNIF ray-tracing pipeline; missing: %s",
                       s.name.c_str(), api_version_string(s.api_version).c_str(), list.c_str());
}

Status check_device_support(VkPhysicalDevice physical) {
  if (!physical) return Status::error("check_device_support: null VkPhysicalDevice");
  if (!vkGetPhysicalDeviceProperties)
    return Status::error("check_device_support: Vulkan instance functions not loaded (call volkLoadInstance)");
  return describe_device_support(query_device_support(physical));
}

std::string api_version_string(uint32_t v) {
  return format("%u.%u.%u", VK_API_VERSION_MAJOR(v), VK_API_VERSION_MINOR(v), VK_API_VERSION_PATCH(v));
}

}  // namespace lsnif::plugin
