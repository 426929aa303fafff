// api.cpp -- the C API of src/lsnif/lsnif.h: argument checks, the thread's last error, the
// error callback, and no exception ever crossing the C boundary. The work is in context.cpp,
// device_support.cpp and the packers of src/lsnif/format/.
#include <cstring>
#include <memory>
#include <mutex>
#include <new>
#include <set>
#include <string>
#include <vector>

#include "lsnif/plugin/context.h"
#include "lsnif/plugin/device_support.h"
#include "lsnif/lsnif.h"
#include "lsnif/format/instance_transform.h"
#include "lsnif/format/model_format.h"

using lsnif::plugin::Outcome;

namespace {

thread_local std::string g_last_error;

// The SPIR-V of src/lsnif/shaders/lsnif.rint, embedded at build time (glslangValidator --vn).
#include "lsnif_rint_record_spirv.h"
#include "lsnif_rint_table_spirv.h"

// Records a failure (last error, callback of `ctx` or of the create info) and returns its code.
LsnifResult report(const Outcome& o, const char* function, PFN_lsnifErrorCallback callback, void* user) {
  if (o.code == LSNIF_SUCCESS) return LSNIF_SUCCESS;
  try {
    g_last_error = std::string(function) + ": " + o.message;
  } catch (...) {
    g_last_error.clear();
  }
  if (callback) callback(o.code, g_last_error.c_str(), user);
  return o.code;
}

// The contexts lsnifCreateContext made and lsnifDestroyContext has not destroyed: a handle is
// looked up here before it is used, as a model handle is looked up in its context. Never destroyed
// itself, so that a context destroyed from another static destructor is still looked up.
std::mutex g_contexts_mutex;
std::set<const LsnifContext_T*>& g_contexts = *new std::set<const LsnifContext_T*>();

bool live(const LsnifContext_T* ctx) {
  std::lock_guard<std::mutex> lock(g_contexts_mutex);
  return g_contexts.count(ctx) != 0;
}

// Every entry point's check of its context handle.
Outcome check_context(const LsnifContext_T* ctx) {
  if (!ctx) return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "context is NULL");
  if (!live(ctx))
    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                         "context %p is not a live context (destroyed by lsnifDestroyContext, or not made by "
                         "lsnifCreateContext)", static_cast<const void*>(ctx));
  return Outcome::ok();
}

// The callback of a live context only: a stale handle's memory is not read.
LsnifResult report(const Outcome& o, const char* function, const LsnifContext_T* ctx) {
  const bool ok = ctx && live(ctx);
  return report(o, function, ok ? ctx->info.pfnErrorCallback : nullptr, ok ? ctx->info.pErrorUserData : nullptr);
}

Outcome invalid(const char* fmt, const char* what) {
  return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, fmt, what);
}

// Runs `body` (returning Outcome) with exceptions turned into results.
template <class Body>
Outcome guarded(Body&& body) {
  try {
    return body();
  } catch (const std::bad_alloc&) {
    return Outcome::fail(LSNIF_ERROR_OUT_OF_HOST_MEMORY, "out of host memory");
  } catch (const std::exception& e) {
    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "internal error: %s", e.what());
  } catch (...) {
    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "internal error");
  }
}

// The models behind pModels[0 .. count), each checked to belong to ctx (and, with `unrecorded`, not
// recorded yet; no model twice).
Outcome collect(const LsnifContext_T& ctx, uint32_t count, const LsnifModel* pModels, bool unrecorded,
                std::vector<LsnifModel_T*>& out) {
  if (count > 0 && !pModels) return invalid("%s is NULL with a non-zero count", "pModels");
  out.clear();
  for (uint32_t i = 0; i < count; ++i) {
    LsnifModel_T* m = ctx.find(pModels[i]);
    if (!m) return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "pModels[%u] is not a model of this context", i);
    if (unrecorded && m->build_recorded)
      return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "pModels[%u]: its build was already recorded", i);
    for (LsnifModel_T* seen : out)
      if (seen == m) return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "pModels[%u] appears twice", i);
    out.push_back(m);
  }
  return Outcome::ok();
}

