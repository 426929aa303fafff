// context.cpp -- the Vulkan context of context.h.
#include "lsnif/vulkan/context.h"  // volk first: lsnif.h then uses its Vulkan declarations

#include <sys/mman.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <utility>
#include <vector>

#include "lsnif/format/file_io.h"
#include "lsnif/lsnif.h"

namespace lsnif::vk {

namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";
// The largest SPIR-V file read_spirv_file reads (the program's own shaders are under 100 KiB).
constexpr uint64_t kMaxSpirvFileBytes = uint64_t(1) << 28;

DeviceType device_type(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return DeviceType::integrated_gpu;
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return DeviceType::discrete_gpu;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return DeviceType::virtual_gpu;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return DeviceType::cpu;
    default: return DeviceType::other;
  }
}

}  // namespace

Status query_device_info(VkInstance instance, VkPhysicalDevice physical, DeviceInfo& out,
                         LsnifDeviceSupport* support) {
  DeviceInfo info;
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(physical, &props);
  info.name = props.deviceName;
  info.type = device_type(props.deviceType);

  // What LSNIF needs: the plugin's own answer, not a second probe of its extensions and features.
  LsnifDeviceSupport lsnif{};
  if (lsnifQueryDeviceSupport(instance, physical, vkGetInstanceProcAddr, &lsnif) != LSNIF_SUCCESS)
    return Status::error("%s", lsnifGetLastErrorMessage());
  info.lsnif_missing = missing_items(lsnif.missing);
  if (!lsnif.supported && info.lsnif_missing.empty()) info.lsnif_missing.emplace_back("LSNIF support");
  info.ray_query = lsnif.rayQuery == VK_TRUE;
  info.primitive_culling = lsnif.rayTraversalPrimitiveCulling == VK_TRUE;
  info.coopmat_mlp = lsnif.cooperativeMatrixMlpNV == VK_TRUE;

  // The context's own: VK_KHR_swapchain (a viewer's window), VK_KHR_spirv_1_4 and scalarBlockLayout
  // (enabled when offered) and a compute queue.
  uint32_t count = 0;
  vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, nullptr);
  std::vector<VkExtensionProperties> extensions(count);
  vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, extensions.data());
  extensions.resize(count);
  for (const VkExtensionProperties& e : extensions) {
    info.ext_swapchain |= std::strcmp(e.extensionName, VK_KHR_SWAPCHAIN_EXTENSION_NAME) == 0;
    info.ext_spirv_1_4 |= std::strcmp(e.extensionName, VK_KHR_SPIRV_1_4_EXTENSION_NAME) == 0;
  }
  // The 1.2 feature struct only on a 1.2+ device (an unknown struct in pNext is invalid usage).
  if (VK_API_VERSION_MAJOR(props.apiVersion) > 1 || VK_API_VERSION_MINOR(props.apiVersion) >= 2) {
    VkPhysicalDeviceVulkan12Features f12{};
    f12.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES;
    VkPhysicalDeviceFeatures2 f2{};
    f2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
    f2.pNext = &f12;
    vkGetPhysicalDeviceFeatures2(physical, &f2);
    info.scalar_block_layout = f12.scalarBlockLayout == VK_TRUE;
  }

  uint32_t family_count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(physical, &family_count, nullptr);
  std::vector<VkQueueFamilyProperties> families(family_count);
  vkGetPhysicalDeviceQueueFamilyProperties(physical, &family_count, families.data());
  for (uint32_t q = 0; q < family_count && !info.compute_queue; ++q)
    if (families[q].queueFlags & VK_QUEUE_COMPUTE_BIT) {
      info.compute_queue = true;
      info.compute_queue_family = q;
    }
  out = std::move(info);
  if (support) *support = lsnif;
  return Status::ok();
}

VKAPI_ATTR VkBool32 VKAPI_CALL Context::on_message(
    VkDebugUtilsMessageSeverityFlagBitsEXT severity, VkDebugUtilsMessageTypeFlagsEXT,
    const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  auto* self = static_cast<Context*>(user);
  const bool error = severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  if (error) ++self->errors_;
  else ++self->warnings_;
  const char* text = data && data->pMessage ? data->pMessage : "(no message)";
  if (self->messages_.size() < kMaxKeptValidationMessages)
    self->messages_.push_back(std::string(error ? "[error] " : "[warning] ") + text);
  if (self->on_validation_message_) self->on_validation_message_(error, text);
  return VK_FALSE;
}

