// device_support.cpp -- query_device_support, the missing-piece message and the feature-chain
// walks (device_support.h).
#include "lsnif/plugin/device_support.h"

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <vector>

namespace lsnif::plugin {

const char* const kRequiredDeviceExtensions[3] = {VK_KHR_ACCELERATION_STRUCTURE_EXTENSION_NAME,
                                                  VK_KHR_RAY_TRACING_PIPELINE_EXTENSION_NAME,
                                                  VK_KHR_DEFERRED_HOST_OPERATIONS_EXTENSION_NAME};

namespace {

bool at_least_1_2(uint32_t api_version) {
  return VK_API_VERSION_MAJOR(api_version) > 1 || VK_API_VERSION_MINOR(api_version) >= 2;
}

// The feature structs of a chain that LSNIF reads or writes (null where absent).
struct FeatureStructs {
  VkPhysicalDeviceFeatures* core = nullptr;  // of VkPhysicalDeviceFeatures2 or VkDeviceCreateInfo
  VkBool32* buffer_device_address = nullptr;  // Vulkan12Features or BufferDeviceAddressFeatures
  VkPhysicalDeviceAccelerationStructureFeaturesKHR* acceleration_structure = nullptr;
  VkPhysicalDeviceRayTracingPipelineFeaturesKHR* ray_tracing_pipeline = nullptr;
  VkPhysicalDeviceRayQueryFeaturesKHR* ray_query = nullptr;  // lsnifCmdQuery only
  // The cooperative-matrix MLP kernel only.
  VkPhysicalDeviceCooperativeMatrixFeaturesNV* cooperative_matrix = nullptr;
  VkBool32* shader_float16 = nullptr;  // Vulkan12Features or ShaderFloat16Int8Features
};

// The one walk of an application's chain: calls visit(s) for each struct from `chain` on, in order.
// It stops at the chain's end, at a struct met before (a loop) or after kMaxChainLength structs,
// and returns why it stopped early ("" at the end). The chain is walked through VkBaseOutStructure;
// the library writes only through pointers the application handed over as writable
// (enable_device_features).
template <class Visit>
std::string walk_chain(const void* chain, Visit&& visit) {
  std::vector<const VkBaseOutStructure*> seen;
  for (auto* s = static_cast<VkBaseOutStructure*>(const_cast<void*>(chain)); s; s = s->pNext) {
    const auto before = std::find(seen.begin(), seen.end(), s);
    if (before != seen.end())
      return format("loops: structure %zu (sType %d) points back to structure %zu", seen.size() - 1,
                    int(seen.back()->sType), size_t(before - seen.begin()));
    if (seen.size() == kMaxChainLength)
      return format("has more than %zu structures", kMaxChainLength);
    seen.push_back(s);
    visit(s);
  }
  return "";
}

// The sTypes LSNIF reads in a feature chain: each may appear once (which one would count?).
bool read_by_lsnif(VkStructureType type) {
  switch (type) {
    case VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO:
    case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2:
    case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES:
    case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_FLOAT16_INT8_FEATURES:
    case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_COOPERATIVE_MATRIX_FEATURES_NV:
    case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES:
    case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR:
    case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR:
    case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_QUERY_FEATURES_KHR:
      return true;
    default:
      return false;
  }
}

FeatureStructs find_feature_structs(const void* chain) {
  FeatureStructs f;
  walk_chain(chain, [&f](VkBaseOutStructure* s) {
    switch (s->sType) {
      case VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO: {
        auto* ci = reinterpret_cast<VkDeviceCreateInfo*>(s);
        if (ci->pEnabledFeatures && !f.core) f.core = const_cast<VkPhysicalDeviceFeatures*>(ci->pEnabledFeatures);
        break;
      }
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2:
        f.core = &reinterpret_cast<VkPhysicalDeviceFeatures2*>(s)->features;
        break;
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES:
        f.buffer_device_address = &reinterpret_cast<VkPhysicalDeviceVulkan12Features*>(s)->bufferDeviceAddress;
        f.shader_float16 = &reinterpret_cast<VkPhysicalDeviceVulkan12Features*>(s)->shaderFloat16;
        break;
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_FLOAT16_INT8_FEATURES:
        f.shader_float16 = &reinterpret_cast<VkPhysicalDeviceShaderFloat16Int8Features*>(s)->shaderFloat16;
        break;
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_COOPERATIVE_MATRIX_FEATURES_NV:
        f.cooperative_matrix = reinterpret_cast<VkPhysicalDeviceCooperativeMatrixFeaturesNV*>(s);
        break;
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES:
        f.buffer_device_address =
            &reinterpret_cast<VkPhysicalDeviceBufferDeviceAddressFeatures*>(s)->bufferDeviceAddress;
        break;
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR:
        f.acceleration_structure = reinterpret_cast<VkPhysicalDeviceAccelerationStructureFeaturesKHR*>(s);
        break;
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR:
        f.ray_tracing_pipeline = reinterpret_cast<VkPhysicalDeviceRayTracingPipelineFeaturesKHR*>(s);
        break;
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_QUERY_FEATURES_KHR:
        f.ray_query = reinterpret_cast<VkPhysicalDeviceRayQueryFeaturesKHR*>(s);
        break;
      default:
        break;
    }
  });
  return f;
}

// The subgroup and shared-memory limits and the NV cooperative-matrix shapes (coopmat MLP kernel).
void query_coopmat_properties(const InstanceDispatch& vk, VkPhysicalDevice physical, DeviceSupport& s) {
  VkPhysicalDeviceProperties props;
  vk.vkGetPhysicalDeviceProperties(physical, &props);
  s.max_compute_shared_memory = props.limits.maxComputeSharedMemorySize;
  if (vk.vkGetPhysicalDeviceProperties2) {
    VkPhysicalDeviceSubgroupProperties sub{};
    sub.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES;
    VkPhysicalDeviceProperties2 p2{};
    p2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
    p2.pNext = &sub;
    vk.vkGetPhysicalDeviceProperties2(physical, &p2);
    s.subgroup_size = sub.subgroupSize;
    s.subgroup_compute_basic = (sub.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) != 0 &&
                               (sub.supportedOperations & VK_SUBGROUP_FEATURE_BASIC_BIT) != 0;
  }
  if (!s.ext_nv_cooperative_matrix || !vk.vkGetPhysicalDeviceCooperativeMatrixPropertiesNV) return;
  uint32_t n = 0;
  if (vk.vkGetPhysicalDeviceCooperativeMatrixPropertiesNV(physical, &n, nullptr) != VK_SUCCESS) return;
  std::vector<VkCooperativeMatrixPropertiesNV> shapes(n);
  for (VkCooperativeMatrixPropertiesNV& p : shapes) p.sType = VK_STRUCTURE_TYPE_COOPERATIVE_MATRIX_PROPERTIES_NV;
  if (vk.vkGetPhysicalDeviceCooperativeMatrixPropertiesNV(physical, &n, shapes.data()) != VK_SUCCESS) return;
  for (uint32_t i = 0; i < n; ++i) {
    const VkCooperativeMatrixPropertiesNV& p = shapes[i];
    s.nv_matrix_16x8x16 |= p.MSize == 16 && p.NSize == 8 && p.KSize == 16 && p.AType == VK_COMPONENT_TYPE_FLOAT16_NV &&
                           p.BType == VK_COMPONENT_TYPE_FLOAT16_NV && p.CType == VK_COMPONENT_TYPE_FLOAT32_NV &&
                           p.DType == VK_COMPONENT_TYPE_FLOAT32_NV && p.scope == VK_SCOPE_SUBGROUP_NV;
  }
}

}  // namespace

DeviceSupport query_device_support(const InstanceDispatch& vk, VkPhysicalDevice physical) {
  DeviceSupport s;
  if (!physical || !vk.vkGetPhysicalDeviceProperties) return s;
  VkPhysicalDeviceProperties props;
  vk.vkGetPhysicalDeviceProperties(physical, &props);
  s.name = props.deviceName;
  s.api_version = props.apiVersion;

  uint32_t count = 0;
  vk.vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, nullptr);
  std::vector<VkExtensionProperties> extensions(count);
  vk.vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, extensions.data());
  extensions.resize(count);
  auto has = [&](const char* name) {
    for (const VkExtensionProperties& e : extensions)
      if (std::strcmp(e.extensionName, name) == 0) return true;
    return false;
  };
  s.ext_acceleration_structure = has(VK_KHR_ACCELERATION_STRUCTURE_EXTENSION_NAME);
  s.ext_ray_tracing_pipeline = has(VK_KHR_RAY_TRACING_PIPELINE_EXTENSION_NAME);
  s.ext_deferred_host_operations = has(VK_KHR_DEFERRED_HOST_OPERATIONS_EXTENSION_NAME);
  s.ext_ray_query = has(VK_KHR_RAY_QUERY_EXTENSION_NAME);
  s.ext_nv_cooperative_matrix = has("VK_NV_cooperative_matrix");
  s.ext_khr_cooperative_matrix = has("VK_KHR_cooperative_matrix");
  s.ext_nv_cooperative_vector = has("VK_NV_cooperative_vector");

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
  const bool v12 = at_least_1_2(s.api_version);
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
  VkPhysicalDeviceRayQueryFeaturesKHR rq{};
  rq.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_QUERY_FEATURES_KHR;
  if (s.ext_ray_query) {
    *tail = &rq;
    tail = &rq.pNext;
  }
  VkPhysicalDeviceCooperativeMatrixFeaturesNV cm{};
  cm.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_COOPERATIVE_MATRIX_FEATURES_NV;
  if (s.ext_nv_cooperative_matrix) {
    *tail = &cm;
    tail = &cm.pNext;
  }
  if (vk.vkGetPhysicalDeviceFeatures2) vk.vkGetPhysicalDeviceFeatures2(physical, &f2);
  s.nv_cooperative_matrix = s.ext_nv_cooperative_matrix && cm.cooperativeMatrix == VK_TRUE;
  s.shader_float16 = v12 && f12.shaderFloat16 == VK_TRUE;
  query_coopmat_properties(vk, physical, s);
  s.shader_int64 = f2.features.shaderInt64 == VK_TRUE;
  s.buffer_device_address = v12 && f12.bufferDeviceAddress == VK_TRUE;
  s.acceleration_structure = s.ext_acceleration_structure && as.accelerationStructure == VK_TRUE;
  s.ray_tracing_pipeline = s.ext_ray_tracing_pipeline && rt.rayTracingPipeline == VK_TRUE;
  s.ray_query = s.ext_ray_query && rq.rayQuery == VK_TRUE;
  s.ray_traversal_primitive_culling = s.ext_ray_tracing_pipeline && rt.rayTraversalPrimitiveCulling == VK_TRUE;
  return s;
}