// The structures chained to a LsnifQueryInfo, each at most once in either order: a
// LsnifQueryTimestampsInfo (into `timestamps`) and a LsnifQueryModelIndexInfo (`model_index`).
Outcome query_chain(const LsnifQueryInfo& info, const LsnifQueryTimestampsInfo*& timestamps,
                    const LsnifQueryModelIndexInfo*& model_index) {
  timestamps = nullptr;
  model_index = nullptr;
  for (const void* next = info.pNext; next;) {
    const auto type = static_cast<const LsnifQueryTimestampsInfo*>(next)->sType;
    if (type == LSNIF_STRUCTURE_TYPE_QUERY_TIMESTAMPS_INFO && !timestamps) {
      timestamps = static_cast<const LsnifQueryTimestampsInfo*>(next);
      if (!timestamps->timestampPool) return invalid("%s is VK_NULL_HANDLE", "LsnifQueryTimestampsInfo::timestampPool");
      next = timestamps->pNext;
    } else if (type == LSNIF_STRUCTURE_TYPE_QUERY_MODEL_INDEX_INFO && !model_index) {
      model_index = static_cast<const LsnifQueryModelIndexInfo*>(next);
      if (model_index->modelIndex != LSNIF_QUERY_MODEL_INDEX_CUSTOM_INDEX &&
          model_index->modelIndex != LSNIF_QUERY_MODEL_INDEX_INSTANCE_INDEX)
        return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "LsnifQueryModelIndexInfo::modelIndex %d is not a LsnifQueryModelIndex",
                             static_cast<int>(model_index->modelIndex));
      if (model_index->customIndexBase >= (1u << 24))
        return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                             "LsnifQueryModelIndexInfo::customIndexBase %u is not below 2^24 (custom indices have 24 bits)",
                             model_index->customIndexBase);
      if (model_index->modelIndex == LSNIF_QUERY_MODEL_INDEX_INSTANCE_INDEX && model_index->customIndexBase != 0)
        return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                             "LsnifQueryModelIndexInfo::customIndexBase %u with LSNIF_QUERY_MODEL_INDEX_INSTANCE_INDEX "
                             "(the base applies to custom indices only; give 0)",
                             model_index->customIndexBase);
      next = model_index->pNext;
    } else {
      const bool repeated = (type == LSNIF_STRUCTURE_TYPE_QUERY_TIMESTAMPS_INFO && timestamps) ||
                            (type == LSNIF_STRUCTURE_TYPE_QUERY_MODEL_INDEX_INFO && model_index);
      return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                           repeated ? "pInfo->pNext: structure type %d appears twice"
                                    : "pInfo->pNext: unknown structure type %d (expected "
                                      "LSNIF_STRUCTURE_TYPE_QUERY_TIMESTAMPS_INFO or "
                                      "LSNIF_STRUCTURE_TYPE_QUERY_MODEL_INDEX_INFO)",
                           static_cast<int>(type));
    }
  }
  return Outcome::ok();
}

// The checks lsnifGetQueryScratchSize and lsnifCmdQuery share: the chained structures (into
// `timestamps` and `model_index`, query_chain), the counts, and the table's models (each of this
// context, or null; built, with `built`), collected into `models`.
Outcome check_query_counts(const LsnifContext_T& ctx, const LsnifQueryInfo& info, bool built,
                           std::vector<const LsnifModel_T*>& models, const LsnifQueryTimestampsInfo*& timestamps,
                           const LsnifQueryModelIndexInfo*& model_index) {
  if (Outcome o = query_chain(info, timestamps, model_index); !o) return o;
  if (info.candidatesPerRay < 1 || info.candidatesPerRay > LSNIF_QUERY_MAX_CANDIDATES_PER_RAY)
    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "pInfo->candidatesPerRay %u is not in 1 .. %u",
                         info.candidatesPerRay, LSNIF_QUERY_MAX_CANDIDATES_PER_RAY);
  if (info.modelCount > LSNIF_QUERY_MAX_MODELS)
    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "pInfo->modelCount %u is more than %u", info.modelCount,
                         LSNIF_QUERY_MAX_MODELS);
  if (info.modelCount > 0 && !info.pModels) return invalid("%s is NULL with a non-zero modelCount", "pInfo->pModels");
  models.assign(info.modelCount, nullptr);
  for (uint32_t i = 0; i < info.modelCount; ++i) {
    if (!info.pModels[i]) continue;  // a hole
    const LsnifModel_T* m = ctx.find(info.pModels[i]);
    if (!m) return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "pInfo->pModels[%u] is not a model of this context", i);
    if (built && !m->build_recorded)
      return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                           "pInfo->pModels[%u] has not been built (lsnifCmdBuildModels / lsnifBuildModels)", i);
    models[i] = m;
  }
  return Outcome::ok();
}

// A required device address: not 0 and a multiple of `alignment`.
Outcome check_address(const char* name, VkDeviceAddress address, VkDeviceAddress alignment) {
  if (address == 0) return invalid("%s is 0", name);
  if (address % alignment != 0)
    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "%s is not %llu-byte aligned", name,
                         static_cast<unsigned long long>(alignment));
  return Outcome::ok();
}

}  // namespace

