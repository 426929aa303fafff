// The plugin's C API (src/lsnif/lsnif.h) on the Vulkan context's device (lavapipe, validation on):
//  - device support, context creation and its errors (null handles, reserved fields, a queue family
//    without compute, an enabled-feature chain that lacks a feature, a real device created without
//    VK_KHR_acceleration_structure), the error callback and the thread's last message;
//  - models from a file and from bytes (properties against the CPU model, memory against the block
//    the CPU packs), corrupt models refused, blocking and recorded builds (with the staging upload),
//    instance records and their field checks, model tables with holes;
//  - traces through the embedded intersection shader against the CPU reference for both model
//    lookups, and every broken convention as a documented miss: a table address of 0, an index past
//    the table, a hole, a block of another layout version or magic; a shader record of 0;
//  - the application's allocation callbacks balanced, and no leak at vkDestroyDevice.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "lsnif/testing/gpu_model.h"
#include "lsnif/testing/gpu_test_support.h"
#include "lsnif/core/intersector.h"
#include <volk.h>  // before lsnif.h, which then uses volk's Vulkan declarations

#include "lsnif/lsnif.hpp"
#include "lsnif/import/mesh.h"
#include "lsnif/vulkan/plugin_device.h"
#include "lsnif/testing/test_plugin.h"
#include "lsnif/testing/test_support.h"
#include "lsnif/testing/test_models.h"
#include "lsnif/train/trainer.h"
#include "lsnif/vulkan/raytracing.h"

namespace lsnif {
namespace {

using namespace gputest;

// The conformance test's ray-tracing shaders: one ray per launch from a ray buffer, one
// LsnifReferenceHit per ray (closest hit decoded with lsnif_hit.glsl).
#include "rt_conformance_rchit_spirv.h"
#include "rt_conformance_rgen_spirv.h"
#include "rt_conformance_rmiss_spirv.h"

const std::string kElephant = test::data_dir() + "/meshes/elephant.off";

// The push constant block of rt_conformance_common.glsl.
using RtPush = RtConformancePush;

vk::RtShaders shaders(LsnifModelLookup lookup, std::vector<std::vector<uint8_t>> records = {}) {
  vk::RtShaders s;
  s.raygen = spirv(rt_conformance_rgen_spirv, sizeof rt_conformance_rgen_spirv);
  s.miss = spirv(rt_conformance_rmiss_spirv, sizeof rt_conformance_rmiss_spirv);
  s.closest_hit = spirv(rt_conformance_rchit_spirv, sizeof rt_conformance_rchit_spirv);
  s.intersection = TestPlugin::intersection_shader(lookup);
  s.procedural_records = std::move(records);
  return s;
}

std::vector<uint8_t> address_bytes(uint64_t address) {
  std::vector<uint8_t> b(LSNIF_SHADER_RECORD_SIZE);
  std::memcpy(b.data(), &address, sizeof address);
  return b;
}

Transform3x4 skewed() {
  Transform3x4 xf = test::skewed_instance();
  return xf;
}

std::string last_error() { return lsnifGetLastErrorMessage(); }

class PluginApi : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    vk_status_ = vk_.init(/*ray_tracing=*/true, test::test_validation(), test::test_device());
    if (vk_status_) vk_status_ = tracer_.init();
    if (vk_status_) vk_status_ = tracer_.create_pipeline(shaders(LSNIF_MODEL_LOOKUP_INSTANCE_TABLE), sizeof(RtPush),
                                                         table_pipeline_);
    if (!std::filesystem::exists(kElephant)) {
      model_status_ = Status::error("%s missing: run scripts/setup.sh", kElephant.c_str());
      return;
    }
    Mesh mesh;
    model_status_ = load_mesh(kElephant, mesh);
    if (model_status_) model_status_ = test::tiny_model("elephant.segments", mesh, tiny_settings(HitParam::VoxelSegments), model_);
    if (model_status_) model_status_ = save_model_to_memory(model_, bytes_);
  }
  static void TearDownTestSuite() {
    tracer_.destroy(table_pipeline_);
    vk_.destroy_device();
  }
  void SetUp() override {
    ASSERT_TRUE(vk_status_) << "no usable Vulkan ray-tracing device: " << vk_status_.message();
    ASSERT_TRUE(model_status_) << model_status_.message();
    vk_.reset_validation_counts();
  }
  void TearDown() override {
    EXPECT_EQ(vk_.validation_errors(), 0u) << vk_.validation_log();
    EXPECT_EQ(vk_.validation_warnings(), 0u) << vk_.validation_log();
  }

  // A context on the Vulkan context's device.
  static LsnifContextCreateInfo create_info() { return vk::plugin_create_info(vk_); }

  // One instance of model m at `xf` (custom index 0) in `rec`, and a host-visible one-entry model
  // table for it in `table_buf`.
  static Status one_model_table(TestPlugin& plugin, LsnifModel m, const Transform3x4& xf,
                                VkAccelerationStructureInstanceKHR& rec, vk::Buffer& table_buf) {
    std::vector<uint64_t> table;
    if (!plugin.make_instance(m, xf, 0, 0xFF, 0, rec) || !plugin.model_table({m}, table))
      return Status::error("instance record or model table refused");
    if (Status s = vk_.create_buffer(sizeof(uint64_t), table_buf); !s) return s;
    std::memcpy(table_buf.mapped, table.data(), sizeof(uint64_t));
    return Status::ok();
  }

  // Traces `rays` through a TLAS of `records` with `pipeline`, the push constants naming the model
  // table `table` with `count` entries.
  static std::vector<LsnifReferenceHit> trace(vk::RtPipeline& pipeline,
                                              const std::vector<VkAccelerationStructureInstanceKHR>& records,
                                              uint64_t table, uint32_t count, const std::vector<Ray>& rays,
                                              uint32_t ray_flags = 0) {
    std::vector<LsnifReferenceHit> out;
    vk::AccelerationStructure tlas;
    Status s = tracer_.build_tlas(records, tlas);
    if (s) {
      RtPush push;
      push.model_table = table;
      push.model_count = count;
      push.ray_flags = ray_flags;
      s = trace_reference(vk_, tracer_, pipeline, tlas, push, rays, out);
    }
    EXPECT_TRUE(s) << s.message();
    tracer_.destroy(tlas);
    return out;
  }

  // Rays at an instance `xf` of the model (every kind of gpu_test_support.h).
  static std::vector<Ray> rays_at(const Transform3x4& xf, size_t count, uint32_t seed) {
    std::vector<Ray> rays;
    std::vector<int> kinds;
    make_world_rays(model_, instance_of(xf), count, seed, rays, kinds);
    return rays;
  }

  // A GPU answer (`hit`, `t`) for `ray` agrees with the CPU's: the same hit / miss and, for hits,
  // t within 2e-4 of the model's diagonal (in the ray's units of length).
  static bool agrees(bool hit, float t, const LsnifHit& cpu, const Ray& ray) {
    const double diag = double(model_.bounds().diagonal());
    return hit == cpu.hit && (!hit || std::fabs(double(t - cpu.t)) * double(glm::length(ray.direction)) <= 2e-4 * diag);
  }

  // Hits of `gpu` that agree with the CPU reference of instance `xf` (agrees); also counts the
  // GPU's hits.
  static void agreement(const Transform3x4& xf, const std::vector<Ray>& rays, const std::vector<LsnifReferenceHit>& gpu,
                        size_t& agree, size_t& gpu_hits) {
    std::vector<LsnifHit> cpu(rays.size());
    const Status s = intersect(model_, xf, rays.data(), rays.size(), cpu.data());
    ASSERT_TRUE(s) << s.message();
    ASSERT_EQ(gpu.size(), rays.size());
    agree = gpu_hits = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      gpu_hits += gpu[i].hit;
      agree += agrees(gpu[i].hit != 0, gpu[i].t, cpu[i], rays[i]);
    }
  }

  // `rays` (object space of `m`), ray i with flags[i] (or 0), through lsnifCmdIntersectModelRays
  // with `pipeline`. The hit buffer starts as 0xFF bytes, so a field left unwritten shows.
  static std::vector<LsnifQueryHit> intersect_batched(const TestPlugin& plugin, LsnifQueryPipeline pipeline,
                                                      LsnifModel m, const std::vector<Ray>& rays,
                                                      const std::vector<uint32_t>& flags = {}) {
    std::vector<LsnifQueryHit> out;
    const uint32_t n = uint32_t(rays.size());
    VkDeviceSize scratch_bytes = 0;
    EXPECT_EQ(lsnifGetIntersectScratchSize(plugin.context(), m, n, &scratch_bytes), LSNIF_SUCCESS);
    vk::Buffer ray_buf, hit_buf, scratch;
    Status s = vk_.create_buffer(std::max<size_t>(1, n) * sizeof(LsnifQueryRay), ray_buf);
    if (s) s = vk_.create_buffer(std::max<size_t>(1, n) * sizeof(LsnifQueryHit), hit_buf);
    if (s) s = vk_.create_buffer(size_t(scratch_bytes), scratch);
    if (s) {
      auto* r = static_cast<LsnifQueryRay*>(ray_buf.mapped);
      for (uint32_t i = 0; i < n; ++i)
        r[i] = {rays[i].origin.x, rays[i].origin.y, rays[i].origin.z, rays[i].tmin, rays[i].direction.x,
                rays[i].direction.y, rays[i].direction.z, rays[i].tmax, i < flags.size() ? flags[i] : 0u, 0, 0, 0};
      std::memset(hit_buf.mapped, 0xFF, std::max<size_t>(1, n) * sizeof(LsnifQueryHit));
      LsnifIntersectModelRaysInfo info{};
      info.model = m;
      info.rayCount = n;
      info.rays = ray_buf.address;
      info.hits = hit_buf.address;
      info.scratch = scratch.address;
      info.scratchSize = scratch_bytes;
      s = vk_.submit("lsnifCmdIntersectModelRays", [&](VkCommandBuffer cmd) {
        EXPECT_EQ(lsnifCmdIntersectModelRays(plugin.context(), cmd, pipeline, &info), LSNIF_SUCCESS)
            << lsnifGetLastErrorMessage();
      });
    }
    EXPECT_TRUE(s) << s.message();
    if (s) {
      const auto* h = static_cast<const LsnifQueryHit*>(hit_buf.mapped);
      out.assign(h, h + n);
    }
    vk_.destroy_buffer(ray_buf);
    vk_.destroy_buffer(hit_buf);
    vk_.destroy_buffer(scratch);
    return out;
  }

  static size_t count_hits(const std::vector<LsnifReferenceHit>& hits) {
    size_t n = 0;
    for (const LsnifReferenceHit& h : hits) n += h.hit;
    return n;
  }

  static vk::Context vk_;
  static vk::RayTracer tracer_;
  static vk::RtPipeline table_pipeline_;
  static Status vk_status_, model_status_;
  static Model model_;
  static std::vector<uint8_t> bytes_;
};
vk::Context PluginApi::vk_;
vk::RayTracer PluginApi::tracer_(PluginApi::vk_);
vk::RtPipeline PluginApi::table_pipeline_;
Status PluginApi::vk_status_, PluginApi::model_status_;
Model PluginApi::model_;
std::vector<uint8_t> PluginApi::bytes_;

