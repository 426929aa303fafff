// convert_blas_device.h -- the converter's BLAS sizes from a Vulkan device (`lsnif convert
// --blas-size device`): vkGetAccelerationStructureBuildSizesKHR for each primitive's BLAS as the
// renderer builds it (convert_blas.h). Its own library, lsnif_convert_device, so that
// lsnif_convert needs no Vulkan.
#pragma once
#include <memory>
#include <string>

#include "lsnif/apps/convert/convert_blas.h"

namespace lsnif::vk {
class Context;
class RayTracer;
}  // namespace lsnif::vk

namespace lsnif::convert {

class DeviceBlasSizer {
 public:
  DeviceBlasSizer();
  ~DeviceBlasSizer();
  DeviceBlasSizer(const DeviceBlasSizer&) = delete;
  DeviceBlasSizer& operator=(const DeviceBlasSizer&) = delete;

  // Opens `device` (vk::ContextOptions::device: an index in `lsnif devices` or part of a name;
  // empty: the Vulkan context's default choice) with ray tracing, without validation. Fails when no such
  // device can ray trace.
  Status open(const std::string& device);
  // A sizer querying the open device (it must outlive the sizer's use), named after the device.
  BlasSizer sizer();

 private:
  std::unique_ptr<vk::Context> ctx_;
  std::unique_ptr<vk::RayTracer> rt_;
};

}  // namespace lsnif::convert
