// The plugin API (plugin/lsnif_vk.h, plugin/device_support.h) on the harness's device (lavapipe):
// the missing-piece message from fake device-support structs, the support check of the real
// device, upload / release of models with no leak reported by validation at vkDestroyDevice (and a
// negative control showing that a leak would be reported), instance records with their fields,
// and the errors: inconsistent or unquantized model, NaN / singular transforms, custom index 2^24,
// unknown handles, null device handles.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "lsnif_vk.h"
#include "network.h"
#include "plugin_device.h"
#include "test_support.h"
#include "vk_compute.h"

namespace lsnif {
namespace {

using plugin::DeviceSupport;

DeviceSupport full_support() {
  DeviceSupport s;
  s.name = "fake";
  s.api_version = VK_MAKE_API_VERSION(0, 1, 3, 0);
  s.ext_acceleration_structure = s.ext_ray_tracing_pipeline = s.ext_deferred_host_operations = true;
  s.acceleration_structure = s.ray_tracing_pipeline = s.buffer_device_address = s.shader_int64 = true;
  return s;
}

TEST(PluginDeviceSupport, MessageListsExactlyTheMissingPieces) {
  EXPECT_TRUE(plugin::describe_device_support(full_support()));

  DeviceSupport s = full_support();
  s.shader_int64 = false;
  Status st = plugin::describe_device_support(s);
  ASSERT_FALSE(st);
  EXPECT_NE(st.message().find("device 'fake' (Vulkan 1.3.0)"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("missing: feature shaderInt64"), std::string::npos) << st.message();
  EXPECT_EQ(st.message().find("rayTracingPipeline"), std::string::npos) << st.message();

  s = full_support();
  s.ext_ray_tracing_pipeline = false;
  s.ray_tracing_pipeline = false;
  s.ext_deferred_host_operations = false;
  EXPECT_EQ(plugin::missing_for_ray_tracing(s),
            (std::vector<std::string>{"extension VK_KHR_ray_tracing_pipeline",
                                      "extension VK_KHR_deferred_host_operations", "feature rayTracingPipeline"}));

  DeviceSupport none;
  none.name = "old";
  none.api_version = VK_MAKE_API_VERSION(0, 1, 1, 0);
  const std::vector<std::string> all = plugin::missing_for_ray_tracing(none);
  EXPECT_EQ(all, (std::vector<std::string>{"Vulkan 1.2", "extension VK_KHR_acceleration_structure",
                                           "extension VK_KHR_ray_tracing_pipeline",
                                           "extension VK_KHR_deferred_host_operations",
                                           "feature accelerationStructure", "feature rayTracingPipeline",
                                           "feature bufferDeviceAddress", "feature shaderInt64"}));
  st = plugin::describe_device_support(none);
  ASSERT_FALSE(st);
  EXPECT_NE(st.message().find("missing: Vulkan 1.2, extension VK_KHR_acceleration_structure, "),
            std::string::npos)
      << st.message();
}

// A small consistent model with random fp16 parameters (V = 4, one level, W = 6).
Model random_model() {
  Model m;
  Config& c = m.config;
  c.voxel_resolution = 4;
  c.max_points = 3;
  c.grid_levels = 1;
  c.grid_resolution[0] = 8;
  c.grid_resolution[1] = 0;
  c.log2_table_size = 4;
  c.features = 2;
  c.hidden_width = 6;
  c.hidden_layers = 1;
  c.material_count = 1;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  m.voxels.resolution = c.voxel_resolution;
  m.voxels.bounds.lo = glm::vec3(-1.0f, 0.0f, 2.0f);
  m.voxels.bounds.hi = glm::vec3(1.0f, 3.0f, 4.0f);
  m.voxels.bits.assign(size_t((c.voxel_count() + 31) / 32), 0u);
  m.voxels.set(1, 2, 3);
  m.materials.resize(c.material_count);
  m.grid.resize(size_t(c.grid_parameter_count()));
  for (float& v : m.grid) v = u(rng);
  m.mlp.resize(size_t(c.mlp_parameter_count()));
  mlp_init_kaiming(c, 3, m.mlp.data());
  m.quantize();
  return m;
}

class Plugin : public ::testing::Test {
 protected:
  void SetUp() override {
    const Status s = vk_.init(/*ray_tracing=*/true, /*validation=*/true, test::kReferenceDevice);
    ASSERT_TRUE(s) << "no usable Vulkan ray-tracing device: " << s.message();
    handles_ = vk::plugin_handles(vk_);
  }
  vk::ComputeContext vk_;
  plugin::DeviceHandles handles_;
};

TEST_F(Plugin, RealDeviceIsSupported) {
  const Status s = plugin::check_device_support(vk_.physical_device());
  EXPECT_TRUE(s) << s.message();
  EXPECT_FALSE(plugin::check_device_support(VK_NULL_HANDLE));
  const std::string spv = plugin::intersection_shader_spirv_path();
  FILE* f = std::fopen(spv.c_str(), "rb");
  ASSERT_NE(f, nullptr) << spv;
  uint32_t magic = 0;
  EXPECT_EQ(std::fread(&magic, 4, 1, f), 1u);
  std::fclose(f);
  EXPECT_EQ(magic, 0x07230203u) << "SPIR-V magic of " << spv;
}

TEST_F(Plugin, CreateContextRejectsNullHandles) {
  plugin::Context ctx;
  plugin::DeviceHandles h = handles_;
  h.device = VK_NULL_HANDLE;
  const Status s = plugin::create_context(h, ctx);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("null handle"), std::string::npos) << s.message();
  EXPECT_FALSE(ctx.valid());
}

TEST_F(Plugin, UploadInstancesReleaseWithoutLeaks) {
  {
    plugin::Context ctx;
    ASSERT_TRUE(plugin::create_context(handles_, ctx));
    const Model model = random_model();
    plugin::ModelHandle a, b;
    ASSERT_TRUE(ctx.upload_model(model, a));
    ASSERT_TRUE(ctx.upload_model(model, b));
    EXPECT_EQ(ctx.model_count(), 2u);
    EXPECT_NE(a.id, b.id);
    EXPECT_NE(ctx.model_address(a), 0u);
    EXPECT_NE(ctx.blas_address(a), 0u);
    EXPECT_NE(ctx.model_address(a), ctx.model_address(b));
    EXPECT_EQ(ctx.model_address(plugin::ModelHandle{999}), 0u);

    std::vector<uint64_t> table;
    ASSERT_TRUE(ctx.model_table({b, a, b}, table));
    EXPECT_EQ(table, (std::vector<uint64_t>{ctx.model_address(b), ctx.model_address(a), ctx.model_address(b)}));
    Status s = ctx.model_table({a, plugin::ModelHandle()}, table);
    EXPECT_FALSE(s);
    EXPECT_NE(s.message().find("entry 1"), std::string::npos) << s.message();

    Transform3x4 xf;
    xf.m[0][3] = 5.0f;
    xf.m[1][0] = 0.5f;
    VkAccelerationStructureInstanceKHR rec;
    ASSERT_TRUE(ctx.make_instance(a, xf, (1u << 24) - 1, 0x0F, 3, rec));
    EXPECT_EQ(rec.instanceCustomIndex, (1u << 24) - 1);
    EXPECT_EQ(rec.mask, 0x0Fu);
    EXPECT_EQ(rec.instanceShaderBindingTableRecordOffset, 3u);
    EXPECT_EQ(rec.accelerationStructureReference, ctx.blas_address(a));
    EXPECT_EQ(rec.transform.matrix[0][3], 5.0f);
    EXPECT_EQ(rec.transform.matrix[1][0], 0.5f);
    EXPECT_EQ(rec.transform.matrix[2][2], 1.0f);

    s = ctx.make_instance(a, xf, 1u << 24, 0xFF, 0, rec);
    ASSERT_FALSE(s);
    EXPECT_NE(s.message().find("custom index 16777216"), std::string::npos) << s.message();
    xf.m[2][1] = std::numeric_limits<float>::quiet_NaN();
    s = ctx.make_instance(a, xf, 0, 0xFF, 0, rec);
    ASSERT_FALSE(s);
    EXPECT_NE(s.message().find("[2][1]"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("not finite"), std::string::npos) << s.message();
    Transform3x4 flat;  // rank 2: the third row repeats the first
    for (int c = 0; c < 4; ++c) flat.m[2][c] = flat.m[0][c];
    s = ctx.make_instance(a, flat, 0, 0xFF, 0, rec);
    ASSERT_FALSE(s);
    EXPECT_NE(s.message().find("singular"), std::string::npos) << s.message();
    Transform3x4 tiny;  // uniform scale 1e-5: tiny but not singular
    for (int r = 0; r < 3; ++r) tiny.m[r][r] = 1e-5f;
    EXPECT_TRUE(ctx.make_instance(a, tiny, 0, 0xFF, 0, rec));

    ctx.release_model(a);
    EXPECT_EQ(a.id, 0u);
    EXPECT_EQ(ctx.model_count(), 1u);
    s = ctx.make_instance(a, Transform3x4(), 0, 0xFF, 0, rec);
    EXPECT_FALSE(s);
    EXPECT_NE(s.message().find("unknown model handle"), std::string::npos) << s.message();
    // b stays: Context::destroy (here via the destructor) must release it.
  }
  vk_.destroy_device();
  EXPECT_EQ(vk_.validation_errors(), 0u) << "Vulkan validation errors (printed above): a leak or misuse";
  EXPECT_EQ(vk_.validation_warnings(), 0u) << "Vulkan validation warnings (printed above)";
}

// Negative control for the leak check above: an object left alive is reported at vkDestroyDevice.
TEST_F(Plugin, ValidationReportsALeakAtDeviceDestruction) {
  VkBufferCreateInfo bci{};
  bci.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  bci.size = 64;
  bci.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  VkBuffer leaked = VK_NULL_HANDLE;
  ASSERT_EQ(vkCreateBuffer(vk_.device(), &bci, nullptr, &leaked), VK_SUCCESS);
  std::printf("(one validation error about a leaked VkBuffer is expected next)\n");
  std::fflush(stdout);
  vk_.destroy_device();
  EXPECT_GT(vk_.validation_errors(), 0u);
}

TEST_F(Plugin, UploadRejectsInconsistentAndUnquantizedModels) {
  plugin::Context ctx;
  ASSERT_TRUE(plugin::create_context(handles_, ctx));
  Model model = random_model();
  model.grid.pop_back();
  plugin::ModelHandle h{77};
  Status s = ctx.upload_model(model, h);
  ASSERT_FALSE(s);
  EXPECT_EQ(h.id, 0u);
  EXPECT_NE(s.message().find("upload_model"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("hash grid"), std::string::npos) << s.message();
  model = random_model();
  model.mlp[2] = 0.1f;  // not an fp16 value
  s = ctx.upload_model(model, h);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("not an fp16 value"), std::string::npos) << s.message();
  EXPECT_EQ(ctx.model_count(), 0u);
  ctx.destroy();
  vk_.destroy_device();
  EXPECT_EQ(vk_.validation_errors(), 0u);
}

}  // namespace
}  // namespace lsnif