constexpr size_t kRays = 4000;

TEST_F(PluginApi, DeviceSupportOfTheRealDevice) {
  LsnifDeviceSupport s;
  ASSERT_EQ(lsnifQueryDeviceSupport(vk_.instance(), vk_.physical_device(), vkGetInstanceProcAddr, &s), LSNIF_SUCCESS)
      << last_error();
  EXPECT_EQ(s.supported, VK_TRUE) << s.missing;
  EXPECT_STREQ(s.missing, "");
  EXPECT_EQ(std::string(s.deviceName), vk_.device_name());
  EXPECT_GE(VK_API_VERSION_MINOR(s.apiVersion), 2u);
}

TEST_F(PluginApi, ContextCreationErrorsAndTheErrorCallback) {
  struct Seen {
    int calls = 0;
    LsnifResult last = LSNIF_SUCCESS;
    std::string message;
  } seen;
  LsnifContextCreateInfo info = create_info();
  info.pfnErrorCallback = [](LsnifResult r, const char* m, void* user) {
    auto* s = static_cast<Seen*>(user);
    ++s->calls;
    s->last = r;
    s->message = m;
  };
  info.pErrorUserData = &seen;
  LsnifContext ctx = nullptr;

  LsnifContextCreateInfo bad = info;
  bad.device = VK_NULL_HANDLE;
  EXPECT_EQ(lsnifCreateContext(&bad, &ctx), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(ctx, nullptr);
  EXPECT_EQ(seen.calls, 1);
  EXPECT_EQ(seen.last, LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(seen.message, last_error());
  EXPECT_NE(seen.message.find("lsnifCreateContext: null handle"), std::string::npos) << seen.message;

  bad = info;
  bad.pNext = &info;  // not a LsnifContextCoreFeaturesInfo
  EXPECT_EQ(lsnifCreateContext(&bad, &ctx), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("pNext: unknown structure type"), std::string::npos) << last_error();
  bad = info;
  bad.flags = 0x80;
  EXPECT_EQ(lsnifCreateContext(&bad, &ctx), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("unknown flags 0x80"), std::string::npos) << last_error();
  bad = info;
  bad.queueFamilyIndex = 1000;
  EXPECT_EQ(lsnifCreateContext(&bad, &ctx), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("queue family 1000 does not exist"), std::string::npos) << last_error();
  EXPECT_EQ(seen.calls, 4);

  // An enabled-feature chain without rayTracingPipeline: the device was not created for LSNIF.
  LsnifDeviceFeatures features;
  lsnifInitDeviceFeatures(&features, nullptr);
  features.rayTracingPipeline.rayTracingPipeline = VK_FALSE;
  bad = info;
  bad.pEnabledFeatures = &features.features2;
  EXPECT_EQ(lsnifCreateContext(&bad, &ctx), LSNIF_ERROR_DEVICE_UNSUPPORTED);
  EXPECT_NE(last_error().find("without what LSNIF needs enabled: feature rayTracingPipeline"), std::string::npos)
      << last_error();
  features.rayTracingPipeline.rayTracingPipeline = VK_TRUE;
  ASSERT_EQ(lsnifCreateContext(&bad, &ctx), LSNIF_SUCCESS) << last_error();
  lsnifDestroyContext(ctx);
  EXPECT_EQ(seen.calls, 5);

  // A destroyed context is checked like a destroyed model: calls are refused, not crashed on (the
  // destroyed context's callback is not called: its memory is gone), destroying it again does
  // nothing but say so.
  LsnifModel model = nullptr;
  EXPECT_EQ(lsnifCreateModelFromMemory(ctx, "x", 1, &model), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("lsnifCreateModelFromMemory: context"), std::string::npos) << last_error();
  EXPECT_NE(last_error().find("is not a live context"), std::string::npos) << last_error();
  EXPECT_EQ(lsnifBuildModels(ctx, 0, nullptr), LSNIF_ERROR_INVALID_ARGUMENT);
  LsnifQueryInfo query{};
  VkDeviceSize size = 0;
  EXPECT_EQ(lsnifGetQueryScratchSize(ctx, &query, &size), LSNIF_ERROR_INVALID_ARGUMENT);
  lsnifDestroyModel(ctx, model);
  lsnifDestroyContext(ctx);
  EXPECT_NE(last_error().find("lsnifDestroyContext: context"), std::string::npos) << last_error();
  EXPECT_EQ(seen.calls, 5);
}

// Debug names: with VK_EXT_debug_utils enabled on the instance (the Vulkan context enables it with the
// validation layer), every object the library creates is named through
// vkSetDebugUtilsObjectNameEXT. A vkGetInstanceProcAddr wrapper hands the context a recorder of
// the names, which forwards them to the layer.
namespace debug_names {
PFN_vkGetInstanceProcAddr real_get_instance_proc_addr = nullptr;
PFN_vkSetDebugUtilsObjectNameEXT real_set_name = nullptr;
std::vector<std::pair<VkObjectType, uint64_t>> handles;
std::vector<std::string> names;
VKAPI_ATTR VkResult VKAPI_CALL record(VkDevice device, const VkDebugUtilsObjectNameInfoEXT* info) {
  handles.emplace_back(info->objectType, info->objectHandle);
  names.emplace_back(info->pObjectName ? info->pObjectName : "");
  return real_set_name(device, info);
}
VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL get_instance_proc_addr(VkInstance instance, const char* name) {
  if (std::strcmp(name, "vkSetDebugUtilsObjectNameEXT") != 0) return real_get_instance_proc_addr(instance, name);
  real_set_name = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(real_get_instance_proc_addr(instance, name));
  return real_set_name ? reinterpret_cast<PFN_vkVoidFunction>(&record) : nullptr;
}
}  // namespace debug_names

TEST_F(PluginApi, EveryObjectTheLibraryCreatesHasADebugName) {
  LsnifContextCreateInfo info = create_info();
  debug_names::real_get_instance_proc_addr = info.pfnGetInstanceProcAddr;
  debug_names::handles.clear();
  debug_names::names.clear();
  info.pfnGetInstanceProcAddr = debug_names::get_instance_proc_addr;
  plugin::Context ctx;
  ASSERT_EQ(ctx.create(info), LSNIF_SUCCESS) << last_error();
  if (!debug_names::real_set_name) GTEST_SKIP() << "the instance was created without VK_EXT_debug_utils";
  plugin::Model model;
  ASSERT_EQ(model.create_from_memory(ctx.get(), bytes_.data(), bytes_.size()), LSNIF_SUCCESS) << last_error();
  LsnifModel handle = model.get();
  ASSERT_EQ(lsnifBuildModels(ctx.get(), 1, &handle), LSNIF_SUCCESS) << last_error();
  plugin::QueryPipeline batched, tlas;
  ASSERT_EQ(batched.create(ctx.get()), LSNIF_SUCCESS) << last_error();
  const bool with_tlas = tlas.create(ctx.get(), LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT) == LSNIF_SUCCESS;

  auto count = [](VkObjectType type) {
    return size_t(std::count_if(debug_names::handles.begin(), debug_names::handles.end(),
                                [&](const auto& h) { return h.first == type; }));
  };
  auto named = [](const std::string& name) {
    return std::find(debug_names::names.begin(), debug_names::names.end(), name) != debug_names::names.end();
  };
  for (size_t i = 0; i < debug_names::names.size(); ++i) {
    EXPECT_EQ(debug_names::names[i].rfind("lsnif ", 0), 0u) << debug_names::names[i];
    EXPECT_NE(debug_names::handles[i].second, 0u) << debug_names::names[i];
  }
  // The model: its block, the BLAS and its buffers, each buffer with its memory.
  EXPECT_TRUE(named("lsnif model 1: block")) << "names of the model's block";
  EXPECT_TRUE(named("lsnif model 1: block memory"));
  EXPECT_TRUE(named("lsnif model 1: BLAS storage"));
  EXPECT_TRUE(named("lsnif model 1: BLAS input"));
  const LsnifModelProperties props = model.properties();
  EXPECT_NE(std::find(debug_names::handles.begin(), debug_names::handles.end(),
                      std::make_pair(VK_OBJECT_TYPE_ACCELERATION_STRUCTURE_KHR, reinterpret_cast<uint64_t>(props.blas))),
            debug_names::handles.end())
      << "the model's BLAS";
  EXPECT_EQ(count(VK_OBJECT_TYPE_BUFFER), count(VK_OBJECT_TYPE_DEVICE_MEMORY));
  // The blocking build's pool, fence and command buffer; the query pipelines' stages and layout.
  EXPECT_EQ(count(VK_OBJECT_TYPE_COMMAND_POOL), 1u);
  EXPECT_EQ(count(VK_OBJECT_TYPE_FENCE), 1u);
  EXPECT_EQ(count(VK_OBJECT_TYPE_COMMAND_BUFFER), 1u);
  EXPECT_TRUE(named("lsnif query pipeline: narrow stage"));
  EXPECT_TRUE(named("lsnif query pipeline: MLP stage"));
  EXPECT_GE(count(VK_OBJECT_TYPE_PIPELINE), with_tlas ? 8u : 4u);
  EXPECT_GE(count(VK_OBJECT_TYPE_PIPELINE_LAYOUT), with_tlas ? 2u : 1u);
  EXPECT_EQ(count(VK_OBJECT_TYPE_SHADER_MODULE), count(VK_OBJECT_TYPE_PIPELINE) +
                                                      (named("lsnif query pipeline: candidate broad phase") ? 4u : 0u))
      << "one module per compute stage, three per broad-phase pipeline";
  std::printf("debug names: %zu objects (%zu buffers, %zu pipelines), TLAS pipeline %s\n",
              debug_names::names.size(), count(VK_OBJECT_TYPE_BUFFER), count(VK_OBJECT_TYPE_PIPELINE),
              with_tlas ? "created" : "not available here");
}

// A framework that creates its device with the core features in VkDeviceCreateInfo::pEnabledFeatures
// and the other feature structs in a chain without VkPhysicalDeviceFeatures2: its features are set
// by lsnifEnableDeviceFeaturesWithCore and checked by the context through a
// LsnifContextCoreFeaturesInfo; each way to get it wrong is named. (The chain is what the application
// says it enabled; the test's device has every feature, so only the claim decides.)
TEST_F(PluginApi, CoreFeaturesApartFromTheChain) {
  VkPhysicalDeviceFeatures core{};
  VkPhysicalDeviceRayTracingPipelineFeaturesKHR rt{};
  rt.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR;
  VkPhysicalDeviceAccelerationStructureFeaturesKHR as{};
  as.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR;
  as.pNext = &rt;
  VkPhysicalDeviceBufferDeviceAddressFeatures bda{};
  bda.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES;
  bda.pNext = &as;
  ASSERT_EQ(lsnifEnableDeviceFeaturesWithCore(&core, &bda), LSNIF_SUCCESS) << last_error();
  EXPECT_EQ(core.shaderInt64, VK_TRUE);

  LsnifContextCreateInfo info = create_info();
  info.pEnabledFeatures = &bda;
  LsnifContext ctx = nullptr;
  // The chain alone: shaderInt64 is not in it, and the message says where it can be given.
  EXPECT_EQ(lsnifCreateContext(&info, &ctx), LSNIF_ERROR_DEVICE_UNSUPPORTED);
  EXPECT_NE(last_error().find("without what LSNIF needs enabled: feature shaderInt64"), std::string::npos)
      << last_error();
  EXPECT_NE(last_error().find("LsnifContextCoreFeaturesInfo"), std::string::npos) << last_error();
  LsnifContextCoreFeaturesInfo core_info{};
  core_info.sType = LSNIF_STRUCTURE_TYPE_CONTEXT_CORE_FEATURES_INFO;
  core_info.pEnabledFeatures = &core;
  info.pNext = &core_info;
  ASSERT_EQ(lsnifCreateContext(&info, &ctx), LSNIF_SUCCESS) << last_error();
  lsnifDestroyContext(ctx);
  ctx = nullptr;
  // Each feature missing is named, wherever it was to be enabled.
  core.shaderInt64 = VK_FALSE;
  EXPECT_EQ(lsnifCreateContext(&info, &ctx), LSNIF_ERROR_DEVICE_UNSUPPORTED);
  EXPECT_NE(last_error().find("enabled: feature shaderInt64 (lsnif"), std::string::npos) << last_error();
  core.shaderInt64 = VK_TRUE;
  bda.bufferDeviceAddress = VK_FALSE;
  EXPECT_EQ(lsnifCreateContext(&info, &ctx), LSNIF_ERROR_DEVICE_UNSUPPORTED);
  EXPECT_NE(last_error().find("enabled: feature bufferDeviceAddress (lsnif"), std::string::npos) << last_error();
  bda.bufferDeviceAddress = VK_TRUE;
  // Core features in two places, or the core features without the chain, are refused.
  LsnifDeviceFeatures features;
  lsnifInitDeviceFeatures(&features, nullptr);
  info.pEnabledFeatures = &features.features2;
  EXPECT_EQ(lsnifCreateContext(&info, &ctx), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("Vulkan allows them in one place"), std::string::npos) << last_error();
  info.pEnabledFeatures = nullptr;
  EXPECT_EQ(lsnifCreateContext(&info, &ctx), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("needs pEnabledFeatures"), std::string::npos) << last_error();
  info.pEnabledFeatures = &bda;
  core_info.pEnabledFeatures = nullptr;
  EXPECT_EQ(lsnifCreateContext(&info, &ctx), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("LsnifContextCoreFeaturesInfo::pEnabledFeatures is NULL"), std::string::npos)
      << last_error();
  EXPECT_EQ(ctx, nullptr);
}

// A real device of the same physical device created without any extension: the plugin cannot load
// the acceleration-structure functions and says so instead of crashing later.
TEST_F(PluginApi, DeviceWithoutTheExtensionsIsRefused) {
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci{};
  qci.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
  qci.queueFamilyIndex = vk_.queue_family();
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  VkDeviceCreateInfo dci{};
  dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  VkDevice bare = VK_NULL_HANDLE;
  ASSERT_EQ(vkCreateDevice(vk_.physical_device(), &dci, nullptr, &bare), VK_SUCCESS);
  LsnifContextCreateInfo info = create_info();
  info.device = bare;
  info.queue = VK_NULL_HANDLE;
  LsnifContext ctx = nullptr;
  EXPECT_EQ(lsnifCreateContext(&info, &ctx), LSNIF_ERROR_DEVICE_UNSUPPORTED);
  EXPECT_EQ(ctx, nullptr);
  EXPECT_NE(last_error().find("does not provide vkCreateAccelerationStructureKHR"), std::string::npos) << last_error();
  // With the create info's chain given, the missing features are named before any function is loaded.
  info.pEnabledFeatures = &dci;
  EXPECT_EQ(lsnifCreateContext(&info, &ctx), LSNIF_ERROR_DEVICE_UNSUPPORTED);
  EXPECT_NE(last_error().find("feature accelerationStructure, feature rayTracingPipeline, feature "
                              "bufferDeviceAddress, feature shaderInt64"),
            std::string::npos)
      << last_error();
  vkDestroyDevice(bare, nullptr);
}

TEST_F(PluginApi, ModelsFromFileAndMemory) {
  plugin::Context ctx;
  ASSERT_EQ(ctx.create(create_info()), LSNIF_SUCCESS) << last_error();
  test::ScopedTestDir dir("plugin_api");
  const std::string path = dir.path("elephant.lsnif");
  {
    std::ofstream f(path, std::ios::binary);
    f.write(reinterpret_cast<const char*>(bytes_.data()), std::streamsize(bytes_.size()));
  }
  plugin::Model from_file, from_memory;
  ASSERT_EQ(from_file.create_from_file(ctx.get(), path.c_str()), LSNIF_SUCCESS) << last_error();
  ASSERT_EQ(from_memory.create_from_memory(ctx.get(), bytes_.data(), bytes_.size()), LSNIF_SUCCESS) << last_error();

  std::vector<uint32_t> words;
  ASSERT_TRUE(pack_gpu_model(model_, words));
  for (const plugin::Model* m : {&from_file, &from_memory}) {
    const LsnifModelProperties p = m->properties();
    EXPECT_NE(p.blockAddress, 0u);
    EXPECT_EQ(p.blockAddress % 32, 0u);
    EXPECT_NE(p.blasAddress, 0u);
    EXPECT_NE(p.blas, VK_NULL_HANDLE);
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(p.boundsMin[a], model_.bounds().lo[a]);
      EXPECT_EQ(p.boundsMax[a], model_.bounds().hi[a]);
    }
    EXPECT_EQ(p.materialCount, model_.config.material_count);
    EXPECT_EQ(p.gpuLayoutVersion, lsnifGetGpuLayoutVersion());
    EXPECT_EQ(p.buildRecorded, VK_FALSE);
    const LsnifModelMemory mem = m->memory();
    EXPECT_EQ(mem.blockBytes, words.size() * sizeof(uint32_t));  // the block the CPU packs
    EXPECT_GT(mem.blasBytes, 0u);
    EXPECT_GT(mem.buildBytes, 0u);  // AABB input and scratch until the build ran
    EXPECT_GE(mem.allocatedBytes, mem.blockBytes + mem.blasBytes + mem.buildBytes);
  }
  const LsnifModel both[2] = {from_file.get(), from_memory.get()};
  ASSERT_EQ(lsnifBuildModels(ctx.get(), 2, both), LSNIF_SUCCESS) << last_error();
  EXPECT_EQ(from_file.properties().buildRecorded, VK_TRUE);
  EXPECT_EQ(from_file.memory().buildBytes, 0u);  // the blocking build frees them
  EXPECT_EQ(lsnifBuildModels(ctx.get(), 1, both), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("pModels[0]: its build was already recorded"), std::string::npos) << last_error();
  const LsnifModel twice[2] = {both[0], both[0]};
  EXPECT_EQ(lsnifFreeModelBuildResources(ctx.get(), 2, twice), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("pModels[1] appears twice"), std::string::npos) << last_error();

  // Files that are not models.
  LsnifModel m = reinterpret_cast<LsnifModel>(uintptr_t(0x1));  // must stay untouched on failure
  EXPECT_EQ(lsnifCreateModelFromFile(ctx.get(), dir.path("missing.lsnif").c_str(), &m), LSNIF_ERROR_FILE);
  EXPECT_NE(last_error().find("missing.lsnif: no such file"), std::string::npos) << last_error();
  EXPECT_EQ(lsnifCreateModelFromFile(ctx.get(), dir.path().string().c_str(), &m), LSNIF_ERROR_FILE);
  EXPECT_NE(last_error().find("is a directory"), std::string::npos) << last_error();
  EXPECT_EQ(m, reinterpret_cast<LsnifModel>(uintptr_t(0x1)));
}

// A model with 8-bit grid features (the default): its block is the one the CPU packs, smaller
// than the same model's with fp16 features by about half the grid.
TEST_F(PluginApi, EightBitGridModelFromMemory) {
  plugin::Context ctx;
  ASSERT_EQ(ctx.create(create_info()), LSNIF_SUCCESS) << last_error();
  Model narrow = model_, wide = model_;
  narrow.config.grid_bits = 8;
  narrow.quantize();
  wide.config.grid_bits = 16;
  wide.quantize();
  std::vector<uint8_t> bytes, wide_bytes;
  ASSERT_TRUE(save_model_to_memory(narrow, bytes));
  ASSERT_TRUE(save_model_to_memory(wide, wide_bytes));
  plugin::Model m8, m16;
  ASSERT_EQ(m8.create_from_memory(ctx.get(), bytes.data(), bytes.size()), LSNIF_SUCCESS) << last_error();
  ASSERT_EQ(m16.create_from_memory(ctx.get(), wide_bytes.data(), wide_bytes.size()), LSNIF_SUCCESS) << last_error();
  std::vector<uint32_t> words;
  ASSERT_TRUE(pack_gpu_model(narrow, words));
  EXPECT_EQ(m8.memory().blockBytes, words.size() * sizeof(uint32_t));
  const uint64_t grid16 = 2 * model_.config.grid_parameter_count();
  EXPECT_NEAR(double(m16.memory().blockBytes - m8.memory().blockBytes), double(grid16 / 2), 64.0);
  const LsnifModel both[2] = {m8.get(), m16.get()};
  ASSERT_EQ(lsnifBuildModels(ctx.get(), 2, both), LSNIF_SUCCESS) << last_error();
}

TEST_F(PluginApi, CorruptModelsInMemoryAreRefused) {
  TestPlugin plugin;
  ASSERT_TRUE(plugin.init(vk_));
  LsnifModel m = nullptr;
  auto refuse = [&](const std::vector<uint8_t>& b, const char* keyword) {
    m = nullptr;
    const LsnifResult r = lsnifCreateModelFromMemory(plugin.context(), b.data(), b.size(), &m);
    EXPECT_EQ(r, LSNIF_ERROR_INVALID_MODEL) << keyword;
    EXPECT_EQ(m, nullptr);
    EXPECT_NE(last_error().find(keyword), std::string::npos) << last_error();
  };
  refuse({}, "empty");
  std::vector<uint8_t> b = bytes_;
  b[9] ^= 0x01;  // format version
  refuse(b, "unsupported format version");
  b = bytes_;
  b[0] = 'X';
  refuse(b, "bad magic");
  refuse(std::vector<uint8_t>(bytes_.begin(), bytes_.begin() + long(bytes_.size() / 2)), "truncated");
  // Every single flipped byte and every truncation the loader sees is an error, never a model.
  std::mt19937 rng(11);
  for (int i = 0; i < 200; ++i) {
    b = bytes_;
    const size_t at = rng() % b.size();
    b[at] = uint8_t(b[at] ^ (1u + rng() % 255u));
    m = nullptr;
    EXPECT_NE(lsnifCreateModelFromMemory(plugin.context(), b.data(), b.size(), &m), LSNIF_SUCCESS) << "byte " << at;
    EXPECT_EQ(m, nullptr);
    b.resize(rng() % bytes_.size());
    EXPECT_NE(lsnifCreateModelFromMemory(plugin.context(), b.data(), b.size(), &m), LSNIF_SUCCESS) << b.size();
  }
  EXPECT_EQ(lsnifCreateModelFromMemory(plugin.context(), nullptr, 16, &m), LSNIF_ERROR_INVALID_ARGUMENT);
}

TEST_F(PluginApi, RecordedBuildThroughStagingMatchesTheCpu) {
  TestPlugin plugin;
  ASSERT_TRUE(plugin.init(vk_, LSNIF_CONTEXT_CREATE_STAGING_UPLOAD_BIT));
  LsnifModel m = nullptr;
  ASSERT_EQ(lsnifCreateModelFromMemory(plugin.context(), bytes_.data(), bytes_.size(), &m), LSNIF_SUCCESS)
      << last_error();
  LsnifModelMemory mem{};
  ASSERT_EQ(lsnifGetModelMemory(plugin.context(), m, &mem), LSNIF_SUCCESS);
  EXPECT_GE(mem.buildBytes, mem.blockBytes);  // the staging copy of the block is part of it
  Status s = vk_.submit("lsnifCmdBuildModels", [&](VkCommandBuffer cmd) {
    EXPECT_EQ(lsnifCmdBuildModels(plugin.context(), cmd, 1, &m), LSNIF_SUCCESS) << last_error();
  });
  ASSERT_TRUE(s) << s.message();
  EXPECT_EQ(plugin.properties(m).buildRecorded, VK_TRUE);
  ASSERT_EQ(lsnifFreeModelBuildResources(plugin.context(), 1, &m), LSNIF_SUCCESS);
  ASSERT_EQ(lsnifGetModelMemory(plugin.context(), m, &mem), LSNIF_SUCCESS);
  EXPECT_EQ(mem.buildBytes, 0u);
  s = vk_.submit("second record", [&](VkCommandBuffer cmd) {
    EXPECT_EQ(lsnifCmdBuildModels(plugin.context(), cmd, 1, &m), LSNIF_ERROR_INVALID_ARGUMENT);
  });
  ASSERT_TRUE(s) << s.message();

  const Transform3x4 xf = skewed();
  VkAccelerationStructureInstanceKHR rec;
  vk::Buffer table_buf;
  ASSERT_TRUE(one_model_table(plugin, m, xf, rec, table_buf));
  const std::vector<Ray> rays = rays_at(xf, kRays, 5);
  size_t agree = 0, hits = 0;
  agreement(xf, rays, trace(table_pipeline_, {rec}, table_buf.address, 1, rays), agree, hits);
  vk_.destroy_buffer(table_buf);
  EXPECT_GE(double(agree), 0.999 * double(rays.size()));
  EXPECT_GT(hits, rays.size() / 10) << "too few hits to tell anything";
}

TEST_F(PluginApi, InstanceRecordsAndModelTables) {
  TestPlugin plugin, other;
  ASSERT_TRUE(plugin.init(vk_));
  ASSERT_TRUE(other.init(vk_));
  LsnifModel a = nullptr, b = nullptr, foreign = nullptr;
  ASSERT_TRUE(plugin.upload(model_, a));
  ASSERT_TRUE(plugin.upload(model_, b));
  ASSERT_TRUE(other.upload(model_, foreign));
  EXPECT_NE(plugin.properties(a).blockAddress, plugin.properties(b).blockAddress);

  LsnifInstanceInfo info{};
  info.model = a;
  info.transform.matrix[0][0] = 2.0f;
  info.transform.matrix[1][1] = 1.0f;
  info.transform.matrix[2][2] = 0.5f;
  info.transform.matrix[0][3] = 5.0f;
  info.transform.matrix[1][0] = 0.5f;
  info.instanceCustomIndex = (1u << 24) - 1;
  info.mask = 0x0F;
  info.instanceShaderBindingTableRecordOffset = 3;
  info.flags = VK_GEOMETRY_INSTANCE_TRIANGLE_FACING_CULL_DISABLE_BIT_KHR;
  VkAccelerationStructureInstanceKHR rec{};
  ASSERT_EQ(lsnifMakeInstance(plugin.context(), &info, &rec), LSNIF_SUCCESS) << last_error();
  EXPECT_EQ(rec.instanceCustomIndex, (1u << 24) - 1);
  EXPECT_EQ(rec.mask, 0x0Fu);
  EXPECT_EQ(rec.instanceShaderBindingTableRecordOffset, 3u);
  EXPECT_EQ(rec.flags, uint32_t(VK_GEOMETRY_INSTANCE_TRIANGLE_FACING_CULL_DISABLE_BIT_KHR));
  EXPECT_EQ(rec.accelerationStructureReference, plugin.properties(a).blasAddress);
  EXPECT_EQ(std::memcmp(&rec.transform, &info.transform, sizeof rec.transform), 0);

  auto refused = [&](const LsnifInstanceInfo& i, const char* keyword) {
    VkAccelerationStructureInstanceKHR r{};
    r.mask = 0x5A;
    EXPECT_EQ(lsnifMakeInstance(plugin.context(), &i, &r), LSNIF_ERROR_INVALID_ARGUMENT) << keyword;
    EXPECT_NE(last_error().find(keyword), std::string::npos) << last_error();
    EXPECT_EQ(r.mask, 0x5Au) << "written on failure";
  };
  LsnifInstanceInfo i = info;
  i.instanceCustomIndex = 1u << 24;
  refused(i, "instanceCustomIndex 16777216");
  i = info;
  i.mask = 256;
  refused(i, "mask 0x100");
  i = info;
  i.instanceShaderBindingTableRecordOffset = 1u << 24;
  refused(i, "instanceShaderBindingTableRecordOffset 16777216");
  i = info;
  i.transform.matrix[2][1] = std::numeric_limits<float>::quiet_NaN();
  refused(i, "[2][1]");
  i = info;
  for (int c = 0; c < 4; ++c) i.transform.matrix[2][c] = i.transform.matrix[0][c];  // rank 2
  refused(i, "singular");
  i = info;
  i.model = foreign;
  refused(i, "pInfo->model is not a model of this context");
  i = info;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) i.transform.matrix[r][c] = r == c ? 1e-5f : 0.0f;  // tiny, not singular
  EXPECT_EQ(lsnifMakeInstance(plugin.context(), &i, &rec), LSNIF_SUCCESS) << last_error();

  // Holes for triangle instances; a foreign model is refused and leaves the table as it was.
  const LsnifModel models[4] = {b, nullptr, a, b};
  uint64_t table[4] = {7, 7, 7, 7};
  ASSERT_EQ(lsnifWriteModelTable(plugin.context(), 4, models, table), LSNIF_SUCCESS) << last_error();
  EXPECT_EQ(table[0], plugin.properties(b).blockAddress);
  EXPECT_EQ(table[1], 0u);
  EXPECT_EQ(table[2], plugin.properties(a).blockAddress);
  EXPECT_EQ(table[3], plugin.properties(b).blockAddress);
  const LsnifModel bad[2] = {a, foreign};
  uint64_t kept[2] = {7, 7};
  EXPECT_EQ(lsnifWriteModelTable(plugin.context(), 2, bad, kept), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("pModels[1] is not a model of this context"), std::string::npos) << last_error();
  EXPECT_EQ(kept[0], 7u);

  plugin.release(a);
  EXPECT_EQ(lsnifMakeInstance(plugin.context(), &info, &rec), LSNIF_ERROR_INVALID_ARGUMENT);
  lsnifDestroyModel(plugin.context(), a);  // already gone (null): ignored
  lsnifDestroyModel(plugin.context(), foreign);  // another context's: ignored, still usable there
  EXPECT_NE(other.properties(foreign).blockAddress, 0u);
}

