// plugin_device.h -- the plugin's view (LsnifContextCreateInfo of src/lsnif/lsnif.h) of the
// Vulkan context's device (context.h), for the renderer, tools, tests and benchmarks that run the
// plugin on it.
// Header-only: users link lsnif_vk_app (which links lsnif_vk).
#pragma once
#include "lsnif/vulkan/context.h"  // volk first: lsnif.h then uses its Vulkan declarations
#include "lsnif/lsnif.h"

namespace lsnif::vk {

// Instance, physical device, device, queue family and queue of `vk` (initialized), loaded through
// volk's vkGetInstanceProcAddr; no error callback, no allocator.
inline LsnifContextCreateInfo plugin_create_info(const Context& vk) {
  LsnifContextCreateInfo info{};
  info.instance = vk.instance();
  info.physicalDevice = vk.physical_device();
  info.device = vk.device();
  info.queueFamilyIndex = vk.queue_family();
  info.queue = vk.queue();
  info.pfnGetInstanceProcAddr = vkGetInstanceProcAddr;
  return info;
}

}  // namespace lsnif::vk
