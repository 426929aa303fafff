// lsnif.hpp -- a thin header-only C++ layer over the C API of lsnif.h: move-only owners of a
// context and of a model that release them in their destructors. Nothing here throws; every call
// returns the C API's LsnifResult (and lsnifGetLastErrorMessage() names the problem).
// Destroy models before their context (declare the Context first).
#ifndef LSNIF_HPP_
#define LSNIF_HPP_

#include <cstddef>
#include <string>
#include <utility>

#include "lsnif.h"

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

}  // namespace lsnif::plugin

#endif  // LSNIF_HPP_