// The instance-table lookup with every broken convention: each is a miss, never a fault; the same
// rays through a correct table entry hit as the CPU reference does. The blocks of another layout
// version or magic are copies of the CPU-packed block with one word changed; the unchanged copy is
// the control (it must hit exactly like the plugin's own block).
TEST_F(PluginApi, BrokenTableConventionsAreMisses) {
  TestPlugin plugin;
  ASSERT_TRUE(plugin.init(vk_));
  LsnifModel m = nullptr;
  ASSERT_TRUE(plugin.upload(model_, m));
  std::vector<uint32_t> words;
  ASSERT_TRUE(pack_gpu_model(model_, words));
  vk::Buffer copies[3], table_buf;
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE(vk_.create_buffer(words.size() * sizeof(uint32_t), copies[k]));
    ASSERT_EQ(copies[k].address % 32, 0u);
    std::memcpy(copies[k].mapped, words.data(), words.size() * sizeof(uint32_t));
  }
  static_cast<uint32_t*>(copies[1].mapped)[1] = LSNIF_GPU_VERSION + 1;  // header.version
  static_cast<uint32_t*>(copies[2].mapped)[0] ^= 0x20u;                 // header.magic
  // Entries: 0 the model, 1 a hole, 2 the control copy, 3 another version, 4 another magic.
  const uint64_t table[5] = {plugin.properties(m).blockAddress, 0, copies[0].address, copies[1].address,
                             copies[2].address};
  ASSERT_TRUE(vk_.create_buffer(sizeof table, table_buf));
  std::memcpy(table_buf.mapped, table, sizeof table);

  const Transform3x4 xf = skewed();
  const std::vector<Ray> rays = rays_at(xf, kRays, 9);
  auto run = [&](uint32_t custom_index, uint64_t table_address, uint32_t count) {
    VkAccelerationStructureInstanceKHR rec;
    EXPECT_TRUE(plugin.make_instance(m, xf, custom_index, 0xFF, 0, rec));
    return trace(table_pipeline_, {rec}, table_address, count, rays);
  };
  const std::vector<LsnifReferenceHit> good = run(0, table_buf.address, 5);
  size_t agree = 0, hits = 0;
  agreement(xf, rays, good, agree, hits);
  EXPECT_GE(double(agree), 0.999 * double(rays.size()));
  EXPECT_GT(hits, rays.size() / 10);
  const std::vector<LsnifReferenceHit> control = run(2, table_buf.address, 5);
  ASSERT_EQ(control.size(), good.size());
  size_t same = 0;
  for (size_t i = 0; i < good.size(); ++i) same += good[i].hit == control[i].hit && good[i].t == control[i].t;
  EXPECT_EQ(same, good.size()) << "the CPU-packed copy of the block must behave as the plugin's block";

  EXPECT_EQ(count_hits(run(1, table_buf.address, 5)), 0u) << "a hole (entry 0)";
  EXPECT_EQ(count_hits(run(3, table_buf.address, 5)), 0u) << "a block of another layout version";
  EXPECT_EQ(count_hits(run(4, table_buf.address, 5)), 0u) << "a block with another magic";
  EXPECT_EQ(count_hits(run(0, table_buf.address, 0)), 0u) << "an index past the table (count 0)";
  EXPECT_EQ(count_hits(run(5, table_buf.address, 5)), 0u) << "an index past the table (5 of 5)";
  EXPECT_EQ(count_hits(run(0, 0, 5)), 0u) << "a table address of 0";
  for (vk::Buffer& b : copies) vk_.destroy_buffer(b);
  vk_.destroy_buffer(table_buf);
}