std::string Context::validation_log() const {
  if (messages_.empty()) return "no validation messages";
  std::string log;
  for (const std::string& m : messages_) log += m + "\n";
  const size_t total = size_t(warnings_) + errors_;
  if (total > messages_.size()) log += format("(and %zu more)\n", total - messages_.size());
  return log;
}

void Context::destroy_device() {
  if (device_) {
    vkDeviceWaitIdle(device_);
    if (fence_) vkDestroyFence(device_, fence_, nullptr);
    if (pool_) vkDestroyCommandPool(device_, pool_, nullptr);
    vkDestroyDevice(device_, nullptr);
  }
  fence_ = VK_NULL_HANDLE;
  pool_ = VK_NULL_HANDLE;
  queue_ = VK_NULL_HANDLE;
  device_ = VK_NULL_HANDLE;
}

void Context::make_current() const {
  if (instance_) volkLoadInstance(instance_);
  if (device_) volkLoadDevice(device_);
}

Context::~Context() {
  destroy_device();
  if (messenger_) vkDestroyDebugUtilsMessengerEXT(instance_, messenger_, nullptr);
  if (instance_) vkDestroyInstance(instance_, nullptr);
}

Status Context::init(bool ray_tracing, bool validation, const std::string& device) {
  ContextOptions options;
  options.ray_tracing = ray_tracing;
  options.validation = validation;
  options.device = device;
  return init(options);
}

namespace {

// With `wanted`: VK_NV_cooperative_matrix into `extensions` and `cm` (cooperativeMatrix) chained after
// `after`; returns `wanted`. (shaderFloat16, the kernel's other feature, is the caller's Vulkan 1.2 struct.)
bool chain_coopmat_mlp(bool wanted, std::vector<const char*>& extensions, VkPhysicalDeviceCooperativeMatrixFeaturesNV& cm,
                       VkBaseOutStructure* after) {
  cm.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_COOPERATIVE_MATRIX_FEATURES_NV;
  if (!wanted) return false;
  extensions.push_back(VK_NV_COOPERATIVE_MATRIX_EXTENSION_NAME);
  cm.cooperativeMatrix = VK_TRUE;
  cm.pNext = after->pNext;
  after->pNext = reinterpret_cast<VkBaseOutStructure*>(&cm);
  return true;
}

}  // namespace

