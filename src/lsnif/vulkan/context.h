// context.h -- the Vulkan context of the renderer, the viewer, the tools, the benchmarks and the
// GPU tests (volk; applications of the SDK bring their own): an instance, with the Khronos
// validation layer and a debug-utils messenger that counts and keeps every warning and error (the
// caller decides whether to print them: ContextOptions::on_validation_message)
// unless validation is turned off, a device with bufferDeviceAddress, shaderInt64 (and
// scalarBlockLayout where offered), host-visible buffers addressed by device address, compute
// pipelines from SPIR-V in memory with a push-constant range, one-time submissions and waits,
// timestamps. Optionally (init(true)) the device also has the ray-tracing extensions and
// features that LSNIF needs (the plugin says which device has them: lsnifQueryDeviceSupport) and
// src/lsnif/vulkan/raytracing.h uses.
// The device: ContextOptions::device selects one (an index in `lsnif devices` order or a part of
// its name; the GPU tests name lavapipe, "llvmpipe", their reference platform); left empty, the
// first discrete GPU that offers what is needed, else an integrated, virtual GPU, else a CPU device
// (device_choice.h). A device lacking something needed is skipped by the automatic choice and is
// an error when selected.
#pragma once
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <volk.h>

#include "lsnif/vulkan/device_choice.h"
#include "lsnif/format/status.h"

// In a function returning Status: returns an error naming the call and its VkResult unless it
// returned VK_SUCCESS.
#define LSNIF_VK_CHECK(call)                                                          \
  do {                                                                                \
    const VkResult result_ = (call);                                                  \
    if (result_ != VK_SUCCESS) return Status::error("%s failed (VkResult %d)", #call, \
                                                    static_cast<int>(result_));      \
  } while (0)

struct LsnifDeviceSupport;  // lsnif/lsnif.h

namespace lsnif::vk {

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  void* mapped = nullptr;         // persistently mapped, host-coherent
  VkDeviceSize size = 0;
  VkDeviceAddress address = 0;    // vkGetBufferDeviceAddress
};

// SPIR-V words in memory (a shader embedded at build time, or lsnifGetIntersectionShaderSpirv).
struct Spirv {
  const uint32_t* code = nullptr;
  size_t bytes = 0;
};

// Reads a SPIR-V file (a positive multiple of 4 bytes, at most 256 MiB) into `code` (replaced on
// success) with read_file (lsnif/format/file_io.h); errors name the file.
Status read_spirv_file(const std::string& path, std::vector<uint32_t>& code);

struct Pipeline {
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  uint32_t push_size = 0;
  // Set 0 of storage buffers at bindings 0 .. storage_buffers - 1 (shaders without buffer device
  // addresses, e.g. HLSL compiled by glslang); none when 0.
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  uint32_t storage_buffers = 0;
  double create_seconds = 0;      // vkCreateComputePipelines wall time (lavapipe compiles here)
};

// What Context::init creates besides compute.
struct ContextOptions {
  bool ray_tracing = false;  // the ray-tracing extensions and features (raytracing.h)
  bool validation = true;    // the Khronos validation layer and a counting messenger
  // Instance extensions to enable (e.g. what glfwGetRequiredInstanceExtensions names for a window
  // surface); an error names one the loader lacks.
  std::vector<std::string> instance_extensions;
  bool swapchain = false;    // VK_KHR_swapchain on the device (presenting to a window)
  // VK_KHR_ray_query with its feature rayQuery required (with ray_tracing; the ray-query broad phase
  // of the plugin's lsnifCmdQuery): an error names the chosen device when it lacks them. Ray-tracing
  // devices get them anyway where offered, and rayTraversalPrimitiveCulling (the ray-tracing broad
  // phase) where offered.
  bool ray_query = false;
  // Which device: "" chooses automatically (a discrete GPU first, then integrated, virtual, CPU);
  // else an index in vkEnumeratePhysicalDevices order or a case-insensitive part of the name
  // (device_choice.h).
  std::string device;
  // Called with each message of the validation layer (`error`: severity error, else a warning) as
  // it arrives, after it is counted and kept; empty: counted and kept only (validation_log()).
  std::function<void(bool error, const char* message)> on_validation_message;
};

