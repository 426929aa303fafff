// context.h -- the objects behind the C API's handles (src/lsnif/lsnif.h): a context on the
// application's device and the models created in it (GPU block, AABB input, BLAS, build scratch).
// Every function returns an Outcome: a result code and, on failure, the message naming the
// problem; api.cpp turns it into the thread's last error and the error callback.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "lsnif/lsnif.h"
#include "lsnif/format/status.h"
#include "lsnif/plugin/vk_dispatch.h"

namespace lsnif::plugin {

struct Outcome {
  LsnifResult code = LSNIF_SUCCESS;
  std::string message;
  explicit operator bool() const { return code == LSNIF_SUCCESS; }
  static Outcome ok() { return Outcome(); }
  static Outcome fail(LsnifResult code, const char* fmt, ...) __attribute__((format(printf, 2, 3)));
  // A failed Status as an Outcome of `code` (ok stays ok).
  static Outcome from(const Status& status, LsnifResult code);
  Outcome& context(const std::string& prefix) {
    if (code != LSNIF_SUCCESS) message = prefix + ": " + message;
    return *this;
  }
};

// One device buffer with its own memory.
struct Allocation {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceAddress address = 0;
  VkDeviceSize bytes = 0, allocated = 0;  // requested size, VkMemoryRequirements::size
  bool host_visible = false;
};

// `value` rounded up to a multiple of `alignment` (0: unchanged).
inline VkDeviceSize align_up(VkDeviceSize value, VkDeviceSize alignment) {
  return alignment == 0 ? value : (value + alignment - 1) / alignment * alignment;
}

// Where a buffer's memory should live.
enum class Placement {
  HostWrite,       // host-visible coherent (staging, build input)
  DeviceDirect,    // device-local and host-visible coherent, written by the host; none: fails
  DeviceOnly,      // device-local, preferably not host-visible
};

}  // namespace lsnif::plugin

struct LsnifModel_T {
  lsnif::plugin::Allocation block;          // the GPU block (device address: the model's address)
  lsnif::plugin::Allocation staging;        // the block's words, when the block is not host-visible
  lsnif::plugin::Allocation aabb;           // the BLAS build input (one VkAabbPositionsKHR)
  lsnif::plugin::Allocation scratch;        // the BLAS build scratch
  lsnif::plugin::Allocation blas_storage;
  VkAccelerationStructureKHR blas = VK_NULL_HANDLE;
  VkDeviceAddress blas_address = 0;
  VkDeviceSize scratch_address = 0;         // aligned to minAccelerationStructureScratchOffsetAlignment
  float bounds_min[3] = {}, bounds_max[3] = {};
  uint32_t material_count = 0;
  uint32_t layout_version = 0;
  uint32_t max_points = 0;                  // H
  uint32_t input_dim = 0, output_dim = 0;   // of the network
  bool build_recorded = false;
};

// The compute pipelines of the batched path (src/lsnif/shaders/lsnif_batch.comp, one per stage) and, with
// LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT, of the TLAS query (src/lsnif/shaders/lsnif_query.comp).
struct LsnifQueryPipeline_T {
  // The ray-tracing broad phase (lsnif_query_broad.*): one launch per pipeline, each with the
  // shader binding table regions of its three groups (raygen, miss, hit; the hit region's stride is
  // 0, so every instance's SBT offset selects the one hit group).
  struct TraceRays {
    VkPipeline pipeline = VK_NULL_HANDLE;
    VkStridedDeviceAddressRegionKHR raygen{}, miss{}, hit{}, callable{};
  };
  VkPipelineLayout layout = VK_NULL_HANDLE;
  // `order` (the slots by walk length for the portable MLP kernel) stays null with the cooperative-matrix one.
  VkPipeline clear = VK_NULL_HANDLE, narrow = VK_NULL_HANDLE, order = VK_NULL_HANDLE, mlp = VK_NULL_HANDLE,
             decode = VK_NULL_HANDLE;
  struct Tlas {
    VkPipeline clear = VK_NULL_HANDLE, broad = VK_NULL_HANDLE, scan = VK_NULL_HANDLE, scatter = VK_NULL_HANDLE,
               run_args = VK_NULL_HANDLE, narrow = VK_NULL_HANDLE, batch_args = VK_NULL_HANDLE, order = VK_NULL_HANDLE,
               mlp = VK_NULL_HANDLE, decode = VK_NULL_HANDLE,
               tie = VK_NULL_HANDLE, resolve_hits = VK_NULL_HANDLE, resolve_rays = VK_NULL_HANDLE,
               status = VK_NULL_HANDLE;
  } tlas;
  // NONE unless created with LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT.
  LsnifQueryBroadPhase broad_phase = LSNIF_QUERY_BROAD_PHASE_NONE;
  // The MLP stages run lsnif_mlp_coopmat.glsl (LSNIF_QUERY_PIPELINE_CREATE_COOPERATIVE_MATRIX_MLP_BIT_NV).
  bool coopmat_mlp = false;
  // With LSNIF_QUERY_BROAD_PHASE_TRACE_RAYS (tlas.broad stays null): its layout (push constants for
  // the ray-tracing stages), the triangle launch (a pipeline skipping AABBs), the candidate launch
  // (skipping triangles) and the shader binding tables of both.
  VkPipelineLayout trace_layout = VK_NULL_HANDLE;
  TraceRays broad_triangles, broad_candidates;
  lsnif::plugin::Allocation sbt;
};

