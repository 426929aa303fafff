// plugin_device.h -- the plugin's view (plugin/lsnif_vk.h DeviceHandles) of the harness's device
// (vk_compute.h), for the tests, benchmarks and samples that run the plugin on it. Header-only:
// users link lsnif_plugin and lsnif_vk_app.
#pragma once
#include "lsnif_vk.h"
#include "vk_compute.h"

namespace lsnif::vk {

// Instance, physical device, device, queue family and queue of `vk` (initialized).
inline plugin::DeviceHandles plugin_handles(const ComputeContext& vk) {
  plugin::DeviceHandles h;
  h.instance = vk.instance();
  h.physical = vk.physical_device();
  h.device = vk.device();
  h.queue_family = vk.queue_family();
  h.queue = vk.queue();
  return h;
}

}  // namespace lsnif::vk