extern "C" {

LSNIF_API uint32_t lsnifGetVersion(void) {
  return LSNIF_MAKE_VERSION(LSNIF_VERSION_MAJOR, LSNIF_VERSION_MINOR, LSNIF_VERSION_PATCH);
}

LSNIF_API uint32_t lsnifGetGpuLayoutVersion(void) { return LSNIF_GPU_VERSION; }

LSNIF_API const char* lsnifResultString(LsnifResult result) {
  switch (result) {
    case LSNIF_SUCCESS: return "LSNIF_SUCCESS";
    case LSNIF_ERROR_INVALID_ARGUMENT: return "LSNIF_ERROR_INVALID_ARGUMENT";
    case LSNIF_ERROR_OUT_OF_HOST_MEMORY: return "LSNIF_ERROR_OUT_OF_HOST_MEMORY";
    case LSNIF_ERROR_VULKAN: return "LSNIF_ERROR_VULKAN";
    case LSNIF_ERROR_DEVICE_UNSUPPORTED: return "LSNIF_ERROR_DEVICE_UNSUPPORTED";
    case LSNIF_ERROR_FILE: return "LSNIF_ERROR_FILE";
    case LSNIF_ERROR_INVALID_MODEL: return "LSNIF_ERROR_INVALID_MODEL";
    default: return "unknown LsnifResult";
  }
}

LSNIF_API const char* lsnifGetLastErrorMessage(void) { return g_last_error.c_str(); }

LSNIF_API const char* const* lsnifGetRequiredDeviceExtensions(uint32_t* pCount) {
  if (pCount) *pCount = uint32_t(sizeof lsnif::plugin::kRequiredDeviceExtensions / sizeof(const char*));
  return lsnif::plugin::kRequiredDeviceExtensions;
}

LSNIF_API void lsnifInitDeviceFeatures(LsnifDeviceFeatures* f, void* pNext) {
  if (!f) return;
  std::memset(f, 0, sizeof *f);
  f->features2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
  f->features2.pNext = &f->vulkan12;
  f->vulkan12.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES;
  f->vulkan12.pNext = &f->accelerationStructure;
  f->accelerationStructure.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR;
  f->accelerationStructure.pNext = &f->rayTracingPipeline;
  f->rayTracingPipeline.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR;
  f->rayTracingPipeline.pNext = pNext;
  lsnif::plugin::enable_device_features(&f->features2);
}

LSNIF_API LsnifResult lsnifEnableDeviceFeatures(void* pFeatureChain) {
  return report(guarded([&]() -> Outcome {
                  if (!pFeatureChain) return invalid("%s is NULL", "pFeatureChain");
                  if (std::string why = lsnif::plugin::chain_problem(pFeatureChain, "pFeatureChain"); !why.empty())
                    return invalid("%s", why.c_str());
                  const std::vector<std::string> absent = lsnif::plugin::enable_device_features(pFeatureChain);
                  if (absent.empty()) return Outcome::ok();
                  std::string list;
                  for (const std::string& a : absent) list += (list.empty() ? "" : ", ") + a;
                  return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "the feature chain lacks %s", list.c_str());
                }),
                "lsnifEnableDeviceFeatures", nullptr);
}

LSNIF_API const LsnifFeatureRequirement* lsnifGetRequiredDeviceFeatures(uint32_t* pCount) {
  if (pCount) *pCount = lsnif::plugin::kRequiredFeatureCount;
  return lsnif::plugin::required_device_features();
}

LSNIF_API LsnifResult lsnifEnableDeviceFeaturesWithCore(VkPhysicalDeviceFeatures* pCoreFeatures, void* pFeatureChain) {
  return report(guarded([&]() -> Outcome {
                  if (!pCoreFeatures) return invalid("%s is NULL", "pCoreFeatures");
                  if (!pFeatureChain) return invalid("%s is NULL", "pFeatureChain");
                  if (std::string why = lsnif::plugin::chain_problem(pFeatureChain, "pFeatureChain"); !why.empty())
                    return invalid("%s", why.c_str());
                  if (lsnif::plugin::has_core_features(pFeatureChain))
                    return invalid("%s", "pFeatureChain reaches core features (a VkPhysicalDeviceFeatures2, or a "
                                         "VkDeviceCreateInfo whose pEnabledFeatures is set): the core features go in one "
                                         "place (Vulkan allows one), so enable them there with lsnifEnableDeviceFeatures");
                  const std::vector<std::string> absent =
                      lsnif::plugin::enable_device_features(pFeatureChain, pCoreFeatures);
                  if (absent.empty()) return Outcome::ok();
                  std::string list;
                  for (const std::string& a : absent) list += (list.empty() ? "" : ", ") + a;
                  return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "the feature chain lacks %s", list.c_str());
                }),
                "lsnifEnableDeviceFeaturesWithCore", nullptr);
}