struct LsnifContext_T {
  LsnifContextCreateInfo info{};
  lsnif::plugin::InstanceDispatch vki;
  lsnif::plugin::DeviceDispatch vk;
  VkPhysicalDeviceMemoryProperties memory{};
  VkDeviceSize scratch_alignment = 0;
  // lsnifCmdQuery's broad phase: the physical device offers VK_KHR_ray_query and rayQuery; and,
  // when the create info had pEnabledFeatures, that chain enabled rayQuery.
  bool ray_query_offered = false;
  bool ray_query_not_enabled = false;
  // Its ray-tracing broad phase: the physical device offers rayTraversalPrimitiveCulling; and,
  // when the create info had pEnabledFeatures, that chain enabled it.
  bool primitive_culling_offered = false;
  bool primitive_culling_not_enabled = false;
  // What the cooperative-matrix MLP kernel lacks on this device (missing_for_coopmat_mlp, then the
  // features the create info's pEnabledFeatures chain did not enable); empty when it can run.
  std::vector<std::string> coopmat_mlp_missing;
  VkPhysicalDeviceRayTracingPipelinePropertiesKHR ray_tracing{};  // shader group handle sizes and alignments
  std::string device_name;
  bool staging_upload = false;  // blocks always go through a staging buffer (LSNIF_CONTEXT_CREATE_STAGING_UPLOAD_BIT)
  // VK_EXT_debug_utils' object naming, where the application enabled the extension on its instance
  // (null otherwise): every object the library creates gets a name starting with "lsnif".
  PFN_vkSetDebugUtilsObjectNameEXT set_object_name = nullptr;
  uint32_t models_created = 0;  // numbers the models in their debug names
  VkCommandPool pool = VK_NULL_HANDLE;  // for the blocking calls (created on first use)
  VkFence fence = VK_NULL_HANDLE;
  std::vector<std::unique_ptr<LsnifModel_T>> models;
  std::vector<std::unique_ptr<LsnifQueryPipeline_T>> query_pipelines;

  // The model or query pipeline behind `handle` if it belongs to this context, else null.
  LsnifModel_T* find(LsnifModel handle) const { return find_in(models, handle); }
  LsnifQueryPipeline_T* find(LsnifQueryPipeline handle) const { return find_in(query_pipelines, handle); }
  // Removes the object behind `handle` from its list and returns it (null when it is not there).
  template <class T>
  static std::unique_ptr<T> take(std::vector<std::unique_ptr<T>>& list, const T* handle) {
    for (auto it = list.begin(); it != list.end(); ++it) {
      if (it->get() != handle) continue;
      std::unique_ptr<T> out = std::move(*it);
      list.erase(it);
      return out;
    }
    return nullptr;
  }

 private:
  template <class T>
  static T* find_in(const std::vector<std::unique_ptr<T>>& list, const T* handle) {
    if (!handle) return nullptr;
    for (const auto& p : list)
      if (p.get() == handle) return p.get();
    return nullptr;
  }
};