std::vector<std::string> missing_for_ray_tracing(const DeviceSupport& s) {
  std::vector<std::string> missing;
  auto need = [&](bool present, const char* what) {
    if (!present) missing.emplace_back(what);
  };
  need(at_least_1_2(s.api_version), "Vulkan 1.2");
  need(s.ext_acceleration_structure, "extension VK_KHR_acceleration_structure");
  need(s.ext_ray_tracing_pipeline, "extension VK_KHR_ray_tracing_pipeline");
  need(s.ext_deferred_host_operations, "extension VK_KHR_deferred_host_operations");
  need(s.acceleration_structure, "feature accelerationStructure");
  need(s.ray_tracing_pipeline, "feature rayTracingPipeline");
  need(s.buffer_device_address, "feature bufferDeviceAddress");
  need(s.shader_int64, "feature shaderInt64");
  return missing;
}

std::vector<std::string> missing_for_coopmat_mlp(const DeviceSupport& s) {
  std::vector<std::string> missing;
  auto need = [&](bool present, const char* what) {
    if (!present) missing.emplace_back(what);
  };
  need(s.ext_nv_cooperative_matrix, "extension VK_NV_cooperative_matrix");
  need(s.nv_cooperative_matrix, "feature cooperativeMatrix");
  need(s.shader_float16, "feature shaderFloat16");
  need(s.nv_matrix_16x8x16, "a 16x8x16 fp16 x fp16 + fp32 subgroup shape");
  need((s.subgroup_size == 32 || s.subgroup_size == 64) && s.subgroup_compute_basic,
       "subgroup size 32 or 64 with basic operations in compute");
  need(s.max_compute_shared_memory >= kCoopmatMlpSharedBytes, "49152 bytes of compute shared memory");
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

std::string chain_problem(const void* chain, const std::string& name) {
  std::vector<VkStructureType> types;
  bool features2 = false, enabled_features = false;
  const std::string stop = walk_chain(chain, [&](const VkBaseOutStructure* s) {
    types.push_back(s->sType);
    features2 = features2 || s->sType == VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
    if (s->sType == VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO)
      enabled_features = reinterpret_cast<const VkDeviceCreateInfo*>(s)->pEnabledFeatures != nullptr;
  });
  if (!stop.empty()) return format("%s: the chain %s", name.c_str(), stop.c_str());
  for (size_t i = 0; i < types.size(); ++i)
    for (size_t j = i + 1; j < types.size(); ++j)
      if (types[i] == types[j] && read_by_lsnif(types[i]))
        return format("%s: structures %zu and %zu of the chain have the same sType %d (Vulkan allows each once)",
                      name.c_str(), i, j, int(types[i]));
  if (features2 && enabled_features)
    return format("%s: the chain has a VkPhysicalDeviceFeatures2 and the VkDeviceCreateInfo's pEnabledFeatures is "
                  "not NULL (Vulkan allows one of the two)", name.c_str());
  return "";
}

std::vector<std::string> features_not_enabled(const void* chain, const VkPhysicalDeviceFeatures* core) {
  FeatureStructs f = find_feature_structs(chain);
  if (core) f.core = const_cast<VkPhysicalDeviceFeatures*>(core);
  std::vector<std::string> missing;
  if (!f.acceleration_structure || !f.acceleration_structure->accelerationStructure)
    missing.emplace_back("feature accelerationStructure");
  if (!f.ray_tracing_pipeline || !f.ray_tracing_pipeline->rayTracingPipeline)
    missing.emplace_back("feature rayTracingPipeline");
  if (!f.buffer_device_address || !*f.buffer_device_address) missing.emplace_back("feature bufferDeviceAddress");
  if (!f.core || !f.core->shaderInt64) missing.emplace_back("feature shaderInt64");
  return missing;
}

bool ray_query_enabled(const void* chain) {
  const FeatureStructs f = find_feature_structs(chain);
  return f.ray_query && f.ray_query->rayQuery;
}

bool primitive_culling_enabled(const void* chain) {
  const FeatureStructs f = find_feature_structs(chain);
  return f.ray_tracing_pipeline && f.ray_tracing_pipeline->rayTraversalPrimitiveCulling;
}

std::vector<std::string> coopmat_mlp_features_not_enabled(const void* chain) {
  const FeatureStructs f = find_feature_structs(chain);
  std::vector<std::string> missing;
  if (!f.cooperative_matrix || !f.cooperative_matrix->cooperativeMatrix) missing.emplace_back("feature cooperativeMatrix");
  if (!f.shader_float16 || !*f.shader_float16) missing.emplace_back("feature shaderFloat16");
  return missing;
}

std::vector<std::string> enable_device_features(void* chain, VkPhysicalDeviceFeatures* core) {
  FeatureStructs f = find_feature_structs(chain);
  if (core) f.core = core;
  std::vector<std::string> absent;
  if (f.acceleration_structure)
    f.acceleration_structure->accelerationStructure = VK_TRUE;
  else
    absent.emplace_back("VkPhysicalDeviceAccelerationStructureFeaturesKHR");
  if (f.ray_tracing_pipeline)
    f.ray_tracing_pipeline->rayTracingPipeline = VK_TRUE;
  else
    absent.emplace_back("VkPhysicalDeviceRayTracingPipelineFeaturesKHR");
  if (f.buffer_device_address)
    *f.buffer_device_address = VK_TRUE;
  else
    absent.emplace_back("VkPhysicalDeviceVulkan12Features (or VkPhysicalDeviceBufferDeviceAddressFeatures)");
  if (f.core)
    f.core->shaderInt64 = VK_TRUE;
  else
    absent.emplace_back("VkPhysicalDeviceFeatures2 (for VkPhysicalDeviceFeatures::shaderInt64; with the core features "
                        "in VkDeviceCreateInfo::pEnabledFeatures use lsnifEnableDeviceFeaturesWithCore)");
  return absent;
}

bool has_core_features(const void* chain) { return find_feature_structs(chain).core != nullptr; }

const LsnifFeatureRequirement* required_device_features() {
  constexpr VkStructureType kNone = VK_STRUCTURE_TYPE_MAX_ENUM;
  static const LsnifFeatureRequirement table[kRequiredFeatureCount] = {
      {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, "VkPhysicalDeviceFeatures2", "shaderInt64",
       uint32_t(offsetof(VkPhysicalDeviceFeatures2, features) + offsetof(VkPhysicalDeviceFeatures, shaderInt64)), kNone,
       "VkPhysicalDeviceFeatures", uint32_t(offsetof(VkPhysicalDeviceFeatures, shaderInt64))},
      {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, "VkPhysicalDeviceVulkan12Features", "bufferDeviceAddress",
       uint32_t(offsetof(VkPhysicalDeviceVulkan12Features, bufferDeviceAddress)),
       VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES, "VkPhysicalDeviceBufferDeviceAddressFeatures",
       uint32_t(offsetof(VkPhysicalDeviceBufferDeviceAddressFeatures, bufferDeviceAddress))},
      {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR,
       "VkPhysicalDeviceAccelerationStructureFeaturesKHR", "accelerationStructure",
       uint32_t(offsetof(VkPhysicalDeviceAccelerationStructureFeaturesKHR, accelerationStructure)), kNone, nullptr, 0},
      {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR,
       "VkPhysicalDeviceRayTracingPipelineFeaturesKHR", "rayTracingPipeline",
       uint32_t(offsetof(VkPhysicalDeviceRayTracingPipelineFeaturesKHR, rayTracingPipeline)), kNone, nullptr, 0},
  };
  return table;
}

void enable_device_features_appending(VkDeviceCreateInfo& create_info, LsnifDeviceFeatureStorage& storage) {
  // The structs of the pNext chain only: pEnabledFeatures may point at read-only memory.
  void* chain = const_cast<void*>(create_info.pNext);
  if (chain) enable_device_features(chain);
  const FeatureStructs f = find_feature_structs(chain);
  // The chain's last struct: appended structs go behind it.
  VkBaseOutStructure* tail = nullptr;
  walk_chain(&create_info, [&tail](VkBaseOutStructure* s) { tail = s; });
  auto append = [&](auto& s, VkStructureType type) {
    std::memset(&s, 0, sizeof s);
    s.sType = type;
    tail->pNext = reinterpret_cast<VkBaseOutStructure*>(&s);
    tail = tail->pNext;
  };
  // Core features: a VkPhysicalDeviceFeatures2 in the chain (shaderInt64 set above); else one from the
  // storage carries a copy of pEnabledFeatures (the two must not be given together).
  if (!f.core) {
    const VkPhysicalDeviceFeatures core = create_info.pEnabledFeatures ? *create_info.pEnabledFeatures
                                                                       : VkPhysicalDeviceFeatures{};
    append(storage.features2, VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2);
    storage.features2.features = core;
    storage.features2.features.shaderInt64 = VK_TRUE;
    create_info.pEnabledFeatures = nullptr;
  }
  // The buffer-device-address struct rather than VkPhysicalDeviceVulkan12Features: the latter must
  // not share a chain with any struct of a feature promoted to 1.2, which frameworks often chain.
  if (!f.buffer_device_address) {
    append(storage.bufferDeviceAddress, VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES);
    storage.bufferDeviceAddress.bufferDeviceAddress = VK_TRUE;
  }
  if (!f.acceleration_structure) {
    append(storage.accelerationStructure, VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR);
    storage.accelerationStructure.accelerationStructure = VK_TRUE;
  }
  if (!f.ray_tracing_pipeline) {
    append(storage.rayTracingPipeline, VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR);
    storage.rayTracingPipeline.rayTracingPipeline = VK_TRUE;
  }
}

std::string core_features_hint(const void* chain) {
  if (find_feature_structs(chain).core) return {};
  return "the chain given has no VkPhysicalDeviceFeatures2: when the device's core features were in "
         "VkDeviceCreateInfo::pEnabledFeatures, pass the VkDeviceCreateInfo itself, or those features in a "
         "LsnifContextCoreFeaturesInfo chained to LsnifContextCreateInfo::pNext";
}

std::string api_version_string(uint32_t v) {
  return format("%u.%u.%u", VK_API_VERSION_MAJOR(v), VK_API_VERSION_MINOR(v), VK_API_VERSION_PATCH(v));
}

}  // namespace lsnif::plugin
