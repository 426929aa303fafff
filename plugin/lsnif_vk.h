// lsnif_vk.h -- the LSNIF Vulkan plugin: puts LSNIF models on the APPLICATION's Vulkan device (it
// never creates an instance or device) as procedural AABB geometry for the application's
// ray-tracing pipeline, following the binding convention of shaders/host_device.h: per model a GPU
// block (plugin/gpu_model.h) and one AABB BLAS shared by all its instances; TLAS instance records;
// the uint64 model table indexed by the custom index; the compiled intersection shader.
// Device functions go through the plugin's own VolkDeviceTable. No exceptions; errors are Status.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <volk.h>

#include "device_support.h"
#include "intersector.h"
#include "model.h"
#include "status.h"

namespace lsnif::plugin {

// The application's handles. The device must have been created from `physical` with
// VK_KHR_acceleration_structure, VK_KHR_ray_tracing_pipeline, VK_KHR_deferred_host_operations and
// the features accelerationStructure, bufferDeviceAddress and shaderInt64 enabled (the plugin can
// only check that the physical device offers them). `queue` belongs to `queue_family`, which must
// support compute; the plugin submits to it only inside its own calls (the application must not
// use the queue concurrently with them). The instance functions must be loaded into volk.
struct DeviceHandles {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  uint32_t queue_family = 0;
  VkQueue queue = VK_NULL_HANDLE;
};

// A model on the device; 0 is "no model".
struct ModelHandle {
  uint32_t id = 0;
  explicit operator bool() const { return id != 0; }
};

// What one uploaded model occupies on the device (the BLAS build's input and scratch buffers are
// freed after the build and not counted).
struct ModelMemory {
  VkDeviceSize block_bytes = 0;      // the GPU model block: pack_gpu_model words x 4
  VkDeviceSize blas_bytes = 0;       // the AABB BLAS: the driver's accelerationStructureSize
  VkDeviceSize allocated_bytes = 0;  // device memory allocated for both (VkMemoryRequirements sizes)
  VkDeviceSize total() const { return block_bytes + blas_bytes; }
};

class Context {
 public:
  Context() = default;
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  // destroy().
  ~Context();

  // Releases every model and the plugin's command pool and fence; the application's device stays.
  // Call before the application destroys its device. Safe to call twice.
  void destroy();

  // Uploads `model`: its GPU block (pack_gpu_model) into a buffer with a device address, and one
  // BLAS with a single OPAQUE AABB geometry whose box is the model's padded AABB grown by 1e-4 of
  // its diagonal (so the driver's box test never culls a ray that the shader would hit on a face;
  // the intersection shader clips to the model's bounds), built on the device and waited for.
  // Fails, naming the problem, on an inconsistent or unquantized model or a Vulkan error (nothing
  // is left allocated then).
  Status upload_model(const Model& model, ModelHandle& out);
  // Frees the model's buffers and BLAS (waits for the queue to be idle first). The handle becomes
  // 0; releasing 0 or an unknown handle does nothing.
  void release_model(ModelHandle& handle);

  // Device addresses of a model's GPU block and BLAS; 0 for an unknown handle.
  VkDeviceAddress model_address(ModelHandle handle) const;
  VkDeviceAddress blas_address(ModelHandle handle) const;
  // Number of models currently uploaded.
  size_t model_count() const;
  // The device memory of model `handle` (ModelMemory). Fails on an unknown or 0 handle.
  Status model_memory(ModelHandle handle, ModelMemory& out) const;

  // A TLAS instance record of model `handle` with object-to-world `xf` (row-major 3x4),
  // instanceCustomIndex `custom_index` (the application's model-table index), `mask` and SBT
  // record offset `sbt_offset` (the hit group of lsnif.rint in the application's SBT). Fails on an
  // unknown handle, a non-finite or singular transform (|det| <= 1e-12 * product of row norms),
  // custom_index >= 2^24 or sbt_offset >= 2^24.
  Status make_instance(ModelHandle handle, const Transform3x4& xf, uint32_t custom_index, uint8_t mask,
                       uint32_t sbt_offset, VkAccelerationStructureInstanceKHR& out) const;

  // The instance model table of the binding convention: table[i] = model_address(models[i]), to be
  // written into a buffer whose device address the application pushes at
  // LSNIF_RT_PUSH_MODEL_TABLE_OFFSET. Fails naming the first unknown handle (a 0 handle is an
  // error too: the shader would read address 0).
  Status model_table(const std::vector<ModelHandle>& models, std::vector<uint64_t>& table) const;

  bool valid() const { return device_ != VK_NULL_HANDLE; }
  const VolkDeviceTable& table() const { return vk_; }

 private:
  friend Status create_context(const DeviceHandles& handles, Context& out);
  struct Allocation {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceAddress address = 0;
    VkDeviceSize bytes = 0, allocated = 0;  // requested size, VkMemoryRequirements::size
  };
  struct Slot {
    uint32_t id = 0;
    Allocation block, blas_storage;
    VkAccelerationStructureKHR blas = VK_NULL_HANDLE;
    VkDeviceAddress blas_address = 0;
  };
  Status allocate(VkDeviceSize bytes, VkBufferUsageFlags usage, bool host_visible, const void* data,
                  Allocation& out);
  void free(Allocation& a);
  Status build_blas(const Model& model, Slot& slot);
  Status submit_and_wait(VkCommandBuffer cmd);
  void release_slot(Slot& slot);
  const Slot* find(ModelHandle handle) const;

  DeviceHandles handles_;
  VkDevice device_ = VK_NULL_HANDLE;
  VolkDeviceTable vk_{};
  VkPhysicalDeviceMemoryProperties memory_{};
  VkDeviceSize scratch_alignment_ = 0;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  std::vector<Slot> slots_;
  uint32_t next_id_ = 1;
};

// Initializes `out` (destroying what it held) on the application's device: checks
// check_device_support(handles.physical), loads the device table (volkLoadDeviceTable), creates a
// command pool on handles.queue_family and a fence. Fails naming the missing pieces or the null
// handle.
Status create_context(const DeviceHandles& handles, Context& out);

// Checks a Transform3x4 as make_instance does (finite, non-singular); ok or an error naming the
// problem. No Vulkan.
Status check_instance_transform(const Transform3x4& xf);

// Absolute path of the SPIR-V of shaders/lsnif.rint compiled at build time (glslangValidator,
// --target-env vulkan1.2) into the build tree.
const char* intersection_shader_spirv_path();

}  // namespace lsnif::plugin
