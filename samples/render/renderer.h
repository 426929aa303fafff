// renderer.h -- the hybrid path tracer (issue 4) on a Vulkan device: a scene's triangle meshes as
// triangle BLASes and its LSNIF objects through the plugin (plugin/lsnif_vk.h), in one TLAS, traced
// by shaders/render.rgen. Two modes over the same scene: LSNIF (every node with an LSNIF object
// uses it) and reference (every such node uses its triangle mesh instead); both use the same
// per-pixel random sequences, so their difference is the geometry's, not noise.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "environment.h"
#include "image_io.h"
#include "lsnif_vk.h"
#include "scene.h"
#include "status.h"
#include "vk_raytracing.h"

namespace lsnif::render {

struct RenderSettings {
  uint32_t width = 320, height = 240;
  uint32_t spp = 16;               // samples per pixel
  uint32_t samples_per_pass = 4;   // per vkCmdTraceRaysKHR (keeps each submission short)
  uint32_t max_bounces = 4;        // path vertices after the camera (the paper's 4)
  uint32_t rr_depth = 4;           // Russian roulette from this bounce on (only with max_bounces > 4)
  bool reference = false;          // triangles instead of LSNIF objects
  bool warm_up = true;              // a discarded first pass (pipeline compile) before the timed ones
  uint32_t first_sample = 0;       // index of the first sample: per-pixel random sequences start here
                                   // (renders with disjoint ranges have independent noise)
  int32_t camera = 0;              // Scene::cameras index; -1 or none: a camera framing the scene
  // The environment map with its sampling tables (scene/environment.h, e.g. load_environment_map of
  // the scene's environment); null: the scene's constant environment color, no importance sampling.
  const scene::EnvironmentMap* environment = nullptr;
};

// What one render cost and occupies on the device.
struct RenderStats {
  double seconds = 0;               // wall time of all passes (submit to finish)
  double ms_per_sample = 0;         // seconds * 1000 / spp (a sample = one path per pixel)
  uint64_t triangle_blas_bytes = 0; // triangle BLASes in use (accelerationStructureSize)
  uint64_t lsnif_bytes = 0;         // LSNIF model blocks + their AABB BLASes in use
  uint64_t tlas_bytes = 0;
  uint32_t triangle_instances = 0, lsnif_instances = 0, lsnif_models = 0;
  uint64_t triangles = 0;           // triangles of the meshes in use (unique, not per instance)
};

class Renderer {
 public:
  // `ctx` must be initialized with ray tracing (ComputeContext::init(true, ...)) and outlive this.
  explicit Renderer(vk::ComputeContext& ctx);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Renders `scene` into `out` (linear RGB, the mean of the samples). `progress` (may be empty) is
  // called after every pass with the samples done. Fails, naming the problem, on an empty scene, a
  // node without the geometry the mode needs, an unreadable or inconsistent .lsnif file, a bad
  // camera index or a device error; everything allocated is released either way.
  Status render(const scene::Scene& scene, const RenderSettings& settings, image::Image& out, RenderStats& stats,
                const std::function<void(uint32_t)>& progress = {});

 private:
  Status create_pipeline();
  vk::ComputeContext& ctx_;
  vk::RayTracer tracer_;
  vk::RtPipeline pipeline_{};
  bool pipeline_ready_ = false;
};

// Path of the compiled shaders of this renderer (build tree).
std::string shader_dir();

}  // namespace lsnif::render