// What `physical` of `instance` offers, for choose_device (device_choice.h): what LSNIF needs as
// the plugin answers it (lsnifQueryDeviceSupport, its full answer also into *support when given),
// and the context's own (queues, scalarBlockLayout, VK_KHR_swapchain, VK_KHR_spirv_1_4). The
// instance-level functions of `instance` must be loaded into volk (volkLoadInstance or
// volkLoadInstanceOnly), and the instance must be created for Vulkan 1.2 or later (the 1.2 features
// are queried on 1.2+ devices). Fails only when the plugin's query does (lsnifGetLastErrorMessage).
Status query_device_info(VkInstance instance, VkPhysicalDevice physical, DeviceInfo& out,
                         LsnifDeviceSupport* support = nullptr);


// The device's limits on one buffer of Context::create_buffer (0: not known).
struct BufferLimits {
  uint64_t max_allocation = 0;     // VkPhysicalDeviceMaintenance3Properties::maxMemoryAllocationSize
  uint64_t max_storage_range = 0;  // VkPhysicalDeviceLimits::maxStorageBufferRange (a buffer bound to a descriptor)
  uint64_t heap = 0;               // the largest heap with host-visible coherent memory
};

// Whether the process can map `bytes` more of address space now: a reservation that takes no
// memory, released at once. Host-visible buffers stay mapped, and a driver whose mapping fails
// under an address-space limit (RLIMIT_AS) may hand back an unusable pointer instead of an error,
// so create_buffer checks the room first (twice the size: a driver on the CPU maps memory twice).
bool address_space_for(uint64_t bytes);

// A pool of timestamp queries on a Context's queue (create_timestamps).
struct Timestamps {
  VkQueryPool pool = VK_NULL_HANDLE;
  uint32_t count = 0;
  double ns_per_tick = 0;  // VkPhysicalDeviceLimits::timestampPeriod
  uint64_t valid_mask = 0; // the queue family's timestampValidBits as a mask
};

class Context {
 public:
  Context() = default;
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  ~Context();

  // Creates instance (validation layer required with `validation`: an error when it is missing),
  // messenger and the device `device` selects (ContextOptions::device; "" chooses automatically).
  // Errors name the missing piece (no Vulkan loader, no device, no qualifying device with what each
  // lacks, a selector naming no device or several, a selected device that lacks something).
  // With `ray_tracing`, the device must offer what LSNIF needs (the plugin's lsnifQueryDeviceSupport
  // says), and the extensions of lsnifGetRequiredDeviceExtensions (with VK_KHR_spirv_1_4 where
  // offered) are enabled with the features accelerationStructure and rayTracingPipeline.
  // With `validation` false (benchmarks, samples), no layer and no messenger are used and the
  // validation counts stay 0.
  Status init(bool ray_tracing = false, bool validation = true, const std::string& device = "");
  // init with more options (window-system extensions for a viewer).
  Status init(const ContextOptions& options);
  // A host-visible storage buffer of `bytes` with a device address (contents zeroed), with the
  // usage bits `extra_usage` added (e.g. acceleration-structure storage, shader binding table).
  // A size past the device's limits (check_buffer_size), memory the device or the host cannot give
  // (vkAllocateMemory failing, a mapping the process's address space cannot take) is an error
  // naming the bytes, the limit or the VkResult, never a crash; `out` is then left empty.
  Status create_buffer(size_t bytes, Buffer& out, VkBufferUsageFlags extra_usage = 0);
  BufferLimits buffer_limits() const;
  // An error unless a buffer of `bytes` fits the device's maxMemoryAllocationSize and its
  // host-visible heap (and maxStorageBufferRange, with `descriptor`: a buffer bound to a descriptor
  // of a pipeline's descriptor, as the GPU tests' dispatch binds them, src/lsnif/testing/vk_dispatch.h): "the WHAT buffer needs N bytes, more than the device's
  // LIMIT (M bytes)". Callers that know what sets the size check first, naming it in `what`
  // ("ray buffer (--rays 16777216)").
  Status check_buffer_size(const std::string& what, uint64_t bytes, bool descriptor = false) const;
  void destroy_buffer(Buffer& buffer);
  // A shader module of `code` on this context's device (caller destroys it).
  Status create_shader_module(const Spirv& code, VkShaderModule& out);
  // A compute pipeline (entry "main") from SPIR-V in memory (a shader embedded at build time), with
  // a push-constant range of `push_size` bytes and `storage_buffers` storage-buffer bindings in set
  // 0 (Pipeline::storage_buffers; the GPU tests' dispatch binds them, src/lsnif/testing/vk_dispatch.h).
  Status create_pipeline(const Spirv& code, uint32_t push_size, Pipeline& out, uint32_t storage_buffers = 0);
  void destroy_pipeline(Pipeline& pipeline);
  // Records `record` into a one-time command buffer, submits it and waits for it (`what` names the
  // work in an error message).
  Status submit(const char* what, const std::function<void(VkCommandBuffer)>& record);