Status Context::init(const ContextOptions& options) {
  const bool ray_tracing = options.ray_tracing, validation = options.validation;
  on_validation_message_ = options.on_validation_message;
  if (volkInitialize() != VK_SUCCESS) return Status::error("no Vulkan loader (libvulkan.so.1) found");

  if (validation) {
    uint32_t layer_count = 0;
    vkEnumerateInstanceLayerProperties(&layer_count, nullptr);
    std::vector<VkLayerProperties> layers(layer_count);
    vkEnumerateInstanceLayerProperties(&layer_count, layers.data());
    bool has_validation = false;
    for (const VkLayerProperties& l : layers) has_validation |= std::strcmp(l.layerName, kValidationLayer) == 0;
    if (!has_validation)
      return Status::error("Vulkan layer %s is not installed (package vulkan-validationlayers)", kValidationLayer);
  }

  VkDebugUtilsMessengerCreateInfoEXT messenger_info{};
  messenger_info.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT;
  messenger_info.messageSeverity =
      VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  messenger_info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  messenger_info.pfnUserCallback = &Context::on_message;
  messenger_info.pUserData = this;

  VkApplicationInfo app{};
  app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
  app.pApplicationName = "lsnif";
  app.apiVersion = VK_API_VERSION_1_2;
  std::vector<const char*> extensions;
  if (validation) extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  {
    uint32_t n = 0;
    vkEnumerateInstanceExtensionProperties(nullptr, &n, nullptr);
    std::vector<VkExtensionProperties> available(n);
    vkEnumerateInstanceExtensionProperties(nullptr, &n, available.data());
    for (const std::string& name : options.instance_extensions) {
      bool found = false;
      for (const VkExtensionProperties& e : available) found |= name == e.extensionName;
      if (!found) return Status::error("the Vulkan loader lacks the instance extension %s", name.c_str());
      extensions.push_back(name.c_str());
    }
  }
  VkInstanceCreateInfo ici{};
  ici.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
  ici.pNext = validation ? &messenger_info : nullptr;  // also report problems of instance creation
  ici.pApplicationInfo = &app;
  ici.enabledLayerCount = validation ? 1 : 0;
  ici.ppEnabledLayerNames = validation ? &kValidationLayer : nullptr;
  ici.enabledExtensionCount = uint32_t(extensions.size());
  ici.ppEnabledExtensionNames = extensions.empty() ? nullptr : extensions.data();
  LSNIF_VK_CHECK(vkCreateInstance(&ici, nullptr, &instance_));
  volkLoadInstance(instance_);
  if (validation)
    LSNIF_VK_CHECK(vkCreateDebugUtilsMessengerEXT(instance_, &messenger_info, nullptr, &messenger_));

  uint32_t count = 0;
  vkEnumeratePhysicalDevices(instance_, &count, nullptr);
  std::vector<VkPhysicalDevice> devices(count);
  if (count > 0) vkEnumeratePhysicalDevices(instance_, &count, devices.data());
  std::vector<DeviceInfo> infos(devices.size());
  for (size_t i = 0; i < devices.size(); ++i)
    if (Status s = query_device_info(instance_, devices[i], infos[i]); !s) return s;
  DeviceNeeds needs;
  needs.ray_tracing = ray_tracing;
  needs.swapchain = options.swapchain;
  size_t chosen = 0;
  if (Status s = choose_device(infos, needs, options.device, chosen); !s) return s;
  physical_ = devices[chosen];
  queue_family_ = infos[chosen].compute_queue_family;
  device_name_ = infos[chosen].name;

  // choose_device checked that the device offers every extension and feature enabled here (what
  // LSNIF needs as the plugin's lsnifQueryDeviceSupport answered, VK_KHR_swapchain).
  std::vector<const char*> device_extensions;
  VkPhysicalDeviceAccelerationStructureFeaturesKHR as_features{};
  as_features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR;
  as_features.accelerationStructure = VK_TRUE;
  VkPhysicalDeviceRayTracingPipelineFeaturesKHR rt_features{};
  rt_features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR;
  rt_features.rayTracingPipeline = VK_TRUE;
  // Where offered, for the ray-tracing broad phase of lsnifCmdQuery.
  rt_features.rayTraversalPrimitiveCulling = infos[chosen].primitive_culling ? VK_TRUE : VK_FALSE;
  as_features.pNext = &rt_features;
  // Vulkan 1.2 covers descriptor indexing, buffer device address, float controls and SPIR-V 1.4;
  // VK_KHR_spirv_1_4, which VK_KHR_ray_tracing_pipeline names as its dependency, is enabled as well
  // where the device offers it.
  if (ray_tracing) {
    uint32_t required = 0;
    const char* const* names = lsnifGetRequiredDeviceExtensions(&required);
    device_extensions.assign(names, names + required);
    if (infos[chosen].ext_spirv_1_4) device_extensions.push_back(VK_KHR_SPIRV_1_4_EXTENSION_NAME);
  }
  if (options.swapchain) device_extensions.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
  VkPhysicalDeviceRayQueryFeaturesKHR rq_features{};
  rq_features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_QUERY_FEATURES_KHR;
  if (ray_tracing && options.ray_query && !infos[chosen].ray_query)
    return Status::error("device '%s' lacks extension VK_KHR_ray_query with feature rayQuery", device_name_.c_str());
  // Where offered (required with options.ray_query), for the ray-query broad phase of lsnifCmdQuery.
  if (ray_tracing && infos[chosen].ray_query) {
    device_extensions.push_back(VK_KHR_RAY_QUERY_EXTENSION_NAME);
    rq_features.rayQuery = VK_TRUE;
    rt_features.pNext = &rq_features;
  }

  // Where offered, for the cooperative-matrix MLP kernel (LSNIF_QUERY_PIPELINE_CREATE_COOPERATIVE_MATRIX_MLP_BIT_NV).
  VkPhysicalDeviceCooperativeMatrixFeaturesNV cm_features{};
  coopmat_mlp_ = chain_coopmat_mlp(ray_tracing && infos[chosen].coopmat_mlp, device_extensions, cm_features,
                                   reinterpret_cast<VkBaseOutStructure*>(&as_features));

  VkPhysicalDeviceVulkan12Features e12{};
  e12.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES;
  e12.shaderFloat16 = coopmat_mlp_ ? VK_TRUE : VK_FALSE;
  e12.pNext = ray_tracing ? &as_features : nullptr;
  e12.bufferDeviceAddress = VK_TRUE;
  // Enabled where offered: the path tracer's shaders use scalar layout.
  e12.scalarBlockLayout = infos[chosen].scalar_block_layout ? VK_TRUE : VK_FALSE;
  scalar_block_layout_ = infos[chosen].scalar_block_layout;
  VkPhysicalDeviceFeatures2 e2{};
  e2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
  e2.pNext = &e12;
  e2.features.shaderInt64 = VK_TRUE;
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci{};
  qci.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
  qci.queueFamilyIndex = queue_family_;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  VkDeviceCreateInfo dci{};
  dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  dci.pNext = &e2;
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  dci.enabledExtensionCount = uint32_t(device_extensions.size());
  dci.ppEnabledExtensionNames = device_extensions.empty() ? nullptr : device_extensions.data();
  LSNIF_VK_CHECK(vkCreateDevice(physical_, &dci, nullptr, &device_));
  volkLoadDevice(device_);
  vkGetDeviceQueue(device_, queue_family_, 0, &queue_);

  VkCommandPoolCreateInfo pci{};
  pci.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pci.queueFamilyIndex = queue_family_;
  LSNIF_VK_CHECK(vkCreateCommandPool(device_, &pci, nullptr, &pool_));
  VkFenceCreateInfo fci{};
  fci.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
  LSNIF_VK_CHECK(vkCreateFence(device_, &fci, nullptr, &fence_));
  return Status::ok();
}

