// context.cpp -- contexts and models on the application's device (context.h): memory, the GPU
// block upload, the AABB BLAS build, release. Every Vulkan object is created with the
// application's allocation callbacks; nothing is submitted except by build_and_wait.
#include "lsnif/plugin/context.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstring>

#include "lsnif/plugin/device_support.h"
#include "lsnif/format/gpu_block.h"
#include "lsnif/format/model_format.h"

namespace lsnif::plugin {

Outcome Outcome::fail(LsnifResult code, const char* fmt, ...) {
  Outcome o;
  o.code = code;
  va_list args;
  va_start(args, fmt);
  o.message = vformat(fmt, args);
  va_end(args);
  return o;
}

Outcome Outcome::from(const Status& status, LsnifResult code) {
  if (status) return ok();
  Outcome o;
  o.code = code;
  o.message = status.message();
  return o;
}

namespace {

#define LSNIF_VK_TRY(call)                                                                             \
  do {                                                                                                 \
    const VkResult result_ = (call);                                                                   \
    if (result_ != VK_SUCCESS)                                                                         \
      return Outcome::fail(LSNIF_ERROR_VULKAN, "%s failed (VkResult %d)", #call, static_cast<int>(result_)); \
  } while (0)

// The best memory type of `bits` for `placement`, or UINT32_MAX.
uint32_t choose_memory_type(const VkPhysicalDeviceMemoryProperties& mp, uint32_t bits, Placement placement) {
  constexpr VkMemoryPropertyFlags kHost = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  constexpr VkMemoryPropertyFlags kLocal = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
  uint32_t best = UINT32_MAX;
  int best_score = -1;
  for (uint32_t i = 0; i < mp.memoryTypeCount; ++i) {
    if (!(bits & (1u << i))) continue;
    const VkMemoryPropertyFlags f = mp.memoryTypes[i].propertyFlags;
    const bool host = (f & kHost) == kHost, local = (f & kLocal) != 0;
    int score = -1;
    switch (placement) {
      case Placement::HostWrite: score = host ? (local ? 1 : 2) : -1; break;  // keep device-local heaps for the GPU
      case Placement::DeviceDirect: score = host && local ? 1 : -1; break;
      case Placement::DeviceOnly: score = local ? (host ? 2 : 3) : 1; break;
    }
    if (score > best_score) {
      best_score = score;
      best = i;
    }
  }
  return best;
}

}  // namespace

void release(LsnifContext_T& ctx, Allocation& a) {
  const VkAllocationCallbacks* cb = ctx.info.pAllocator;
  if (a.buffer) ctx.vk.vkDestroyBuffer(ctx.info.device, a.buffer, cb);
  if (a.memory) ctx.vk.vkFreeMemory(ctx.info.device, a.memory, cb);
  a = Allocation();
}

void name_object(const LsnifContext_T& ctx, VkObjectType type, uint64_t handle, const std::string& name) {
  if (!ctx.set_object_name || handle == 0) return;
  VkDebugUtilsObjectNameInfoEXT info{};
  info.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT;
  info.objectType = type;
  info.objectHandle = handle;
  info.pObjectName = name.c_str();
  ctx.set_object_name(ctx.info.device, &info);
}

Outcome allocate(LsnifContext_T& ctx, VkDeviceSize bytes, VkBufferUsageFlags usage, Placement placement,
                 const void* data, const std::string& name, Allocation& out) {
  out = Allocation();
  const VkDevice device = ctx.info.device;
  const VkAllocationCallbacks* cb = ctx.info.pAllocator;
  VkBufferCreateInfo bci{};
  bci.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  bci.size = bytes > 0 ? bytes : 4;
  bci.usage = usage | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
  bci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  LSNIF_VK_TRY(ctx.vk.vkCreateBuffer(device, &bci, cb, &out.buffer));
  VkMemoryRequirements req;
  ctx.vk.vkGetBufferMemoryRequirements(device, out.buffer, &req);
  const uint32_t type = choose_memory_type(ctx.memory, req.memoryTypeBits, placement);
  if (type == UINT32_MAX) {
    release(ctx, out);
    return Outcome::fail(LSNIF_ERROR_VULKAN, "no %s memory type for a %llu-byte buffer",
                         placement == Placement::DeviceDirect ? "device-local host-visible"
                         : placement == Placement::HostWrite  ? "host-visible coherent"
                                                              : "suitable",
                         static_cast<unsigned long long>(bytes));
  }
  const VkMemoryPropertyFlags flags = ctx.memory.memoryTypes[type].propertyFlags;
  out.host_visible = (flags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT) != 0;
  VkMemoryAllocateFlagsInfo af{};
  af.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO;
  af.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
  VkMemoryAllocateInfo mai{};
  mai.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
  mai.pNext = &af;
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = type;
  out.bytes = bytes;
  out.allocated = req.size;
  VkResult r = ctx.vk.vkAllocateMemory(device, &mai, cb, &out.memory);
  if (r == VK_SUCCESS) r = ctx.vk.vkBindBufferMemory(device, out.buffer, out.memory, 0);
  if (r == VK_SUCCESS && data) {
    void* mapped = nullptr;
    r = out.host_visible ? ctx.vk.vkMapMemory(device, out.memory, 0, VK_WHOLE_SIZE, 0, &mapped)
                         : VK_ERROR_MEMORY_MAP_FAILED;
    if (r == VK_SUCCESS) {
      std::memcpy(mapped, data, size_t(bytes));
      ctx.vk.vkUnmapMemory(device, out.memory);
    }
  }
  if (r != VK_SUCCESS) {
    release(ctx, out);
    return Outcome::fail(r == VK_ERROR_OUT_OF_HOST_MEMORY ? LSNIF_ERROR_OUT_OF_HOST_MEMORY : LSNIF_ERROR_VULKAN,
                         "allocating a %llu-byte buffer failed (VkResult %d)", static_cast<unsigned long long>(bytes),
                         static_cast<int>(r));
  }
  name_object(ctx, VK_OBJECT_TYPE_BUFFER, out.buffer, name);
  name_object(ctx, VK_OBJECT_TYPE_DEVICE_MEMORY, out.memory, name + " memory");
  VkBufferDeviceAddressInfo ai{};
  ai.sType = VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO;
  ai.buffer = out.buffer;
  out.address = ctx.vk.vkGetBufferDeviceAddress(device, &ai);
  return Outcome::ok();
}

namespace {

// The geometry of a model's one AABB (input at the model's aabb buffer).
VkAccelerationStructureGeometryKHR aabb_geometry(const LsnifModel_T& m) {
  VkAccelerationStructureGeometryKHR g{};
  g.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR;
  g.geometryType = VK_GEOMETRY_TYPE_AABBS_KHR;
  g.flags = VK_GEOMETRY_OPAQUE_BIT_KHR;
  g.geometry.aabbs.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_AABBS_DATA_KHR;
  g.geometry.aabbs.data.deviceAddress = m.aabb.address;
  g.geometry.aabbs.stride = sizeof(VkAabbPositionsKHR);
  return g;
}

VkAccelerationStructureBuildGeometryInfoKHR blas_build_info(const VkAccelerationStructureGeometryKHR* geometry) {
  VkAccelerationStructureBuildGeometryInfoKHR info{};
  info.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR;
  info.type = VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR;
  info.flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR;
  info.mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR;
  info.geometryCount = 1;
  info.pGeometries = geometry;
  return info;
}

// Buffers and the (unbuilt) BLAS of `m`, whose block words are `words` and box `box`.
Outcome create_device_objects(LsnifContext_T& ctx, LsnifModel_T& m, const std::vector<uint32_t>& words,
                              const VkAabbPositionsKHR& box) {
  const VkDeviceSize block_bytes = words.size() * sizeof(uint32_t);
  const VkBufferUsageFlags block_usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  const std::string name = "lsnif model " + std::to_string(++ctx.models_created);
  Outcome o;
  if (!ctx.staging_upload) {
    o = allocate(ctx, block_bytes, block_usage, Placement::DeviceDirect, words.data(), name + ": block", m.block);
    if (!o && o.code != LSNIF_ERROR_VULKAN) return o;
  }
  if (ctx.staging_upload || !o) {  // no device-local host-visible memory (or asked for): stage it
    o = allocate(ctx, block_bytes, block_usage, Placement::DeviceOnly, nullptr, name + ": block", m.block);
    if (o)
      o = allocate(ctx, block_bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, Placement::HostWrite, words.data(),
                   name + ": block staging", m.staging);
    if (!o) return o.context("GPU block");
  }
  if (m.block.address % 32 != 0)  // the shaders read the MLP in 32-byte loads
    return Outcome::fail(LSNIF_ERROR_VULKAN, "model block at device address 0x%llx is not 32-byte aligned",
                         static_cast<unsigned long long>(m.block.address));
  o = allocate(ctx, sizeof box, VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR,
               Placement::HostWrite, &box, name + ": BLAS input", m.aabb);
  if (!o) return o.context("BLAS input");

  const VkAccelerationStructureGeometryKHR geometry = aabb_geometry(m);
  const VkAccelerationStructureBuildGeometryInfoKHR info = blas_build_info(&geometry);
  const uint32_t primitives = 1;
  VkAccelerationStructureBuildSizesInfoKHR sizes{};
  sizes.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR;
  ctx.vk.vkGetAccelerationStructureBuildSizesKHR(ctx.info.device, VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR,
                                                 &info, &primitives, &sizes);
  o = allocate(ctx, sizes.accelerationStructureSize, VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR,
               Placement::DeviceOnly, nullptr, name + ": BLAS storage", m.blas_storage);
  if (!o) return o.context("BLAS storage");
  o = allocate(ctx, sizes.buildScratchSize + ctx.scratch_alignment, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
               Placement::DeviceOnly, nullptr, name + ": BLAS scratch", m.scratch);
  if (!o) return o.context("BLAS scratch");
  m.scratch_address = align_up(m.scratch.address, ctx.scratch_alignment);

  VkAccelerationStructureCreateInfoKHR aci{};
  aci.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_KHR;
  aci.buffer = m.blas_storage.buffer;
  aci.size = sizes.accelerationStructureSize;
  aci.type = VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR;
  LSNIF_VK_TRY(ctx.vk.vkCreateAccelerationStructureKHR(ctx.info.device, &aci, ctx.info.pAllocator, &m.blas));
  name_object(ctx, VK_OBJECT_TYPE_ACCELERATION_STRUCTURE_KHR, m.blas, name + ": BLAS");
  VkAccelerationStructureDeviceAddressInfoKHR dai{};
  dai.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_DEVICE_ADDRESS_INFO_KHR;
  dai.accelerationStructure = m.blas;
  m.blas_address = ctx.vk.vkGetAccelerationStructureDeviceAddressKHR(ctx.info.device, &dai);
  return Outcome::ok();
}

}  // namespace

Outcome create_context(const LsnifContextCreateInfo& info, std::unique_ptr<LsnifContext_T>& out) {
  if (info.pEnabledFeatures)
    if (std::string why = chain_problem(info.pEnabledFeatures, "pEnabledFeatures"); !why.empty())
      return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "%s", why.c_str());
  // The core features kept apart from the chain (LsnifContextCoreFeaturesInfo), or null.
  const VkPhysicalDeviceFeatures* core = nullptr;
  if (info.pNext) {
    const auto* c = static_cast<const LsnifContextCoreFeaturesInfo*>(info.pNext);
    if (c->sType != LSNIF_STRUCTURE_TYPE_CONTEXT_CORE_FEATURES_INFO)
      return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                           "pNext: unknown structure type %d (expected LSNIF_STRUCTURE_TYPE_CONTEXT_CORE_FEATURES_INFO)",
                           int(c->sType));
    if (c->pNext) return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "LsnifContextCoreFeaturesInfo::pNext must be NULL");
    if (!c->pEnabledFeatures)
      return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "LsnifContextCoreFeaturesInfo::pEnabledFeatures is NULL");
    if (!info.pEnabledFeatures)
      return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                           "a LsnifContextCoreFeaturesInfo needs pEnabledFeatures: the chain of the device's other "
                           "feature structs");
    if (has_core_features(info.pEnabledFeatures))
      return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                           "pEnabledFeatures holds core features (a VkPhysicalDeviceFeatures2 or a VkDeviceCreateInfo's "
                           "pEnabledFeatures) and pNext a LsnifContextCoreFeaturesInfo: Vulkan allows them in one place");
    core = c->pEnabledFeatures;
  }
  if (info.flags & ~LsnifContextCreateFlags(LSNIF_CONTEXT_CREATE_STAGING_UPLOAD_BIT))
    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "unknown flags 0x%x", info.flags);
  if (!info.instance || !info.physicalDevice || !info.device || !info.pfnGetInstanceProcAddr)
    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                         "null handle (instance %p, physical device %p, device %p, vkGetInstanceProcAddr %s)",
                         static_cast<void*>(info.instance), static_cast<void*>(info.physicalDevice),
                         static_cast<void*>(info.device), info.pfnGetInstanceProcAddr ? "set" : "null");
  auto ctx = std::make_unique<LsnifContext_T>();
  ctx->info = info;
  ctx->info.pNext = nullptr;
  ctx->info.pEnabledFeatures = nullptr;  // not kept: it may not outlive this call
  ctx->staging_upload = (info.flags & LSNIF_CONTEXT_CREATE_STAGING_UPLOAD_BIT) != 0;
  if (const char* missing = load_instance_dispatch(info.pfnGetInstanceProcAddr, info.instance, ctx->vki))
    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                         "the instance does not provide %s (create it with apiVersion 1.2 or newer)", missing);
  // Null unless the application enabled VK_EXT_debug_utils on the instance.
  ctx->set_object_name = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(
      info.pfnGetInstanceProcAddr(info.instance, "vkSetDebugUtilsObjectNameEXT"));
  // A Vulkan 1.2 core command that the device does not hand out: the instance's apiVersion caps the
  // device's (Mesa, the validation layer and the loader hand out no core command newer than it), so
  // everything else would fail obscurely. Checked first: the queries below chain 1.2 structs. (A
  // device below 1.2 is named as such by describe_device_support.)
  VkPhysicalDeviceProperties device_props;
  ctx->vki.vkGetPhysicalDeviceProperties(info.physicalDevice, &device_props);
  if (device_props.apiVersion >= VK_API_VERSION_1_2 && !ctx->vki.vkGetDeviceProcAddr(info.device, "vkGetBufferDeviceAddress"))
    return Outcome::fail(LSNIF_ERROR_DEVICE_UNSUPPORTED,
                         "the device '%s' (Vulkan %s) does not provide the Vulkan 1.2 command "
                         "vkGetBufferDeviceAddress: the instance was created with an apiVersion below 1.2 "
                         "(VkApplicationInfo::apiVersion caps the device's version); LSNIF needs Vulkan 1.2 "
                         "(its shaders are SPIR-V 1.5): create the instance with VK_API_VERSION_1_2 or newer",
                         device_props.deviceName, api_version_string(device_props.apiVersion).c_str());
  const DeviceSupport support = query_device_support(ctx->vki, info.physicalDevice);
  if (Status s = describe_device_support(support); !s) return Outcome::from(s, LSNIF_ERROR_DEVICE_UNSUPPORTED);
  if (info.pEnabledFeatures) {
    const std::vector<std::string> off = features_not_enabled(info.pEnabledFeatures, core);
    if (!off.empty()) {
      std::string list;
      for (const std::string& f : off) list += (list.empty() ? "" : ", ") + f;
      const std::string hint = core ? std::string() : core_features_hint(info.pEnabledFeatures);
      return Outcome::fail(LSNIF_ERROR_DEVICE_UNSUPPORTED, "the device '%s' was created without what LSNIF needs enabled: %s (%s)%s%s",
                           support.name.c_str(), list.c_str(),
                           core ? "lsnifEnableDeviceFeaturesWithCore"
                                : "lsnifInitDeviceFeatures, lsnifEnableDeviceFeaturesInCreateInfo",
                           hint.empty() ? "" : "; ", hint.c_str());
    }
  }
  ctx->ray_query_offered = support.ray_query;
  ctx->ray_query_not_enabled = info.pEnabledFeatures && !ray_query_enabled(info.pEnabledFeatures);
  ctx->primitive_culling_offered = support.ray_traversal_primitive_culling;
  ctx->primitive_culling_not_enabled = info.pEnabledFeatures && !primitive_culling_enabled(info.pEnabledFeatures);
  ctx->coopmat_mlp_missing = missing_for_coopmat_mlp(support);
  if (info.pEnabledFeatures && ctx->coopmat_mlp_missing.empty())
    for (const std::string& f : coopmat_mlp_features_not_enabled(info.pEnabledFeatures))
      ctx->coopmat_mlp_missing.push_back(f + " not enabled");
  ctx->device_name = support.name;
  if (const char* missing = load_device_dispatch(ctx->vki, info.device, ctx->vk))
    return Outcome::fail(LSNIF_ERROR_DEVICE_UNSUPPORTED,
                         "the device does not provide %s: create it with the extensions of "
                         "lsnifGetRequiredDeviceExtensions enabled",
                         missing);
  ctx->vki.vkGetPhysicalDeviceMemoryProperties(info.physicalDevice, &ctx->memory);
  VkPhysicalDeviceAccelerationStructurePropertiesKHR as{};
  as.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_PROPERTIES_KHR;
  VkPhysicalDeviceProperties2 p2{};
  p2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
  p2.pNext = &as;
  ctx->ray_tracing.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_PROPERTIES_KHR;
  as.pNext = &ctx->ray_tracing;
  ctx->vki.vkGetPhysicalDeviceProperties2(info.physicalDevice, &p2);
  ctx->ray_tracing.pNext = nullptr;
  ctx->scratch_alignment = as.minAccelerationStructureScratchOffsetAlignment;
  if (info.queue) {
    uint32_t families = 0;
    ctx->vki.vkGetPhysicalDeviceQueueFamilyProperties(info.physicalDevice, &families, nullptr);
    std::vector<VkQueueFamilyProperties> props(families);
    ctx->vki.vkGetPhysicalDeviceQueueFamilyProperties(info.physicalDevice, &families, props.data());
    if (info.queueFamilyIndex >= families || !(props[info.queueFamilyIndex].queueFlags & VK_QUEUE_COMPUTE_BIT))
      return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                           "queue family %u %s (the blocking calls build acceleration structures on it)",
                           info.queueFamilyIndex, info.queueFamilyIndex >= families ? "does not exist" : "has no compute");
  }
  out = std::move(ctx);
  return Outcome::ok();
}