// The shader-record lookup: the hit group's record holds the model address, the custom index is
// the application's (any value), no table is pushed; a record of 0 is a miss.
TEST_F(PluginApi, ShaderRecordLookupMatchesTheCpu) {
  TestPlugin plugin;
  ASSERT_TRUE(plugin.init(vk_));
  LsnifModel m = nullptr;
  ASSERT_TRUE(plugin.upload(model_, m));
  vk::RtPipeline pipeline;
  ASSERT_TRUE(tracer_.create_pipeline(
      shaders(LSNIF_MODEL_LOOKUP_SHADER_RECORD, {address_bytes(plugin.properties(m).blockAddress), address_bytes(0)}),
      sizeof(RtPush), pipeline));
  const Transform3x4 xf = skewed();
  const std::vector<Ray> rays = rays_at(xf, kRays, 13);
  VkAccelerationStructureInstanceKHR rec;
  ASSERT_TRUE(plugin.make_instance(m, xf, 12345, 0xFF, 0, rec));
  size_t agree = 0, hits = 0;
  const std::vector<LsnifReferenceHit> gpu = trace(pipeline, {rec}, 0, 0, rays);
  agreement(xf, rays, gpu, agree, hits);
  EXPECT_GE(double(agree), 0.999 * double(rays.size()));
  EXPECT_GT(hits, rays.size() / 10);
  for (const LsnifReferenceHit& h : gpu) {
    if (!h.hit) continue;
    EXPECT_EQ(h.instance >> 16, 12345u) << "gl_InstanceCustomIndexEXT is the application's";
  }
  ASSERT_TRUE(plugin.make_instance(m, xf, 12345, 0xFF, 1, rec));  // the record holding 0
  EXPECT_EQ(count_hits(trace(pipeline, {rec}, 0, 0, rays)), 0u);
  tracer_.destroy(pipeline);
}