  // Makes compute-shader writes recorded before visible to the host after the submit.
  static void barrier_compute_to_host(VkCommandBuffer cmd);

  // A pool of `count` timestamp queries; fails when the queue family has no timestamps
  // (timestampValidBits 0). Record vkCmdResetQueryPool before writing them.
  Status create_timestamps(uint32_t count, Timestamps& out);
  void destroy_timestamps(Timestamps& timestamps);
  // Queries [first, first + count), read after the submission that wrote them finished, in
  // milliseconds after query `first` (the differences wrapped to the valid bits). Fails naming the
  // first query that was not written (no wait: a query never written would block forever).
  Status read_timestamps_ms(const Timestamps& timestamps, uint32_t first, uint32_t count, std::vector<double>& ms);

  const std::string& device_name() const { return device_name_; }
  // Validation messages of severity warning / error seen so far.
  uint32_t validation_warnings() const { return warnings_; }
  uint32_t validation_errors() const { return errors_; }
  void reset_validation_counts() {
    warnings_ = errors_ = 0;
    messages_.clear();
  }
  // The messages seen so far, one a line ("[error] ...", "[warning] ..."; the first
  // kMaxKeptValidationMessages, then how many more), or "no validation messages".
  std::string validation_log() const;
  static constexpr size_t kMaxKeptValidationMessages = 64;
  VkDevice device() const { return device_; }
  VkInstance instance() const { return instance_; }
  VkQueue queue() const { return queue_; }
  uint32_t queue_family() const { return queue_family_; }
  // Destroys the device (after waiting for it), keeping the instance and the messenger, so that
  // what validation reports at vkDestroyDevice (leaked objects) is counted. init() is not
  // possible afterwards; everything created on the device must be released before.
  void destroy_device();
  // Points volk's process-wide Vulkan functions at this context's instance and device. The tools
  // hold one context; a process holding several (the Python module's devices) calls it before using
  // one, one context at a time.
  void make_current() const;
  VkPhysicalDevice physical_device() const { return physical_; }
  // Whether the device was created with the scalarBlockLayout feature (enabled when offered).
  bool scalar_block_layout() const { return scalar_block_layout_; }
  // The device was created with what the cooperative-matrix MLP kernel needs (DeviceInfo::coopmat_mlp).
  bool coopmat_mlp() const { return coopmat_mlp_; }

 private:
  static VKAPI_ATTR VkBool32 VKAPI_CALL on_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                    VkDebugUtilsMessageTypeFlagsEXT types,
                                                    const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                    void* user);
  VkInstance instance_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  uint32_t queue_family_ = 0;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  std::string device_name_;
  uint32_t warnings_ = 0, errors_ = 0;
  std::vector<std::string> messages_;  // the first kMaxKeptValidationMessages
  std::function<void(bool, const char*)> on_validation_message_;
  bool scalar_block_layout_ = false;
  bool coopmat_mlp_ = false;
};

}  // namespace lsnif::vk