LSNIF_API LsnifResult lsnifEnableDeviceFeaturesInCreateInfo(VkDeviceCreateInfo* pCreateInfo,
                                                            LsnifDeviceFeatureStorage* pStorage) {
  return report(guarded([&]() -> Outcome {
                  if (!pCreateInfo) return invalid("%s is NULL", "pCreateInfo");
                  if (!pStorage) return invalid("%s is NULL", "pStorage");
                  if (pCreateInfo->sType != VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO)
                    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                                         "pCreateInfo->sType is %d, not VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO",
                                         int(pCreateInfo->sType));
                  if (std::string why = lsnif::plugin::chain_problem(pCreateInfo, "pCreateInfo"); !why.empty())
                    return invalid("%s", why.c_str());
                  lsnif::plugin::enable_device_features_appending(*pCreateInfo, *pStorage);
                  return Outcome::ok();
                }),
                "lsnifEnableDeviceFeaturesInCreateInfo", nullptr);
}

LSNIF_API LsnifResult lsnifQueryDeviceSupport(VkInstance instance, VkPhysicalDevice physicalDevice,
                                              PFN_vkGetInstanceProcAddr pfnGetInstanceProcAddr,
                                              LsnifDeviceSupport* pSupport) {
  return report(guarded([&]() -> Outcome {
                  if (!instance || !physicalDevice || !pfnGetInstanceProcAddr || !pSupport)
                    return invalid("%s", "null argument (instance, physicalDevice, pfnGetInstanceProcAddr and "
                                         "pSupport are required)");
                  lsnif::plugin::InstanceDispatch vki;
                  if (const char* missing = lsnif::plugin::load_instance_dispatch(pfnGetInstanceProcAddr, instance, vki))
                    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                                         "the instance does not provide %s (create it with apiVersion 1.2 or newer)",
                                         missing);
                  const lsnif::plugin::DeviceSupport s = lsnif::plugin::query_device_support(vki, physicalDevice);
                  LsnifDeviceSupport out{};
                  std::string missing;
                  for (const std::string& m : lsnif::plugin::missing_for_ray_tracing(s))
                    missing += (missing.empty() ? "" : ", ") + m;
                  out.supported = missing.empty() ? VK_TRUE : VK_FALSE;
                  out.apiVersion = s.api_version;
                  std::strncpy(out.deviceName, s.name.c_str(), sizeof out.deviceName - 1);
                  std::strncpy(out.missing, missing.c_str(), sizeof out.missing - 1);
                  out.rayQuery = s.ray_query;
                  out.cooperativeMatrixNV = s.ext_nv_cooperative_matrix;
                  out.cooperativeMatrixKHR = s.ext_khr_cooperative_matrix;
                  out.cooperativeVectorNV = s.ext_nv_cooperative_vector;
                  out.rayTraversalPrimitiveCulling = s.ray_traversal_primitive_culling;
                  out.cooperativeMatrixMlpNV = lsnif::plugin::missing_for_coopmat_mlp(s).empty();
                  *pSupport = out;
                  return Outcome::ok();
                }),
                "lsnifQueryDeviceSupport", nullptr);
}

LSNIF_API LsnifResult lsnifCreateContext(const LsnifContextCreateInfo* pCreateInfo, LsnifContext* pContext) {
  PFN_lsnifErrorCallback callback = pCreateInfo ? pCreateInfo->pfnErrorCallback : nullptr;
  void* user = pCreateInfo ? pCreateInfo->pErrorUserData : nullptr;
  return report(guarded([&]() -> Outcome {
                  if (!pCreateInfo) return invalid("%s is NULL", "pCreateInfo");
                  if (!pContext) return invalid("%s is NULL", "pContext");
                  std::unique_ptr<LsnifContext_T> ctx;
                  Outcome o = lsnif::plugin::create_context(*pCreateInfo, ctx);
                  if (o) {
                    std::lock_guard<std::mutex> lock(g_contexts_mutex);
                    g_contexts.insert(ctx.get());
                    *pContext = ctx.release();
                  }
                  return o;
                }),
                "lsnifCreateContext", callback, user);
}

LSNIF_API void lsnifDestroyContext(LsnifContext context) {
  if (!context) return;
  bool erased = false;
  {
    std::lock_guard<std::mutex> lock(g_contexts_mutex);
    erased = g_contexts.erase(context) != 0;
  }
  if (!erased) {
    // Destroyed already (or never made): nothing is touched; the last error message says why.
    report(check_context(context), "lsnifDestroyContext", nullptr, nullptr);
    return;
  }
  lsnif::plugin::destroy_context(*context);
  delete context;
}

LSNIF_API LsnifResult lsnifCreateModelFromMemory(LsnifContext context, const void* pData, size_t size,
                                                 LsnifModel* pModel) {
  return report(guarded([&]() -> Outcome {
                  if (Outcome o = check_context(context); !o) return o;
                  if (!pModel) return invalid("%s is NULL", "pModel");
                  if (!pData && size != 0) return invalid("%s is NULL with a non-zero size", "pData");
                  return lsnif::plugin::create_model(*context, static_cast<const uint8_t*>(pData), size, *pModel);
                }),
                "lsnifCreateModelFromMemory", context);
}