// The batched path (lsnifCmdIntersectModelRays) against the intersection shader on the same rays
// (the same GLSL functions run in another order of passes: walk, encoding, network, heads and the
// acceptance are computed in fp32 on both sides, so the points agree exactly and t and the normal
// to rounding) and against the CPU reference, for every ray kind of gpu_test_support.h, with no
// culling, back-face and front-face culling. The instance is the identity: object = world space.
TEST_F(PluginApi, BatchedQueriesMatchTheIntersectionShaderAndTheCpu) {
  TestPlugin plugin;
  ASSERT_TRUE(plugin.init(vk_));
  // The trained model, then the same with surface channels (random surface rows, emission up to 8):
  // LsnifQueryHit::surface and the emission against the shader's attributes and the CPU's.
  const Model surface_model = with_surface_channels(model_, 8.0f, 41);
  const Model* const models[] = {&model_, &surface_model};
  for (const Model* model : models) {
    SCOPED_TRACE(model->config.describe());
    LsnifModel m = nullptr;
    ASSERT_TRUE(plugin.upload(*model, m));
    LsnifQueryPipeline pipeline = nullptr;
    ASSERT_EQ(lsnifCreateQueryPipeline(plugin.context(), nullptr, &pipeline), LSNIF_SUCCESS) << last_error();
    const Transform3x4 xf;  // identity
    VkAccelerationStructureInstanceKHR rec;
    vk::Buffer table_buf;
    ASSERT_TRUE(one_model_table(plugin, m, xf, rec, table_buf));
    const std::vector<Ray> rays = rays_at(xf, kRays, 21);
    const double diag = double(model->bounds().diagonal());
    const float scale = model->config.emission_scale;

    for (const uint32_t flags : {0u, LSNIF_RAY_FLAG_CULL_BACK_FACING, LSNIF_RAY_FLAG_CULL_FRONT_FACING}) {
      SCOPED_TRACE(testing::Message() << "ray flags 0x" << std::hex << flags);
      const std::vector<LsnifQueryHit> batched =
          intersect_batched(plugin, pipeline, m, rays, std::vector<uint32_t>(rays.size(), flags));
      const std::vector<LsnifReferenceHit> inline_hits = trace(table_pipeline_, {rec}, table_buf.address, 1, rays, flags);
      std::vector<LsnifHit> cpu(rays.size());
      ASSERT_TRUE(intersect(*model, xf, rays.data(), rays.size(), cpu.data(), flags));
      ASSERT_EQ(batched.size(), rays.size());
      ASSERT_EQ(inline_hits.size(), rays.size());
      size_t same_hit = 0, cpu_agree = 0, hits = 0, evaluated = 0;
      SurfaceAgreement surface;  // the batched hits' channels against the CPU's
      double max_dt = 0.0, max_angle = 0.0;
      for (size_t i = 0; i < rays.size(); ++i) {
        const LsnifQueryHit& b = batched[i];
        ASSERT_TRUE(b.kind == LSNIF_QUERY_HIT_NONE || b.kind == LSNIF_QUERY_HIT_LSNIF) << "ray " << i;
        EXPECT_EQ(b.reserved0 | b.reserved1, 0u) << "ray " << i;
        EXPECT_EQ(b.reports_uv, 0u) << "ray " << i << ": a model without uv cells reports no coordinate";
        const bool hit = b.kind == LSNIF_QUERY_HIT_LSNIF;
        hits += hit;
        evaluated += b.points > 0;
        if (b.points == 0) {
          EXPECT_FALSE(hit);
          EXPECT_EQ(b.occlusion_logit, 0.0f);
          EXPECT_EQ(b.surface, 0u);
          EXPECT_EQ(b.emission_r + b.emission_g + b.emission_b, 0.0f);
        }
        // The shader reports points only for hits; where it hit, they must agree exactly.
        if (inline_hits[i].hit) {
          EXPECT_EQ(b.points, inline_hits[i].points) << "ray " << i;
        }
        if (hit == bool(inline_hits[i].hit)) ++same_hit;
        if (hit && inline_hits[i].hit) {
          const double len = double(glm::length(rays[i].direction));
          max_dt = std::max(max_dt, std::fabs(double(b.t - inline_hits[i].t)) * len / diag);
          const glm::vec3 nb(b.normal_x, b.normal_y, b.normal_z);
          const glm::vec3 ni(inline_hits[i].normal_x, inline_hits[i].normal_y, inline_hits[i].normal_z);
          max_angle = std::max(max_angle, double(std::acos(std::clamp(glm::dot(nb, ni), -1.0f, 1.0f))) * 180.0 / M_PI);
          // The shader's attributes hold the same channels (unorm8) and the emission as RGBE.
          EXPECT_EQ(b.surface >> 24, inline_hits[i].surface >> 24) << "ray " << i;
          for (int k = 0; k < 3; ++k)
            EXPECT_LE(std::abs(int((b.surface >> (8 * k)) & 0xffu) - int((inline_hits[i].surface >> (8 * k)) & 0xffu)), 1)
                << "ray " << i;
          const float largest = std::max({b.emission_r, b.emission_g, b.emission_b});
          EXPECT_NEAR(b.emission_r, inline_hits[i].emission_r, std::ldexp(largest, -8) * 1.001f + 1e-6f) << "ray " << i;
          EXPECT_NEAR(b.emission_b, inline_hits[i].emission_b, std::ldexp(largest, -8) * 1.001f + 1e-6f) << "ray " << i;
        }
        const bool agree = agrees(hit, b.t, cpu[i], rays[i]);
        cpu_agree += agree;
        if (agree && hit)
          add_surface(surface, b.surface, glm::vec3(b.emission_r, b.emission_g, b.emission_b), cpu[i], scale,
                      [scale](float) { return 1e-4f * scale; });
      }
      EXPECT_GE(double(same_hit), 0.999 * double(rays.size())) << "hit/miss vs the intersection shader";
      EXPECT_LE(max_dt, 1e-5) << "largest |t difference| / diagonal vs the intersection shader";
      EXPECT_LE(max_angle, 0.05) << "largest normal difference (degrees) vs the intersection shader";
      EXPECT_GE(double(cpu_agree), 0.999 * double(rays.size())) << "agreement with the CPU reference";
      EXPECT_GT(hits, rays.size() / 20) << "too few hits to tell anything";
      EXPECT_LT(evaluated, rays.size()) << "every ray had boundary points: the miss-before-network path is untested";
      expect_surface_agreement(surface, model->config.surface_channels != 0);
    }
    vk_.destroy_buffer(table_buf);
    lsnifDestroyQueryPipeline(plugin.context(), pipeline);
  }
}