BufferLimits Context::buffer_limits() const {
  BufferLimits out;
  if (!physical_) return out;
  VkPhysicalDeviceMaintenance3Properties m3{};
  m3.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES;
  VkPhysicalDeviceProperties2 p2{};
  p2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
  p2.pNext = &m3;
  vkGetPhysicalDeviceProperties2(physical_, &p2);
  out.max_allocation = m3.maxMemoryAllocationSize;
  out.max_storage_range = p2.properties.limits.maxStorageBufferRange;
  VkPhysicalDeviceMemoryProperties mem;
  vkGetPhysicalDeviceMemoryProperties(physical_, &mem);
  const VkMemoryPropertyFlags want = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  for (uint32_t i = 0; i < mem.memoryTypeCount; ++i)
    if ((mem.memoryTypes[i].propertyFlags & want) == want)
      out.heap = std::max<uint64_t>(out.heap, mem.memoryHeaps[mem.memoryTypes[i].heapIndex].size);
  return out;
}

Status Context::check_buffer_size(const std::string& what, uint64_t bytes, bool descriptor) const {
  const BufferLimits limits = buffer_limits();
  const auto past = [&](uint64_t limit, const char* name) {
    return Status::error("the %s needs %llu bytes, more than the device's %s (%llu bytes)", what.c_str(),
                         (unsigned long long)bytes, name, (unsigned long long)limit);
  };
  if (limits.max_allocation && bytes > limits.max_allocation) return past(limits.max_allocation, "maxMemoryAllocationSize");
  if (limits.heap && bytes > limits.heap) return past(limits.heap, "host-visible memory heap");
  if (descriptor && bytes > limits.max_storage_range) return past(limits.max_storage_range, "maxStorageBufferRange");
  return Status::ok();
}