LSNIF_API LsnifResult lsnifCreateModelFromFile(LsnifContext context, const char* path, LsnifModel* pModel) {
  return report(guarded([&]() -> Outcome {
                  if (Outcome o = check_context(context); !o) return o;
                  if (!path) return invalid("%s is NULL", "path");
                  if (!pModel) return invalid("%s is NULL", "pModel");
                  std::vector<uint8_t> bytes;
                  if (lsnif::Status s = lsnif::read_model_file(path, bytes); !s)
                    return Outcome::from(s, LSNIF_ERROR_FILE);
                  return lsnif::plugin::create_model(*context, bytes.data(), bytes.size(), *pModel).context(path);
                }),
                "lsnifCreateModelFromFile", context);
}

LSNIF_API LsnifResult lsnifCmdBuildModels(LsnifContext context, VkCommandBuffer commandBuffer, uint32_t modelCount,
                                          const LsnifModel* pModels) {
  return report(guarded([&]() -> Outcome {
                  if (Outcome o = check_context(context); !o) return o;
                  if (!commandBuffer) return invalid("%s is VK_NULL_HANDLE", "commandBuffer");
                  std::vector<LsnifModel_T*> models;
                  Outcome o = collect(*context, modelCount, pModels, true, models);
                  if (o) lsnif::plugin::record_builds(*context, commandBuffer, models);
                  return o;
                }),
                "lsnifCmdBuildModels", context);
}

LSNIF_API LsnifResult lsnifBuildModels(LsnifContext context, uint32_t modelCount, const LsnifModel* pModels) {
  return report(guarded([&]() -> Outcome {
                  if (Outcome o = check_context(context); !o) return o;
                  std::vector<LsnifModel_T*> models;
                  Outcome o = collect(*context, modelCount, pModels, true, models);
                  if (o) o = lsnif::plugin::build_and_wait(*context, models);
                  return o;
                }),
                "lsnifBuildModels", context);
}

LSNIF_API LsnifResult lsnifFreeModelBuildResources(LsnifContext context, uint32_t modelCount,
                                                   const LsnifModel* pModels) {
  return report(guarded([&]() -> Outcome {
                  if (Outcome o = check_context(context); !o) return o;
                  std::vector<LsnifModel_T*> models;
                  Outcome o = collect(*context, modelCount, pModels, false, models);
                  if (!o) return o;
                  for (LsnifModel_T* m : models)
                    if (m->build_recorded) lsnif::plugin::free_build_resources(*context, *m);
                  return o;
                }),
                "lsnifFreeModelBuildResources", context);
}

LSNIF_API void lsnifDestroyModel(LsnifContext context, LsnifModel model) {
  if (!live(context)) return;  // NULL or not a live context
  if (auto m = LsnifContext_T::take(context->models, model)) lsnif::plugin::destroy_model(*context, *m);
}

LSNIF_API LsnifResult lsnifGetModelProperties(LsnifContext context, LsnifModel model,
                                              LsnifModelProperties* pProperties) {
  return report(guarded([&]() -> Outcome {
                  if (Outcome o = check_context(context); !o) return o;
                  if (!pProperties) return invalid("%s is NULL", "pProperties");
                  const LsnifModel_T* m = context->find(model);
                  if (!m) return invalid("%s is not a model of this context", "model");
                  LsnifModelProperties p{};
                  p.blockAddress = m->block.address;
                  p.blasAddress = m->blas_address;
                  p.blas = m->blas;
                  for (int a = 0; a < 3; ++a) {
                    p.boundsMin[a] = m->bounds_min[a];
                    p.boundsMax[a] = m->bounds_max[a];
                  }
                  p.materialCount = m->material_count;
                  p.gpuLayoutVersion = m->layout_version;
                  p.buildRecorded = m->build_recorded ? VK_TRUE : VK_FALSE;
                  *pProperties = p;
                  return Outcome::ok();
                }),
                "lsnifGetModelProperties", context);
}

LSNIF_API LsnifResult lsnifGetModelMemory(LsnifContext context, LsnifModel model, LsnifModelMemory* pMemory) {
  return report(guarded([&]() -> Outcome {
                  if (Outcome o = check_context(context); !o) return o;
                  if (!pMemory) return invalid("%s is NULL", "pMemory");
                  const LsnifModel_T* m = context->find(model);
                  if (!m) return invalid("%s is not a model of this context", "model");
                  LsnifModelMemory mem{};
                  mem.blockBytes = m->block.bytes;
                  mem.blasBytes = m->blas_storage.bytes;
                  mem.buildBytes = m->staging.bytes + m->aabb.bytes + m->scratch.bytes;
                  mem.allocatedBytes = m->block.allocated + m->blas_storage.allocated + m->staging.allocated +
                                       m->aabb.allocated + m->scratch.allocated;
                  *pMemory = mem;
                  return Outcome::ok();
                }),
                "lsnifGetModelMemory", context);
}