// Texture coordinates through the batched path: a model with uv cells (gputest::uv_sphere_model)
// reports on LsnifQueryHit the coordinate its uv cells give at the predicted point, as the CPU
// reference does (fp32 on both sides: the same lookup, a hit point differing in its last bits can
// tip a choice between two pieces whose scores tie, rare and bounded) and as the intersection shader
// packs it into the hit attributes (within half a step of its 16 fractional bits). Misses and hits
// without a piece report none, and their coordinate is zero.
TEST_F(PluginApi, BatchedQueriesReportTextureCoordinates) {
  TestPlugin plugin;
  ASSERT_TRUE(plugin.init(vk_));
  Model model;
  const Status trained = uv_sphere_model(model);
  ASSERT_TRUE(trained) << trained.message();
  ASSERT_EQ(model.config.uv_materials, 1u);
  LsnifModel m = nullptr;
  ASSERT_TRUE(plugin.upload(model, m));
  LsnifQueryPipeline pipeline = nullptr;
  ASSERT_EQ(lsnifCreateQueryPipeline(plugin.context(), nullptr, &pipeline), LSNIF_SUCCESS) << last_error();
  const Transform3x4 xf;  // identity: the batched rays are in object space
  VkAccelerationStructureInstanceKHR rec;
  vk::Buffer table_buf;
  ASSERT_TRUE(one_model_table(plugin, m, xf, rec, table_buf));
  std::vector<Ray> rays;
  std::vector<int> kinds;
  make_world_rays(model, instance_of(xf), kRays, 23, rays, kinds);
  const std::vector<LsnifQueryHit> batched = intersect_batched(plugin, pipeline, m, rays);
  const std::vector<LsnifReferenceHit> shader = trace(table_pipeline_, {rec}, table_buf.address, 1, rays);
  std::vector<LsnifHit> cpu(rays.size());
  ASSERT_TRUE(intersect(model, xf, rays.data(), rays.size(), cpu.data()));
  ASSERT_EQ(batched.size(), rays.size());
  ASSERT_EQ(shader.size(), rays.size());
  const double step = 0.5 / 65536.0 + 1e-6;  // half a step of pack_uv's fixed point
  const double diag = double(model.bounds().diagonal());
  size_t hits = 0, reported = 0;
  size_t cpu_both = 0, cpu_one_side = 0, cpu_apart = 0, shader_both = 0, shader_one_side = 0, shader_apart = 0;
  double cpu_max = 0.0, shader_max = 0.0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const LsnifQueryHit& b = batched[i];
    EXPECT_EQ(b.reserved0 | b.reserved1, 0u) << "ray " << i;
    const bool hit = b.kind == LSNIF_QUERY_HIT_LSNIF;
    ASSERT_TRUE(b.reports_uv == 0u || b.reports_uv == 1u) << "ray " << i;
    if (!hit) {
      EXPECT_EQ(b.reports_uv, 0u) << "ray " << i << ": a miss reports no coordinate";
    }
    if (b.reports_uv == 0u) {
      EXPECT_TRUE(b.uv_u == 0.0f && b.uv_v == 0.0f) << "ray " << i;
    }
    hits += hit;
    reported += b.reports_uv;
    const glm::dvec2 uv(b.uv_u, b.uv_v);
    const bool same_t = std::fabs(double(b.t - cpu[i].t)) * double(glm::length(rays[i].direction)) <= 2e-4 * diag;
    if (hit && cpu[i].hit && same_t) {
      if ((b.reports_uv != 0u) != cpu[i].reports_uv) {
        ++cpu_one_side;
      } else if (cpu[i].reports_uv) {
        ++cpu_both;
        const double err = glm::length(uv - glm::dvec2(cpu[i].uv));
        cpu_max = std::max(cpu_max, err);
        cpu_apart += err > 1e-4;
      }
    }
    if (hit && shader[i].hit) {
      if ((b.reports_uv != 0u) != (shader[i].reports_uv != 0u)) {
        ++shader_one_side;
      } else if (b.reports_uv != 0u) {
        ++shader_both;
        const glm::dvec2 d = glm::abs(uv - glm::dvec2(shader[i].uv_u, shader[i].uv_v));
        shader_max = std::max(shader_max, std::max(d.x, d.y));
        shader_apart += std::max(d.x, d.y) > step;
      }
    }
  }
  std::printf("%zu rays, %zu hits, %zu report a coordinate; vs CPU: %zu both, %zu one side, %zu apart, max %.3g; "
              "vs the intersection shader: %zu both, %zu one side, %zu apart, max %.3g\n",
              rays.size(), hits, reported, cpu_both, cpu_one_side, cpu_apart, cpu_max, shader_both, shader_one_side,
              shader_apart, shader_max);
  EXPECT_GT(reported, hits / 2) << "not vacuous: most hits report a texture coordinate";
  EXPECT_GT(cpu_both, hits / 2);
  EXPECT_LE(double(cpu_one_side), 2e-3 * double(cpu_both));
  EXPECT_LE(double(cpu_apart), 5e-3 * double(cpu_both));
  EXPECT_GT(shader_both, hits / 2);
  EXPECT_LE(double(shader_one_side), 2e-3 * double(shader_both));
  EXPECT_LE(double(shader_apart), 5e-3 * double(shader_both));
  vk_.destroy_buffer(table_buf);
  lsnifDestroyQueryPipeline(plugin.context(), pipeline);
}

