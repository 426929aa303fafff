// The device choice of the Vulkan context (device_choice.h) on hand-built device lists: the automatic
// ranking, qualification on the plugin's missing items, selection by index and by name, and the
// errors.
#include "lsnif/vulkan/device_choice.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace lsnif::vk {
namespace {

const char* kLavapipe = "llvmpipe (LLVM 15.0.6, 256 bits)";

// Everything the plugin can report missing (LsnifDeviceSupport::missing of lsnif.h), in its order.
const std::vector<std::string> kLsnifItems = {
    "Vulkan 1.2", "extension VK_KHR_acceleration_structure", "extension VK_KHR_ray_tracing_pipeline",
    "extension VK_KHR_deferred_host_operations", "feature accelerationStructure", "feature rayTracingPipeline",
    "feature bufferDeviceAddress", "feature shaderInt64"};

// A device that offers everything the context can ask for (ray tracing and a swapchain): the plugin
// reports nothing missing.
DeviceInfo full(const std::string& name, DeviceType type) {
  DeviceInfo d;
  d.name = name;
  d.type = type;
  d.compute_queue = true;
  d.scalar_block_layout = d.ext_swapchain = d.ext_spirv_1_4 = d.ray_query = true;
  return d;
}

// A device with compute but without any ray-tracing extension or feature, as the plugin reports it.
DeviceInfo compute_only(const std::string& name, DeviceType type) {
  DeviceInfo d = full(name, type);
  d.lsnif_missing = {"extension VK_KHR_acceleration_structure", "extension VK_KHR_ray_tracing_pipeline",
                     "extension VK_KHR_deferred_host_operations", "feature accelerationStructure",
                     "feature rayTracingPipeline"};
  return d;
}

DeviceNeeds ray_tracing() {
  DeviceNeeds needs;
  needs.ray_tracing = true;
  return needs;
}

// The index choose_device picks; fails the test with its message on an error.
size_t chosen(const std::vector<DeviceInfo>& devices, const DeviceNeeds& needs,
              const std::string& selector = "") {
  size_t index = 99;
  const Status s = choose_device(devices, needs, selector, index);
  EXPECT_TRUE(s) << s.message();
  return index;
}

// The error message of a choice that must fail; `chosen` must stay untouched.
std::string refusal(const std::vector<DeviceInfo>& devices, const DeviceNeeds& needs,
                    const std::string& selector) {
  size_t index = 77;
  const Status s = choose_device(devices, needs, selector, index);
  EXPECT_FALSE(s) << "selector '" << selector << "' chose device " << index;
  EXPECT_EQ(index, 77u);
  return s.message();
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(DeviceChoice, PrefersDiscreteThenIntegratedThenVirtualThenCpu) {
  std::vector<DeviceInfo> devices = {full(kLavapipe, DeviceType::cpu),
                                     full("Virtio GPU", DeviceType::virtual_gpu),
                                     full("Intel UHD 770", DeviceType::integrated_gpu),
                                     full("NVIDIA RTX 4090", DeviceType::discrete_gpu)};
  EXPECT_EQ(chosen(devices, ray_tracing()), 3u);
  devices.pop_back();
  EXPECT_EQ(chosen(devices, ray_tracing()), 2u);
  devices.pop_back();
  EXPECT_EQ(chosen(devices, ray_tracing()), 1u);
  devices.pop_back();
  EXPECT_EQ(chosen(devices, ray_tracing()), 0u);
  // A device of another type only when nothing else qualifies.
  devices = {full("Mystery", DeviceType::other), full(kLavapipe, DeviceType::cpu)};
  EXPECT_EQ(chosen(devices, ray_tracing()), 1u);
  devices = {full("Mystery", DeviceType::other)};
  EXPECT_EQ(chosen(devices, ray_tracing()), 0u);
}

TEST(DeviceChoice, AmongEqualsTheFirstEnumerated) {
  const std::vector<DeviceInfo> devices = {full(kLavapipe, DeviceType::cpu),
                                           full("AMD RX 7900", DeviceType::discrete_gpu),
                                           full("NVIDIA RTX 4090", DeviceType::discrete_gpu)};
  EXPECT_EQ(chosen(devices, ray_tracing()), 1u);
}

TEST(DeviceChoice, SkipsDevicesLackingWhatIsNeeded) {
  std::vector<DeviceInfo> devices = {compute_only("Old GPU", DeviceType::discrete_gpu),
                                     full(kLavapipe, DeviceType::cpu)};
  EXPECT_EQ(chosen(devices, ray_tracing()), 1u);
  EXPECT_EQ(chosen(devices, DeviceNeeds()), 0u);  // compute alone: the GPU qualifies
  devices[0] = full("GPU without deferred host operations", DeviceType::discrete_gpu);
  devices[0].lsnif_missing = {"extension VK_KHR_deferred_host_operations"};
  EXPECT_EQ(chosen(devices, ray_tracing()), 1u);
  EXPECT_EQ(chosen(devices, DeviceNeeds()), 0u);
  // Whatever else the plugin may come to need counts for ray tracing, not for compute alone.
  devices[0] = full("GPU lacking a future requirement", DeviceType::discrete_gpu);
  devices[0].lsnif_missing = {"feature somethingNew"};
  EXPECT_EQ(chosen(devices, ray_tracing()), 1u);
  EXPECT_EQ(chosen(devices, DeviceNeeds()), 0u);
  devices[0] = full("GPU without a compute queue", DeviceType::discrete_gpu);
  devices[0].compute_queue = false;
  EXPECT_EQ(chosen(devices, DeviceNeeds()), 1u);
  devices[0] = full("Headless GPU", DeviceType::discrete_gpu);
  devices[0].ext_swapchain = false;
  DeviceNeeds window = ray_tracing();
  window.swapchain = true;
  EXPECT_EQ(chosen(devices, window), 1u);
  EXPECT_EQ(chosen(devices, ray_tracing()), 0u);
}

TEST(DeviceChoice, MissingListsEveryPieceInOrder) {
  DeviceInfo d;
  d.name = "Bare";
  d.lsnif_missing = kLsnifItems;
  DeviceNeeds needs = ray_tracing();
  needs.swapchain = true;
  // The plugin's items every context's device needs first, then the others in the plugin's order.
  const std::vector<std::string> want = {
      "a compute queue", "Vulkan 1.2", "feature bufferDeviceAddress", "feature shaderInt64",
      "extension VK_KHR_acceleration_structure", "extension VK_KHR_ray_tracing_pipeline",
      "extension VK_KHR_deferred_host_operations", "feature accelerationStructure",
      "feature rayTracingPipeline", "extension VK_KHR_swapchain"};
  EXPECT_EQ(missing_for(d, needs), want);
  EXPECT_EQ(missing_for(d, DeviceNeeds()), std::vector<std::string>(want.begin(), want.begin() + 4));
  EXPECT_TRUE(missing_for(full("All", DeviceType::cpu), needs).empty());
  // scalarBlockLayout and VK_KHR_spirv_1_4 are used where offered, never required; ray queries are
  // checked when asked for (ContextOptions::ray_query), not by the choice.
  DeviceInfo optional_less = full("No optional pieces", DeviceType::cpu);
  optional_less.scalar_block_layout = optional_less.ext_spirv_1_4 = optional_less.ray_query = false;
  EXPECT_TRUE(missing_for(optional_less, needs).empty());
}

TEST(DeviceChoice, SplitsThePluginsList) {
  EXPECT_TRUE(missing_items("").empty());
  EXPECT_EQ(missing_items("feature shaderInt64"), std::vector<std::string>{"feature shaderInt64"});
  std::string list;
  for (const std::string& item : kLsnifItems) list += (list.empty() ? "" : ", ") + item;
  EXPECT_EQ(missing_items(list), kLsnifItems);
}

TEST(DeviceChoice, NoQualifyingDeviceNamesEachAndWhatItLacks) {
  DeviceInfo int64_less = full(kLavapipe, DeviceType::cpu);
  int64_less.lsnif_missing = {"feature shaderInt64"};
  const std::vector<DeviceInfo> devices = {compute_only("Old GPU", DeviceType::discrete_gpu), int64_less};
  const std::string m = refusal(devices, ray_tracing(), "");
  EXPECT_TRUE(contains(m, "no Vulkan device can be used for ray tracing")) << m;
  EXPECT_TRUE(contains(m, "0 'Old GPU' (discrete GPU) lacks extension VK_KHR_acceleration_structure")) << m;
  EXPECT_TRUE(contains(m, "feature rayTracingPipeline")) << m;
  EXPECT_TRUE(contains(m, std::string("1 '") + kLavapipe + "' (CPU) lacks feature shaderInt64")) << m;

  const std::string none = refusal({}, ray_tracing(), "");
  EXPECT_TRUE(contains(none, "no Vulkan physical device")) << none;
}

TEST(DeviceChoice, SelectsByIndexWhateverTheRanking) {
  const std::vector<DeviceInfo> devices = {full(kLavapipe, DeviceType::cpu),
                                           full("NVIDIA RTX 4090", DeviceType::discrete_gpu)};
  EXPECT_EQ(chosen(devices, ray_tracing(), "0"), 0u);
  EXPECT_EQ(chosen(devices, ray_tracing(), "1"), 1u);
  EXPECT_EQ(chosen(devices, ray_tracing()), 1u);
  for (const char* bad : {"2", "99", "123456789012345678901234567890"}) {
    const std::string m = refusal(devices, ray_tracing(), bad);
    EXPECT_TRUE(contains(m, std::string("there is no device ") + bad)) << m;
    const std::string list = std::string("0 '") + kLavapipe + "' (CPU), 1 'NVIDIA RTX 4090' (discrete GPU)";
    EXPECT_TRUE(contains(m, list)) << m;
  }
}

TEST(DeviceChoice, SelectsByPartOfTheNameIgnoringCase) {
  const std::vector<DeviceInfo> devices = {full("NVIDIA RTX 4090", DeviceType::discrete_gpu),
                                           full(kLavapipe, DeviceType::cpu),
                                           full("Intel UHD 770", DeviceType::integrated_gpu)};
  EXPECT_EQ(chosen(devices, ray_tracing(), "llvmpipe"), 1u);
  EXPECT_EQ(chosen(devices, ray_tracing(), "LLVMpipe"), 1u);
  EXPECT_EQ(chosen(devices, ray_tracing(), "lavapipe"), 1u);  // Mesa's name for its Vulkan llvmpipe
  EXPECT_EQ(chosen(devices, ray_tracing(), "cpu"), 1u);       // the type word
  EXPECT_EQ(chosen(devices, ray_tracing(), "rtx 40"), 0u);
  EXPECT_EQ(chosen(devices, ray_tracing(), "Integrated"), 2u);
}

TEST(DeviceChoice, AmbiguousOrUnknownNamesListTheDevices) {
  const std::vector<DeviceInfo> devices = {full("NVIDIA RTX 4090", DeviceType::discrete_gpu),
                                           full(kLavapipe, DeviceType::cpu),
                                           full("NVIDIA RTX A2000", DeviceType::discrete_gpu)};
  std::string m = refusal(devices, ray_tracing(), "nvidia");
  EXPECT_TRUE(contains(m, "'nvidia' matches 2 devices: 0 'NVIDIA RTX 4090' (discrete GPU), "
                          "2 'NVIDIA RTX A2000' (discrete GPU)")) << m;
  EXPECT_FALSE(contains(m, "llvmpipe")) << m;
  m = refusal(devices, ray_tracing(), "discrete");
  EXPECT_TRUE(contains(m, "matches 2 devices")) << m;
  m = refusal(devices, ray_tracing(), "no-such-gpu");
  EXPECT_TRUE(contains(m, "'no-such-gpu' matches no device")) << m;
  for (const char* name : {"0 'NVIDIA RTX 4090'", "1 'llvmpipe", "2 'NVIDIA RTX A2000'"})
    EXPECT_TRUE(contains(m, name)) << name << " in: " << m;
}

TEST(DeviceChoice, ASelectedDeviceLackingSomethingIsAnErrorNotAFallback) {
  DeviceInfo bda_less = full("Intel UHD 770", DeviceType::integrated_gpu);
  bda_less.lsnif_missing = {"feature bufferDeviceAddress"};
  const std::vector<DeviceInfo> devices = {compute_only("Old GPU", DeviceType::discrete_gpu),
                                           full(kLavapipe, DeviceType::cpu), bda_less};
  std::string m = refusal(devices, ray_tracing(), "old");
  EXPECT_TRUE(contains(m, "device 0 'Old GPU' (discrete GPU), selected by 'old', cannot be used for ray "
                          "tracing: it lacks extension VK_KHR_acceleration_structure")) << m;
  EXPECT_TRUE(contains(m, "feature rayTracingPipeline")) << m;
  EXPECT_FALSE(contains(m, "bufferDeviceAddress")) << m;
  EXPECT_EQ(chosen(devices, DeviceNeeds(), "0"), 0u);  // compute alone is fine
  m = refusal(devices, DeviceNeeds(), "2");
  EXPECT_TRUE(contains(m, "'Intel UHD 770' (integrated GPU), selected by '2', cannot be used for compute: "
                          "it lacks feature bufferDeviceAddress")) << m;
  DeviceNeeds window = ray_tracing();
  window.swapchain = true;
  DeviceInfo headless = full(kLavapipe, DeviceType::cpu);
  headless.ext_swapchain = false;
  m = refusal({headless}, window, "llvmpipe");
  EXPECT_TRUE(contains(m, "for ray tracing with a swapchain: it lacks extension VK_KHR_swapchain")) << m;
}

}  // namespace
}  // namespace lsnif::vk