LSNIF_API LsnifResult lsnifMakeInstance(LsnifContext context, const LsnifInstanceInfo* pInfo,
                                        VkAccelerationStructureInstanceKHR* pInstance) {
  return report(guarded([&]() -> Outcome {
                  if (Outcome o = check_context(context); !o) return o;
                  if (!pInfo) return invalid("%s is NULL", "pInfo");
                  if (!pInstance) return invalid("%s is NULL", "pInstance");
                  const LsnifModel_T* m = context->find(pInfo->model);
                  if (!m) return invalid("%s is not a model of this context", "pInfo->model");
                  if (pInfo->instanceCustomIndex >= (1u << 24))
                    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                                         "instanceCustomIndex %u does not fit its 24 bits", pInfo->instanceCustomIndex);
                  if (pInfo->mask > 0xFFu)
                    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "mask 0x%x does not fit its 8 bits", pInfo->mask);
                  if (pInfo->instanceShaderBindingTableRecordOffset >= (1u << 24))
                    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                                         "instanceShaderBindingTableRecordOffset %u does not fit its 24 bits",
                                         pInfo->instanceShaderBindingTableRecordOffset);
                  if (pInfo->flags > 0xFFu)
                    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "flags 0x%x do not fit their 8 bits",
                                         pInfo->flags);
                  if (lsnif::Status s = lsnif::check_instance_transform(pInfo->transform.matrix); !s)
                    return Outcome::from(s, LSNIF_ERROR_INVALID_ARGUMENT);
                  VkAccelerationStructureInstanceKHR rec{};
                  rec.transform = pInfo->transform;
                  rec.instanceCustomIndex = pInfo->instanceCustomIndex & 0xFFFFFFu;
                  rec.mask = pInfo->mask & 0xFFu;
                  rec.instanceShaderBindingTableRecordOffset = pInfo->instanceShaderBindingTableRecordOffset & 0xFFFFFFu;
                  rec.flags = pInfo->flags & 0xFFu;
                  rec.accelerationStructureReference = m->blas_address;
                  *pInstance = rec;
                  return Outcome::ok();
                }),
                "lsnifMakeInstance", context);
}

LSNIF_API LsnifResult lsnifWriteModelTable(LsnifContext context, uint32_t count, const LsnifModel* pModels,
                                           uint64_t* pTable) {
  return report(guarded([&]() -> Outcome {
                  if (Outcome o = check_context(context); !o) return o;
                  if (count > 0 && (!pModels || !pTable)) return invalid("%s", "pModels and pTable are required");
                  std::vector<uint64_t> table(count, 0);
                  for (uint32_t i = 0; i < count; ++i) {
                    if (!pModels[i]) continue;  // a hole
                    const LsnifModel_T* m = context->find(pModels[i]);
                    if (!m)
                      return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "pModels[%u] is not a model of this context", i);
                    table[i] = m->block.address;
                  }
                  if (count > 0) std::memcpy(pTable, table.data(), count * sizeof(uint64_t));
                  return Outcome::ok();
                }),
                "lsnifWriteModelTable", context);
}

LSNIF_API LsnifResult lsnifGetIntersectionShaderSpirv(LsnifModelLookup lookup, const uint32_t** ppCode,
                                                      size_t* pCodeSize) {
  return report(guarded([&]() -> Outcome {
                  if (!ppCode || !pCodeSize) return invalid("%s", "ppCode and pCodeSize are required");
                  switch (lookup) {
                    case LSNIF_MODEL_LOOKUP_INSTANCE_TABLE:
                      *ppCode = lsnif_rint_table_spirv;
                      *pCodeSize = sizeof lsnif_rint_table_spirv;
                      return Outcome::ok();
                    case LSNIF_MODEL_LOOKUP_SHADER_RECORD:
                      *ppCode = lsnif_rint_record_spirv;
                      *pCodeSize = sizeof lsnif_rint_record_spirv;
                      return Outcome::ok();
                    default:
                      return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "unknown LsnifModelLookup %d",
                                           static_cast<int>(lookup));
                  }
                }),
                "lsnifGetIntersectionShaderSpirv", nullptr);
}

