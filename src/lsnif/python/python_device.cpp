// python_device.cpp -- lsnif.Device: a Vulkan device (chosen as the tools' --device does) with the
// plugin on it, for Model.intersect's batched path (lsnifCmdIntersectModelRays, in the model's object
// space: world rays mapped there and normals back, as the CPU intersector does) and for lsnif.render.
#include "lsnif/python/python_device.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>

#include "lsnif/renderer/renderer.h"
#include "lsnif/vulkan/plugin_device.h"

namespace lsnif::python {

namespace {

// Rays per device pass: the host-visible buffers of one pass hold this many rays and hits (128 bytes
// a ray); larger batches run pass after pass.
constexpr size_t kPassRays = size_t(1) << 20;
// Rays per lsnifCmdIntersectModelRays call: one chunk of the plugin's (it would chunk them itself,
// but one call per chunk keeps the scratch at its size for a chunk).
constexpr uint32_t kCallRays = LSNIF_BATCH_CHUNK_RAYS;

LsnifHit hit_of(const LsnifQueryHit& q, const glm::mat3& normal_to_world) {
  LsnifHit h;
  if (q.points > 0) h.occlusion = 1.0f / (1.0f + std::exp(-q.occlusion_logit));
  if (q.kind != LSNIF_QUERY_HIT_LSNIF) return h;
  h.hit = true;
  h.t = q.t;
  const glm::vec3 nw = normal_to_world * glm::vec3(q.normal_x, q.normal_y, q.normal_z);
  const float len = glm::length(nw);
  h.normal = len > 0.0f ? nw / len : glm::vec3(0.0f);
  h.albedo = {q.albedo_r, q.albedo_g, q.albedo_b};
  h.material = q.material;
  const LsnifSurfaceChannels s = lsnifUnpackSurface(q.surface);
  h.surface_learned = s.learned == VK_TRUE;
  h.metallic = s.metallic;
  h.roughness = s.roughness;
  h.ambient_occlusion = s.ambientOcclusion;
  h.emission = {q.emission_r, q.emission_g, q.emission_b};
  h.reports_uv = q.reports_uv != 0;
  h.uv = {q.uv_u, q.uv_v};
  return h;
}

}  // namespace

std::mutex& PyDevice::process_lock() {
  static std::mutex lock;
  return lock;
}

PyDevice::Use::Use(PyDevice& device) : lock_(process_lock()), device_(device) {
  if (!device.ctx_) throw Error("the device is closed");
  device.ctx_->make_current();
}

PyDevice::PyDevice(const std::string& name, bool validation) : ctx_(std::make_unique<vk::Context>()) {
  vk::ContextOptions options = render::context_options(validation, name);
  options.on_validation_message = [this](bool error, const char* message) {
    const std::lock_guard<std::mutex> lock(messages_mutex_);
    messages_.push_back(std::string(error ? "error: " : "warning: ") + message);
  };
  Status s;
  {
    py::gil_scoped_release nogil;
    const std::lock_guard<std::mutex> lock(process_lock());
    s = ctx_->init(options);
    if (s && plugin_.create(vk::plugin_create_info(*ctx_)) != LSNIF_SUCCESS)
      s = Status::error("the LSNIF plugin on %s: %s", ctx_->device_name().c_str(), lsnifGetLastErrorMessage());
    name_ = ctx_->device_name();
    if (!s) {
      plugin_.reset();
      ctx_.reset();
    }
  }
  check(s, "no usable Vulkan ray-tracing device (`lsnif devices` tells what is missing)");
  check_validation("creating the device");
}

PyDevice::~PyDevice() {
  try {
    close();
  } catch (...) {  // a destructor does not throw; close() itself raises nothing
  }
}

void PyDevice::close() {
  if (!ctx_) return;
  // Another thread may hold the lock in a render whose progress callback waits for the GIL: wait
  // for the lock without the GIL then (uncontended, e.g. at the interpreter's exit, keep it).
  std::unique_lock<std::mutex> lock(process_lock(), std::try_to_lock);
  if (!lock.owns_lock()) {
    py::gil_scoped_release nogil;
    lock.lock();
  }
  ctx_->make_current();
  query_.reset();
  plugin_.reset();
  ctx_.reset();
}

void PyDevice::check_validation(const char* what) {
  std::vector<std::string> messages;
  {
    const std::lock_guard<std::mutex> lock(messages_mutex_);
    messages.swap(messages_);
  }
  if (messages.empty()) return;
  std::string text = std::string(what) + ": the validation layer reported " + std::to_string(messages.size()) +
                     " message(s):";
  for (const std::string& m : messages) text += "\n  " + m;
  throw Error(text);
}

Status PyDevice::intersect(const Model& model, const std::vector<Ray>& rays, const Transform3x4& object_to_world,
                           uint32_t ray_flags, std::vector<LsnifHit>& hits) {
  auto plugin_error = [](const char* what) { return Status::error("%s: %s", what, lsnifGetLastErrorMessage()); };
  glm::mat3 A, A_inv;
  glm::vec3 T;
  if (Status s = split_transform(object_to_world, A, T, A_inv); !s) return s;
  const glm::mat3 normal_to_world = glm::transpose(A_inv);
  if (!query_ && query_.create(plugin_.get(), 0) != LSNIF_SUCCESS) return plugin_error("the batched query pipeline");
  std::vector<uint8_t> bytes;
  if (Status s = save_model_to_memory(model, bytes); !s) return s;
  plugin::Model device_model;
  if (device_model.create_from_memory(plugin_.get(), bytes.data(), bytes.size()) != LSNIF_SUCCESS)
    return plugin_error("uploading the model");
  const LsnifModel handle = device_model.get();
  if (lsnifBuildModels(plugin_.get(), 1, &handle) != LSNIF_SUCCESS) return plugin_error("building the model");

  vk::Context& ctx = *ctx_;
  hits.assign(rays.size(), LsnifHit());
  const size_t pass_rays = std::min(rays.size(), kPassRays);
  if (pass_rays == 0) return Status::ok();
  VkDeviceSize scratch_bytes = 0;
  if (lsnifGetIntersectScratchSize(plugin_.get(), handle, uint32_t(std::min<size_t>(pass_rays, kCallRays)),
                                   &scratch_bytes) != LSNIF_SUCCESS)
    return plugin_error("scratch size of the batched path");
  vk::Buffer ray_buffer, hit_buffer, scratch;
  struct Release {
    vk::Context& ctx;
    vk::Buffer* buffers[3];
    ~Release() {
      for (vk::Buffer* b : buffers) ctx.destroy_buffer(*b);
    }
  } release{ctx, {&ray_buffer, &hit_buffer, &scratch}};
  Status s = ctx.create_buffer(pass_rays * sizeof(LsnifQueryRay), ray_buffer);
  if (s) s = ctx.create_buffer(pass_rays * sizeof(LsnifQueryHit), hit_buffer);
  if (s) s = ctx.create_buffer(size_t(scratch_bytes), scratch);
  if (!s) return s.context("buffers of the batched path");

  for (size_t first = 0; first < rays.size(); first += pass_rays) {
    const size_t n = std::min(pass_rays, rays.size() - first);
    auto* out = static_cast<LsnifQueryRay*>(ray_buffer.mapped);
    for (size_t i = 0; i < n; ++i) {
      const Ray& r = rays[first + i];
      const glm::vec3 o = A_inv * (r.origin - T), d = A_inv * r.direction;
      out[i] = LsnifQueryRay{};
      out[i].origin_x = o.x;
      out[i].origin_y = o.y;
      out[i].origin_z = o.z;
      out[i].tmin = r.tmin;
      out[i].direction_x = d.x;
      out[i].direction_y = d.y;
      out[i].direction_z = d.z;
      out[i].tmax = r.tmax;
      out[i].flags = ray_flags;
    }
    LsnifResult result = LSNIF_SUCCESS;
    s = ctx.submit("lsnifCmdIntersectModelRays", [&](VkCommandBuffer cmd) {
      VkMemoryBarrier barrier{};
      barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
      barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
      barrier.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
      for (size_t c = 0; c < n && result == LSNIF_SUCCESS; c += kCallRays) {
        if (c > 0)  // the calls share the scratch
          vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 1,
                               &barrier, 0, nullptr, 0, nullptr);
        LsnifIntersectModelRaysInfo info{};
        info.model = handle;
        info.rayCount = uint32_t(std::min<size_t>(n - c, kCallRays));
        info.rays = ray_buffer.address + VkDeviceAddress(c * sizeof(LsnifQueryRay));
        info.hits = hit_buffer.address + VkDeviceAddress(c * sizeof(LsnifQueryHit));
        info.scratch = scratch.address;
        info.scratchSize = scratch.size;
        result = query_.cmd_intersect_model_rays(cmd, info);
      }
      vk::Context::barrier_compute_to_host(cmd);
    });
    if (result != LSNIF_SUCCESS) return plugin_error("lsnifCmdIntersectModelRays");
    if (!s) return s;
    const auto* in = static_cast<const LsnifQueryHit*>(hit_buffer.mapped);
    for (size_t i = 0; i < n; ++i) hits[first + i] = hit_of(in[i], normal_to_world);
  }
  return Status::ok();
}