void destroy_context(LsnifContext_T& ctx) {
  for (auto& p : ctx.query_pipelines) destroy_query_pipeline(ctx, *p);
  ctx.query_pipelines.clear();
  for (auto& m : ctx.models) destroy_model(ctx, *m);
  ctx.models.clear();
  const VkAllocationCallbacks* cb = ctx.info.pAllocator;
  if (ctx.fence) ctx.vk.vkDestroyFence(ctx.info.device, ctx.fence, cb);
  if (ctx.pool) ctx.vk.vkDestroyCommandPool(ctx.info.device, ctx.pool, cb);
  ctx.fence = VK_NULL_HANDLE;
  ctx.pool = VK_NULL_HANDLE;
}

Outcome create_model(LsnifContext_T& ctx, const uint8_t* data, size_t size, LsnifModel& out) {
  ModelFileView view;
  if (Status s = parse_model_file(data, size, view); !s)
    return Outcome::from(s, LSNIF_ERROR_INVALID_MODEL).context("not a valid .lsnif model");
  std::vector<uint32_t> words;
  if (Status s = pack_gpu_block(view, words); !s) return Outcome::from(s, LSNIF_ERROR_INVALID_MODEL);
  if (Status s = check_gpu_block_header(words); !s)
    return Outcome::from(s, LSNIF_ERROR_INVALID_MODEL).context("internal error");

  auto m = std::make_unique<LsnifModel_T>();
  // The BLAS box: the model's AABB grown by 1e-4 of its diagonal, so that the driver's box test
  // never culls a ray the shader would hit on a face (the shader clips to the model's bounds).
  float diagonal2 = 0.0f;
  for (int a = 0; a < 3; ++a) {
    m->bounds_min[a] = view.bounds_lo[a];
    m->bounds_max[a] = view.bounds_hi[a];
    const float e = view.bounds_hi[a] - view.bounds_lo[a];
    diagonal2 += e * e;
  }
  const float grow = 1e-4f * std::sqrt(diagonal2);
  const VkAabbPositionsKHR box{view.bounds_lo[0] - grow, view.bounds_lo[1] - grow, view.bounds_lo[2] - grow,
                               view.bounds_hi[0] + grow, view.bounds_hi[1] + grow, view.bounds_hi[2] + grow};
  for (const float v : {box.minX, box.minY, box.minZ, box.maxX, box.maxY, box.maxZ})
    if (!std::isfinite(v)) return Outcome::fail(LSNIF_ERROR_INVALID_MODEL, "the model's bounds overflow when padded");
  m->material_count = view.config.material_count;
  const LsnifGpuModelHeader header = gpu_block_header(words);
  m->layout_version = header.version;
  m->max_points = header.max_points;
  m->input_dim = header.max_points * header.grid_levels * header.features;
  m->output_dim = view.config.output_dim();  // with the surface channels when the model has them
  Outcome o = create_device_objects(ctx, *m, words, box);
  if (!o) {
    destroy_model(ctx, *m);
    return o;
  }
  out = m.get();
  ctx.models.push_back(std::move(m));
  return Outcome::ok();
}