LSNIF_API LsnifResult lsnifCreateQueryPipeline(LsnifContext context, const LsnifQueryPipelineCreateInfo* pCreateInfo,
                                               LsnifQueryPipeline* pPipeline) {
  return report(guarded([&]() -> Outcome {
                  if (Outcome o = check_context(context); !o) return o;
                  if (!pPipeline) return invalid("%s is NULL", "pPipeline");
                  LsnifQueryPipelineCreateFlags flags = 0;
                  if (pCreateInfo && pCreateInfo->pNext) {
                    const auto* chained = static_cast<const LsnifQueryPipelineFlagsCreateInfo*>(pCreateInfo->pNext);
                    if (chained->sType != LSNIF_STRUCTURE_TYPE_QUERY_PIPELINE_FLAGS_CREATE_INFO)
                      return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                                           "pCreateInfo->pNext: unknown structure type %d (expected "
                                           "LSNIF_STRUCTURE_TYPE_QUERY_PIPELINE_FLAGS_CREATE_INFO)",
                                           static_cast<int>(chained->sType));
                    if (chained->pNext) return invalid("%s must be NULL", "LsnifQueryPipelineFlagsCreateInfo::pNext");
                    flags = chained->flags;
                  }
                  std::unique_ptr<LsnifQueryPipeline_T> p;
                  Outcome o = lsnif::plugin::create_query_pipeline(
                      *context, flags,
                      pCreateInfo ? pCreateInfo->pipelineCache : VK_NULL_HANDLE, p);
                  if (!o) return o;
                  *pPipeline = p.get();
                  context->query_pipelines.push_back(std::move(p));
                  return o;
                }),
                "lsnifCreateQueryPipeline", context);
}

LSNIF_API void lsnifDestroyQueryPipeline(LsnifContext context, LsnifQueryPipeline pipeline) {
  if (!live(context)) return;  // NULL or not a live context
  if (auto p = LsnifContext_T::take(context->query_pipelines, pipeline))
    lsnif::plugin::destroy_query_pipeline(*context, *p);
}

LSNIF_API LsnifQueryBroadPhase lsnifGetQueryBroadPhase(LsnifContext context, LsnifQueryPipeline pipeline) {
  if (!live(context)) return LSNIF_QUERY_BROAD_PHASE_NONE;
  const LsnifQueryPipeline_T* p = context->find(pipeline);
  return p ? p->broad_phase : LSNIF_QUERY_BROAD_PHASE_NONE;
}

LSNIF_API LsnifResult lsnifGetIntersectScratchSize(LsnifContext context, LsnifModel model, uint32_t rayCount,
                                                   VkDeviceSize* pSize) {
  return report(guarded([&]() -> Outcome {
                  if (Outcome o = check_context(context); !o) return o;
                  if (!pSize) return invalid("%s is NULL", "pSize");
                  const LsnifModel_T* m = context->find(model);
                  if (!m) return invalid("%s is not a model of this context", "model");
                  *pSize = lsnif::plugin::intersect_scratch_bytes(*m, rayCount);
                  return Outcome::ok();
                }),
                "lsnifGetIntersectScratchSize", context);
}

LSNIF_API LsnifResult lsnifCmdIntersectModelRays(LsnifContext context, VkCommandBuffer commandBuffer,
                                                 LsnifQueryPipeline pipeline, const LsnifIntersectModelRaysInfo* pInfo) {
  return report(guarded([&]() -> Outcome {
                  if (Outcome o = check_context(context); !o) return o;
                  if (!commandBuffer) return invalid("%s is VK_NULL_HANDLE", "commandBuffer");
                  if (!pInfo) return invalid("%s is NULL", "pInfo");
                  const LsnifIntersectModelRaysInfo& info = *pInfo;
                  if (info.pNext) return invalid("%s must be NULL", "pInfo->pNext");
                  const LsnifQueryPipeline_T* p = context->find(pipeline);
                  if (!p) return invalid("%s is not a query pipeline of this context", "pipeline");
                  const LsnifModel_T* m = context->find(info.model);
                  if (!m) return invalid("%s is not a model of this context", "pInfo->model");
                  if (!m->build_recorded)
                    return invalid("%s has not been built (lsnifCmdBuildModels / lsnifBuildModels)", "pInfo->model");
                  if (info.rayCount == 0) return Outcome::ok();
                  const struct {
                    const char* name;
                    VkDeviceAddress address;
                  } addresses[] = {{"pInfo->rays", info.rays}, {"pInfo->hits", info.hits}, {"pInfo->scratch", info.scratch}};
                  for (const auto& a : addresses) {
                    if (a.address == 0) return invalid("%s is 0", a.name);
                    if (a.address % 16 != 0) return invalid("%s is not 16-byte aligned", a.name);
                  }
                  const VkDeviceSize need = lsnif::plugin::intersect_scratch_bytes(*m, info.rayCount);
                  if (info.scratchSize < need)
                    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                                         "pInfo->scratchSize %llu is less than the %llu bytes %u rays need "
                                         "(lsnifGetIntersectScratchSize)",
                                         static_cast<unsigned long long>(info.scratchSize),
                                         static_cast<unsigned long long>(need), info.rayCount);
                  lsnif::plugin::record_intersect_model_rays(*context, *p, commandBuffer, *m, info);
                  return Outcome::ok();
                }),
                "lsnifCmdIntersectModelRays", context);
}

