// lsnif devices: the Vulkan devices of this machine, which LSNIF paths each one supports, and which
// one the other commands use (the Vulkan context's choice for ray tracing, src/lsnif/vulkan/device_choice.h,
// automatic or by --device). The CLI creates its own instance here (an application's instance is
// not involved); the per-device check is the plugin's (lsnifQueryDeviceSupport of lsnif.h), asked
// once per device through the Vulkan context (query_device_info), whose choice rests on the same answer.
#include <cstdio>
#include <string>
#include <vector>

#include <volk.h>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/lsnif/device_option.h"
#include "lsnif/lsnif.h"
#include "lsnif/vulkan/context.h"
#include "lsnif/import/json_text.h"

namespace lsnif::cli {

namespace {

struct DeviceReport {
  LsnifDeviceSupport support{};  // the plugin's answer
  vk::DeviceInfo info;           // what the Vulkan context's choice looks at; lsnif_missing: the plugin's items
  std::string type, driver, driver_info;
  // VK_NV_cooperative_matrix's shapes and types (vkGetPhysicalDeviceCooperativeMatrixPropertiesNV),
  // "MxNxK A B C D scope" each, where the device offers the extension.
  std::vector<std::string> nv_matrix_shapes;
};

const char* component_type_name(VkComponentTypeNV t) {
  switch (t) {
    case VK_COMPONENT_TYPE_FLOAT16_NV: return "fp16";
    case VK_COMPONENT_TYPE_FLOAT32_NV: return "fp32";
    case VK_COMPONENT_TYPE_FLOAT64_NV: return "fp64";
    case VK_COMPONENT_TYPE_SINT8_NV: return "s8";
    case VK_COMPONENT_TYPE_SINT16_NV: return "s16";
    case VK_COMPONENT_TYPE_SINT32_NV: return "s32";
    case VK_COMPONENT_TYPE_SINT64_NV: return "s64";
    case VK_COMPONENT_TYPE_UINT8_NV: return "u8";
    case VK_COMPONENT_TYPE_UINT16_NV: return "u16";
    case VK_COMPONENT_TYPE_UINT32_NV: return "u32";
    case VK_COMPONENT_TYPE_UINT64_NV: return "u64";
    default: return "other";
  }
}

// The device's VK_NV_cooperative_matrix shapes as "16x8x16 A fp16 B fp16 C fp32 D fp32 subgroup".
std::vector<std::string> nv_matrix_shapes(VkPhysicalDevice physical) {
  std::vector<std::string> shapes;
  if (!vkGetPhysicalDeviceCooperativeMatrixPropertiesNV) return shapes;
  uint32_t n = 0;
  if (vkGetPhysicalDeviceCooperativeMatrixPropertiesNV(physical, &n, nullptr) != VK_SUCCESS || n == 0) return shapes;
  std::vector<VkCooperativeMatrixPropertiesNV> props(n);
  for (VkCooperativeMatrixPropertiesNV& p : props) p.sType = VK_STRUCTURE_TYPE_COOPERATIVE_MATRIX_PROPERTIES_NV;
  if (vkGetPhysicalDeviceCooperativeMatrixPropertiesNV(physical, &n, props.data()) != VK_SUCCESS) return shapes;
  for (uint32_t i = 0; i < n; ++i) {
    const VkCooperativeMatrixPropertiesNV& p = props[i];
    shapes.push_back(format("%ux%ux%u A %s B %s C %s D %s %s", p.MSize, p.NSize, p.KSize, component_type_name(p.AType),
                            component_type_name(p.BType), component_type_name(p.CType), component_type_name(p.DType),
                            p.scope == VK_SCOPE_SUBGROUP_NV ? "subgroup" : "other scope"));
  }
  return shapes;
}

std::string api_version_string(uint32_t v) {
  return format("%u.%u.%u", VK_API_VERSION_MAJOR(v), VK_API_VERSION_MINOR(v), VK_API_VERSION_PATCH(v));
}

Status report(VkInstance instance, VkPhysicalDevice physical, DeviceReport& r) {
  if (Status s = vk::query_device_info(instance, physical, r.info, &r.support); !s) return s;
  r.type = vk::device_type_name(r.info.type);
  if (r.support.cooperativeMatrixNV) r.nv_matrix_shapes = nv_matrix_shapes(physical);
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(physical, &props);
  if (VK_API_VERSION_MAJOR(props.apiVersion) > 1 || VK_API_VERSION_MINOR(props.apiVersion) >= 2) {
    VkPhysicalDeviceDriverProperties driver{};
    driver.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES;
    VkPhysicalDeviceProperties2 p2{};
    p2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
    p2.pNext = &driver;
    vkGetPhysicalDeviceProperties2(physical, &p2);
    r.driver = driver.driverName;
    r.driver_info = driver.driverInfo;
  } else {
    r.driver = "driver version " + std::to_string(props.driverVersion);
  }
  return Status::ok();
}

// The broad phase lsnifCmdQuery would run on a device offering `s` (the plugin's automatic choice,
// LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT of lsnif.h): "trace-rays", "ray-query" or "none".
const char* broad_phase(const LsnifDeviceSupport& s) {
  if (!s.supported) return "none";
  if (s.rayQuery) return "ray-query";
  return s.rayTraversalPrimitiveCulling ? "trace-rays" : "none";
}

std::string joined(const std::vector<std::string>& items) {
  std::string s;
  for (const std::string& i : items) s += (s.empty() ? "" : ", ") + i;
  return s;
}

}  // namespace

int cmd_devices(int argc, char** argv) {
  bool json = false;
  std::string selector;
  Args args("devices",
            "Lists the Vulkan devices and which LSNIF paths each supports: the ray-tracing pipeline (with what is "
            "missing), ray query, primitive culling, the broad phase lsnifCmdQuery would run and the batched MLP "
            "kernel, NV / KHR cooperative matrix and NV cooperative vector.\n"
            "Marks the device that render, view, bench, bench-trace, bench-memory and demo use with the same\n"
            "--device (text: '*', JSON: \"selected\": true). Exit code 1 when there is no Vulkan driver or no\n"
            "device, or when --device names no usable device.");
  args.flag("json", "print JSON instead of text", &json);
  add_device_option(args, &selector);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;

  if (volkInitialize() != VK_SUCCESS) {
    std::fprintf(stderr, "lsnif devices: no Vulkan loader (libvulkan.so.1) found; install a Vulkan driver\n");
    return 1;
  }
  uint32_t loader_version = VK_API_VERSION_1_0;
  if (vkEnumerateInstanceVersion) vkEnumerateInstanceVersion(&loader_version);
  VkApplicationInfo app{};
  app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
  app.pApplicationName = "lsnif devices";
  app.apiVersion = loader_version;
  VkInstanceCreateInfo ici{};
  ici.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
  ici.pApplicationInfo = &app;
  VkInstance instance = VK_NULL_HANDLE;
  const VkResult created = vkCreateInstance(&ici, nullptr, &instance);
  if (created != VK_SUCCESS) {
    std::fprintf(stderr, "lsnif devices: cannot create a Vulkan instance (VkResult %d%s)\n", static_cast<int>(created),
                 created == VK_ERROR_INCOMPATIBLE_DRIVER ? ": no Vulkan driver installed" : "");
    return 1;
  }
  volkLoadInstanceOnly(instance);
  uint32_t count = 0;
  vkEnumeratePhysicalDevices(instance, &count, nullptr);
  std::vector<VkPhysicalDevice> physicals(count);
  if (count > 0) vkEnumeratePhysicalDevices(instance, &count, physicals.data());
  std::vector<DeviceReport> reports(physicals.size());
  Status queried = Status::ok();
  for (size_t i = 0; i < physicals.size() && queried; ++i) queried = report(instance, physicals[i], reports[i]);
  vkDestroyInstance(instance, nullptr);
  if (!queried) {
    std::fprintf(stderr, "lsnif devices: %s\n", queried.message().c_str());
    return 1;
  }
  if (reports.empty()) {
    std::fprintf(stderr, "lsnif devices: the Vulkan loader found no physical device (is a driver such as "
                         "mesa-vulkan-drivers installed?)\n");
    return 1;
  }
  // The device the ray-tracing commands would use. An explicit --device that names no usable device
  // is an error as it is for them; with none qualifying for the automatic choice, the list still
  // shows what each device lacks.
  std::vector<vk::DeviceInfo> infos;
  for (const DeviceReport& r : reports) infos.push_back(r.info);
  vk::DeviceNeeds needs;
  needs.ray_tracing = true;
  size_t chosen = 0;
  const Status choice = vk::choose_device(infos, needs, selector, chosen);
  if (!choice && !selector.empty()) {
    std::fprintf(stderr, "lsnif devices: %s\n", choice.message().c_str());
    return 1;
  }
  auto selected = [&](size_t i) { return choice && i == chosen; };

  if (json) {
    nlohmann::ordered_json j;
    j["loader_api_version"] = api_version_string(loader_version);
    j["selected_index"] = choice ? nlohmann::ordered_json(chosen) : nlohmann::ordered_json(nullptr);
    j["selection"] = selector.empty() ? "automatic" : selector;
    if (!choice) j["selection_error"] = choice.message();
    nlohmann::ordered_json& devices = j["devices"] = nlohmann::ordered_json::array();
    for (size_t i = 0; i < reports.size(); ++i) {
      const DeviceReport& r = reports[i];
      const LsnifDeviceSupport& s = r.support;
      devices.push_back({{"index", i},
                         {"name", std::string(s.deviceName)},
                         {"type", r.type},
                         {"driver", r.driver},
                         {"driver_info", r.driver_info},
                         {"api_version", api_version_string(s.apiVersion)},
                         {"ray_tracing_pipeline", bool(s.supported)},
                         {"ray_tracing_pipeline_missing", r.info.lsnif_missing},
                         {"ray_query", bool(s.rayQuery)},
                         {"ray_traversal_primitive_culling", bool(s.rayTraversalPrimitiveCulling)},
                         {"query_broad_phase", broad_phase(s)},
                         {"mlp_kernel", s.supported ? "portable" : "none"},
                         {"cooperative_matrix_mlp", s.cooperativeMatrixMlpNV ? "unverified (opt in)" : "unavailable"},
                         {"nv_cooperative_matrix", bool(s.cooperativeMatrixNV)},
                         {"nv_cooperative_matrix_shapes", r.nv_matrix_shapes},
                         {"khr_cooperative_matrix", bool(s.cooperativeMatrixKHR)},
                         {"nv_cooperative_vector", bool(s.cooperativeVectorNV)},
                         {"selected", selected(i)}});
    }
    std::printf("%s\n", json::dump(j).c_str());
    return 0;
  }
  auto yes_no = [](bool b) { return b ? "yes" : "no"; };
  for (size_t i = 0; i < reports.size(); ++i) {
    const DeviceReport& r = reports[i];
    const LsnifDeviceSupport& s = r.support;
    std::printf("%s device %zu: %s\n", selected(i) ? "*" : " ", i, s.deviceName);
    std::printf("  type                    %s\n", r.type.c_str());
    std::printf("  driver                  %s%s%s\n", r.driver.c_str(), r.driver_info.empty() ? "" : " ",
                r.driver_info.c_str());
    std::printf("  Vulkan                  %s\n", api_version_string(s.apiVersion).c_str());
    if (s.supported)
      std::printf("  ray-tracing pipeline    yes\n");
    else
      std::printf("  ray-tracing pipeline    no (missing: %s)\n", joined(r.info.lsnif_missing).c_str());
    std::printf("  ray query               %s\n", yes_no(s.rayQuery));
    std::printf("  primitive culling       %s (rayTraversalPrimitiveCulling)\n", yes_no(s.rayTraversalPrimitiveCulling));
    std::printf("  query broad phase       %s (lsnifCmdQuery, automatic choice)\n", broad_phase(s));
    std::printf("  batched MLP kernel      %s\n", s.supported ? "portable (GLSL, fp32)" : "none");
    std::printf("  cooperative-matrix MLP  %s\n",
                s.cooperativeMatrixMlpNV
                    ? "unverified: never run on a GPU; opt in (LSNIF_QUERY_PIPELINE_CREATE_COOPERATIVE_MATRIX_MLP_BIT_NV)"
                    : "unavailable (VK_NV_cooperative_matrix, a 16x8x16 fp16/fp32 shape, shaderFloat16, 48 KiB shared)");
    std::printf("  NV cooperative matrix   %s\n", yes_no(s.cooperativeMatrixNV));
    for (const std::string& shape : r.nv_matrix_shapes) std::printf("                          %s\n", shape.c_str());
    std::printf("  KHR cooperative matrix  %s\n", yes_no(s.cooperativeMatrixKHR));
    std::printf("  NV cooperative vector   %s\n", yes_no(s.cooperativeVectorNV));
  }
  if (choice)
    std::printf("\n* used by render, view, bench, bench-trace, bench-memory and demo (%s)\n",
                selector.empty()
                    ? "automatic choice: discrete GPU, then integrated, virtual, CPU; --device to pick one"
                    : ("--device " + selector).c_str());
  else
    std::printf("\nno device is usable by render, view, bench, bench-trace, bench-memory and demo: %s\n",
                choice.message().c_str());
  return 0;
}

}  // namespace lsnif::cli
