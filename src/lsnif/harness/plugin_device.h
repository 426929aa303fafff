// plugin_device.h -- the plugin's view (LsnifContextCreateInfo of src/lsnif/lsnif.h) of the
// harness's device (vk_compute.h), for the tests, benchmarks and samples that run the plugin on it.
// Header-only: users link lsnif_vk_app (which links lsnif_vk).
#pragma once
#include "lsnif/harness/vk_compute.h"  // volk first: lsnif.h then uses its Vulkan declarations
#include "lsnif/lsnif.h"

namespace lsnif::vk {

// Instance, physical device, device, queue family and queue of `vk` (initialized), loaded through
// volk's vkGetInstanceProcAddr; no error callback, no allocator.
inline LsnifContextCreateInfo plugin_create_info(const ComputeContext& vk) {
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
