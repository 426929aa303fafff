// device_choice.cpp -- qualification, ranking and the device selector (device_choice.h).
#include "lsnif/vulkan/device_choice.h"

#include <cctype>

namespace lsnif::vk {

namespace {

std::string lowercase(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Higher is preferred by the automatic choice.
int preference(DeviceType type) {
  switch (type) {
    case DeviceType::discrete_gpu: return 4;
    case DeviceType::integrated_gpu: return 3;
    case DeviceType::virtual_gpu: return 2;
    case DeviceType::cpu: return 1;
    default: return 0;
  }
}

// The word a selector may use for a device type instead of a part of the name ("" for none).
const char* type_word(DeviceType type) {
  switch (type) {
    case DeviceType::discrete_gpu: return "discrete";
    case DeviceType::integrated_gpu: return "integrated";
    case DeviceType::virtual_gpu: return "virtual";
    case DeviceType::cpu: return "cpu";
    default: return "";
  }
}

// Whether a (lowercase, non-numeric) selector names `device`: a part of its name, its type word,
// or "lavapipe" for Mesa's CPU device, whose name says llvmpipe.
bool selects(const std::string& selector, const DeviceInfo& device) {
  const std::string name = lowercase(device.name);
  return name.find(selector) != std::string::npos || selector == type_word(device.type) ||
         (selector == "lavapipe" && name.find("llvmpipe") != std::string::npos);
}

std::string joined(const std::vector<std::string>& items) {
  std::string s;
  for (const std::string& i : items) s += (s.empty() ? "" : ", ") + i;
  return s;
}

// "1 'NAME' (discrete GPU)"
std::string describe(const std::vector<DeviceInfo>& devices, size_t i) {
  return format("%zu '%s' (%s)", i, devices[i].name.c_str(), device_type_name(devices[i].type));
}

// "0 'NAME' (CPU), 1 'NAME' (discrete GPU)"
std::string described(const std::vector<DeviceInfo>& devices, const std::vector<size_t>& indices) {
  std::vector<std::string> items;
  for (const size_t i : indices) items.push_back(describe(devices, i));
  return joined(items);
}

std::string all_devices(const std::vector<DeviceInfo>& devices) {
  std::vector<size_t> indices(devices.size());
  for (size_t i = 0; i < devices.size(); ++i) indices[i] = i;
  return described(devices, indices);
}

// Whether an item of the plugin's list is one that every context's device needs: the context creates
// each device, ray tracing or not, with Vulkan 1.2, bufferDeviceAddress and shaderInt64.
bool needed_for_compute(const std::string& item) {
  return item == "Vulkan 1.2" || item == "feature bufferDeviceAddress" || item == "feature shaderInt64";
}

std::string purpose(const DeviceNeeds& needs) {
  const std::string what = needs.ray_tracing ? "ray tracing" : "compute";
  return needs.swapchain ? what + " with a swapchain" : what;
}

}  // namespace

const char* device_type_name(DeviceType type) {
  switch (type) {
    case DeviceType::integrated_gpu: return "integrated GPU";
    case DeviceType::discrete_gpu: return "discrete GPU";
    case DeviceType::virtual_gpu: return "virtual GPU";
    case DeviceType::cpu: return "CPU";
    default: return "other";
  }
}

std::vector<std::string> missing_items(const std::string& list) {
  std::vector<std::string> items;
  size_t at = 0;
  while (at < list.size()) {
    size_t comma = list.find(", ", at);
    if (comma == std::string::npos) comma = list.size();
    items.push_back(list.substr(at, comma - at));
    at = comma + 2;
  }
  return items;
}

std::vector<std::string> missing_for(const DeviceInfo& d, const DeviceNeeds& needs) {
  std::vector<std::string> missing;
  if (!d.compute_queue) missing.emplace_back("a compute queue");
  for (const std::string& item : d.lsnif_missing)
    if (needed_for_compute(item)) missing.push_back(item);
  if (needs.ray_tracing)
    for (const std::string& item : d.lsnif_missing)
      if (!needed_for_compute(item)) missing.push_back(item);
  if (needs.swapchain && !d.ext_swapchain) missing.emplace_back("extension VK_KHR_swapchain");
  return missing;
}

Status choose_device(const std::vector<DeviceInfo>& devices, const DeviceNeeds& needs,
                     const std::string& selector, size_t& chosen) {
  if (devices.empty())
    return Status::error("no Vulkan physical device (is a driver such as mesa-vulkan-drivers installed?)");

  if (selector.empty()) {
    int best = -1;
    for (size_t i = 0; i < devices.size(); ++i)
      if (missing_for(devices[i], needs).empty() && preference(devices[i].type) > best) {
        best = preference(devices[i].type);
        chosen = i;
      }
    if (best >= 0) return Status::ok();
    std::string why;
    for (size_t i = 0; i < devices.size(); ++i)
      why += (i ? "; " : "") + describe(devices, i) + " lacks " + joined(missing_for(devices[i], needs));
    return Status::error("no Vulkan device can be used for %s: %s", purpose(needs).c_str(), why.c_str());
  }

  size_t index = 0;
  const bool numeric = selector.find_first_not_of("0123456789") == std::string::npos;
  if (numeric) {
    // More digits than any device count could need: out of range (and no overflow).
    index = selector.size() > 9 ? devices.size() : size_t(std::stoul(selector));
    if (index >= devices.size())
      return Status::error("device selector '%s': there is no device %s; the Vulkan devices are %s",
                           selector.c_str(), selector.c_str(), all_devices(devices).c_str());
  } else {
    const std::string wanted = lowercase(selector);
    std::vector<size_t> matches;
    for (size_t i = 0; i < devices.size(); ++i)
      if (selects(wanted, devices[i])) matches.push_back(i);
    if (matches.empty())
      return Status::error("device selector '%s' matches no device; the Vulkan devices are %s",
                           selector.c_str(), all_devices(devices).c_str());
    if (matches.size() > 1)
      return Status::error("device selector '%s' matches %zu devices: %s; select one by its index or a "
                           "longer part of its name", selector.c_str(), matches.size(),
                           described(devices, matches).c_str());
    index = matches[0];
  }
  const std::vector<std::string> missing = missing_for(devices[index], needs);
  if (!missing.empty())
    return Status::error("device %s, selected by '%s', cannot be used for %s: it lacks %s",
                         describe(devices, index).c_str(), selector.c_str(), purpose(needs).c_str(),
                         joined(missing).c_str());
  chosen = index;
  return Status::ok();
}

}  // namespace lsnif::vk
