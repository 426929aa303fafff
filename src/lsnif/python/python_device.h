// python_device.h -- lsnif.Device (python_device.cpp): a Vulkan context with ray tracing (as the
// renderer asks for it: render::context_options) and the LSNIF plugin on it; what Model.intersect's
// batched path and lsnif.render run on.
#pragma once
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "lsnif/vulkan/context.h"  // volk first: it declares the Vulkan functions

#include "lsnif/lsnif.hpp"
#include "lsnif/python/python_module.h"

namespace lsnif::python {

// Several devices may be open at once, but Vulkan is reached through volk's process-wide functions
// (src/lsnif/vulkan/context.h): every use of a device holds one lock for the whole process and makes
// its context current first (Use).
class PyDevice {
 public:
  // Raises lsnif.Error when no such device can ray trace or the plugin cannot run on it.
  PyDevice(const std::string& name, bool validation);
  ~PyDevice();
  PyDevice(const PyDevice&) = delete;
  PyDevice& operator=(const PyDevice&) = delete;

  // Holds the process's device lock and makes this device's context current while it lives;
  // raises lsnif.Error when the device was closed. Take it without the GIL.
  class Use {
   public:
    explicit Use(PyDevice& device);
    vk::Context& context() { return *device_.ctx_; }

   private:
    std::lock_guard<std::mutex> lock_;
    PyDevice& device_;
  };

  // Releases the plugin and the device (what the destructor does); later uses raise.
  void close();
  bool closed() const { return ctx_ == nullptr; }
  std::string name() const { return name_; }
  // Raises lsnif.Error listing the validation layer's messages since the last check (clearing them),
  // for the call `what`.
  void check_validation(const char* what);
  // The batched path on `rays` (world space) against one instance of `model`: hits as the CPU
  // intersector reports them. Call with a Use of this device, without the GIL.
  Status intersect(const Model& model, const std::vector<Ray>& rays, const Transform3x4& object_to_world,
                   uint32_t ray_flags, std::vector<LsnifHit>& hits);

 private:
  static std::mutex& process_lock();
  std::unique_ptr<vk::Context> ctx_;  // null once closed; the plugin's objects are released before it
  plugin::Context plugin_;
  plugin::QueryPipeline query_;        // made by the first intersect
  std::string name_;
  std::mutex messages_mutex_;
  std::vector<std::string> messages_;  // the validation layer's, since the last check_validation
};

// A lsnif.Device argument: the Device itself, or a new one (without validation) for a name or index.
std::shared_ptr<PyDevice> device_argument(py::handle device);

}  // namespace lsnif::python
