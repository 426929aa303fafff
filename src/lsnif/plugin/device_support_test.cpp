// device_support_test.cpp -- the parts of the plugin that need no device: the missing-piece
// message from hand-built device-support structs, the feature-chain helpers (which features a
// VkDeviceCreateInfo chain enables, setting them in chains of either buffer-device-address struct),
// the required extensions, result strings, versions, and the embedded intersection shaders.
#include "lsnif/plugin/device_support.h"

#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "lsnif/lsnif.h"

namespace lsnif::plugin {
namespace {

DeviceSupport full_support() {
  DeviceSupport s;
  s.name = "fake";
  s.api_version = VK_MAKE_API_VERSION(0, 1, 3, 0);
  s.ext_acceleration_structure = s.ext_ray_tracing_pipeline = s.ext_deferred_host_operations = true;
  s.acceleration_structure = s.ray_tracing_pipeline = s.buffer_device_address = s.shader_int64 = true;
  return s;
}

TEST(DeviceSupport, MessageListsExactlyTheMissingPieces) {
  EXPECT_TRUE(describe_device_support(full_support()));

  DeviceSupport s = full_support();
  s.shader_int64 = false;
  Status st = describe_device_support(s);
  ASSERT_FALSE(st);
  EXPECT_NE(st.message().find("device 'fake' (Vulkan 1.3.0)"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("missing: feature shaderInt64"), std::string::npos) << st.message();
  EXPECT_EQ(st.message().find("rayTracingPipeline"), std::string::npos) << st.message();

  s = full_support();
  s.ext_ray_tracing_pipeline = false;
  s.ray_tracing_pipeline = false;
  s.ext_deferred_host_operations = false;
  EXPECT_EQ(missing_for_ray_tracing(s),
            (std::vector<std::string>{"extension VK_KHR_ray_tracing_pipeline",
                                      "extension VK_KHR_deferred_host_operations", "feature rayTracingPipeline"}));

  DeviceSupport none;
  none.name = "old";
  none.api_version = VK_MAKE_API_VERSION(0, 1, 1, 0);
  EXPECT_EQ(missing_for_ray_tracing(none),
            (std::vector<std::string>{"Vulkan 1.2", "extension VK_KHR_acceleration_structure",
                                      "extension VK_KHR_ray_tracing_pipeline",
                                      "extension VK_KHR_deferred_host_operations", "feature accelerationStructure",
                                      "feature rayTracingPipeline", "feature bufferDeviceAddress",
                                      "feature shaderInt64"}));
  st = describe_device_support(none);
  ASSERT_FALSE(st);
  EXPECT_NE(st.message().find("missing: Vulkan 1.2, extension VK_KHR_acceleration_structure, "), std::string::npos)
      << st.message();
}

TEST(DeviceFeatures, InitEnablesExactlyWhatLsnifNeedsInAChain) {
  VkPhysicalDeviceVulkan11Features tail{};
  tail.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES;
  LsnifDeviceFeatures f;
  std::memset(&f, 0xAB, sizeof f);  // garbage first: everything must be written
  lsnifInitDeviceFeatures(&f, &tail);
  EXPECT_EQ(f.features2.sType, VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2);
  EXPECT_EQ(f.features2.pNext, &f.vulkan12);
  EXPECT_EQ(f.vulkan12.pNext, &f.accelerationStructure);
  EXPECT_EQ(f.accelerationStructure.pNext, &f.rayTracingPipeline);
  EXPECT_EQ(f.rayTracingPipeline.pNext, &tail);
  EXPECT_EQ(f.features2.features.shaderInt64, VK_TRUE);
  EXPECT_EQ(f.features2.features.robustBufferAccess, VK_FALSE);
  EXPECT_EQ(f.vulkan12.bufferDeviceAddress, VK_TRUE);
  EXPECT_EQ(f.vulkan12.scalarBlockLayout, VK_FALSE);
  EXPECT_EQ(f.accelerationStructure.accelerationStructure, VK_TRUE);
  EXPECT_EQ(f.accelerationStructure.accelerationStructureCaptureReplay, VK_FALSE);
  EXPECT_EQ(f.rayTracingPipeline.rayTracingPipeline, VK_TRUE);
  EXPECT_EQ(f.rayTracingPipeline.rayTraversalPrimitiveCulling, VK_FALSE);
  // A device create info carrying this chain enables everything.
  VkDeviceCreateInfo dci{};
  dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  dci.pNext = &f.features2;
  EXPECT_TRUE(features_not_enabled(&dci).empty());
  EXPECT_TRUE(features_not_enabled(&f.features2).empty());
  lsnifInitDeviceFeatures(nullptr, nullptr);  // ignored
}

TEST(DeviceFeatures, NotEnabledNamesEachMissingFeature) {
  LsnifDeviceFeatures f;
  lsnifInitDeviceFeatures(&f, nullptr);
  f.rayTracingPipeline.rayTracingPipeline = VK_FALSE;
  EXPECT_EQ(features_not_enabled(&f.features2), std::vector<std::string>{"feature rayTracingPipeline"});
  // Without the acceleration-structure struct in the chain, its feature counts as not enabled.
  f.vulkan12.pNext = &f.rayTracingPipeline;
  f.rayTracingPipeline.rayTracingPipeline = VK_TRUE;
  EXPECT_EQ(features_not_enabled(&f.features2), std::vector<std::string>{"feature accelerationStructure"});
  // shaderInt64 through VkDeviceCreateInfo::pEnabledFeatures, buffer device address through the
  // Vulkan 1.2 core struct's predecessor.
  VkPhysicalDeviceFeatures core{};
  VkPhysicalDeviceBufferDeviceAddressFeatures bda{};
  bda.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES;
  bda.bufferDeviceAddress = VK_TRUE;
  bda.pNext = &f.accelerationStructure;
  f.accelerationStructure.pNext = &f.rayTracingPipeline;
  VkDeviceCreateInfo dci{};
  dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  dci.pNext = &bda;
  dci.pEnabledFeatures = &core;
  EXPECT_EQ(features_not_enabled(&dci), std::vector<std::string>{"feature shaderInt64"});
  core.shaderInt64 = VK_TRUE;
  EXPECT_TRUE(features_not_enabled(&dci).empty());
  dci.pNext = nullptr;
  dci.pEnabledFeatures = nullptr;
  EXPECT_EQ(features_not_enabled(&dci),
            (std::vector<std::string>{"feature accelerationStructure", "feature rayTracingPipeline",
                                      "feature bufferDeviceAddress", "feature shaderInt64"}));
}

// The features of the two broad phases of lsnifCmdQuery, read from an application's chain wherever
// their structs are: absent structs count as not enabled.
TEST(DeviceFeatures, BroadPhaseFeaturesAreReadFromTheChain) {
  LsnifDeviceFeatures f;
  lsnifInitDeviceFeatures(&f, nullptr);
  EXPECT_FALSE(primitive_culling_enabled(&f.features2)) << "lsnifInitDeviceFeatures sets only what LSNIF needs";
  EXPECT_FALSE(ray_query_enabled(&f.features2));
  f.rayTracingPipeline.rayTraversalPrimitiveCulling = VK_TRUE;
  EXPECT_TRUE(primitive_culling_enabled(&f.features2));
  VkPhysicalDeviceRayQueryFeaturesKHR rq{};
  rq.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_QUERY_FEATURES_KHR;
  rq.rayQuery = VK_TRUE;
  // The ray-query struct first, the rest after it, behind a VkDeviceCreateInfo.
  rq.pNext = &f.features2;
  VkDeviceCreateInfo dci{};
  dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  dci.pNext = &rq;
  EXPECT_TRUE(ray_query_enabled(&dci));
  EXPECT_TRUE(primitive_culling_enabled(&dci));
  f.vulkan12.pNext = nullptr;  // the ray-tracing struct out of the chain
  EXPECT_FALSE(primitive_culling_enabled(&dci));
  EXPECT_TRUE(ray_query_enabled(&dci));
  // query_device_support reads the offer; missing_for_ray_tracing never lists the broad phases'
  // features (they are not required).
  DeviceSupport s = full_support();
  s.ray_query = s.ray_traversal_primitive_culling = false;
  EXPECT_TRUE(missing_for_ray_tracing(s).empty());
}

// The cooperative-matrix MLP kernel: what it needs, each missing piece named in order, none of it
// required by the ray-tracing path; and its two features read from an application's chain.
TEST(DeviceFeatures, CooperativeMatrixMlpNeedsAndFeatures) {
  DeviceSupport s = full_support();
  EXPECT_TRUE(missing_for_ray_tracing(s).empty());
  EXPECT_EQ(missing_for_coopmat_mlp(s),
            (std::vector<std::string>{"extension VK_NV_cooperative_matrix", "feature cooperativeMatrix",
                                      "feature shaderFloat16", "a 16x8x16 fp16 x fp16 + fp32 subgroup shape",
                                      "subgroup size 32 or 64 with basic operations in compute",
                                      "49152 bytes of compute shared memory"}));
  s.ext_nv_cooperative_matrix = s.nv_cooperative_matrix = s.shader_float16 = s.nv_matrix_16x8x16 = true;
  s.subgroup_size = 32;
  s.subgroup_compute_basic = true;
  s.max_compute_shared_memory = kCoopmatMlpSharedBytes;
  EXPECT_TRUE(missing_for_coopmat_mlp(s).empty());
  s.subgroup_size = 64;
  EXPECT_TRUE(missing_for_coopmat_mlp(s).empty());
  s.subgroup_size = 16;  // more than two subgroups per workgroup: the kernel's staging has two
  EXPECT_EQ(missing_for_coopmat_mlp(s),
            (std::vector<std::string>{"subgroup size 32 or 64 with basic operations in compute"}));
  s.subgroup_size = 32;
  s.max_compute_shared_memory = kCoopmatMlpSharedBytes - 1;
  EXPECT_EQ(missing_for_coopmat_mlp(s), (std::vector<std::string>{"49152 bytes of compute shared memory"}));

  LsnifDeviceFeatures f;
  lsnifInitDeviceFeatures(&f, nullptr);
  EXPECT_EQ(coopmat_mlp_features_not_enabled(&f.features2),
            (std::vector<std::string>{"feature cooperativeMatrix", "feature shaderFloat16"}));
  VkPhysicalDeviceCooperativeMatrixFeaturesNV cm{};
  cm.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_COOPERATIVE_MATRIX_FEATURES_NV;
  cm.cooperativeMatrix = VK_TRUE;
  cm.pNext = &f.features2;
  f.vulkan12.shaderFloat16 = VK_TRUE;
  EXPECT_TRUE(coopmat_mlp_features_not_enabled(&cm).empty());
  f.features2.pNext = &f.accelerationStructure;  // Vulkan 1.2's struct out (both in one chain is invalid)
  EXPECT_EQ(coopmat_mlp_features_not_enabled(&cm), (std::vector<std::string>{"feature shaderFloat16"}));
  VkPhysicalDeviceShaderFloat16Int8Features f16{};  // the extension's struct counts as well
  f16.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_FLOAT16_INT8_FEATURES;
  f16.shaderFloat16 = VK_TRUE;
  f16.pNext = &cm;
  EXPECT_TRUE(coopmat_mlp_features_not_enabled(&f16).empty());
}

TEST(DeviceFeatures, EnableSetsWhatItFindsAndNamesWhatIsAbsent) {
  VkPhysicalDeviceBufferDeviceAddressFeatures bda{};
  bda.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES;
  VkPhysicalDeviceRayTracingPipelineFeaturesKHR rt{};
  rt.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR;
  rt.pNext = &bda;
  VkPhysicalDeviceFeatures2 f2{};
  f2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
  f2.pNext = &rt;
  EXPECT_EQ(lsnifEnableDeviceFeatures(&f2), LSNIF_ERROR_INVALID_ARGUMENT);
  const std::string message = lsnifGetLastErrorMessage();
  EXPECT_NE(message.find("VkPhysicalDeviceAccelerationStructureFeaturesKHR"), std::string::npos) << message;
  EXPECT_EQ(message.find("VkPhysicalDeviceFeatures2"), std::string::npos) << message;
  EXPECT_EQ(f2.features.shaderInt64, VK_TRUE);
  EXPECT_EQ(rt.rayTracingPipeline, VK_TRUE);
  EXPECT_EQ(bda.bufferDeviceAddress, VK_TRUE);

  VkPhysicalDeviceAccelerationStructureFeaturesKHR as{};
  as.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR;
  bda.pNext = &as;
  EXPECT_EQ(lsnifEnableDeviceFeatures(&f2), LSNIF_SUCCESS);
  EXPECT_EQ(as.accelerationStructure, VK_TRUE);
  EXPECT_TRUE(features_not_enabled(&f2).empty());
  EXPECT_EQ(lsnifEnableDeviceFeatures(nullptr), LSNIF_ERROR_INVALID_ARGUMENT);
}

// The features as data: each entry's struct, member and offset are Vulkan's (offsetof here), and a
// chain built from the table alone -- each listed struct zeroed, each listed member set through its
// offset -- enables exactly what the context check needs; leaving any one out is named.
TEST(DeviceFeatures, RequiredFeaturesAsDataAreWhatTheCheckNeeds) {
  uint32_t count = 0;
  const LsnifFeatureRequirement* req = lsnifGetRequiredDeviceFeatures(&count);
  ASSERT_EQ(count, 4u);
  ASSERT_NE(req, nullptr);
  EXPECT_EQ(std::string(req[0].memberName), "shaderInt64");
  EXPECT_EQ(req[0].sType, VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2);
  EXPECT_EQ(req[0].offset, offsetof(VkPhysicalDeviceFeatures2, features) + offsetof(VkPhysicalDeviceFeatures, shaderInt64));
  EXPECT_EQ(req[0].alternativeSType, VK_STRUCTURE_TYPE_MAX_ENUM);  // VkPhysicalDeviceFeatures: no sType
  EXPECT_EQ(std::string(req[0].alternativeStructName), "VkPhysicalDeviceFeatures");
  EXPECT_EQ(req[0].alternativeOffset, offsetof(VkPhysicalDeviceFeatures, shaderInt64));
  EXPECT_EQ(std::string(req[1].memberName), "bufferDeviceAddress");
  EXPECT_EQ(req[1].offset, offsetof(VkPhysicalDeviceVulkan12Features, bufferDeviceAddress));
  EXPECT_EQ(req[1].alternativeSType, VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES);
  EXPECT_EQ(req[1].alternativeOffset, offsetof(VkPhysicalDeviceBufferDeviceAddressFeatures, bufferDeviceAddress));
  EXPECT_EQ(std::string(req[2].memberName), "accelerationStructure");
  EXPECT_EQ(req[2].offset, offsetof(VkPhysicalDeviceAccelerationStructureFeaturesKHR, accelerationStructure));
  EXPECT_EQ(req[2].alternativeStructName, nullptr);
  EXPECT_EQ(std::string(req[3].memberName), "rayTracingPipeline");
  EXPECT_EQ(req[3].offset, offsetof(VkPhysicalDeviceRayTracingPipelineFeaturesKHR, rayTracingPipeline));
  // A framework's generic code: one zeroed struct per listed sType, chained, each listed member set
  // at its offset; or each alternative: the other struct type, or for a struct without sType the
  // VkPhysicalDeviceFeatures a VkDeviceCreateInfo's pEnabledFeatures points to.
  for (bool alternative : {false, true})
    for (uint32_t skip = 0; skip <= count; ++skip) {  // skip == count: nothing left out
      VkPhysicalDeviceFeatures2 f2{};
      VkPhysicalDeviceVulkan12Features v12{};
      VkPhysicalDeviceBufferDeviceAddressFeatures bda{};
      VkPhysicalDeviceAccelerationStructureFeaturesKHR as{};
      VkPhysicalDeviceRayTracingPipelineFeaturesKHR rt{};
      VkPhysicalDeviceFeatures core{};
      VkDeviceCreateInfo dci{};
      const std::pair<VkStructureType, VkBaseOutStructure*> storage[] = {
          {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, reinterpret_cast<VkBaseOutStructure*>(&f2)},
          {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, reinterpret_cast<VkBaseOutStructure*>(&v12)},
          {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES, reinterpret_cast<VkBaseOutStructure*>(&bda)},
          {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR,
           reinterpret_cast<VkBaseOutStructure*>(&as)},
          {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR, reinterpret_cast<VkBaseOutStructure*>(&rt)}};
      VkBaseOutStructure* head = nullptr;
      bool core_apart = false;
      for (uint32_t i = 0; i < count; ++i) {
        const bool alt = alternative && req[i].alternativeStructName;
        const VkBool32 on = VK_TRUE;
        if (alt && req[i].alternativeSType == VK_STRUCTURE_TYPE_MAX_ENUM) {  // the struct without sType
          core_apart = true;
          if (i != skip) std::memcpy(reinterpret_cast<uint8_t*>(&core) + req[i].alternativeOffset, &on, sizeof on);
          continue;
        }
        const VkStructureType type = alt ? req[i].alternativeSType : req[i].sType;
        VkBaseOutStructure* s = nullptr;
        for (const auto& [t, p] : storage)
          if (t == type) s = p;
        ASSERT_NE(s, nullptr) << type;
        s->sType = type;
        s->pNext = head;
        head = s;
        if (i != skip) std::memcpy(reinterpret_cast<uint8_t*>(s) + (alt ? req[i].alternativeOffset : req[i].offset), &on,
                                   sizeof on);
      }
      if (core_apart) {
        dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
        dci.pNext = head;
        dci.pEnabledFeatures = &core;
        head = reinterpret_cast<VkBaseOutStructure*>(&dci);
      }
      EXPECT_EQ(core_apart, alternative);
      const std::vector<std::string> off = features_not_enabled(head);
      if (skip == count)
        EXPECT_TRUE(off.empty()) << off.front();
      else
        EXPECT_EQ(off, std::vector<std::string>{std::string("feature ") + req[skip].memberName}) << skip;
    }
  EXPECT_EQ(lsnifGetRequiredDeviceFeatures(nullptr), req);
}

// Core features kept apart from the chain (VkDeviceCreateInfo::pEnabledFeatures beside a chain
// without VkPhysicalDeviceFeatures2): set in both; a chain lacking a struct, or holding a
// VkPhysicalDeviceFeatures2, is named; lsnifEnableDeviceFeatures on such a chain points here.
TEST(DeviceFeatures, EnableWithCoreSetsTheCoreFeaturesApart) {
  VkPhysicalDeviceFeatures core{};
  VkPhysicalDeviceRayTracingPipelineFeaturesKHR rt{};
  rt.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR;
  VkPhysicalDeviceBufferDeviceAddressFeatures bda{};
  bda.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES;
  bda.pNext = &rt;
  EXPECT_EQ(lsnifEnableDeviceFeatures(&bda), LSNIF_ERROR_INVALID_ARGUMENT);
  std::string message = lsnifGetLastErrorMessage();
  EXPECT_NE(message.find("VkPhysicalDeviceFeatures::shaderInt64"), std::string::npos) << message;
  EXPECT_NE(message.find("lsnifEnableDeviceFeaturesWithCore"), std::string::npos) << message;

  bda.bufferDeviceAddress = rt.rayTracingPipeline = VK_FALSE;
  EXPECT_EQ(lsnifEnableDeviceFeaturesWithCore(&core, &bda), LSNIF_ERROR_INVALID_ARGUMENT);
  message = lsnifGetLastErrorMessage();
  EXPECT_NE(message.find("lacks VkPhysicalDeviceAccelerationStructureFeaturesKHR"), std::string::npos) << message;
  EXPECT_EQ(message.find("VkPhysicalDeviceFeatures2"), std::string::npos) << message;
  EXPECT_EQ(core.shaderInt64, VK_TRUE);  // what was found is set
  EXPECT_EQ(bda.bufferDeviceAddress, VK_TRUE);
  EXPECT_EQ(rt.rayTracingPipeline, VK_TRUE);

  VkPhysicalDeviceAccelerationStructureFeaturesKHR as{};
  as.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR;
  rt.pNext = &as;
  core = VkPhysicalDeviceFeatures{};
  core.samplerAnisotropy = VK_TRUE;  // the framework's own, kept
  EXPECT_EQ(lsnifEnableDeviceFeaturesWithCore(&core, &bda), LSNIF_SUCCESS) << lsnifGetLastErrorMessage();
  EXPECT_EQ(core.shaderInt64, VK_TRUE);
  EXPECT_EQ(core.samplerAnisotropy, VK_TRUE);
  EXPECT_TRUE(features_not_enabled(&bda, &core).empty());
  EXPECT_EQ(features_not_enabled(&bda), std::vector<std::string>{"feature shaderInt64"});

  VkPhysicalDeviceFeatures2 f2{};
  f2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
  as.pNext = &f2;
  EXPECT_EQ(lsnifEnableDeviceFeaturesWithCore(&core, &bda), LSNIF_ERROR_INVALID_ARGUMENT);
  message = lsnifGetLastErrorMessage();
  EXPECT_NE(message.find("reaches core features"), std::string::npos) << message;
  EXPECT_EQ(f2.features.shaderInt64, VK_FALSE);  // refused before anything is written
  // So is a create info whose own pEnabledFeatures the device would read instead.
  as.pNext = nullptr;
  VkPhysicalDeviceFeatures other{};
  VkDeviceCreateInfo dci{};
  dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  dci.pNext = &bda;
  dci.pEnabledFeatures = &other;
  EXPECT_EQ(lsnifEnableDeviceFeaturesWithCore(&core, &dci), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(other.shaderInt64, VK_FALSE);
  dci.pEnabledFeatures = nullptr;
  EXPECT_EQ(lsnifEnableDeviceFeaturesWithCore(&core, &dci), LSNIF_SUCCESS) << lsnifGetLastErrorMessage();
  EXPECT_EQ(lsnifEnableDeviceFeaturesWithCore(nullptr, &bda), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(lsnifEnableDeviceFeaturesWithCore(&core, nullptr), LSNIF_ERROR_INVALID_ARGUMENT);
}

// A framework's own VkDeviceCreateInfo: its structs in its order, the core features in
// pEnabledFeatures (read-only), a struct of a feature promoted to 1.2 (which rules out
// VkPhysicalDeviceVulkan12Features). Found structs are updated, missing ones appended once.
TEST(DeviceFeatures, EnableInCreateInfoUpdatesFoundStructsAndAppendsMissingOnes) {
  static const VkPhysicalDeviceFeatures core = [] {
    VkPhysicalDeviceFeatures c{};
    c.samplerAnisotropy = VK_TRUE;
    return c;
  }();
  VkPhysicalDeviceRayTracingPipelineFeaturesKHR rt{};
  rt.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR;
  rt.rayTraversalPrimitiveCulling = VK_TRUE;
  VkPhysicalDeviceDescriptorIndexingFeatures indexing{};
  indexing.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DESCRIPTOR_INDEXING_FEATURES;
  indexing.runtimeDescriptorArray = VK_TRUE;
  indexing.pNext = &rt;
  VkDeviceCreateInfo dci{};
  dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  dci.pNext = &indexing;
  dci.pEnabledFeatures = &core;
  EXPECT_FALSE(features_not_enabled(&dci).empty());
  LsnifDeviceFeatureStorage storage;
  std::memset(&storage, 0xAB, sizeof storage);  // garbage: what is appended must be written
  ASSERT_EQ(lsnifEnableDeviceFeaturesInCreateInfo(&dci, &storage), LSNIF_SUCCESS) << lsnifGetLastErrorMessage();
  EXPECT_TRUE(features_not_enabled(&dci).empty());
  EXPECT_EQ(rt.rayTracingPipeline, VK_TRUE);
  EXPECT_EQ(rt.rayTraversalPrimitiveCulling, VK_TRUE) << "the application's own features stay";
  EXPECT_EQ(indexing.runtimeDescriptorArray, VK_TRUE);
  EXPECT_EQ(dci.pEnabledFeatures, nullptr) << "VkPhysicalDeviceFeatures2 carries the core features now";
  EXPECT_EQ(core.shaderInt64, VK_FALSE) << "pEnabledFeatures is never written";
  EXPECT_EQ(storage.features2.features.samplerAnisotropy, VK_TRUE);
  EXPECT_EQ(storage.features2.features.shaderInt64, VK_TRUE);
  EXPECT_EQ(storage.features2.features.robustBufferAccess, VK_FALSE);
  EXPECT_EQ(storage.accelerationStructure.accelerationStructureCaptureReplay, VK_FALSE);
  // The chain: the application's structs first, then the appended ones in the storage's order,
  // without the ray-tracing struct the chain had.
  std::vector<const void*> chain;
  for (auto* s = static_cast<const VkBaseInStructure*>(dci.pNext); s; s = s->pNext) chain.push_back(s);
  EXPECT_EQ(chain, (std::vector<const void*>{&indexing, &rt, &storage.features2, &storage.bufferDeviceAddress,
                                             &storage.accelerationStructure}));
  ASSERT_EQ(lsnifEnableDeviceFeaturesInCreateInfo(&dci, &storage), LSNIF_SUCCESS);
  size_t again = 0;
  for (auto* s = static_cast<const VkBaseInStructure*>(dci.pNext); s; s = s->pNext) ++again;
  EXPECT_EQ(again, chain.size()) << "a second call appends nothing";

  // An empty create info gets every struct; pEnabledFeatures NULL stays NULL.
  VkDeviceCreateInfo empty{};
  empty.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  ASSERT_EQ(lsnifEnableDeviceFeaturesInCreateInfo(&empty, &storage), LSNIF_SUCCESS);
  EXPECT_TRUE(features_not_enabled(&empty).empty());
  EXPECT_EQ(storage.features2.features.samplerAnisotropy, VK_FALSE);

  EXPECT_EQ(lsnifEnableDeviceFeaturesInCreateInfo(nullptr, &storage), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(lsnifEnableDeviceFeaturesInCreateInfo(&empty, nullptr), LSNIF_ERROR_INVALID_ARGUMENT);
  VkPhysicalDeviceFeatures2 not_a_create_info{};
  not_a_create_info.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
  EXPECT_EQ(lsnifEnableDeviceFeaturesInCreateInfo(reinterpret_cast<VkDeviceCreateInfo*>(&not_a_create_info), &storage),
            LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(lsnifGetLastErrorMessage()).find("VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO"), std::string::npos);
  EXPECT_EQ(not_a_create_info.pNext, nullptr);
}

// The hint for core features that a chain without VkPhysicalDeviceFeatures2 cannot show.
TEST(DeviceFeatures, CoreFeaturesHintNamesTheCreateInfo) {
  LsnifDeviceFeatures f;
  lsnifInitDeviceFeatures(&f, nullptr);
  EXPECT_EQ(core_features_hint(&f.features2), "");
  EXPECT_NE(core_features_hint(&f.vulkan12).find("pass the VkDeviceCreateInfo itself"), std::string::npos);
}

TEST(PluginApi, ExtensionsResultsAndVersions) {
  uint32_t count = 0;
  const char* const* names = lsnifGetRequiredDeviceExtensions(&count);
  ASSERT_EQ(count, 3u);
  EXPECT_STREQ(names[0], "VK_KHR_acceleration_structure");
  EXPECT_STREQ(names[1], "VK_KHR_ray_tracing_pipeline");
  EXPECT_STREQ(names[2], "VK_KHR_deferred_host_operations");
  EXPECT_STREQ(lsnifResultString(LSNIF_ERROR_INVALID_MODEL), "LSNIF_ERROR_INVALID_MODEL");
  EXPECT_STREQ(lsnifResultString(LsnifResult(-99)), "unknown LsnifResult");
  EXPECT_EQ(lsnifGetVersion(), LSNIF_HEADER_VERSION);
  EXPECT_EQ(LSNIF_VERSION_GET_MAJOR(lsnifGetVersion()), uint32_t(LSNIF_VERSION_MAJOR));
  EXPECT_EQ(LSNIF_VERSION_GET_MINOR(lsnifGetVersion()), uint32_t(LSNIF_VERSION_MINOR));
  EXPECT_EQ(LSNIF_VERSION_GET_PATCH(lsnifGetVersion()), uint32_t(LSNIF_VERSION_PATCH));
  EXPECT_EQ(lsnifGetGpuLayoutVersion(), LSNIF_GPU_VERSION);
}

TEST(PluginApi, EmbeddedIntersectionShaders) {
  const uint32_t* table = nullptr;
  const uint32_t* record = nullptr;
  size_t table_bytes = 0, record_bytes = 0;
  ASSERT_EQ(lsnifGetIntersectionShaderSpirv(LSNIF_MODEL_LOOKUP_INSTANCE_TABLE, &table, &table_bytes), LSNIF_SUCCESS);
  ASSERT_EQ(lsnifGetIntersectionShaderSpirv(LSNIF_MODEL_LOOKUP_SHADER_RECORD, &record, &record_bytes), LSNIF_SUCCESS);
  for (auto [code, bytes] : {std::pair{table, table_bytes}, std::pair{record, record_bytes}}) {
    ASSERT_NE(code, nullptr);
    EXPECT_GT(bytes, 1000u);
    EXPECT_EQ(bytes % 4, 0u);
    EXPECT_EQ(code[0], 0x07230203u);  // SPIR-V magic
  }
  EXPECT_TRUE(table_bytes != record_bytes || std::memcmp(table, record, table_bytes) != 0)
      << "the two model lookups compiled to the same SPIR-V";
  const uint32_t* code = nullptr;
  size_t bytes = 0;
  EXPECT_EQ(lsnifGetIntersectionShaderSpirv(LsnifModelLookup(7), &code, &bytes), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(lsnifGetLastErrorMessage()).find("unknown LsnifModelLookup 7"), std::string::npos);
  EXPECT_EQ(lsnifGetIntersectionShaderSpirv(LSNIF_MODEL_LOOKUP_INSTANCE_TABLE, nullptr, &bytes),
            LSNIF_ERROR_INVALID_ARGUMENT);
}

// Hostile chains: each is refused by every entry point that takes a chain, with a message, and no
// walk hangs. A loop of two feature structs, a struct pointing to itself, a loop among structs
// LSNIF does not know, a chain longer than any walk goes, and a struct LSNIF reads given twice.
struct HostileChains {
  VkPhysicalDeviceFeatures2 f2{}, f2b{};
  VkPhysicalDeviceVulkan12Features v12{};
  VkPhysicalDeviceAccelerationStructureFeaturesKHR as{};
  VkPhysicalDeviceRayTracingPipelineFeaturesKHR rt{};
  VkPhysicalDeviceDescriptorIndexingFeatures u1{}, u2{};
  std::vector<VkPhysicalDeviceDescriptorIndexingFeatures> longer;

  void reset() {
    for (VkPhysicalDeviceFeatures2* f : {&f2, &f2b}) f->sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
    v12.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES;
    as.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR;
    rt.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR;
    for (auto* u : {&u1, &u2}) u->sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DESCRIPTOR_INDEXING_FEATURES;
  }
};

// Builds each hostile chain in `h` in turn (links set just before use, since they overlap) and calls
// check(first struct, the refusal's words for that chain, the words for the same chain behind a
// VkDeviceCreateInfo, which counts as its structure 0).
template <class Check>
void for_each_hostile_chain(HostileChains& h, Check&& check) {
  h.reset();
  // Two feature structs pointing at each other.
  h.f2.pNext = &h.v12;
  h.v12.pNext = &h.f2;
  check(static_cast<void*>(&h.f2), "the chain loops: structure 1 (sType 51) points back to structure 0",
        "the chain loops: structure 2 (sType 51) points back to structure 1");
  // A struct pointing to itself, behind a good one.
  h.f2.pNext = &h.as;
  h.as.pNext = &h.as;
  check(static_cast<void*>(&h.f2), "the chain loops: structure 1 (sType 1000150013) points back to structure 1",
        "the chain loops: structure 2 (sType 1000150013) points back to structure 2");
  // A loop among structs LSNIF does not read, behind the ones it does.
  h.f2.pNext = &h.rt;
  h.rt.pNext = &h.u1;
  h.u1.pNext = &h.u2;
  h.u2.pNext = &h.u1;
  check(static_cast<void*>(&h.f2), "the chain loops: structure 3 (sType 1000161001) points back to structure 2",
        "the chain loops: structure 4 (sType 1000161001) points back to structure 3");
  // Longer than any walk goes (no loop).
  h.longer.assign(kMaxChainLength + 1, h.u1);
  for (size_t i = 0; i + 1 < h.longer.size(); ++i) h.longer[i].pNext = &h.longer[i + 1];
  h.longer.back().pNext = nullptr;
  h.f2.pNext = h.longer.data();
  check(static_cast<void*>(&h.f2), "the chain has more than 256 structures", "the chain has more than 256 structures");
  // The same struct type twice (which one would count?).
  h.f2.pNext = &h.as;
  h.as.pNext = &h.f2b;
  h.f2b.pNext = nullptr;
  check(static_cast<void*>(&h.f2), "structures 0 and 2 of the chain have the same sType 1000059000",
        "structures 1 and 3 of the chain have the same sType 1000059000");
}

TEST(DeviceFeatures, LoopedAndRepeatedChainsAreRefusedByEveryEntryPoint) {
  HostileChains h;
  const auto last = [] { return std::string(lsnifGetLastErrorMessage()); };
  for_each_hostile_chain(h, [&](void* chain, const std::string& words, const std::string& behind_create_info) {
    SCOPED_TRACE(words);
    EXPECT_EQ(lsnifEnableDeviceFeatures(chain), LSNIF_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(last().find("lsnifEnableDeviceFeatures: pFeatureChain: " + words), std::string::npos) << last();
    VkDeviceCreateInfo dci{};
    dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    dci.pNext = chain;
    LsnifDeviceFeatureStorage storage{};
    const void* before = dci.pNext;
    EXPECT_EQ(lsnifEnableDeviceFeaturesInCreateInfo(&dci, &storage), LSNIF_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(last().find("lsnifEnableDeviceFeaturesInCreateInfo: pCreateInfo: " + behind_create_info),
              std::string::npos)
        << last();
    EXPECT_EQ(dci.pNext, before) << "nothing appended";
    // lsnifCreateContext reads the chain it is given before anything else.
    LsnifContextCreateInfo info{};
    info.pEnabledFeatures = chain;
    LsnifContext ctx = nullptr;
    EXPECT_EQ(lsnifCreateContext(&info, &ctx), LSNIF_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(last().find("lsnifCreateContext: pEnabledFeatures: " + words), std::string::npos) << last();
    EXPECT_EQ(ctx, nullptr);
    // lsnifInitDeviceFeatures returns no result: its bounded walk ends, the chain is attached as
    // given (lsnifCreateContext refuses it later, as above).
    LsnifDeviceFeatures f;
    lsnifInitDeviceFeatures(&f, chain);
    EXPECT_EQ(f.rayTracingPipeline.pNext, chain);
  });
  // Vulkan allows VkPhysicalDeviceFeatures2 or pEnabledFeatures, not both.
  static const VkPhysicalDeviceFeatures core{};
  VkPhysicalDeviceFeatures2 f2{};
  f2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
  VkDeviceCreateInfo dci{};
  dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  dci.pNext = &f2;
  dci.pEnabledFeatures = &core;
  LsnifDeviceFeatureStorage storage{};
  EXPECT_EQ(lsnifEnableDeviceFeaturesInCreateInfo(&dci, &storage), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last().find("VkPhysicalDeviceFeatures2 and the VkDeviceCreateInfo's pEnabledFeatures"), std::string::npos)
      << last();
  LsnifContextCreateInfo info{};
  info.pEnabledFeatures = &dci;
  LsnifContext ctx = nullptr;
  EXPECT_EQ(lsnifCreateContext(&info, &ctx), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last().find("pEnabledFeatures: the chain has a VkPhysicalDeviceFeatures2"), std::string::npos) << last();
}

// A context handle that lsnifCreateContext did not make (or that was destroyed) is refused by
// every entry point without being read; destroying it is a no-op with a message.
TEST(PluginApi, AContextThatIsNotLiveIsRefusedUnread) {
  alignas(16) unsigned char garbage[4096];
  std::memset(garbage, 0xAB, sizeof garbage);
  const LsnifContext stale = reinterpret_cast<LsnifContext>(garbage);
  const auto last = [] { return std::string(lsnifGetLastErrorMessage()); };
  LsnifModel model = nullptr;
  EXPECT_EQ(lsnifCreateModelFromMemory(stale, "x", 1, &model), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last().find("is not a live context"), std::string::npos) << last();
  EXPECT_EQ(lsnifCreateModelFromFile(stale, "x.lsnif", &model), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(lsnifBuildModels(stale, 0, nullptr), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(lsnifGetQueryBroadPhase(stale, nullptr), LSNIF_QUERY_BROAD_PHASE_NONE);
  lsnifDestroyModel(stale, nullptr);
  lsnifDestroyQueryPipeline(stale, nullptr);
  lsnifDestroyContext(stale);
  EXPECT_NE(last().find("lsnifDestroyContext: context"), std::string::npos) << last();
  for (unsigned char b : garbage) ASSERT_EQ(b, 0xAB) << "the handle's memory was written";
}

TEST(PluginApi, NullArgumentsAreErrorsNotCrashes) {
  LsnifContext ctx = nullptr;
  EXPECT_EQ(lsnifCreateContext(nullptr, &ctx), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(lsnifGetLastErrorMessage()).find("pCreateInfo is NULL"), std::string::npos);
  LsnifContextCreateInfo info{};
  EXPECT_EQ(lsnifCreateContext(&info, &ctx), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(lsnifGetLastErrorMessage()).find("null handle"), std::string::npos);
  EXPECT_EQ(ctx, nullptr);
  LsnifModel model = nullptr;
  EXPECT_EQ(lsnifCreateModelFromMemory(nullptr, "x", 1, &model), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(lsnifCreateModelFromFile(nullptr, "x.lsnif", &model), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(lsnifBuildModels(nullptr, 0, nullptr), LSNIF_ERROR_INVALID_ARGUMENT);
  LsnifDeviceSupport support;
  EXPECT_EQ(lsnifQueryDeviceSupport(nullptr, nullptr, nullptr, &support), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(model, nullptr);
  lsnifDestroyContext(nullptr);
  lsnifDestroyModel(nullptr, nullptr);
}

}  // namespace
}  // namespace lsnif::plugin