std::shared_ptr<PyDevice> device_argument(py::handle device) {
  if (py::isinstance<PyDevice>(device)) return device.cast<std::shared_ptr<PyDevice>>();
  if (py::isinstance<py::str>(device) || (py::isinstance<py::int_>(device) && !py::isinstance<py::bool_>(device)))
    return std::make_shared<PyDevice>(std::string(py::str(device)), false);
  throw py::type_error("device must be a lsnif.Device, a device name (a case-insensitive part of it) or an index in "
                       "`lsnif devices`, not " + std::string(py::str(device.get_type().attr("__name__"))));
}

py::dict device_intersect(py::handle device, const PyModel& model, const std::vector<Ray>& rays,
                          const Transform3x4& object_to_world, uint32_t ray_flags) {
  const std::shared_ptr<PyDevice> dev = device_argument(device);
  std::vector<LsnifHit> hits;
  Status s;
  {
    py::gil_scoped_release nogil;
    PyDevice::Use use(*dev);
    s = dev->intersect(model.model, rays, object_to_world, ray_flags, hits);
  }
  check(s);
  dev->check_validation("Model.intersect");
  return hits_dict(hits);
}

void register_device(py::module_& m) {
  using namespace pybind11::literals;
  py::class_<PyDevice, std::shared_ptr<PyDevice>>(
      m, "Device",
      "A Vulkan device with ray tracing and the LSNIF plugin on it, for Model.intersect(device=...) and "
      "lsnif.render(device=...). name: its index in `lsnif devices` or a case-insensitive part of its name (empty: a "
      "discrete GPU first, then integrated, virtual, CPU); validation: the Khronos validation layer, any message an "
      "error.")
      .def(py::init<const std::string&, bool>(), "name"_a = "", py::kw_only(), "validation"_a = false)
      .def_property_readonly("name", &PyDevice::name)
      .def_property_readonly("closed", &PyDevice::closed)
      .def("close", &PyDevice::close, "Releases the device now (it is released when the object is, otherwise).")
      .def("__enter__", [](std::shared_ptr<PyDevice> d) { return d; })
      .def("__exit__", [](PyDevice& d, py::args) { d.close(); })
      .def("__repr__", [](const PyDevice& d) { return "<lsnif.Device '" + d.name() + (d.closed() ? "' (closed)>" : "'>"); });
}

}  // namespace lsnif::python