bool address_space_for(uint64_t bytes) {
  if (bytes > uint64_t(SIZE_MAX)) return false;
  void* p = ::mmap(nullptr, size_t(bytes), PROT_NONE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
  if (p == MAP_FAILED) return false;
  ::munmap(p, size_t(bytes));
  return true;
}

Status Context::create_buffer(size_t bytes, Buffer& out, VkBufferUsageFlags extra_usage) {
  out = Buffer();
  if (!device_) return Status::error("create_buffer: context not initialized");
  if (Status s = check_buffer_size("buffer", bytes); !s) return s;
  VkBufferCreateInfo bci{};
  bci.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  bci.size = bytes > 0 ? bytes : 4;
  bci.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT | extra_usage;
  bci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  LSNIF_VK_CHECK(vkCreateBuffer(device_, &bci, nullptr, &out.buffer));
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(device_, out.buffer, &req);
  VkPhysicalDeviceMemoryProperties mem;
  vkGetPhysicalDeviceMemoryProperties(physical_, &mem);
  const VkMemoryPropertyFlags want = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  uint32_t type = UINT32_MAX;
  for (uint32_t i = 0; i < mem.memoryTypeCount && type == UINT32_MAX; ++i)
    if ((req.memoryTypeBits & (1u << i)) && (mem.memoryTypes[i].propertyFlags & want) == want) type = i;
  // Every failure from here on releases what was made and names the size.
  const auto fail = [&](const char* what, VkResult result) {
    destroy_buffer(out);
    const std::string code = result == VK_SUCCESS ? std::string() : format(" (VkResult %d)", int(result));
    return Status::error("a buffer of %llu bytes: %s%s", (unsigned long long)req.size, what, code.c_str());
  };
  if (type == UINT32_MAX) return fail("no host-visible coherent memory type", VK_SUCCESS);
  VkMemoryAllocateFlagsInfo flags{};
  flags.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO;
  flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
  VkMemoryAllocateInfo mai{};
  mai.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
  mai.pNext = &flags;
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = type;
  // The mapping needs the address space (twice: a driver on the CPU may keep its own mapping too).
  if (!address_space_for(2 * req.size)) return fail("the process's address space cannot take it", VK_SUCCESS);
  if (VkResult r = vkAllocateMemory(device_, &mai, nullptr, &out.memory); r != VK_SUCCESS)
    return fail("out of device memory (vkAllocateMemory failed)", r);
  if (VkResult r = vkBindBufferMemory(device_, out.buffer, out.memory, 0); r != VK_SUCCESS)
    return fail("vkBindBufferMemory failed", r);
  if (VkResult r = vkMapMemory(device_, out.memory, 0, VK_WHOLE_SIZE, 0, &out.mapped); r != VK_SUCCESS)
    return fail("cannot map it into the host's address space (vkMapMemory failed)", r);
  if (!out.mapped || out.mapped == MAP_FAILED)
    return fail("cannot map it into the host's address space (vkMapMemory gave no address)", VK_SUCCESS);
  std::memset(out.mapped, 0, bci.size);
  out.size = bci.size;
  VkBufferDeviceAddressInfo ai{};
  ai.sType = VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO;
  ai.buffer = out.buffer;
  out.address = vkGetBufferDeviceAddress(device_, &ai);
  return Status::ok();
}

void Context::destroy_buffer(Buffer& buffer) {
  if (device_) {
    if (buffer.buffer) vkDestroyBuffer(device_, buffer.buffer, nullptr);
    if (buffer.memory) vkFreeMemory(device_, buffer.memory, nullptr);  // also unmaps
  }
  buffer = Buffer();
}

Status read_spirv_file(const std::string& path, std::vector<uint32_t>& code) {
  std::string bytes;
  ReadFailure f;
  if (!read_file(path, bytes, kMaxSpirvFileBytes, &f)) {
    switch (f.problem) {
      case ReadProblem::TooLarge:
        return Status::error("SPIR-V file %s has %llu bytes (more than the %llu a shader may have)", path.c_str(),
                             static_cast<unsigned long long>(f.size),
                             static_cast<unsigned long long>(kMaxSpirvFileBytes));
      case ReadProblem::OutOfMemory:
      case ReadProblem::ReadError:
      case ReadProblem::ChangedSize: return Status::error("cannot read SPIR-V file %s", path.c_str());
      default: return Status::error("cannot open SPIR-V file %s", path.c_str());
    }
  }
  if (bytes.empty() || bytes.size() % 4 != 0)
    return Status::error("SPIR-V file %s has %lld bytes (not a positive multiple of 4)", path.c_str(),
                         static_cast<long long>(bytes.size()));
  code.assign(bytes.size() / 4, 0u);
  std::memcpy(code.data(), bytes.data(), bytes.size());
  return Status::ok();
}

Status Context::create_shader_module(const Spirv& code, VkShaderModule& out) {
  if (!device_) return Status::error("create_shader_module: context not initialized");
  if (!code.code || code.bytes == 0 || code.bytes % 4 != 0 || code.code[0] != 0x07230203u)
    return Status::error("not SPIR-V (%zu bytes, a positive multiple of 4 starting with the magic 0x07230203 expected)",
                         code.bytes);
  VkShaderModuleCreateInfo smi{};
  smi.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  smi.codeSize = code.bytes;
  smi.pCode = code.code;
  LSNIF_VK_CHECK(vkCreateShaderModule(device_, &smi, nullptr, &out));
  return Status::ok();
}

Status Context::create_pipeline(const Spirv& code, uint32_t push_size, Pipeline& out,
                                       uint32_t storage_buffers) {
  out = Pipeline();
  if (!device_) return Status::error("create_pipeline: context not initialized");
  if (storage_buffers > 0) {
    std::vector<VkDescriptorSetLayoutBinding> bindings(storage_buffers);
    for (uint32_t i = 0; i < storage_buffers; ++i)
      bindings[i] = VkDescriptorSetLayoutBinding{i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT,
                                                 nullptr};
    VkDescriptorSetLayoutCreateInfo dci{};
    dci.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
    dci.bindingCount = storage_buffers;
    dci.pBindings = bindings.data();
    LSNIF_VK_CHECK(vkCreateDescriptorSetLayout(device_, &dci, nullptr, &out.set_layout));
    out.storage_buffers = storage_buffers;
  }
  VkShaderModule module;
  if (Status st = create_shader_module(code, module); !st) {
    destroy_pipeline(out);
    return st;
  }

  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, push_size};
  VkPipelineLayoutCreateInfo lci{};
  lci.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  lci.setLayoutCount = out.set_layout ? 1 : 0;
  lci.pSetLayouts = &out.set_layout;
  lci.pushConstantRangeCount = push_size > 0 ? 1 : 0;
  lci.pPushConstantRanges = &range;
  VkResult r = vkCreatePipelineLayout(device_, &lci, nullptr, &out.layout);
  if (r != VK_SUCCESS) {
    vkDestroyShaderModule(device_, module, nullptr);
    destroy_pipeline(out);
    return Status::error("vkCreatePipelineLayout failed (VkResult %d)", static_cast<int>(r));
  }
  VkComputePipelineCreateInfo cpi{};
  cpi.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
  cpi.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  cpi.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  cpi.stage.module = module;
  cpi.stage.pName = "main";
  cpi.layout = out.layout;
  const auto t0 = std::chrono::steady_clock::now();
  r = vkCreateComputePipelines(device_, VK_NULL_HANDLE, 1, &cpi, nullptr, &out.pipeline);
  out.create_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  vkDestroyShaderModule(device_, module, nullptr);
  if (r != VK_SUCCESS) {
    destroy_pipeline(out);
    return Status::error("vkCreateComputePipelines failed (VkResult %d)", static_cast<int>(r));
  }
  out.push_size = push_size;
  return Status::ok();
}