// The cooperative-matrix MLP kernel (LSNIF_QUERY_PIPELINE_CREATE_COOPERATIVE_MATRIX_MLP_BIT_NV,
// lsnif_mlp_coopmat.glsl) against the portable kernel on the same rays and model: the same walk,
// encoding, heads and acceptance, the network with fp16 activations instead of fp32, so hit/miss
// agrees but for rays whose occlusion is near the threshold, t to ~1e-3 of the diagonal and normals
// to a degree. A device without what the kernel needs must refuse the pipeline naming it; the
// comparison is then skipped naming it (lavapipe has no cooperative matrices, so until a GPU runs
// this test the kernel is unverified).
TEST_F(PluginApi, CooperativeMatrixMlpMatchesThePortableKernel) {
  TestPlugin plugin;
  ASSERT_TRUE(plugin.init(vk_));
  LsnifModel m = nullptr;
  ASSERT_TRUE(plugin.upload(model_, m));
  LsnifQueryPipelineFlagsCreateInfo chained{};
  chained.sType = LSNIF_STRUCTURE_TYPE_QUERY_PIPELINE_FLAGS_CREATE_INFO;
  chained.flags = LSNIF_QUERY_PIPELINE_CREATE_COOPERATIVE_MATRIX_MLP_BIT_NV;
  LsnifQueryPipelineCreateInfo pi{};
  pi.pNext = &chained;
  LsnifQueryPipeline coopmat = nullptr;
  const LsnifResult created = lsnifCreateQueryPipeline(plugin.context(), &pi, &coopmat);
  if (!vk_.coopmat_mlp()) {
    EXPECT_EQ(created, LSNIF_ERROR_DEVICE_UNSUPPORTED);
    EXPECT_NE(last_error().find("LSNIF_QUERY_PIPELINE_CREATE_COOPERATIVE_MATRIX_MLP_BIT_NV"), std::string::npos)
        << last_error();
    EXPECT_NE(last_error().find("VK_NV_cooperative_matrix"), std::string::npos) << last_error();
    EXPECT_EQ(coopmat, nullptr);
    GTEST_SKIP() << "device '" << vk_.device_name()
                 << "' lacks the cooperative-matrix MLP kernel's needs (extension VK_NV_cooperative_matrix, "
                    "a 16x8x16 fp16 x fp16 + fp32 shape, shaderFloat16): " << last_error();
  }
  ASSERT_EQ(created, LSNIF_SUCCESS) << last_error();
  LsnifQueryPipeline portable = nullptr;
  ASSERT_EQ(lsnifCreateQueryPipeline(plugin.context(), nullptr, &portable), LSNIF_SUCCESS) << last_error();
  const std::vector<Ray> rays = rays_at(Transform3x4(), kRays, 23);
  const std::vector<LsnifQueryHit> a = intersect_batched(plugin, portable, m, rays);
  const std::vector<LsnifQueryHit> b = intersect_batched(plugin, coopmat, m, rays);
  ASSERT_EQ(a.size(), rays.size());
  ASSERT_EQ(b.size(), rays.size());
  const double diag = double(model_.bounds().diagonal());
  size_t same = 0, both = 0;
  double max_dt = 0.0, max_angle = 0.0;
  for (size_t i = 0; i < rays.size(); ++i) {
    EXPECT_EQ(a[i].points, b[i].points) << "ray " << i;
    same += a[i].kind == b[i].kind;
    if (a[i].kind != LSNIF_QUERY_HIT_LSNIF || b[i].kind != LSNIF_QUERY_HIT_LSNIF) continue;
    ++both;
    max_dt = std::max(max_dt, std::fabs(double(a[i].t - b[i].t)) * double(glm::length(rays[i].direction)) / diag);
    const glm::vec3 na(a[i].normal_x, a[i].normal_y, a[i].normal_z), nb(b[i].normal_x, b[i].normal_y, b[i].normal_z);
    max_angle = std::max(max_angle, double(std::acos(std::clamp(glm::dot(na, nb), -1.0f, 1.0f))) * 180.0 / M_PI);
  }
  std::printf("[cooperative-matrix MLP] %zu rays, hit/miss agreement %.4f%%, %zu hits compared, max |dt| / diagonal "
              "%.2e, max normal angle %.3f deg\n", rays.size(), 100.0 * double(same) / double(rays.size()), both,
              max_dt, max_angle);
  EXPECT_GE(double(same), 0.995 * double(rays.size())) << "hit/miss vs the portable kernel";
  EXPECT_GT(both, rays.size() / 20) << "too few hits to tell anything";
  EXPECT_LE(max_dt, 2e-3) << "largest |t difference| / diagonal vs the portable kernel";
  EXPECT_LE(max_angle, 2.0) << "largest normal difference (degrees) vs the portable kernel";
  lsnifDestroyQueryPipeline(plugin.context(), portable);
  lsnifDestroyQueryPipeline(plugin.context(), coopmat);
}

