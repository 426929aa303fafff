// convert_blas_device.cpp -- BLAS sizes from a Vulkan device (convert_blas_device.h).
#include "lsnif/apps/convert/convert_blas_device.h"

#include <cstdint>

#include "lsnif/vulkan/raytracing.h"

namespace lsnif::convert {

DeviceBlasSizer::DeviceBlasSizer() = default;

DeviceBlasSizer::~DeviceBlasSizer() {
  rt_.reset();
  ctx_.reset();
}

Status DeviceBlasSizer::open(const std::string& device) {
  rt_.reset();
  ctx_ = std::make_unique<vk::Context>();
  if (Status s = ctx_->init(/*ray_tracing=*/true, /*validation=*/false, device); !s) {
    ctx_.reset();
    return Status::error("no usable Vulkan ray-tracing device for --blas-size device (`lsnif devices` tells what is "
                         "missing): %s", s.message().c_str());
  }
  rt_ = std::make_unique<vk::RayTracer>(*ctx_);
  if (Status s = rt_->init(); !s) {
    rt_.reset();
    ctx_.reset();
    return s;
  }
  return Status::ok();
}

BlasSizer DeviceBlasSizer::sizer() {
  BlasSizer out;
  if (!rt_) return out;
  vk::RayTracer* rt = rt_.get();
  out.source = "device query (vkGetAccelerationStructureBuildSizesKHR) on '" + ctx_->device_name() + "'";
  out.query = [rt](const BlasPrimitive& p, uint64_t& bytes) {
    bytes = 0;
    if (p.vertices > UINT32_MAX || p.triangles > rt->max_primitive_count() || p.triangles > UINT32_MAX)
      return Status::error("more than the device's maxPrimitiveCount %llu triangles or 2^32 vertices in one BLAS",
                           (unsigned long long)rt->max_primitive_count());
    vk::BlasSizes sizes;
    // The flags of RayTracer::build_triangle_blas, which the renderer builds its BLASes with.
    if (Status s = rt->triangle_blas_sizes(uint32_t(p.vertices), uint32_t(p.triangles),
                                           VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR, sizes);
        !s)
      return s;
    bytes = sizes.acceleration_structure;
    return Status::ok();
  };
  return out;
}

}  // namespace lsnif::convert