namespace lsnif::plugin {

// lsnifCreateContext / lsnifDestroyContext.
Outcome create_context(const LsnifContextCreateInfo& info, std::unique_ptr<LsnifContext_T>& out);
void destroy_context(LsnifContext_T& ctx);

// lsnifCreateModelFromMemory: parse, pack, allocate, write the block and the AABB; no commands.
Outcome create_model(LsnifContext_T& ctx, const uint8_t* data, size_t size, LsnifModel& out);
void destroy_model(LsnifContext_T& ctx, LsnifModel_T& model);
// Records block uploads and BLAS builds of `models` (checked by the caller) and the barrier.
void record_builds(LsnifContext_T& ctx, VkCommandBuffer cmd, const std::vector<LsnifModel_T*>& models);
// Records into the context's own command buffer, submits, waits, frees the build resources.
Outcome build_and_wait(LsnifContext_T& ctx, const std::vector<LsnifModel_T*>& models);
void free_build_resources(LsnifContext_T& ctx, LsnifModel_T& model);

// A buffer of `bytes` with a device address and its own memory placed as `placement` asks,
// holding `data` (when not null; the memory must then be host-visible), both named `name` (the
// memory with " memory" appended; name_object); release frees it.
Outcome allocate(LsnifContext_T& ctx, VkDeviceSize bytes, VkBufferUsageFlags usage, Placement placement,
                 const void* data, const std::string& name, Allocation& out);

// Gives `handle` (of `type`) the debug name `name` through VK_EXT_debug_utils when the application
// enabled it (LsnifContext_T::set_object_name); nothing otherwise. Names are for tools only: a
// failure is ignored.
void name_object(const LsnifContext_T& ctx, VkObjectType type, uint64_t handle, const std::string& name);
template <class Handle>
void name_object(const LsnifContext_T& ctx, VkObjectType type, Handle handle, const std::string& name) {
  name_object(ctx, type, reinterpret_cast<uint64_t>(handle), name);
}
void release(LsnifContext_T& ctx, Allocation& a);

// lsnifCreateQueryPipeline / lsnifDestroyQueryPipeline (query_pipeline.cpp).
Outcome create_query_pipeline(LsnifContext_T& ctx, LsnifQueryPipelineCreateFlags flags, VkPipelineCache cache,
                              std::unique_ptr<LsnifQueryPipeline_T>& out);
void destroy_query_pipeline(LsnifContext_T& ctx, LsnifQueryPipeline_T& pipeline);
// Bytes of scratch lsnifCmdIntersectModelRays needs for `rays` rays of `model`.
VkDeviceSize intersect_scratch_bytes(const LsnifModel_T& model, uint32_t rays);
// Records the stages of lsnifCmdIntersectModelRays (arguments checked by the caller).
void record_intersect_model_rays(LsnifContext_T& ctx, const LsnifQueryPipeline_T& pipeline, VkCommandBuffer cmd,
                                 const LsnifModel_T& model, const LsnifIntersectModelRaysInfo& info);
// Bytes of scratch lsnifCmdQuery needs for `rays` rays, `per_ray` candidates per ray, `table_entries`
// model-table entries of which `models` (non-null) are the models.
VkDeviceSize query_scratch_bytes(const std::vector<const LsnifModel_T*>& models, uint32_t table_entries, uint32_t rays,
                                 uint32_t per_ray);
// Records the stages of lsnifCmdQuery (arguments checked by the caller); models[i] is the model of
// table entry i or null; `timestamps` (may be null): where the stage timestamps go.
void record_query(LsnifContext_T& ctx, const LsnifQueryPipeline_T& pipeline, VkCommandBuffer cmd,
                  const std::vector<const LsnifModel_T*>& models, const LsnifQueryInfo& info,
                  const LsnifQueryTimestampsInfo* timestamps,
                  const LsnifQueryModelIndexInfo* model_index);
// Records the LSNIF_QUERY_TIMESTAMP_COUNT timestamps of an lsnifCmdQuery that has no rays.
void record_query_timestamps(LsnifContext_T& ctx, VkCommandBuffer cmd, const LsnifQueryTimestampsInfo& timestamps);

}  // namespace lsnif::plugin