void Context::destroy_pipeline(Pipeline& pipeline) {
  if (device_) {
    if (pipeline.pipeline) vkDestroyPipeline(device_, pipeline.pipeline, nullptr);
    if (pipeline.layout) vkDestroyPipelineLayout(device_, pipeline.layout, nullptr);
    if (pipeline.set_layout) vkDestroyDescriptorSetLayout(device_, pipeline.set_layout, nullptr);
  }
  pipeline = Pipeline();
}

Status Context::submit(const char* what, const std::function<void(VkCommandBuffer)>& record) {
  if (!device_) return Status::error("%s: context not initialized", what);
  VkCommandBufferAllocateInfo cai{};
  cai.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
  cai.commandPool = pool_;
  cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cai.commandBufferCount = 1;
  VkCommandBuffer cmd;
  LSNIF_VK_CHECK(vkAllocateCommandBuffers(device_, &cai, &cmd));
  VkCommandBufferBeginInfo bi{};
  bi.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  vkBeginCommandBuffer(cmd, &bi);
  record(cmd);
  vkEndCommandBuffer(cmd);
  VkSubmitInfo si{};
  si.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
  si.commandBufferCount = 1;
  si.pCommandBuffers = &cmd;
  VkResult r = vkQueueSubmit(queue_, 1, &si, fence_);
  if (r == VK_SUCCESS) r = vkWaitForFences(device_, 1, &fence_, VK_TRUE, UINT64_MAX);
  if (r == VK_SUCCESS) r = vkResetFences(device_, 1, &fence_);
  vkFreeCommandBuffers(device_, pool_, 1, &cmd);
  if (r != VK_SUCCESS) return Status::error("%s failed (VkResult %d)", what, static_cast<int>(r));
  return Status::ok();
}