// Rays that start on the LSNIF surface, spawned with the self-intersection rule (origin at the
// predicted hit point, back-face culling, tmin = leaving_tmin): the batched path answers them as
// the CPU reference does. Also an empty batch (records nothing), a batch in which no ray reaches
// the model (every field of every hit written: no network ran), and the argument errors.
TEST_F(PluginApi, BatchedQueriesFromTheSurfaceEmptyAndMissingBatchesAndErrors) {
  TestPlugin plugin;
  ASSERT_TRUE(plugin.init(vk_));
  LsnifModel m = nullptr;
  ASSERT_TRUE(plugin.upload(model_, m));
  LsnifQueryPipeline pipeline = nullptr;
  ASSERT_EQ(lsnifCreateQueryPipeline(plugin.context(), nullptr, &pipeline), LSNIF_SUCCESS) << last_error();
  const Transform3x4 xf;  // identity

  // Leaving rays: from the CPU's hits of primary rays, in random directions.
  const std::vector<Ray> primary = rays_at(xf, kRays, 23);
  std::vector<LsnifHit> first(primary.size());
  ASSERT_TRUE(intersect(model_, xf, primary.data(), primary.size(), first.data()));
  std::mt19937 rng(5);
  std::normal_distribution<float> g(0.0f, 1.0f);
  std::vector<Ray> leaving;
  for (size_t i = 0; i < primary.size(); ++i) {
    if (!first[i].hit) continue;
    Ray r;
    r.origin = primary[i].origin + first[i].t * primary[i].direction;
    r.direction = glm::normalize(glm::vec3(g(rng), g(rng), g(rng)));
    r.tmin = leaving_tmin(model_, xf, r.direction);
    leaving.push_back(r);
  }
  ASSERT_GT(leaving.size(), primary.size() / 20);
  const std::vector<uint32_t> cull(leaving.size(), LSNIF_RAY_FLAG_CULL_BACK_FACING);
  const std::vector<LsnifQueryHit> batched = intersect_batched(plugin, pipeline, m, leaving, cull);
  std::vector<LsnifHit> cpu(leaving.size());
  ASSERT_TRUE(intersect(model_, xf, leaving.data(), leaving.size(), cpu.data(), LSNIF_RAY_FLAG_CULL_BACK_FACING));
  ASSERT_EQ(batched.size(), leaving.size());
  size_t agree = 0;
  for (size_t i = 0; i < leaving.size(); ++i) {
    agree += agrees(batched[i].kind == LSNIF_QUERY_HIT_LSNIF, batched[i].t, cpu[i], leaving[i]);
  }
  EXPECT_GE(double(agree), 0.999 * double(leaving.size())) << "rays leaving the surface";

  // An empty batch records nothing and succeeds.
  EXPECT_TRUE(intersect_batched(plugin, pipeline, m, {}).empty());

  // Batches of 1, 2, 3, 63, 64, 65 and 129 rays that each reach the network: the MLP stage runs two
  // slots per invocation, so an odd count leaves one invocation a single slot. Each ray answers
  // bit for bit as it does in the batch of all of them (whose rays the CPU checks above and below),
  // whatever its partner, and as the CPU does.
  {
    std::vector<Ray> reaching;
    std::vector<LsnifHit> reaching_cpu;
    for (size_t i = 0; i < primary.size(); ++i)
      if (first[i].hit) {
        reaching.push_back(primary[i]);
        reaching_cpu.push_back(first[i]);
      }
    ASSERT_GE(reaching.size(), 129u);
    const std::vector<LsnifQueryHit> all = intersect_batched(plugin, pipeline, m, reaching);
    for (const size_t n : {size_t(1), size_t(2), size_t(3), size_t(63), size_t(64), size_t(65), size_t(129)}) {
      const std::vector<Ray> some(reaching.begin(), reaching.begin() + long(n));
      const std::vector<LsnifQueryHit> got = intersect_batched(plugin, pipeline, m, some);
      ASSERT_EQ(got.size(), n);
      size_t cpu_agree = 0;
      for (size_t i = 0; i < n; ++i) {
        EXPECT_GT(got[i].points, 0u) << n << " rays, ray " << i << ": it reaches the network";
        EXPECT_EQ(got[i].kind, all[i].kind) << n << " rays, ray " << i;
        EXPECT_EQ(got[i].t, all[i].t) << n << " rays, ray " << i;
        EXPECT_EQ(got[i].normal_x, all[i].normal_x) << n << " rays, ray " << i;
        EXPECT_EQ(got[i].occlusion_logit, all[i].occlusion_logit) << n << " rays, ray " << i;
        cpu_agree += agrees(got[i].kind == LSNIF_QUERY_HIT_LSNIF, got[i].t, reaching_cpu[i], some[i]);
      }
      EXPECT_GE(double(cpu_agree), 0.98 * double(n)) << n << " rays";
    }
  }

  // A batch of more than one chunk (LSNIF_BATCH_CHUNK_RAYS): the scratch is sized for one chunk
  // and reused; every ray of both chunks answers as the CPU does.
  {
    const size_t n = LSNIF_BATCH_CHUNK_RAYS + 3001;
    VkDeviceSize one_chunk = 0, big = 0;
    ASSERT_EQ(lsnifGetIntersectScratchSize(plugin.context(), m, LSNIF_BATCH_CHUNK_RAYS, &one_chunk), LSNIF_SUCCESS);
    ASSERT_EQ(lsnifGetIntersectScratchSize(plugin.context(), m, uint32_t(n), &big), LSNIF_SUCCESS);
    EXPECT_EQ(big, one_chunk);
    const std::vector<Ray> many = rays_at(xf, n, 29);
    const std::vector<LsnifQueryHit> got = intersect_batched(plugin, pipeline, m, many);
    std::vector<LsnifHit> want(n);
    ASSERT_TRUE(intersect(model_, xf, many.data(), n, want.data()));
    ASSERT_EQ(got.size(), n);
    size_t same = 0, second_chunk_hits = 0;
    for (size_t i = 0; i < n; ++i) {
      const bool hit = got[i].kind == LSNIF_QUERY_HIT_LSNIF;
      same += agrees(hit, got[i].t, want[i], many[i]);
      if (i >= LSNIF_BATCH_CHUNK_RAYS) second_chunk_hits += hit;
    }
    EXPECT_GE(double(same), 0.999 * double(n)) << "a batch of two chunks";
    EXPECT_GT(second_chunk_hits, 100u) << "the second chunk must hit too";
  }

  // No ray reaches the model: parallel to it, outside the box, pointing away.
  std::vector<Ray> away(300);
  const Aabb& b = model_.bounds();
  for (size_t i = 0; i < away.size(); ++i) {
    away[i].origin = b.hi + glm::vec3(0.1f + 0.01f * float(i));
    away[i].direction = glm::vec3(1.0f, 0.5f, 0.25f);
  }
  for (const LsnifQueryHit& h : intersect_batched(plugin, pipeline, m, away)) {
    EXPECT_EQ(h.kind, LSNIF_QUERY_HIT_NONE);
    EXPECT_EQ(h.points, 0u);
    EXPECT_EQ(h.t, 0.0f);
    EXPECT_EQ(h.material, 0u);
    EXPECT_EQ(h.occlusion_logit, 0.0f);
    EXPECT_EQ(h.reserved0 | h.reserved1, 0u);
    EXPECT_EQ(h.reports_uv, 0u);
  }

  // Argument errors: nothing recorded, a message naming the problem.
  VkDeviceSize need = 0;
  ASSERT_EQ(lsnifGetIntersectScratchSize(plugin.context(), m, 1000, &need), LSNIF_SUCCESS);
  LsnifIntersectModelRaysInfo info{};
  info.model = m;
  info.rayCount = 1000;
  info.rays = 0x10000;
  info.hits = 0x20000;
  info.scratch = 0x30000;
  info.scratchSize = need;
  auto refused = [&](LsnifQueryPipeline p, const LsnifIntersectModelRaysInfo& in, const char* words) {
    Status s = vk_.submit("refused", [&](VkCommandBuffer cmd) {
      EXPECT_EQ(lsnifCmdIntersectModelRays(plugin.context(), cmd, p, &in), LSNIF_ERROR_INVALID_ARGUMENT);
    });
    EXPECT_TRUE(s) << s.message();
    EXPECT_NE(last_error().find(words), std::string::npos) << last_error();
  };
  LsnifIntersectModelRaysInfo bad = info;
  bad.scratchSize = need - 4;
  refused(pipeline, bad, "scratchSize");
  bad = info;
  bad.rays = 0x10008;
  refused(pipeline, bad, "pInfo->rays is not 16-byte aligned");
  bad = info;
  bad.hits = 0;
  refused(pipeline, bad, "pInfo->hits is 0");
  bad = info;
  bad.model = reinterpret_cast<LsnifModel>(&bad);
  refused(pipeline, bad, "not a model of this context");
  refused(reinterpret_cast<LsnifQueryPipeline>(&bad), info, "not a query pipeline of this context");
  LsnifModel unbuilt = nullptr;
  ASSERT_EQ(lsnifCreateModelFromMemory(plugin.context(), bytes_.data(), bytes_.size(), &unbuilt), LSNIF_SUCCESS);
  bad = info;
  bad.model = unbuilt;
  refused(pipeline, bad, "has not been built");
  lsnifDestroyQueryPipeline(plugin.context(), pipeline);
}


// Allocation callbacks of the application see every allocation freed, and validation reports no
// leaked object at vkDestroyDevice (own device: the suite's must stay alive for the other tests).
TEST(PluginLeaks, AllocatorBalancedAndNothingLeaked) {
  vk::Context vk;
  Status s = vk.init(/*ray_tracing=*/true, test::test_validation(), test::test_device());
  ASSERT_TRUE(s) << s.message();
  struct Counts {
    std::atomic<int> live{0}, total{0};
  } counts;
  VkAllocationCallbacks cb{};
  cb.pUserData = &counts;
  cb.pfnAllocation = [](void* user, size_t size, size_t alignment, VkSystemAllocationScope) -> void* {
    void* p = std::aligned_alloc(alignment, (size + alignment - 1) / alignment * alignment);
    if (p) ++static_cast<Counts*>(user)->live, ++static_cast<Counts*>(user)->total;
    return p;
  };
  cb.pfnFree = [](void* user, void* p) {
    if (p) --static_cast<Counts*>(user)->live;
    std::free(p);
  };
  cb.pfnReallocation = [](void*, void*, size_t, size_t, VkSystemAllocationScope) -> void* {
    return nullptr;  // not used by the plugin's objects (a failure would show as an error)
  };
  Mesh mesh;
  ASSERT_TRUE(load_mesh(kElephant, mesh));
  Model model;
  TrainSettings settings = tiny_settings(HitParam::VoxelSegments);
  settings.steps = 20;
  ASSERT_TRUE(test::tiny_model("elephant.segments_20_steps", mesh, settings, model));
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(save_model_to_memory(model, bytes));
  {
    LsnifContextCreateInfo info = vk::plugin_create_info(vk);
    info.pAllocator = &cb;
    plugin::Context ctx;
    ASSERT_EQ(ctx.create(info), LSNIF_SUCCESS) << last_error();
    plugin::Model a, b;
    ASSERT_EQ(a.create_from_memory(ctx.get(), bytes.data(), bytes.size()), LSNIF_SUCCESS) << last_error();
    ASSERT_EQ(b.create_from_memory(ctx.get(), bytes.data(), bytes.size()), LSNIF_SUCCESS) << last_error();
    const LsnifModel handle = a.get();
    ASSERT_EQ(lsnifBuildModels(ctx.get(), 1, &handle), LSNIF_SUCCESS) << last_error();
    a.reset();
    // b stays alive: lsnifDestroyContext must release it (the wrapper gives it up first).
    (void)b.release();
    ctx.reset();
  }
  EXPECT_GT(counts.total.load(), 0) << "the plugin did not use the application's allocator";
  EXPECT_EQ(counts.live.load(), 0) << "allocations not freed through the application's allocator";
  vk.destroy_device();
  EXPECT_EQ(vk.validation_errors(), 0u) << vk.validation_log();
  EXPECT_EQ(vk.validation_warnings(), 0u) << vk.validation_log();
}

// Negative control for the leak check above: an object left alive is reported at vkDestroyDevice.
TEST(PluginLeaks, ValidationReportsALeakAtDeviceDestruction) {
  if (!test::test_validation()) GTEST_SKIP() << "needs the validation layer (LSNIF_TEST_VALIDATION=0)";
  vk::Context vk;
  Status s = vk.init(/*ray_tracing=*/true, test::test_validation(), test::test_device());
  ASSERT_TRUE(s) << s.message();
  VkBufferCreateInfo bci{};
  bci.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  bci.size = 64;
  bci.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  VkBuffer leaked = VK_NULL_HANDLE;
  ASSERT_EQ(vkCreateBuffer(vk.device(), &bci, nullptr, &leaked), VK_SUCCESS);
  std::printf("(one validation error about a leaked VkBuffer is expected next)\n");
  std::fflush(stdout);
  vk.destroy_device();
  EXPECT_GT(vk.validation_errors(), 0u);
}

}  // namespace
}  // namespace lsnif
