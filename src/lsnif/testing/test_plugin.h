// test_plugin.h -- the plugin's C API (src/lsnif/lsnif.h) on the Vulkan context's device, with the
// shape the GPU tests need: in-process models (trained in the test) uploaded through their .lsnif
// bytes and built at once, instance records from the CPU side's Transform3x4, errors as Status
// carrying the plugin's message. Header-only; include inside no namespace.
#pragma once
#include <cstddef>
#include <cstring>
#include <vector>

#include "lsnif/core/intersector.h"
#include "lsnif/core/model.h"
#include "lsnif/vulkan/plugin_device.h"  // volk before lsnif.h
#include "lsnif/vulkan/raytracing.h"

namespace lsnif::gputest {

// The push constant block of tests/gpu/rt_conformance_common.glsl (model table first: the binding
// convention of host_device.h).
struct RtConformancePush {
  uint64_t model_table = 0;
  uint32_t model_count = 0, reserved = 0;
  uint64_t rays = 0, hits = 0;
  uint32_t ray_count = 0, mode = 0, ray_flags = 0, pad = 0;
};
static_assert(sizeof(RtConformancePush) == 48, "push constant layout");
static_assert(offsetof(RtConformancePush, model_table) == LSNIF_RT_PUSH_MODEL_TABLE_OFFSET, "binding convention");
static_assert(offsetof(RtConformancePush, model_count) == LSNIF_RT_PUSH_MODEL_COUNT_OFFSET, "binding convention");
static_assert(offsetof(RtConformancePush, rays) == LSNIF_RT_PUSH_APP_OFFSET, "binding convention");

class TestPlugin {
 public:
  TestPlugin() = default;
  TestPlugin(const TestPlugin&) = delete;
  TestPlugin& operator=(const TestPlugin&) = delete;
  ~TestPlugin() { destroy(); }

  Status init(const vk::Context& vk, LsnifContextCreateFlags flags = 0) {
    destroy();
    LsnifContextCreateInfo info = vk::plugin_create_info(vk);
    info.flags = flags;
    return check(lsnifCreateContext(&info, &ctx_), "lsnifCreateContext");
  }
  // lsnifDestroyContext (every model with it).
  void destroy() {
    lsnifDestroyContext(ctx_);
    ctx_ = nullptr;
  }
  // `model` through its .lsnif bytes: created and built (blocking).
  Status upload(const Model& model, LsnifModel& out) {
    out = nullptr;
    std::vector<uint8_t> bytes;
    if (Status s = save_model_to_memory(model, bytes); !s) return s;
    if (Status s = check(lsnifCreateModelFromMemory(ctx_, bytes.data(), bytes.size(), &out), "create model"); !s)
      return s;
    return check(lsnifBuildModels(ctx_, 1, &out), "lsnifBuildModels");
  }
  void release(LsnifModel& model) {
    lsnifDestroyModel(ctx_, model);
    model = nullptr;
  }
  Status make_instance(LsnifModel model, const Transform3x4& xf, uint32_t custom_index, uint32_t mask,
                       uint32_t sbt_offset, VkAccelerationStructureInstanceKHR& out) const {
    LsnifInstanceInfo info{};
    info.model = model;
    std::memcpy(info.transform.matrix, xf.m, sizeof info.transform.matrix);
    info.instanceCustomIndex = custom_index;
    info.mask = mask;
    info.instanceShaderBindingTableRecordOffset = sbt_offset;
    return check(lsnifMakeInstance(ctx_, &info, &out), "lsnifMakeInstance");
  }
  Status model_table(const std::vector<LsnifModel>& models, std::vector<uint64_t>& table) const {
    table.assign(models.size(), 0);
    return check(lsnifWriteModelTable(ctx_, uint32_t(models.size()), models.data(), table.data()), "lsnifWriteModelTable");
  }
  LsnifModelProperties properties(LsnifModel model) const {
    LsnifModelProperties p{};
    lsnifGetModelProperties(ctx_, model, &p);
    return p;
  }
  LsnifContext context() const { return ctx_; }

  // The intersection shader of `lookup` (the plugin's embedded SPIR-V).
  static vk::Spirv intersection_shader(LsnifModelLookup lookup = LSNIF_MODEL_LOOKUP_INSTANCE_TABLE) {
    vk::Spirv s;
    lsnifGetIntersectionShaderSpirv(lookup, &s.code, &s.bytes);
    return s;
  }
  // Ok for LSNIF_SUCCESS, else an error with the plugin's last message.
  static Status check(LsnifResult r, const char* what) {
    if (r == LSNIF_SUCCESS) return Status::ok();
    return Status::error("%s: %s (%s)", what, lsnifGetLastErrorMessage(), lsnifResultString(r));
  }

 private:
  LsnifContext ctx_ = nullptr;
};

// `rays` (world space) through `pipeline`, a pipeline of the rt_conformance shaders, over `tlas`:
// one LsnifReferenceHit per ray in `out`. `push` holds the model table, mode and ray flags; the ray
// and hit buffers and the count are filled in here.
inline Status trace_reference(vk::Context& vk, vk::RayTracer& tracer, vk::RtPipeline& pipeline,
                              const vk::AccelerationStructure& tlas, RtConformancePush push,
                              const std::vector<Ray>& rays, std::vector<LsnifReferenceHit>& out) {
  out.clear();
  vk::Buffer ray_buf, hit_buf;
  Status s = vk.create_buffer(rays.size() * sizeof(LsnifReferenceRay), ray_buf);
  if (s) s = vk.create_buffer(rays.size() * sizeof(LsnifReferenceHit), hit_buf);
  if (s) {
    auto* r = static_cast<LsnifReferenceRay*>(ray_buf.mapped);
    for (size_t i = 0; i < rays.size(); ++i)
      r[i] = {rays[i].origin.x, rays[i].origin.y, rays[i].origin.z, rays[i].tmin,
              rays[i].direction.x, rays[i].direction.y, rays[i].direction.z, rays[i].tmax};
    push.rays = ray_buf.address;
    push.hits = hit_buf.address;
    push.ray_count = uint32_t(rays.size());
    s = tracer.trace(pipeline, tlas, &push, uint32_t(rays.size()));
  }
  if (s) {
    const auto* h = static_cast<const LsnifReferenceHit*>(hit_buf.mapped);
    out.assign(h, h + rays.size());
  }
  vk.destroy_buffer(ray_buf);
  vk.destroy_buffer(hit_buf);
  return s;
}

// SPIR-V words of a header generated by lsnif_spirv_header (cmake/LsnifShaders.cmake).
inline vk::Spirv spirv(const uint32_t* code, size_t bytes) {
  vk::Spirv s;
  s.code = code;
  s.bytes = bytes;
  return s;
}

}  // namespace lsnif::gputest
