// vk_dispatch.h -- the Vulkan functions the plugin calls, loaded through the application's
// vkGetInstanceProcAddr (and the device's vkGetDeviceProcAddr). The plugin links no loader and
// uses no global function pointers, so it coexists with whatever loader the application uses
// (volk, the Vulkan loader, its own table).
#pragma once
#include <vulkan/vulkan_core.h>

namespace lsnif::plugin {

#define LSNIF_INSTANCE_FUNCTIONS(X)            \
  X(vkGetPhysicalDeviceProperties)             \
  X(vkGetPhysicalDeviceProperties2)            \
  X(vkGetPhysicalDeviceFeatures2)              \
  X(vkGetPhysicalDeviceMemoryProperties)       \
  X(vkGetPhysicalDeviceQueueFamilyProperties)  \
  X(vkEnumerateDeviceExtensionProperties)      \
  X(vkGetDeviceProcAddr)

#define LSNIF_DEVICE_FUNCTIONS(X)                 \
  X(vkCreateBuffer)                               \
  X(vkDestroyBuffer)                              \
  X(vkGetBufferMemoryRequirements)                \
  X(vkAllocateMemory)                             \
  X(vkFreeMemory)                                 \
  X(vkBindBufferMemory)                           \
  X(vkMapMemory)                                  \
  X(vkUnmapMemory)                                \
  X(vkGetBufferDeviceAddress)                     \
  X(vkCreateAccelerationStructureKHR)             \
  X(vkDestroyAccelerationStructureKHR)            \
  X(vkGetAccelerationStructureBuildSizesKHR)      \
  X(vkGetAccelerationStructureDeviceAddressKHR)   \
  X(vkCmdBuildAccelerationStructuresKHR)          \
  X(vkCmdCopyBuffer)                              \
  X(vkCmdPipelineBarrier)                         \
  X(vkCreateCommandPool)                          \
  X(vkDestroyCommandPool)                         \
  X(vkAllocateCommandBuffers)                     \
  X(vkFreeCommandBuffers)                         \
  X(vkBeginCommandBuffer)                         \
  X(vkEndCommandBuffer)                           \
  X(vkQueueSubmit)                                \
  X(vkCreateFence)                                \
  X(vkDestroyFence)                               \
  X(vkWaitForFences)                              \
  X(vkResetFences)                                \
  X(vkCreateShaderModule)                         \
  X(vkDestroyShaderModule)                        \
  X(vkCreatePipelineLayout)                       \
  X(vkDestroyPipelineLayout)                      \
  X(vkCreateComputePipelines)                     \
  X(vkDestroyPipeline)                            \
  X(vkCmdBindPipeline)                            \
  X(vkCmdPushConstants)                           \
  X(vkCmdDispatch)                                \
  X(vkCmdDispatchIndirect)                        \
  X(vkCmdWriteTimestamp)                          \
  X(vkCreateRayTracingPipelinesKHR)               \
  X(vkGetRayTracingShaderGroupHandlesKHR)         \
  X(vkCmdTraceRaysKHR)

struct InstanceDispatch {
#define LSNIF_DECLARE(name) PFN_##name name = nullptr;
  LSNIF_INSTANCE_FUNCTIONS(LSNIF_DECLARE)
#undef LSNIF_DECLARE
  // Optional (null where no driver exposes VK_NV_cooperative_matrix): the shapes the cooperative-
  // matrix MLP kernel needs (device_support.h).
  PFN_vkGetPhysicalDeviceCooperativeMatrixPropertiesNV vkGetPhysicalDeviceCooperativeMatrixPropertiesNV = nullptr;
};

struct DeviceDispatch {
#define LSNIF_DECLARE(name) PFN_##name name = nullptr;
  LSNIF_DEVICE_FUNCTIONS(LSNIF_DECLARE)
#undef LSNIF_DECLARE
};

// Loads every instance function of `instance`; returns the name of the first one that could not be
// loaded, or nullptr when all were.
const char* load_instance_dispatch(PFN_vkGetInstanceProcAddr get, VkInstance instance, InstanceDispatch& out);

// Loads every device function of `device` through instance.vkGetDeviceProcAddr; returns the name
// of the first one that could not be loaded (e.g. vkCreateAccelerationStructureKHR when
// VK_KHR_acceleration_structure was not enabled), or nullptr when all were.
const char* load_device_dispatch(const InstanceDispatch& instance, VkDevice device, DeviceDispatch& out);

}  // namespace lsnif::plugin