LSNIF_API LsnifResult lsnifGetQueryScratchSize(LsnifContext context, const LsnifQueryInfo* pInfo, VkDeviceSize* pSize) {
  return report(guarded([&]() -> Outcome {
                  if (Outcome o = check_context(context); !o) return o;
                  if (!pInfo) return invalid("%s is NULL", "pInfo");
                  if (!pSize) return invalid("%s is NULL", "pSize");
                  std::vector<const LsnifModel_T*> models;
                  const LsnifQueryTimestampsInfo* timestamps = nullptr;
                  const LsnifQueryModelIndexInfo* model_index = nullptr;
                  if (Outcome o = check_query_counts(*context, *pInfo, false, models, timestamps, model_index); !o)
                    return o;
                  *pSize = lsnif::plugin::query_scratch_bytes(models, pInfo->modelCount, pInfo->rayCount,
                                                              pInfo->candidatesPerRay);
                  return Outcome::ok();
                }),
                "lsnifGetQueryScratchSize", context);
}

LSNIF_API LsnifResult lsnifCmdQuery(LsnifContext context, VkCommandBuffer commandBuffer, LsnifQueryPipeline pipeline,
                                    const LsnifQueryInfo* pInfo) {
  return report(guarded([&]() -> Outcome {
                  if (Outcome o = check_context(context); !o) return o;
                  if (!commandBuffer) return invalid("%s is VK_NULL_HANDLE", "commandBuffer");
                  if (!pInfo) return invalid("%s is NULL", "pInfo");
                  const LsnifQueryInfo& info = *pInfo;
                  const LsnifQueryPipeline_T* p = context->find(pipeline);
                  if (!p) return invalid("%s is not a query pipeline of this context", "pipeline");
                  if (p->broad_phase == LSNIF_QUERY_BROAD_PHASE_NONE)
                    return invalid("%s was created without LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT", "pipeline");
                  std::vector<const LsnifModel_T*> models;
                  const LsnifQueryTimestampsInfo* timestamps = nullptr;
                  const LsnifQueryModelIndexInfo* model_index = nullptr;
                  if (Outcome o = check_query_counts(*context, info, true, models, timestamps, model_index); !o)
                    return o;
                  if (info.cullMask > 0xFFu)
                    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT, "pInfo->cullMask 0x%x does not fit its 8 bits",
                                         info.cullMask);
                  if (info.rayCount == 0) {
                    if (timestamps) lsnif::plugin::record_query_timestamps(*context, commandBuffer, *timestamps);
                    return Outcome::ok();
                  }
                  if (info.tlas == 0) return invalid("%s is 0", "pInfo->tlas");
                  for (Outcome o : {check_address("pInfo->rays", info.rays, 16),
                                    check_address("pInfo->results", info.results, 16)})
                    if (!o) return o;
                  if (info.modelCount > 0) {
                    if (Outcome o = check_address("pInfo->modelTable", info.modelTable, 8); !o) return o;
                  }
                  if (info.status != 0) {
                    if (Outcome o = check_address("pInfo->status", info.status, 4); !o) return o;
                  }
                  if (!info.scratchBuffer) return invalid("%s is VK_NULL_HANDLE", "pInfo->scratchBuffer");
                  if (info.scratchOffset % 16 != 0) return invalid("%s is not a multiple of 16", "pInfo->scratchOffset");
                  if (info.scratchSize > ~VkDeviceSize(0) - info.scratchOffset)
                    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                                         "pInfo->scratchOffset %llu plus pInfo->scratchSize %llu overflows a VkDeviceSize",
                                         static_cast<unsigned long long>(info.scratchOffset),
                                         static_cast<unsigned long long>(info.scratchSize));
                  const VkDeviceSize need = lsnif::plugin::query_scratch_bytes(models, info.modelCount, info.rayCount,
                                                                               info.candidatesPerRay);
                  if (info.scratchSize < need)
                    return Outcome::fail(LSNIF_ERROR_INVALID_ARGUMENT,
                                         "pInfo->scratchSize %llu is less than the %llu bytes this query needs "
                                         "(lsnifGetQueryScratchSize)",
                                         static_cast<unsigned long long>(info.scratchSize),
                                         static_cast<unsigned long long>(need));
                  lsnif::plugin::record_query(*context, *p, commandBuffer, models, info, timestamps, model_index);
                  return Outcome::ok();
                }),
                "lsnifCmdQuery", context);
}

}  // extern "C"