void free_build_resources(LsnifContext_T& ctx, LsnifModel_T& m) {
  release(ctx, m.staging);
  release(ctx, m.aabb);
  release(ctx, m.scratch);
  m.scratch_address = 0;
}

void destroy_model(LsnifContext_T& ctx, LsnifModel_T& m) {
  if (m.blas) ctx.vk.vkDestroyAccelerationStructureKHR(ctx.info.device, m.blas, ctx.info.pAllocator);
  m.blas = VK_NULL_HANDLE;
  free_build_resources(ctx, m);
  release(ctx, m.blas_storage);
  release(ctx, m.block);
}

void record_builds(LsnifContext_T& ctx, VkCommandBuffer cmd, const std::vector<LsnifModel_T*>& models) {
  bool copied = false;
  for (LsnifModel_T* m : models) {
    if (!m->staging.buffer) continue;
    const VkBufferCopy region{0, 0, m->block.bytes};
    ctx.vk.vkCmdCopyBuffer(cmd, m->staging.buffer, m->block.buffer, 1, &region);
    copied = true;
  }
  std::vector<VkAccelerationStructureGeometryKHR> geometries(models.size());
  std::vector<VkAccelerationStructureBuildGeometryInfoKHR> infos(models.size());
  std::vector<VkAccelerationStructureBuildRangeInfoKHR> ranges(models.size());
  std::vector<const VkAccelerationStructureBuildRangeInfoKHR*> range_pointers(models.size());
  for (size_t i = 0; i < models.size(); ++i) {
    geometries[i] = aabb_geometry(*models[i]);
    infos[i] = blas_build_info(&geometries[i]);
    infos[i].dstAccelerationStructure = models[i]->blas;
    infos[i].scratchData.deviceAddress = models[i]->scratch_address;
    ranges[i] = VkAccelerationStructureBuildRangeInfoKHR{};
    ranges[i].primitiveCount = 1;
    range_pointers[i] = &ranges[i];
    models[i]->build_recorded = true;
  }
  if (!models.empty())
    ctx.vk.vkCmdBuildAccelerationStructuresKHR(cmd, uint32_t(models.size()), infos.data(), range_pointers.data());
  // The BLASes are read by later TLAS builds and traces, the blocks by ray-tracing and compute shaders.
  VkMemoryBarrier barrier{};
  barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
  barrier.srcAccessMask = VK_ACCESS_ACCELERATION_STRUCTURE_WRITE_BIT_KHR | (copied ? VK_ACCESS_TRANSFER_WRITE_BIT : 0);
  barrier.dstAccessMask = VK_ACCESS_ACCELERATION_STRUCTURE_READ_BIT_KHR | VK_ACCESS_SHADER_READ_BIT;
  const VkPipelineStageFlags src =
      VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR | (copied ? VK_PIPELINE_STAGE_TRANSFER_BIT : 0);
  const VkPipelineStageFlags dst = VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR |
                                   VK_PIPELINE_STAGE_RAY_TRACING_SHADER_BIT_KHR | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT;
  ctx.vk.vkCmdPipelineBarrier(cmd, src, dst, 0, 1, &barrier, 0, nullptr, 0, nullptr);
}

