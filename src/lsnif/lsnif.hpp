// lsnif.hpp -- a thin header-only C++ layer over the C API of lsnif.h: move-only owners of a
// context, of a model and of a query pipeline that release them in their destructors, and the
// batched calls on the pipeline. Nothing here throws; every call returns the C API's LsnifResult
// (and lsnifGetLastErrorMessage() names the problem).
// Destroy models and query pipelines before their context (declare the Context first).
#ifndef LSNIF_HPP_
#define LSNIF_HPP_

#include <cstddef>
#include <string>
#include <utility>

#include "lsnif/lsnif.h"

namespace lsnif::plugin {

// The calling thread's last error message.
inline std::string last_error() { return lsnifGetLastErrorMessage(); }

class Context {
 public:
  Context() = default;
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  Context(Context&& other) noexcept : context_(std::exchange(other.context_, nullptr)) {}
  Context& operator=(Context&& other) noexcept {
    if (this != &other) {
      reset();
      context_ = std::exchange(other.context_, nullptr);
    }
    return *this;
  }
  ~Context() { reset(); }

  // lsnifCreateContext (destroying the context held before).
  LsnifResult create(const LsnifContextCreateInfo& info) {
    reset();
    return lsnifCreateContext(&info, &context_);
  }
  // lsnifDestroyContext.
  void reset() {
    lsnifDestroyContext(context_);
    context_ = nullptr;
  }
  // Gives up ownership without destroying (the caller destroys the context).
  LsnifContext release() { return std::exchange(context_, nullptr); }
  LsnifContext get() const { return context_; }
  explicit operator bool() const { return context_ != nullptr; }

 private:
  LsnifContext context_ = nullptr;
};

class Model {
 public:
  Model() = default;
  Model(const Model&) = delete;
  Model& operator=(const Model&) = delete;
  Model(Model&& other) noexcept
      : context_(std::exchange(other.context_, nullptr)), model_(std::exchange(other.model_, nullptr)) {}
  Model& operator=(Model&& other) noexcept {
    if (this != &other) {
      reset();
      context_ = std::exchange(other.context_, nullptr);
      model_ = std::exchange(other.model_, nullptr);
    }
    return *this;
  }
  ~Model() { reset(); }

  // lsnifCreateModelFromFile / lsnifCreateModelFromMemory (destroying the model held before).
  LsnifResult create_from_file(LsnifContext context, const char* path) {
    reset();
    const LsnifResult r = lsnifCreateModelFromFile(context, path, &model_);
    if (r == LSNIF_SUCCESS) context_ = context;
    return r;
  }
  LsnifResult create_from_memory(LsnifContext context, const void* data, std::size_t size) {
    reset();
    const LsnifResult r = lsnifCreateModelFromMemory(context, data, size, &model_);
    if (r == LSNIF_SUCCESS) context_ = context;
    return r;
  }
  // lsnifDestroyModel.
  void reset() {
    if (model_) lsnifDestroyModel(context_, model_);
    context_ = nullptr;
    model_ = nullptr;
  }
  // lsnifGetModelProperties / lsnifGetModelMemory; zeroed when the model is empty.
  LsnifModelProperties properties() const {
    LsnifModelProperties p{};
    if (model_) lsnifGetModelProperties(context_, model_, &p);
    return p;
  }
  LsnifModelMemory memory() const {
    LsnifModelMemory m{};
    if (model_) lsnifGetModelMemory(context_, model_, &m);
    return m;
  }
  // Gives up ownership without destroying (e.g. when lsnifDestroyContext already destroyed it).
  LsnifModel release() {
    context_ = nullptr;
    return std::exchange(model_, nullptr);
  }
  LsnifModel get() const { return model_; }
  LsnifContext context() const { return context_; }
  explicit operator bool() const { return model_ != nullptr; }

 private:
  LsnifContext context_ = nullptr;
  LsnifModel model_ = nullptr;
};

class QueryPipeline {
 public:
  QueryPipeline() = default;
  QueryPipeline(const QueryPipeline&) = delete;
  QueryPipeline& operator=(const QueryPipeline&) = delete;
  QueryPipeline(QueryPipeline&& other) noexcept
      : context_(std::exchange(other.context_, nullptr)), pipeline_(std::exchange(other.pipeline_, nullptr)) {}
  QueryPipeline& operator=(QueryPipeline&& other) noexcept {
    if (this != &other) {
      reset();
      context_ = std::exchange(other.context_, nullptr);
      pipeline_ = std::exchange(other.pipeline_, nullptr);
    }
    return *this;
  }
  ~QueryPipeline() { reset(); }

  // lsnifCreateQueryPipeline (destroying the pipeline held before); flags of
  // LsnifQueryPipelineCreateFlagBits (LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT for cmd_query).
  LsnifResult create(LsnifContext context, LsnifQueryPipelineCreateFlags flags = 0,
                     VkPipelineCache cache = VK_NULL_HANDLE) {
    reset();
    LsnifQueryPipelineFlagsCreateInfo chained{};
    chained.sType = LSNIF_STRUCTURE_TYPE_QUERY_PIPELINE_FLAGS_CREATE_INFO;
    chained.flags = flags;
    LsnifQueryPipelineCreateInfo info{};
    info.pNext = flags ? &chained : nullptr;
    info.pipelineCache = cache;
    const LsnifResult r = lsnifCreateQueryPipeline(context, &info, &pipeline_);
    if (r == LSNIF_SUCCESS) context_ = context;
    return r;
  }
  // lsnifDestroyQueryPipeline (the GPU must no longer use it).
  void reset() {
    if (pipeline_) lsnifDestroyQueryPipeline(context_, pipeline_);
    context_ = nullptr;
    pipeline_ = nullptr;
  }
  // lsnifCmdIntersectModelRays / lsnifCmdQuery on this pipeline and its context.
  LsnifResult cmd_intersect_model_rays(VkCommandBuffer commandBuffer, const LsnifIntersectModelRaysInfo& info) const {
    return lsnifCmdIntersectModelRays(context_, commandBuffer, pipeline_, &info);
  }
  LsnifResult cmd_query(VkCommandBuffer commandBuffer, const LsnifQueryInfo& info) const {
    return lsnifCmdQuery(context_, commandBuffer, pipeline_, &info);
  }
  // lsnifGetQueryBroadPhase: the broad phase cmd_query runs (NONE without a TLAS pipeline).
  LsnifQueryBroadPhase broad_phase() const { return lsnifGetQueryBroadPhase(context_, pipeline_); }
  // Gives up ownership without destroying (e.g. when lsnifDestroyContext already destroyed it).
  LsnifQueryPipeline release() {
    context_ = nullptr;
    return std::exchange(pipeline_, nullptr);
  }
  LsnifQueryPipeline get() const { return pipeline_; }
  LsnifContext context() const { return context_; }
  explicit operator bool() const { return pipeline_ != nullptr; }

 private:
  LsnifContext context_ = nullptr;
  LsnifQueryPipeline pipeline_ = nullptr;
};

// lsnifGetQueryScratchSize; `size` is written on success only.
inline LsnifResult query_scratch_size(LsnifContext context, const LsnifQueryInfo& info, VkDeviceSize& size) {
  return lsnifGetQueryScratchSize(context, &info, &size);
}

}  // namespace lsnif::plugin

#endif  // LSNIF_HPP_