void Context::barrier_compute_to_host(VkCommandBuffer cmd) {
  VkMemoryBarrier b{};
  b.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
  b.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
  b.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &b, 0, nullptr, 0,
                       nullptr);
}

Status Context::create_timestamps(uint32_t count, Timestamps& out) {
  out = Timestamps();
  if (!device_) return Status::error("create_timestamps: context not initialized");
  if (count == 0) return Status::error("create_timestamps: no queries asked for");
  uint32_t family_count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(physical_, &family_count, nullptr);
  std::vector<VkQueueFamilyProperties> families(family_count);
  vkGetPhysicalDeviceQueueFamilyProperties(physical_, &family_count, families.data());
  const uint32_t bits = queue_family_ < family_count ? families[queue_family_].timestampValidBits : 0u;
  if (bits == 0) return Status::error("device %s: its queue family has no timestamps", device_name_.c_str());
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(physical_, &props);
  VkQueryPoolCreateInfo qci{};
  qci.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
  qci.queryType = VK_QUERY_TYPE_TIMESTAMP;
  qci.queryCount = count;
  LSNIF_VK_CHECK(vkCreateQueryPool(device_, &qci, nullptr, &out.pool));
  out.count = count;
  out.ns_per_tick = double(props.limits.timestampPeriod);
  out.valid_mask = bits >= 64 ? ~uint64_t(0) : (uint64_t(1) << bits) - 1;
  return Status::ok();
}

void Context::destroy_timestamps(Timestamps& timestamps) {
  if (timestamps.pool && device_) vkDestroyQueryPool(device_, timestamps.pool, nullptr);
  timestamps = Timestamps();
}

Status Context::read_timestamps_ms(const Timestamps& timestamps, uint32_t first, uint32_t count,
                                          std::vector<double>& ms) {
  ms.clear();
  if (!timestamps.pool || uint64_t(first) + count > timestamps.count)
    return Status::error("read_timestamps_ms: queries %u..%u outside the pool of %u", first, first + count,
                         timestamps.count);
  if (count == 0) return Status::ok();
  std::vector<uint64_t> ticks(2 * size_t(count));  // {timestamp, availability} per query
  const VkResult r =
      vkGetQueryPoolResults(device_, timestamps.pool, first, count, ticks.size() * sizeof(uint64_t), ticks.data(),
                            2 * sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WITH_AVAILABILITY_BIT);
  if (r != VK_SUCCESS && r != VK_NOT_READY)
    return Status::error("vkGetQueryPoolResults (timestamps) failed (VkResult %d)", int(r));
  ms.resize(count);
  for (uint32_t i = 0; i < count; ++i) {
    if (ticks[2 * i + 1] == 0) {
      ms.clear();
      return Status::error("timestamp query %u was not written", first + i);
    }
    ms[i] = double((ticks[2 * i] - ticks[0]) & timestamps.valid_mask) * timestamps.ns_per_tick * 1e-6;
  }
  return Status::ok();
}

}  // namespace lsnif::vk
