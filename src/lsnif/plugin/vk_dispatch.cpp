// vk_dispatch.cpp -- loading the plugin's Vulkan function tables (vk_dispatch.h).
#include "lsnif/plugin/vk_dispatch.h"

namespace lsnif::plugin {

const char* load_instance_dispatch(PFN_vkGetInstanceProcAddr get, VkInstance instance, InstanceDispatch& out) {
  out = InstanceDispatch();
  if (!get || !instance) return "vkGetInstanceProcAddr";
#define LSNIF_LOAD(name)                                                      \
  out.name = reinterpret_cast<PFN_##name>(get(instance, #name));              \
  if (!out.name) return #name;
  LSNIF_INSTANCE_FUNCTIONS(LSNIF_LOAD)
#undef LSNIF_LOAD
  out.vkGetPhysicalDeviceCooperativeMatrixPropertiesNV = reinterpret_cast<PFN_vkGetPhysicalDeviceCooperativeMatrixPropertiesNV>(
      get(instance, "vkGetPhysicalDeviceCooperativeMatrixPropertiesNV"));
  return nullptr;
}

const char* load_device_dispatch(const InstanceDispatch& instance, VkDevice device, DeviceDispatch& out) {
  out = DeviceDispatch();
  if (!instance.vkGetDeviceProcAddr || !device) return "vkGetDeviceProcAddr";
#define LSNIF_LOAD(name)                                                            \
  out.name = reinterpret_cast<PFN_##name>(instance.vkGetDeviceProcAddr(device, #name)); \
  if (!out.name) return #name;
  LSNIF_DEVICE_FUNCTIONS(LSNIF_LOAD)
#undef LSNIF_LOAD
  return nullptr;
}

}  // namespace lsnif::plugin