Outcome build_and_wait(LsnifContext_T& ctx, const std::vector<LsnifModel_T*>& models) {
  if (!ctx.info.queue)
    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                         "the context has no queue (LsnifContextCreateInfo::queue): use lsnifCmdBuildModels");
  const VkDevice device = ctx.info.device;
  const VkAllocationCallbacks* cb = ctx.info.pAllocator;
  if (!ctx.pool) {
    VkCommandPoolCreateInfo pci{};
    pci.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    pci.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
    pci.queueFamilyIndex = ctx.info.queueFamilyIndex;
    LSNIF_VK_TRY(ctx.vk.vkCreateCommandPool(device, &pci, cb, &ctx.pool));
    name_object(ctx, VK_OBJECT_TYPE_COMMAND_POOL, ctx.pool, "lsnif context: command pool of the blocking calls");
  }
  if (!ctx.fence) {
    VkFenceCreateInfo fci{};
    fci.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    LSNIF_VK_TRY(ctx.vk.vkCreateFence(device, &fci, cb, &ctx.fence));
    name_object(ctx, VK_OBJECT_TYPE_FENCE, ctx.fence, "lsnif context: fence of the blocking calls");
  }
  VkCommandBufferAllocateInfo cai{};
  cai.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
  cai.commandPool = ctx.pool;
  cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cai.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  LSNIF_VK_TRY(ctx.vk.vkAllocateCommandBuffers(device, &cai, &cmd));
  name_object(ctx, VK_OBJECT_TYPE_COMMAND_BUFFER, cmd, "lsnif context: model builds");
  VkCommandBufferBeginInfo bi{};
  bi.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  VkResult r = ctx.vk.vkBeginCommandBuffer(cmd, &bi);
  if (r == VK_SUCCESS) {
    record_builds(ctx, cmd, models);
    r = ctx.vk.vkEndCommandBuffer(cmd);
  }
  VkSubmitInfo si{};
  si.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
  si.commandBufferCount = 1;
  si.pCommandBuffers = &cmd;
  if (r == VK_SUCCESS) r = ctx.vk.vkQueueSubmit(ctx.info.queue, 1, &si, ctx.fence);
  if (r == VK_SUCCESS) r = ctx.vk.vkWaitForFences(device, 1, &ctx.fence, VK_TRUE, UINT64_MAX);
  if (r == VK_SUCCESS) r = ctx.vk.vkResetFences(device, 1, &ctx.fence);
  ctx.vk.vkFreeCommandBuffers(device, ctx.pool, 1, &cmd);
  if (r != VK_SUCCESS) {
    // The recorded state stays false: nothing may rely on a build that did not run.
    for (LsnifModel_T* m : models) m->build_recorded = false;
    return Outcome::fail(LSNIF_ERROR_VULKAN, "building the model BLASes failed (VkResult %d)", static_cast<int>(r));
  }
  for (LsnifModel_T* m : models) free_build_resources(ctx, *m);
  return Outcome::ok();
}

}  // namespace lsnif::plugin
